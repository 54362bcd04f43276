"""Particle swarm as in Rookfighter/pso-cpp ``Optimizer::minimize`` (002_56eb235931bf5f5d.txt §3.6, eqs. 9-11).

Registered as ``pso`` (kind ``global``). Fitness of joint vector ``q``: ``|p_goal - p(q)|`` for the
position-only criteria (``position``, ``dq_norm_body``), else ``sqrt(|p_goal - p(q)|^2 +
(orientation_scale * angle)^2)`` with ``angle`` the rotation angle between goal and reached orientation.

The library's loop, transcribed: particles uniform in the search box (one draw per particle and
joint, particle-major), initial velocities ``clamp(U(-range, range), -max_velocity, max_velocity)`` (all
zero when ``max_velocity`` = 0, the library default), then per iteration
``v = w v + c1 u (pbest - x) + c2 u (gbest - x)`` (clamped to +-max_velocity only when it is > 0),
``x = clamp(x + v, box)``, personal and global bests; the library stops when the mean over particles of
|change of personal-best fitness| <= ``feps`` or of ||change of personal-best position|| <= ``xeps``
(a negative value disables that test); ``max_iterations`` caps the run (the library's default is
unlimited). The library's stop claims success only when the global best is within the tolerances
(``|dp| <= tol_pos``, and ``angle <= tol_rot`` for full pose goals), else code 2; the cap gives code 4.
``stop_at_tolerance`` (not in pso-cpp) also ends the run, with success, as soon as the global best is
within the tolerances.

Search box (``search``): ``box`` = :meth:`Prepared.search_box` (the joint limits, +-pi for an unbounded
revolute joint); ``window`` = ``q_start +- window_half_width`` intersected with the joint limits (the
path mode of §3.6: the previous solution's neighbourhood). With ``window_max_distance`` > 0 the window
is used only when the start pose's position lies within that distance of the goal; a start farther
away searches the whole box (a path's first point, far from the start configuration). A robot with a
prismatic joint without limits is refused (no finite box).

Random stream: numba's generator seeded once per solve with the ``seed`` argument of
:func:`pipeline.solvers.solve` when the ``seed`` setting is 0, else with a number mixed from both by
``numpy.random.SeedSequence([setting, argument])``. The library seeds with ``time(0)``.
Timing as :mod:`pipeline.solvers.iterative.fd_jacobian` (``Raw.info``: ``cpu_time_s``, ``stream_seed``, ``window``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

import pipeline.solvers.kernels.kin as _kin
from pipeline.solvers.kernels.kin import NEVER
from pipeline.solvers.kernels.loop import iterate, pose_row
from pipeline.solvers.core import POSITION_CRITERIA, Prepared, Raw, Settings, SettingsError, setting
from pipeline.solvers.core.driver import run_loop
from pipeline.solvers.core.registry import Solver, register

SOURCE = "002_56eb235931bf5f5d.txt (Borges et al.) §3.6, eqs. 9-11; Rookfighter/pso-cpp Optimizer::minimize"



@dataclass(frozen=True)
class PSOSettings(Settings):
    """Settings of ``pso``. Defaults: a constriction-type swarm (Clerc & Kennedy 2002: w = 0.7298,
    c1 = c2 = 1.49618) over the joint box that stops at the tolerance; the document's swarm is w = 1,
    c1 = c2 = 2 with the library stop (data/studies/borges_kr6.yaml)."""

    particles: int = setting(100, "swarm size", minimum=1, maximum=1_000_000)
    inertia: float = setting(0.7298, "inertia weight w (pso-cpp ConstantWeight)")
    c1: float = setting(1.49618, "cognitive coefficient (pso-cpp phip)")
    c2: float = setting(1.49618, "social coefficient (pso-cpp phig)")
    max_velocity: float = setting(0.0, "pso-cpp maxVel per iteration (rad; working length unit for a prismatic "
                                  "joint): > 0 draws random initial velocities clamped to +-maxVel and clamps every "
                                  "velocity; 0 (library default) starts at rest and never clamps", unit="rad",
                                  minimum=0.0)
    max_velocity_fraction: float = setting(0.0, "velocity clamp per joint as a fraction k of that joint's search "
                                           "range, Vmax_j = k (hi_j - lo_j) (Eberhart & Shi 2001: Vmax at 10-20 % "
                                           "of the dynamic range); > 0 replaces max_velocity, with its meaning",
                                           minimum=0.0, maximum=1.0)
    feps: float = setting(1e-9, "library stop: mean |change of personal-best fitness| <= feps; negative disables",
                          unit="m", length=True)
    xeps: float = setting(1e-6, "library stop: mean ||change of personal-best position|| <= xeps; negative "
                          "disables", unit="rad")
    max_iterations: int = setting(1000, "iteration cap (stop code 4; pso-cpp's default is unlimited)", minimum=1,
                                  maximum=10_000_000)
    stop_at_tolerance: bool = setting(True, "also stop, with success, as soon as the global best meets tol_pos "
                                      "(and tol_rot for full pose goals); not in pso-cpp")
    search: str = setting("box", "box: the joint-limit box (prep.search_box(): +-pi for unbounded revolute "
                          "joints); window: q_start +- window_half_width within the limits", choices=("box", "window"))
    window_half_width: float = setting(0.25, "half-width of the window around q_start (search: window)", unit="rad",
                                       above=0.0)
    window_max_distance: float = setting(0.0, "search: window only when |p(q_start) - p_goal| <= this, else the whole "
                                         "box; 0 = always the window", unit="m", minimum=0.0, length=True)
    orientation_scale: float = setting(0.1, "length per rad that weights the rotation angle in the fitness (full "
                                       "pose goals)", unit="m", above=0.0, length=True)
    seed: int = setting(0, "0: the solve's seed argument seeds the stream as is; else mixed with it "
                        "(numpy SeedSequence)", minimum=0)

    def check(self, where: str) -> None:
        if self.max_velocity > 0 and self.max_velocity_fraction > 0:
            raise SettingsError(f"{where}: field 'max_velocity_fraction': set either max_velocity or "
                                "max_velocity_fraction, not both")

    def pose(self) -> bool:
        return self.criterion not in POSITION_CRITERIA

    def velocity_limits(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Per-joint velocity clamp (n,) for the search box [lo, hi]; 0 = no clamp (the library default)."""
        if self.max_velocity_fraction > 0:
            return self.max_velocity_fraction * (hi - lo)
        return np.full(len(lo), float(self.max_velocity))


# ---- compiled kernel ------------------------------------------------------------------------
@numba.njit(cache=True)
def _fitness(a, alpha, d, offs, prism, modified, base, tool, Tg, x, pose, scale, T):
    _kin.forward_pose(a, alpha, d, offs, prism, modified, base, tool, x, T)
    dx, dy, dz = Tg[0, 3] - T[0, 3], Tg[1, 3] - T[1, 3], Tg[2, 3] - T[2, 3]
    dp = np.sqrt(dx * dx + dy * dy + dz * dz)
    if pose:
        so = scale * _kin.rotation_angle(Tg, T)
        return np.sqrt(dp * dp + so * so)
    return dp


@numba.njit(cache=True)
def _best(problem, state, q):
    """The global best: its index into ``state``'s ``gb``, its joints into ``q``, its FK into ``T`` (and its
    rotation vector into ``rv`` for pose goals); returns (fitness, success: within tol_pos (and tol_rot))."""
    a, alpha, d, offs, prism, modified, base, tool, Tg = problem[:9]
    pose, tol_pos, tol_rot = problem[19], problem[21], problem[22]
    T, qa, qb, rv, x, v, fv, bx, bf, gb = state
    g = 0
    for i in range(bf.shape[0]):
        if bf[i] < bf[g]:
            g = i
    gb[0] = g
    for j in range(q.shape[0]):
        q[j] = bx[g, j]
    _kin.forward_pose(a, alpha, d, offs, prism, modified, base, tool, q, T)
    dx, dy, dz = Tg[0, 3] - T[0, 3], Tg[1, 3] - T[1, 3], Tg[2, 3] - T[2, 3]
    dp = np.sqrt(dx * dx + dy * dy + dz * dz)
    ang = _kin.rotation_vector(Tg, T, qa, qb, rv) if pose else 0.0
    return bf[g], dp <= tol_pos and (not pose or ang <= tol_rot)


@numba.njit(cache=True)
def _start(problem, q):
    """:func:`pipeline.solvers.kernels.loop.iterate`'s ``start``: the swarm drawn in the box [lo, hi].

    State: ``(T, qa, qb, rv, x, v, fv, bx, bf, gb)``: positions ``x`` (P, n), velocities ``v``, fitness
    ``fv`` (P,), each particle's best ``bx``, ``bf``, the global best's index ``gb`` (1,)."""
    a, alpha, d, offs, prism, modified, base, tool, Tg, lo, hi, P = problem[:12]
    vmax, pose, scale, stop_at_tol = problem[15], problem[19], problem[20], problem[18]
    n = lo.shape[0]
    x = np.empty((P, n))
    v = np.empty((P, n))
    for i in range(P):
        for j in range(n):
            x[i, j] = lo[j] + np.random.random() * (hi[j] - lo[j])
    for i in range(P):
        for j in range(n):
            diff = hi[j] - lo[j]
            vel = -diff + np.random.random() * 2.0 * diff
            v[i, j] = min(vmax[j], max(-vmax[j], vel))
    T = np.empty((4, 4))
    fv = np.empty(P)
    for i in range(P):
        fv[i] = _fitness(a, alpha, d, offs, prism, modified, base, tool, Tg, x[i], pose, scale, T)
    state = (T, np.empty(4), np.empty(4), np.empty(3), x, v, fv, x.copy(), fv.copy(), np.zeros(1, np.int64))
    fbest, within = _best(problem, state, q)
    return state, fbest, stop_at_tol and within, False


@numba.njit(cache=True)
def _step(problem, state, q, it):
    """``step``: every particle's velocity and position, fitness, bests; converged when the mean
    improvement of the bests or their mean move is below feps or xeps (then a success when the global
    best is within the tolerances, else a stall); with ``stop_at_tol``, success as soon as it is."""
    a, alpha, d, offs, prism, modified, base, tool, Tg, lo, hi, P, w, phip, phig, vmax, feps, xeps = problem[:18]
    stop_at_tol, pose, scale = problem[18], problem[19], problem[20]
    T, qa, qb, rv, x, v, fv, bx, bf, gb = state
    n = lo.shape[0]
    g = gb[0]
    for i in range(P):
        for j in range(n):
            velp = np.random.random() * (bx[i, j] - x[i, j])
            velg = np.random.random() * (bx[g, j] - x[i, j])
            vel = w * v[i, j] + phip * velp + phig * velg
            if vmax[j] > 0:
                vel = min(vmax[j], max(-vmax[j], vel))
            v[i, j] = vel
    for i in range(P):
        for j in range(n):
            x[i, j] = min(hi[j], max(lo[j], x[i, j] + v[i, j]))
    for i in range(P):
        fv[i] = _fitness(a, alpha, d, offs, prism, modified, base, tool, Tg, x[i], pose, scale, T)
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
    fbest, within = _best(problem, state, q)
    converged = fsum / P <= feps or xsum / P <= xeps
    return fbest, within and (stop_at_tol or converged), converged and not within, 0


@numba.njit(cache=True)
def _record(problem, state, trace, row):
    """``record``: ``[best fitness, p_goal - p (3), rotation vector (3) (0 for position goals), |dp|]``."""
    bf, gb = state[8], state[9]
    pose_row(trace, row, bf[gb[0]], problem[8], state[0], state[3], problem[19])


@numba.njit(cache=True)
def pso_solve(a, alpha, d, offs, prism, modified, base, tool, Tg, q0, lo, hi, n_particles, w, phip, phig, vmax, feps,
              xeps, max_iter, stop_at_tol, pose, scale, tol_pos, tol_rot, seed, q, trace, times):
    """The pso-cpp loop in the box [lo, hi] (:func:`pipeline.solvers.kernels.loop.iterate` with this module's
    step; ``q0`` only fills ``q`` before the swarm's best does). Returns (code, iterations); ``times`` =
    (wall ns, 0, thread CPU ns)."""
    np.random.seed(seed)
    code, it, _ = iterate(_start, _step, _record, (a, alpha, d, offs, prism, modified, base, tool, Tg, lo, hi,
                                                   n_particles, w, phip, phig, vmax, feps, xeps, stop_at_tol, pose,
                                                   scale, tol_pos, tol_rot), q0, q, trace, times, NEVER, max_iter)
    return code, it


# ---- registry entry -------------------------------------------------------------------------
def stream_seed(setting_seed: int, seed: int) -> int:
    """The seed of numba's generator for one solve (see the module docstring)."""
    if setting_seed == 0:
        return int(seed) % 2**32
    return int(np.random.SeedSequence([int(setting_seed), int(seed) % 2**63]).generate_state(1)[0])


def search_bounds(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray,
                  s: PSOSettings) -> tuple[np.ndarray, np.ndarray, bool]:
    """(lo, hi, window used) of one solve (``T_goal`` and ``q_start`` in the working unit)."""
    use_window = s.search == "window"
    if use_window and s.window_max_distance > 0:
        T0 = np.empty((4, 4))
        _kin.forward_pose(*prep.args, np.ascontiguousarray(q_start, dtype=float), T0)
        use_window = _kin.position_distance(T0, T_goal) <= s.window_max_distance
    if not use_window:
        box = prep.memo(("pso_box",), prep.search_box)
        return np.ascontiguousarray(box[:, 0]), np.ascontiguousarray(box[:, 1]), False
    lim = prep.limits
    c = np.clip(q_start, lim[:, 0], lim[:, 1])
    lo = np.maximum(lim[:, 0], c - s.window_half_width)
    hi = np.minimum(lim[:, 1], c + s.window_half_width)
    return np.ascontiguousarray(lo), np.ascontiguousarray(hi), True


def applies_to(prep: Prepared) -> str | None:
    """PSO needs a finite joint box: refused for a prismatic joint without limits (also in window mode, since
    the registry decides applicability from the robot alone)."""
    unbounded = [i + 1 for i in range(prep.n) if prep.prismatic[i] and not np.all(np.isfinite(prep.limits[i]))]
    if unbounded:
        return f"prismatic joint(s) {unbounded} without limits give no finite search box"
    return None


def run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: PSOSettings, seed: int) -> Raw:
    lo, hi, window = search_bounds(prep, T_goal, q_start, s)
    sseed = stream_seed(s.seed, seed)
    q, trace, times, (code, it) = run_loop(
        pso_solve, (*prep.args, T_goal, q_start, lo, hi, int(s.particles), float(s.inertia), float(s.c1), float(s.c2),
                    s.velocity_limits(lo, hi), float(s.feps), float(s.xeps), int(s.max_iterations),
                    bool(s.stop_at_tolerance), s.pose(), float(s.orientation_scale), float(s.tol_pos),
                    float(s.tol_rot), sseed), q_start, s.max_iterations, clocks=3)
    return Raw(q=q, code=int(code), iterations=int(it), solve_ns=int(times[0]), trace=trace,
               info={"cpu_time_s": int(times[2]) * 1e-9, "stream_seed": sseed, "window": window})


register(Solver("pso", "particle swarm optimisation over the joint box or a window around the start (pso-cpp; "
                "eqs. 9-11)", "global", PSOSettings, run, applies_to=applies_to, source=SOURCE))
