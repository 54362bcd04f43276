"""Erthal (1992) study inputs shared by the problem generators and the run writers: robot bases,
joint values and goal frames as the study settings write them."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pipeline.robots import RobotModel
from pipeline.studies.erthal1992.tasks import frame
from pipeline.yamlio import load_yaml


class RunError(ValueError):
    """A run cannot start (bad settings, unknown test/run name); one line."""


ROBOT_BASES_FILE = "robot_bases.yaml"  # data/erthal1992/: DH frame 0 in the document's robot base frame


def robot_base(data_dir: Path, name: str) -> list | None:
    """Position [mm] of ``name``'s DH frame 0 in the document's base frame (A4.2), or None if not listed."""
    path = Path(data_dir) / "erthal1992" / ROBOT_BASES_FILE
    if not path.exists():
        return None
    doc = load_yaml(path, "robot base file") or {}
    entry = doc.get(name)
    if entry is None:
        return None
    try:
        pos = [float(v) for v in entry["position"]]
    except (TypeError, KeyError, ValueError):
        raise RunError(f"{path}: field '{name}/position': expected 3 numbers [mm]") from None
    if len(pos) != 3:
        raise RunError(f"{path}: field '{name}/position': expected 3 numbers [mm]")
    return pos


def q_from_settings(model: RobotModel, values) -> np.ndarray:
    """Joint values from settings: degrees for revolute joints, length for prismatic."""
    v = np.array(values, dtype=float)
    if v.shape != (model.n,):
        raise RunError(f"{model.name}: expected {model.n} joint values, got {list(values)}")
    return np.where(model.chain.prismatic, v, np.radians(v))


def goal_frame(g: dict) -> np.ndarray:
    """Goal pose from {p, u_a, u_t} (z = u_a, y = u_t; A5.1-A5.6) or {p} only (position)."""
    p = np.zeros(3)
    p[: len(g["p"])] = g["p"]
    if "u_a" in g:
        return frame(g["u_t"], g["u_a"], p)
    T = np.eye(4)
    T[:3, 3] = p
    return T
