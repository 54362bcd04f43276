"""Path tasks (block TAREFA, §5.2.3; files .AMB and .RES of Appendix 3 of 001_7601717b50b5e768.txt).

A task file (``data/erthal1992/<task>.yaml``) gives the robot, the robot / auxiliary / tool frames
(origin + Y axis + Z axis, X = Y x Z, as the program's keyboard input), the number of segments,
points per segment, and the segment start frames plus the end of the last one (w.r.t. the
auxiliary frame). A segment is interpolated in Cartesian space (straight line, equal division of
the distance and of the single equivalent rotation) or in joint space (equal division of each
joint's travel between the endpoint IK solutions). Points per segment include both endpoints
(step 1/(k-1)), as SCARA1.RES shows (q4: 510 -> 310 in steps of 22.2222).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pipeline.robots import robot_number
from pipeline.settings import read_yaml


class TaskFileError(ValueError):
    """Invalid task file (one line naming the file and field)."""


def frame(y, z, position) -> np.ndarray:
    """4x4 frame from its Y and Z axes and origin (``monta_matriz_homo()``; X = Y x Z)."""
    y = np.asarray(y, float) / np.linalg.norm(y)
    z = np.asarray(z, float) / np.linalg.norm(z)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = np.cross(y, z), y, z, position
    return T


@dataclass(frozen=True)
class Task:
    name: str
    robot: str
    T_robot: np.ndarray      # (4, 4) robot base w.r.t. inertial
    T_aux: np.ndarray        # (4, 4) auxiliary frame w.r.t. inertial
    T_tool: np.ndarray       # (4, 4) effector w.r.t. the robot tip
    points: np.ndarray       # (segments + 1, 4, 4) w.r.t. the auxiliary frame
    points_per_segment: int
    q_start: np.ndarray      # (n,)

    @property
    def segments(self) -> int:
        return len(self.points) - 1

    def goal_in_base(self, T_aux_point: np.ndarray) -> np.ndarray:
        """Flange goal in the robot base frame: T_robot^-1 T_aux T_point T_tool^-1."""
        return np.linalg.inv(self.T_robot) @ self.T_aux @ T_aux_point @ np.linalg.inv(self.T_tool)


def _frame_field(doc, path, key) -> np.ndarray:
    f = doc.get(key) if isinstance(doc, dict) else None
    if not isinstance(f, dict) or any(k not in f for k in ("y", "z", "position")):
        raise TaskFileError(f"{path}: field '{key}': expected {{y, z, position}}")
    try:
        y, z, p = (np.array(f[k], dtype=float).reshape(3) for k in ("y", "z", "position"))
    except (TypeError, ValueError):
        raise TaskFileError(f"{path}: field '{key}': y, z, position must be 3 numbers each") from None
    if abs(y @ z) > 1e-9 * np.linalg.norm(y) * np.linalg.norm(z) or np.linalg.norm(y) == 0 or np.linalg.norm(z) == 0:
        raise TaskFileError(f"{path}: field '{key}': Y and Z axes must be non-zero and perpendicular")
    return frame(y, z, p)


def load_task(path: str | Path, overrides: dict | None = None) -> Task:
    """Read a task file; ``overrides`` may replace fields (e.g. the auxiliary frame of Test 5)."""
    path = Path(path)
    doc = read_yaml(path, TaskFileError, "task file")
    if not isinstance(doc, dict):
        raise TaskFileError(f"{path}: expected a mapping")
    doc = {**doc, **(overrides or {})}
    for k in ("name", "robot", "frames", "segments", "points_per_segment", "points", "initial_position"):
        if k not in doc:
            raise TaskFileError(f"{path}: field '{k}': missing")
    fr = doc["frames"]
    T_robot, T_aux, T_tool = (_frame_field({f"frames/{k}": fr[k]}, path, f"frames/{k}") if k in fr else np.eye(4)
                              for k in ("robot", "auxiliary", "tool"))
    pts = doc["points"]
    if not isinstance(pts, list) or len(pts) != int(doc["segments"]) + 1:
        raise TaskFileError(f"{path}: field 'points': expected segments + 1 = {int(doc['segments']) + 1} frames")
    P = np.array([_frame_field({f"points/{i}": p}, path, f"points/{i}") for i, p in enumerate(pts)])
    k = int(doc["points_per_segment"])
    if k < 2:
        raise TaskFileError(f"{path}: field 'points_per_segment': at least 2 (both endpoints)")
    q = np.array([robot_number(v, str(path), "field 'initial_position'", angle=True) for v in doc["initial_position"]])
    return Task(str(doc["name"]), str(doc["robot"]), T_robot, T_aux, T_tool, P, k, q)


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """angle * axis of a rotation matrix (the single equivalent rotation), angle in [0, pi]."""
    c = np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)
    ang = math.acos(c)
    if ang < 1e-12:
        return np.zeros(3)
    if ang > math.pi - 1e-6:
        # axis from the symmetric part (R = 2 u u^T - I at pi)
        k = int(np.argmax(np.diag(R)))
        u = (R[:, k] + np.eye(3)[k]) / math.sqrt(2 * (1 + R[k, k]))
        return ang * u / np.linalg.norm(u)
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / (2 * math.sin(ang))
    return ang * v


def rotation_from_vector(w: np.ndarray) -> np.ndarray:
    ang = float(np.linalg.norm(w))
    if ang < 1e-15:
        return np.eye(3)
    from pipeline.kinematics.zero_position import axis_angle_matrix

    return axis_angle_matrix(ang, w / ang)


def cartesian_points(T0: np.ndarray, T1: np.ndarray, k: int) -> np.ndarray:
    """k frames from T0 to T1 (both included): straight line, equal division of the distance and of
    the single equivalent rotation R0^T R1 (about its axis in the moving frame). Shape (k, 4, 4)."""
    w = rotation_vector(T0[:3, :3].T @ T1[:3, :3])
    out = np.empty((k, 4, 4))
    for j in range(k):
        s = j / (k - 1)
        out[j] = np.eye(4)
        out[j, :3, :3] = T0[:3, :3] @ rotation_from_vector(s * w)
        out[j, :3, 3] = (1 - s) * T0[:3, 3] + s * T1[:3, 3]
    return out


def joint_points(q0: np.ndarray, q1: np.ndarray, k: int) -> np.ndarray:
    """k joint vectors from q0 to q1 (both included), equal increments per joint. Shape (k, n)."""
    s = np.linspace(0.0, 1.0, k)[:, None]
    return (1 - s) * q0[None] + s * q1[None]


def format_res(name: str, segments: int, k: int, rows: np.ndarray, prismatic: np.ndarray) -> str:
    """The RES layout of Appendix 3: name, 'segments<TAB>points', then per point
    'id segment index q...' (rad for revolute joints, mm for prismatic, 4 decimals)."""
    out = [name.upper(), f"{segments}\t{k}"]
    for r, q in enumerate(rows):
        seg, idx = divmod(r, k)
        out.append("\t".join([str(r + 1), str(seg), str(idx)] + [f"{v:.4f}" for v in q]))
    return "\n".join(out) + "\n"


def parse_res(text: str) -> tuple[str, int, int, np.ndarray]:
    """Read a RES file: (name, segments, points per segment, rows (m, 3 + n))."""
    lines = [ln.split() for ln in text.strip().splitlines()]
    name = " ".join(lines[0])
    seg, k = int(lines[1][0]), int(lines[1][1])
    rows = np.array([[float(v) for v in ln] for ln in lines[2:]])
    return name, seg, k, rows
