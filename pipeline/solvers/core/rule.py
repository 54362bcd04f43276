"""The one result rule every IK method shares (``finish``), with the independent FK check and the limits.

Call shape (see :mod:`pipeline.solvers.core.registry`)::

    solve(name, robot, T_goal, q_start, settings=None, *, seed=0) -> IKResult

A registered method supplies only its kernel call, ``run(prep, T_goal, q_start, settings, seed) ->
Raw``; :func:`finish` turns that raw output into an :class:`IKResult`: it re-checks the returned
angles with forward kinematics that share no code with the solvers' (compiled dual-quaternion FK,
:mod:`pipeline.kinematics.fkcheck`; never the kernel's own FK), sets ``success``
only when the method claimed success *and* that check passes, marks a contradicted claim as
:attr:`StopReason.FK_CHECK_FAILED`, and records whether the solution lies within the robot file's
joint limits.

Units. Settings are written in SI (m, rad) whatever the robot file's unit. ``length_unit`` names the
unit the method computes in (default m); the robot and the goal are converted to it once per job
(:class:`Prepared`) and every length-valued setting once per job (:meth:`Settings.converted`). A
study that needs a document's own unit (cerbaro2019's cm reading, borges_kr6's mm) sets
``length_unit`` and still writes its tolerances in metres. Results (``position_error``, traces) are
in ``length_unit``, which the result and the archive record.

Timing (one definition for every method, :mod:`pipeline.solvers.core.timing`): ``solve_time_s`` is the
method's own computation, from its first to its last operation on this problem, on the monotonic
clock; ``call_time_s`` is the whole Python call of :func:`pipeline.solvers.solve`, input conversion
and the FK check included.
"""

from __future__ import annotations

import math

import numpy as np

import numba

from pipeline.kinematics import fk_htm
from pipeline.kinematics.fkcheck import CHECK8_SCRATCH, check_one, pose_check, pose_check8
from pipeline.kinematics.fkcheck import meets as meets_compiled
from pipeline.io.layout import TRACE_COLS
from pipeline.robots import RobotModel
from pipeline.solvers.kernels.kin import CRITERION_CODE
from pipeline.solvers.kernels.kin import FK_CHECK_FAILED, LIMIT_TOL, NON_FINITE, OUT_OF_LIMITS, SUCCESS, TRACE_DP
from pipeline.solvers.kernels.kin import borrowed, grid
from pipeline.solvers.core.settings import Settings, SettingsError
from pipeline.solvers.core.prepared import Prepared
from pipeline.solvers.core.results import BatchRaw, BatchResult, IKResult, Raw


def finish_batch(prep: Prepared, goals: np.ndarray, raw: BatchRaw, settings: Settings) -> BatchResult:
    """:func:`finish` for N problems at once: the same compiled rule per problem (:func:`_result`), on
    every core (not for ``require_limits``; the registry solves those one at a time).

    ``goals`` (N, 4, 4) and ``settings`` in the working unit; ``call_time_s`` is left at 0.
    """
    q = np.ascontiguousarray(raw.q, dtype=float)
    N = q.shape[0]
    code = np.asarray(raw.code, dtype=np.int64).copy()
    claimed, success, inside = np.zeros(N, np.bool_), np.zeros(N, np.bool_), np.zeros(N, np.bool_)
    dp, ang = np.empty(N), np.empty(N)
    F, prism = finish_args(prep)
    _finish_many(F, prism, q, np.ascontiguousarray(goals, dtype=float), CRITERION_CODE[settings.criterion],
                 settings.tol_pos, settings.tol_rot, settings.tol_dq, bool(settings.require_limits), code, claimed,
                 success, dp, ang, inside)
    if settings.criterion == "position":
        ang = np.full(N, np.nan)
    return BatchResult(q=q, success=success, stop_reason=code,
                       iterations=np.asarray(raw.iterations, dtype=np.int64), solve_time_s=raw.solve_ns * 1e-9,
                       ik_time_s=raw.ik_ns * 1e-9, position_error=dp, orientation_error=ang,
                       claimed_success=claimed, within_limits=inside, call_time_s=0.0, length_unit=prep.unit,
                       trace_rows=raw.trace_rows, trace_offsets=raw.trace_offsets, solutions=raw.solutions,
                       n_solutions=raw.n_solutions, info=raw.info,
                       cpu_times_s=None if raw.cpu_ns is None else raw.cpu_ns * 1e-9)


def pose_errors(model: RobotModel, T_goal: np.ndarray, q: np.ndarray) -> tuple[float, float, float]:
    """Independent FK of ``q``: (|dp| [unit], rotation angle [rad], |t| of ``T_goal T^-1`` [unit])."""
    T = fk_htm(model.chain, q)
    Rg, R = T_goal[:3, :3], T[:3, :3]
    dpv = T_goal[:3, 3] - T[:3, 3]
    dp = float(math.sqrt(dpv @ dpv))
    Rrel = Rg @ R.T
    c = (np.trace(Rrel) - 1.0) / 2.0
    s = 0.5 * math.sqrt((Rrel[2, 1] - Rrel[1, 2]) ** 2 + (Rrel[0, 2] - Rrel[2, 0]) ** 2 + (Rrel[1, 0] - Rrel[0, 1]) ** 2)
    ang = float(math.atan2(s, c)) if math.isfinite(c) and math.isfinite(s) else math.nan
    tv = T_goal[:3, 3] - Rrel @ T[:3, 3]
    return dp, ang, float(math.sqrt(tv @ tv))


def meets(settings: Settings, dp: float, ang: float, t: float) -> bool:
    """The success test of ``settings.criterion`` on FK errors (tolerances in the working unit)."""
    if not math.isfinite(dp) or (settings.criterion != "position" and not math.isfinite(ang)):
        return False
    crit = settings.criterion
    if crit == "dq_norm":
        return math.sqrt(1 + t * t / 4) <= settings.tol_dq * (1 + 1e-12)
    if crit == "dq_norm_body":
        return math.sqrt(1 + dp * dp / 4) <= settings.tol_dq * (1 + 1e-12)
    if crit == "position":
        return dp <= settings.tol_pos * (1 + 1e-9)
    return dp <= settings.tol_pos * (1 + 1e-9) and ang <= settings.tol_rot * (1 + 1e-9)


def verify(model: RobotModel, T_goal: np.ndarray, q: np.ndarray, settings: Settings) -> tuple[bool, float, float]:
    """Independent FK check of a solution: (meets the success criterion, |dp| [length], angle [rad]).

    Uses the numpy reference FK (not a compiled kernel). The DQ norm of ``Q_goal Q*`` is taken in
    its closed form ``sqrt(1 + |t|^2 / 4)``, t the translation of ``T_goal T^-1`` (tested against the
    explicit dual-quaternion product in tests/kinematics/test_kinematics.py).

    Parameters
    ----------
    model : RobotModel
        The robot, in the unit the settings are in.
    T_goal : ndarray, shape (4, 4) [model's length unit]
        Goal pose.
    q : ndarray, shape (n,) [rad | model's length unit]
        The solution to check.
    settings : Settings
        Success criterion and tolerances, already in the model's unit (:meth:`Settings.converted`).

    Returns
    -------
    tuple of (bool, float, float)
        Meets the criterion; ``|dp|`` [length]; rotation angle [rad].
    """
    dp, ang, t = pose_errors(model, T_goal, q)
    return meets(settings, dp, ang, t), dp, ang


def check(prep: Prepared, T_goal: np.ndarray, q: np.ndarray, settings: Settings) -> tuple[bool, float, float]:
    """:func:`verify` by the compiled dual-quaternion FK (:mod:`pipeline.kinematics.fkcheck`): the
    check every solve gets. ``T_goal`` and ``settings`` in the working unit; returns (ok, |dp|, angle)."""
    ok, dp, ang, _ = check_one(*prep.check, np.asarray(q, dtype=float), T_goal, CRITERION_CODE[settings.criterion],
                               settings.tol_pos, settings.tol_rot, settings.tol_dq, np.empty(8))
    return bool(ok), dp, ang


@numba.njit(cache=True)
def _within(q, limits, prismatic, tol):
    for i in range(q.shape[0]):
        x, lo, hi = q[i], limits[i, 0], limits[i, 1]
        if not math.isfinite(x):
            return False
        if not prismatic[i] and math.isfinite(lo):
            x = lo + np.mod(x - lo, 2 * math.pi)
            if abs(x - 2 * math.pi - lo) <= tol:
                x = lo
        if x < lo - tol or x > hi + tol:
            return False
    return True


def within_limits(q: np.ndarray, limits: np.ndarray, prismatic: np.ndarray, tol: float = LIMIT_TOL) -> bool:
    """True when every joint lies within its limits (up to ``tol``, by default the one tolerance
    :data:`pipeline.solvers.kernels.kin.LIMIT_TOL`); a revolute joint may first be wrapped by 2 pi.

    A wrapped value just below ``lo + 2 pi`` (within ``tol``) counts as ``lo``. Compiled (called
    once per solve).

    Parameters
    ----------
    q : ndarray, shape (n,) [rad | length]
        Joint values.
    limits : ndarray, shape (n, 2) [rad | length]
        Lower and upper limit per joint (+-inf where none).
    prismatic : ndarray of bool, shape (n,)
        Which joints are prismatic (never wrapped).
    tol : float
        Tolerance [rad | length].

    Returns
    -------
    bool
    """
    return bool(_within(np.asarray(q, dtype=float), np.asarray(limits, dtype=float), np.asarray(prismatic, dtype=np.bool_),
                        float(tol)))


def wrap_into_limits(q: np.ndarray, limits: np.ndarray, prismatic: np.ndarray) -> np.ndarray:
    """``q`` with each revolute joint moved by a multiple of 2 pi into its limits where that fits.

    Joints that do not fit either way (and prismatic or unbounded joints) keep their value, so
    the pose is unchanged up to rounding of ``q +- 2 k pi``.
    """
    q = np.array(q, dtype=float)
    lo, hi = limits[:, 0], limits[:, 1]
    for i in range(q.shape[0]):
        if prismatic[i] or not math.isfinite(lo[i]) or not math.isfinite(q[i]) or lo[i] <= q[i] <= hi[i]:
            continue
        w = lo[i] + math.fmod(q[i] - lo[i], 2 * math.pi) % (2 * math.pi)
        if w <= hi[i]:
            q[i] = w
    return q


@numba.njit(cache=True)
def nearest_rep(x, ref, limits, prismatic, tol, out):
    """``x`` (n,) moved joint by joint by whole turns to the value within the limits (up to ``tol``)
    nearest ``ref`` (n,), into ``out``; returns the joint travel from ``ref`` (Euclidean norm of the
    moves), inf when a joint fits no turn or a value is not finite. Prismatic joints keep their value;
    an unbounded revolute joint takes the turn nearest ``ref``."""
    two_pi = 2.0 * math.pi
    acc = 0.0
    for j in range(x.shape[0]):
        if prismatic[j]:
            c = x[j] - ref[j]
        else:
            w = x[j] - ref[j]
            w = w - two_pi * math.floor((w + math.pi) / two_pi)
            c = math.inf
            for k in (0, -1, 1, -2, 2):
                y = w + two_pi * k
                if limits[j, 0] - tol <= ref[j] + y <= limits[j, 1] + tol and abs(y) < abs(c):
                    c = y
        out[j] = ref[j] + c
        acc += c * c
    return math.sqrt(acc) if math.isfinite(acc) else math.inf


@numba.njit(cache=True)
def nearest_of(q, S, ref, limits, prismatic, tol, out, d):
    """:func:`nearest_rep` of ``q`` (n,) and of every row of ``S`` (m, n): ``d`` (m + 1,) their travels
    (``q`` first); the representative of the least travel into ``out``. Returns its index (0: ``q``,
    1 + i: row i of ``S``), -1 when none fits the limits."""
    best = -1
    bd = math.inf
    for i in range(S.shape[0] + 1):
        d[i] = nearest_rep(q if i == 0 else S[i - 1], ref, limits, prismatic, tol, out)
        if d[i] < bd:
            bd = d[i]
            best = i
    if best >= 0:
        nearest_rep(q if best == 0 else S[best - 1], ref, limits, prismatic, tol, out)
    return best


def _within_limit_choice(prep: Prepared, T_goal: np.ndarray, raw: Raw, settings: Settings,
                         q_start: np.ndarray | None) -> np.ndarray:
    """The returned angles under ``require_limits``: wrapped into the limits; for an analytic method, the
    solution that moves the joints least from the start (each one, the method's first choice among them,
    moved by whole turns to its value within the limits nearest the start, :func:`nearest_of`). The first
    choice is judged beside the method's other solutions: a joint whose limits are narrower than a turn
    may put the solution nearest by wrapped angles on the far side of the joint's range (a UR3 elbow at
    +3.13 rad for a seed at -2.88), where a neighbouring solution lies within 0.5 rad. Another solution
    than the first is taken only if it passes the independent FK check (the first is checked by
    :func:`finish` as every result is); if it does not, the next nearest that does."""
    if raw.solutions is None or len(raw.solutions) == 0 or q_start is None:
        return wrap_into_limits(raw.q, prep.limits, prep.prismatic)
    S = np.ascontiguousarray(raw.solutions, dtype=float).reshape(len(raw.solutions), -1)
    ref = np.ascontiguousarray(q_start, dtype=float)
    lim, prism = prep.memo("limit_arrays", lambda: (np.ascontiguousarray(prep.limits, dtype=float),
                                                    np.ascontiguousarray(prep.prismatic, dtype=np.bool_)))
    out, d = np.empty(ref.shape[0]), np.empty(len(S) + 1)
    best = nearest_of(np.ascontiguousarray(raw.q, dtype=float), S, ref, lim, prism, LIMIT_TOL, out, d)
    if best == 0 or (best > 0 and check(prep, T_goal, out, settings)[0]):
        return out
    for i in np.argsort(d, kind="stable"):  # (rare) the nearest other solution failed the check
        if i == best or not np.isfinite(d[i]):
            continue
        nearest_rep(np.asarray(raw.q if i == 0 else S[i - 1], dtype=float), ref, lim, prism, LIMIT_TOL, out)
        if i == 0 or check(prep, T_goal, out, settings)[0]:
            return out
    return wrap_into_limits(raw.q, prep.limits, prep.prismatic)


def finish(prep: Prepared, T_goal: np.ndarray, raw: Raw, settings: Settings, call_ns: int = 0,
           q_start: np.ndarray | None = None) -> IKResult:
    """Turn a kernel's raw output into the result: FK check, stop reason, limits, timings.

    Parameters
    ----------
    prep : Prepared
        The robot prepared for the solver.
    T_goal : ndarray, shape (4, 4) [working length unit]
        Goal pose.
    raw : Raw
        The kernel's output.
    settings : Settings
        Converted to the working unit.
    call_ns : int
        The whole call's duration so far [ns] (set again by the registry).
    q_start : ndarray, shape (n,) [rad | working length unit], optional
        The start (for an analytic method's choice under ``require_limits``).

    Returns
    -------
    IKResult

    Notes
    -----
    The stop reason, ``success``, the errors and the limit record come from one compiled rule,
    :func:`_result`, which :func:`finish_batch` and the analytic closed forms' fused public calls
    (``Solver.bind_call``, through :func:`finish_packed`) run too.
    """
    if settings.require_limits:
        q = _within_limit_choice(prep, T_goal, raw, settings, q_start)
    else:
        q = raw.q
        if type(q) is not np.ndarray or q.dtype != np.float64:
            q = np.asarray(q, dtype=float)
    F, prism = finish_args(prep)
    code, claimed, success, dp, ang, inside = _finish_one(F, prism, q, T_goal, CRITERION_CODE[settings.criterion],
                                                          settings.tol_pos, settings.tol_rot, settings.tol_dq,
                                                          int(raw.code), settings.require_limits)
    trace = raw.trace
    if trace is None:
        trace = np.full((1, TRACE_COLS), np.nan)
        trace[0, TRACE_DP] = dp
    elif len(trace) != raw.iterations + 1:
        trace = np.asarray(trace)[: raw.iterations + 1]
    # positional: a keyword call of the 15-field dataclass costs ~0.5 us more (Python 3.11), on every solve
    return IKResult(q, success, code, int(raw.iterations), trace,
                    raw.solve_ns * 1e-9, raw.ik_ns * 1e-9, dp, math.nan if settings.criterion == "position" else ang,
                    claimed, inside, call_ns * 1e-9, prep.unit, raw.solutions, raw.info)


def finish_args(prep: Prepared) -> tuple[np.ndarray, np.ndarray]:
    """``(F, prism)`` of :func:`_result` for ``prep`` (built once, kept on the prepared robot)."""
    fa = prep._finish_args
    if fa is None:
        fa = prep._finish_args = _finish_args(prep)
    return fa


def _finish_args(prep: Prepared) -> tuple[np.ndarray, np.ndarray]:
    """The check's model and the limits packed into one float array (fewer arguments = a cheaper
    compiled call): K (n+1, 8), axis (n, 3), offset (n,), limits (n, 2), then 8 floats of scratch."""
    K, axis, offset, prism = prep.check
    F = np.concatenate([K.ravel(), axis.ravel(), offset, prep.limits.ravel(), np.zeros(8)])
    return F, np.ascontiguousarray(prism)


@numba.njit(cache=True, inline="always")
def final_code(code, ok, dp, q, inside, require_limits):
    """The one result rule: the stop reason and success from the method's own stop ``code`` and the
    independent FK check (``ok``, ``dp``) of ``q``. A claimed success the check contradicts is
    FK_CHECK_FAILED; a NaN error from a non-finite joint value is NON_FINITE; under
    ``require_limits`` a success outside the limits is OUT_OF_LIMITS. Returns (code, claimed, success)."""
    claimed = code == SUCCESS
    if claimed and not ok:
        code = FK_CHECK_FAILED
    if dp != dp:  # a NaN error: a non-finite joint value (or goal)
        for j in range(q.shape[0]):
            if not math.isfinite(q[j]):
                code = NON_FINITE
                break
    if code == SUCCESS and require_limits and not inside:
        code = OUT_OF_LIMITS
    return code, claimed, claimed and ok and code == SUCCESS


@numba.njit(cache=True, inline="always")
def unpack_check(F, n):
    """(K (n+1, 8), axis (n, 3), offset (n,), limits (n, 2), scratch (8,)) views of :func:`_finish_args`'s array."""
    o1 = 8 * (n + 1)
    o2 = o1 + 3 * n
    o3 = o2 + n
    o4 = o3 + 2 * n
    return grid(F, n + 1, 8), grid(F[o1:], n, 3), F[o2:o3], grid(F[o3:], n, 2), F[o4:o4 + 8]


@numba.njit(cache=True, inline="always")
def _result(F, prism, q, Tg, crit, tol_pos, tol_rot, tol_dq, code, require_limits, buf):
    """Everything of a result but its packing, for one solution (every path's finish): the FK check, the
    joint-limit record and :func:`final_code`. Returns (code, claimed, success, |dp|, angle, within)."""
    K, axis, offset, _, _ = unpack_check(F, q.shape[0])
    dp, ang, t = pose_check(K, axis, offset, prism, q, Tg, buf)
    return _verdict(F, prism, q, crit, tol_pos, tol_rot, tol_dq, code, require_limits, dp, ang, t)


@numba.njit(cache=True, inline="always")
def _verdict(F, prism, q, crit, tol_pos, tol_rot, tol_dq, code, require_limits, dp, ang, t):
    """:func:`_result` from the check's errors (|dp|, angle, |t|) of ``q``."""
    limits = unpack_check(F, q.shape[0])[3]
    ok = meets_compiled(crit, tol_pos, tol_rot, tol_dq, dp, ang, t)
    inside = _within(q, limits, prism, LIMIT_TOL)
    code, claimed, success = final_code(code, ok, dp, q, inside, require_limits)
    return code, claimed, success, dp, ang, inside


@numba.njit(cache=True)
def _finish_one(F, prism, q, Tg, crit, tol_pos, tol_rot, tol_dq, code, require_limits):
    """:func:`_result` of one solution in one compiled call (``F``: :func:`_finish_args`, its scratch used)."""
    return _result(F, prism, q, Tg, crit, tol_pos, tol_rot, tol_dq, code, require_limits, unpack_check(F, q.shape[0])[4])


@numba.njit(cache=True, parallel=True)
def _finish_many(F, prism, Q, goals, crit, tol_pos, tol_rot, tol_dq, require_limits, code, claimed, success, dp, ang,
                 inside):
    """:func:`_result` for every row of ``Q`` (N, n) against ``goals`` (N, 4, 4); ``code`` (N,) in and out.

    The check runs 8 rows at a time (:func:`~pipeline.kinematics.fkcheck.pose_check8`, vector lanes), the
    rows past the last 8 one at a time: the same floats either way."""
    Fb, pb, Qb, gb = borrowed(F), borrowed(prism), borrowed(Q), borrowed(goals)  # no atomic counting per row
    N, n, chunk = Q.shape[0], Q.shape[1], 32
    K, axis, offset, _, _ = unpack_check(Fb, n)
    for c_ in numba.prange((N + chunk - 1) // chunk):  # work items of 32 rows, one scratch each
        W = np.empty(CHECK8_SCRATCH + 8 * n)
        E = np.empty((3, 8))
        Wb, Eb = borrowed(W), borrowed(E)
        hi = min(N, (c_ + 1) * chunk)
        for k8 in range(c_ * chunk, hi, 8):
            full = k8 + 8 <= hi
            if full:
                pose_check8(K, axis, offset, pb, Qb, gb, k8, Wb, Eb)
            for k in range(k8, min(hi, k8 + 8)):
                if full:
                    e0, e1, e2 = Eb[0, k - k8], Eb[1, k - k8], Eb[2, k - k8]
                else:
                    e0, e1, e2 = pose_check(K, axis, offset, pb, Qb[k], gb[k], Wb)
                c, cl, su, d, a, w = _verdict(Fb, pb, Qb[k], crit, tol_pos, tol_rot, tol_dq, code[k], require_limits,
                                              e0, e1, e2)
                code[k], claimed[k], success[k], dp[k], ang[k], inside[k] = c, cl, su, d, a, w
        # the work item's scratch read after its last borrowed use (numba frees a local after its last use)
        E[0, 0] = W[0]


# ---- the check packed for a fused call (an analytic solver's kernel, choice and check in one call) ----
C_CRIT, C_TOLP, C_TOLR, C_TOLDQ, C_F = 0, 1, 2, 3, 4  # criterion code, tolerances, then F (:func:`_finish_args`)


def fused_inputs(prep: Prepared, scaled: bool = True):
    """The input half of a fused closed-form call (``Solver.bind_call``): ``inputs(T_goal, q_start) ->
    (goal (4, 4), start (n,))``, both contiguous float64, the shapes checked (one-line SettingsError)
    as :meth:`pipeline.solvers.core.driver.Bound.solve` does; the goal in the working unit, or left in the
    robot file's unit when not ``scaled`` (a kernel that scales it itself)."""
    scale, working_goal, contiguous, shape = prep.goal_scale, prep.working_goal, np.ascontiguousarray, (prep.n,)
    if not scaled:
        scale = 1.0

    def inputs(T_goal, q_start):
        Tg = contiguous(T_goal, dtype=float) if scale == 1.0 else working_goal(T_goal)
        if Tg.shape != (4, 4):
            raise SettingsError(f"T_goal: expected shape (4, 4), got {Tg.shape}")
        q0 = contiguous(q_start, dtype=float)  # the kernels never write into the start
        if q0.shape != shape:
            raise SettingsError(f"q_start: expected shape {shape}, got {q0.shape}")
        return Tg, q0

    return inputs


def check_pack(prep: Prepared, settings: Settings) -> np.ndarray:
    """The success test, the FK check's model and the limits in one float array, for :func:`finish_packed`.

    ``[criterion code, tol_pos, tol_rot, tol_dq, F (see :func:`_finish_args`), prismatic flags as 1.0/0.0]``
    (``settings`` in the working unit). A kernel that runs the check inside its own compiled call
    takes this appended to its own packed parameters, so the check adds no argument to the call
    (numba's dispatch costs ~40 ns per array argument).
    """
    F, prism = finish_args(prep)
    head = [float(CRITERION_CODE[settings.criterion]), float(settings.tol_pos), float(settings.tol_rot),
            float(settings.tol_dq)]
    return np.concatenate([head, F, prism.astype(float)])


@numba.njit(cache=True, inline="always")
def check_fields(C, n):
    """The parts of one :func:`check_pack` array of an n-joint arm: (F (:func:`_finish_args`), prismatic
    flags (n,), criterion code, tol_pos, tol_rot, tol_dq)."""
    nf = 14 * n + 16  # len(F): K 8 (n + 1), axis 3 n, offset n, limits 2 n, scratch 8
    return C[C_F:C_F + nf], C[C_F + nf:C_F + nf + n], int(C[C_CRIT]), C[C_TOLP], C[C_TOLR], C[C_TOLDQ]


@numba.njit(cache=True, inline="always")
def finish_packed_limits(C, q, Tg, code):
    """:func:`finish_packed` under ``require_limits`` for a method without a solution set: each revolute
    joint of ``q`` first moved by whole turns into its limits where that fits, in place (the values of
    :func:`wrap_into_limits`, the generic path's choice for such a method)."""
    n = q.shape[0]
    F, prism, crit, tol_pos, tol_rot, tol_dq = check_fields(C, n)
    lim = unpack_check(F, n)[3]
    for i in range(n):
        lo, hi = lim[i, 0], lim[i, 1]
        if prism[i] != 0.0 or not math.isfinite(lo) or not math.isfinite(q[i]) or lo <= q[i] <= hi:
            continue
        w = lo + np.fmod(q[i] - lo, 2 * math.pi) % (2 * math.pi)  # C fmod, as math.fmod (numba has no math.fmod)
        if w <= hi:
            q[i] = w
    return _result(F, prism, q, Tg, crit, tol_pos, tol_rot, tol_dq, code, True, unpack_check(F, n)[4])


@numba.njit(cache=True, inline="always")
def finish_packed(C, q, Tg, code):
    """:func:`_result` (without ``require_limits``) from one :func:`check_pack` array, for a fused
    compiled call: (code, claimed, success, |dp|, angle, within)."""
    n = q.shape[0]
    F, prism, crit, tol_pos, tol_rot, tol_dq = check_fields(C, n)
    return _result(F, prism, q, Tg, crit, tol_pos, tol_rot, tol_dq, code, False, unpack_check(F, n)[4])
