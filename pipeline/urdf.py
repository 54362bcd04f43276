"""URDF import and export for robot files (general joint form).

:func:`import_urdf` walks a URDF (parsed with `yourdfpy`) from ``base_link`` down to ``tip_link`` and
returns a robot-file document in the general form (``convention: general``, see
:mod:`pipeline.robots`): each revolute, continuous or prismatic joint becomes a joint with its
``<origin>`` (``xyz``, ``rpy``), ``<axis>`` and ``<limit>``; fixed joints are folded into the next
moving joint's origin, or into ``tool`` after the last one; the base stays identity. Anything else in
the chain (mimic, floating, planar or unknown joints), an unknown link, a tip not below the base or a
chain without a moving joint is refused with one line ``<file>: <what> (joint 'NAME')``.
:func:`robot_yaml` writes such a document as YAML text with ``repr``-exact numbers (same URDF ->
byte-identical file).

:func:`to_urdf` writes any robot (standard or modified DH, or general) as a URDF string, lengths in
metres, through :meth:`pipeline.kinematics.Chain.as_general`: links ``base_link`` (the robot's world
frame) -> ``link0`` (the base transform, a fixed joint) -> ``link1`` ... ``linkN`` -> ``tool0`` (the
tool transform, a fixed joint). A revolute joint without limits becomes ``continuous``; a prismatic
joint without limits gets the finite range ``+-UNLIMITED_PRISMATIC_M`` (URDF has no unlimited
prismatic joint), which :func:`import_urdf` reads back as "no limits".
"""

from __future__ import annotations

import json
import math
import re
from decimal import Decimal
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from pipeline.robots import LENGTH_UNITS, MAX_ANGLE, MAX_LENGTH_M, RobotModel, origin_matrix, rpy_from_matrix

# [m] to_urdf's +- range for a prismatic joint without limits; import_urdf reads bounds this wide as "no limits"
UNLIMITED_PRISMATIC_M = 1000.0
MOVING = ("revolute", "continuous", "prismatic")
SNAP = 1e-14  # [m | rad] origin numbers computed from matrices (folded joints, DH export) below this are written as 0
_EYE = np.eye(4)


class URDFImportError(ValueError):
    """A URDF cannot be imported; the message is one line ``<file>: <what> (joint 'NAME')``."""


# ---------------------------------------------------------------------------------------------------------------
# numbers


def fmt_float(x: float) -> str:
    """``repr`` of a float, readable back by YAML 1.1 (``1e-05`` -> ``1.0e-05``) and without ``-0.0``."""
    x = float(x) + 0.0
    if not math.isfinite(x):
        raise ValueError(f"not a finite number: {x!r}")
    r = repr(x)
    mant, e, exp = r.partition("e")
    if e and "." not in mant:
        r = f"{mant}.0e{exp}"
    return r


def _fmt_angle(x: float) -> str:
    """An angle: a ``pi`` expression where one is exactly equal (as read by pipeline.robots), else a float."""
    x = float(x) + 0.0
    for div in (1, 2, 3, 4, 6, 8, 12):
        for mul in range(1, 2 * div + 1):
            if math.gcd(mul, div) != 1:
                continue
            for sign in (1.0, -1.0):
                if sign * float(mul) * math.pi / float(div) == x:  # same arithmetic as robots.robot_number
                    s = "-" if sign < 0 else ""
                    m = "" if mul == 1 else f"{mul}*"
                    d = "" if div == 1 else f"/{div}"
                    return f"{s}{m}pi{d}"
    return fmt_float(x)


def _scale(x: float, factor: Decimal) -> float:
    """``x * factor`` through the decimal repr (0.31 m -> 310.0 mm exactly, not 310.00000000000006)."""
    if factor == 1:
        return float(x)
    return float(Decimal(repr(float(x))) * factor)


def _clean(values) -> list[float]:
    """Rounding noise of a matrix product (|v| < 1e-14: m or rad) written as 0.0, so files read cleanly."""
    return [0.0 if abs(float(v)) < SNAP else float(v) + 0.0 for v in values]


def _unit_factor(frm: str, to: str) -> Decimal:
    return Decimal(repr(LENGTH_UNITS[frm])) / Decimal(repr(LENGTH_UNITS[to]))


# ---------------------------------------------------------------------------------------------------------------
# import


def _fail(path, what: str, joint: str | None = None, link: str | None = None) -> URDFImportError:
    tail = f" (joint {joint!r})" if joint is not None else f" (link {link!r})" if link is not None else ""
    return URDFImportError(f"{path}: {what}{tail}")


def _raw_origins(root) -> dict:
    """Joint name -> (xyz, rpy) as written in the file (floats), for origins not folded with others."""
    out = {}
    for el in root.findall("joint"):
        o = el.find("origin")
        name = el.get("name")
        if name in out:
            out[name] = None  # duplicate names: do not trust the raw values
            continue
        try:
            xyz = [float(v) for v in (o.get("xyz", "0 0 0") if o is not None else "0 0 0").split()]
            rpy = [float(v) for v in (o.get("rpy", "0 0 0") if o is not None else "0 0 0").split()]
        except ValueError:
            xyz = rpy = []
        out[name] = (xyz, rpy) if len(xyz) == 3 and len(rpy) == 3 else None
    return out


def is_xacro(path: Path) -> bool:
    """A xacro file: named ``*.xacro`` or using the xacro namespace (``xmlns:xacro``). Only a regular file
    is opened to look (a FIFO would block)."""
    import os
    import stat

    if str(path).endswith(".xacro"):
        return True
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return False
        with open(path, "rb") as fh:
            return b"xmlns:xacro" in fh.read(65536)
    except (OSError, ValueError):
        return False


def expand_xacro(path: Path, args: dict | None = None, xacro_paths=(), *, time_limit: float | None = None,
                 memory_mib: int | None = None) -> str:
    """The URDF text of a xacro file, expanded in a separate, limited process (:mod:`pipeline.xacro_sandbox`):
    macros, properties, includes, ``xacro.load_yaml``, ``$(arg ...)`` with ``args``; expressions through
    :mod:`pipeline.safe_expr` (arithmetic, never code); files read only from the file's own folder and
    ``xacro_paths``; ``$(env X)``/``$(optenv X)`` only from ``args``; no ROS substitutions (``$(find
    pkg)``). Any failure or refusal is one line naming the file (:class:`URDFImportError`)."""
    import os

    from pipeline import xacro_sandbox

    for d in xacro_paths or ():
        if not os.path.isdir(d):
            raise _fail(path, f"--xacro-path {d}: no such folder")
    try:
        return xacro_sandbox.expand(path, args, tuple(xacro_paths or ()),
                                    time_limit=xacro_sandbox.TIME_LIMIT_S if time_limit is None else time_limit,
                                    memory_mib=xacro_sandbox.MEMORY_MIB if memory_mib is None else memory_mib)
    except xacro_sandbox.SandboxError as exc:
        raise _fail(path, str(exc)) from None


def _parse_expanded(path: Path, text: str):
    """The URDF text a xacro file expanded to, parsed from memory; messages name the user's file."""
    import io

    from lxml import etree

    shown = f"{path} (expanded by xacro)"
    data = text.encode("utf-8")
    parser = etree.XMLParser(remove_blank_text=True, resolve_entities=False, no_network=True, load_dtd=False)
    try:
        root = etree.fromstring(data, parser)
    except etree.XMLSyntaxError as exc:
        raise _fail(shown, f"not valid XML ({str(exc).splitlines()[0]})") from None
    return _model(root, shown, io.BytesIO(data), mesh_dir=str(Path(path).parent))


def _load(path: Path, xacro_args: dict | None = None, xacro_paths=()):
    """Parse the URDF (lxml for the XML check and the written origins, yourdfpy for the model); a xacro
    file is expanded first (:func:`expand_xacro`) and its text parsed from memory."""
    from lxml import etree

    from pipeline.errors import not_regular

    why = not_regular(path)
    if why:  # a FIFO would block the read
        raise _fail(path, why)
    if is_xacro(path) and Path(path).is_file():
        return _parse_expanded(path, expand_xacro(path, xacro_args, xacro_paths))
    try:
        root = etree.parse(str(path), etree.XMLParser(remove_blank_text=True)).getroot()
    except OSError as exc:
        raise _fail(path, f"cannot read URDF ({exc.strerror or exc})") from None
    except etree.XMLSyntaxError as exc:
        raise _fail(path, f"not valid XML ({str(exc).splitlines()[0]})") from None
    return _model(root, path, str(path))


def _model(root, shown, source, **load_kw):
    """(yourdfpy robot, raw origins) of a parsed URDF ``root`` read from ``source`` (a path or a file
    object); ``shown`` is the file errors name."""
    import yourdfpy

    if root.tag != "robot":
        hint = "; an MJCF file: use import-mjcf" if root.tag == "mujoco" else ""
        raise _fail(shown, f"not a URDF (root element <{root.tag}>, expected <robot>{hint})")
    _check_elements(root, shown)
    try:
        urdf = yourdfpy.URDF.load(source, build_scene_graph=False, build_collision_scene_graph=False,
                                  load_meshes=False, load_collision_meshes=False, **load_kw)
    except Exception as exc:  # noqa: BLE001  the library raises many kinds; one line names the file
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise _fail(shown, f"yourdfpy cannot parse the URDF ({msg})") from None
    return urdf.robot, _raw_origins(root)


# <element attribute>: (count of numbers, bound on |value|, unit of the bound); lengths in metres (URDF's unit)
_NUMBERS = {("origin", "xyz"): (3, MAX_LENGTH_M, "m"), ("origin", "rpy"): (3, MAX_ANGLE, "rad"),
            ("axis", "xyz"): (3, 1e6, ""), ("limit", "lower"): (1, None, ""), ("limit", "upper"): (1, None, ""),
            ("limit", "effort"): (1, None, ""), ("limit", "velocity"): (1, None, ""),
            ("mimic", "multiplier"): (1, MAX_ANGLE, ""), ("mimic", "offset"): (1, MAX_ANGLE, "")}


def _numbers(el, attr: str, path, joint: str):
    """The numbers of one attribute of a joint's element, checked: count, finite, within the bound."""
    count, bound, unit = _NUMBERS[(el.tag, attr)]
    raw = el.get(attr)
    if raw is None:
        return
    shown = f"<{el.tag} {attr}={raw[:60]!r}>".replace("'", '"')
    words = raw.split()
    if len(words) != count:
        raise _fail(path, f"{shown}: expected {count} number{'s' if count > 1 else ''}, got {len(words)}",
                    joint=joint)
    for w in words:
        try:
            v = float(w)
        except ValueError:
            raise _fail(path, f"{shown}: {w[:30]!r} is not a number", joint=joint) from None
        infinite_limit = el.tag == "limit" and attr in ("lower", "upper") and math.isinf(v)  # read by _limits
        if not (math.isfinite(v) or infinite_limit):
            raise _fail(path, f"{shown}: {w[:30]!r} is not a finite number", joint=joint)
        if bound is not None and abs(v) > bound:
            raise _fail(path, f"{shown}: {w[:30]} is beyond the sane maximum {bound:g}{' ' + unit if unit else ''} "
                        "in absolute value", joint=joint)


def _unique_names(root, tag: str, path) -> set:
    """The names of the ``<tag>`` elements; a missing or repeated name is refused in one line."""
    names = set()
    for el in root.findall(tag):
        name = el.get("name")
        if not name:
            raise _fail(path, f"<{tag}> without a name")
        if name in names:
            raise _fail(path, f"<{tag}> defined twice", **{tag: name})
        names.add(name)
    return names


def _check_elements(root, path) -> None:
    """Refuse, in one line naming the element and the joint or link, what the URDF reader would take or
    crash on: a joint without name, parent or child, a link named twice or not defined, a joint whose
    parent is its child, a loop of joints, and in ``<origin>``, ``<axis>``, ``<limit>`` and ``<mimic>``
    a wrong count of numbers (``xyz="0 0 0 1"``), a non-number, a non-finite number (``nan``, ``inf``,
    ``1e400``) or one beyond the robot files' sane maxima (:data:`pipeline.robots.MAX_LENGTH_M` metres,
    :data:`pipeline.robots.MAX_ANGLE` rad)."""
    links = _unique_names(root, "link", path)
    _unique_names(root, "joint", path)
    parent_of = {}
    for el in root.findall("joint"):
        name, ends = el.get("name"), {}
        for sub in ("parent", "child"):
            if el.find(sub) is None or not el.find(sub).get("link"):
                raise _fail(path, f"joint without <{sub} link=...>", joint=name)
            ends[sub] = el.find(sub).get("link")
            if ends[sub] not in links:
                raise _fail(path, f"<{sub} link={ends[sub][:60]!r}> names a link the file does not define "
                            f"(no <link name={ends[sub][:60]!r}>)".replace("'", '"'), joint=name)
        if ends["parent"] == ends["child"]:
            raise _fail(path, f"<parent> and <child> are the same link {ends['child']!r} (a loop)", joint=name)
        if ends["child"] in parent_of:
            raise _fail(path, f"link {ends['child']!r} is the child of two joints (not a tree)", joint=name)
        parent_of[ends["child"]] = (ends["parent"], name)
        for sub in el:
            if isinstance(sub.tag, str):
                for attr in sub.keys():
                    if (sub.tag, attr) in _NUMBERS:
                        _numbers(sub, attr, path, name)
    rooted = set()  # links whose parents lead up to a root
    for start in parent_of:  # follow the parents up from every link: a tree reaches a root, a loop comes back
        seen, cur = [start], start
        while cur in parent_of and cur not in rooted:
            cur, joint = parent_of[cur]
            if cur in seen:
                raise _fail(path, f"the joints form a loop through link {cur!r} (a URDF is a tree)", joint=joint)
            seen.append(cur)
        rooted.update(seen)


def _chain_joints(robot, path: Path, base_link: str, tip_link: str) -> list:
    links = {lk.name for lk in robot.links}
    children = {j.child for j in robot.joints}
    parents = {j.parent for j in robot.joints}
    for lk, flag, pool in ((base_link, "--base", sorted(links - children)), (tip_link, "--tip", sorted(links - parents))):
        if lk not in links:
            raise _fail(path, f"unknown link {lk!r} given as {flag}; candidates: {', '.join(pool) or '-'} "
                        f"({'roots' if flag == '--base' else 'leaves'} of the tree); every link: "
                        f"{', '.join(sorted(links))}")
    parent_joint = {}
    for j in robot.joints:
        if j.child in parent_joint:
            raise _fail(path, f"link {j.child!r} is the child of two joints (not a tree)", joint=j.name)
        parent_joint[j.child] = j
    chain, cur = [], tip_link
    while cur != base_link:
        j = parent_joint.get(cur)
        if j is None or len(chain) > len(robot.joints):
            raise _fail(path, f"tip link {tip_link!r} is not below base link {base_link!r}", link=tip_link)
        chain.append(j)
        cur = j.parent
    return chain[::-1]


def _joint_entry(j, pending: np.ndarray, origin: np.ndarray, raw: dict, path: Path, f: float) -> dict:
    """The robot-file entry of one moving URDF joint ``j`` whose origin (4, 4) follows the fixed joints folded
    into ``pending`` (4, 4); ``f`` converts metres to the document's unit. Refuses joints a robot file cannot hold."""
    if j.type in ("floating", "planar"):
        raise _fail(path, f"{j.type} joint in the chain (only revolute, continuous, prismatic and fixed "
                    "joints can be imported)", joint=j.name)
    if j.type not in MOVING:
        raise _fail(path, f"unknown joint type {j.type!r} (allowed: revolute, continuous, prismatic, fixed)",
                    joint=j.name)
    if j.mimic is not None:
        raise _fail(path, f"mimic joint in the chain (it follows joint {j.mimic.joint!r}; robot files have "
                    "one independent variable per joint)", joint=j.name)
    axis = np.asarray(j.axis if j.axis is not None else [1.0, 0.0, 0.0], dtype=float)
    if axis.shape != (3,) or not np.all(np.isfinite(axis)) or not np.linalg.norm(axis) > 1e-12:
        raise _fail(path, f"joint axis must be a finite non-zero 3-vector, got {axis.tolist()}", joint=j.name)
    T = pending @ origin
    if raw.get(j.name) and not np.any(pending != _EYE):  # the file's own numbers where nothing was folded in
        xyz, rpy = raw[j.name]
    else:
        xyz, rpy = _clean(T[:3, 3]), _clean(rpy_from_matrix(T))
    if not np.allclose(origin_matrix(xyz, rpy), T, rtol=0, atol=1e-12):
        xyz, rpy = _clean(T[:3, 3]), _clean(rpy_from_matrix(T))
    entry = {"name": j.name, "type": "prismatic" if j.type == "prismatic" else "revolute",
             "xyz": [_scale(v, f) for v in xyz], "rpy": [float(v) + 0.0 for v in rpy],
             "axis": [float(v) + 0.0 for v in axis]}
    lim = _limits(j, path)
    if lim is not None:
        entry["limits"] = [_scale(v, f) for v in lim] if j.type == "prismatic" else lim
    return entry


def import_urdf(path, base_link: str, tip_link: str, name: str | None = None, length_unit: str = "m",
                xacro_args: dict | None = None, xacro_paths=()) -> dict:
    """A robot-file document (general form) for the URDF chain from ``base_link`` to ``tip_link``.

    Parameters
    ----------
    path : str or Path            the URDF file (lengths in metres, as URDF defines them)
    base_link, tip_link : str     link names; the tip must be below the base in the URDF tree
    name : str, optional          robot name (= the robot file's stem); default the URDF's robot name
    length_unit : {"m", "cm", "mm"}
        The document's unit: translations and prismatic limits are converted from metres.
    xacro_args : dict, optional   a xacro file's ``$(arg NAME)`` values (also its only ``$(env NAME)`` values)
    xacro_paths : folders         folders besides the xacro file's own that it may include or load YAML from

    Returns
    -------
    doc : dict
        ``name, source, length_unit, convention: general, joints`` (``name, type, xyz, rpy, axis`` and
        ``limits`` unless continuous or unlimited), ``tool`` (4x4, when not identity) and ``notes``,
        ready for :func:`pipeline.robots.parse_robot` and :func:`robot_yaml`.

    Raises
    ------
    URDFImportError
        One line ``<file>: <what> (joint 'NAME')`` (or ``(link 'NAME')``).
    """
    path = Path(path)
    if length_unit not in LENGTH_UNITS:
        raise _fail(path, f"unknown length unit {length_unit!r} (allowed: {', '.join(LENGTH_UNITS)})")
    robot, raw = _load(path, xacro_args, xacro_paths)
    joints_urdf = _chain_joints(robot, path, base_link, tip_link)
    f = _unit_factor("m", length_unit)
    pending, folded_names, joints, folds = _EYE, [], [], []
    for j in joints_urdf:
        origin = _EYE if j.origin is None else np.asarray(j.origin, dtype=float)
        if j.type == "fixed":
            pending = pending @ origin
            folded_names.append(j.name)
            continue
        entry = _joint_entry(j, pending, origin, raw, path, f)
        if folded_names:
            folds.append(f"{', '.join(repr(n) for n in folded_names)} into {j.name!r}")
        pending, folded_names = _EYE, []
        joints.append(entry)
    if not joints:
        raise _fail(path, f"no revolute, continuous or prismatic joint between links {base_link!r} and "
                    f"{tip_link!r}", link=tip_link)
    if folded_names:
        folds.append(f"{', '.join(repr(n) for n in folded_names)} into the tool")
    doc = {
        "name": name if name is not None else robot.name,
        "source": f"URDF {path.name} (robot {robot.name!r}), links {base_link} -> {tip_link}",
        "length_unit": length_unit,
        "convention": "general",
        "joints": joints,
    }
    if np.any(pending != _EYE):
        tool = pending.copy()
        tool[:3, :3] = np.reshape(_clean(tool[:3, :3].ravel()), (3, 3))
        tool[:3, 3] = [_scale(v, f) for v in _clean(tool[:3, 3])]
        tool[3] = [0.0, 0.0, 0.0, 1.0]
        doc["tool"] = [[float(v) + 0.0 for v in row] for row in tool]
    unit = "in m (URDF's unit)" if length_unit == "m" else f"converted from m to {length_unit}"
    note = f"Imported from {path.name} by pipeline.urdf.import_urdf; lengths {unit}."
    note += (" Fixed joints folded: " + "; ".join(folds) + ".") if folds else " No fixed joints in the chain."
    doc["notes"] = note
    return doc


def _limits(j, path: Path) -> list | None:
    """``[lower, upper]`` (URDF units) or None for a continuous or an unlimited prismatic joint."""
    if j.type == "continuous":
        return None
    lim = j.limit
    if lim is None or lim.lower is None or lim.upper is None:
        hint = " (an unlimited revolute joint is type continuous)" if j.type == "revolute" else ""
        raise _fail(path, f"{j.type} joint without <limit lower=... upper=...>{hint}", joint=j.name)
    lo, hi = float(lim.lower), float(lim.upper)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        if j.type == "prismatic" and lo == -math.inf and hi == math.inf:
            return None
        raise _fail(path, f"joint limits must be finite, got [{lo}, {hi}]", joint=j.name)
    if lo > hi:
        raise _fail(path, f"lower limit {lo:g} is above upper limit {hi:g}", joint=j.name)
    if j.type == "prismatic" and lo <= -UNLIMITED_PRISMATIC_M and hi >= UNLIMITED_PRISMATIC_M:
        return None  # to_urdf's stand-in for "no limits" (or a range no real slide has)
    return [lo + 0.0, hi + 0.0]


# ---------------------------------------------------------------------------------------------------------------
# YAML


_PLAIN = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
_YAML_WORDS = {"y", "n", "yes", "no", "true", "false", "on", "off", "null"}


def _flow(v, angle: bool = False) -> str:
    if isinstance(v, str):
        plain = _PLAIN.match(v) and v.lower() not in _YAML_WORDS
        return v if plain else json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_flow(x, angle) for x in v) + "]"
    if isinstance(v, bool) or v is None:
        raise TypeError(f"cannot write {v!r}")
    return _fmt_angle(v) if angle else fmt_float(v)


def robot_yaml(doc: dict, header: str = "") -> str:
    """A robot-file document as YAML text: one joint per line, numbers ``repr``-exact.

    ``header`` (lines without ``#``) becomes a comment block at the top. Works for general and DH
    documents; angles (``rpy``, ``alpha``, ``theta_offset``, revolute limits) that equal a simple
    ``pi`` expression exactly (as :mod:`pipeline.robots` reads it) are written as one.
    """
    angle_keys = {"rpy", "alpha", "theta_offset"}
    out = [f"# {line}".rstrip() for line in header.splitlines()] if header else []
    for key in ("name", "source", "length_unit", "convention"):
        out.append(f"{key}: {_flow(doc[key]) if key != 'source' else json.dumps(doc[key])}")
    if "limits_source" in doc:
        out.append(f"limits_source: {_flow(doc['limits_source'])}")
    if "base" in doc:
        out.append(f"base: {_flow(doc['base'])}")
    out.append("joints:")
    for j in doc["joints"]:
        items = []
        for k, v in j.items():
            angle = k in angle_keys or (k == "limits" and j.get("type") == "revolute")
            items.append(f"{k}: {_flow(v, angle=angle)}")
        out.append("  - {" + ", ".join(items) + "}")
    if "tool" in doc:
        out.append(f"tool: {_flow(doc['tool'])}")
    if doc.get("notes"):
        out.append(f"notes: {_flow(doc['notes'])}")
    return "\n".join(out) + "\n"


def import_header(path, base_link: str, tip_link: str, length_unit: str = "m") -> str:
    """The comment block of an imported robot file (no date: same URDF -> same file)."""
    return (f"Imported from URDF {Path(path).name}, links {base_link} -> {tip_link}, by `python -m pipeline "
            f"import-urdf` (pipeline.urdf.import_urdf).\n"
            "General joint form: each joint's <origin> (xyz [" + length_unit + "], rpy [rad], URDF order "
            "R = Rz(yaw) Ry(pitch) Rx(roll)) and <axis>;\n"
            "fixed joints are folded into the next joint's origin (into `tool` after the last moving joint).")


def imported_yaml(path, base_link: str, tip_link: str, name: str | None = None, length_unit: str = "m",
                  xacro_args: dict | None = None, xacro_paths=()) -> str:
    """:func:`import_urdf` written as a robot file (header comment + :func:`robot_yaml`)."""
    doc = import_urdf(path, base_link, tip_link, name=name, length_unit=length_unit, xacro_args=xacro_args,
                      xacro_paths=xacro_paths)
    return robot_yaml(doc, import_header(path, base_link, tip_link, length_unit))


# ---------------------------------------------------------------------------------------------------------------
# export


_XML_NAME = re.compile(r"^[A-Za-z0-9_.\-]+$")


def _joint_names(model: RobotModel) -> list[str]:
    given = list(model.joint_names) if len(model.joint_names) == model.n else [""] * model.n
    names, seen = [], {"base_joint", "tool0_joint"}
    for i, nm in enumerate(given, start=1):
        nm = str(nm).strip()
        if not nm or nm in seen or not _XML_NAME.match(nm):
            nm = f"joint{i}" if f"joint{i}" not in seen else f"joint{i}_{len(seen)}"
        seen.add(nm)
        names.append(nm)
    return names


def _origin_xml(T: np.ndarray) -> str:
    xyz = " ".join(fmt_float(v) for v in _clean(T[:3, 3]))
    rpy = " ".join(fmt_float(v) for v in _clean(rpy_from_matrix(T)))
    return f'<origin xyz="{xyz}" rpy="{rpy}"/>'


def _comment(text: str) -> str:
    text = escape(text).replace("--", "- -")
    return text[:-1] + "- " if text.endswith("-") else text


def to_urdf(model: RobotModel, name: str | None = None) -> str:
    """A URDF string of any robot: links ``base_link`` -> ``link0`` ... ``linkN`` -> ``tool0``, metres.

    ``base_link`` is the robot's world frame; the fixed joint ``base_joint`` carries the base
    transform, ``jointI`` (or the robot file's joint names) the chain in the general form of
    :meth:`Chain.as_general`, and the fixed joint ``tool0_joint`` the tool transform. The pose of
    ``tool0`` in ``base_link`` equals ``fk_htm(model.chain, q)`` (lengths in metres). Limits: a
    revolute joint without limits is ``continuous``; a prismatic joint without limits gets
    ``+-UNLIMITED_PRISMATIC_M`` (commented); effort/velocity are written as 0 (robot files do not give
    them). Deterministic: the same model gives the same string.
    """
    f = _unit_factor(model.length_unit, "m")
    chain = model.chain
    origins, axes, tool = chain.as_general()
    base = chain.base.copy()

    def metres(T):
        T = np.array(T, dtype=float)
        T[:3, 3] = [_scale(v, f) for v in T[:3, 3]]
        return T

    robot_name = name or model.name
    names = _joint_names(model)
    src = Path(model.path).name if model.path else "(built in code)"
    lines = [
        '<?xml version="1.0"?>',
        f"<!-- Written by pipeline.urdf.to_urdf from robot {_comment(model.name)} ({_comment(src)}; "
        f"{chain.convention} form in {model.length_unit}).",
        f"     Source: {_comment(model.source)}",
        "     Lengths in metres. base_link = the robot's world frame (base transform in base_joint);",
        "     tool0 = the tool frame (tool transform in tool0_joint). effort/velocity limits are",
        "     placeholders (0): robot files do not give them. -->",
        f"<robot name={quoteattr(robot_name)}>",
        '  <link name="base_link"/>',
        *[f'  <link name="link{i}"/>' for i in range(chain.n + 1)],
        '  <link name="tool0"/>',
        '  <joint name="base_joint" type="fixed">',
        '    <parent link="base_link"/>',
        '    <child link="link0"/>',
        f"    {_origin_xml(metres(base))}",
        "  </joint>",
    ]
    for i in range(chain.n):
        lo, hi = model.limits[i]
        finite = bool(np.isfinite(lo) and np.isfinite(hi))
        if chain.prismatic[i]:
            typ = "prismatic"
        else:
            typ = "revolute" if finite else "continuous"
        lines += [f"  <joint name={quoteattr(names[i])} type=\"{typ}\">",
                  f'    <parent link="link{i}"/>',
                  f'    <child link="link{i + 1}"/>',
                  f"    {_origin_xml(metres(origins[i]))}",
                  f"    <axis xyz=\"{' '.join(fmt_float(v) for v in axes[i])}\"/>"]
        if chain.prismatic[i]:
            if finite:
                lo, hi = _scale(lo, f), _scale(hi, f)
            else:
                lo, hi = -UNLIMITED_PRISMATIC_M, UNLIMITED_PRISMATIC_M
                lines.append(f"    <!-- no limits in the robot file: +-{fmt_float(UNLIMITED_PRISMATIC_M)} m stands "
                             "for unlimited (pipeline.urdf.UNLIMITED_PRISMATIC_M) -->")
        if typ != "continuous":
            lines.append(f'    <limit lower="{fmt_float(lo)}" upper="{fmt_float(hi)}" effort="0" velocity="0"/>')
        lines.append("  </joint>")
    lines += [
        '  <joint name="tool0_joint" type="fixed">',
        f'    <parent link="link{chain.n}"/>',
        '    <child link="tool0"/>',
        f"    {_origin_xml(metres(tool))}",
        "  </joint>",
        "</robot>",
    ]
    return "\n".join(lines) + "\n"
