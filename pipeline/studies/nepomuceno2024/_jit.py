"""Compiled kernels of the nepomuceno2024 study: UR forward kinematics, the document's costs, the
Jacobian-pseudoinverse descent loop and the closed-form UR inverse kinematics.

Conventions are those of :mod:`pipeline.kinematics` (standard DH ``Rz(θ) Tz(d) Tx(a) Rx(α)``,
radians, metres, error six-vectors ordered (v, ω)). Base and tool transforms are not applied here:
the wrapper in :mod:`.methods` rejects robots that have them.

A robot is passed as one packed float vector ``dh`` of length ``4 n`` = ``[a, alpha, d, theta_offset]``
(so that SciPy's cost calls go through a two-argument numba dispatch); a goal as ``goal`` of
length 12 = ``[p (3), R row-major (9)]``, the ``target_pose`` 12-vector of the document's
listings (Apêndices B, C and E of 004_957b32c2b06ea31d.txt).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# stop codes (same meaning as pipeline.solvers: 1 success, 4 iteration cap, 5 non-finite)
SUCCESS = 1
ITERATION_CAP = 4
NON_FINITE = 5
TRACE_COLS = 8  # scalar error, e (6), |dp|
# closed form: a cosine beyond ±1 by less than this is rounding at a boundary (stretched elbow,
# wrist on the shoulder cylinder) and is clipped; the FK check of the solution decides validity
CLIP_TOL = 1e-9


@njit(cache=True)
def _link(a, al, d, th, A):
    ct, st, ca, sa = math.cos(th), math.sin(th), math.cos(al), math.sin(al)
    A[0, 0] = ct; A[0, 1] = -st * ca; A[0, 2] = st * sa; A[0, 3] = a * ct
    A[1, 0] = st; A[1, 1] = ct * ca; A[1, 2] = -ct * sa; A[1, 3] = a * st
    A[2, 0] = 0.0; A[2, 1] = sa; A[2, 2] = ca; A[2, 3] = d
    A[3, 0] = 0.0; A[3, 1] = 0.0; A[3, 2] = 0.0; A[3, 3] = 1.0


@njit(cache=True)
def _chain(dh, q, T, Z, O):
    """Standard-DH chain: ``T_0n`` into ``T`` (4, 4); joint axes/origins into ``Z``/``O`` (n, 3)."""
    n = q.shape[0]
    for r in range(4):
        for c in range(4):
            T[r, c] = 1.0 if r == c else 0.0
    A = np.empty((4, 4))
    M = np.empty((4, 4))
    for i in range(n):
        for r in range(3):
            Z[i, r] = T[r, 2]
            O[i, r] = T[r, 3]
        _link(dh[i], dh[n + i], dh[2 * n + i], q[i] + dh[3 * n + i], A)
        for r in range(3):
            for c in range(4):
                s = 0.0
                for k in range(4):
                    s += T[r, k] * A[k, c]
                M[r, c] = s
        for r in range(3):
            for c in range(4):
                T[r, c] = M[r, c]


@njit(cache=True)
def fk(dh, q, T):
    """``T_0n`` of a standard-DH chain into ``T`` (4, 4); ``dh`` (4 n,), ``q`` (n,) [rad]."""
    n = q.shape[0]
    _chain(dh, q, T, np.empty((n, 3)), np.empty((n, 3)))


@njit(cache=True)
def jacobian(dh, q, J):
    """Geometric Jacobian (6, n) of the chain's last frame, base frame, rows (v, ω)."""
    n = q.shape[0]
    Z = np.empty((n, 3))
    O = np.empty((n, 3))
    T = np.empty((4, 4))
    _chain(dh, q, T, Z, O)
    px, py, pz = T[0, 3], T[1, 3], T[2, 3]
    for i in range(n):
        zx, zy, zz = Z[i, 0], Z[i, 1], Z[i, 2]
        rx, ry, rz = px - O[i, 0], py - O[i, 1], pz - O[i, 2]
        J[0, i] = zy * rz - zz * ry
        J[1, i] = zz * rx - zx * rz
        J[2, i] = zx * ry - zy * rx
        J[3, i] = zx
        J[4, i] = zy
        J[5, i] = zz


@njit(cache=True)
def pose_error(T, goal, e):
    """Six-vector ``e = [p_goal - p; ½ Σ_i c_i × d_i]`` (``compute_error`` of Apêndice E).

    ``c_i`` are the columns of the current rotation, ``d_i`` those of the goal rotation
    (Siciliano & Sciavicco's column cross-product orientation error). Returns |dp| [m].
    """
    for r in range(3):
        e[r] = goal[r] - T[r, 3]
    ox = 0.0
    oy = 0.0
    oz = 0.0
    for i in range(3):
        cx, cy, cz = T[0, i], T[1, i], T[2, i]
        dx, dy, dz = goal[3 + i], goal[6 + i], goal[9 + i]  # column i of the row-major goal R
        ox += cy * dz - cz * dy
        oy += cz * dx - cx * dz
        oz += cx * dy - cy * dx
    e[3] = 0.5 * ox
    e[4] = 0.5 * oy
    e[5] = 0.5 * oz
    return math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])


@njit(cache=True)
def pos_rot_norms(T, goal):
    """(‖p - p_goal‖₂ [m], ‖R - R_goal‖_F [1]) — the two terms of the document's costs."""
    dp = 0.0
    for r in range(3):
        x = T[r, 3] - goal[r]
        dp += x * x
    dr = 0.0
    for r in range(3):
        for c in range(3):
            x = T[r, c] - goal[3 + 3 * r + c]
            dr += x * x
    return math.sqrt(dp), math.sqrt(dr)


@njit(cache=True)
def cost(q, params):
    """Weighted cost ``w_p ‖Δp‖₂ + w_R ‖ΔR‖_F`` (Apêndices B and C, norms not squared).

    ``params`` = ``[w_p, w_R, squared, goal (12), dh (4 n)]``: cost A is ``w = (1, 1)`` (BFGS
    listing), cost B ``w = (1, 0.1)`` (L-BFGS-B listing); ``squared = 1`` gives
    ``w_p ‖Δp‖² + w_R ‖ΔR‖²_F`` (the theory's eq. 2.15 form) instead.
    """
    n = q.shape[0]
    T = np.empty((4, 4))
    fk(params[15:15 + 4 * n], q, T)
    dp, dr = pos_rot_norms(T, params[3:15])
    if params[2] != 0.0:
        return params[0] * dp * dp + params[1] * dr * dr
    return params[0] * dp + params[1] * dr


@njit(cache=True)
def pinv_descent(dh_fk, dh_jac, goal, q0, rate, tol, max_iter, rcond, q, trace):
    """Jacobian-pseudoinverse descent ``θ ← θ + rate · J⁺ e`` (Apêndice E, first listing).

    Stops when ‖e‖₂ < ``tol`` (checked before each step, as the listing) or after ``max_iter``
    steps. ``J`` is the geometric Jacobian of ``dh_jac`` (the FK model itself, or the document's
    roboticstoolbox UR5 model); ``J⁺`` by SVD with singular values below ``rcond · σ_max`` dropped
    (a guard the listing does not have). ``trace`` (max_iter + 1, 8) receives per iteration
    [‖e‖, e (6), |dp|]. Returns (stop code, steps taken).
    """
    n = q0.shape[0]
    for i in range(n):
        q[i] = q0[i]
    T = np.empty((4, 4))
    e = np.empty(6)
    J = np.empty((6, n))
    it = 0
    while True:
        fk(dh_fk, q, T)
        dp = pose_error(T, goal, e)
        en = 0.0
        for k in range(6):
            en += e[k] * e[k]
        en = math.sqrt(en)
        trace[it, 0] = en
        for k in range(6):
            trace[it, 1 + k] = e[k]
        trace[it, 7] = dp
        if not math.isfinite(en):
            return NON_FINITE, it
        if en < tol:
            return SUCCESS, it
        if it >= max_iter:
            return ITERATION_CAP, it
        jacobian(dh_jac, q, J)
        u, s, vh = np.linalg.svd(J, full_matrices=False)
        cut = rcond * s[0]
        # dq = V diag(1/s) U^T e
        w = np.zeros(s.shape[0])
        for k in range(s.shape[0]):
            if s[k] > cut:
                acc = 0.0
                for r in range(6):
                    acc += u[r, k] * e[r]
                w[k] = acc / s[k]
        for j in range(n):
            acc = 0.0
            for k in range(s.shape[0]):
                acc += vh[k, j] * w[k]
            q[j] += rate * acc
        it += 1


@njit(cache=True)
def _wrap(x):
    """Angle wrapped to (-π, π]."""
    y = x - 2.0 * math.pi * math.floor((x + math.pi) / (2.0 * math.pi))  # in [-π, π)
    if y <= -math.pi:
        return y + 2.0 * math.pi
    return y


@njit(cache=True)
def _matmul4(X, Y, out):
    """``out = X @ Y`` for 4 x 4 arrays without allocating."""
    for r in range(4):
        for c in range(4):
            acc = 0.0
            for k in range(4):
                acc += X[r, k] * Y[k, c]
            out[r, c] = acc


@njit(cache=True)
def _inv_rigid(A, out):
    for r in range(3):
        for c in range(3):
            out[r, c] = A[c, r]
    for r in range(3):
        out[r, 3] = -(A[0, r] * A[0, 3] + A[1, r] * A[1, 3] + A[2, r] * A[2, 3])
    out[3, 0] = 0.0; out[3, 1] = 0.0; out[3, 2] = 0.0; out[3, 3] = 1.0


@njit(cache=True)
def ur_ik_all(dh, Tg, q6_ref, wrist_eps, tol_pos, tol_rot, Q, valid, err):
    """All 8 closed-form solutions of a UR-type arm (Hawkins 2013 geometry), each FK-verified.

    The arm must have ``alpha = (π/2, 0, 0, π/2, -π/2, 0)``, ``a1 = a4 = a5 = a6 = 0``,
    ``d2 = d3 = 0`` and zero offsets (checked by the Python wrapper). Branches are ordered
    ``(shoulder ±) × (wrist ±) × (elbow ±)``; row ``4 i1 + 2 i5 + i3``.

    θ1: the wrist-2 origin ``p05 = p - d6 z6`` satisfies ``p05 · z1 = d4`` with
    ``z1 = (sin θ1, -cos θ1, 0)``. θ5 = atan2(±|z6 × z1|, z6 · z1) (the classic
    ``acos((p · z1 - d4) / d6)`` loses half the digits near θ5 = 0). θ6 from the x/y axes of the
    base in the tool frame, signed by sin θ5; when ``|sin θ5| < wrist_eps`` (wrist singularity,
    joints 4 and 6 aligned) θ6 is free and is set to ``q6_ref`` (θ4 then absorbs the rest), so
    nothing is divided by ~0.
    θ3, θ2, θ4 from the planar 3R arm in frame 1 (``T14 = A1⁻¹ T A6⁻¹ A5⁻¹``).
    Unreachable branches (|cos| > 1 + CLIP_TOL) are clipped, computed to finite numbers and marked
    invalid; boundary cases within CLIP_TOL are clipped and kept if the FK check passes.

    Outputs: ``Q`` (8, 6) [rad] wrapped to (-π, π]; ``valid`` (8,) FK check passed (|dp| ≤
    ``tol_pos`` and ``‖R - R_goal‖_F`` ≤ ``tol_rot``); ``err`` (8, 2) = (|dp|, ‖ΔR‖_F).
    Returns the number of valid solutions.
    """
    n = 6
    d1 = dh[2 * n + 0]
    a2 = dh[1]
    a3 = dh[2]
    d4 = dh[2 * n + 3]
    d5 = dh[2 * n + 4]
    d6 = dh[2 * n + 5]
    px, py = Tg[0, 3], Tg[1, 3]
    p5x = px - d6 * Tg[0, 2]
    p5y = py - d6 * Tg[1, 2]
    r5 = math.sqrt(p5x * p5x + p5y * p5y)
    psi = math.atan2(p5y, p5x)
    ok1 = True
    if r5 < 1e-300:
        c = 0.0
        ok1 = False
    else:
        c = d4 / r5
    if c > 1.0 + CLIP_TOL:
        ok1 = False
    if c < -1.0 - CLIP_TOL:
        ok1 = False
    c = min(1.0, max(-1.0, c))
    phi = math.acos(c)
    A = np.empty((4, 4))
    Ai = np.empty((4, 4))
    B = np.empty((4, 4))
    C = np.empty((4, 4))
    T = np.empty((4, 4))
    goal = np.empty(12)
    for r in range(3):
        goal[r] = Tg[r, 3]
        for cc in range(3):
            goal[3 + 3 * r + cc] = Tg[r, cc]
    qq = np.empty(6)
    nvalid = 0
    for i1 in range(2):
        th1 = psi + (phi if i1 == 0 else -phi) + 0.5 * math.pi
        s1, c1 = math.sin(th1), math.cos(th1)
        # z6 · z1 = cos θ5 and |z6 × z1| = |sin θ5| (accurate near the wrist singularity, unlike acos)
        c5 = Tg[0, 2] * s1 - Tg[1, 2] * c1
        s5abs = math.sqrt(Tg[2, 2] * Tg[2, 2] + (Tg[0, 2] * c1 + Tg[1, 2] * s1) ** 2)
        for i5 in range(2):
            s5 = s5abs if i5 == 0 else -s5abs
            th5 = math.atan2(s5, c5)
            if s5abs < wrist_eps:
                th6 = q6_ref
            else:
                # rows 0 and 1 of R06 = x and y axes of the base seen from the tool frame
                sg = 1.0 if s5 > 0.0 else -1.0
                th6 = math.atan2(sg * (-Tg[0, 1] * s1 + Tg[1, 1] * c1), sg * (Tg[0, 0] * s1 - Tg[1, 0] * c1))
            # T14 = A1^-1 Tg A6^-1 A5^-1
            _link(dh[0], dh[n + 0], d1, th1, A)
            _inv_rigid(A, Ai)
            _matmul4(Ai, Tg, B)
            _link(dh[5], dh[n + 5], d6, th6, A)
            _inv_rigid(A, Ai)
            _matmul4(B, Ai, C)
            _link(dh[4], dh[n + 4], d5, th5, A)
            _inv_rigid(A, Ai)
            _matmul4(C, Ai, B)
            x, y = B[0, 3], B[1, 3]
            c3 = (x * x + y * y - a2 * a2 - a3 * a3) / (2.0 * a2 * a3)
            ok3 = ok1
            if c3 > 1.0 + CLIP_TOL:
                ok3 = False
            if c3 < -1.0 - CLIP_TOL:
                ok3 = False
            c3 = min(1.0, max(-1.0, c3))
            th234 = math.atan2(B[1, 0], B[0, 0])
            for i3 in range(2):
                th3 = math.acos(c3) if i3 == 0 else -math.acos(c3)
                th2 = math.atan2(y, x) - math.atan2(a3 * math.sin(th3), a2 + a3 * math.cos(th3))
                th4 = th234 - th2 - th3
                row = 4 * i1 + 2 * i5 + i3
                qq[0] = _wrap(th1); qq[1] = _wrap(th2); qq[2] = _wrap(th3)
                qq[3] = _wrap(th4); qq[4] = _wrap(th5); qq[5] = _wrap(th6)
                for j in range(6):
                    Q[row, j] = qq[j]
                fk(dh, qq, T)
                dp, dr = pos_rot_norms(T, goal)
                err[row, 0] = dp
                err[row, 1] = dr
                good = ok3 and dp <= tol_pos and dr <= tol_rot
                valid[row] = good
                if good:
                    nvalid += 1
    return nvalid


@njit(cache=True)
def ur_ik_nearest(dh, Tg, q_prev, wrist_eps, tol_pos, tol_rot, q, Q, valid, err):
    """Closed-form IK, then the valid solution nearest ``q_prev`` (wrapped joint distance),
    unwrapped to lie within π of ``q_prev`` per joint. Returns (number valid, chosen row or -1)."""
    nv = ur_ik_all(dh, Tg, q_prev[5], wrist_eps, tol_pos, tol_rot, Q, valid, err)
    best = -1
    bestd = 1e300
    for r in range(8):
        if not valid[r]:
            continue
        dist = 0.0
        for j in range(6):
            dj = _wrap(Q[r, j] - q_prev[j])
            dist += dj * dj
        if dist < bestd:
            bestd = dist
            best = r
    if best < 0:
        for j in range(6):
            q[j] = q_prev[j]
    else:
        for j in range(6):
            q[j] = q_prev[j] + _wrap(Q[best, j] - q_prev[j])
    return nv, best
