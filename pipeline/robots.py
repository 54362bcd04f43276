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

Sane maxima (a file beyond them is refused before anything is computed; the reasons are beside
each constant): :data:`MAX_JOINTS` joints, lengths up to :data:`MAX_LENGTH_M` metres, angles up to
:data:`MAX_ANGLE` rad. A ``base``/``tool`` rotation block orthonormal to :data:`RIGID_TOL` is used
as written; one orthonormal only to :data:`REPAIR_TOL` (e.g. 0.7071 typed to four decimals) is
replaced by the nearest rotation, and the model's ``repairs`` say so (the archives' ``run``
metadata records them); anything further from a rotation is refused.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pipeline.kinematics.chain import CONVENTIONS, GENERAL, Chain
from pipeline.yamlio import YAMLInputError, load_yaml

LENGTH_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
JOINT_TYPES = ("revolute", "prismatic")
TOP_REQUIRED = ("name", "source", "length_unit", "convention", "joints")
TOP_OPTIONAL = ("base", "tool", "notes", "limits_source")
JOINT_REQUIRED = ("type", "a", "alpha", "d", "theta_offset")
JOINT_OPTIONAL = ("limits", "name")
GENERAL_REQUIRED = ("type", "xyz", "rpy", "axis")
DH_FIELDS = ("a", "alpha", "d", "theta_offset")
GENERAL_FIELDS = ("xyz", "rpy", "axis")
RIGID_TOL = 1e-6  # a base/tool rotation block orthonormal to this is used as written
REPAIR_TOL = 1e-4  # ... orthonormal only to this (four typed decimals: 0.7071) is re-orthonormalised, with a note
MAX_JOINTS = 64  # real arms have 2-7 joints (the catalogue's largest: 7); 64 leaves room for hyper-redundant
#                  chains while every per-joint array of a job stays tiny (a 20 000-joint file is refused at once)
MAX_LENGTH_M = 1000.0  # |a|, |d|, xyz, base/tool translations and prismatic limits, in metres: the largest arm
#                        here reaches 1.6 m; a kilometre bounds any manipulator and keeps squares of lengths far
#                        from overflow (1e300 would make every solve non-finite)
MAX_ANGLE = 1000.0  # |angle| [rad] of alpha, theta_offset, rpy and revolute limits: ~159 turns, far beyond any
#                     multi-turn joint, and small enough that sin/cos keep their precision

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
    repairs: tuple = ()  # one line per value changed on load (a near-orthonormal rotation re-orthonormalised)

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
                          self.joint_names, self.repairs)


def _fail(path: str, where: str, msg: str) -> RobotFileError:
    return RobotFileError(f"{path}: {where}: {msg}")


def _short(value) -> str:
    """``repr`` of a value for a message, cut to 60 characters (a message stays one short line)."""
    r = repr(value)
    return r if len(r) <= 60 else r[:57] + "..."


def robot_number(value, path: str, where: str, angle: bool = False, bound: float | None = None) -> float:
    """A finite number (or, with ``angle``, a ``pi`` expression) with ``|x| <= bound``; else one line."""
    if isinstance(value, bool):
        raise _fail(path, where, f"expected a number, got {value!r}")
    if isinstance(value, (int, float)):
        try:
            x = float(value)
        except OverflowError:  # an integer beyond the float range
            raise _fail(path, where, f"must be finite, got {_short(value)}") from None
    elif angle and isinstance(value, str) and _PI_EXPR.match(value):
        sign, mul, div = _PI_EXPR.match(value).groups()
        if div is not None and float(div) == 0.0:
            raise _fail(path, where, f"division by zero in {value!r}")
        x = (-1.0 if sign == "-" else 1.0) * float(mul or 1) * math.pi / float(div or 1)
    else:
        kind = "a number or a pi expression" if angle else "a number"
        raise _fail(path, where, f"expected {kind}, got {_short(value)}")
    if not math.isfinite(x):
        raise _fail(path, where, f"must be finite, got {_short(value)}")
    if bound is not None and abs(x) > bound:
        raise _fail(path, where, f"{x:g} is beyond the sane maximum {bound:g} in absolute value")
    return x


def _length(value, path: str, where: str, unit: str) -> float:
    return robot_number(value, path, where, bound=MAX_LENGTH_M / LENGTH_UNITS[unit])


def _angle(value, path: str, where: str) -> float:
    return robot_number(value, path, where, angle=True, bound=MAX_ANGLE)


def _check_keys(d: dict, required, optional, path: str, where: str) -> None:
    if not isinstance(d, dict):
        what = "an empty file" if d is None and not where else type(d).__name__
        raise _fail(path, where.rstrip(": ") or "top level", f"expected a mapping, got {what}")
    for k in required:
        if k not in d:
            raise _fail(path, f"{where}field '{k}'" if where else f"field '{k}'", "missing")
    for k in d:
        if k not in required and k not in optional:
            raise _fail(path, f"{where}field '{_short(k)[1:-1] if isinstance(k, str) else k}'",
                        f"unknown field (allowed: {', '.join(list(required) + list(optional))})")


def orthonormality_error(R) -> float:
    """``max |R Rᵀ - I|`` of a 3x3 matrix (plain float arithmetic: the same on every machine).

    Parameters
    ----------
    R : array_like, shape (3, 3) [1]
        Nested lists or an array; only the first 3 rows and columns are read.

    Returns
    -------
    float
    """
    R = [[float(x) for x in row[:3]] for row in list(R)[:3]]
    return max(abs(sum(R[i][k] * R[j][k] for k in range(3)) - (1.0 if i == j else 0.0))
               for i in range(3) for j in range(3))


def _det3(R) -> float:
    return (R[0][0] * (R[1][1] * R[2][2] - R[1][2] * R[2][1]) - R[0][1] * (R[1][0] * R[2][2] - R[1][2] * R[2][0])
            + R[0][2] * (R[1][0] * R[2][1] - R[1][1] * R[2][0]))


def nearest_rotation(R) -> list[list[float]]:
    """The rotation nearest a near-orthonormal 3x3 matrix (its polar factor), as nested lists.

    Björck-Bowie iteration ``R <- R (3 I - Rᵀ R) / 2`` in plain float arithmetic (no BLAS or LAPACK,
    so the result is bit-identical on every machine); converges quadratically for ``|R Rᵀ - I| < 1``.

    Parameters
    ----------
    R : array_like, shape (3, 3) [1]
        Nested lists or an array; only the first 3 rows and columns are read.

    Returns
    -------
    list of list of float, shape (3, 3)
    """
    R = [[float(x) for x in row[:3]] for row in list(R)[:3]]
    for _ in range(60):
        RtR = [[sum(R[k][i] * R[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
        M = [[(3.0 if i == j else 0.0) - RtR[i][j] for j in range(3)] for i in range(3)]
        nxt = [[0.5 * sum(R[i][k] * M[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
        if nxt == R:
            break
        R = nxt
    return R


def _transform(value, path: str, field: str, unit: str, repairs: list) -> np.ndarray:
    where = f"field '{field}'"
    if not (isinstance(value, list) and len(value) == 4 and all(isinstance(r, list) and len(r) == 4 for r in value)):
        raise _fail(path, where, "expected a 4x4 list of numbers")
    T = np.array([[robot_number(x, path, where) for x in row] for row in value])
    if T[3].tolist() != [0.0, 0.0, 0.0, 1.0]:
        raise _fail(path, where, f"not a rigid transform: the last row must be 0 0 0 1, got {T[3].tolist()}")
    for x in T[:3, 3]:
        _length(float(x), path, f"{where} (translation)", unit)
    R = T[:3, :3].tolist()
    err, det = orthonormality_error(R), _det3(R)
    if det <= 0 or err > REPAIR_TOL:
        what = "a reflection (determinant < 0)" if det <= 0 and err <= REPAIR_TOL else \
            f"R Rᵀ differs from the identity by {err:.2g}, more than {REPAIR_TOL:g}"
        raise _fail(path, where, f"not a rigid transform: the rotation block is not a rotation ({what})")
    if err > RIGID_TOL:
        T[:3, :3] = nearest_rotation(R)
        repairs.append(f"{path}: field '{field}': rotation block orthonormal only to {err:.2g}; replaced by the "
                       f"nearest rotation")
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

    Parameters
    ----------
    R : ndarray, shape (3, 3) or (4, 4) [1]
        A rotation matrix, or a homogeneous transform whose rotation block is used.

    Returns
    -------
    roll, pitch, yaw : float
        Angles [rad].
    """
    R = np.asarray(R, dtype=float)[:3, :3]
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    roll = math.atan2(R[2, 1], R[2, 2])  # (0 when both are 0: gimbal lock, yaw takes it all)
    M = R @ rpy_matrix(roll, pitch, 0.0).T  # = Rz(yaw)
    yaw = math.atan2(M[1, 0], M[0, 0])
    return roll + 0.0, pitch + 0.0, yaw + 0.0


def origin_matrix(xyz, rpy) -> np.ndarray:
    """URDF ``<origin xyz rpy>`` as a 4x4 transform ``Trans(xyz) Rz(yaw) Ry(pitch) Rx(roll)``.

    Parameters
    ----------
    xyz : array_like, shape (3,) [length]
        Translation.
    rpy : array_like, shape (3,) [rad]
        Roll, pitch, yaw.

    Returns
    -------
    T : ndarray, shape (4, 4)
    """
    T = np.eye(4)
    T[:3, :3] = rpy_matrix(*(float(v) for v in rpy))
    T[:3, 3] = [float(v) for v in xyz]
    return T


def _vector3(value, path: str, where: str, angle: bool = False, bound: float | None = None) -> list[float]:
    if not (isinstance(value, list) and len(value) == 3):
        raise _fail(path, where, f"expected a list of 3 numbers, got {_short(value)}")
    return [robot_number(x, path, where, angle=angle, bound=bound) for x in value]


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


def _length_unit(doc: dict, path: str) -> str:
    if doc["length_unit"] not in LENGTH_UNITS:
        raise _fail(path, "field 'length_unit'", f"unknown unit {doc['length_unit']!r} (allowed: {', '.join(LENGTH_UNITS)})")
    return doc["length_unit"]


def _joint_list(doc: dict, path: str) -> list:
    """The ``joints`` list: non-empty, at most :data:`MAX_JOINTS` entries (one line otherwise)."""
    joints = doc["joints"]
    if not isinstance(joints, list) or not joints:
        raise _fail(path, "field 'joints'", "expected a non-empty list of joints")
    if len(joints) > MAX_JOINTS:
        raise _fail(path, "field 'joints'", f"{len(joints)} joints, beyond the sane maximum of {MAX_JOINTS}")
    return joints


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
            raise _fail(path, f"field '{key}'", f"expected a non-empty string, got {_short(doc[key])}")
    unit = _length_unit(doc, path)
    if doc["convention"] not in CONVENTIONS:
        raise _fail(path, "field 'convention'", f"unknown convention {doc['convention']!r} (allowed: {', '.join(CONVENTIONS)})")
    joints = _joint_list(doc, path)
    general = doc["convention"] == GENERAL
    cols = {k: [] for k in ("a", "alpha", "d", "theta_offset")}
    prismatic, limits, names, origins, axes = [], [], [], [], []
    for i, j in enumerate(joints, start=1):
        where = f"joint {i}: "
        _check_joint_keys(j, doc["convention"], path, where)
        if j["type"] not in JOINT_TYPES:
            raise _fail(path, f"joint {i}: field 'type'", f"unknown joint type {_short(j['type'])} (allowed: {', '.join(JOINT_TYPES)})")
        if general:
            xyz = _vector3(j["xyz"], path, f"joint {i}: field 'xyz'", bound=MAX_LENGTH_M / LENGTH_UNITS[unit])
            rpy = _vector3(j["rpy"], path, f"joint {i}: field 'rpy'", angle=True, bound=MAX_ANGLE)
            axis = _vector3(j["axis"], path, f"joint {i}: field 'axis'", bound=1e6)
            norm = math.sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2])  # no BLAS: same everywhere
            if not norm > 1e-12:
                raise _fail(path, f"joint {i}: field 'axis'", f"must be a non-zero 3-vector, got {j['axis']!r}")
            origins.append(origin_matrix(xyz, rpy))
            axes.append(np.array([v / norm for v in axis]))
        else:
            for k in cols:
                w = f"joint {i}: field '{k}'"
                cols[k].append(_angle(j[k], path, w) if k in ("alpha", "theta_offset") else _length(j[k], path, w, unit))
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
                raise _fail(path, w, f"expected [lower, upper], got {_short(lim)}")
            bound = MAX_LENGTH_M / LENGTH_UNITS[unit] if j["type"] == "prismatic" else MAX_ANGLE
            lo = robot_number(lim[0], path, w, angle=True, bound=bound)
            hi = robot_number(lim[1], path, w, angle=True, bound=bound)
            if lo > hi:
                raise _fail(path, w, f"lower limit {lo:g} is above upper limit {hi:g}")
            limits.append((lo, hi))
    repairs: list[str] = []
    base = _transform(doc["base"], path, "base", unit, repairs) if "base" in doc else np.eye(4)
    tool = _transform(doc["tool"], path, "tool", unit, repairs) if "tool" in doc else np.eye(4)
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
                      tuple(names), tuple(repairs))


ROBOT_FILES = Path(__file__).resolve().parent / "robot_files"
"""The robot files shipped with the package (``data/robots`` of the checkout; a wheel holds a copy)."""


JOINT_POINT_TOP = ("name", "length_unit", "joints", "effector")  # a joint-point input (erthal1992 Case 1)
JOINT_POINT_OPTIONAL = ("source", "notes")
JOINT_POINT_JOINT = ("type", "position", "axis")
JOINT_POINT_EFFECTOR = ("position", "u_a", "u_t")
JOINT_POINT_TYPES = ("r", "p")


def check_joint_points(doc, path: str) -> dict:
    """Validate a joint-point input (``data/erthal1992/*_input.yaml``: each joint's type ``r``/``p``, a point
    ``position`` of its axis and the ``axis``, the effector's ``position``, approach ``u_a`` and orientation
    ``u_t``, lengths in ``length_unit``) as strictly as a robot file: known fields only, at most
    :data:`MAX_JOINTS` joints, finite numbers within :data:`MAX_LENGTH_M`, non-zero direction vectors.

    Returns
    -------
    doc : dict (the same document)

    Raises
    ------
    RobotFileError
        One line naming the file, the joint or ``effector`` and the field.
    """
    _check_keys(doc, JOINT_POINT_TOP, JOINT_POINT_OPTIONAL, path, "")
    for key in ("name", "length_unit") + tuple(k for k in JOINT_POINT_OPTIONAL if k in doc):
        if not isinstance(doc[key], str) or not doc[key].strip():
            raise _fail(path, f"field '{key}'", f"expected a non-empty string, got {_short(doc[key])}")
    unit, joints = _length_unit(doc, path), _joint_list(doc, path)
    bound = MAX_LENGTH_M / LENGTH_UNITS[unit]

    def direction(value, where):
        v = _vector3(value, path, where, bound=1e6)
        if not math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) > 1e-12:
            raise _fail(path, where, f"must be a non-zero 3-vector, got {_short(value)}")

    for i, j in enumerate(joints, start=1):
        _check_keys(j, JOINT_POINT_JOINT, (), path, f"joint {i}: ")
        if j["type"] not in JOINT_POINT_TYPES:
            raise _fail(path, f"joint {i}: field 'type'", f"{_short(j['type'])} is not one of r, p")
        _vector3(j["position"], path, f"joint {i}: field 'position'", bound=bound)
        direction(j["axis"], f"joint {i}: field 'axis'")
    e = doc["effector"]
    _check_keys(e, JOINT_POINT_EFFECTOR, (), path, "effector: ")
    _vector3(e["position"], path, "effector: field 'position'", bound=bound)
    for key in ("u_a", "u_t"):
        direction(e[key], f"effector: field '{key}'")
    return doc


def shipped_robots() -> list[str]:
    """Names of the robot files shipped with the package (``load_robot(name)`` loads one)."""
    return sorted(p.stem for p in ROBOT_FILES.glob("*.yaml"))


def load_robot(path: str | Path) -> RobotModel:
    """Read and validate a robot file: a path, or the bare name of a shipped one (``"ur5e"``, ``"franka_panda"``:
    :func:`shipped_robots`; data/robots/CATALOGUE.md describes them).

    Raises
    ------
    RobotFileError
        Missing file, YAML syntax error, or any invalid field (one line, file + joint + field).
    """
    if isinstance(path, str) and path and "/" not in path and "." not in path and not Path(path).exists():
        shipped = ROBOT_FILES / f"{path}.yaml"
        if not shipped.is_file():
            raise RobotFileError(f"{path}: no such robot file, and not the name of a shipped robot "
                                 f"({', '.join(shipped_robots())})")
        path = shipped
    path = Path(path)
    try:
        doc = load_yaml(path, "robot file")
    except YAMLInputError as exc:
        raise RobotFileError(str(exc)) from None
    model = parse_robot(doc, str(path))
    if model.name != path.stem:
        raise _fail(str(path), "field 'name'", f"{model.name!r} must equal the file name {path.stem!r}")
    return model


def describe_general(model: RobotModel, q0=None) -> str:
    """A plain-text report of a general-form robot.

    Origins (xyz, rpy), axes, limits, base/tool and the zero-position vectors at ``q0``. For the
    ``robot`` verb, whose DH report cannot describe a general-form chain.

    Parameters
    ----------
    model : RobotModel
        A general-form robot.
    q0 : array_like, shape (n,) [rad | length], optional
        Where to take the zero-position vectors (default all zero).

    Returns
    -------
    str

    Raises
    ------
    ValueError
        For a DH robot.
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
