"""Newton-Raphson with Whitney step control (001_7601717b50b5e768.txt eqs 4.10-4.13; Erthal 1992 §4.1).

``q <- q + s J^+(q) e(q)`` with ``e = ((p_goal - p) / L, angle * axis)`` the 6-vector pose error
(position in units of ``length_scale`` L, orientation the rotation vector of ``R_goal R^T``) and
``J^+`` the least-squares solution of ``J dq = e`` (the inverse for a square non-singular J, the
minimum-norm solution for a redundant arm such as the 7-DoF LWR, the least-squares one for fewer
than 6 joints). J is the geometric Jacobian of :mod:`pipeline.solvers.kernels.kin` (any DH chain:
standard or modified, prismatic joints, base and tool transforms). The step length s is chosen
by Whitney's control: ``s = 1, 1/2, ..., 2^-step_halvings``, the first whose error norm ``|e|`` is
below the current one; when none is, the iteration has stalled (stop code 2, ``stall``).

Stop tests. ``tolerance`` (default): the FK check's criterion (``tol_pos``, ``tol_rot``...).
``error_norm``: the document's ``|e| < epsilon`` (with L = 1 length_unit the norm mixes that unit
and rad, as NR's program [70] did).

Trace rows (row 0 = start): ``[|e|, e (6), |dp|]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

import pipeline.solvers.kernels.kin as _kin
from pipeline.solvers.kernels.kin import CRIT_POSITION, CRIT_POS_ORIENT, NEVER
from pipeline.solvers.kernels.loop import error_row, iterate
import pipeline.solvers.kernels.pose as _jit
from pipeline.solvers.kernels.pose import pose_error
from pipeline.solvers.core import CRITERION_CODE, Prepared, Raw, Settings, setting
from pipeline.solvers.core.driver import run_loop
from pipeline.solvers.core.registry import Solver, register

SOURCE = "001_7601717b50b5e768.txt (Erthal 1992) eqs 4.10-4.13 (Newton-Raphson, Whitney step control)"
STOP_TESTS = ("tolerance", "error_norm")


I_MAX_ITER, I_HALVINGS, I_STALL, I_STOP, I_CRIT = range(5)
F_EPS, F_TOL_POS, F_TOL_ROT, F_TOL_DQ, F_INV_L, F_RCOND = range(6)


@dataclass(frozen=True)
class NewtonRaphsonSettings(Settings):
    """Settings of Newton-Raphson with Whitney step control."""

    max_iterations: int = setting(200, "stop code 4 after this many Newton steps (the document's Test 1: 60)",
                                  minimum=1, maximum=10_000_000)
    step_halvings: int = setting(30, "Whitney search over s = 1, 1/2, ..., 2^-step_halvings", minimum=0,
                                 maximum=60)
    stall: bool = setting(True, "stop (code 2) when no step length lowers |e|")
    stop_test: str = setting("tolerance", "tolerance: the FK check's criterion; error_norm: |e| < epsilon "
                             "(the document)", choices=STOP_TESTS)
    epsilon: float = setting(1e-3, "stop_test error_norm: |e| < epsilon (position part in units of length_scale, "
                             "orientation in rad); the FK check confirms such a claim when tol_pos >= epsilon L and "
                             "tol_rot >= epsilon", above=0.0)
    rcond: float = setting(1e-5, "singular values of J below rcond * the largest are treated as zero in the "
                           "least-squares step (numpy lstsq; -1 = machine precision)", minimum=-1.0, maximum=1.0)
    length_scale: float = setting(1.0, "L: the position part of e is (p_goal - p) / L (the document: 1 mm)",
                                  unit="m", above=0.0, length=True)


def packed(s: NewtonRaphsonSettings) -> tuple[np.ndarray, np.ndarray]:
    ip = np.zeros(5, np.int64)
    fp = np.zeros(6)
    ip[I_MAX_ITER] = s.max_iterations
    ip[I_HALVINGS] = s.step_halvings
    ip[I_STALL] = int(s.stall)
    ip[I_STOP] = STOP_TESTS.index(s.stop_test)
    ip[I_CRIT] = CRITERION_CODE[s.criterion]
    fp[F_EPS] = s.epsilon
    fp[F_TOL_POS] = s.tol_pos
    fp[F_TOL_ROT] = s.tol_rot
    fp[F_TOL_DQ] = s.tol_dq
    fp[F_INV_L] = 1.0 / s.length_scale
    fp[F_RCOND] = s.rcond
    return ip, fp


@numba.njit(cache=True)
def _error(Tg, T, pip, pfp, qa, qb, e, inv_l, crit):
    """e = ((p_goal - p) / L, angle axis) (orientation zeroed for position-only goals); returns (|e|, |dp|, angle)."""
    err, dp, ang = pose_error(Tg, T, pip, pfp, qa, qb, e)
    if crit == CRIT_POSITION:
        e[3], e[4], e[5] = 0.0, 0.0, 0.0
    if inv_l != 1.0 or crit == CRIT_POSITION:
        for r in range(3):
            e[r] *= inv_l
        err = np.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2] + e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
    return err, dp, ang


@numba.njit(cache=True)
def _met(problem, T, err):
    """The stop test: ``|e| < epsilon`` (error_norm) or the FK check's criterion (tolerance)."""
    Tg, ip, fp = problem[8], problem[9], problem[10]
    if ip[I_STOP] == 1:
        return err < fp[F_EPS]
    return _kin.meets(ip[I_CRIT], Tg, T, fp[F_TOL_POS], fp[F_TOL_ROT], fp[F_TOL_DQ])


@numba.njit(cache=True)
def _start(problem, q):
    """:func:`pipeline.solvers.kernels.loop.iterate`'s ``start``: scratch, first FK and error.

    State: ``(pip, pfp, axes, origins, T, J, e, e_try, qa, qb, p, q_try, m, clk, halved)`` with ``pip``,
    ``pfp`` pose_error's slots (orientation error = axis-angle, scalar = |e|), ``m`` = (|e|, |dp|),
    ``halved`` (1,) the step halvings used."""
    a, alpha, d, offs, prism, modified, base, tool, Tg, ip, fp = problem
    n = q.shape[0]
    pip = np.zeros(_jit.N_IP, np.int64)
    pip[_jit.I_CRITERION] = CRIT_POS_ORIENT
    pip[_jit.I_ORIENT] = 1
    pfp = np.zeros(_jit.N_FP)
    axes = np.empty((n, 3))
    origins = np.empty((n, 3))
    T = np.empty((4, 4))
    J = np.empty((6, n))
    e = np.empty(6)
    e_try = np.empty(6)
    qa = np.empty(4)
    qb = np.empty(4)
    p = np.empty(3)
    q_try = np.empty(n)
    m = np.empty(2)
    _kin.forward(a, alpha, d, offs, prism, modified, base, tool, q, axes, origins, T)
    err, dp, ang = _error(Tg, T, pip, pfp, qa, qb, e, fp[F_INV_L], ip[I_CRIT])
    m[0], m[1] = err, dp
    state = (pip, pfp, axes, origins, T, J, e, e_try, qa, qb, p, q_try, m, np.zeros(2, np.int64), np.zeros(1, np.int64))
    return state, err, _met(problem, T, err), False


@numba.njit(cache=True)
def _step(problem, state, q, it):
    """``step``: least-squares Newton step J^+ e, halved until |e| decreases (Whitney)."""
    a, alpha, d, offs, prism, modified, base, tool, Tg, ip, fp = problem
    pip, pfp, axes, origins, T, J, e, e_try, qa, qb, p, q_try, m, clk, halved = state
    n = q.shape[0]
    crit, inv_l = ip[I_CRIT], fp[F_INV_L]
    err = m[0]
    for r in range(3):
        p[r] = T[r, 3]
    _kin.jacobian(prism, axes, origins, p, J)
    if inv_l != 1.0:
        for r in range(3):
            for c in range(n):
                J[r, c] *= inv_l
    if crit == CRIT_POSITION:  # no orientation rows
        for r in range(3, 6):
            for c in range(n):
                J[r, c] = 0.0
    t0 = _kin.now_ns(clk)
    dq = np.linalg.lstsq(J, e, fp[F_RCOND])[0]  # = J^-1 e for a square non-singular J; minimum norm when redundant
    t_ik = _kin.now_ns(clk) - t0
    s = 1.0
    accepted = False
    for k in range(ip[I_HALVINGS] + 1):
        for i in range(n):
            q_try[i] = q[i] + s * dq[i]
        _kin.forward(a, alpha, d, offs, prism, modified, base, tool, q_try, axes, origins, T)
        new_err, dp_try, ang_try = _error(Tg, T, pip, pfp, qa, qb, e_try, inv_l, crit)
        if np.isfinite(new_err) and new_err < err:
            accepted = True
            halved[0] += k
            break
        s *= 0.5
    if accepted:
        for i in range(n):
            q[i] = q_try[i]
        err = new_err
        m[0], m[1] = new_err, dp_try
        e[:] = e_try
    else:
        _kin.forward(a, alpha, d, offs, prism, modified, base, tool, q, axes, origins, T)
    return err, _met(problem, T, err), not accepted and ip[I_STALL] != 0, t_ik


@numba.njit(cache=True)
def _record(problem, state, trace, row):
    """``record``: ``[|e|, e (6), |dp|]``."""
    m = state[12]
    error_row(trace, row, m[0], state[6], m[1])


@numba.njit(cache=True)
def nr_kernel(a, alpha, d, offs, prism, modified, base, tool, Tg, q0, ip, fp, q, trace, times):
    """Newton-Raphson with Whitney step control (:func:`pipeline.solvers.kernels.loop.iterate` with this
    module's step); returns (stop code, iterations, step halvings used)."""
    code, it, state = iterate(_start, _step, _record, (a, alpha, d, offs, prism, modified, base, tool, Tg, ip, fp),
                              q0, q, trace, times, NEVER, ip[I_MAX_ITER])
    return code, it, state[14][0]


def run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: NewtonRaphsonSettings, seed: int) -> Raw:
    ip, fp = prep.memo(("newton_raphson_packed", s), lambda: packed(s))
    q, trace, times, (code, iters, halved) = run_loop(nr_kernel, (*prep.args, T_goal, q_start, ip, fp), q_start,
                                                      s.max_iterations)
    return Raw(q=q, code=int(code), iterations=int(iters), solve_ns=int(times[0]), trace=trace, ik_ns=int(times[1]),
               info={"step_halvings": int(halved)})


register(Solver("newton_raphson", "Newton-Raphson with Whitney step control: least-squares step J^+ e, "
                "step length halved until |e| decreases", "local", NewtonRaphsonSettings, run, source=SOURCE))
