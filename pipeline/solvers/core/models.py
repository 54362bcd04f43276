"""The arm as the all-solution methods take it: in metres (``Metric``), in product-of-exponentials form
(``POE``), and which arms a 6R method takes. Shared by the closed forms (``general_6r``) and the peer
adapters; built once per job and robot (``Prepared.memo``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pipeline.robots import LENGTH_UNITS
from pipeline.solvers.core.prepared import Prepared


class Metric:
    """The prepared robot in metres, as the peers take it (built once per Prepared)."""

    def __init__(self, prep: Prepared):
        self.to_m = LENGTH_UNITS[prep.unit]
        self.model = prep.model if prep.unit == "m" else prep.model.in_unit("m")
        c = self.model.chain
        self.n = c.n
        self.prismatic = np.asarray(c.prismatic, dtype=bool)
        self.origins, self.axes, self.tool = (np.array(x, dtype=float) for x in c.as_general())
        self.base = np.array(c.base, dtype=float)
        self.limits = np.array(self.model.limits, dtype=float)

    def goal(self, T: np.ndarray) -> np.ndarray:
        """Goal in the working unit -> metres (C-contiguous copy)."""
        T = np.array(T, dtype=float, order="C")
        T[:3, 3] *= self.to_m
        return T

    def q_in(self, q: np.ndarray) -> np.ndarray:
        q = np.array(q, dtype=float, order="C")
        q[self.prismatic] *= self.to_m
        return q

    def q_out(self, q) -> np.ndarray:
        q = np.array(q, dtype=float, order="C").reshape(-1)
        q[self.prismatic] /= self.to_m
        return q

    def reach(self) -> float:
        """The chain's total length [m] (a box for unbounded prismatic joints), at least 1 m."""
        total = np.linalg.norm(self.origins[:, :3, 3], axis=1).sum() + np.linalg.norm(self.base[:3, 3]) \
            + np.linalg.norm(self.tool[:3, 3])
        return float(max(total, 1.0))


def metric(prep: Prepared) -> Metric:
    return prep.memo(("peers", "metric"), lambda: Metric(prep))


def wrap_angles(x):
    """Angles wrapped to (−π, π]."""
    y = np.mod(np.asarray(x, dtype=float) + math.pi, 2 * math.pi) - math.pi
    return np.where(y <= -math.pi, y + 2 * math.pi, y)


def revolute_only(prep: Prepared, who: str) -> str | None:
    m = metric(prep)
    if m.prismatic.any():
        joints = ", ".join(str(i + 1) for i in np.flatnonzero(m.prismatic))
        return f"{who} solves revolute joints only, joint(s) {joints} of the robot are prismatic"
    return None


def six_revolute(prep: Prepared, who: str) -> str | None:
    """Why ``who`` (a 6R solver) does not take the robot: a prismatic joint or another joint count."""
    why = revolute_only(prep, who)
    if why:
        return why
    n = metric(prep).n
    return None if n == 6 else f"{who} solves 6R arms, the robot has {n} joints"


@dataclass(frozen=True)
class POE:
    """The robot at q = 0 in product-of-exponentials form (metres, world frame, base included)."""

    H: np.ndarray       # (n, 3) unit joint axes
    pts: np.ndarray     # (n, 3) one point on each axis (joint i's frame origin)
    T0: np.ndarray      # (4, 4) the tool frame at q = 0 (its rotation is R_nT)
    size: float         # [m] the chain's length (sum of the point-to-point distances), at least 1e-3

    def P(self, pts: np.ndarray | None = None) -> np.ndarray:
        """(n + 1, 3): p_01, p_12, ..., p_nT for these points (default: the frame origins)."""
        pts = self.pts if pts is None else pts
        return np.diff(np.vstack([np.zeros(3), pts, self.T0[:3, 3]]), axis=0)


def poe(prep: Prepared) -> POE:
    def make():
        m = metric(prep)
        F = np.array(m.base, dtype=float)
        H, pts = np.empty((m.n, 3)), np.empty((m.n, 3))
        for i in range(m.n):
            F = F @ m.origins[i]
            h = F[:3, :3] @ m.axes[i]
            H[i] = h / np.linalg.norm(h)
            pts[i] = F[:3, 3]
        T0 = F @ m.tool
        size = float(np.linalg.norm(np.diff(np.vstack([np.zeros(3), pts, T0[:3, 3]]), axis=0), axis=1).sum())
        return POE(H, pts, T0, max(size, 1e-3))

    return prep.memo(("peers_geo", "poe"), make)
