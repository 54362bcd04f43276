"""Levenberg-Marquardt as in MRPT's ``CLevenbergMarquardtTempl::execute`` (002_56eb235931bf5f5d.txt §3.5, eqs. 7-8).

Registered as ``levenberg_marquardt``. Residual ``f(q)`` (``residual``):

``vector``  ``p(q) - p_goal`` (3), plus ``orientation_scale * r`` for full pose goals, ``r`` the rotation
            vector of ``R(q) R_goal^T`` (6 rows in all)
``scalar``  the single number ``e = |p(q) - p_goal|`` (eq. 3 as eq. 7 writes it), or
            ``sqrt(|p - p_goal|^2 + (orientation_scale * angle)^2)`` for full pose goals

Position-only goals are the criteria ``position`` and ``dq_norm_body``; the others are full pose.
MRPT's loop: central-difference Jacobian (``increment``, the same number for every joint: rad, or the
working length unit for a prismatic joint, whose FK is affine so any increment is exact),
``lambda_0 = tau max diag(J^T J)``, step ``h = -(J^T J + lambda I)^-1 J^T f``, gain ratio
``rho = (F(x) - F(x + h)) / (h^T (lambda h - g))``; an accepted step (rho > 0) sets
``lambda *= max(min_shrink, 1 - (2 rho - 1)^3)``, ``nu = 2`` (Nielsen; Madsen et al. 2004 eq. 2.21),
a rejected one ``lambda *= nu``, ``nu *= 2``. Stops: ``||J^T f||_inf <= gradient_tol``,
``||h|| < step_tol (||x|| + step_tol)``, an accepted step changing the error ``e`` by less than
``error_change_stop`` (the document's common stop), or MRPT's iteration counter
(``while (!found && ++iter < maxIter)``, ``iterations`` = MRPT's ``iterations_executed``). A stop
claims success only when the last accepted pose is within tol_pos (and tol_rot for full pose goals),
else code 2 (stalled); iteration cap: 4; non-finite value or a singular damped system: 5.

Units: ``gradient_tol`` is in m^2 (f times df/dq) and converted with the square of the working unit;
``error_change_stop`` and ``orientation_scale`` are lengths (m); ``step_tol`` is relative.
Timing as :mod:`pipeline.solvers.iterative.fd_jacobian` (``Raw.info["cpu_time_s"]``: thread CPU time).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from pipeline.robots import LENGTH_UNITS
import pipeline.solvers.kernels.kin as _kin
from pipeline.solvers.kernels.kin import ITERATION_CAP, NON_FINITE, STALLED, SUCCESS, TRACE_DP
from pipeline.solvers.core import POSITION_CRITERIA, Prepared, Raw, Settings, setting
from pipeline.solvers.core.driver import run_loop
from pipeline.solvers.core.registry import Solver, register

SOURCE = "002_56eb235931bf5f5d.txt (Borges et al.) §3.5, eqs. 7-8; MRPT CLevenbergMarquardtTempl"
RES_SCALAR, RES_VECTOR = 0, 1



@dataclass(frozen=True)
class LMSettings(Settings):
    """Settings of ``levenberg_marquardt`` (defaults: MRPT's, with a 3- or 6-row residual)."""

    residual: str = setting("vector", "vector: p - p_goal (+ orientation_scale * rotation vector for full pose "
                            "goals); scalar: its norm e (eq. 7 of 002)", choices=("vector", "scalar"))
    increment: float = setting(1e-3, "central-difference increment of the Jacobian (rad; the working length unit "
                               "for a prismatic joint)", unit="rad", above=0.0)
    tau: float = setting(1e-3, "lambda_0 = tau * max diag(J^T J) (eq. 8)", above=0.0)
    gradient_tol: float = setting(1e-14, "stop when ||J^T f||_inf <= this (MRPT e1; converted with the square of "
                                  "the working unit)", unit="m^2", minimum=0.0)
    step_tol: float = setting(1e-8, "stop when ||h|| < step_tol (||x|| + step_tol) (MRPT e2)", minimum=0.0)
    min_shrink: float = setting(0.33, "floor of Nielsen's damping factor on an accepted step (MRPT: 0.33)",
                                above=0.0, maximum=1.0)
    error_change_stop: float = setting(1e-9, "stop when an accepted step changes the error e by less than this",
                                       unit="m", minimum=0.0, length=True)
    orientation_scale: float = setting(0.1, "length per rad that weights the rotation vector against the "
                                       "position error (full pose goals)", unit="m", above=0.0, length=True)
    max_iterations: int = setting(200, "MRPT maxIter (iterations counted as MRPT does)", minimum=2,
                                  maximum=10_000_000)

    def pose(self) -> bool:
        return self.criterion not in POSITION_CRITERIA


# ---- compiled kernel ------------------------------------------------------------------------
@numba.njit(cache=True)
def nielsen(lam, nu, rho, min_shrink):
    """Damping update after a step with gain ratio ``rho`` (Madsen et al. 2004 eq. 2.21; MRPT):
    accepted (rho > 0): lam * max(min_shrink, 1 - (2 rho - 1)^3), nu = 2; rejected: lam * nu, nu * 2."""
    if rho > 0:
        return lam * max(min_shrink, 1.0 - (2.0 * rho - 1.0) ** 3), 2.0
    return lam * nu, nu * 2.0


@numba.njit(cache=True)
def _errors(Tg, T, pose, scale, qa, qb, rv):
    """(e, |dp|, angle); ``rv`` = rotation vector of R R_goal^T (angle 0 and ``rv`` untouched for position goals)."""
    dx, dy, dz = Tg[0, 3] - T[0, 3], Tg[1, 3] - T[1, 3], Tg[2, 3] - T[2, 3]
    dp = np.sqrt(dx * dx + dy * dy + dz * dz)
    if pose:
        ang = _kin.rotation_vector(T, Tg, qa, qb, rv)
        so = scale * ang
        return np.sqrt(dp * dp + so * so), dp, ang
    return dp, dp, 0.0


@numba.njit(cache=True)
def _residual(a, alpha, d, offs, prism, modified, base, tool, Tg, q, kind, pose, scale, r, T, qa, qb, rv):
    _kin.forward_pose(a, alpha, d, offs, prism, modified, base, tool, q, T)
    if kind == RES_SCALAR:
        e, dp, ang = _errors(Tg, T, pose, scale, qa, qb, rv)
        r[0] = e
    else:
        for i in range(3):
            r[i] = T[i, 3] - Tg[i, 3]
        if pose:
            _kin.rotation_vector(T, Tg, qa, qb, rv)
            for i in range(3):
                r[3 + i] = scale * rv[i]


@numba.njit(cache=True)
def _jacobian_central(a, alpha, d, offs, prism, modified, base, tool, Tg, q, kind, pose, scale, incr, J, rp, rm,
                      qp, T, qa, qb, rv):
    """MRPT ``estimateJacobian``: column j = (f(x + incr e_j) - f(x - incr e_j)) / (2 incr)."""
    n = q.shape[0]
    m = J.shape[0]
    for j in range(n):
        for i in range(n):
            qp[i] = q[i]
        qp[j] = q[j] + incr
        _residual(a, alpha, d, offs, prism, modified, base, tool, Tg, qp, kind, pose, scale, rp, T, qa, qb, rv)
        qp[j] = q[j] - incr
        _residual(a, alpha, d, offs, prism, modified, base, tool, Tg, qp, kind, pose, scale, rm, T, qa, qb, rv)
        for i in range(m):
            J[i, j] = (rp[i] - rm[i]) / (2.0 * incr)


@numba.njit(cache=True)
def _trace_row(trace, k, e, Tg, T, pose, qa, qb, rv):
    trace[k, 0] = e
    trace[k, 1], trace[k, 2], trace[k, 3] = Tg[0, 3] - T[0, 3], Tg[1, 3] - T[1, 3], Tg[2, 3] - T[2, 3]
    if pose:
        _kin.rotation_vector(Tg, T, qa, qb, rv)
        trace[k, 4], trace[k, 5], trace[k, 6] = rv[0], rv[1], rv[2]
    else:
        trace[k, 4], trace[k, 5], trace[k, 6] = 0.0, 0.0, 0.0
    dx, dy, dz = trace[k, 1], trace[k, 2], trace[k, 3]
    trace[k, TRACE_DP] = np.sqrt(dx * dx + dy * dy + dz * dz)


@numba.njit(cache=True)
def lm_solve(a, alpha, d, offs, prism, modified, base, tool, Tg, q0, kind, pose, scale, incr, max_iter, tau, e1, e2,
             min_shrink, tol_change, tol_pos, tol_rot, q, trace, times):
    """Levenberg-Marquardt loop. Returns (code, iterations); ``times`` = (wall ns, thread CPU ns)."""
    clk = np.zeros(2, np.int64)
    c0 = _kin.thread_cpu_ns(clk)
    t0 = _kin.now_ns(clk)
    n = q0.shape[0]
    if kind == RES_SCALAR:
        m = 1
    else:
        m = 6 if pose else 3
    T = np.empty((4, 4))
    Tlast = np.empty((4, 4))
    qa = np.empty(4)
    qb = np.empty(4)
    rv = np.empty(3)
    f = np.empty(m)
    fnew = np.empty(m)
    rp = np.empty(m)
    rm = np.empty(m)
    qp = np.empty(n)
    xnew = np.empty(n)
    J = np.empty((m, n))
    for j in range(n):
        q[j] = q0[j]
    _jacobian_central(a, alpha, d, offs, prism, modified, base, tool, Tg, q, kind, pose, scale, incr, J, rp, rm, qp,
                      T, qa, qb, rv)
    H = J.T @ J
    _residual(a, alpha, d, offs, prism, modified, base, tool, Tg, q, kind, pose, scale, f, T, qa, qb, rv)
    e, dp, ang = _errors(Tg, T, pose, scale, qa, qb, rv)
    _trace_row(trace, 0, e, Tg, T, pose, qa, qb, rv)
    g = J.T @ f
    found = np.max(np.abs(g)) <= e1
    dmax = 0.0
    for i in range(n):
        dmax = max(dmax, H[i, i])
    lam = tau * dmax
    nu = 2.0
    Fx = 0.0
    for i in range(m):
        Fx += f[i] * f[i]
    code = SUCCESS if found else ITERATION_CAP
    it = 0
    Tlast[:, :] = T
    while not found:
        it += 1
        if it >= max_iter:
            _trace_row(trace, it, e, Tg, Tlast, pose, qa, qb, rv)
            break
        A = H.copy()
        for i in range(n):
            A[i, i] += lam
        ok = True
        try:
            h = -np.linalg.solve(A, g)
        except Exception:  # singular damped system (lambda = 0 and J^T J singular)
            ok = False
            h = np.zeros(n)
        if not ok:
            code = NON_FINITE
            _trace_row(trace, it, e, Tg, Tlast, pose, qa, qb, rv)
            break
        nh = np.sqrt(np.sum(h * h))
        nx = np.sqrt(np.sum(q * q))
        if nh < e2 * (nx + e2):
            found = True
            code = SUCCESS
        else:
            for i in range(n):
                xnew[i] = q[i] + h[i]
            _residual(a, alpha, d, offs, prism, modified, base, tool, Tg, xnew, kind, pose, scale, fnew, T, qa, qb, rv)
            Fnew = 0.0
            for i in range(m):
                Fnew += fnew[i] * fnew[i]
            denom = 0.0
            for i in range(n):
                denom += h[i] * (lam * h[i] - g[i])
            rho = (Fx - Fnew) / denom
            if rho > 0:
                for i in range(n):
                    q[i] = xnew[i]
                for i in range(m):
                    f[i] = fnew[i]
                Fx = Fnew
                Tlast[:, :] = T
                _jacobian_central(a, alpha, d, offs, prism, modified, base, tool, Tg, q, kind, pose, scale, incr, J,
                                  rp, rm, qp, T, qa, qb, rv)
                H = J.T @ J
                g = J.T @ f
                if np.max(np.abs(g)) <= e1:
                    found = True
                    code = SUCCESS
                lam, nu = nielsen(lam, nu, rho, min_shrink)
                e_new, dp, ang = _errors(Tg, Tlast, pose, scale, qa, qb, rv)
                if abs(e - e_new) < tol_change:
                    found = True
                    code = SUCCESS
                e = e_new
            else:
                lam, nu = nielsen(lam, nu, rho, min_shrink)
        _trace_row(trace, it, e, Tg, Tlast, pose, qa, qb, rv)
        if not (np.isfinite(e) and np.isfinite(lam)):
            code = NON_FINITE
            break
    if it >= max_iter:
        it = max_iter
    if code == SUCCESS:
        e_last, dp, ang = _errors(Tg, Tlast, pose, scale, qa, qb, rv)
        if dp > tol_pos or (pose and ang > tol_rot):
            code = STALLED
    times[0] = _kin.now_ns(clk) - t0
    times[1] = _kin.thread_cpu_ns(clk) - c0
    return code, it


# ---- registry entry -------------------------------------------------------------------------
def run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: LMSettings, seed: int) -> Raw:
    e1 = s.gradient_tol / LENGTH_UNITS[prep.unit] ** 2
    q, trace, times, (code, it) = run_loop(
        lm_solve, (*prep.args, T_goal, q_start, RES_SCALAR if s.residual == "scalar" else RES_VECTOR, s.pose(),
                   float(s.orientation_scale), float(s.increment), int(s.max_iterations), float(s.tau), float(e1),
                   float(s.step_tol), float(s.min_shrink), float(s.error_change_stop), float(s.tol_pos),
                   float(s.tol_rot)), q_start, s.max_iterations)
    return Raw(q=q, code=int(code), iterations=int(it), solve_ns=int(times[0]), trace=trace,
               info={"cpu_time_s": int(times[1]) * 1e-9})


register(Solver("levenberg_marquardt", "Levenberg-Marquardt with Nielsen's damping update and a central-difference "
                "Jacobian (MRPT; eqs. 7-8)", "local", LMSettings, run, source=SOURCE))
