"""Analytic IK of the PUMA 560 (Fu, Gonzalez & Lee [02]; ``cin_inv_PUMA()`` of A5.3 of
001_7601717b50b5e768.txt): all 8 solutions, each verified by forward kinematics.

Geometry: standard DH with alpha = (-90, 0, 90, -90, 90, 0) deg, a1 = d1 = 0 (the Fu et al. table
of data/robots/puma560.yaml). Wrist centre ``p_w = p - d6 z``; theta1 from the shoulder offset d2
(two branches, ARM), theta2/theta3 from the planar two-link problem with the forearm
``L = sqrt(a3^2 + d4^2)`` (two branches, ELBOW), theta4..6 from ``R36 = R03^T R06`` (two
branches, WRIST). At the wrist degeneracy (sin theta5 = 0) theta4 = 0 and theta6 takes the sum,
as the document's program does.

Flags: ``arm`` = +1 for theta1 = phi - asin(d2/r), -1 for the other branch; ``elbow`` = sign of
the elbow angle (theta3 - atan2(d4, a3)); ``wrist`` = sign of sin theta5. These are our branch
labels: the document's flag names (OMBRO_ESQUERDO/DIREITO, COTOVELO_BAIXO/ALTO, PULSO_BAIXO/ALTO)
are not defined numerically in the surviving text (Fig. A5.9 is missing).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from pipeline.kinematics import dh_transform, fk_frames, fk_htm, orientation_error_angle, position_error
from pipeline.robots import RobotModel
from pipeline.solvers import IKResult
from pipeline.solvers._jit import FK_CHECK_FAILED, SUCCESS

PUMA_ALPHA = np.radians([-90, 0, 90, -90, 90, 0])
FK_POS_TOL = 1e-6   # [mm] a closed-form solution must reproduce the goal to rounding
FK_ROT_TOL = 1e-8   # [rad]
DEGENERATE_S5 = 1e-12  # |sin theta5| below this: wrist degeneracy (theta4 := 0)


class PumaGeometryError(ValueError):
    """The robot is not of the PUMA 560 layout (one line)."""


@dataclass(frozen=True)
class PumaSolution:
    q: np.ndarray
    arm: int
    elbow: int
    wrist: int
    degenerate: bool
    result: IKResult


def _check(model: RobotModel) -> None:
    c = model.chain
    if (model.n != 6 or c.convention != "standard" or c.prismatic.any() or not np.allclose(c.alpha, PUMA_ALPHA)
            or abs(c.a[0]) > 1e-12 or np.any(np.abs(c.a[3:]) > 1e-12) or abs(c.d[2]) > 1e-12 or abs(c.d[4]) > 1e-12):
        raise PumaGeometryError(f"{model.name}: not a PUMA 560 layout (alpha -90 0 90 -90 90 0, a1 = a4..6 = 0, d3 = d5 = 0)")


def puma_ik_all(model: RobotModel, T_goal: np.ndarray) -> list[PumaSolution]:
    """All (up to 8) analytic solutions for ``T_goal`` (4, 4) in the base frame, each with an
    :class:`IKResult` whose success is confirmed by ``fk_htm``. Unreachable poses give []."""
    _check(model)
    c = model.chain
    t0 = time.perf_counter_ns()
    T06 = np.linalg.inv(c.base) @ T_goal @ np.linalg.inv(c.tool)
    a2, a3, d2, d4, d6 = c.a[1], c.a[2], c.d[1], c.d[3], c.d[5]
    off = c.theta_offset
    pw = T06[:3, 3] - d6 * T06[:3, 2] - np.array([0.0, 0.0, c.d[0]])
    r = math.hypot(pw[0], pw[1])
    out = []
    if r < abs(d2):
        return out
    phi = math.atan2(pw[1], pw[0])
    L = math.hypot(a3, d4)
    beta = math.atan2(d4, a3)
    raw = []
    for arm, th1 in ((1, phi - math.asin(d2 / r)), (-1, phi - math.pi + math.asin(d2 / r))):
        A1 = dh_transform(0.0, c.alpha[0], 0.0, th1)
        p1 = np.linalg.inv(A1)[:3, :3] @ pw
        X, Y = p1[0], p1[1]
        cg = (X * X + Y * Y - a2 * a2 - L * L) / (2 * a2 * L)
        if abs(cg) > 1 + 1e-12:
            continue
        cg = max(-1.0, min(1.0, cg))
        for elbow in (1, -1):
            g = elbow * math.acos(cg)
            th2 = math.atan2(Y, X) - math.atan2(L * math.sin(g), a2 + L * math.cos(g))
            th3 = g + beta
            q3 = np.array([th1, th2, th3, 0, 0, 0]) - off
            R03 = fk_frames(c, q3)[3, :3, :3]
            R = R03.T @ T06[:3, :3]
            s5 = math.hypot(R[0, 2], R[1, 2])
            for wrist in (1, -1):
                th5 = math.atan2(wrist * s5, R[2, 2])
                deg = s5 < DEGENERATE_S5
                th4 = 0.0 if deg else math.atan2(wrist * R[1, 2], wrist * R[0, 2])
                # theta6 from the residual rotation (R4 R5)^T R36 = Rz(theta6): exact even when the
                # theta4/theta6 split is ill-conditioned near sin theta5 = 0
                R45 = (dh_transform(0.0, c.alpha[3], 0.0, th4) @ dh_transform(0.0, c.alpha[4], 0.0, th5))[:3, :3]
                Rr = R45.T @ R
                th6 = math.atan2(Rr[1, 0], Rr[0, 0])
                raw.append((np.array([th1, th2, th3, th4, th5, th6]) - off, arm, elbow, wrist, deg))
    t_all = time.perf_counter_ns() - t0
    for q, arm, elbow, wrist, deg in raw:
        T = fk_htm(c, q)
        dp = float(np.linalg.norm(position_error(T_goal, T)))
        ang = float(orientation_error_angle(T_goal, T))
        ok = dp < FK_POS_TOL and ang < FK_ROT_TOL
        tr = np.zeros((1, 8))
        tr[0, 0] = math.hypot(dp, ang)
        tr[0, 1:4] = position_error(T_goal, T)
        tr[0, 7] = dp
        res = IKResult(q=q, success=ok, stop_reason=SUCCESS if ok else FK_CHECK_FAILED, iterations=0, trace=tr,
                       solve_time_s=t_all * 1e-9 / max(1, len(raw)), ik_time_s=t_all * 1e-9 / max(1, len(raw)),
                       position_error=dp, orientation_error=ang, claimed_success=True)
        out.append(PumaSolution(q, arm, elbow, wrist, deg, res))
    return out
