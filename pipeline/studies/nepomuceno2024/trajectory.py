"""Designed pick-and-place motions (``data/nepomuceno2024/motions.yaml``) and their interpolation.

004_957b32c2b06ea31d.txt gives no target poses, waypoints, point counts or timing law (notes §5.6).
The motions are therefore designed here and kept as data; the interpolation follows the document's
base repository (``controller.move_to`` of pietrolechthaler/UR5-Pick-and-Place-Simulation, notes
§5.7): straight-line Cartesian interpolation with cosine time scaling ``s' = (1 - cos(π s)) / 2``,
an optional lift ``z_raise (1 - cos(2π s)) / 2``, orientation by quaternion slerp with ``s'``, and
``N = int(points_per_metre · |Δp| + min_points)`` points per segment (300 and 80 in that repository).

A motion file::

    poses:                               # TCP poses in the robot base frame
      home: {position: [x, y, z], yaw_deg: 0}     # R = Rz(yaw) · Ry(π): tool z pointing down
    motions:
      home:
        test: 1                          # Tabela 5.1 column
        start_joints: [6 angles, rad]    # the robot's joint state when the motion starts
        segments:
          - {name: return_home, to: home}
          - {name: grasp, event: close_gripper}         # gripper action: no motion, no IK point
          - {name: transfer, to: above_box, z_raise: 0.1}
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pipeline.kinematics import matrix_from_quat, quat_from_matrix
from pipeline.settings import read_yaml


class MotionFileError(ValueError):
    """A motion file is unreadable or invalid (one line naming the file and field)."""


@dataclass(frozen=True)
class MotionPoints:
    """The interpolated IK goals of one motion.

    Attributes
    ----------
    name : str
    test : int                                   Tabela 5.1 column (1 home, 2 pick-and-place)
    q_start : ndarray, shape (6,) [rad]          joint state before the first point
    T : ndarray, shape (N, 4, 4) [m]             goal poses, in order
    segment : ndarray of str, shape (N,)         segment name of each point
    waypoints : dict[str, ndarray (4, 4)]        the named poses the motion passes through
    """

    name: str
    test: int
    q_start: np.ndarray
    T: np.ndarray
    segment: np.ndarray
    waypoints: dict

    def __len__(self) -> int:
        return int(self.T.shape[0])


def rot_y(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def pose_from_spec(spec: dict) -> np.ndarray:
    """``{position: [x, y, z] m, yaw_deg}`` -> T (4, 4) with R = Rz(yaw) Ry(π) (tool pointing down)."""
    T = np.eye(4)
    # element-wise product and sum, not ``@``: BLAS kernels differ in their last digits between CPUs
    A, B = rot_z(math.radians(float(spec.get("yaw_deg", 0.0)))), rot_y(math.pi)
    T[:3, :3] = (A[:, :, None] * B[None, :, :]).sum(axis=1)
    T[:3, 3] = np.asarray(spec["position"], dtype=float)
    return T


def slerp(q0: np.ndarray, q1: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Shortest-arc spherical interpolation of w-first unit quaternions; ``s`` (N,) -> (N, 4)."""
    q0 = np.asarray(q0, float)
    q1 = np.asarray(q1, float)
    dot = float((q0 * q1).sum())  # not np.dot (BLAS): the same digits on every machine
    if dot < 0.0:
        q1, dot = -q1, -dot
    s = np.asarray(s, float)[:, None]
    if dot > 1.0 - 1e-12:
        out = q0 + s * (q1 - q0)
    else:
        om = math.acos(min(dot, 1.0))
        out = (np.sin((1.0 - s) * om) * q0 + np.sin(s * om) * q1) / math.sin(om)
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def segment_count(dist: float, points_per_metre: float, min_points: int) -> int:
    """Number of interpolated points of one segment: ``int(points_per_metre · dist + min_points)``."""
    return int(points_per_metre * dist + min_points)


def interpolate(T0: np.ndarray, T1: np.ndarray, n: int, z_raise: float = 0.0) -> np.ndarray:
    """``n`` poses from (excluded) ``T0`` to (included) ``T1``: cosine-scaled line, lift, slerp.

    Returns
    -------
    T : ndarray, shape (n, 4, 4)
    """
    s = np.arange(1, n + 1) / n
    sc = 0.5 * (1.0 - np.cos(np.pi * s))
    p = T0[:3, 3] + sc[:, None] * (T1[:3, 3] - T0[:3, 3])
    p[:, 2] += z_raise * 0.5 * (1.0 - np.cos(2.0 * np.pi * s))
    q = slerp(quat_from_matrix(T0[:3, :3]), quat_from_matrix(T1[:3, :3]), sc)
    T = np.zeros((n, 4, 4))
    T[:, :3, :3] = matrix_from_quat(q)
    T[:, :3, 3] = p
    T[:, 3, 3] = 1.0
    return T


def load_motions(path: str | Path) -> dict:
    """Read and check a motion file; returns the parsed document."""
    path = Path(path)
    doc = read_yaml(path, MotionFileError, "motion file")
    if not isinstance(doc, dict) or "poses" not in doc or "motions" not in doc:
        raise MotionFileError(f"{path}: field 'poses'/'motions': both are required")
    for name, spec in doc["poses"].items():
        pos = spec.get("position") if isinstance(spec, dict) else None
        if not (isinstance(pos, list) and len(pos) == 3 and all(isinstance(v, (int, float)) for v in pos)):
            raise MotionFileError(f"{path}: field 'poses/{name}/position': expected [x, y, z] in metres")
    for mname, m in doc["motions"].items():
        qs = m.get("start_joints")
        if not (isinstance(qs, list) and len(qs) == 6):
            raise MotionFileError(f"{path}: field 'motions/{mname}/start_joints': expected 6 joint angles [rad]")
        for i, seg in enumerate(m.get("segments", [])):
            if "to" in seg and seg["to"] not in doc["poses"]:
                raise MotionFileError(f"{path}: field 'motions/{mname}/segments/{i}/to': unknown pose {seg['to']!r}")
            if "to" not in seg and "event" not in seg:
                raise MotionFileError(f"{path}: field 'motions/{mname}/segments/{i}': needs 'to' or 'event'")
    return doc


def build_motion(doc: dict, name: str, fk, points_per_metre: float, min_points: int) -> MotionPoints:
    """Interpolate motion ``name`` of a parsed motion file.

    Parameters
    ----------
    fk : callable, q (6,) -> T (4, 4)
        Forward kinematics of the robot (gives the start pose from ``start_joints``).
    points_per_metre, min_points
        Point count per segment (see :func:`segment_count`).
    """
    if name not in doc["motions"]:
        raise MotionFileError(f"motion {name!r} not in the motion file (have: {', '.join(doc['motions'])})")
    m = doc["motions"][name]
    q0 = np.asarray(m["start_joints"], dtype=float)
    T_cur = fk(q0)
    Ts, segs = [], []
    waypoints = {"start": T_cur}
    for seg in m["segments"]:
        if "to" not in seg:
            continue  # gripper event: no motion, no IK point
        T_to = pose_from_spec(doc["poses"][seg["to"]])
        n = segment_count(float(np.linalg.norm(T_to[:3, 3] - T_cur[:3, 3])), points_per_metre, min_points)
        Ts.append(interpolate(T_cur, T_to, n, float(seg.get("z_raise", 0.0))))
        segs += [seg["name"]] * n
        waypoints[seg["to"]] = T_to
        T_cur = T_to
    return MotionPoints(name, int(m.get("test", 0)), q0, np.concatenate(Ts), np.array(segs), waypoints)
