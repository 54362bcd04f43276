"""Zero-Position IK of Kazerounian (001_7601717b50b5e768.txt, Appendix 4; Erthal 1992 §4.2, §6.2c).

The method works on the zero-position description of a robot: joint i turns (or slides) about
its axis ``u_i`` through a point of that axis, and the effector pose follows from the rotations
of the joints before it (eqs 3.5-3.17). Joints are corrected one at a time, 1..N, each by the
exact minimiser of

    delta(dq) = (1 - c_i) delta_R + c_i delta_P,
    delta_R = ||R_goal R(dq)^T - I||_F^2,  delta_P = |p_goal - p(dq)|^2 / L^2     (A4.11-A4.13)

over that joint alone (A4.16-A4.29: a rotation about ``u_i`` for a revolute joint, a slide along
it for a prismatic one), then again from joint 1 (cyclic). ``c_i`` is the weight of joint i; the
ten strategies of §6.2c choose it (:func:`strategy_weights`), NaN meaning Kazerounian's
``c = delta_P / (delta_R + delta_P)`` evaluated before the step (A4.30).

Zero-position description from any DH chain. The step of joint i needs only that joint's axis
``u_i`` and a point ``o_i`` on it, expressed in the base frame at the current configuration, and
the effector pose. Those are the zero-position vectors of Appendix 1 (Case 3: axis directions and
origin differences of the DH frames, :func:`pipeline.kinematics.zero_position.pz_from_dh`) moved
to the current configuration, and :func:`pipeline.solvers.kernels.kin.forward` returns exactly them
(``axes``, ``origins``) for any DH chain: standard or modified, prismatic joints, base and tool
transforms. Taking the zero position at the current configuration of each step makes the
document's ``q - q0`` bookkeeping vanish; tests/solvers/iterative/test_solvers_erthal.py checks that the axes and
origins of ``forward`` equal the PZ description (rotated by the PZ forward kinematics) on the
robots of the catalogue.

Units. ``delta_P`` mixes a squared length with the dimensionless ``delta_R``, so the method is
not unit-free as printed. ``length_scale`` L (a length, written in m) makes it so: the document's
reading (mm) is ``length_unit: mm, length_scale: 0.001`` (L = 1 mm, delta_P in mm^2 exactly as
printed). ``epsilon`` (the document's stop test, ``stop_test: delta_sum``) is then dimensionless.

Stop tests. ``delta_sum``: Etapa 10, ``delta_R + delta_P < epsilon`` after every joint step; it
implies ``|dp| < L sqrt(epsilon)`` and ``angle < 2 asin(sqrt(epsilon / 8))`` (``delta_R = 8
sin^2(angle / 2)``), so tolerances at least those make the FK check confirm exactly the claims of
this test (data/studies/erthal1992.yaml writes them).
``tolerance`` (default): the FK check's own test (``criterion``, ``tol_pos``, ``tol_rot``) after
every joint step. One iteration = one sweep over the N joints (the study's reading, which
reproduces Tables 6.16-6.17); the count is the number of sweeps begun. ``criterion: position``
drops delta_R and sets c = 1 for every joint (position-only goals, Test 6).

Trace rows (one per sweep, row 0 = start): ``[delta_R + delta_P, p_goal - p (3),
vex(M - M^T)/2 (3), |dp|]`` with ``M = R_goal R^T`` (``vex(M - M^T)/2 = sin(angle) axis``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

import pipeline.solvers.kernels.kin as _kin
from pipeline.solvers.kernels.kin import NEVER, TRACE_DP
from pipeline.solvers.kernels.loop import iterate
from pipeline.solvers.core import CRITERION_CODE, Prepared, Raw, Settings, SettingsError, setting
from pipeline.solvers.core.driver import run_loop
from pipeline.solvers.core.registry import Solver, register

SOURCE = "001_7601717b50b5e768.txt (Erthal 1992) Appendix 4 (Kazerounian's Zero-Position method), §6.2c strategies"
STRATEGIES = tuple(range(1, 11))
STOP_TESTS = ("tolerance", "delta_sum")
FLAT_REL = 64 * 2.220446049250313e-16  # |K| below this times the sum of |terms| is rounding: no step


# kernel parameter slots
I_MAX_ITER, I_STOP, I_CRIT, I_ORIENT = range(4)
F_EPS, F_TOL_POS, F_TOL_ROT, F_TOL_DQ, F_INV_L2 = range(5)


def strategy_weights(strategy: int, prismatic: np.ndarray) -> np.ndarray:
    """Per-joint weight c of ZP strategy 1..10 (§6.2c); NaN = Kazerounian's A4.30 at run time.

    1: A4.30 for all; 2: c = 1 for joint 1, A4.30 for 2..N-1, c = 0 for N; 3: c = 1 for joints
    1-3, 0 for 4..N; 4: c = 1 for all; 5: A4.30 for joints 1-3, 0 for 4..N; 6-8: eq. 6.1
    ``c = ((j - N) / (1 - N))^n`` with n = 1, 2, 3; 9-10: eq. 6.2 ``c = (j^n - N^n) / (1 - N^n)``
    with n = 2, 3. Prismatic joints ignore c (A4.29 is position only).

    Parameters
    ----------
    strategy : int in 1..10
    prismatic : ndarray of bool, shape (n,)

    Returns
    -------
    c : ndarray, shape (n,)
    """
    n = len(prismatic)
    j = np.arange(1, n + 1, dtype=float)
    nan = np.nan
    if strategy == 1:
        c = np.full(n, nan)
    elif strategy == 2:
        c = np.full(n, nan)
        c[0] = 1.0
        c[-1] = 0.0
    elif strategy == 3:
        c = np.where(j <= 3, 1.0, 0.0)
    elif strategy == 4:
        c = np.ones(n)
    elif strategy == 5:
        c = np.where(j <= 3, nan, 0.0)
    elif strategy in (6, 7, 8):
        p = strategy - 5
        c = ((j - n) / (1 - n)) ** p if n > 1 else np.ones(n)
    elif strategy in (9, 10):
        p = strategy - 7
        c = (j**p - n**p) / (1 - n**p) if n > 1 else np.ones(n)
    else:
        raise SettingsError(f"zero_position: field 'strategy': unknown weight strategy {strategy!r} (allowed: 1..10)")
    return np.asarray(c, dtype=float)


@dataclass(frozen=True)
class ZeroPositionSettings(Settings):
    """Settings of the Zero-Position method (defaults: the generic warm-start reading)."""

    strategy: int = setting(1, "weight strategy of §6.2c: 1 = Kazerounian's c = dP/(dR + dP) for every joint "
                            "(A4.30); 2-10 as the document (5 = its default: A4.30 for joints 1-3, c = 0 after)",
                            choices=STRATEGIES)
    stop_test: str = setting("tolerance", "tolerance: the FK check's criterion after every joint step; "
                             "delta_sum: the document's dR + dP < epsilon (Etapa 10)", choices=STOP_TESTS)
    epsilon: float = setting(1e-3, "stop_test delta_sum: dR + dP < epsilon (dimensionless: dP = |dp|^2 / L^2); "
                             "the FK check confirms such a claim when tol_pos >= L sqrt(epsilon) and tol_rot >= "
                             "2 asin(sqrt(epsilon / 8))", above=0.0)
    length_scale: float = setting(0.1, "L of dP = |dp|^2 / L^2 (the document: 1 mm)", unit="m", above=0.0,
                                  length=True)
    max_iterations: int = setting(20000, "stop code 4 after this many sweeps over the joints", minimum=1,
                                  maximum=10_000_000)


def packed(s: ZeroPositionSettings, prismatic: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(weights c (n,), integer and float parameters) of the kernel; settings in the working unit."""
    use_orient = s.criterion != "position"
    c = strategy_weights(s.strategy, prismatic) if use_orient else np.ones(len(prismatic))
    ip = np.zeros(4, np.int64)
    fp = np.zeros(5)
    ip[I_MAX_ITER] = s.max_iterations
    ip[I_STOP] = STOP_TESTS.index(s.stop_test)
    ip[I_CRIT] = CRITERION_CODE[s.criterion]
    ip[I_ORIENT] = int(use_orient)
    fp[F_EPS] = s.epsilon
    fp[F_TOL_POS] = s.tol_pos
    fp[F_TOL_ROT] = s.tol_rot
    fp[F_TOL_DQ] = s.tol_dq
    fp[F_INV_L2] = 1.0 / (s.length_scale * s.length_scale)
    return np.ascontiguousarray(c), ip, fp


@numba.njit(cache=True)
def _errors(Tg, T, M, dv, inv_l2):
    """M = R_goal R^T (3, 3), dv = p_goal - p (3,); returns (delta_R, delta_P) of A4.12-A4.13 at dq = 0."""
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
    if inv_l2 != 1.0:
        dP *= inv_l2
    return dR, dP


@numba.njit(cache=True)
def _trace_row(trace, row, dR, dP, M, dv):
    trace[row, 0] = dR + dP
    for j in range(3):
        trace[row, 1 + j] = dv[j]
    trace[row, 4] = 0.5 * (M[2, 1] - M[1, 2])
    trace[row, 5] = 0.5 * (M[0, 2] - M[2, 0])
    trace[row, 6] = 0.5 * (M[1, 0] - M[0, 1])
    trace[row, TRACE_DP] = np.sqrt(dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2])


@numba.njit(cache=True)
def step_revolute(M, dv, u, h, c, inv_l2):
    """Closed-form minimiser of delta = (1-c) delta_R + c delta_P over a rotation dq about ``u``.

    A4.16-A4.26: with ``R(dq) = I + (1 - cos dq) A + sin dq B`` (A = u u^T - I, B = [u]x),
    ``delta(dq) = C + K_c cos dq - K_s sin dq`` where ``K_c = 2(1-c) tr(M^T A) + 2c (d+h).(A h) / L^2``
    and ``K_s = 2(1-c) tr(M^T B) + 2c (d+h).(B h) / L^2``; the minimum is at ``atan2(K_s, -K_c)``
    (the document's atg(-Z2/Z1) with its A4.25-A4.26 branch test folded into atan2). ``h`` is the
    vector from a point of the axis to the effector (A4.19), ``dv = p_goal - p``. When ``|K|`` is at
    rounding level (delta flat along the joint) the step is 0: atan2 of rounding noise would turn the
    joint by an arbitrary angle (the document's atg(-Z2/Z1) is undefined there too).
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
    mag_r = 0.0  # sums of |terms|: the rounding scale of K_c, K_s
    mag_p = 0.0
    for j in range(3):
        for k in range(3):
            mag_r += abs(M[j, k]) * (abs(A[j, k]) + abs(B[j, k]))
        ah = A[j, 0] * h[0] + A[j, 1] * h[1] + A[j, 2] * h[2]
        bh = B[j, 0] * h[0] + B[j, 1] * h[1] + B[j, 2] * h[2]
        pa += (dv[j] + h[j]) * ah
        pb += (dv[j] + h[j]) * bh
        mag_p += abs(dv[j] + h[j]) * (abs(h[0]) + abs(h[1]) + abs(h[2]))
    if inv_l2 != 1.0:
        pa *= inv_l2
        pb *= inv_l2
        mag_p *= inv_l2
    kc = 2.0 * (1.0 - c) * trA + 2.0 * c * pa
    ks = 2.0 * (1.0 - c) * trB + 2.0 * c * pb
    # delta flat to rounding along this joint (e.g. a roll joint whose axis passes through the effector
    # under c = 1, or an exactly met orientation): no direction to move in, the joint stays
    mag = 2.0 * (abs(1.0 - c) * mag_r + abs(c) * mag_p)
    if np.hypot(kc, ks) <= FLAT_REL * mag:
        return 0.0
    return np.arctan2(ks, -kc)


@numba.njit(cache=True)
def _measure(problem, q, axes, origins, T, M, dv, sc):
    """FK at ``q``, the errors into ``sc`` = (delta_R (0 for position goals), delta_P); returns (delta, met)."""
    a, alpha, d, offs, prism, modified, base, tool, Tg, cfix, ip, fp = problem
    _kin.forward(a, alpha, d, offs, prism, modified, base, tool, q, axes, origins, T)
    dR, dP = _errors(Tg, T, M, dv, fp[F_INV_L2])
    if ip[I_ORIENT] == 0:
        dR = 0.0
    sc[0], sc[1] = dR, dP
    if ip[I_STOP] == 1:
        return dR + dP, dR + dP < fp[F_EPS]
    return dR + dP, _kin.meets(ip[I_CRIT], Tg, T, fp[F_TOL_POS], fp[F_TOL_ROT], fp[F_TOL_DQ])


@numba.njit(cache=True)
def _start(problem, q):
    """:func:`pipeline.solvers.kernels.loop.iterate`'s ``start``. State: ``(axes, origins, T, M, dv, h, u, sc,
    clk, steps)``, ``sc`` = (delta_R, delta_P), ``steps`` (1,) the joint steps taken."""
    n = q.shape[0]
    state = (np.empty((n, 3)), np.empty((n, 3)), np.empty((4, 4)), np.empty((3, 3)), np.empty(3), np.empty(3),
             np.empty(3), np.empty(2), np.zeros(2, np.int64), np.zeros(1, np.int64))
    axes, origins, T, M, dv, h, u, sc, clk, steps = state
    delta, met = _measure(problem, q, axes, origins, T, M, dv, sc)
    return state, delta, met, False


@numba.njit(cache=True)
def _step(problem, state, q, it):
    """``step``: one sweep over the joints (Etapas 5-10), each joint moved to its exact minimiser; the sweep
    stops at the first joint step after which the error is non-finite or the stop test is met."""
    prism, cfix, fp = problem[4], problem[9], problem[11]
    axes, origins, T, M, dv, h, u, sc, clk, steps = state
    t_ik = 0
    delta = sc[0] + sc[1]
    met = False
    for i in range(q.shape[0]):
        t0 = _kin.now_ns(clk)
        for r in range(3):
            u[r] = axes[i, r]
        if prism[i]:
            dq = dv[0] * u[0] + dv[1] * u[1] + dv[2] * u[2]  # A4.29
        else:
            c = cfix[i]
            if np.isnan(c):
                tot = sc[0] + sc[1]
                c = sc[1] / tot if tot > 0 else 1.0  # A4.30
            for r in range(3):
                h[r] = T[r, 3] - origins[i, r]  # A4.19
            dq = step_revolute(M, dv, u, h, c, fp[F_INV_L2])
        q[i] += dq
        t_ik += _kin.now_ns(clk) - t0
        steps[0] += 1
        delta, met = _measure(problem, q, axes, origins, T, M, dv, sc)
        if not np.isfinite(delta) or met:
            break
    return delta, met, False, t_ik


@numba.njit(cache=True)
def _record(problem, state, trace, row):
    sc = state[7]
    _trace_row(trace, row, sc[0], sc[1], state[3], state[4])


@numba.njit(cache=True)
def zp_kernel(a, alpha, d, offs, prism, modified, base, tool, Tg, q0, cfix, ip, fp, q, trace, times):
    """Zero-Position IK (Appendix 4, ``cin_inv_pz()`` Etapas 5-10; :func:`pipeline.solvers.kernels.loop.iterate`
    with this module's sweep as its step); returns (stop code, sweeps, joint steps).

    ``cfix[i]`` is the weight c of joint i or NaN for A4.30 evaluated before the step. ``times``
    receives (solve ns, IK-block ns): the IK block is the joint steps' own arithmetic.
    """
    problem = (a, alpha, d, offs, prism, modified, base, tool, Tg, cfix, ip, fp)
    code, it, state = iterate(_start, _step, _record, problem, q0, q, trace, times, NEVER, ip[I_MAX_ITER])
    return code, it, state[9][0]


def run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: ZeroPositionSettings, seed: int) -> Raw:
    c, ip, fp = prep.memo(("zero_position_packed", s), lambda: packed(s, prep.prismatic))
    q, trace, times, (code, iters, steps) = run_loop(zp_kernel, (*prep.args, T_goal, q_start, c, ip, fp), q_start,
                                                     s.max_iterations)
    return Raw(q=q, code=int(code), iterations=int(iters), solve_ns=int(times[0]), trace=trace, ik_ns=int(times[1]),
               info={"joint_steps": int(steps)})


register(Solver("zero_position", "Zero-Position method (Kazerounian): cyclic exact one-joint minimisation of "
                "(1 - c) dR + c dP, ten weight strategies", "local", ZeroPositionSettings, run, source=SOURCE))
