"""J⁺ gradient descent, BFGS, L-BFGS-B and Nelder-Mead (004_957b32c2b06ea31d.txt, Nepomuceno 2024).

``jpinv_descent``  θ ← θ + rate · J⁺ e with the document's error six-vector
                   e = [p_goal − p; ½ Σ_i c_i × d_i] (c_i / d_i the columns of the current / goal
                   rotation; Apêndice E), stopped when ‖e‖ < ``tolerance`` (checked before each
                   step, as the listing) or after ``max_iterations`` steps. One compiled loop;
                   ``jacobian_robot`` may name another robot file whose DH table gives the Jacobian
                   (the listing calls roboticstoolbox's UR5, not the FK model).
``bfgs``, ``lbfgsb``, ``nelder_mead``
                   ``scipy.optimize.minimize`` on the cost
                   ``w_p ‖Δp‖ + w_R ‖R − R_goal‖_F`` (Apêndices B, C; norms not squared) or, with
                   ``squared``, ``w_p ‖Δp‖² + w_R ‖R − R_goal‖²_F`` (the theory's eq. 2.15). Cost and
                   its analytic gradient are compiled on :mod:`pipeline.solvers.kernels.kin` (any DH chain:
                   standard/modified, prismatic joints, base/tool). ``‖Δp‖`` is in metres whatever
                   the working unit, so the weights mean the same on every robot.
                   ``gradient: 2-point`` gives SciPy's own forward differences (the listings pass
                   no ``jac``). L-BFGS-B's box is the robot file's joint limits where finite
                   (``bounds: limits``) or an explicit list.

What a method claims. The descent claims success when its own stop test (‖e‖ < tolerance) fires.
SciPy's optimisers have no pose test: their claim is the pose of the returned angles checked with
the compiled FK against the settings' success criterion (``tol_pos``/``tol_rot``); otherwise the
stop reason is the optimiser's: iteration/evaluation cap (4), non-finite (5), or any other stop
(converged above the tolerance, line-search precision loss: 2). :func:`pipeline.solvers.finish`
then re-checks every claim with the numpy FK.

Timing (:mod:`pipeline.solvers.core.timing`): the descent reads the monotonic clock inside the kernel;
SciPy methods read :func:`~pipeline.solvers.core.timing.clock_ns` right before and after ``minimize``
(the iterate-recording callback included, as the study always did). ``Raw.info`` carries nfev,
njev, the method's own error measure at the solution (``doc_error``) and SciPy's stop message.

Traces: one row per iterate (SciPy callback / descent step): [the method's own measure (‖e‖ or
the cost), e (6), |Δp| (working unit)], computed after the timed region for SciPy methods.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numba
import numpy as np

import pipeline.solvers.kernels.kin as _kin
from pipeline.solvers.kernels.kin import ITERATION_CAP, NEVER, NON_FINITE, STALLED, SUCCESS, TRACE_COLS, TRACE_DP
from pipeline.solvers.kernels.loop import error_row, iterate
from pipeline.solvers.core import Prepared, Raw, Settings, SettingsError, StopReason, check_data_path, meets, setting
from pipeline.solvers.core.driver import run_loop
from pipeline.solvers.core.registry import Solver, register
from pipeline.solvers.kernels.pose import half_cross
from pipeline.solvers.core.timing import clock_ns

SOURCE = "004_957b32c2b06ea31d.txt (Nepomuceno 2024) §4.2, Apêndices B, C, E"

# ---- compiled pieces -------------------------------------------------------------------------

# packed cost parameters P (one float vector, so SciPy's calls go through a two-argument dispatch)
P_WP, P_WR, P_SQ, P_MOD = 0, 1, 2, 3
P_GOAL = 4     # p (3), R row-major (9)
P_BASE = 16    # 4 x 4 row-major
P_TOOL = 32
P_CHAIN = 48   # a, alpha, d, offs, prism (n each, prism as 0/1; general form: a 12 n, alpha 3 n)


@numba.njit(cache=True)
def doc_error(T, Tg, e):
    """Six-vector ``e = [p_goal - p; ½ Σ_i c_i × d_i]`` (``compute_error`` of Apêndice E) into ``e``.

    ``c_i`` are the columns of ``T``'s rotation, ``d_i`` those of ``Tg`` (Siciliano & Sciavicco's
    column cross-product orientation error: sin(angle) · axis). Returns |Δp|.
    """
    for r in range(3):
        e[r] = Tg[r, 3] - T[r, 3]
    e[3], e[4], e[5] = half_cross(T, Tg)
    return math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])


@numba.njit(cache=True)
def _norm6(e):
    s = 0.0
    for k in range(6):
        s += e[k] * e[k]
    return math.sqrt(s)


@numba.njit(cache=True)
def _merit(T, Tg):
    """|Δp|² + angle² (‖e‖ itself is no merit: its orientation part, sin(angle), falls beyond π/2)."""
    dp = _kin.position_distance(Tg, T)
    ang = _kin.rotation_angle(Tg, T)
    return dp * dp + ang * ang


@numba.njit(cache=True)
def _measure(problem, state, q):
    """FK at ``q``, the document's error ``e`` and (‖e‖, |Δp|) into the state; returns (‖e‖, the stop test:
    ‖e‖ < tolerance, or with ``tol_pos >= 0`` |Δp| <= tol_pos and angle <= tol_rot)."""
    a, alpha, d, offs, prism, modified, base, tool = problem[:8]
    Tg, tol, tol_pos, tol_rot = problem[17], problem[19], problem[25], problem[26]
    T, Tj, axes, origins, p, e, J, dq, qc, Tc, m = state
    _kin.forward(a, alpha, d, offs, prism, modified, base, tool, q, axes, origins, T)
    dp = doc_error(T, Tg, e)
    en = _norm6(e)
    m[0], m[1] = en, dp
    return en, en < tol or (tol_pos >= 0.0 and dp <= tol_pos and _kin.rotation_angle(Tg, T) <= tol_rot)


@numba.njit(cache=True)
def _plan(problem, state, q):
    """The next step ``rate · J⁺ e`` (``dq``, its scale ``f`` into ``m[2]``) at the measured ``q``; with
    ``halvings > 0`` the backtracked joints into ``qc``. Returns False when no halving decreased the merit."""
    a, alpha, d, offs, prism, modified, base, tool = problem[:8]
    ja, jalpha, jd, joffs, jprism, jmodified, jbase, jtool, own_jacobian, Tg, rate = problem[8:19]
    rcond, lam2, max_step, halvings = problem[21], problem[22], problem[23], problem[24]
    T, Tj, axes, origins, p, e, J, dq, qc, Tc, m = state
    n = q.shape[0]
    if own_jacobian:
        for r in range(3):
            p[r] = T[r, 3]
    else:
        _kin.forward(ja, jalpha, jd, joffs, jprism, jmodified, jbase, jtool, q, axes, origins, Tj)
        for r in range(3):
            p[r] = Tj[r, 3]
    _kin.jacobian(jprism, axes, origins, p, J)
    u, s, vh = np.linalg.svd(J, full_matrices=False)
    cut = rcond * s[0]
    w = np.zeros(s.shape[0])
    for k in range(s.shape[0]):
        if s[k] > cut:
            acc = 0.0
            for r in range(6):
                acc += u[r, k] * e[r]
            w[k] = acc / s[k] if lam2 == 0.0 else acc * s[k] / (s[k] * s[k] + lam2)
    big = 0.0
    for j in range(n):
        acc = 0.0
        for k in range(s.shape[0]):
            acc += vh[k, j] * w[k]
        dq[j] = rate * acc
        big = max(big, abs(dq[j]))
    f = max_step / big if max_step > 0.0 and big > max_step else 1.0
    m[2] = f
    if halvings == 0:
        return True
    merit = _merit(T, Tg)  # backtracking: halve the step until |Δp|² + angle² decreases
    for h in range(halvings + 1):
        for j in range(n):
            qc[j] = q[j] + f * dq[j]
        _kin.forward_pose(a, alpha, d, offs, prism, modified, base, tool, qc, Tc)
        if _merit(Tc, Tg) < merit:
            return True
        f *= 0.5
    return False


@numba.njit(cache=True)
def _start(problem, q):
    """:func:`pipeline.solvers.kernels.loop.iterate`'s ``start``: FK and error at the start, and the first step
    planned (a stall when backtracking finds none). State: ``(T, Tj, axes, origins, p, e, J, dq, qc, Tc, m)``,
    ``m`` = (‖e‖, |Δp|, step scale)."""
    n = q.shape[0]
    state = (np.empty((4, 4)), np.empty((4, 4)), np.empty((n, 3)), np.empty((n, 3)), np.empty(3), np.empty(6),
             np.empty((6, n)), np.empty(n), np.empty(n), np.empty((4, 4)), np.empty(3))
    en, ok = _measure(problem, state, q)
    stalled = math.isfinite(en) and not ok and 0 < problem[20] and not _plan(problem, state, q)
    return state, en, ok, stalled


@numba.njit(cache=True)
def _step(problem, state, q, it):
    """``step``: the planned step taken, FK and error, and (below the cap, unless stopping) the next step
    planned: a stall when backtracking finds none (the step that was not taken is not counted)."""
    dq, qc, m = state[7], state[8], state[10]
    f = m[2]
    for j in range(q.shape[0]):
        if problem[24] > 0:
            q[j] = qc[j]
        else:
            q[j] += f * dq[j] if f != 1.0 else dq[j]
    en, ok = _measure(problem, state, q)
    stalled = math.isfinite(en) and not ok and it < problem[20] and not _plan(problem, state, q)
    return en, ok, stalled, 0


@numba.njit(cache=True)
def _record(problem, state, trace, row):
    """``record``: ``[‖e‖, e (6), |Δp|]``."""
    m = state[10]
    error_row(trace, row, m[0], state[5], m[1])


@numba.njit(cache=True)
def descent(a, alpha, d, offs, prism, modified, base, tool, ja, jalpha, jd, joffs, jprism, jmodified, jbase, jtool,
            own_jacobian, Tg, q0, rate, tol, max_iter, rcond, lam2, max_step, halvings, tol_pos, tol_rot, q, trace,
            times):
    """Jacobian-pseudoinverse descent ``θ ← θ + rate · J⁺ e`` (Apêndice E, first listing;
    :func:`pipeline.solvers.kernels.loop.iterate` with this module's step).

    The second chain (``ja ... jtool``) gives the geometric Jacobian unless ``own_jacobian``.
    ``J⁺`` by SVD with singular values below ``rcond · σ_max`` dropped (a guard the listing does
    not have); ``lam2 > 0`` replaces 1/σ by σ / (σ² + lam2) (a damped J⁺); ``max_step > 0`` scales a step
    whose largest joint change exceeds it down to it (0: the listing, no clamp); ``halvings > 0`` backtracks:
    a step that does not decrease ‖e‖ is halved up to ``halvings`` times (merit |Δp|² + angle²), then the loop
    stops (code 2; 0: the listing, every step taken).
    ``tol_pos >= 0`` adds the stop test |Δp| <= tol_pos and angle <= tol_rot (success).
    ``trace`` (max_iter + 1, 8) receives [‖e‖, e (6), |Δp|] per iterate; ``times`` (2,) [ns] the solve time
    and 0. Returns (stop code, steps).
    """
    code, it, _ = iterate(_start, _step, _record, (a, alpha, d, offs, prism, modified, base, tool, ja, jalpha, jd, joffs,
                                                   jprism, jmodified, jbase, jtool, own_jacobian, Tg, rate, tol,
                                                   max_iter, rcond, lam2, max_step, halvings, tol_pos, tol_rot),
                          q0, q, trace, times, NEVER, max_iter)
    return code, it


@numba.njit(cache=True)
def _chain_of(P, n):
    form = int(P[P_MOD])
    na, nal = (12 * n, 3 * n) if form == 2 else (n, n)  # general form: origins and axes, see _kin
    c = P_CHAIN
    e = c + na + nal
    return (P[c:c + na], P[c + na:e], P[e:e + n], P[e + n:e + 2 * n], P[e + 2 * n:e + 3 * n],
            form, P[P_BASE:P_BASE + 16].reshape((4, 4)), P[P_TOOL:P_TOOL + 16].reshape((4, 4)))


@numba.njit(cache=True)
def _norms(T, P):
    """(‖p − p_goal‖ [working unit], ‖R − R_goal‖_F) — the two terms of the costs."""
    dp = 0.0
    for r in range(3):
        x = T[r, 3] - P[P_GOAL + r]
        dp += x * x
    dr = 0.0
    for r in range(3):
        for c in range(3):
            x = T[r, c] - P[P_GOAL + 3 + 3 * r + c]
            dr += x * x
    return math.sqrt(dp), math.sqrt(dr)


@numba.njit(cache=True)
def cost(q, P):
    """``w_p ‖Δp‖ + w_R ‖ΔR‖_F`` (or its squared form when ``P[P_SQ]``); ``w_p`` already per working unit."""
    a, alpha, d, offs, prism, modified, base, tool = _chain_of(P, q.shape[0])
    T = np.empty((4, 4))
    _kin.forward_pose(a, alpha, d, offs, prism, modified, base, tool, q, T)
    dp, dr = _norms(T, P)
    if P[P_SQ] != 0.0:
        return P[P_WP] * dp * dp + P[P_WR] * dr * dr
    return P[P_WP] * dp + P[P_WR] * dr


@numba.njit(cache=True)
def cost_grad(q, P):
    """(cost, gradient (n,)): ∂p/∂q_j = J_v[:, j], ∂R/∂q_j = [ω_j]× R (ω_j = J_ω[:, j]).

    At a kink of the non-squared cost (Δp = 0 or ΔR = 0) that term's gradient is taken as 0.
    """
    n = q.shape[0]
    a, alpha, d, offs, prism, modified, base, tool = _chain_of(P, n)
    T = np.empty((4, 4))
    axes = np.empty((n, 3))
    origins = np.empty((n, 3))
    J = np.empty((6, n))
    p = np.empty(3)
    _kin.forward(a, alpha, d, offs, prism, modified, base, tool, q, axes, origins, T)
    for r in range(3):
        p[r] = T[r, 3]
    _kin.jacobian(prism, axes, origins, p, J)
    dpv = np.empty(3)
    dR = np.empty((3, 3))
    for r in range(3):
        dpv[r] = T[r, 3] - P[P_GOAL + r]
        for c in range(3):
            dR[r, c] = T[r, c] - P[P_GOAL + 3 + 3 * r + c]
    dp, dr = _norms(T, P)
    sq = P[P_SQ] != 0.0
    wp, wr = P[P_WP], P[P_WR]
    if sq:
        f = wp * dp * dp + wr * dr * dr
        cp, cr = 2.0 * wp, 2.0 * wr
    else:
        f = wp * dp + wr * dr
        # d‖x‖ = ½ d(‖x‖²) / ‖x‖, and gp, gr below are ½ d(‖·‖²)/dq_j
        cp = wp / dp if dp > 0.0 else 0.0
        cr = wr / dr if dr > 0.0 else 0.0
    g = np.empty(n)
    for j in range(n):
        gp = dpv[0] * J[0, j] + dpv[1] * J[1, j] + dpv[2] * J[2, j]
        wx, wy, wz = J[3, j], J[4, j], J[5, j]
        gr = 0.0  # ½ d‖ΔR‖²_F / dq_j = Σ ΔR ⊙ ([ω]× R)
        for c in range(3):
            rx, ry, rz = T[0, c], T[1, c], T[2, c]
            gr += dR[0, c] * (wy * rz - wz * ry) + dR[1, c] * (wz * rx - wx * rz) + dR[2, c] * (wx * ry - wy * rx)
        g[j] = cp * gp + cr * gr
    return f, g


@numba.njit(cache=True)
def trace_rows(X, P, Tg, out):
    """Per iterate ``X[k]``: [cost, e (6), |Δp|] into ``out`` (k, 8)."""
    n = X.shape[1]
    a, alpha, d, offs, prism, modified, base, tool = _chain_of(P, n)
    T = np.empty((4, 4))
    e = np.empty(6)
    for k in range(X.shape[0]):
        q = X[k].copy()
        _kin.forward_pose(a, alpha, d, offs, prism, modified, base, tool, q, T)
        dp = doc_error(T, Tg, e)
        d1, d2 = _norms(T, P)
        if P[P_SQ] != 0.0:
            out[k, 0] = P[P_WP] * d1 * d1 + P[P_WR] * d2 * d2
        else:
            out[k, 0] = P[P_WP] * d1 + P[P_WR] * d2
        for r in range(6):
            out[k, 1 + r] = e[r]
        out[k, TRACE_DP] = dp


@numba.njit(cache=True)
def pose_check(a, alpha, d, offs, prism, modified, base, tool, q, Tg):
    """(|Δp|, rotation angle, |t| of T_goal T⁻¹) of ``q`` by the compiled FK (a method's own claim)."""
    T = np.empty((4, 4))
    _kin.forward_pose(a, alpha, d, offs, prism, modified, base, tool, q, T)
    return _kin.position_distance(Tg, T), _kin.rotation_angle(Tg, T), _kin.relative_translation_norm(Tg, T)


# ---- settings --------------------------------------------------------------------------------

_PI = re.compile(r"^\s*([-+]?)\s*(?:(\d+(?:\.\d+)?)\s*\*\s*)?pi\s*(?:/\s*(\d+(?:\.\d+)?))?\s*$")


def _angle(text: str) -> float:
    m = _PI.match(text)
    if m:
        sign, mul, div = m.groups()
        return (-1.0 if sign == "-" else 1.0) * float(mul or 1) * math.pi / float(div or 1)
    return float(text)


def parse_bounds(text: str) -> list[tuple[float, float]] | str:
    """``limits`` / ``none`` or ``"lo, hi; lo, hi; ..."`` (one pair per joint, numbers or pi expressions)."""
    t = text.strip()
    if t in ("limits", "none"):
        return t
    out = []
    for k, pair in enumerate(t.split(";")):
        parts = [x for x in pair.split(",")]
        if len(parts) != 2:
            raise ValueError(f"joint {k + 1}: expected 'lo, hi', got {pair.strip()!r}")
        lo, hi = (_angle(x) for x in parts)
        if not lo < hi:
            raise ValueError(f"joint {k + 1}: lo must be < hi, got {pair.strip()!r}")
        out.append((lo, hi))
    return out


@dataclass(frozen=True)
class DescentSettings(Settings):
    """J⁺ gradient descent. Defaults: a faster, safeguarded descent (rate 0.5, λ = 0.01, backtracking,
    stop at the success tolerance) that solves >= 99 % of warm starts; the listing is rate 0.05,
    damping 0, halvings 0, stop_at_tolerance false (data/studies/nepomuceno2024.yaml)."""

    rate: float = setting(0.5, "step factor of θ ← θ + rate · J⁺ e (Apêndice E: 0.05)", above=0.0, maximum=2.0)
    tolerance: float = setting(1e-6, "stop (success claim) when ‖e‖ < tolerance, e = [Δp; ½Σcᵢ×dᵢ] "
                               "(position part in length_unit, orientation part sin(angle))", unit="m | 1",
                               above=0.0, length=True)
    max_iterations: int = setting(5000, "iteration cap (stop code 4)", minimum=1, maximum=10_000_000)
    rcond: float = setting(1e-12, "singular values below rcond · σ_max are dropped from J⁺", minimum=0.0, maximum=1.0)
    damping: float = setting(0.01, "λ of the damped inverse σ / (σ² + λ²) of each singular value "
                             "(0 = the listing's 1 / σ)", minimum=0.0)
    max_step: float = setting(0.0, "largest joint change of one step; a longer step is scaled down to it "
                              "(0 = no clamp, the listing)", unit="rad | m", minimum=0.0)
    halvings: int = setting(30, "backtracking: a step that does not decrease |Δp|² + angle² is halved up to "
                            "this many times, then stop code 2 (0 = every step taken, the listing)", minimum=0, maximum=60)
    stop_at_tolerance: bool = setting(True, "also stop (success claim) as soon as the pose meets tol_pos / tol_rot "
                                      "(pos_orient and position criteria; false = only the listing's ‖e‖ test)")
    jacobian_robot: str = setting("", "robot file (path from the repository root, inside its data folder) whose "
                                  "DH table gives the Jacobian; '' = the solved robot (model-mismatch runs)",
                                  file=True)


@dataclass(frozen=True)
class CostSettings(Settings):
    """The cost every SciPy method minimises (defaults: squared, in SI, so that 0.1 mm is reachable)."""

    position_weight: float = setting(1.0, "w_p of w_p ‖Δp‖ (‖Δp‖ in m; per m² when squared)", minimum=0.0)
    rotation_weight: float = setting(1.0, "w_R of w_R ‖R − R_goal‖_F (Apêndice B: 1, Apêndice C: 0.1)", minimum=0.0)
    squared: bool = setting(True, "square both norms (eq. 2.15; the listings' costs are not squared)")

    def check(self, where: str) -> None:
        if self.position_weight == 0.0 and self.rotation_weight == 0.0:
            raise SettingsError(f"{where}: field 'position_weight': both weights are 0")


@dataclass(frozen=True)
class BFGSSettings(CostSettings):
    gradient: str = setting("analytic", "analytic (compiled) or SciPy's 2-point forward differences "
                            "(the listings pass no jac)", choices=("analytic", "2-point"))
    max_iterations: int = setting(1000, "SciPy maxiter (its default is 200 n)", minimum=1, maximum=10_000_000)
    gtol: float = setting(1e-12, "SciPy gtol: stop when the gradient's max-norm is below this "
                          "(Apêndice B: 1e-6)", minimum=0.0)


@dataclass(frozen=True)
class LBFGSBSettings(CostSettings):
    gradient: str = setting("analytic", "analytic (compiled) or SciPy's 2-point forward differences",
                            choices=("analytic", "2-point"))
    bounds: str = setting("limits", "box: 'limits' (the robot file's joint limits where finite), 'none', or "
                          "'lo, hi; lo, hi; ...' one pair per joint [rad | m] (pi expressions allowed)")
    max_iterations: int = setting(15000, "SciPy maxiter", minimum=1, maximum=10_000_000)
    max_evaluations: int = setting(15000, "SciPy maxfun", minimum=1, maximum=10_000_000)
    gtol: float = setting(1e-12, "SciPy gtol (projected gradient max-norm)", minimum=0.0)
    ftol: float = setting(1e-15, "SciPy ftol: relative cost decrease (absolute when the cost is < 1; "
                          "Apêndice C: 1e-6)", minimum=0.0)
    maxcor: int = setting(10, "SciPy maxcor (stored corrections)", minimum=1)

    def check(self, where: str) -> None:
        super().check(where)
        try:
            parse_bounds(self.bounds)
        except ValueError as exc:
            raise SettingsError(f"{where}: field 'bounds': {exc}") from None

    def check_robot(self, n_joints: int, where: str) -> None:
        b = parse_bounds(self.bounds)
        if isinstance(b, list) and len(b) != n_joints:
            raise SettingsError(f"{where}: field 'bounds': {len(b)} pairs for a robot with {n_joints} joints")


@dataclass(frozen=True)
class NelderMeadSettings(CostSettings):
    max_iterations: int = setting(5000, "SciPy maxiter (its default is 200 n)", minimum=1, maximum=10_000_000)
    max_evaluations: int = setting(0, "SciPy maxfev; 0 = unlimited when max_iterations is given", minimum=0)
    xatol: float = setting(1e-10, "SciPy xatol: simplex size in the joints [rad]", minimum=0.0)
    fatol: float = setting(1e-14, "SciPy fatol: spread of the cost over the simplex", minimum=0.0)
    adaptive: bool = setting(True, "SciPy adaptive (dimension-dependent coefficients)")
    simplex_step: float = setting(0.05, "initial simplex q0 + step e_i [rad | m]; 0 = SciPy's default "
                                  "(5 % of each non-zero start angle)", minimum=0.0)


# ---- helpers ---------------------------------------------------------------------------------

def _m_per_unit(prep: Prepared) -> float:
    from pipeline.robots import LENGTH_UNITS

    return float(LENGTH_UNITS[prep.unit])


def packed_cost(prep: Prepared, T_goal: np.ndarray, s: CostSettings) -> np.ndarray:
    """The cost's packed parameters for one goal (weights turned into the working unit)."""
    a, alpha, d, offs, prism, modified, base, tool = prep.args
    k = _m_per_unit(prep)
    wp = s.position_weight * (k * k if s.squared else k)
    head = np.array([wp, s.rotation_weight, 1.0 if s.squared else 0.0, float(modified)])
    goal = np.concatenate([T_goal[:3, 3], T_goal[:3, :3].ravel()])
    return np.ascontiguousarray(np.concatenate([head, goal, base.ravel(), tool.ravel(), a, alpha, d, offs,
                                                prism.astype(float)]))


def _claim(prep: Prepared, T_goal: np.ndarray, q: np.ndarray, s: Settings) -> bool:
    if not np.all(np.isfinite(q)):
        return False
    dp, ang, t = pose_check(*prep.args, np.ascontiguousarray(q, dtype=float), T_goal)
    return meets(s, float(dp), float(ang), float(t))


def _bounds(prep: Prepared, s: LBFGSBSettings):
    return prep.memo(("lbfgsb_bounds", s.bounds), lambda: _make_bounds(prep, s))


def _make_bounds(prep: Prepared, s: LBFGSBSettings):
    b = parse_bounds(s.bounds)
    if b == "none":
        return None
    if b == "limits":
        lim = prep.limits
        out = [(float(lo) if math.isfinite(lo) else None, float(hi) if math.isfinite(hi) else None) for lo, hi in lim]
        return None if all(lo is None and hi is None for lo, hi in out) else out
    if len(b) != prep.n:
        raise SettingsError(f"solver settings: field 'bounds': {len(b)} pairs for a robot with {prep.n} joints")
    f = prep.goal_scale
    return [(lo * f, hi * f) if prep.prismatic[i] else (lo, hi) for i, (lo, hi) in enumerate(b)]


def _jacobian_args(prep: Prepared, robot_file: str) -> tuple:
    """Kernel arrays of the robot file whose Jacobian the descent uses (``jacobian_robot``)."""
    from pipeline.robots import load_robot

    jm = load_robot(check_data_path(robot_file, "solver settings: field 'jacobian_robot'"))
    if jm.n != prep.n:
        raise SettingsError(f"solver settings: field 'jacobian_robot': {jm.n} joints, the robot has {prep.n}")
    return Prepared(jm, prep.unit).args




# ---- run functions ---------------------------------------------------------------------------

def run_descent(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: DescentSettings, seed: int) -> Raw:
    if s.jacobian_robot:
        jargs = prep.memo(("jpinv_jacobian", s.jacobian_robot), lambda: _jacobian_args(prep, s.jacobian_robot))
        own = False
    else:
        jargs, own = prep.args, True
    tp, tr = -1.0, -1.0
    if s.stop_at_tolerance and s.criterion in ("pos_orient", "position"):
        tp, tr = s.tol_pos, (math.inf if s.criterion == "position" else s.tol_rot)
    q, trace, times, (code, it) = run_loop(
        descent, (*prep.args, *jargs, own, T_goal, q_start, float(s.rate), float(s.tolerance), int(s.max_iterations),
                  float(s.rcond), float(s.damping) ** 2, float(s.max_step), int(s.halvings), tp, tr),
        q_start, s.max_iterations)
    it = int(it)
    return Raw(q=q, code=int(code), iterations=it, solve_ns=int(times[0]), trace=trace,
               info={"nfev": it + 1, "njev": it, "doc_error": float(trace[it, 0]),
                     "message": {SUCCESS: "norm(e) < tolerance", STALLED: "no decrease after backtracking",
                                 ITERATION_CAP: "iteration cap", NON_FINITE: "non-finite"}.get(int(code), "")})


def _scipy_runner(method: str):
    def run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: CostSettings, seed: int) -> Raw:
        from scipy.optimize import minimize

        P = packed_cost(prep, T_goal, s)
        q0 = np.ascontiguousarray(q_start, dtype=float)
        bounds = None
        if method == "Nelder-Mead":
            options = {"maxiter": s.max_iterations, "xatol": s.xatol, "fatol": s.fatol, "adaptive": s.adaptive}
            if s.max_evaluations:
                options["maxfev"] = s.max_evaluations
            if s.simplex_step > 0.0:
                options["initial_simplex"] = np.vstack([q0, q0 + s.simplex_step * np.eye(prep.n)])
            fun, jac = cost, None
        else:
            fun, jac = (cost_grad, True) if s.gradient == "analytic" else (cost, None)
            if method == "BFGS":
                options = {"maxiter": s.max_iterations, "gtol": s.gtol}
            else:
                options = {"maxiter": s.max_iterations, "maxfun": s.max_evaluations, "gtol": s.gtol,
                           "ftol": s.ftol, "maxcor": s.maxcor}
                bounds = _bounds(prep, s)
        xs = [q0.copy()]

        def callback(xk):
            xs.append(np.array(xk, dtype=float))

        t0 = clock_ns()
        res = minimize(fun, q0, args=(P,), method=method, jac=jac, bounds=bounds, callback=callback, options=options)
        t1 = clock_ns()
        q = np.array(res.x, dtype=float)
        nit = int(res.nit)
        msg = str(res.message)
        if not np.all(np.isfinite(q)) or not math.isfinite(float(res.fun)):
            code = StopReason.NON_FINITE
        elif _claim(prep, T_goal, q, s):
            code = StopReason.SUCCESS
        elif nit >= s.max_iterations or "maximum number" in msg.lower() or "limit" in msg.lower():
            code = StopReason.ITERATION_CAP
        else:
            code = StopReason.STALLED
        X = np.ascontiguousarray(np.array(xs[: nit + 1]))
        trace = np.empty((X.shape[0], TRACE_COLS))
        trace_rows(X, P, T_goal, trace)
        nfev = int(res.nfev)
        njev = int(getattr(res, "njev", 0) or 0)
        return Raw(q=q, code=int(code), iterations=nit, solve_ns=int(t1 - t0), trace=trace,
                   info={"nfev": nfev, "njev": njev, "doc_error": float(res.fun), "message": msg,
                         "optimizer_success": bool(res.success), "optimizer_status": int(res.status)})

    return run


register(Solver("jpinv_descent", "Jacobian-pseudoinverse gradient descent θ += rate · J⁺ e, "
                "e = [Δp; ½Σcᵢ×dᵢ] (Apêndice E)", "local", DescentSettings, run_descent, source=SOURCE))
register(Solver("bfgs", "SciPy BFGS on w_p‖Δp‖ + w_R‖ΔR‖_F (squared or not; Apêndice B)", "local",
                BFGSSettings, _scipy_runner("BFGS"), source=SOURCE))
register(Solver("lbfgsb", "SciPy L-BFGS-B on w_p‖Δp‖ + w_R‖ΔR‖_F in a joint box (Apêndice C)", "local",
                LBFGSBSettings, _scipy_runner("L-BFGS-B"), source=SOURCE))
register(Solver("nelder_mead", "SciPy Nelder-Mead on w_p‖Δp‖ + w_R‖ΔR‖_F (§4.2; no listing)", "local",
                NelderMeadSettings, _scipy_runner("Nelder-Mead"), source=SOURCE))
