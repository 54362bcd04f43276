"""Robot files (``data/robots/<name>.yaml``): loading and validation into an immutable model.

A robot file::

    name: kuka_lwr                      # must equal the file stem
    source: "000_7e3cb7ad5ee98ff0.txt, Table 2"
    length_unit: cm                     # m | cm | mm
    convention: standard                # standard | modified DH | general (see pipeline.kinematics)
    joints:                             # one entry per joint, base to tip
      - {type: revolute, a: 0, alpha: -pi/2, d: 31, theta_offset: 0, limits: [-2.9, 2.9]}
    base: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]   # optional, T_world_base
    tool: [[...]]                                     # optional, T_flange_tool
    notes: free text                                  # optional

The general (URDF-style) form writes each joint as a fixed origin and an axis instead of DH rows::

    convention: general
    joints:
      - {name: A1, type: revolute, xyz: [0, 0, 0.31], rpy: [0, 0, 0], axis: [0, 0, 1], limits: [-2.9, 2.9]}
      - {name: A2, type: prismatic, xyz: [0.1, 0, 0], rpy: [pi/2, 0, 0], axis: [0, 1, 0]}

``xyz`` [length] and ``rpy`` [rad] are joint i's origin in the previous joint's frame (the base for
joint 1), exactly as URDF's ``<origin>``: ``T = Trans(xyz) Rz(yaw) Ry(pitch) Rx(roll)`` with
``rpy = [roll, pitch, yaw]``. ``axis`` (non-zero, normalised on load) is URDF's ``<axis>`` in joint
i's frame; the joint turns about it (revolute) or slides along it (prismatic) after its origin. A
URDF ``continuous`` joint is a revolute joint without ``limits``. DH fields (``a``, ``alpha``,
``d``, ``theta_offset``) are refused in a general joint, and ``xyz``/``rpy``/``axis`` in a DH joint.
``pipeline.urdf.import_urdf`` writes such files from a URDF.

Angles may be written as numbers or as ``pi`` expressions (``-pi/2``, ``3*pi/4``).
Every problem is reported as one line naming the file, the joint and the field.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from pipeline.kinematics.chain import CONVENTIONS, GENERAL, Chain

LENGTH_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
JOINT_TYPES = ("revolute", "prismatic")
TOP_REQUIRED = ("name", "source", "length_unit", "convention", "joints")
TOP_OPTIONAL = ("base", "tool", "notes", "limits_source")
JOINT_REQUIRED = ("type", "a", "alpha", "d", "theta_offset")
JOINT_OPTIONAL = ("limits", "name")
GENERAL_REQUIRED = ("type", "xyz", "rpy", "axis")
DH_FIELDS = ("a", "alpha", "d", "theta_offset")
GENERAL_FIELDS = ("xyz", "rpy", "axis")
RIGID_TOL = 1e-6  # a base/tool rotation block must be orthonormal to this (typed-in decimals)

_PI_EXPR = re.compile(r"^\s*([-+]?)\s*(?:(\d+(?:\.\d+)?)\s*\*\s*)?pi\s*(?:/\s*(\d+(?:\.\d+)?))?\s*$")


class RobotFileError(ValueError):
    """A robot file is unreadable or invalid; the message is one line naming file and field."""


@dataclass(frozen=True)
class RobotModel:
    """An immutable, validated robot.

    Attributes
    ----------
    name, source, length_unit : str
    chain : Chain
    limits : ndarray, shape (n, 2) [rad | length]
        Lower/upper joint limits; ``-inf``/``inf`` where the file gives none.
    path : str
        The file it came from (for messages).
    joint_names : tuple of str
        The joints' ``name`` fields (``""`` where the file gives none); empty when built in code.
    """

    name: str
    source: str
    length_unit: str
    chain: Chain
    limits: np.ndarray
    path: str = ""
    notes: str = ""
    joint_names: tuple = ()

    @property
    def n(self) -> int:
        return self.chain.n

    def in_unit(self, unit: str) -> "RobotModel":
        """A copy whose lengths are expressed in ``unit`` (m, cm or mm)."""
        if unit not in LENGTH_UNITS:
            raise ValueError(f"unknown length unit {unit!r}; expected one of {sorted(LENGTH_UNITS)}")
        f = LENGTH_UNITS[self.length_unit] / LENGTH_UNITS[unit]
        lim = self.limits.copy()
        lim[self.chain.prismatic] *= f
        lim.setflags(write=False)
        return RobotModel(self.name, self.source, unit, self.chain.scaled(f), lim, self.path, self.notes,
                          self.joint_names)


def _fail(path: str, where: str, msg: str) -> RobotFileError:
    return RobotFileError(f"{path}: {where}: {msg}")


def _number(value, path: str, where: str, angle: bool = False) -> float:
    if isinstance(value, bool):
        raise _fail(path, where, f"expected a number, got {value!r}")
    if isinstance(value, (int, float)):
        x = float(value)
    elif angle and isinstance(value, str) and _PI_EXPR.match(value):
        sign, mul, div = _PI_EXPR.match(value).groups()
        x = (-1.0 if sign == "-" else 1.0) * float(mul or 1) * math.pi / float(div or 1)
    else:
        kind = "a number or a pi expression" if angle else "a number"
        raise _fail(path, where, f"expected {kind}, got {value!r}")
    if not math.isfinite(x):
        raise _fail(path, where, f"must be finite, got {value!r}")
    return x


def _check_keys(d: dict, required, optional, path: str, where: str) -> None:
    if not isinstance(d, dict):
        raise _fail(path, where, f"expected a mapping, got {type(d).__name__}")
    for k in required:
        if k not in d:
            raise _fail(path, f"{where}field '{k}'" if where else f"field '{k}'", "missing")
    for k in d:
        if k not in required and k not in optional:
            raise _fail(path, f"{where}field '{k}'" if where else f"field '{k}'",
                        f"unknown field (allowed: {', '.join(list(required) + list(optional))})")


def _transform(value, path: str, field: str) -> np.ndarray:
    where = f"field '{field}'"
    if not (isinstance(value, list) and len(value) == 4 and all(isinstance(r, list) and len(r) == 4 for r in value)):
        raise _fail(path, where, "expected a 4x4 list of numbers")
    T = np.array([[_number(x, path, where) for x in row] for row in value])
    R = T[:3, :3]
    if not np.allclose(R @ R.T, np.eye(3), atol=RIGID_TOL) or np.linalg.det(R) < 0 or not np.allclose(T[3], [0, 0, 0, 1]):
        raise _fail(path, where, "not a rigid transform (rotation block must be orthonormal, last row 0 0 0 1)")
    return T


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF's rotation of ``rpy = [roll, pitch, yaw]``: ``Rz(yaw) Ry(pitch) Rx(roll)``, shape (3, 3)."""
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def rpy_from_matrix(R: np.ndarray) -> tuple[float, float, float]:
    """``(roll, pitch, yaw)`` with ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (URDF), pitch in [-pi/2, pi/2].

    Well conditioned at and near gimbal lock: pitch from ``atan2``, roll from the last row, yaw
    fitted to what remains (so an ill-determined roll is absorbed by yaw).
    """
    R = np.asarray(R, dtype=float)[:3, :3]
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    roll = math.atan2(R[2, 1], R[2, 2])  # (0 when both are 0: gimbal lock, yaw takes it all)
    M = R @ rpy_matrix(roll, pitch, 0.0).T  # = Rz(yaw)
    yaw = math.atan2(M[1, 0], M[0, 0])
    return roll + 0.0, pitch + 0.0, yaw + 0.0


def origin_matrix(xyz, rpy) -> np.ndarray:
    """URDF ``<origin xyz rpy>`` as a 4x4 transform ``Trans(xyz) Rz(yaw) Ry(pitch) Rx(roll)``."""
    T = np.eye(4)
    T[:3, :3] = rpy_matrix(*(float(v) for v in rpy))
    T[:3, 3] = [float(v) for v in xyz]
    return T


def _vector3(value, path: str, where: str, angle: bool = False) -> list[float]:
    if not (isinstance(value, list) and len(value) == 3):
        raise _fail(path, where, f"expected a list of 3 numbers, got {value!r}")
    return [_number(x, path, where, angle=angle) for x in value]


def _check_joint_keys(j, convention: str, path: str, where: str) -> None:
    """Like ``_check_keys``, naming a field of the other joint form as such."""
    general = convention == GENERAL
    required = GENERAL_REQUIRED if general else JOINT_REQUIRED
    if isinstance(j, dict):
        foreign = GENERAL_FIELDS if not general else DH_FIELDS
        for k in j:
            if k in foreign:
                kind = "a DH field" if general else "a general-form field"
                raise _fail(path, f"{where}field '{k}'", f"{kind}, not allowed with convention {convention} "
                            f"(allowed: {', '.join(list(required) + list(JOINT_OPTIONAL))})")
    _check_keys(j, required, JOINT_OPTIONAL, path, where)


def parse_robot(doc, path: str = "<robot>") -> RobotModel:
    """Validate a parsed robot document and build the model.

    Raises
    ------
    RobotFileError
        With one line naming the file, the joint and the field.
    """
    _check_keys(doc, TOP_REQUIRED, TOP_OPTIONAL, path, "")
    for key in ("name", "source", "length_unit", "convention"):
        if not isinstance(doc[key], str) or not doc[key].strip():
            raise _fail(path, f"field '{key}'", f"expected a non-empty string, got {doc[key]!r}")
    if doc["length_unit"] not in LENGTH_UNITS:
        raise _fail(path, "field 'length_unit'", f"unknown unit {doc['length_unit']!r} (allowed: {', '.join(LENGTH_UNITS)})")
    if doc["convention"] not in CONVENTIONS:
        raise _fail(path, "field 'convention'", f"unknown convention {doc['convention']!r} (allowed: {', '.join(CONVENTIONS)})")
    joints = doc["joints"]
    if not isinstance(joints, list) or not joints:
        raise _fail(path, "field 'joints'", "expected a non-empty list of joints")
    general = doc["convention"] == GENERAL
    cols = {k: [] for k in ("a", "alpha", "d", "theta_offset")}
    prismatic, limits, names, origins, axes = [], [], [], [], []
    for i, j in enumerate(joints, start=1):
        where = f"joint {i}: "
        _check_joint_keys(j, doc["convention"], path, where)
        if j["type"] not in JOINT_TYPES:
            raise _fail(path, f"joint {i}: field 'type'", f"unknown joint type {j['type']!r} (allowed: {', '.join(JOINT_TYPES)})")
        if general:
            xyz = _vector3(j["xyz"], path, f"joint {i}: field 'xyz'")
            rpy = _vector3(j["rpy"], path, f"joint {i}: field 'rpy'", angle=True)
            axis = np.array(_vector3(j["axis"], path, f"joint {i}: field 'axis'"))
            norm = float(np.linalg.norm(axis))
            if not norm > 1e-12:
                raise _fail(path, f"joint {i}: field 'axis'", f"must be a non-zero 3-vector, got {j['axis']!r}")
            origins.append(origin_matrix(xyz, rpy))
            axes.append(axis / norm)
        else:
            for k in cols:
                cols[k].append(_number(j[k], path, f"joint {i}: field '{k}'", angle=k in ("alpha", "theta_offset")))
        prismatic.append(j["type"] == "prismatic")
        name = j.get("name", "")
        if isinstance(name, (dict, list)):
            raise _fail(path, f"joint {i}: field 'name'", f"expected a string, got {name!r}")
        names.append("" if name is None else str(name))
        lim = j.get("limits")
        if lim is None:
            limits.append((-math.inf, math.inf))
        else:
            w = f"joint {i}: field 'limits'"
            if not isinstance(lim, list) or len(lim) != 2:
                raise _fail(path, w, f"expected [lower, upper], got {lim!r}")
            lo = _number(lim[0], path, w, angle=True)
            hi = _number(lim[1], path, w, angle=True)
            if lo > hi:
                raise _fail(path, w, f"lower limit {lo:g} is above upper limit {hi:g}")
            limits.append((lo, hi))
    base = _transform(doc["base"], path, "base") if "base" in doc else np.eye(4)
    tool = _transform(doc["tool"], path, "tool") if "tool" in doc else np.eye(4)
    if general:
        zeros = np.zeros(len(joints))
        chain = Chain(zeros, zeros, zeros, zeros, np.array(prismatic), GENERAL, base, tool,
                      np.array(origins), np.array(axes))
    else:
        chain = Chain(np.array(cols["a"]), np.array(cols["alpha"]), np.array(cols["d"]),
                      np.array(cols["theta_offset"]), np.array(prismatic), doc["convention"], base, tool)
    lim = np.array(limits, dtype=float)
    lim.setflags(write=False)
    return RobotModel(doc["name"], doc["source"], doc["length_unit"], chain, lim, path, str(doc.get("notes", "")),
                      tuple(names))


def load_robot(path: str | Path) -> RobotModel:
    """Read and validate ``data/robots/<name>.yaml``.

    Raises
    ------
    RobotFileError
        Missing file, YAML syntax error, or any invalid field (one line, file + joint + field).
    """
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise RobotFileError(f"{path}: cannot read robot file ({exc.strerror})") from None
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark else "YAML"
        raise RobotFileError(f"{path}: {where}: not valid YAML ({getattr(exc, 'problem', exc)})") from None
    model = parse_robot(doc, str(path))
    if model.name != path.stem:
        raise _fail(str(path), "field 'name'", f"{model.name!r} must equal the file name {path.stem!r}")
    return model


def describe_general(model: RobotModel, q0=None) -> str:
    """A plain-text report of a general-form robot: origins (xyz, rpy), axes, limits, base/tool and
    the zero-position vectors at ``q0`` (default all zero). For the ``robot`` verb, whose DH report
    cannot describe a general-form chain.
    """
    from pipeline.kinematics.zero_position import pz_from_dh

    chain = model.chain
    if not chain.general:
        raise ValueError(f"{model.name}: describe_general takes a general-form robot, not {chain.convention} DH")
    q0 = np.zeros(model.n) if q0 is None else np.asarray(q0, dtype=float)
    u = model.length_unit
    names = model.joint_names if len(model.joint_names) == model.n else ("",) * model.n
    rnd = lambda v: np.round(np.asarray(v, float), 6) + 0.0  # noqa: E731  no "-0.0000" in print
    out = [f"ROBOT: {model.name}  ({model.n} joints, general joint form, lengths in {u}, angles in deg)",
           f"source: {model.source}", "",
           f"joint\tname\ttype\txyz [{u}]\t\t\trpy [deg]\t\t\taxis\t\t\tlimits"]
    for i in range(model.n):
        T = chain.origins[i]
        rpy = np.degrees(rpy_from_matrix(T))
        lo, hi = model.limits[i]
        conv = (lambda v: v) if chain.prismatic[i] else np.degrees
        lim = f"[{conv(lo):.3f}, {conv(hi):.3f}]" if np.isfinite(lo) and np.isfinite(hi) else "-"
        out.append(f"{i + 1}\t{names[i] or '-'}\t{'p' if chain.prismatic[i] else 'r'}\t"
                   + "\t".join(f"{v:.4f}" for v in rnd(T[:3, 3])) + "\t"
                   + "\t".join(f"{v:.4f}" for v in rnd(rpy)) + "\t"
                   + "\t".join(f"{v:.4f}" for v in rnd(chain.axes[i])) + f"\t{lim}")
    for label, T in (("base", chain.base), ("tool", chain.tool)):
        out += ["", f"{label} (4x4)"] + ["\t" + "\t".join(f"{v:.6f}" for v in row) for row in rnd(T)]
    pz = pz_from_dh(chain, q0)
    out += ["", "ZERO-POSITION VECTORS at q0 = [" + ", ".join(f"{v:g}" for v in q0) + "] (rad | " + u + ")",
            "i\tb[i]\t\t\tu[i]"]
    for i in range(model.n + 1):
        row = f"{i + 1}\t" + "\t".join(f"{v:.4f}" for v in rnd(pz.b[i]))
        if i < model.n:
            row += "\t" + "\t".join(f"{v:.4f}" for v in rnd(pz.u[i]))
        out.append(row)
    out += ["ua\t" + "\t".join(f"{v:.4f}" for v in rnd(pz.u_a)), "ut\t" + "\t".join(f"{v:.4f}" for v in rnd(pz.u_t))]
    return "\n".join(out) + "\n"
