"""Allocation-free hot loop of the Jacobian IK methods, and their batch form on every core.

The loop of 000 §3 (the four Jacobian methods), computed without allocating inside the loop
(``tests/solvers/core/test_fast_path.py`` holds its iterates to the same loop written with the numpy kinematics):

* forward kinematics multiplies the running 3x4 frame by each link in place, with the link's
  cos/sin alpha computed once per robot (:func:`lean_chain`), about 36 multiply-adds per link;
* the geometric Jacobian is written into a preallocated (6, n) array;
* the transpose, pseudoinverse and DLS steps form ``J J^T + lambda^2 I`` (6x6, lower half),
  factor it by Cholesky in place and solve two triangular systems; when the factor meets a
  non-positive pivot (``J J^T`` singular, pseudoinverse) the reference step
  (:func:`pipeline.solvers.kernels.pose.step`: LU, then the SVD pseudoinverse) takes over for that
  iteration. SDLS always uses the reference step (its SVD allocates, and it is not on the hot path
  of any study).

Flops of one 7-DoF DLS iteration (:func:`flops_per_iteration`; ``benchmarks/bench_fast.py``
reports achieved time against this floor): FK 7 x 36 + tool 36 = 288 plus 7 sin/cos pairs; Jacobian
7 x 9 = 63; pose error ~75; ``J J^T`` 21 x 7 x 2 = 294; Cholesky 6x6 ~ 91; two triangular solves 72;
``J^T y`` 84; update 7: 974 flops and 7 sin/cos pairs.

:func:`solve_batch` runs N problems with ``numba.prange``: each problem only reads shared inputs
and writes its own rows, so results do not depend on the number of threads.
"""

from __future__ import annotations

import math

import numba
import numpy as np

import pipeline.solvers.kernels.pose as _jit
from pipeline.solvers.kernels.kin import (CRIT_DQ_BODY, CRIT_DQ_NORM, LIM_OFF, LIM_REFLECT, NEVER, dh_joint,
                                          jacobian_at, now_ns, quat_from_rot, quat_relative,
                                          relative_translation_norm, rodrigues)
from pipeline.solvers.kernels.loop import error_row, iterate
from pipeline.solvers.kernels.specialise import closed_to
from pipeline.solvers.core import finish_packed, finish_packed_limits


def flops_per_iteration(n: int, method: str = "dls") -> int:
    """Floating-point operations of one iteration of ``method`` on an n-joint chain (a multiply-add
    counts 2; sin, cos, sqrt and atan2 are not counted here: the benchmark adds their measured cost).

    Common to every method: forward kinematics 36 n + 36 (the running 3x4 frame times each link,
    then the tool), the Jacobian 9 n, the pose error ~75 (two quaternions and their product). Then
    the step: transpose ``J^T e`` 12 n, ``J g`` 12 n, two dot products 24, scaling n; pseudoinverse and
    DLS ``J J^T`` (lower half) 21 x 2 n, Cholesky ~91, two triangular solves 72, ``J^T y`` 12 n.
    Every method adds the update n.
    """
    common = (36 * n + 36) + 9 * n + 75 + n
    if method == "jacobian_transpose":
        return common + 12 * n + 12 * n + 24 + n
    if method in ("pseudoinverse", "dls"):
        return common + 42 * n + 91 + 72 + 12 * n
    raise ValueError(f"no flop count for {method!r} (its step is the reference SVD code)")


def lean_chain(args: tuple) -> tuple:
    """``Prepared.args`` -> the lean kernels' chain tuple ``(form, a, ca, sa, d, offs, prism, base, tool)``."""
    a, alpha, d, offs, prism, form, base, tool = args
    if form == 2:
        ca, sa = alpha.copy(), np.zeros(1)  # general form: alpha holds the axes (see _kin.link_transform)
    else:
        ca, sa = np.cos(alpha), np.sin(alpha)
    return (int(form), a, np.ascontiguousarray(ca), np.ascontiguousarray(sa), d, offs, prism, base, tool)


@numba.njit(cache=True, inline="always")
def _mul_rows(C, l00, l01, l02, l03, l10, l11, l12, l13, l20, l21, l22, l23):
    """C (3, 4) := C @ L with L the 3x4 rows of a rigid transform (row 3 = 0 0 0 1), in place."""
    for r in range(3):
        c0, c1, c2, c3 = C[r, 0], C[r, 1], C[r, 2], C[r, 3]
        C[r, 0] = c0 * l00 + c1 * l10 + c2 * l20
        C[r, 1] = c0 * l01 + c1 * l11 + c2 * l21
        C[r, 2] = c0 * l02 + c1 * l12 + c2 * l22
        C[r, 3] = c0 * l03 + c1 * l13 + c2 * l23 + c3


# fk, _jacobian and _step are inlined into the loop at numba's level: 0.5 µs less per iiwa 14 search (13
# iterations; benchmarks/results/placo_paired.md) for about 4 s more CPU on the first call's compile
@numba.njit(cache=True, inline="always")
def fk(form, a, ca, sa, d, offs, prism, base, tool, q, axes, origins, T, C):
    """Tool pose into ``T`` (4, 4) (row 3 untouched), joint axes/origins into (n, 3); ``C`` (3, 4) scratch."""
    for r in range(3):
        for c in range(4):
            C[r, c] = base[r, c]
    n = q.shape[0]
    for i in range(n):
        if form == 2:
            o = 12 * i
            k0, k1, k2 = ca[3 * i], ca[3 * i + 1], ca[3 * i + 2]
            _mul_rows(C, a[o], a[o + 1], a[o + 2], a[o + 3], a[o + 4], a[o + 5], a[o + 6], a[o + 7],
                      a[o + 8], a[o + 9], a[o + 10], a[o + 11])
            if prism[i]:
                x = q[i]
                for r in range(3):
                    C[r, 3] += x * (C[r, 0] * k0 + C[r, 1] * k1 + C[r, 2] * k2)
            else:
                m00, m01, m02, m10, m11, m12, m20, m21, m22 = rodrigues(k0, k1, k2, q[i])
                _mul_rows(C, m00, m01, m02, 0.0, m10, m11, m12, 0.0, m20, m21, m22, 0.0)
            for r in range(3):
                axes[i, r] = C[r, 0] * k0 + C[r, 1] * k1 + C[r, 2] * k2
                origins[i, r] = C[r, 3]
            continue
        th, di = dh_joint(offs, d, prism, q, i)
        ct, st = math.cos(th), math.sin(th)
        cal, sal, ai = ca[i], sa[i], a[i]
        if form == 1:  # modified: Rx(alpha) Tx(a) Rz(theta) Tz(d); axis = z after Rx(alpha) Tx(a)
            for r in range(3):
                c0, c1, c2, c3 = C[r, 0], C[r, 1], C[r, 2], C[r, 3]
                u = c1 * cal + c2 * sal
                z = c2 * cal - c1 * sal
                axes[i, r] = z
                origins[i, r] = c0 * ai + c3
                C[r, 0] = c0 * ct + u * st
                C[r, 1] = u * ct - c0 * st
                C[r, 2] = z
                C[r, 3] = c0 * ai + z * di + c3
        else:  # standard: Rz(theta) Tz(d) Tx(a) Rx(alpha); axis = z before the link
            for r in range(3):
                c0, c1, c2, c3 = C[r, 0], C[r, 1], C[r, 2], C[r, 3]
                axes[i, r] = c2
                origins[i, r] = c3
                x0 = c0 * ct + c1 * st
                y0 = c1 * ct - c0 * st
                C[r, 0] = x0
                C[r, 1] = y0 * cal + c2 * sal
                C[r, 2] = c2 * cal - y0 * sal
                C[r, 3] = ai * x0 + c2 * di + c3
    for r in range(3):
        c0, c1, c2, c3 = C[r, 0], C[r, 1], C[r, 2], C[r, 3]
        for c in range(4):
            T[r, c] = c0 * tool[0, c] + c1 * tool[1, c] + c2 * tool[2, c]
        T[r, 3] += c3


@numba.njit(cache=True, inline="always")
def _jacobian(prism, axes, origins, T, J):
    """:func:`pipeline.solvers.kernels.kin.jacobian` at the effector position of ``T`` (4, 4)."""
    jacobian_at(prism, axes, origins, T[0, 3], T[1, 3], T[2, 3], J)


@numba.njit(cache=True, inline="always")
def _step(method, J, e, lam2, A, y, dq):
    """Transpose / pseudoinverse / DLS step into ``dq`` (n,); False when J J^T + lam2 I is not
    positive definite (the caller then uses the reference step)."""
    n = J.shape[1]
    if method == 0:  # g = J^T e; alpha = <e, J g> / |J g|^2 (eq. 48 of 000)
        for j in range(n):
            s = 0.0
            for r in range(6):
                s += J[r, j] * e[r]
            dq[j] = s
        num = 0.0
        den = 0.0
        for r in range(6):
            s = 0.0
            for j in range(n):
                s += J[r, j] * dq[j]
            num += e[r] * s
            den += s * s
        alpha = num / den if den > 0 else 0.0
        for j in range(n):
            dq[j] *= alpha
        return True
    for r in range(6):  # lower half of J J^T + lam2 I
        for c in range(r + 1):
            s = 0.0
            for j in range(n):
                s += J[r, j] * J[c, j]
            A[r, c] = s
        A[r, r] += lam2
    for c in range(6):  # Cholesky in place (lower); the diagonal holds 1 / L[c, c] (6 divisions, not 27)
        s = A[c, c]
        for k in range(c):
            s -= A[c, k] * A[c, k]
        if not s > 0.0:
            return False
        inv = 1.0 / math.sqrt(s)
        A[c, c] = inv
        for r in range(c + 1, 6):
            s = A[r, c]
            for k in range(c):
                s -= A[r, k] * A[c, k]
            A[r, c] = s * inv
    for r in range(6):  # L z = e
        s = e[r]
        for k in range(r):
            s -= A[r, k] * y[k]
        y[r] = s * A[r, r]
    for r in range(5, -1, -1):  # L^T y = z
        s = y[r]
        for k in range(r + 1, 6):
            s -= A[k, r] * y[k]
        y[r] = s * A[r, r]
    for j in range(n):
        s = 0.0
        for r in range(6):
            s += J[r, j] * y[r]
        dq[j] = s
    return True


@numba.njit(cache=True, inline="always")
def _into_box(q, fp):
    """Clamp ``q`` (n,) into the joint box held in ``fp`` (:data:`pipeline.solvers.kernels.pose.I_LIMITS`)."""
    n = q.shape[0]
    for j in range(n):
        q[j] = min(max(q[j], fp[_jit.N_FP + j]), fp[_jit.N_FP + n + j])


@numba.njit(cache=True, inline="always")
def _reflect_into_box(q, fp):
    """``search_limits = reflect``: a joint past a limit is mirrored at it (``2 hi - q`` or ``2 lo - q``: the
    search moves on instead of stalling on the limit as a clamp does), then clamped into the box (held in ``fp``, :data:`pipeline.solvers.kernels.pose.I_LIMITS`)."""
    n = q.shape[0]
    for j in range(n):
        lo, hi = fp[_jit.N_FP + j], fp[_jit.N_FP + n + j]
        x = q[j]
        if x > hi:
            x = 2.0 * hi - x
        elif x < lo:
            x = 2.0 * lo - x
        q[j] = min(max(x, lo), hi)


@numba.njit(cache=True, inline="always")
def _met(crit, err, dp, ang, fp):
    """The success test: ``err <= tol_dq`` (dq_norm criteria) or ``|dp| <= tol_pos`` and ``angle <= tol_rot``."""
    if crit == CRIT_DQ_NORM or crit == CRIT_DQ_BODY:
        return err <= fp[_jit.F_TOL_DQ]
    return dp <= fp[_jit.F_TOL_POS] and ang <= fp[_jit.F_TOL_ROT]


@numba.njit(cache=True, inline="always")
def _start(problem, q):
    """:func:`pipeline.solvers.kernels.loop.iterate`'s ``start``: the scratch, the first FK and error.

    State: ``(axes, origins, T, Tprev, C, J, e, A, y, dq, qg, qt, qp, m, clk)`` with ``qg`` the goal's
    quaternion (once per solve), ``qt``/``qp`` this and the previous iterate's, ``m`` = (error, |dp|). With
    ``search_limits`` on, the start is first clamped into the joint box.
    """
    form, a, ca, sa, d, offs, prism, base, tool, Tg, ip, fp = problem
    n = q.shape[0]
    if ip[_jit.I_LIMITS] != LIM_OFF:
        _into_box(q, fp)
    axes = np.empty((n, 3))
    origins = np.empty((n, 3))
    T = np.zeros((4, 4))
    T[3, 3] = 1.0
    Tprev = np.zeros((4, 4))
    Tprev[3, 3] = 1.0
    C = np.empty((3, 4))
    J = np.empty((6, n))
    e = np.empty(6)
    A = np.empty((6, 6))
    y = np.empty(6)
    dq = np.empty(n)
    qg = np.empty(4)
    qt = np.empty(4)
    qp = np.empty(4)
    m = np.empty(2)
    clk = np.zeros(2, np.int64)
    quat_from_rot(Tg, qg)
    fk(form, a, ca, sa, d, offs, prism, base, tool, q, axes, origins, T, C)
    err, dp, ang = _jit.pose_error_q(Tg, T, qg, qt, ip, fp, e)
    m[0], m[1] = err, dp
    ok = _met(ip[_jit.I_CRITERION], err, dp, ang, fp)
    return (axes, origins, T, Tprev, C, J, e, A, y, dq, qg, qt, qp, m, clk), err, ok, False


@numba.njit(cache=True, inline="always")
def _advance(problem, state, q, it):
    """``step``: the method's update (Cholesky fast path, else the reference step; with ``search_limits`` the
    iterate clamped or reflected into the joint box), FK, error and stall test."""
    form, a, ca, sa, d, offs, prism, base, tool, Tg, ip, fp = problem
    axes, origins, T, Tprev, C, J, e, A, y, dq, qg, qt, qp, m, clk = state
    n = q.shape[0]
    method = ip[_jit.I_METHOD]
    crit = ip[_jit.I_CRITERION]  # pipeline.solvers.kernels.kin.CRITERION_CODE
    time_ik = ip[_jit.I_TIME_IK] != 0
    lam = fp[_jit.F_LAMBDA] if method == 2 else 0.0
    _jacobian(prism, axes, origins, T, J)
    lim = ip[_jit.I_LIMITS]
    t0 = now_ns(clk) if time_ik else 0
    if method == 3 or not _step(method, J, e, lam * lam, A, y, dq):
        ref = _jit.step(method, J, e, ip, fp)
        for j in range(n):
            dq[j] = ref[j]
    t_ik = now_ns(clk) - t0 if time_ik else 0
    for j in range(n):
        q[j] += dq[j]
    if lim == LIM_REFLECT:
        _reflect_into_box(q, fp)
    elif lim != LIM_OFF:
        _into_box(q, fp)
    for r in range(3):
        for c in range(4):
            Tprev[r, c] = T[r, c]
    for k in range(4):
        qp[k] = qt[k]
    fk(form, a, ca, sa, d, offs, prism, base, tool, q, axes, origins, T, C)
    err, dp, ang = _jit.pose_error_q(Tg, T, qg, qt, ip, fp, e)
    m[0], m[1] = err, dp
    if crit == CRIT_DQ_NORM or crit == CRIT_DQ_BODY:
        if crit == CRIT_DQ_NORM:
            t = relative_translation_norm(T, Tprev)
        else:
            t = math.sqrt((T[0, 3] - Tprev[0, 3]) ** 2 + (T[1, 3] - Tprev[1, 3]) ** 2 + (T[2, 3] - Tprev[2, 3]) ** 2)
        stalled = math.sqrt(1.0 + 0.25 * t * t) < fp[_jit.F_STALL_DQ]
    else:
        dmove = math.sqrt((T[0, 3] - Tprev[0, 3]) ** 2 + (T[1, 3] - Tprev[1, 3]) ** 2 + (T[2, 3] - Tprev[2, 3]) ** 2)
        stalled = False
        if dmove < fp[_jit.F_STALL_POS]:  # the rotation only matters when the position stalled
            w, x, yy, z = quat_relative(qt, qp)
            stalled = 2.0 * math.atan2(math.sqrt(x * x + yy * yy + z * z), w) < fp[_jit.F_STALL_ROT]
    return err, _met(crit, err, dp, ang, fp), stalled and ip[_jit.I_NO_STALL] == 0, t_ik


@numba.njit(cache=True, inline="always")
def _record(problem, state, trace, row):
    """``record``: ``[error, e (6), |dp|]``."""
    m = state[13]
    error_row(trace, row, m[0], state[6], m[1])


@numba.njit(cache=True)
def solve(form, a, ca, sa, d, offs, prism, base, tool, Tg, q0, ip, fp, q, trace, times):
    """One problem of the Jacobian loop (000 §3; :func:`pipeline.solvers.kernels.loop.iterate` with this
    module's step; stop rule :func:`pipeline.solvers.kernels.kin.stop_rule` with ``disable_stall`` and
    ``disable_grow`` applied).

    Writes the solution into ``q`` (n,), trace rows ``0..iterations`` of ``trace`` (k, 8) (rows
    beyond its length are not written; it needs at least one row), and ``times`` (2,) = (total,
    IK block) [ns], or (3,) with the thread's CPU time over the total as well (two readings of a clock
    that costs a system call each: the batch only). Returns ``(stop code, iterations)``.
    """
    grow = ip[_jit.I_GROW_LIMIT] if ip[_jit.I_NO_GROW] == 0 else NEVER
    code, it, _ = iterate(_start, _advance, _record, (form, a, ca, sa, d, offs, prism, base, tool, Tg, ip, fp), q0, q,
                          trace, times, grow, ip[_jit.I_MAX_ITER])
    return code, it


def pack_checked(chain: tuple, ip: np.ndarray, fp: np.ndarray, C: np.ndarray, require_limits: bool):
    """The per-bind inputs of :func:`solve_checked` in two arrays ``(K, F)``, so that a call hands the
    kernel six arrays instead of eighteen arguments (numba's dispatch costs about 50 ns an argument,
    ~0.5 µs a call saved on the iiwa 14). ``chain`` = :func:`lean_chain`'s tuple, ``ip``/``fp`` the packed
    parameters, ``C`` a :func:`~pipeline.solvers.core.check_pack` array. ``K`` (int64) = ``ip``, then
    ``form``, ``require_limits``, the lengths of ``a, ca, sa, d, offs, fp, C``, ``prism`` (0/1 per joint)
    and last ``len(ip)``; ``F`` (float64) = ``a, ca, sa, d, offs``, ``base`` and ``tool`` (4 x 4, row-major),
    ``fp``, ``C``."""
    form, a, ca, sa, d, offs, prism, base, tool = chain
    if np.shape(base) != (4, 4) or np.shape(tool) != (4, 4):
        raise ValueError(f"lean chain: base and tool must be 4 x 4, got {np.shape(base)} and {np.shape(tool)}")
    flat = [np.ravel(np.asarray(x, dtype=float)) for x in (a, ca, sa, d, offs)]
    K = np.concatenate([ip, [int(form), int(bool(require_limits))], [len(x) for x in flat], [len(fp), len(C)],
                        np.asarray(prism, dtype=np.int64), [len(ip)]], dtype=np.int64)
    F = np.concatenate([*flat, np.ravel(base), np.ravel(tool), fp, C], dtype=float)
    return K, F  # new, C-contiguous and writable: the kernel's one signature


@numba.njit(cache=True, inline="always")
def _unpack_checked(K, F, n):
    """:func:`pack_checked`'s arrays back as views: (form, a, ca, sa, d, offs, prism, base, tool, ip, fp, C,
    require_limits); ``prism`` a new bool array (n,), every other array a view of ``K`` or ``F``."""
    li = K[K.shape[0] - 1]
    h = li + 2  # the seven lengths
    o = 0
    a = F[o:o + K[h]]
    o += K[h]
    ca = F[o:o + K[h + 1]]
    o += K[h + 1]
    sa = F[o:o + K[h + 2]]
    o += K[h + 2]
    d = F[o:o + K[h + 3]]
    o += K[h + 3]
    offs = F[o:o + K[h + 4]]
    o += K[h + 4]
    base = F[o:o + 16].reshape((4, 4))
    tool = F[o + 16:o + 32].reshape((4, 4))
    o += 32
    fp = F[o:o + K[h + 5]]
    o += K[h + 5]
    C = F[o:o + K[h + 6]]
    prism = np.empty(n, np.bool_)
    for j in range(n):
        prism[j] = K[h + 7 + j] != 0
    return K[li], a, ca, sa, d, offs, prism, base, tool, K[:li], fp, C, K[li + 1]


@numba.njit(cache=True)
def solve_checked(K, F, Tg, q0, q, trace):
    """The public single call in one compiled call: :func:`solve`, then the result rule of every finish
    (:func:`pipeline.solvers.core.finish_packed` on the :func:`~pipeline.solvers.core.check_pack` array:
    the independent FK check, the limit record, the stop reason), on :func:`pack_checked`'s ``(K, F)``.
    Returns (stop code, iterations, claimed, success, |dp| [working unit], angle [rad], within limits,
    solve time [ns], IK-block time [ns]) (the times as ints: no clock array for the caller to allocate and
    read); stop code -1 (and nothing written) when ``Tg`` is not (4, 4) or ``q0`` not shaped like ``q``. With
    ``require_limits``: :func:`pipeline.solvers.core.finish_packed_limits` (``q`` moved by turns into the
    limits, success only within them)."""
    if Tg.shape[0] != 4 or Tg.shape[1] != 4 or q0.shape[0] != q.shape[0]:
        return -1, 0, False, False, math.nan, math.nan, False, 0, 0
    form, a, ca, sa, d, offs, prism, base, tool, ip, fp, C, require_limits = _unpack_checked(K, F, q.shape[0])
    times = np.zeros(2, np.int64)  # two slots: no thread-CPU clock (a system call each read, ~0.45 µs)
    code, it = solve(form, a, ca, sa, d, offs, prism, base, tool, Tg, q0, ip, fp, q, trace, times)
    if require_limits:
        c, claimed, success, dp, ang, inside = finish_packed_limits(C, q, Tg, code)
    else:
        c, claimed, success, dp, ang, inside = finish_packed(C, q, Tg, code)
    return c, it, claimed, success, dp, ang, inside, times[0], times[1]


_F1, _F2 = numba.types.float64[::1], numba.types.float64[:, ::1]
CHECKED_SIGNATURE = (numba.types.int64[::1], _F1, _F2, _F1, _F1, _F2)


def checked_call():
    """:func:`solve_checked` compiled for :data:`CHECKED_SIGNATURE` only (C-contiguous arrays: the packed
    inputs, the goal, the start and the two outputs) and closed to any other: a caller hands it its
    arrays unchecked and converts them only on the TypeError any other array raises."""
    return closed_to(solve_checked, CHECKED_SIGNATURE)


@numba.njit(cache=True, parallel=True)
def solve_batch(form, a, ca, sa, d, offs, prism, base, tool, goals, starts, ip, fp, Q, codes, iters, times, traces):
    """:func:`solve` for every row: ``goals`` (N, 4, 4), ``starts`` (N, n) -> ``Q`` (N, n),
    ``codes``/``iters`` (N,), ``times`` (N, 3), ``traces`` (N, k, 8) (k >= 1; rows past k dropped)."""
    for i in numba.prange(goals.shape[0]):
        c, it = solve(form, a, ca, sa, d, offs, prism, base, tool, goals[i], starts[i], ip, fp, Q[i], traces[i], times[i])
        codes[i] = c
        iters[i] = it
