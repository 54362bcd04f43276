"""Compiled kinematics layer (numba, nopython) shared by every iterative IK method.

One transcription of :mod:`pipeline.kinematics` into scalar loops: forward kinematics of standard
and modified DH chains with prismatic joints and base/tool transforms (:func:`forward`, which also
returns the joint axes and origins for :func:`jacobian`), the geometric Jacobian, quaternion and
pose-error helpers, a thin SVD for small matrices, and the monotonic clock every kernel times its
solve with (:func:`now_ns`). ``tests/solvers/iterative/test_solvers.py`` checks these against the numpy reference.

Array arguments of a chain, in this order everywhere (see :class:`pipeline.solvers.core.Prepared`):
``a, alpha, d, offs, prism, modified, base, tool`` with shapes (n,), (n,), (n,), (n,), (n,) bool,
scalar bool, (4, 4), (4, 4); lengths in the solver's working unit, angles in rad.

Timing uses ``clock_gettime(CLOCK_MONOTONIC)`` called from compiled code (about 25 ns a call),
the same clock as Python's ``time.perf_counter_ns`` on Linux, so that a kernel-timed solve and a
solve timed around a Python call (:mod:`pipeline.solvers.core.timing`) mean the same thing.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from pipeline.io.layout import TRACE_COLS, StopReason

# ---- the one joint-limit tolerance -------------------------------------------------------------
LIMIT_TOL = 1e-6
"""[rad or length unit] A returned joint value counts as within its limits up to this far beyond them,
for every method alike. Peer libraries that keep joint values in float32 (TRAC-IK's KDL limits pass
through float32 in pytracik) return solutions on a limit rounded 5e-9 to 1e-7 beyond it; 1e-6 rad
(0.2 arc-second; 1 µm on a prismatic joint) admits them and is far below any encoder's resolution."""

# ---- the one table of codes the compiled kernels use -------------------------------------------
# Stop codes: the values of pipeline.io.layout.StopReason as plain ints (numba compiles a module
# global int as a constant; every method module imports these names, none defines its own).
SUCCESS, STALLED, DIVERGING, ITERATION_CAP, NON_FINITE, FK_CHECK_FAILED, NO_SOLUTION, OUT_OF_LIMITS = (
    int(StopReason.SUCCESS), int(StopReason.STALLED), int(StopReason.DIVERGING), int(StopReason.ITERATION_CAP),
    int(StopReason.NON_FINITE), int(StopReason.FK_CHECK_FAILED), int(StopReason.NO_SOLUTION),
    int(StopReason.OUT_OF_LIMITS))
# Success tests (Settings.criterion) as every compiled kernel and the FK check
# (pipeline.kinematics.fkcheck) take them: one integer code per criterion
CRITERIA = ("pos_orient", "position", "dq_norm", "dq_norm_body")
CRITERION_CODE = {c: i for i, c in enumerate(CRITERIA)}
CRIT_POS_ORIENT, CRIT_POSITION, CRIT_DQ_NORM, CRIT_DQ_BODY = (CRITERION_CODE[c] for c in CRITERIA)
# Joint limits inside a Jacobian-family search (the ``search_limits`` setting): off (the unconstrained
# iterates of the documents), clamp (each iterate clamped to the box), reflect (a joint past a limit is
# mirrored at it, then clamped). An active set and Chan & Dubey's weighted least norm were measured and
# dropped (benchmarks/results/limits_aware.md)
SEARCH_LIMITS = ("off", "clamp", "reflect")
LIM_OFF, LIM_CLAMP, LIM_REFLECT = range(3)
# Trace rows: TRACE_COLS columns (pipeline.io.layout.TRACE_COLUMNS), the last one |dp|
TRACE_DP = TRACE_COLS - 1
NEVER = 1 << 62  # a grow limit or iteration cap that is never reached


@numba.njit(cache=True)
def stop_rule(err, ok, stalled, grew, grow_limit, it, max_iter):
    """The stop rule of an iterative method after iteration ``it`` (000 §3.4; the order is ours: a
    converged step is never counted as a failure): 0 = go on, else the stop code. ``stalled``: the
    method's own stall test fired; ``grew``: iterations in a row whose error grew."""
    if not np.isfinite(err):
        return NON_FINITE
    if ok:
        return SUCCESS
    if stalled:
        return STALLED
    if grew >= grow_limit:
        return DIVERGING
    if it >= max_iter:
        return ITERATION_CAP
    return 0

# libc's clock_gettime, resolved by symbol name so that compiled functions can be cached on disk
_clock_gettime = types.ExternalFunction("clock_gettime", types.int32(types.int32, types.voidptr))
CLOCK_MONOTONIC = 1
CLOCK_THREAD_CPUTIME_ID = 3


@intrinsic
def _data_ptr(typingctx, arr):
    """``void*`` to an array's data (to hand a ``struct timespec`` buffer to libc)."""

    def codegen(context, builder, signature, args):
        ary = context.make_array(signature.args[0])(context, builder, args[0])
        return builder.bitcast(ary.data, cgutils.voidptr_t)

    return types.voidptr(arr), codegen


@intrinsic
def borrowed(typingctx, arr):
    """``arr`` as an array view that carries no reference count (its meminfo pointer null).

    numba increments and decrements an array's reference count atomically wherever an array
    enters a compiled function that is not inlined or a view of it is made; in a closed form's
    per-pose path those atomic operations cost about as much as the arithmetic. A borrowed view
    skips them. It is valid only while ``arr`` itself is alive: an argument of the calling
    function, or a local the function uses again after its last use of the view (numba frees a
    local right after its last use, so ``f(borrowed(local))`` would hand ``f`` freed memory). It
    must never be returned to Python.
    """

    def codegen(context, builder, signature, args):
        ary = context.make_array(signature.args[0])(context, builder, args[0])
        ary.meminfo = cgutils.get_null_value(ary.meminfo.type)
        return ary._getvalue()

    return arr(arr), codegen


@intrinsic
def grid(typingctx, arr, rows, cols):
    """The first ``rows * cols`` entries of the 1-D C-contiguous ``arr`` as a (rows, cols) C view.

    What ``arr[:rows * cols].reshape((rows, cols))`` gives, without numba's reshape, which calls a C
    helper to work out the strides (about 16 ns; a closed-form pose made 7 to 13 of them). The view
    shares ``arr``'s reference count (a borrowed ``arr`` gives a borrowed view); the caller keeps
    ``rows * cols`` within ``arr``'s length."""
    if not (isinstance(arr, types.Array) and arr.ndim == 1 and arr.layout == "C"
            and isinstance(rows, types.Integer) and isinstance(cols, types.Integer)):
        return None
    ret = arr.copy(ndim=2, layout="C")

    def codegen(context, builder, signature, args):
        from numba.core.imputils import impl_ret_borrowed
        from numba.np.arrayobj import populate_array

        src = context.make_array(signature.args[0])(context, builder, args[0])
        r = context.cast(builder, args[1], signature.args[1], types.intp)
        c = context.cast(builder, args[2], signature.args[2], types.intp)
        size = context.get_constant(types.intp, context.get_abi_sizeof(context.get_data_type(arr.dtype)))
        out = context.make_array(ret)(context, builder)
        populate_array(out, data=src.data, shape=cgutils.pack_array(builder, [r, c]),
                       strides=cgutils.pack_array(builder, [builder.mul(c, size), size]), itemsize=size,
                       meminfo=src.meminfo, parent=src.parent)
        return impl_ret_borrowed(context, builder, ret, out._getvalue())

    return ret(arr, rows, cols), codegen


@numba.njit(cache=True)
def now_ns(buf):
    """Monotonic clock in ns; ``buf`` is an int64 array (2,) used as ``struct timespec``."""
    _clock_gettime(CLOCK_MONOTONIC, _data_ptr(buf))
    return buf[0] * 1000000000 + buf[1]


@numba.njit(cache=True, inline="always")
def rodrigues(k0, k1, k2, angle):
    """Rows of the rotation about the unit axis (k0, k1, k2) by ``angle`` [rad] (Rodrigues), 9 floats."""
    c, s = np.cos(angle), np.sin(angle)
    v = 1.0 - c
    return (c + v * k0 * k0, v * k0 * k1 - s * k2, v * k0 * k2 + s * k1,
            v * k0 * k1 + s * k2, c + v * k1 * k1, v * k1 * k2 - s * k0,
            v * k0 * k2 - s * k1, v * k1 * k2 + s * k0, c + v * k2 * k2)


@numba.njit(cache=True, inline="always")
def dh_joint(offs, d, prism, q, i):
    """Joint ``i``'s DH angle and offset with its joint value added: ``(theta [rad], d [length])``, the
    value going to ``d`` for a prismatic joint and to ``theta`` for a revolute one."""
    th = offs[i]
    di = d[i]
    if prism[i]:
        di += q[i]
    else:
        th += q[i]
    return th, di


@numba.njit(cache=True)
def link_transform(a, alpha, d, offs, prism, modified, q, i, L):
    """Rows 0-2 of joint ``i``'s link transform into ``L`` (4, 4); returns (cos alpha_i, sin alpha_i).

    ``modified`` is the chain's form code (:attr:`pipeline.kinematics.Chain.form_code`; a bool
    works for the two DH forms). Standard DH (0): Rz(theta) Tz(d) Tx(a) Rx(alpha); modified DH (1):
    Rx(alpha) Tx(a) Rz(theta) Tz(d), with ``q[i]`` added to theta (revolute) or d (prismatic).
    General form (2): ``a`` holds rows 0-2 of every joint's origin transform, flattened (12 n,),
    ``alpha`` the unit joint axes (3 n,); the link is ``origin_i Rot(axis_i, q_i)`` (Rodrigues) or
    ``origin_i Trans(axis_i q_i)``; the returned pair is then (1, 0) and unused.
    Row 3 is left to the caller (0 0 0 1).
    """
    if modified == 2:
        o = 12 * i
        k0, k1, k2 = alpha[3 * i], alpha[3 * i + 1], alpha[3 * i + 2]
        if prism[i]:
            for r in range(3):
                L[r, 0], L[r, 1], L[r, 2] = a[o + 4 * r], a[o + 4 * r + 1], a[o + 4 * r + 2]
                L[r, 3] = a[o + 4 * r + 3] + q[i] * (L[r, 0] * k0 + L[r, 1] * k1 + L[r, 2] * k2)
        else:
            m00, m01, m02, m10, m11, m12, m20, m21, m22 = rodrigues(k0, k1, k2, q[i])
            for r in range(3):
                o0, o1, o2 = a[o + 4 * r], a[o + 4 * r + 1], a[o + 4 * r + 2]
                L[r, 0] = o0 * m00 + o1 * m10 + o2 * m20
                L[r, 1] = o0 * m01 + o1 * m11 + o2 * m21
                L[r, 2] = o0 * m02 + o1 * m12 + o2 * m22
                L[r, 3] = a[o + 4 * r + 3]
        return 1.0, 0.0
    th, di = dh_joint(offs, d, prism, q, i)
    ct, st = np.cos(th), np.sin(th)
    ca, sa = np.cos(alpha[i]), np.sin(alpha[i])
    if modified:
        L[0, 0], L[0, 1], L[0, 2], L[0, 3] = ct, -st, 0.0, a[i]
        L[1, 0], L[1, 1], L[1, 2], L[1, 3] = st * ca, ct * ca, -sa, -sa * di
        L[2, 0], L[2, 1], L[2, 2], L[2, 3] = st * sa, ct * sa, ca, ca * di
    else:
        L[0, 0], L[0, 1], L[0, 2], L[0, 3] = ct, -st * ca, st * sa, a[i] * ct
        L[1, 0], L[1, 1], L[1, 2], L[1, 3] = st, ct * ca, -ct * sa, a[i] * st
        L[2, 0], L[2, 1], L[2, 2], L[2, 3] = 0.0, sa, ca, di
    return ca, sa


@numba.njit(cache=True)
def forward(a, alpha, d, offs, prism, modified, base, tool, q, axes, origins, T):
    """Tool pose into ``T`` (4, 4); joint axes/origins into ``axes``/``origins`` (n, 3)."""
    n = q.shape[0]
    C = base.copy()
    L = np.empty((4, 4))
    L[3, 0], L[3, 1], L[3, 2], L[3, 3] = 0.0, 0.0, 0.0, 1.0
    for i in range(n):
        ca, sa = link_transform(a, alpha, d, offs, prism, modified, q, i, L)
        if modified == 2:
            # the axis is fixed by its own rotation: axis_i = R(C @ L) k_i, origin = p(C @ L)
            C = C @ L
            for r in range(3):
                axes[i, r] = C[r, 0] * alpha[3 * i] + C[r, 1] * alpha[3 * i + 1] + C[r, 2] * alpha[3 * i + 2]
                origins[i, r] = C[r, 3]
            continue
        if modified:
            # pre-transform Rx(alpha) Tx(a): the joint axis is z of C @ pre
            for r in range(3):
                axes[i, r] = C[r, 1] * (-sa) + C[r, 2] * ca
                origins[i, r] = C[r, 0] * a[i] + C[r, 3]
        else:
            for r in range(3):
                axes[i, r] = C[r, 2]
                origins[i, r] = C[r, 3]
        C = C @ L
    R = C @ tool
    for r in range(4):
        for c in range(4):
            T[r, c] = R[r, c]


@numba.njit(cache=True)
def jacobian(prism, axes, origins, p, J):
    """The geometric Jacobian ``J`` (6, n) (rows: linear [length/rad or 1], angular [1]) of the chain
    with joint axes ``axes`` (n, 3) through ``origins`` (n, 3) [length], at the effector position ``p``
    (3,) [length]; a prismatic joint (``prism`` (n,) bool) moves along its axis."""
    jacobian_at(prism, axes, origins, p[0], p[1], p[2], J)


@numba.njit(cache=True, inline="always")
def jacobian_at(prism, axes, origins, p0, p1, p2, J):
    """:func:`jacobian` at the effector position ``(p0, p1, p2)`` [length] (the one Jacobian loop)."""
    n = axes.shape[0]
    for i in range(n):
        z0, z1, z2 = axes[i, 0], axes[i, 1], axes[i, 2]
        if prism[i]:
            J[0, i], J[1, i], J[2, i] = z0, z1, z2
            J[3, i], J[4, i], J[5, i] = 0.0, 0.0, 0.0
        else:
            r0, r1, r2 = p0 - origins[i, 0], p1 - origins[i, 1], p2 - origins[i, 2]
            J[0, i] = z1 * r2 - z2 * r1
            J[1, i] = z2 * r0 - z0 * r2
            J[2, i] = z0 * r1 - z1 * r0
            J[3, i], J[4, i], J[5, i] = z0, z1, z2


@numba.njit(cache=True)
def quat_from_rot(T, q):
    """w-first unit quaternion of T[:3, :3] with w >= 0 (Shepperd)."""
    tr = T[0, 0] + T[1, 1] + T[2, 2]
    if tr >= T[0, 0] and tr >= T[1, 1] and tr >= T[2, 2]:
        q[0], q[1], q[2], q[3] = 1 + tr, T[2, 1] - T[1, 2], T[0, 2] - T[2, 0], T[1, 0] - T[0, 1]
    elif T[0, 0] >= T[1, 1] and T[0, 0] >= T[2, 2]:
        q[0], q[1], q[2], q[3] = T[2, 1] - T[1, 2], 1 + 2 * T[0, 0] - tr, T[0, 1] + T[1, 0], T[0, 2] + T[2, 0]
    elif T[1, 1] >= T[2, 2]:
        q[0], q[1], q[2], q[3] = T[0, 2] - T[2, 0], T[0, 1] + T[1, 0], 1 + 2 * T[1, 1] - tr, T[1, 2] + T[2, 1]
    else:
        q[0], q[1], q[2], q[3] = T[1, 0] - T[0, 1], T[0, 2] + T[2, 0], T[1, 2] + T[2, 1], 1 + 2 * T[2, 2] - tr
    inv = 1.0 / np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])  # one division, not four
    if q[0] < 0:
        inv = -inv
    for k in range(4):
        q[k] *= inv


@numba.njit(cache=True)
def quat_relative(qa, qb):
    """(w, x, y, z) of ``q_a q_b*`` with w >= 0 (unit quaternions, w-first)."""
    w = qa[0] * qb[0] + qa[1] * qb[1] + qa[2] * qb[2] + qa[3] * qb[3]
    x = -qa[0] * qb[1] + qa[1] * qb[0] - qa[2] * qb[3] + qa[3] * qb[2]
    y = -qa[0] * qb[2] + qa[1] * qb[3] + qa[2] * qb[0] - qa[3] * qb[1]
    z = -qa[0] * qb[3] - qa[1] * qb[2] + qa[2] * qb[1] + qa[3] * qb[0]
    if w < 0:
        return -w, -x, -y, -z
    return w, x, y, z


@numba.njit(cache=True)
def relative_rotation(Ta, Tb, qa, qb):
    """Vector part and w of ``q_a q_b*`` with w >= 0; returns (w, x, y, z)."""
    quat_from_rot(Ta, qa)
    quat_from_rot(Tb, qb)
    return quat_relative(qa, qb)


@numba.njit(cache=True)
def relative_translation_norm(Ta, Tb):
    """|t| of ``T_a T_b^-1``: ``p_a - R_a R_b^T p_b``."""
    s = 0.0
    for r in range(3):
        acc = Ta[r, 3]
        for k in range(3):
            # (R_a R_b^T p_b)_r = sum_k R_a[r,k] (R_b^T p_b)_k
            rbtp = Tb[0, k] * Tb[0, 3] + Tb[1, k] * Tb[1, 3] + Tb[2, k] * Tb[2, 3]
            acc -= Ta[r, k] * rbtp
        s += acc * acc
    return np.sqrt(s)


@numba.njit(cache=True)
def vec_norm(x, kind):
    if kind == 0:
        return np.max(np.abs(x))
    if kind == 1:
        return np.sum(np.abs(x))
    return np.sqrt(np.sum(x * x))


@numba.njit(cache=True)
def small_svd(J):
    """Thin SVD of a small matrix by one-sided Jacobi rotations (Hestenes).

    Same contract as ``np.linalg.svd(J, full_matrices=False)``: ``U`` (m, k), ``S`` (k,) in
    descending order, ``Vt`` (k, n), k = min(m, n); singular vectors of zero singular values are
    zero. For the 6 x 7 Jacobians here this costs about a microsecond, where the LAPACK call
    spends most of its time on workspace handling, so that the SVD methods' timings reflect the
    method. Checked against numpy in tests/solvers/iterative/test_solvers.py.
    """
    m, n = J.shape
    tall = m > n
    A = J.copy() if tall else J.T.copy()  # rotate the k columns of A (r x k)
    r, k = A.shape
    W = np.eye(k)
    for _ in range(60):
        rotated = False
        for p in range(k - 1):
            for q in range(p + 1, k):
                alpha = 0.0
                beta = 0.0
                gamma = 0.0
                for i in range(r):
                    alpha += A[i, p] * A[i, p]
                    beta += A[i, q] * A[i, q]
                    gamma += A[i, p] * A[i, q]
                if gamma == 0.0 or abs(gamma) <= 1e-15 * np.sqrt(alpha * beta):
                    continue
                rotated = True
                zeta = (beta - alpha) / (2.0 * gamma)
                t = (1.0 if zeta >= 0 else -1.0) / (abs(zeta) + np.sqrt(1.0 + zeta * zeta))
                c = 1.0 / np.sqrt(1.0 + t * t)
                sn = c * t
                for i in range(r):
                    ap, aq = A[i, p], A[i, q]
                    A[i, p] = c * ap - sn * aq
                    A[i, q] = sn * ap + c * aq
                for i in range(k):
                    wp, wq = W[i, p], W[i, q]
                    W[i, p] = c * wp - sn * wq
                    W[i, q] = sn * wp + c * wq
        if not rotated:
            break
    norms = np.empty(k)
    for j in range(k):
        norms[j] = np.sqrt(np.sum(A[:, j] * A[:, j]))
    order = np.argsort(-norms)
    S = norms[order]
    Ua = np.zeros((r, k))  # normalised columns of A: the "other side" singular vectors
    for jj in range(k):
        j = order[jj]
        if norms[j] > 0.0:
            Ua[:, jj] = A[:, j] / norms[j]
    Wo = W[:, order]
    if tall:
        return Ua, S, Wo.T.copy()  # J W = Ua S  ->  J = Ua S W^T
    return Wo, S, Ua.T.copy()  # J^T W = Ua S  ->  J = W S Ua^T


@numba.njit(cache=True)
def forward_pose(a, alpha, d, offs, prism, modified, base, tool, q, T):
    """Tool pose only, into ``T`` (4, 4) (no axes: cheaper for derivative-free methods).

    Allocation-light: two 4 x 4 scratch arrays, the product of rigid transforms taken over their
    top three rows (the last row is 0 0 0 1).
    """
    C = np.empty((4, 4))
    L = np.empty((4, 4))
    for r in range(4):
        for c in range(4):
            C[r, c] = base[r, c]
    n = q.shape[0]
    for i in range(n + 1):
        if i < n:
            link_transform(a, alpha, d, offs, prism, modified, q, i, L)
        else:
            for r in range(3):
                for c in range(4):
                    L[r, c] = tool[r, c]
        for r in range(3):  # T = C @ L over the top three rows
            c0, c1, c2, c3 = C[r, 0], C[r, 1], C[r, 2], C[r, 3]
            for c in range(4):
                T[r, c] = c0 * L[0, c] + c1 * L[1, c] + c2 * L[2, c]
            T[r, 3] += c3
        for r in range(3):
            for c in range(4):
                C[r, c] = T[r, c]
    T[3, 0], T[3, 1], T[3, 2], T[3, 3] = 0.0, 0.0, 0.0, 1.0


@numba.njit(cache=True)
def rotation_angle(Ta, Tb):
    """Angle [rad] of the rotation between the orientations of ``Ta`` and ``Tb`` (4, 4)."""
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    tr = 0.0
    # R = Ra Rb^T
    R = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            R[i, j] = Ta[i, 0] * Tb[j, 0] + Ta[i, 1] * Tb[j, 1] + Ta[i, 2] * Tb[j, 2]
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    s0 = R[2, 1] - R[1, 2]
    s1 = R[0, 2] - R[2, 0]
    s2 = R[1, 0] - R[0, 1]
    return np.arctan2(0.5 * np.sqrt(s0 * s0 + s1 * s1 + s2 * s2), 0.5 * (tr - 1.0))


@numba.njit(cache=True)
def meets(crit, Tg, T, tol_pos, tol_rot, tol_dq):
    """The success test of :func:`pipeline.solvers.core.meets` on a compiled pose ``T`` (4, 4).

    ``crit`` is :data:`CRITERION_CODE` ``[criterion]``;
    tolerances in the working unit, with the same slack as the independent FK check.
    """
    dp = position_distance(Tg, T)
    if not np.isfinite(dp):
        return False
    if crit == CRIT_POSITION:
        return dp <= tol_pos * (1 + 1e-9)
    if crit == CRIT_DQ_BODY:
        return np.sqrt(1 + dp * dp / 4) <= tol_dq * (1 + 1e-12)
    if crit == CRIT_DQ_NORM:
        t = relative_translation_norm(Tg, T)
        return np.sqrt(1 + t * t / 4) <= tol_dq * (1 + 1e-12)
    ang = rotation_angle(Tg, T)
    return np.isfinite(ang) and dp <= tol_pos * (1 + 1e-9) and ang <= tol_rot * (1 + 1e-9)


@numba.njit(cache=True)
def position_distance(Ta, Tb):
    """|p_a - p_b| of two poses (4, 4)."""
    x = Ta[0, 3] - Tb[0, 3]
    y = Ta[1, 3] - Tb[1, 3]
    z = Ta[2, 3] - Tb[2, 3]
    return np.sqrt(x * x + y * y + z * z)


@numba.njit(cache=True)
def thread_cpu_ns(buf):
    """The calling thread's CPU time in ns (``CLOCK_THREAD_CPUTIME_ID``; ``buf``: int64 (2,); a system
    call, about 0.2 µs): what machine load does not move, since time the thread waits for a core is
    not counted. Read around a solve beside its monotonic solve time, never instead of it."""
    _clock_gettime(CLOCK_THREAD_CPUTIME_ID, _data_ptr(buf))
    return buf[0] * 1000000000 + buf[1]


@numba.njit(cache=True)
def rotation_vector(Ta, Tb, qa, qb, out):
    """Rotation vector (unit axis times angle, angle in [0, pi]) of ``R_a R_b^T`` into ``out`` (3,).

    Returns the angle [rad]. ``qa``, ``qb`` are (4,) scratch. For small angles it is the angular
    displacement that takes orientation b to orientation a, in the base frame.
    """
    w, x, y, z = relative_rotation(Ta, Tb, qa, qb)
    s = np.sqrt(x * x + y * y + z * z)
    angle = 2.0 * np.arctan2(s, w)
    g = angle / s if s > 1e-300 else 2.0
    out[0], out[1], out[2] = g * x, g * y, g * z
    return angle


# ---- whole-chain FK over a batch (the host speed comparison of 003: HTM vs dual quaternions) ----
@numba.njit(cache=True)
def fk_htm_batch(a, alpha, d, off, prism, modified, Q, out):
    """Tip positions (B, 3) into ``out`` of the bare chain (no base or tool) at each row of ``Q`` (B, n).

    The general homogeneous-matrix chain: full 4 x 4 link products in scalar loops (the work counted
    by mariano2019 with ``general=True``), the batch loop inside the kernel so that a per-FK time
    excludes the Python call.
    """
    n = a.shape[0]
    T = np.empty((4, 4))
    L = np.empty((4, 4))
    C = np.empty((4, 4))
    L[3, 0], L[3, 1], L[3, 2], L[3, 3] = 0.0, 0.0, 0.0, 1.0
    for b in range(Q.shape[0]):
        q = Q[b]
        for i in range(n):
            link_transform(a, alpha, d, off, prism, modified, q, i, L)
            if i == 0:
                T[:, :] = L
            else:
                for r in range(4):
                    for c in range(4):
                        s = T[r, 0] * L[0, c]
                        for k in range(1, 4):
                            s += T[r, k] * L[k, c]
                        C[r, c] = s
                T[:, :] = C
        out[b, 0] = T[0, 3]
        out[b, 1] = T[1, 3]
        out[b, 2] = T[2, 3]


@numba.njit(cache=True)
def _qmul(p0, p1, p2, p3, q0, q1, q2, q3):
    return (p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3,
            p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2,
            p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1,
            p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0)


@numba.njit(cache=True)
def fk_dq_batch(a, alpha, d, off, prism, modified, Q, out):
    """As :func:`fk_htm_batch` with the chain as a product of unit dual quaternions (w-first; 003 eqs. 9-14)."""
    n = a.shape[0]
    P = np.empty(8)
    L = np.empty(8)
    for b in range(Q.shape[0]):
        for i in range(n):
            th = off[i] if prism[i] else Q[b, i] + off[i]
            di = d[i] + Q[b, i] if prism[i] else d[i]
            ct, st = np.cos(0.5 * th), np.sin(0.5 * th)
            ca, sa = np.cos(0.5 * alpha[i]), np.sin(0.5 * alpha[i])
            if modified:
                r0, r1, r2, r3 = ca * ct, sa * ct, -sa * st, ca * st
                sal, cal = 2.0 * sa * ca, ca * ca - sa * sa
                t1, t2, t3 = a[i], -sal * di, cal * di
                e0, e1, e2, e3 = _qmul(0.0, t1, t2, t3, r0, r1, r2, r3)
                L[0] = r0; L[1] = r1; L[2] = r2; L[3] = r3
                L[4] = 0.5 * e0; L[5] = 0.5 * e1; L[6] = 0.5 * e2; L[7] = 0.5 * e3
            else:
                a2, d2 = 0.5 * a[i], 0.5 * di
                cc, sc, ss, cs = ca * ct, sa * ct, sa * st, ca * st
                L[0] = cc; L[1] = sc; L[2] = ss; L[3] = cs
                L[4] = -a2 * sc - d2 * cs; L[5] = a2 * cc - d2 * ss
                L[6] = a2 * cs + d2 * sc; L[7] = -a2 * ss + d2 * cc
            if i == 0:
                P[:] = L
            else:
                r = _qmul(P[0], P[1], P[2], P[3], L[0], L[1], L[2], L[3])
                x = _qmul(P[0], P[1], P[2], P[3], L[4], L[5], L[6], L[7])
                y = _qmul(P[4], P[5], P[6], P[7], L[0], L[1], L[2], L[3])
                P[0] = r[0]; P[1] = r[1]; P[2] = r[2]; P[3] = r[3]
                P[4] = x[0] + y[0]; P[5] = x[1] + y[1]; P[6] = x[2] + y[2]; P[7] = x[3] + y[3]
        q1, q2, q3, q4, q5, q6, q7, q8 = P[0], P[1], P[2], P[3], P[4], P[5], P[6], P[7]
        out[b, 0] = 2.0 * (-q2 * q5 + q1 * q6 - q4 * q7 + q3 * q8)
        out[b, 1] = 2.0 * (-q3 * q5 + q4 * q6 + q1 * q7 - q2 * q8)
        out[b, 2] = 2.0 * (-q4 * q5 - q3 * q6 + q2 * q7 + q1 * q8)
