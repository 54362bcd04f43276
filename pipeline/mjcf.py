"""MJCF import for robot files (general joint form), through the ``mujoco`` package's own parser.

:func:`import_mjcf` compiles an MJCF file with ``mujoco.MjModel.from_xml_path`` (so includes,
defaults, ``<frame>`` elements, euler angles and ``compiler`` settings are MuJoCo's business, not
ours) and walks the compiled model's body tree from a base body down to a tip (a body, or a site
whose frame becomes the tool). It returns the same robot-file document as
:func:`pipeline.urdf.import_urdf` (``convention: general``), with the same one-line refusals.

The chain. A body's pose in its parent is ``B = (body_pos, body_quat)``; a hinge joint with anchor
``p`` (``jnt_pos``) and axis ``a`` (``jnt_axis``, body frame) moves it by ``Trans(p) Rot(a, q − ref)
Trans(−p)`` (a slide joint by ``Trans(a (q − ref))``), ``ref`` being the joint's reference value
(``qpos0``). So joint i's origin is ``pending · B · Trans(p) · Rot(a, −ref)`` (slide: ``pending · B ·
Trans(−a ref)``), its axis ``a``, and ``pending`` becomes ``Trans(−p)``; a body without a joint is
folded into ``pending``, and after the last joint ``pending`` (and the tip site's pose) is the tool.
Angles and lengths are the compiled model's: radians and metres (MJCF's unit). Refused, each in one
line ``<file>: <what> (body 'NAME')`` or ``(joint 'NAME')``: a file MuJoCo cannot compile (its first
message line), a root element other than ``<mujoco>`` (a URDF goes to ``import-urdf``), an unknown
base or tip, a tip not below the base, a body with more than one joint, a ball or free joint, a chain
without a joint. Joint limits: ``jnt_range`` of a limited joint, none otherwise.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from pipeline.robots import LENGTH_UNITS, origin_matrix, rpy_from_matrix
from pipeline.urdf import URDFImportError, robot_yaml

_EYE = np.eye(4)
RPY_EXACT = 1e-12  # [m, 1] an origin written as xyz/rpy must give back the compiled matrix to this


class MJCFImportError(URDFImportError):
    """An MJCF file cannot be imported; the message is one line ``<file>: <what> (body 'NAME')``."""


def _fail(path, what: str, body: str | None = None, joint: str | None = None) -> MJCFImportError:
    tail = f" (joint {joint!r})" if joint is not None else f" (body {body!r})" if body is not None else ""
    return MJCFImportError(f"{path}: {what}{tail}")


def _pose(mujoco, pos, quat) -> np.ndarray:
    T = np.eye(4)
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, np.asarray(quat, dtype=float))
    T[:3, :3] = R.reshape(3, 3)
    T[:3, 3] = pos
    return T


def _rot(axis: np.ndarray, angle: float) -> np.ndarray:
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    T = np.eye(4)
    T[:3, :3] = np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * (K @ K)
    return T


def _trans(v) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = v
    return T


def load_mjcf(path):
    """The compiled ``mujoco.MjModel`` of an MJCF file, or a one-line :class:`MJCFImportError`.

    Parameters
    ----------
    path : str or Path
        The MJCF file.

    Returns
    -------
    mujoco.MjModel

    Raises
    ------
    MJCFImportError
        The file is missing, not MJCF (root element other than ``<mujoco>``), or MuJoCo cannot compile it.
    """
    path = Path(path)
    if not path.is_file():
        raise _fail(path, "no such file")
    try:
        root = ET.parse(path).getroot().tag
    except ET.ParseError as exc:
        raise _fail(path, f"not well-formed XML ({exc})") from None
    if root != "mujoco":
        hint = " (use import-urdf)" if root == "robot" else ""
        raise _fail(path, f"not an MJCF (root element <{root}>){hint}")
    try:
        import mujoco
    except ImportError:
        raise _fail(path, "reading MJCF needs the mujoco package (pip install mujoco)") from None
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except Exception as exc:  # noqa: BLE001  (MuJoCo's compiler errors are ValueError, several lines)
        first = next((ln.strip() for ln in str(exc).splitlines() if ln.strip()), type(exc).__name__)
        raise _fail(path, f"MuJoCo cannot compile it: {first[:200]}") from None


def _chain_bodies(mujoco, model, path: Path, base: str, tip: str) -> tuple[list[int], np.ndarray]:
    """Body ids from below ``base`` down to the tip body, and the tip site's pose in that body."""
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, base)
    if bid < 0:
        raise _fail(path, "no such body", body=base)
    site_T = _EYE
    tid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, tip)
    if tid < 0:
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, tip)
        if sid < 0:
            raise _fail(path, "no such body or site", body=tip)
        tid = int(model.site_bodyid[sid])
        site_T = _pose(mujoco, model.site_pos[sid], model.site_quat[sid])
    chain, b = [], tid
    while b != bid:
        if b == 0:
            raise _fail(path, f"the tip {tip!r} is not below the base {base!r}", body=tip)
        chain.append(b)
        b = int(model.body_parentid[b])
    return chain[::-1], site_T


def _joint_entry(mujoco, model, j: int, origin: np.ndarray, path: Path, f: float) -> dict:
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}"
    xyz, rpy = origin[:3, 3] * f, rpy_from_matrix(origin[:3, :3])
    back = origin_matrix(origin[:3, 3], rpy)
    if not np.allclose(back, origin, rtol=0, atol=RPY_EXACT):
        raise _fail(path, "its origin cannot be written as xyz/rpy exactly", joint=name)
    prism = int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_SLIDE)
    entry = {"name": name, "type": "prismatic" if prism else "revolute",
             "xyz": [float(v) + 0.0 for v in xyz], "rpy": [float(v) + 0.0 for v in rpy],
             "axis": [float(v) + 0.0 for v in model.jnt_axis[j]]}
    if model.jnt_limited[j]:
        lo, hi = (float(v) for v in model.jnt_range[j])
        entry["limits"] = [lo * f, hi * f] if prism else [lo, hi]
    return entry


def import_mjcf(path, base: str, tip: str, name: str | None = None, length_unit: str = "m") -> dict:
    """A robot-file document (general form) for the MJCF chain from body ``base`` to ``tip``.

    Parameters
    ----------
    path : str or Path            the MJCF file (lengths in metres, angles as its compiler says)
    base : str                    a body name (``world`` for the world frame)
    tip : str                     a body or site name below ``base`` (a site's frame becomes the tool)
    name : str, optional          robot name (= the robot file's stem); default the MJCF's model name
    length_unit : {"m", "cm", "mm"}
        The document's unit: translations and prismatic limits are converted from metres.

    Returns
    -------
    doc : dict
        As :func:`pipeline.urdf.import_urdf`: ``name, source, length_unit, convention: general,
        joints``, ``tool`` (when not identity) and ``notes``.

    Raises
    ------
    MJCFImportError
        One line ``<file>: <what> (body 'NAME')`` (or ``(joint 'NAME')``).
    """
    import mujoco  # load_mjcf checked it imports

    path = Path(path)
    if length_unit not in LENGTH_UNITS:
        raise _fail(path, f"unknown length unit {length_unit!r} (allowed: {', '.join(LENGTH_UNITS)})")
    model = load_mjcf(path)
    bodies, site_T = _chain_bodies(mujoco, model, path, base, tip)
    f = 1.0 / LENGTH_UNITS[length_unit]
    pending, joints, folded = _EYE, [], []
    hinge, slide = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)
    for b in bodies:
        bname = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}"
        B = _pose(mujoco, model.body_pos[b], model.body_quat[b])
        n_j, j0 = int(model.body_jntnum[b]), int(model.body_jntadr[b])
        if n_j == 0:
            pending = pending @ B
            folded.append(bname)
            continue
        if n_j > 1:
            raise _fail(path, f"{n_j} joints in one body (a serial chain has one per body)", body=bname)
        kind = int(model.jnt_type[j0])
        if kind not in (hinge, slide):
            jname = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j0) or f"joint{j0}"
            raise _fail(path, "a ball or free joint (only hinge and slide joints make a serial chain)", joint=jname)
        a = np.asarray(model.jnt_axis[j0], dtype=float)
        ref = float(model.qpos0[model.jnt_qposadr[j0]])
        if kind == hinge:
            p = np.asarray(model.jnt_pos[j0], dtype=float)
            origin = pending @ B @ _trans(p) @ _rot(a, -ref)
            pending = _trans(-p)
        else:
            origin = pending @ B @ _trans(-a * ref)
            pending = _EYE
        joints.append(_joint_entry(mujoco, model, j0, origin, path, f))
    if not joints:
        raise _fail(path, f"no hinge or slide joint between bodies {base!r} and {tip!r}", body=tip)
    tool = pending @ site_T
    model_name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_MODEL, 0) if hasattr(mujoco.mjtObj, "mjOBJ_MODEL") else None
    doc = {"name": name if name is not None else (model_name or path.stem),
           "source": f"MJCF {path.name}, bodies {base} -> {tip}", "length_unit": length_unit,
           "convention": "general", "joints": joints}
    if not np.allclose(tool, _EYE, rtol=0, atol=0):
        T = tool.copy()
        T[:3, 3] *= f
        T[3] = [0.0, 0.0, 0.0, 1.0]
        doc["tool"] = [[float(v) + 0.0 for v in row] for row in T]
    unit = "in m (MJCF's unit)" if length_unit == "m" else f"converted from m to {length_unit}"
    doc["notes"] = (f"Imported from {path.name} by pipeline.mjcf.import_mjcf (MuJoCo {mujoco.__version__}'s "
                    f"compiled model); lengths {unit}. "
                    + (f"Bodies without a joint folded: {', '.join(folded)}." if folded else "No joint-less bodies."))
    return doc


def imported_mjcf_yaml(path, base: str, tip: str, name: str | None = None, length_unit: str = "m") -> str:
    """:func:`import_mjcf` written as a robot file (header comment + :func:`pipeline.urdf.robot_yaml`)."""
    doc = import_mjcf(path, base, tip, name=name, length_unit=length_unit)
    header = (f"Imported from MJCF {Path(path).name}, bodies {base} -> {tip}, by `python -m pipeline import-mjcf` "
              "(pipeline.mjcf.import_mjcf).\n"
              "General joint form: each joint's origin (xyz [" + length_unit + "], rpy [rad], URDF order "
              "R = Rz(yaw) Ry(pitch) Rx(roll)) and axis,\nfrom MuJoCo's compiled body poses, joint anchors, "
              "axes and reference values.")
    return robot_yaml(doc, header)
