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
from pipeline.solvers.kernels.kin import LIM_OFF, LIM_REFLECT, NEVER, SEARCH_LIMITS
from pipeline.solvers.kernels.loop import iterate, pose_row
from pipeline.solvers.core import POSITION_CRITERIA, Prepared, Raw, Settings, search_limits_setting, setting
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
    search_limits: str = search_limits_setting()

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
    if pose:
        _kin.rotation_vector(Tg, T, qa, qb, rv)
    pose_row(trace, k, e, Tg, T, rv, pose)


@numba.njit(cache=True)
def _linearise(problem, state, q):
    """J (central differences), H = J^T J and g = J^T f at ``q`` into the state (``T`` used as scratch)."""
    a, alpha, d, offs, prism, modified, base, tool, Tg, kind, pose, scale, incr = problem[:13]
    T, Tlast, qa, qb, rv, f, fnew, rp, rm, qp, xnew, J, H, g, sc = state
    _jacobian_central(a, alpha, d, offs, prism, modified, base, tool, Tg, q, kind, pose, scale, incr, J, rp, rm, qp,
                      T, qa, qb, rv)
    H[:, :] = J.T @ J


@numba.njit(cache=True)
def _start(problem, q):
    """:func:`pipeline.solvers.kernels.loop.iterate`'s ``start``: J, H, f, g at the start, lambda = tau max H_ii.

    State: ``(T, Tlast, qa, qb, rv, f, fnew, rp, rm, qp, xnew, J, H, g, sc)`` with ``Tlast`` the pose of the
    last accepted iterate, ``sc`` = (e, lambda, nu, F = |f|^2)."""
    a, alpha, d, offs, prism, modified, base, tool, Tg, kind, pose, scale, incr = problem[:13]
    tau, e1 = problem[14], problem[15]
    n = q.shape[0]
    if problem[21] != LIM_OFF:  # search_limits: the start clamped into the joint box
        _into_box(q, problem[22], problem[23])
    m = 1 if kind == RES_SCALAR else (6 if pose else 3)
    state = (np.empty((4, 4)), np.empty((4, 4)), np.empty(4), np.empty(4), np.empty(3), np.empty(m), np.empty(m),
             np.empty(m), np.empty(m), np.empty(n), np.empty(n), np.empty((m, n)), np.empty((n, n)), np.empty(n),
             np.empty(4))
    T, Tlast, qa, qb, rv, f, fnew, rp, rm, qp, xnew, J, H, g, sc = state
    _linearise(problem, state, q)
    _residual(a, alpha, d, offs, prism, modified, base, tool, Tg, q, kind, pose, scale, f, T, qa, qb, rv)
    e, dp, ang = _errors(Tg, T, pose, scale, qa, qb, rv)
    g[:] = J.T @ f
    found = np.max(np.abs(g)) <= e1
    dmax = 0.0
    for i in range(n):
        dmax = max(dmax, H[i, i])
    Fx = 0.0
    for i in range(m):
        Fx += f[i] * f[i]
    sc[0], sc[1], sc[2], sc[3] = e, tau * dmax, 2.0, Fx
    Tlast[:, :] = T
    ok, stalled = _claim(problem, state, found)
    return state, e, ok, stalled


@numba.njit(cache=True)
def _claim(problem, state, found):
    """(success, stall): a claimed convergence ``found`` is a success when the last accepted pose is within
    tol_pos (and tol_rot for pose goals), else a stall."""
    Tg, pose, scale, tol_pos, tol_rot = problem[8], problem[10], problem[11], problem[19], problem[20]
    if not found:
        return False, False
    T, Tlast, qa, qb, rv = state[:5]
    e_last, dp, ang = _errors(Tg, Tlast, pose, scale, qa, qb, rv)
    within = not (dp > tol_pos or (pose and ang > tol_rot))
    return within, not within


@numba.njit(cache=True, inline="always")
def _into_box(q, lo, hi):
    """Clamp ``q`` (n,) into ``[lo, hi]`` (n,) in place."""
    for j in range(q.shape[0]):
        q[j] = min(max(q[j], lo[j]), hi[j])


@numba.njit(cache=True)
def _bounded_step(q, lo, hi, lim, h):
    """``search_limits``: the damped step ``h`` (n,) kept in the joint box ``[lo, hi]`` (n,) around ``q`` (n,):
    reflect mirrors a joint the step takes past a limit at that limit; then (both modes) ``q + h`` is clamped
    into the box. Returns ``(h, mirrored)``: the kept step (n,) and whether a joint was mirrored. The caller
    judges the kept step by :func:`_predicted` (MRPT's ``h^T (lambda h - g)`` for the unconstrained step) and
    takes a mirrored step even when it does not lower the error (the damping unchanged): a mirrored step leaves
    the limit instead of stalling on it, which is what makes reflection work."""
    mirrored = False
    for j in range(q.shape[0]):
        x = q[j] + h[j]
        if lim == LIM_REFLECT and (x > hi[j] or x < lo[j]):  # mirrored at the limit it passed
            x = 2.0 * hi[j] - x if x > hi[j] else 2.0 * lo[j] - x
            mirrored = True
        h[j] = min(max(x, lo[j]), hi[j]) - q[j]
    return h, mirrored


@numba.njit(cache=True)
def _predicted(H, g, h):
    """Predicted decrease of ``|f|^2`` for the step ``h`` (n,) under the linear model: ``-(2 g.h + h.H.h)``."""
    return -(2.0 * np.dot(g, h) + np.dot(h, H @ h))


@numba.njit(cache=True)
def _step(problem, state, q, it):
    """``step``: MRPT's iteration (the damped system, the gain ratio, Nielsen's update); no step at the cap
    (MRPT counts the last test as an iteration)."""
    a, alpha, d, offs, prism, modified, base, tool, Tg, kind, pose, scale, incr, max_iter = problem[:14]
    e1, e2, min_shrink, tol_change = problem[15], problem[16], problem[17], problem[18]
    T, Tlast, qa, qb, rv, f, fnew, rp, rm, qp, xnew, J, H, g, sc = state
    n = q.shape[0]
    if it >= max_iter:
        return sc[0], False, False, 0
    e, lam, nu, Fx = sc[0], sc[1], sc[2], sc[3]
    A = H.copy()
    for i in range(n):
        A[i, i] += lam
    lim = problem[21]
    mirrored = False
    try:
        h = -np.linalg.solve(A, g)
        if lim != LIM_OFF:
            h, mirrored = _bounded_step(q, problem[22], problem[23], lim, h)
    except Exception:  # singular damped system (lambda = 0 and J^T J singular)
        return np.nan, False, False, 0
    found = False
    if np.sqrt(np.sum(h * h)) < e2 * (np.sqrt(np.sum(q * q)) + e2):
        found = True
    else:
        for i in range(n):
            xnew[i] = q[i] + h[i]
        if lim != LIM_OFF:  # q + (limit - q) can miss the limit by a rounding
            _into_box(xnew, problem[22], problem[23])
        _residual(a, alpha, d, offs, prism, modified, base, tool, Tg, xnew, kind, pose, scale, fnew, T, qa, qb, rv)
        Fnew = 0.0
        for i in range(fnew.shape[0]):
            Fnew += fnew[i] * fnew[i]
        denom = 0.0
        if lim == LIM_OFF:
            for i in range(n):
                denom += h[i] * (lam * h[i] - g[i])
            rho = (Fx - Fnew) / denom
        else:  # a kept step whose model predicts no decrease is rejected (damping grows)
            denom = _predicted(H, g, h)
            rho = (Fx - Fnew) / denom if denom > 0.0 else -1.0
            if mirrored and not rho > 0.0:  # a mirrored step is taken (it leaves the limit), damping unchanged
                rho = 0.5
        if rho > 0:
            q[:] = xnew
            f[:] = fnew
            sc[3] = Fnew
            Tlast[:, :] = T
            _linearise(problem, state, q)
            g[:] = J.T @ f
            found = np.max(np.abs(g)) <= e1
            e_new, dp, ang = _errors(Tg, Tlast, pose, scale, qa, qb, rv)
            found = found or abs(e - e_new) < tol_change
            sc[0] = e_new
        sc[1], sc[2] = nielsen(lam, nu, rho, min_shrink)
    ok, stalled = _claim(problem, state, found)
    return sc[0] if np.isfinite(sc[1]) else np.nan, ok, stalled, 0


@numba.njit(cache=True)
def _record(problem, state, trace, row):
    """``record``: ``[e, p_goal - p (3), rotation vector of R_goal R^T (3), |dp|]`` at the last accepted pose."""
    _trace_row(trace, row, state[14][0], problem[8], state[1], problem[10], state[2], state[3], state[4])


@numba.njit(cache=True)
def lm_solve(a, alpha, d, offs, prism, modified, base, tool, Tg, q0, kind, pose, scale, incr, max_iter, tau, e1, e2,
             min_shrink, tol_change, tol_pos, tol_rot, lim, lo, hi, q, trace, times):
    """Levenberg-Marquardt loop (:func:`pipeline.solvers.kernels.loop.iterate` with this module's step).
    ``lim`` the ``search_limits`` code (:data:`pipeline.solvers.kernels.kin.SEARCH_LIMITS`), ``lo``, ``hi`` (n,)
    the joint box. Returns (code, iterations); ``times`` = (wall ns, 0, thread CPU ns)."""
    problem = (a, alpha, d, offs, prism, modified, base, tool, Tg, kind, pose, scale, incr, max_iter, tau, e1, e2,
               min_shrink, tol_change, tol_pos, tol_rot, lim, lo, hi)
    code, it, _ = iterate(_start, _step, _record, problem, q0, q, trace, times, NEVER, max_iter)
    return code, it


# ---- registry entry -------------------------------------------------------------------------
def _box(prep: Prepared) -> tuple[np.ndarray, np.ndarray]:
    """The joint limits' lower and upper columns (n,) each, C-contiguous (once per prepared robot)."""
    return prep.memo("limit_columns", lambda: (np.ascontiguousarray(prep.limits[:, 0]),
                                               np.ascontiguousarray(prep.limits[:, 1])))


def run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: LMSettings, seed: int) -> Raw:
    e1 = s.gradient_tol / LENGTH_UNITS[prep.unit] ** 2
    q, trace, times, (code, it) = run_loop(
        lm_solve, (*prep.args, T_goal, q_start, RES_SCALAR if s.residual == "scalar" else RES_VECTOR, s.pose(),
                   float(s.orientation_scale), float(s.increment), int(s.max_iterations), float(s.tau), float(e1),
                   float(s.step_tol), float(s.min_shrink), float(s.error_change_stop), float(s.tol_pos),
                   float(s.tol_rot), SEARCH_LIMITS.index(s.search_limits), *_box(prep)), q_start, s.max_iterations,
        clocks=3)
    return Raw(q=q, code=int(code), iterations=int(it), solve_ns=int(times[0]), trace=trace,
               info={"cpu_time_s": int(times[2]) * 1e-9})


register(Solver("levenberg_marquardt", "Levenberg-Marquardt with Nielsen's damping update and a central-difference "
                "Jacobian (MRPT; eqs. 7-8)", "local", LMSettings, run, source=SOURCE))
