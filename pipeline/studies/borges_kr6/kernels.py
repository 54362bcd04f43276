"""Compiled loops of the three IK methods of 002_56eb235931bf5f5d.txt (numba, nopython).

All three minimise the position error of eq. 3, ``e = |p_goal - p(q)|`` [mm], on a standard-DH
chain (eq. 1) with optional base/tool transforms:

``ji_solve``   inverse Jacobian (§3.4, eqs. 4-6): undivided finite-difference Jacobian, step
               ``dq = alpha J^-1 (X_f - X)``.
``lm_solve``   Levenberg-Marquardt as in MRPT's ``CLevenbergMarquardtTempl::execute`` (§3.5,
               eqs. 7-8): central-difference Jacobian, Nielsen's damping update, gradient/step stops.
``pso_solve``  particle swarm as in Rookfighter/pso-cpp ``Optimizer::_minimize`` (§3.6, eqs. 9-11).

Every solve is timed inside compiled code with the project's monotonic clock
(:func:`pipeline.solvers._jit.now_ns`, ``times[0]``) and with the thread's CPU clock (``times[1]``,
robust to a shared machine descheduling the job); nothing else runs in the timed region.

Trace rows (``iterations + 1`` of them, shape (., 8)): scalar error e [mm], the position
difference ``p_goal - p`` (3) [mm], three zeros (no orientation error: position-only IK), e [mm].
Stop codes follow :mod:`pipeline.solvers`: 1 success, 2 stalled (stop test fired but e above the
success tolerance), 4 iteration cap, 5 non-finite value.
"""

from __future__ import annotations

import numba
import numpy as np

from pipeline.solvers._jit import _clock_gettime, _data_ptr, now_ns

CLOCK_THREAD_CPUTIME_ID = 3  # Linux: CPU time of the calling thread (excludes time descheduled)

SUCCESS, STALLED, ITERATION_CAP, NON_FINITE = 1, 2, 4, 5
TRACE_COLS = 8

# JI orientation rows
JI_ROWS_POSITION, JI_ROWS_HOLD = 0, 1
# JI stop rules
STOP_REACH, STOP_CHANGE = 0, 1
# LM residual kinds
LM_SCALAR, LM_VECTOR = 0, 1


@numba.njit(cache=True)
def cpu_ns(buf):
    """Thread CPU time in ns (``buf``: int64 (2,) used as ``struct timespec``)."""
    _clock_gettime(CLOCK_THREAD_CPUTIME_ID, _data_ptr(buf))
    return buf[0] * 1000000000 + buf[1]


@numba.njit(cache=True)
def fk_pose(a, alpha, d, offs, base, tool, q, T, C, L):
    """Flange/tool pose ``base @ A_1 ... A_n @ tool`` into ``T`` (4, 4); ``C``, ``L`` are scratch (4, 4)."""
    for r in range(4):
        for c in range(4):
            C[r, c] = base[r, c]
    n = q.shape[0]
    for i in range(n + 1):
        if i < n:
            th = q[i] + offs[i]
            ct, st = np.cos(th), np.sin(th)
            ca, sa = np.cos(alpha[i]), np.sin(alpha[i])
            L[0, 0], L[0, 1], L[0, 2], L[0, 3] = ct, -st * ca, st * sa, a[i] * ct
            L[1, 0], L[1, 1], L[1, 2], L[1, 3] = st, ct * ca, -ct * sa, a[i] * st
            L[2, 0], L[2, 1], L[2, 2], L[2, 3] = 0.0, sa, ca, d[i]
        else:
            for r in range(3):
                for c in range(4):
                    L[r, c] = tool[r, c]
        # T = C @ L (last row of both is 0 0 0 1)
        for r in range(3):
            c0, c1, c2, c3 = C[r, 0], C[r, 1], C[r, 2], C[r, 3]
            for c in range(4):
                T[r, c] = c0 * L[0, c] + c1 * L[1, c] + c2 * L[2, c]
            T[r, 3] += c3
        T[3, 0], T[3, 1], T[3, 2], T[3, 3] = 0.0, 0.0, 0.0, 1.0
        for r in range(3):
            for c in range(4):
                C[r, c] = T[r, c]


@numba.njit(cache=True)
def fk_x(a, alpha, d, offs, base, tool, q, X, T, C, L):
    """Eq. 4: ``X = (x, y, z, roll, pitch, yaw)`` (ZYX Euler: R = Rz(yaw) Ry(pitch) Rx(roll))."""
    fk_pose(a, alpha, d, offs, base, tool, q, T, C, L)
    X[0], X[1], X[2] = T[0, 3], T[1, 3], T[2, 3]
    X[3] = np.arctan2(T[2, 1], T[2, 2])
    X[4] = np.arctan2(-T[2, 0], np.sqrt(T[2, 1] * T[2, 1] + T[2, 2] * T[2, 2]))
    X[5] = np.arctan2(T[1, 0], T[0, 0])


@numba.njit(cache=True)
def _wrap(x):
    return (x + np.pi) % (2.0 * np.pi) - np.pi


@numba.njit(cache=True)
def _dist(pg, X):
    dx, dy, dz = pg[0] - X[0], pg[1] - X[1], pg[2] - X[2]
    return np.sqrt(dx * dx + dy * dy + dz * dz)


@numba.njit(cache=True)
def _trace_row(trace, k, e, pg, X):
    trace[k, 0] = e
    trace[k, 1], trace[k, 2], trace[k, 3] = pg[0] - X[0], pg[1] - X[1], pg[2] - X[2]
    trace[k, 4], trace[k, 5], trace[k, 6] = 0.0, 0.0, 0.0
    trace[k, 7] = e


@numba.njit(cache=True)
def ji_jacobian(a, alpha, d, offs, base, tool, q, X, delta, J, qp, Xp, T, C, L):
    """Eq. 5 as used: column j = f(Q + delta e_j) - f(Q), NOT divided by delta, into ``J`` (6, n).

    ``X`` must hold f(Q); orientation rows are wrapped to (-pi, pi].
    """
    n = q.shape[0]
    for j in range(n):
        for m in range(n):
            qp[m] = q[m]
        qp[j] += delta
        fk_x(a, alpha, d, offs, base, tool, qp, Xp, T, C, L)
        for r in range(3):
            J[r, j] = Xp[r] - X[r]
        for r in range(3, 6):
            J[r, j] = _wrap(Xp[r] - X[r])


@numba.njit(cache=True)
def nielsen(lam, nu, rho, min_shrink):
    """Damping update after a step with gain ratio ``rho`` (Madsen et al. 2004 eq. 2.21; MRPT):
    accepted (rho > 0): lam * max(min_shrink, 1 - (2 rho - 1)^3), nu = 2; rejected: lam * nu, nu * 2."""
    if rho > 0:
        return lam * max(min_shrink, 1.0 - (2.0 * rho - 1.0) ** 3), 2.0
    return lam * nu, nu * 2.0


@numba.njit(cache=True)
def ji_solve(a, alpha, d, offs, base, tool, pg, q0, gain, delta, rows, stop_rule, tol_reach, tol_change,
             tol_success, max_iter, q, trace, times):
    """Inverse Jacobian, eqs. 5-6 of the document.

    Column j of the Jacobian is ``f(Q + delta e_j) - f(Q)`` (eq. 5 without division by delta; the
    document prints ``X - f(Q + delta e_j)``, whose sign would make eq. 6 climb, so the forward
    difference is used). ``rows``: 0 = position rows only (3x6, minimum-norm pseudo-inverse), 1 =
    the 6x6 inverse with the orientation entries of ``X_f - X`` held at zero (target RPY = current).
    ``stop_rule``: 0 = stop when e < ``tol_reach`` (Table 2), 1 = stop when |e_k - e_{k-1}| <
    ``tol_change`` (§4.1). Returns (code, iterations).
    """
    clk = np.zeros(2, np.int64)
    c0 = cpu_ns(clk)
    t0 = now_ns(clk)
    n = q0.shape[0]
    T = np.empty((4, 4))
    C = np.empty((4, 4))
    L = np.empty((4, 4))
    X = np.empty(6)
    Xp = np.empty(6)
    qp = np.empty(n)
    J = np.empty((6, n))
    for j in range(n):
        q[j] = q0[j]
    fk_x(a, alpha, d, offs, base, tool, q, X, T, C, L)
    e = _dist(pg, X)
    _trace_row(trace, 0, e, pg, X)
    code = ITERATION_CAP
    k = 0
    if stop_rule == STOP_REACH and e < tol_reach:
        code = SUCCESS
    while code == ITERATION_CAP and k < max_iter:
        ji_jacobian(a, alpha, d, offs, base, tool, q, X, delta, J, qp, Xp, T, C, L)
        dx = np.zeros(6)
        for r in range(3):
            dx[r] = pg[r] - X[r]
        if rows == JI_ROWS_POSITION:
            Jp = np.ascontiguousarray(J[:3, :])
            y = np.linalg.solve(Jp @ Jp.T, dx[:3])
            dq = Jp.T @ y
        else:
            dq = np.linalg.solve(J, dx)
        for j in range(n):
            q[j] += gain * dq[j]
        fk_x(a, alpha, d, offs, base, tool, q, X, T, C, L)
        e_new = _dist(pg, X)
        k += 1
        _trace_row(trace, k, e_new, pg, X)
        if not np.isfinite(e_new):
            code = NON_FINITE
        elif stop_rule == STOP_REACH:
            if e_new < tol_reach:
                code = SUCCESS
        elif abs(e - e_new) < tol_change:
            code = SUCCESS if e_new <= tol_success else STALLED
        e = e_new
    times[0] = now_ns(clk) - t0
    times[1] = cpu_ns(clk) - c0
    return code, k


@numba.njit(cache=True)
def _residual(a, alpha, d, offs, base, tool, pg, q, kind, r, X, T, C, L):
    fk_x(a, alpha, d, offs, base, tool, q, X, T, C, L)
    if kind == LM_SCALAR:
        r[0] = _dist(pg, X)
    else:
        for i in range(3):
            r[i] = X[i] - pg[i]


@numba.njit(cache=True)
def _jacobian_central(a, alpha, d, offs, base, tool, pg, q, kind, incr, J, rp, rm, qp, X, T, C, L):
    """MRPT ``estimateJacobian``: column j = (f(x + incr_j) - f(x - incr_j)) / (2 incr_j)."""
    n = q.shape[0]
    m = J.shape[0]
    for j in range(n):
        for i in range(n):
            qp[i] = q[i]
        qp[j] = q[j] + incr
        _residual(a, alpha, d, offs, base, tool, pg, qp, kind, rp, X, T, C, L)
        qp[j] = q[j] - incr
        _residual(a, alpha, d, offs, base, tool, pg, qp, kind, rm, X, T, C, L)
        for i in range(m):
            J[i, j] = (rp[i] - rm[i]) / (2.0 * incr)


@numba.njit(cache=True)
def lm_solve(a, alpha, d, offs, base, tool, pg, q0, kind, incr, max_iter, tau, e1, e2, min_shrink, tol_change,
             tol_success, q, trace, times):
    """Levenberg-Marquardt (eqs. 7-8; MRPT ``CLevenbergMarquardtTempl::execute``).

    Residual ``kind``: 0 = the scalar e of eq. 3 (as eq. 7 writes it), 1 = the 3-vector p - p_goal.
    lambda_0 = tau max diag(J^T J); accepted step (gain ratio l > 0): lambda *= max(min_shrink,
    1 - (2l - 1)^3), nu = 2; rejected: lambda *= nu, nu *= 2. Stops: ||J^T f||_inf <= e1,
    ||h|| < e2 (||x|| + e2), an accepted step changing e by less than ``tol_change``, or the
    iteration counter reaching ``max_iter`` (MRPT's ``while (!found && ++iter < maxIter)``).
    Returns (code, iterations) with iterations = MRPT's ``iterations_executed``.
    """
    clk = np.zeros(2, np.int64)
    c0 = cpu_ns(clk)
    t0 = now_ns(clk)
    n = q0.shape[0]
    m = 1 if kind == LM_SCALAR else 3
    T = np.empty((4, 4))
    C = np.empty((4, 4))
    L = np.empty((4, 4))
    X = np.empty(6)
    f = np.empty(m)
    fnew = np.empty(m)
    rp = np.empty(m)
    rm = np.empty(m)
    qp = np.empty(n)
    xnew = np.empty(n)
    J = np.empty((m, n))
    for j in range(n):
        q[j] = q0[j]
    _jacobian_central(a, alpha, d, offs, base, tool, pg, q, kind, incr, J, rp, rm, qp, X, T, C, L)
    H = J.T @ J
    _residual(a, alpha, d, offs, base, tool, pg, q, kind, f, X, T, C, L)
    e = _dist(pg, X)
    _trace_row(trace, 0, e, pg, X)
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
    Xlast = X.copy()
    while not found:
        it += 1
        if it >= max_iter:
            _trace_row(trace, it, e, pg, Xlast)
            break
        A = H.copy()
        for i in range(n):
            A[i, i] += lam
        h = -np.linalg.solve(A, g)
        nh = np.sqrt(np.sum(h * h))
        nx = np.sqrt(np.sum(q * q))
        if nh < e2 * (nx + e2):
            found = True
            code = SUCCESS
        else:
            for i in range(n):
                xnew[i] = q[i] + h[i]
            _residual(a, alpha, d, offs, base, tool, pg, xnew, kind, fnew, X, T, C, L)
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
                for i in range(6):
                    Xlast[i] = X[i]
                _jacobian_central(a, alpha, d, offs, base, tool, pg, q, kind, incr, J, rp, rm, qp, X, T, C, L)
                H = J.T @ J
                g = J.T @ f
                if np.max(np.abs(g)) <= e1:
                    found = True
                    code = SUCCESS
                lam, nu = nielsen(lam, nu, rho, min_shrink)
                e_new = _dist(pg, Xlast)
                if abs(e - e_new) < tol_change:
                    found = True
                    code = SUCCESS
                e = e_new
            else:
                lam, nu = nielsen(lam, nu, rho, min_shrink)
        _trace_row(trace, it, e, pg, Xlast)
        if not (np.isfinite(e) and np.isfinite(lam)):
            code = NON_FINITE
            break
    if it >= max_iter:
        it = max_iter
    if code == SUCCESS and e > tol_success:
        code = STALLED
    times[0] = now_ns(clk) - t0
    times[1] = cpu_ns(clk) - c0
    return code, it


@numba.njit(cache=True)
def _fitness(a, alpha, d, offs, base, tool, pg, x, T, C, L):
    fk_pose(a, alpha, d, offs, base, tool, x, T, C, L)
    dx, dy, dz = pg[0] - T[0, 3], pg[1] - T[1, 3], pg[2] - T[2, 3]
    return np.sqrt(dx * dx + dy * dy + dz * dz)


@numba.njit(cache=True)
def pso_solve(a, alpha, d, offs, base, tool, pg, lo, hi, n_particles, w, phip, phig, max_vel, feps, xeps,
              max_iter, seed, tol_success, q, trace, times):
    """Particle swarm, transcribed from pso-cpp ``Optimizer::minimize(bounds, particleCnt)``.

    Particles uniform in [lo, hi] (one draw per particle and joint, particle-major as the library),
    velocities ``clamp(-diff + 2 diff u, -max_vel, max_vel)`` (all zero with the default max_vel = 0),
    then per iteration: ``v = w v + phip u (pbest - x) + phig u (gbest - x)`` (clamped only when
    max_vel > 0), ``x = clamp(x + v, lo, hi)``, personal/global bests; stop when the mean over
    particles of |delta pbest f| <= feps or of ||delta pbest x|| <= xeps, or at ``max_iter``
    (0 = unlimited, the library default). ``seed`` seeds numba's generator (one stream per run).
    Returns (code, iterations).
    """
    np.random.seed(seed)
    clk = np.zeros(2, np.int64)
    c0 = cpu_ns(clk)
    t0 = now_ns(clk)
    n = lo.shape[0]
    P = n_particles
    T = np.empty((4, 4))
    C = np.empty((4, 4))
    L = np.empty((4, 4))
    x = np.empty((P, n))
    v = np.empty((P, n))
    for i in range(P):
        for j in range(n):
            x[i, j] = lo[j] + np.random.random() * (hi[j] - lo[j])
    for i in range(P):
        for j in range(n):
            diff = hi[j] - lo[j]
            vel = -diff + np.random.random() * 2.0 * diff
            v[i, j] = min(max_vel, max(-max_vel, vel))
    fv = np.empty(P)
    for i in range(P):
        fv[i] = _fitness(a, alpha, d, offs, base, tool, pg, x[i], T, C, L)
    bx = x.copy()
    bf = fv.copy()
    gb = 0
    for i in range(P):
        if bf[i] < bf[gb]:
            gb = i
    fk_pose(a, alpha, d, offs, base, tool, bx[gb], T, C, L)
    trace[0, 0] = bf[gb]
    trace[0, 1], trace[0, 2], trace[0, 3] = pg[0] - T[0, 3], pg[1] - T[1, 3], pg[2] - T[2, 3]
    trace[0, 7] = bf[gb]
    it = 0
    fdiff = np.inf
    xdiff = np.inf
    code = ITERATION_CAP
    while fdiff > feps and xdiff > xeps and (max_iter == 0 or it < max_iter):
        for i in range(P):
            for j in range(n):
                velp = np.random.random() * (bx[i, j] - x[i, j])
                velg = np.random.random() * (bx[gb, j] - x[i, j])
                vel = w * v[i, j] + phip * velp + phig * velg
                if max_vel > 0:
                    vel = min(max_vel, max(-max_vel, vel))
                v[i, j] = vel
        for i in range(P):
            for j in range(n):
                x[i, j] = min(hi[j], max(lo[j], x[i, j] + v[i, j]))
        for i in range(P):
            fv[i] = _fitness(a, alpha, d, offs, base, tool, pg, x[i], T, C, L)
        xsum = 0.0
        fsum = 0.0
        for i in range(P):
            if fv[i] < bf[i]:
                s = 0.0
                for j in range(n):
                    dd = x[i, j] - bx[i, j]
                    s += dd * dd
                    bx[i, j] = x[i, j]
                xsum += np.sqrt(s)
                fsum += bf[i] - fv[i]
                bf[i] = fv[i]
        gb = 0
        for i in range(P):
            if bf[i] < bf[gb]:
                gb = i
        xdiff = xsum / P
        fdiff = fsum / P
        it += 1
        fk_pose(a, alpha, d, offs, base, tool, bx[gb], T, C, L)
        trace[it, 0] = bf[gb]
        trace[it, 1], trace[it, 2], trace[it, 3] = pg[0] - T[0, 3], pg[1] - T[1, 3], pg[2] - T[2, 3]
        trace[it, 4], trace[it, 5], trace[it, 6] = 0.0, 0.0, 0.0
        trace[it, 7] = bf[gb]
        if not np.isfinite(bf[gb]):
            code = NON_FINITE
            break
    if code != NON_FINITE and (fdiff <= feps or xdiff <= xeps):
        code = SUCCESS if bf[gb] <= tol_success else STALLED
    for j in range(n):
        q[j] = bx[gb, j]
    times[0] = now_ns(clk) - t0
    times[1] = cpu_ns(clk) - c0
    return code, it
