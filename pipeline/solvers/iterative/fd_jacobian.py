"""Inverse Jacobian with a finite-difference Jacobian (002_56eb235931bf5f5d.txt §3.4, eqs. 4-6).

Registered as ``inverse_jacobian_fd``. One iteration::

    J[:, j] = f(q + delta e_j) - f(q)          (eq. 5 as the document uses it: NOT divided by delta)
    dq      = alpha J^-1 (X_f - X)             (eq. 6; J^-1 = the inverse, or the minimum-norm /
                                                least-squares pseudo-inverse when J is not square)

so the effective Newton gain is ``alpha / delta`` (0.5 with the document's 0.005 and 0.01 rad).
Eq. 5 prints ``X - f(Q + delta e_j)``, whose sign makes eq. 6 climb; the forward difference is used.
``delta`` perturbs every joint by the same number (rad, or the working length unit for a prismatic
joint), so the gain is the same for every joint.

Rows of ``f`` (``orientation_rows``):

``position``          the 3 position rows (the document's reading for its position-only cost, eq. 3)
``hold_orientation``  position + roll/pitch/yaw rows (eq. 4's X), whose target difference is held at
                      zero (the document's alternative; position-only goals)
``pose``              position + the rotation vector of ``R(q + delta e_j) R(q)^T`` scaled by
                      ``orientation_scale`` (a length per rad); the target is the rotation vector of
                      ``R_goal R(q)^T`` scaled the same way: full pose goals
``auto``              ``position`` for the position-only criteria (position, dq_norm_body), else ``pose``

Scalar error ``e``: ``|p_goal - p|`` for position rows, ``sqrt(|p_goal - p|^2 + (orientation_scale *
angle)^2)`` for pose rows. Stops (``stop``): ``reach`` ends as soon as the goal is within the success
tolerances (``|dp| < tol_pos`` and, for pose rows, ``angle < tol_rot``; Table 2); ``error_change`` ends
when ``|e_k - e_{k-1}| < error_change_stop`` (§4.1), claiming success only within those tolerances
(else code 2). Iteration cap: code 4; non-finite error: code 5.

Timing: ``solve_ns`` is the kernel's monotonic clock around the whole solve; ``Raw.info["cpu_time_s"]``
the thread CPU time of the same interval (a load-robust companion, not the solve time).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

import pipeline.solvers.kernels.kin as _kin
from pipeline.solvers.kernels.kin import NEVER, TRACE_DP
from pipeline.solvers.kernels.loop import iterate
from pipeline.solvers.core import POSITION_CRITERIA, Prepared, Raw, Settings, SettingsError, setting
from pipeline.solvers.core.driver import run_loop
from pipeline.solvers.core.registry import Solver, register

SOURCE = "002_56eb235931bf5f5d.txt (Borges et al.) §3.4, eqs. 4-6"

ROWS_POSITION, ROWS_HOLD, ROWS_POSE = 0, 1, 2
STOP_REACH, STOP_CHANGE = 0, 1



@dataclass(frozen=True)
class FDJacobianSettings(Settings):
    """Settings of ``inverse_jacobian_fd`` (defaults: the document's gain, perturbation and cap)."""

    alpha: float = setting(0.005, "attenuation factor of eq. 6; the effective Newton gain is alpha / delta",
                           above=0.0)
    delta: float = setting(0.01, "finite-difference perturbation of eq. 5 (the same number for every joint: "
                           "rad, or the working length unit for a prismatic joint); columns are not divided by it",
                           unit="rad", above=0.0)
    orientation_rows: str = setting("auto", "rows of the Jacobian: position (3 rows), hold_orientation (roll/pitch/"
                                    "yaw rows with zero target difference), pose (rotation-vector rows), auto "
                                    "(position for the position-only criteria, else pose)",
                                    choices=("auto", "position", "hold_orientation", "pose"))
    orientation_scale: float = setting(0.1, "length per rad that weights the orientation error (rotation vector) "
                                       "against the position error in pose rows and in the scalar error e",
                                       unit="m", above=0.0, length=True)
    stop: str = setting("reach", "reach: stop as soon as the goal is within tol_pos (and tol_rot for pose rows), "
                        "Table 2; error_change: stop when |e_k - e_(k-1)| < error_change_stop, section 4.1",
                        choices=("reach", "error_change"))
    error_change_stop: float = setting(1e-9, "error-change stop threshold (stop: error_change)", unit="m",
                                       minimum=0.0, length=True)
    max_iterations: int = setting(500, "iteration cap (stop code 4); the document gives none", minimum=1,
                                  maximum=10_000_000)

    def rows(self) -> int:
        r = self.orientation_rows
        if r == "auto":
            r = "position" if self.criterion in POSITION_CRITERIA else "pose"
        return {"position": ROWS_POSITION, "hold_orientation": ROWS_HOLD, "pose": ROWS_POSE}[r]

    def check(self, where: str) -> None:
        if self.criterion not in POSITION_CRITERIA and self.orientation_rows in ("position", "hold_orientation"):
            raise SettingsError(f"{where}: field 'orientation_rows': {self.orientation_rows!r} ignores the goal "
                                f"orientation, which criterion {self.criterion!r} tests (use pose or auto)")


# ---- compiled kernel ------------------------------------------------------------------------
@numba.njit(cache=True)
def _wrap(x):
    return (x + np.pi) % (2.0 * np.pi) - np.pi


@numba.njit(cache=True)
def rpy(T, out):
    """Eq. 4's orientation part: (roll, pitch, yaw), R = Rz(yaw) Ry(pitch) Rx(roll)."""
    out[0] = np.arctan2(T[2, 1], T[2, 2])
    out[1] = np.arctan2(-T[2, 0], np.sqrt(T[2, 1] * T[2, 1] + T[2, 2] * T[2, 2]))
    out[2] = np.arctan2(T[1, 0], T[0, 0])


@numba.njit(cache=True)
def _error(Tg, T, rows, scale, qa, qb, rv):
    """(scalar error e, |dp|, rotation angle goal vs T); ``rv`` = rotation vector of R_goal R^T (pose rows only;
    angle 0 otherwise)."""
    dx, dy, dz = Tg[0, 3] - T[0, 3], Tg[1, 3] - T[1, 3], Tg[2, 3] - T[2, 3]
    dp = np.sqrt(dx * dx + dy * dy + dz * dz)
    if rows == ROWS_POSE:
        ang = _kin.rotation_vector(Tg, T, qa, qb, rv)
        so = scale * ang
        return np.sqrt(dp * dp + so * so), dp, ang
    return dp, dp, 0.0


@numba.njit(cache=True)
def _trace_row(trace, k, e, Tg, T, rows, rv, dp):
    trace[k, 0] = e
    trace[k, 1], trace[k, 2], trace[k, 3] = Tg[0, 3] - T[0, 3], Tg[1, 3] - T[1, 3], Tg[2, 3] - T[2, 3]
    if rows == ROWS_POSE:
        trace[k, 4], trace[k, 5], trace[k, 6] = rv[0], rv[1], rv[2]
    else:
        trace[k, 4], trace[k, 5], trace[k, 6] = 0.0, 0.0, 0.0
    trace[k, TRACE_DP] = dp


@numba.njit(cache=True)
def _within(dp, ang, rows, tol_pos, tol_rot):
    """The kernel's success test (strict, as Table 2's 'e < 0.01 mm')."""
    if rows == ROWS_POSE:
        return dp < tol_pos and ang < tol_rot
    return dp < tol_pos


@numba.njit(cache=True)
def pinv_solve(J, dx):
    """``J^-1 dx``: the inverse when square, ``J^T (J J^T)^-1 dx`` when wide, ``(J^T J)^-1 J^T dx`` when tall;
    the SVD pseudo-inverse (:func:`pipeline.solvers.kernels.kin.small_svd`) when the system is singular."""
    m, n = J.shape
    try:
        if m < n:
            Jc = np.ascontiguousarray(J)
            y = np.linalg.solve(Jc @ Jc.T, dx)
            return Jc.T @ y
        if m == n:
            return np.linalg.solve(J, dx)
        Jc = np.ascontiguousarray(J)
        return np.linalg.solve(Jc.T @ Jc, Jc.T @ dx)
    except Exception:  # singular: Moore-Penrose through the SVD
        U, S, Vt = _kin.small_svd(np.ascontiguousarray(J))
        tol = max(m, n) * S[0] * 2.220446049250313e-16
        out = np.zeros(n)
        for k in range(S.shape[0]):
            if S[k] > tol:
                c = 0.0
                for i in range(m):
                    c += U[i, k] * dx[i]
                c /= S[k]
                for j in range(n):
                    out[j] += c * Vt[k, j]
        return out


@numba.njit(cache=True)
def fd_jacobian(a, alpha, d, offs, prism, modified, base, tool, q, T, X, delta, rows, scale, J, qp, Tp, Xp, qa, qb, rv):
    """Eq. 5 as used: column j = f(q + delta e_j) - f(q), not divided by delta, into ``J`` (m, n).

    ``T`` must hold the pose at ``q`` and ``X`` its roll/pitch/yaw (hold_orientation rows).
    """
    n = q.shape[0]
    for j in range(n):
        for m in range(n):
            qp[m] = q[m]
        qp[j] += delta
        _kin.forward_pose(a, alpha, d, offs, prism, modified, base, tool, qp, Tp)
        for r in range(3):
            J[r, j] = Tp[r, 3] - T[r, 3]
        if rows == ROWS_HOLD:
            rpy(Tp, Xp)
            for r in range(3):
                J[3 + r, j] = _wrap(Xp[r] - X[r])
        elif rows == ROWS_POSE:
            _kin.rotation_vector(Tp, T, qa, qb, rv)
            for r in range(3):
                J[3 + r, j] = scale * rv[r]


@numba.njit(cache=True)
def _start(problem, q):
    """:func:`pipeline.solvers.kernels.loop.iterate`'s ``start``: scratch, first FK and error.

    State: ``(T, Tp, X, Xp, qa, qb, rv, rg, qp, J, dx, m)`` with ``m`` = (error, |dp|) of the iterate."""
    a, alpha, d, offs, prism, modified, base, tool, Tg, gain, delta, rows, scale, stop = problem[:14]
    tol_pos, tol_rot, tol_change = problem[14:]
    n = q.shape[0]
    m_rows = 3 if rows == ROWS_POSITION else 6
    state = (np.empty((4, 4)), np.empty((4, 4)), np.empty(3), np.empty(3), np.empty(4), np.empty(4), np.empty(3),
             np.empty(3), np.empty(n), np.empty((m_rows, n)), np.zeros(m_rows), np.empty(2))
    T, Tp, X, Xp, qa, qb, rv, rg, qp, J, dx, m = state
    _kin.forward_pose(a, alpha, d, offs, prism, modified, base, tool, q, T)
    e, dp, ang = _error(Tg, T, rows, scale, qa, qb, rg)
    m[0], m[1] = e, dp
    return state, e, stop == STOP_REACH and _within(dp, ang, rows, tol_pos, tol_rot), False


@numba.njit(cache=True)
def _step(problem, state, q, it):
    """``step``: ``q += alpha J^+ (X_goal - X)`` with the finite-difference J; the stop test of ``stop``
    (reach: within the tolerances; change: the error changed by less than ``tol_change``, success when
    within the tolerances, else a stall)."""
    a, alpha, d, offs, prism, modified, base, tool, Tg, gain, delta, rows, scale, stop = problem[:14]
    tol_pos, tol_rot, tol_change = problem[14:]
    T, Tp, X, Xp, qa, qb, rv, rg, qp, J, dx, m = state
    if rows == ROWS_HOLD:
        rpy(T, X)
    fd_jacobian(a, alpha, d, offs, prism, modified, base, tool, q, T, X, delta, rows, scale, J, qp, Tp, Xp,
                qa, qb, rv)
    for r in range(3):
        dx[r] = Tg[r, 3] - T[r, 3]
    if rows == ROWS_POSE:
        for r in range(3):
            dx[3 + r] = scale * rg[r]
    dq = pinv_solve(J, dx)
    for j in range(q.shape[0]):
        q[j] += gain * dq[j]
    _kin.forward_pose(a, alpha, d, offs, prism, modified, base, tool, q, T)
    e_new, dp, ang = _error(Tg, T, rows, scale, qa, qb, rg)
    e = m[0]
    m[0], m[1] = e_new, dp
    if stop == STOP_REACH:
        return e_new, _within(dp, ang, rows, tol_pos, tol_rot), False, 0
    changed = abs(e - e_new) < tol_change
    ok = changed and _within_or_equal(dp, ang, rows, tol_pos, tol_rot)
    return e_new, ok, changed and not ok, 0


@numba.njit(cache=True)
def _record(problem, state, trace, row):
    T, rg, m = state[0], state[7], state[11]
    _trace_row(trace, row, m[0], problem[8], T, problem[11], rg, m[1])


@numba.njit(cache=True)
def ji_solve(a, alpha, d, offs, prism, modified, base, tool, Tg, q0, gain, delta, rows, scale, stop,
             tol_pos, tol_rot, tol_change, max_iter, q, trace, times):
    """Inverse Jacobian loop (eqs. 5-6; :func:`pipeline.solvers.kernels.loop.iterate` with this module's
    step). Returns (code, iterations); ``times`` = (wall ns, 0, thread CPU ns)."""
    problem = (a, alpha, d, offs, prism, modified, base, tool, Tg, gain, delta, rows, scale, stop, tol_pos, tol_rot,
               tol_change)
    code, it, _ = iterate(_start, _step, _record, problem, q0, q, trace, times, NEVER, max_iter)
    return code, it


@numba.njit(cache=True)
def _within_or_equal(dp, ang, rows, tol_pos, tol_rot):
    if rows == ROWS_POSE:
        return dp <= tol_pos and ang <= tol_rot
    return dp <= tol_pos


# ---- registry entry -------------------------------------------------------------------------
def run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: FDJacobianSettings, seed: int) -> Raw:
    q, trace, times, (code, it) = run_loop(
        ji_solve, (*prep.args, T_goal, q_start, float(s.alpha), float(s.delta), s.rows(), float(s.orientation_scale),
                   STOP_REACH if s.stop == "reach" else STOP_CHANGE, float(s.tol_pos), float(s.tol_rot),
                   float(s.error_change_stop), int(s.max_iterations)), q_start, s.max_iterations, clocks=3)
    return Raw(q=q, code=int(code), iterations=int(it), solve_ns=int(times[0]), trace=trace,
               info={"cpu_time_s": int(times[2]) * 1e-9})


register(Solver("inverse_jacobian_fd", "inverse Jacobian from an undivided finite-difference Jacobian, "
                "dq = alpha J^-1 (X_f - X) (eqs. 5-6)", "local", FDJacobianSettings, run, source=SOURCE))
