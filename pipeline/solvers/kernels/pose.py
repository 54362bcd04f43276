"""The Jacobian IK methods' parameter slots, pose error, reference step and stop rule (numba, nopython).

The loop itself is :func:`pipeline.solvers.iterative.lean.solve`; this module holds what it calls that is
written as a straight transcription of 000 (the pose error 6-vector, the four updates of eqs. 48-61,
the stop rule of §3.4), and the layout of the packed parameters (:func:`pipeline.solvers.iterative.jacobian.packed`).
``tests/solvers/iterative/test_solvers.py`` and ``tests/solvers/core/test_fast_path.py`` check them, and the loop's iterates,
against the numpy kinematics.
"""

from __future__ import annotations

import numba
import numpy as np

from pipeline.solvers.kernels.kin import quat_from_rot, quat_relative, relative_translation_norm, small_svd, vec_norm
from pipeline.solvers.kernels.kin import CRIT_DQ_BODY, CRIT_DQ_NORM  # success tests (CRITERION_CODE)

# integer parameter slots -------------------------------------------------------------------
I_METHOD, I_MAX_ITER, I_CRITERION, I_ORIENT, I_GROW_LIMIT, I_SDLS_NORM, I_SDLS_BLOCKS, I_NO_STALL, I_NO_GROW = range(9)
I_TIME_IK = 9  # read by the lean loop (pipeline.solvers.iterative.lean) only
I_LIMITS = 10  # search_limits code (pipeline.solvers.kernels.kin.LIM_*; the lean loop only); with it on, the
#                float vector holds the lower limits at N_FP..N_FP+n-1 and the upper ones at N_FP+n..N_FP+2n-1
N_IP = 11
# float parameter slots
F_LAMBDA, F_GAMMA_MAX, F_TOL_DQ, F_STALL_DQ, F_TOL_POS, F_TOL_ROT, F_STALL_POS, F_STALL_ROT, F_ORIENT_GAIN = range(9)
N_FP = 9

METHODS = {"jacobian_transpose": 0, "pseudoinverse": 1, "dls": 2, "sdls": 3}
ORIENT_ERRORS = {"quat_vec": 0, "axis_angle": 1}
NORMS = {"maxabs": 0, "one": 1, "two": 2}



@numba.njit(cache=True)
def pose_error(Tg, T, ip, fp, qa, qb, e):
    """Fill the 6-vector ``e`` (v, omega); return (scalar error, |dp|, rotation angle).
    ``qa``, ``qb`` (4,) receive the goal's and the pose's quaternions."""
    quat_from_rot(Tg, qa)
    return pose_error_q(Tg, T, qa, qb, ip, fp, e)


@numba.njit(cache=True)
def pose_error_q(Tg, T, qg, qt, ip, fp, e):
    """:func:`pose_error` with the goal's quaternion ``qg`` given; the pose's is written into ``qt``
    (so that a loop computes the goal's once and the stall test reuses the pose's)."""
    for r in range(3):
        e[r] = Tg[r, 3] - T[r, 3]
    quat_from_rot(T, qt)
    w, x, y, z = quat_relative(qg, qt)
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
    crit = ip[I_CRITERION]  # pipeline.solvers.kernels.kin.CRITERION_CODE
    if crit == CRIT_DQ_NORM:
        t = relative_translation_norm(Tg, T)
        err = np.sqrt(1.0 + 0.25 * t * t)
    elif crit == CRIT_DQ_BODY:
        # Q* Q_goal: its translation is R^T (p_goal - p), so the norm sees position only
        err = np.sqrt(1.0 + 0.25 * dp * dp)
    else:
        err = np.sqrt(dp * dp + e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
    return err, dp, angle


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


@numba.njit(cache=True, inline="always")
def half_cross(R, Tg):
    """``½ Σ_i c_i × d_i`` over the rotation columns ``c_i`` of ``R`` and ``d_i`` of ``Tg`` (3 × 3 or
    4 × 4 arrays): the orientation part of :func:`doc_error`, as three floats."""
    ox = 0.0
    oy = 0.0
    oz = 0.0
    for i in range(3):
        cx, cy, cz = R[0, i], R[1, i], R[2, i]
        dx, dy, dz = Tg[0, i], Tg[1, i], Tg[2, i]
        ox += cy * dz - cz * dy
        oy += cz * dx - cx * dz
        oz += cx * dy - cy * dx
    return 0.5 * ox, 0.5 * oy, 0.5 * oz
