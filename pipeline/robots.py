"""Robot files (``data/robots/<name>.yaml``): loading and validation into an immutable model.

A robot file::

    name: kuka_lwr                      # must equal the file stem
    source: "000_7e3cb7ad5ee98ff0.txt, Table 2"
    length_unit: cm                     # m | cm | mm
    convention: standard                # standard | modified DH (see pipeline.kinematics)
    joints:                             # one entry per joint, base to tip
      - {type: revolute, a: 0, alpha: -pi/2, d: 31, theta_offset: 0, limits: [-2.9, 2.9]}
    base: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]   # optional, T_world_base
    tool: [[...]]                                     # optional, T_flange_tool
    notes: free text                                  # optional

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

from pipeline.kinematics.chain import CONVENTIONS, Chain

LENGTH_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
JOINT_TYPES = ("revolute", "prismatic")
TOP_REQUIRED = ("name", "source", "length_unit", "convention", "joints")
TOP_OPTIONAL = ("base", "tool", "notes", "limits_source")
JOINT_REQUIRED = ("type", "a", "alpha", "d", "theta_offset")
JOINT_OPTIONAL = ("limits", "name")
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
    """

    name: str
    source: str
    length_unit: str
    chain: Chain
    limits: np.ndarray
    path: str = ""
    notes: str = ""

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
        return RobotModel(self.name, self.source, unit, self.chain.scaled(f), lim, self.path, self.notes)


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
    cols = {k: [] for k in ("a", "alpha", "d", "theta_offset")}
    prismatic, limits = [], []
    for i, j in enumerate(joints, start=1):
        where = f"joint {i}: "
        _check_keys(j, JOINT_REQUIRED, JOINT_OPTIONAL, path, where)
        if j["type"] not in JOINT_TYPES:
            raise _fail(path, f"joint {i}: field 'type'", f"unknown joint type {j['type']!r} (allowed: {', '.join(JOINT_TYPES)})")
        for k in cols:
            cols[k].append(_number(j[k], path, f"joint {i}: field '{k}'", angle=k in ("alpha", "theta_offset")))
        prismatic.append(j["type"] == "prismatic")
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
    chain = Chain(np.array(cols["a"]), np.array(cols["alpha"]), np.array(cols["d"]),
                  np.array(cols["theta_offset"]), np.array(prismatic), doc["convention"], base, tool)
    lim = np.array(limits, dtype=float)
    lim.setflags(write=False)
    return RobotModel(doc["name"], doc["source"], doc["length_unit"], chain, lim, path, str(doc.get("notes", "")))


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
