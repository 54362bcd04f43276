"""Compiled loops of the Zero-Position and Newton-Raphson methods of 001_7601717b50b5e768.txt.

Both reuse the standard/modified-DH forward kinematics, geometric Jacobian, pose error and
monotonic clock of :mod:`pipeline.solvers._jit` (numba, nopython), so a solve's time reflects the
method and not interpreter overhead.

Trace rows (one per iteration, row 0 = start): ``[scalar error, e (6), |dp|]`` with
``e = (p_goal - p, orientation vector)``. For ZP the scalar error is the document's stop quantity
``delta_R + delta_P`` (A4.12 + A4.13) and the orientation vector is ``vex(M - M^T)/2 =
sin(angle) axis`` of ``M = R_goal R^T``; for NR it is the Euclidean norm of the 6-vector
``(p_goal - p [length], angle * axis [rad])``.
"""

from __future__ import annotations

import numba
import numpy as np

from pipeline.solvers._jit import (
    ITERATION_CAP,
    NON_FINITE,
    STALLED,
    SUCCESS,
    forward,
    jacobian,
    now_ns,
    pose_error,
    I_CRITERION,
    I_ORIENT,
    N_IP,
    N_FP,
)

TRACE_COLS = 8


@numba.njit(cache=True)
def _errors(Tg, T, M, dv):
    """M = R_goal R^T (3, 3), d = p_goal - p (3,); returns (delta_R, delta_P) of A4.12-A4.13 at dq = 0."""
    dR = 0.0
    for j in range(3):
        for k in range(3):
            s = 0.0
            for m in range(3):
                s += Tg[j, m] * T[k, m]
            M[j, k] = s
            diff = s - (1.0 if j == k else 0.0)
            dR += diff * diff
    dP = 0.0
    for j in range(3):
        dv[j] = Tg[j, 3] - T[j, 3]
        dP += dv[j] * dv[j]
    return dR, dP


@numba.njit(cache=True)
def _zp_trace(trace, row, dR, dP, M, dv):
    trace[row, 0] = dR + dP
    for j in range(3):
        trace[row, 1 + j] = dv[j]
    trace[row, 4] = 0.5 * (M[2, 1] - M[1, 2])
    trace[row, 5] = 0.5 * (M[0, 2] - M[2, 0])
    trace[row, 6] = 0.5 * (M[1, 0] - M[0, 1])
    trace[row, 7] = np.sqrt(dP)


@numba.njit(cache=True)
def zp_step_revolute(M, dv, u, h, c):
    """Closed-form minimiser of delta = (1-c) delta_R + c delta_P over a rotation dq about ``u``.

    A4.16-A4.26 of the document: with ``R(dq) = I + (1 - cos dq) A + sin dq B`` (A = u u^T - I,
    B = [u]x), ``delta(dq) = C + K_c cos dq - K_s sin dq`` where
    ``K_c = 2(1-c) tr(M^T A) + 2c (d+h).(A h)`` and ``K_s = 2(1-c) tr(M^T B) + 2c (d+h).(B h)``;
    the minimum is at ``atan2(K_s, -K_c)`` (the document's atg(-Z2/Z1) with its A4.25-A4.26
    branch test folded into atan2).
    """
    ux, uy, uz = u[0], u[1], u[2]
    A = np.empty((3, 3))
    B = np.zeros((3, 3))
    for j in range(3):
        for k in range(3):
            A[j, k] = u[j] * u[k] - (1.0 if j == k else 0.0)
    B[0, 1], B[0, 2] = -uz, uy
    B[1, 0], B[1, 2] = uz, -ux
    B[2, 0], B[2, 1] = -uy, ux
    trA = 0.0
    trB = 0.0
    for j in range(3):
        for k in range(3):
            trA += M[j, k] * A[j, k]
            trB += M[j, k] * B[j, k]
    pa = 0.0
    pb = 0.0
    for j in range(3):
        ah = A[j, 0] * h[0] + A[j, 1] * h[1] + A[j, 2] * h[2]
        bh = B[j, 0] * h[0] + B[j, 1] * h[1] + B[j, 2] * h[2]
        pa += (dv[j] + h[j]) * ah
        pb += (dv[j] + h[j]) * bh
    kc = 2.0 * (1.0 - c) * trA + 2.0 * c * pa
    ks = 2.0 * (1.0 - c) * trB + 2.0 * c * pb
    if kc == 0.0 and ks == 0.0:
        return 0.0
    return np.arctan2(ks, -kc)


@numba.njit(cache=True)
def zp_solve(a, alpha, d, offs, prism, modified, base, tool, Tg, q0, cfix, eps, max_iter, use_orient, q, trace,
             times):
    """Zero-Position IK (Kazerounian; Appendix 4, ``cin_inv_pz()`` Etapas 5-10).

    Joints are corrected one at a time, 1..N, then again from 1 (cyclic). ``cfix[i]`` is the
    weight c of joint i, or NaN for Kazerounian's ``c = delta_P / (delta_R + delta_P)`` (A4.30)
    evaluated before the step. The stop test ``delta_R + delta_P < eps`` (Etapa 10) runs after
    every joint step. One iteration = one sweep over the N joints (our reading); the count is the
    number of sweeps begun. ``use_orient = False`` drops delta_R (position-only task, planar
    arms of Test 6). Returns ``(stop_code, iterations, joint_steps)``.
    """
    clk = np.zeros(2, np.int64)
    t_start = now_ns(clk)
    n = q0.shape[0]
    for i in range(n):
        q[i] = q0[i]
    axes = np.empty((n, 3))
    origins = np.empty((n, 3))
    T = np.empty((4, 4))
    M = np.empty((3, 3))
    dv = np.empty(3)
    h = np.empty(3)
    u = np.empty(3)
    forward(a, alpha, d, offs, prism, modified, base, tool, q, axes, origins, T)
    dR, dP = _errors(Tg, T, M, dv)
    if not use_orient:
        dR = 0.0
    _zp_trace(trace, 0, dR, dP, M, dv)
    t_ik = 0
    code = 0
    it = 0
    steps = 0
    if not np.isfinite(dR + dP):
        code = NON_FINITE
    elif dR + dP < eps:
        code = SUCCESS
    while code == 0:
        it += 1
        for i in range(n):
            t0 = now_ns(clk)
            for r in range(3):
                u[r] = axes[i, r]
            if prism[i]:
                dq = dv[0] * u[0] + dv[1] * u[1] + dv[2] * u[2]  # A4.29
            else:
                c = cfix[i]
                if np.isnan(c):
                    tot = dR + dP
                    c = dP / tot if tot > 0 else 1.0  # A4.30
                for r in range(3):
                    h[r] = T[r, 3] - origins[i, r]  # A4.19
                dq = zp_step_revolute(M, dv, u, h, c)
            q[i] += dq
            t_ik += now_ns(clk) - t0
            steps += 1
            forward(a, alpha, d, offs, prism, modified, base, tool, q, axes, origins, T)
            dR, dP = _errors(Tg, T, M, dv)
            if not use_orient:
                dR = 0.0
            if not np.isfinite(dR + dP):
                code = NON_FINITE
                break
            if dR + dP < eps:
                code = SUCCESS
                break
        _zp_trace(trace, it, dR, dP, M, dv)
        if code == 0 and it >= max_iter:
            code = ITERATION_CAP
    times[0] = now_ns(clk) - t_start
    times[1] = t_ik
    return code, it, steps


@numba.njit(cache=True)
def nr_solve(a, alpha, d, offs, prism, modified, base, tool, Tg, q0, eps, max_iter, s_halvings, stall, q, trace,
             times):
    """Newton-Raphson with Whitney step control (eqs 4.12-4.13 of the document).

    ``q <- q + s J^+(q) e(q)`` with e the 6-vector (p_goal - p, angle * axis) and ``J^+`` the
    inverse (square J) or pseudo-inverse (least squares) of the geometric Jacobian. The step
    length s is chosen by an inner search over ``s = 1, 1/2, ..., 2^-s_halvings``: the first s
    whose error is below the current one is taken (backtracking line search on s); when none is,
    the iteration has stalled (stop code 2). Success when ``|e| < eps``.
    Returns ``(stop_code, iterations)``.
    """
    clk = np.zeros(2, np.int64)
    t_start = now_ns(clk)
    n = q0.shape[0]
    for i in range(n):
        q[i] = q0[i]
    ip = np.zeros(N_IP, np.int64)
    fp = np.zeros(N_FP)
    ip[I_ORIENT] = 1
    ip[I_CRITERION] = 1
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
    forward(a, alpha, d, offs, prism, modified, base, tool, q, axes, origins, T)
    err, dp, ang = pose_error(Tg, T, ip, fp, qa, qb, e)
    trace[0, 0] = err
    trace[0, 1:7] = e
    trace[0, 7] = dp
    t_ik = 0
    code = 0
    it = 0
    if not np.isfinite(err):
        code = NON_FINITE
    elif err < eps:
        code = SUCCESS
    while code == 0:
        it += 1
        for r in range(3):
            p[r] = T[r, 3]
        jacobian(prism, axes, origins, p, J)
        t0 = now_ns(clk)
        dq = np.linalg.lstsq(J, e)[0]  # = J^-1 e for a square non-singular J
        t_ik += now_ns(clk) - t0
        s = 1.0
        accepted = False
        new_err = err
        for k in range(s_halvings + 1):
            for i in range(n):
                q_try[i] = q[i] + s * dq[i]
            forward(a, alpha, d, offs, prism, modified, base, tool, q_try, axes, origins, T)
            new_err, dp, ang = pose_error(Tg, T, ip, fp, qa, qb, e_try)
            if np.isfinite(new_err) and new_err < err:
                accepted = True
                break
            s *= 0.5
        if accepted:
            for i in range(n):
                q[i] = q_try[i]
            err = new_err
            e[:] = e_try
        else:
            forward(a, alpha, d, offs, prism, modified, base, tool, q, axes, origins, T)
        trace[it, 0] = err
        trace[it, 1:7] = e
        trace[it, 7] = np.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        if not np.isfinite(err):
            code = NON_FINITE
        elif err < eps:
            code = SUCCESS
        elif not accepted and stall:
            code = STALLED
        elif it >= max_iter:
            code = ITERATION_CAP
    times[0] = now_ns(clk) - t_start
    times[1] = t_ik
    return code, it
