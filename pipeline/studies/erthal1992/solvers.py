"""IK methods of 001_7601717b50b5e768.txt, each returning :class:`pipeline.solvers.IKResult`.

* :func:`zp_solve` — Kazerounian's Zero-Position method (Appendix 4), 10 weight strategies (§6.2c).
* :func:`nr_solve` — Newton-Raphson with Whitney step control (eqs 4.12-4.13).
* :func:`geometric_planar_solve` — the iterative geometric method of Pinto & Bevilacqua [72] for
  planar arms (Test 6), position only.

Every claimed success is re-checked with the numpy forward kinematics (``fk_htm``) before
``success`` is set (stop code 6 when the check contradicts the claim).
"""

from __future__ import annotations

import math
import time

import numpy as np

from pipeline.kinematics import fk_frames, fk_htm, orientation_error_angle, position_error
from pipeline.robots import RobotModel
from pipeline.solvers import IKResult
from pipeline.solvers._jit import FK_CHECK_FAILED, ITERATION_CAP, NON_FINITE, SUCCESS

from pipeline.studies.erthal1992 import kernels

STRATEGIES = tuple(range(1, 11))
FK_REL_TOL = 1e-9  # independent FK may differ from the kernel's by rounding only


class StrategyError(ValueError):
    """Unknown weight strategy (one line)."""


def strategy_weights(strategy: int, prismatic: np.ndarray) -> np.ndarray:
    """Per-joint weight c of ZP strategy 1..10 (§6.2c); NaN = Kazerounian's A4.30 at run time.

    1: A4.30 for all; 2: c=1 for joint 1, A4.30 for 2..N-1, c=0 for N; 3: c=1 for joints 1-3, 0 for
    4..N; 4: c=1 for all; 5: A4.30 for joints 1-3, 0 for 4..N; 6-8: eq. 6.1
    ``c = ((j-N)/(1-N))^n`` with n = 1, 2, 3; 9-10: eq. 6.2 ``c = (j^n - N^n)/(1 - N^n)`` with
    n = 2, 3. Prismatic joints ignore c (A4.29 is position only).

    Parameters
    ----------
    strategy : int in 1..10
    prismatic : ndarray of bool, shape (n,)

    Returns
    -------
    c : ndarray, shape (n,)
    """
    n = len(prismatic)
    j = np.arange(1, n + 1, dtype=float)
    nan = np.nan
    if strategy == 1:
        c = np.full(n, nan)
    elif strategy == 2:
        c = np.full(n, nan)
        c[0] = 1.0
        c[-1] = 0.0
    elif strategy == 3:
        c = np.where(j <= 3, 1.0, 0.0)
    elif strategy == 4:
        c = np.ones(n)
    elif strategy == 5:
        c = np.where(j <= 3, nan, 0.0)
    elif strategy in (6, 7, 8):
        p = strategy - 5
        c = ((j - n) / (1 - n)) ** p if n > 1 else np.ones(n)
    elif strategy in (9, 10):
        p = strategy - 7
        c = (j**p - n**p) / (1 - n**p) if n > 1 else np.ones(n)
    else:
        raise StrategyError(f"unknown ZP weight strategy {strategy!r} (allowed: 1..10)")
    return np.asarray(c, dtype=float)


def _args(model: RobotModel):
    c = model.chain
    return (np.ascontiguousarray(c.a), np.ascontiguousarray(c.alpha), np.ascontiguousarray(c.d),
            np.ascontiguousarray(c.theta_offset), np.ascontiguousarray(c.prismatic), bool(c.modified),
            np.ascontiguousarray(c.base), np.ascontiguousarray(c.tool))


def zp_error(T_goal: np.ndarray, T: np.ndarray, use_orientation: bool = True) -> tuple[float, float]:
    """(delta_R, delta_P) of A4.12-A4.13 at the current pose (dq = 0): ||R_g R^T - I||_F^2, |dp|^2."""
    M = T_goal[:3, :3] @ T[:3, :3].T
    dR = float(np.sum((M - np.eye(3)) ** 2)) if use_orientation else 0.0
    dP = float(np.sum((T_goal[:3, 3] - T[:3, 3]) ** 2))
    return dR, dP


def _result(model, T_goal, q, code, iters, trace, times, claimed_ok) -> IKResult:
    T = fk_htm(model.chain, q)
    dp = float(np.linalg.norm(position_error(T_goal, T)))
    ang = float(orientation_error_angle(T_goal, T))
    claimed = code == SUCCESS
    if claimed and not claimed_ok(T):
        code = FK_CHECK_FAILED
    if not np.all(np.isfinite(q)):
        code = NON_FINITE
    return IKResult(q=q, success=bool(claimed and code == SUCCESS), stop_reason=int(code), iterations=int(iters),
                    trace=trace[: iters + 1].copy(), solve_time_s=times[0] * 1e-9, ik_time_s=times[1] * 1e-9,
                    position_error=dp, orientation_error=ang, claimed_success=claimed)


def zp_solve(model: RobotModel, T_goal: np.ndarray, q_start: np.ndarray, strategy: int = 5, eps: float = 1e-3,
             max_iter: int = 100, use_orientation: bool = True) -> IKResult:
    """Zero-Position IK (Appendix 4 of 001_7601717b50b5e768.txt).

    Parameters
    ----------
    model : RobotModel
    T_goal : ndarray, shape (4, 4) [length]         goal pose in the robot base frame
    q_start : ndarray, shape (n,) [rad | length]    initial configuration (selects the branch)
    strategy : int                                  weight strategy 1..10 (§6.2c)
    eps : float [length^2]                          stop when delta_R + delta_P < eps (Etapa 10)
    max_iter : int                                  cap on sweeps over the joints
    use_orientation : bool                          False: position-only task (delta_R := 0, c = 1)

    Returns
    -------
    IKResult
        ``trace[:, 0]`` = delta_R + delta_P after each sweep.
    """
    c = strategy_weights(strategy, model.chain.prismatic)
    if not use_orientation:
        c = np.ones_like(c)
    Tg = np.ascontiguousarray(T_goal, dtype=float)
    q = np.empty(model.n)
    trace = np.zeros((max_iter + 1, kernels.TRACE_COLS))
    times = np.zeros(3, np.int64)
    code, iters, _ = kernels.zp_solve(*_args(model), Tg, np.ascontiguousarray(q_start, dtype=float), c,
                                      float(eps), int(max_iter), bool(use_orientation), q, trace, times)

    def ok(T):
        dR, dP = zp_error(Tg, T, use_orientation)
        return dR + dP < eps * (1 + FK_REL_TOL) + 1e-12

    return _result(model, Tg, q, code, iters, trace, times, ok)


def nr_solve(model: RobotModel, T_goal: np.ndarray, q_start: np.ndarray, eps: float = 1e-3, max_iter: int = 60,
             s_halvings: int = 10, stall: bool = True) -> IKResult:
    """Newton-Raphson with Whitney step control (eqs 4.12-4.13 of 001_7601717b50b5e768.txt).

    Parameters
    ----------
    eps : float                 stop when |(p_goal - p, angle axis)| < eps (mixed length/rad norm)
    max_iter : int              iteration cap (60 in Test 1)
    s_halvings : int            inner search over s = 1, 1/2, ..., 2^-s_halvings
    stall : bool                stop (code 2) when no s decreases the error
    """
    Tg = np.ascontiguousarray(T_goal, dtype=float)
    q = np.empty(model.n)
    trace = np.zeros((max_iter + 1, kernels.TRACE_COLS))
    times = np.zeros(3, np.int64)
    code, iters = kernels.nr_solve(*_args(model), Tg, np.ascontiguousarray(q_start, dtype=float), float(eps),
                                   int(max_iter), int(s_halvings), bool(stall), q, trace, times)

    def ok(T):
        dp = np.linalg.norm(position_error(Tg, T))
        ang = float(orientation_error_angle(Tg, T))
        return math.hypot(dp, ang) < eps * (1 + FK_REL_TOL) + 1e-12

    return _result(model, Tg, q, code, iters, trace, times, ok)


def geometric_planar_solve(model: RobotModel, p_goal: np.ndarray, q_start: np.ndarray, tol: float = 1e-3,
                           max_iter: int = 100) -> IKResult:
    """Iterative geometric method for planar revolute arms (Pinto & Bevilacqua [72], Test 6).

    Each joint, from the last to the first, is turned in isolation so that the line from the joint
    to the effector points at the goal (position only, no orientation correction, as the
    document describes [72]); one iteration = one sweep. Success when |dp| < tol [length].
    The document does not give [72]'s joint order, limits or stop rule (our reading: tip to base,
    no limits, |dp| < tol).

    Parameters
    ----------
    p_goal : ndarray, shape (2,) or (3,) [length]   goal in the arm's xy plane
    """
    if model.chain.prismatic.any() or np.any(np.abs(model.chain.alpha) > 1e-12):
        raise ValueError(f"{model.name}: the geometric method needs a planar revolute arm (all alpha = 0)")
    t0 = time.perf_counter_ns()
    g = np.zeros(3)
    g[: len(p_goal)] = p_goal
    q = np.array(q_start, dtype=float)
    n = model.n
    trace = np.zeros((max_iter + 1, kernels.TRACE_COLS))

    def fill(row, F):
        p = (F[-1] @ model.chain.tool)[:3, 3]
        dv = g - p
        trace[row, 0] = float(np.linalg.norm(dv[:2]))
        trace[row, 1:4] = dv
        trace[row, 7] = trace[row, 0]
        return trace[row, 0]

    F = fk_frames(model.chain, q)
    err = fill(0, F)
    code, it = (SUCCESS if err < tol else 0), 0
    t_ik = 0
    while code == 0:
        it += 1
        for i in reversed(range(n)):
            ts = time.perf_counter_ns()
            o = F[i][:2, 3]
            p = (F[-1] @ model.chain.tool)[:2, 3]
            v1, v2 = p - o, g[:2] - o
            if np.linalg.norm(v1) > 1e-12 and np.linalg.norm(v2) > 1e-12:
                q[i] += math.atan2(v1[0] * v2[1] - v1[1] * v2[0], v1 @ v2)
            t_ik += time.perf_counter_ns() - ts
            F = fk_frames(model.chain, q)
            p = (F[-1] @ model.chain.tool)[:2, 3]
            if np.linalg.norm(g[:2] - p) < tol:
                code = SUCCESS
                break
        fill(it, F)
        if code == 0 and it >= max_iter:
            code = ITERATION_CAP
    times = (time.perf_counter_ns() - t0, t_ik)
    Tg = fk_htm(model.chain, q).copy()
    Tg[:3, 3] = g
    return _result(model, Tg, q, code, it, trace, times,
                   lambda T: np.linalg.norm(T[:2, 3] - g[:2]) < tol * (1 + FK_REL_TOL))
