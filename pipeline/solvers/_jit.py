"""Compiled hot path of the Jacobian IK methods (numba, nopython).

Everything here is a straight transcription of :mod:`pipeline.kinematics` (standard/modified
DH, geometric Jacobian, quaternion errors) into scalar loops so that a solve's time reflects the
method and not interpreter overhead. ``tests/test_solvers.py`` checks these kernels against the
numpy reference on random chains.

Timing uses ``clock_gettime(CLOCK_MONOTONIC)`` called from compiled code (about 25 ns a call),
so the IK-block time of one iteration can be measured on its own.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

# libc's clock_gettime, resolved by symbol name so that compiled functions can be cached on disk
_clock_gettime = types.ExternalFunction("clock_gettime", types.int32(types.int32, types.voidptr))
CLOCK_MONOTONIC = 1


@intrinsic
def _data_ptr(typingctx, arr):
    """``void*`` to an array's data (to hand a ``struct timespec`` buffer to libc)."""

    def codegen(context, builder, signature, args):
        ary = context.make_array(signature.args[0])(context, builder, args[0])
        return builder.bitcast(ary.data, cgutils.voidptr_t)

    return types.voidptr(arr), codegen

# integer parameter slots -------------------------------------------------------------------
I_METHOD, I_MAX_ITER, I_CRITERION, I_ORIENT, I_GROW_LIMIT, I_SDLS_NORM, I_SDLS_BLOCKS, I_NO_STALL, I_NO_GROW = range(9)
N_IP = 9
# float parameter slots
F_LAMBDA, F_GAMMA_MAX, F_TOL_DQ, F_STALL_DQ, F_TOL_POS, F_TOL_ROT, F_STALL_POS, F_STALL_ROT, F_ORIENT_GAIN = range(9)
N_FP = 9

METHODS = {"jacobian_transpose": 0, "pseudoinverse": 1, "dls": 2, "sdls": 3}
CRITERIA = {"dq_norm": 0, "pos_orient": 1, "dq_norm_body": 2}
ORIENT_ERRORS = {"quat_vec": 0, "axis_angle": 1}
NORMS = {"maxabs": 0, "one": 1, "two": 2}

# stop codes (000_7e3cb7ad5ee98ff0.txt §3.4), plus two of ours
SUCCESS, STALLED, DIVERGING, ITERATION_CAP, NON_FINITE, FK_CHECK_FAILED = 1, 2, 3, 4, 5, 6
TRACE_COLS = 8  # scalar error, e (6), position error norm


@numba.njit(cache=True)
def now_ns(buf):
    """Monotonic clock in ns; ``buf`` is an int64 array (2,) used as ``struct timespec``."""
    _clock_gettime(CLOCK_MONOTONIC, _data_ptr(buf))
    return buf[0] * 1000000000 + buf[1]


@numba.njit(cache=True)
def forward(a, alpha, d, offs, prism, modified, base, tool, q, axes, origins, T):
    """Tool pose into ``T`` (4, 4); joint axes/origins into ``axes``/``origins`` (n, 3)."""
    n = q.shape[0]
    C = base.copy()
    L = np.empty((4, 4))
    for i in range(n):
        th = offs[i]
        di = d[i]
        if prism[i]:
            di += q[i]
        else:
            th += q[i]
        ct, st = np.cos(th), np.sin(th)
        ca, sa = np.cos(alpha[i]), np.sin(alpha[i])
        if modified:
            # pre-transform Rx(alpha) Tx(a): the joint axis is z of C @ pre
            L[0, 0], L[0, 1], L[0, 2], L[0, 3] = ct, -st, 0.0, a[i]
            L[1, 0], L[1, 1], L[1, 2], L[1, 3] = st * ca, ct * ca, -sa, -sa * di
            L[2, 0], L[2, 1], L[2, 2], L[2, 3] = st * sa, ct * sa, ca, ca * di
            for r in range(3):
                axes[i, r] = C[r, 1] * (-sa) + C[r, 2] * ca
                origins[i, r] = C[r, 0] * a[i] + C[r, 3]
        else:
            L[0, 0], L[0, 1], L[0, 2], L[0, 3] = ct, -st * ca, st * sa, a[i] * ct
            L[1, 0], L[1, 1], L[1, 2], L[1, 3] = st, ct * ca, -ct * sa, a[i] * st
            L[2, 0], L[2, 1], L[2, 2], L[2, 3] = 0.0, sa, ca, di
            for r in range(3):
                axes[i, r] = C[r, 2]
                origins[i, r] = C[r, 3]
        L[3, 0], L[3, 1], L[3, 2], L[3, 3] = 0.0, 0.0, 0.0, 1.0
        C = C @ L
    R = C @ tool
    for r in range(4):
        for c in range(4):
            T[r, c] = R[r, c]


@numba.njit(cache=True)
def jacobian(prism, axes, origins, p, J):
    n = axes.shape[0]
    for i in range(n):
        z0, z1, z2 = axes[i, 0], axes[i, 1], axes[i, 2]
        if prism[i]:
            J[0, i], J[1, i], J[2, i] = z0, z1, z2
            J[3, i], J[4, i], J[5, i] = 0.0, 0.0, 0.0
        else:
            r0, r1, r2 = p[0] - origins[i, 0], p[1] - origins[i, 1], p[2] - origins[i, 2]
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
    s = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if q[0] < 0:
        s = -s
    for k in range(4):
        q[k] /= s


@numba.njit(cache=True)
def relative_rotation(Ta, Tb, qa, qb):
    """Vector part and w of ``q_a q_b*`` with w >= 0; returns (w, x, y, z)."""
    quat_from_rot(Ta, qa)
    quat_from_rot(Tb, qb)
    w = qa[0] * qb[0] + qa[1] * qb[1] + qa[2] * qb[2] + qa[3] * qb[3]
    x = -qa[0] * qb[1] + qa[1] * qb[0] - qa[2] * qb[3] + qa[3] * qb[2]
    y = -qa[0] * qb[2] + qa[1] * qb[3] + qa[2] * qb[0] - qa[3] * qb[1]
    z = -qa[0] * qb[3] - qa[1] * qb[2] + qa[2] * qb[1] + qa[3] * qb[0]
    if w < 0:
        w, x, y, z = -w, -x, -y, -z
    return w, x, y, z


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
def pose_error(Tg, T, ip, fp, qa, qb, e):
    """Fill the 6-vector ``e`` (v, omega); return (scalar error, |dp|, rotation angle)."""
    for r in range(3):
        e[r] = Tg[r, 3] - T[r, 3]
    w, x, y, z = relative_rotation(Tg, T, qa, qb)
    s = np.sqrt(x * x + y * y + z * z)
    angle = 2.0 * np.arctan2(s, w)
    if ip[I_ORIENT] == 1 and s > 1e-300:
        g = angle / s
    elif ip[I_ORIENT] == 1:
        g = 2.0
    else:
        g = fp[F_ORIENT_GAIN]
    e[3], e[4], e[5] = g * x, g * y, g * z
    dp = np.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    if ip[I_CRITERION] == 0:
        t = relative_translation_norm(Tg, T)
        err = np.sqrt(1.0 + 0.25 * t * t)
    elif ip[I_CRITERION] == 2:
        # Q* Q_goal: its translation is R^T (p_goal - p), so the norm sees position only
        err = np.sqrt(1.0 + 0.25 * dp * dp)
    else:
        err = np.sqrt(dp * dp + e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
    return err, dp, angle


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
    method. Checked against numpy in tests/test_solvers.py.
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
def step(method, J, e, ip, fp):
    """One IK functional block: joint update for error ``e`` (6,) and Jacobian ``J`` (6, n)."""
    if method == 0:  # Jacobian transpose, adaptive alpha (eq. 48 of 000)
        g = J.T @ e
        jjte = J @ g
        den = np.dot(jjte, jjte)
        alpha = np.dot(e, jjte) / den if den > 0 else 0.0
        return alpha * g
    if method == 1:  # pseudoinverse, eq. 49 of 000: J^T (J J^T)^-1 e
        A = J @ J.T
        try:
            return J.T @ np.linalg.solve(A, e)
        except Exception:  # J J^T singular: Moore-Penrose through the SVD
            U, S, Vt = small_svd(J)
            tol = max(J.shape[0], J.shape[1]) * S[0] * 2.220446049250313e-16
            ue = U.T @ e
            out = np.zeros(J.shape[1])
            for i in range(S.shape[0]):
                if S[i] > tol:
                    out += (ue[i] / S[i]) * Vt[i]
            return out
    if method == 2:  # damped least squares (eq. 50 of 000)
        lam = fp[F_LAMBDA]
        A = J @ J.T
        for i in range(A.shape[0]):
            A[i, i] += lam * lam
        return J.T @ np.linalg.solve(A, e)
    # selectively damped least squares (Buss & Kim 2004; eqs. 56-61 of 000)
    gmax = fp[F_GAMMA_MAX]
    kind = ip[I_SDLS_NORM]
    blocks = ip[I_SDLS_BLOCKS]
    U, S, Vt = small_svd(J)
    n = J.shape[1]
    rho = np.empty(n)  # per-joint sum over end-effector blocks of |dS/dtheta_j|
    for j in range(n):
        if blocks == 2:
            rho[j] = np.sqrt(J[0, j] ** 2 + J[1, j] ** 2 + J[2, j] ** 2) + np.sqrt(J[3, j] ** 2 + J[4, j] ** 2 + J[5, j] ** 2)
        else:
            rho[j] = np.sqrt(np.sum(J[:, j] ** 2))
    out = np.zeros(n)
    tol = max(J.shape[0], n) * S[0] * 2.220446049250313e-16
    for i in range(S.shape[0]):
        if S[i] <= tol:
            continue
        u = U[:, i]
        alpha_i = np.dot(u, e)
        if blocks == 2:
            N = np.sqrt(u[0] ** 2 + u[1] ** 2 + u[2] ** 2) + np.sqrt(u[3] ** 2 + u[4] ** 2 + u[5] ** 2)
        else:
            N = np.sqrt(np.sum(u * u))
        M = np.sum(np.abs(Vt[i]) * rho) / S[i]
        gamma = gmax * min(1.0, N / M)
        phi = (alpha_i / S[i]) * Vt[i]
        m = vec_norm(phi, kind)
        if m > gamma:
            phi = phi * (gamma / m)
        out += phi
    m = vec_norm(out, kind)
    if m > gmax:
        out = out * (gmax / m)
    return out


@numba.njit(cache=True)
def solve_one(a, alpha, d, offs, prism, modified, base, tool, Tg, q0, ip, fp, q, trace, times):
    """Run one IK problem.

    Writes the solution into ``q`` (n,), the per-iteration trace into ``trace`` rows
    ``0..iterations`` (scalar error, e(6), |dp|), and into ``times`` (3,) the total, IK-block and
    FK+Jacobian+error times in ns. Returns ``(stop_code, iterations)``.
    """
    clk = np.zeros(2, np.int64)
    t_start = now_ns(clk)
    n = q0.shape[0]
    for i in range(n):
        q[i] = q0[i]
    axes = np.empty((n, 3))
    origins = np.empty((n, 3))
    T = np.empty((4, 4))
    Tprev = np.empty((4, 4))
    J = np.empty((6, n))
    e = np.empty(6)
    qa = np.empty(4)
    qb = np.empty(4)
    p = np.empty(3)
    method = ip[I_METHOD]
    max_iter = ip[I_MAX_ITER]
    crit = ip[I_CRITERION]
    forward(a, alpha, d, offs, prism, modified, base, tool, q, axes, origins, T)
    err, dp, ang = pose_error(Tg, T, ip, fp, qa, qb, e)
    trace[0, 0] = err
    trace[0, 1:7] = e
    trace[0, 7] = dp
    t_ik = 0
    code = 0
    it = 0
    grew = 0
    if not np.isfinite(err):
        code = NON_FINITE
    elif (crit != 1 and err <= fp[F_TOL_DQ]) or (crit == 1 and dp <= fp[F_TOL_POS] and ang <= fp[F_TOL_ROT]):
        code = SUCCESS
    while code == 0:
        it += 1
        for r in range(3):
            p[r] = T[r, 3]
        jacobian(prism, axes, origins, p, J)
        t0 = now_ns(clk)
        dq = step(method, J, e, ip, fp)
        t_ik += now_ns(clk) - t0
        for i in range(n):
            q[i] += dq[i]
        Tprev[:, :] = T
        forward(a, alpha, d, offs, prism, modified, base, tool, q, axes, origins, T)
        prev_err = err
        err, dp, ang = pose_error(Tg, T, ip, fp, qa, qb, e)
        trace[it, 0] = err
        trace[it, 1:7] = e
        trace[it, 7] = dp
        if crit == 0 or crit == 2:
            if crit == 0:
                t = relative_translation_norm(T, Tprev)
            else:
                t = np.sqrt((T[0, 3] - Tprev[0, 3]) ** 2 + (T[1, 3] - Tprev[1, 3]) ** 2 + (T[2, 3] - Tprev[2, 3]) ** 2)
            moved = np.sqrt(1.0 + 0.25 * t * t)
            stalled = moved < fp[F_STALL_DQ]
            ok = err <= fp[F_TOL_DQ]
        else:
            w, x, y, z = relative_rotation(T, Tprev, qa, qb)
            dmove = np.sqrt((T[0, 3] - Tprev[0, 3]) ** 2 + (T[1, 3] - Tprev[1, 3]) ** 2 + (T[2, 3] - Tprev[2, 3]) ** 2)
            rmove = 2.0 * np.arctan2(np.sqrt(x * x + y * y + z * z), w)
            stalled = dmove < fp[F_STALL_POS] and rmove < fp[F_STALL_ROT]
            ok = dp <= fp[F_TOL_POS] and ang <= fp[F_TOL_ROT]
        grew = grew + 1 if err > prev_err else 0
        if not np.isfinite(err):
            code = NON_FINITE
        elif ok:
            code = SUCCESS
        elif stalled and ip[I_NO_STALL] == 0:
            code = STALLED
        elif grew >= ip[I_GROW_LIMIT] and ip[I_NO_GROW] == 0:
            code = DIVERGING
        elif it >= max_iter:
            code = ITERATION_CAP
    t_end = now_ns(clk)
    times[0] = t_end - t_start
    times[1] = t_ik
    return code, it
