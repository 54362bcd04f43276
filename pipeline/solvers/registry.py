"""The solver registry: a name -> settings type, applicability test and kernel call.

Every method of the five studies registers here under one name (``python -m pipeline solvers``
lists them). A method module defines a :class:`~pipeline.solvers.base.Settings` subclass and a
``run(prep, T_goal, q_start, settings, seed) -> Raw`` function and calls :func:`register`; the
registry does the rest the same way for all of them (settings validation, unit conversion,
applicability, timing of the whole call, FK check, limits).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from pipeline.robots import RobotModel
from pipeline.solvers.base import (BatchResult, IKResult, NotApplicableError, Prepared, Raw, Settings, SettingsError,
                                   finish, finish_batch)
from pipeline.solvers.timing import clock_ns

KINDS = ("local", "global", "analytic")


@dataclass(frozen=True)
class Solver:
    """One registered IK method.

    Attributes
    ----------
    name : str                      registry name (letters, digits, underscores)
    title : str                     one-line description
    kind : {"local", "global", "analytic"}
        local: iterates from the start angles; global: searches the joint box (start ignored or
        used as a seed); analytic: closed form, all solutions, the one nearest the start returned.
    settings : type[Settings]
    run : callable                  ``run(prep, T_goal, q_start, settings, seed) -> Raw``
    applies_to : callable           ``applies_to(prep) -> str | None``: why the method does not fit
                                    the robot (None = it does)
    source : str                    where the method comes from (document, section, reference)
    bind : callable, optional       ``bind(prep, settings) -> run1(T_goal, q_start, seed) -> Raw``:
                                    ``run`` with everything per job (packed settings, robot arrays)
                                    done once; the public call uses it when given
    batch : callable, optional      ``batch(prep, settings, goals, starts, seeds, threads, traces) ->
                                    BatchRaw``: N problems in one compiled call (see
                                    :func:`solve_batch`); without it a batch runs ``run`` per problem
    bind_call : callable, optional  ``bind_call(prep, settings) -> call(T_goal, q_start, seed, t0) ->
                                    IKResult`` or None: the whole public call fused (kernel, FK check,
                                    limits and result in one compiled call; ``T_goal`` in the robot
                                    file's unit, ``t0`` the call's start [ns]), for methods whose
                                    kernel is so short that ``bind`` + :func:`finish` would cost more
                                    than it (the analytic closed forms). It must give what ``bind`` +
                                    :func:`finish` give, bit for bit, timings aside; used only with
                                    ``bind``, and not for restarts or scaled prismatic joints; None =
                                    the generic path for these settings
    """

    name: str
    title: str
    kind: str
    settings: type
    run: Callable
    applies_to: Callable | None = None
    source: str = ""
    bind: Callable | None = None
    batch: Callable | None = None
    bind_call: Callable | None = None

    def refusal(self, prep: Prepared) -> str | None:
        """Why this solver does not apply to the prepared robot, or None."""
        if self.applies_to is None:
            return None
        return prep.memo(("applies", self.name), lambda: self.applies_to(prep))


_REGISTRY: dict[str, Solver] = {}


def register(solver: Solver) -> Solver:
    if solver.kind not in KINDS:
        raise ValueError(f"solver {solver.name}: kind {solver.kind!r} not in {KINDS}")
    if solver.name in _REGISTRY:
        raise ValueError(f"solver {solver.name!r} registered twice")
    _REGISTRY[solver.name] = solver
    return solver


def names() -> list[str]:
    return list(_REGISTRY)


def get(name: str) -> Solver:
    try:
        return _REGISTRY[name]
    except KeyError:
        raise SettingsError(f"unknown solver {name!r} (registered: {', '.join(_REGISTRY)})") from None


def make_settings(name: str, mapping: dict | Settings | None = None, where: str = "solver settings") -> Settings:
    """Validated settings of solver ``name`` from a mapping (defaults for missing fields)."""
    spec = get(name)
    if isinstance(mapping, Settings):
        if not isinstance(mapping, spec.settings):
            raise SettingsError(f"{where}: settings of type {type(mapping).__name__} given to solver {name!r} "
                                f"(expects {spec.settings.__name__})")
        mapping.validate(where)
        return mapping
    return spec.settings.from_dict(mapping or {}, where)


def prepare(name: str, robot: RobotModel | Prepared, settings: Settings) -> Prepared:
    """The robot prepared for ``settings.length_unit``; raises NotApplicableError if the solver does not fit."""
    spec = get(name)
    prep = robot if isinstance(robot, Prepared) and robot.unit == settings.length_unit else Prepared(robot, settings.length_unit)
    why = spec.refusal(prep)
    if why:
        raise NotApplicableError(f"{prep.source.path or prep.source.name}: solver '{name}' does not apply: {why}")
    return prep


def _converted(prep: Prepared, settings: Settings) -> Settings:
    return prep.memo(("settings", settings), settings.converted)


class Bound:
    """A solver bound to a prepared robot and its settings: what is done once per job, done once.

    Holds the validated settings converted to the working unit, the method's packed parameters
    (through ``Solver.bind``) and the FK check's model, so that :meth:`solve` costs the kernel plus a
    few microseconds. Obtain one with :func:`bind`; :func:`solve` uses a cached one when given a
    :class:`Prepared` robot and a :class:`Settings` object.

    ``call(T_goal, q_start, seed, t0)`` is what :func:`solve` calls: the solver's fused call
    (``Solver.bind_call``) when it has one for these settings, else :meth:`solve`; :func:`solve`
    calls it straight from the cache, one Python frame less per call.
    """

    __slots__ = ("spec", "prep", "settings", "sc", "run1", "scaled", "shape", "may_restart", "fused", "call")

    def __init__(self, spec: Solver, prep: Prepared, settings: Settings):
        self.spec, self.prep, self.settings = spec, prep, settings
        self.sc = _converted(prep, settings)
        if spec.bind is not None:
            self.run1 = spec.bind(prep, self.sc)
        else:
            run, sc = spec.run, self.sc
            self.run1 = lambda Tg, q0, seed: run(prep, Tg, q0, sc, seed)
        prep.check  # noqa: B018  (build the FK check's model now, not in the first timed call)
        self.scaled = prep.goal_scale != 1.0 and bool(prep.prismatic.any())
        self.shape = (prep.n,)
        self.may_restart = bool(self.sc.restarts) and spec.kind != "analytic"
        self.fused = None
        if spec.bind_call is not None and spec.bind is not None and not self.may_restart and not self.scaled:
            self.fused = spec.bind_call(prep, self.sc)
        self.call = self.fused if self.fused is not None else self.solve

    def solve(self, T_goal: np.ndarray, q_start: np.ndarray, seed: int = 0, t0: int | None = None) -> IKResult:
        """One problem (see :func:`solve`); ``t0`` = the caller's start time on the call clock [ns]."""
        t0 = clock_ns() if t0 is None else t0
        if self.fused is not None:
            return self.fused(T_goal, q_start, seed, t0)
        prep, sc = self.prep, self.sc
        Tg = prep.working_goal(T_goal)
        q0 = np.ascontiguousarray(q_start, dtype=float)  # kernels never write into the start
        if q0.shape != self.shape:
            raise SettingsError(f"q_start: expected shape {self.shape}, got {q0.shape}")
        if self.scaled:
            q0 = q0.copy()
            q0[prep.prismatic] *= prep.goal_scale
        res = finish(prep, Tg, self.run1(Tg, q0, seed), sc, q_start=q0)
        if self.may_restart and not res.success:
            res = _restart(self.spec, prep, Tg, sc, int(seed), res, t0)
        if self.scaled:  # joint values go back in the robot file's unit
            res.q[prep.prismatic] /= prep.goal_scale
        res.call_time_s = (clock_ns() - t0) * 1e-9
        return res


def bind(name: str, robot: RobotModel | Prepared, settings: Settings | dict | None = None) -> Bound:
    """Solver ``name`` bound to ``robot`` and ``settings`` (validated; NotApplicableError if it does not fit).

    With a :class:`Prepared` robot and a :class:`Settings` object the binding is cached on the
    prepared robot (keyed by the settings object's identity), so repeated calls are cheap.
    """
    if type(robot) is Prepared:  # the cached binding, checked by identity (cheapest path first)
        hit = robot._bound.get((name, id(settings)))
        if hit is not None and hit.settings is settings:
            return hit
    spec = get(name)
    s = settings if isinstance(settings, spec.settings) else make_settings(name, settings)
    prep = prepare(name, robot, s)
    b = Bound(spec, prep, s)
    if isinstance(robot, Prepared) and robot is prep and s is settings:
        robot._bound[(name, id(s))] = b  # the Bound holds s, so the id stays unique while cached
    return b


def solve(name: str, robot: RobotModel | Prepared, T_goal: np.ndarray, q_start: np.ndarray,
          settings: Settings | dict | None = None, *, seed: int = 0) -> IKResult:
    """Solve one IK problem with a registered method.

    Parameters
    ----------
    name : str                          a registered solver (``python -m pipeline solvers``)
    robot : RobotModel or Prepared      a Prepared robot (from :func:`prepare`) together with a
                                        Settings object makes repeated calls cheap (the binding
                                        of :func:`bind` is cached)
    T_goal : ndarray, shape (4, 4)      goal pose in the robot file's length unit
    q_start : ndarray, shape (n,)       start joint values [rad | robot file's length unit]
    settings : Settings, mapping or None
        The solver's settings (SI units); None = the registered defaults.
    seed : int
        Seed of stochastic methods (PSO); ignored by deterministic ones.

    Returns
    -------
    IKResult
        ``success`` only when an independent FK confirms the method's claim. ``q`` is in the robot
        file's unit like ``q_start``; errors and traces are in ``result.length_unit``.

    Raises
    ------
    SettingsError, NotApplicableError
        One line naming the field, or the robot and why the method does not fit it.
    """
    t0 = clock_ns()
    if type(robot) is Prepared:  # the cached binding (as in bind), called without further frames
        hit = robot._bound.get((name, id(settings)))
        if hit is not None and hit.settings is settings:
            return hit.call(T_goal, q_start, seed, t0)
    return bind(name, robot, settings).call(T_goal, q_start, seed, t0)


def solve_batch(name: str, robot: RobotModel | Prepared, goals: np.ndarray, starts: np.ndarray,
                settings: Settings | dict | None = None, *, seeds=None, threads: int | None = None,
                traces: bool = True) -> BatchResult:
    """Solve N independent IK problems in one call; results as arrays.

    Methods with a batch kernel (``Solver.batch``: the Jacobian methods and the analytic solvers)
    solve the problems in compiled code on ``threads`` threads (numba ``prange``); each problem
    reads only shared inputs and writes only its own outputs, so results are the same whatever the
    thread count. Other methods, and any method with ``require_limits`` or ``restarts``, run
    :meth:`Bound.solve` per problem and are stacked into the same arrays.

    Parameters
    ----------
    name : str
    robot : RobotModel or Prepared
    goals : ndarray, shape (N, 4, 4)     goal poses in the robot file's length unit
    starts : ndarray, shape (N, n)       start joint values [rad | robot file's length unit]
    settings : Settings, mapping or None
    seeds : array_like of int, shape (N,), optional   per-problem seeds (stochastic methods); default 0..N-1
    threads : int, optional              compiled threads (default: numba's, i.e. every core)
    traces : bool                        keep every problem's per-iteration trace

    Returns
    -------
    BatchResult
        ``call_time_s`` is the whole call; per-problem ``solve_time_s`` is measured inside the kernel.
    """
    t0 = clock_ns()
    b = bind(name, robot, settings)
    prep, sc = b.prep, b.sc
    G = np.array(goals, dtype=float, order="C")
    S = np.array(starts, dtype=float, order="C")
    if G.ndim != 3 or G.shape[1:] != (4, 4):
        raise SettingsError(f"goals: expected shape (N, 4, 4), got {G.shape}")
    if S.shape != (G.shape[0], prep.n):
        raise SettingsError(f"starts: expected shape ({G.shape[0]}, {prep.n}), got {S.shape}")
    seeds = np.arange(len(G), dtype=np.int64) if seeds is None else np.asarray(seeds, dtype=np.int64)
    if b.spec.batch is None or sc.require_limits or sc.restarts:
        res = _stack([b.solve(G[i], S[i], int(seeds[i])) for i in range(len(G))], prep.unit, traces)
    else:
        if prep.goal_scale != 1.0:
            G[:, :3, 3] *= prep.goal_scale
        if b.scaled:
            S[:, prep.prismatic] *= prep.goal_scale
        with _numba_threads(threads):
            raw = b.spec.batch(prep, sc, G, S, seeds, traces)
        res = finish_batch(prep, G, raw, sc)
        if b.scaled:
            res.q[:, prep.prismatic] /= prep.goal_scale
    res.call_time_s = (clock_ns() - t0) * 1e-9
    return res


class _numba_threads:
    """Context: numba's thread count set to ``n`` (None = unchanged), restored afterwards."""

    def __init__(self, n: int | None):
        self.n, self.old = n, None

    def __enter__(self):
        if self.n is not None:
            import numba

            self.old = numba.get_num_threads()
            numba.set_num_threads(max(1, min(int(self.n), numba.config.NUMBA_NUM_THREADS)))

    def __exit__(self, *exc):
        if self.old is not None:
            import numba

            numba.set_num_threads(self.old)


def _stack(results: list[IKResult], unit: str, traces: bool) -> BatchResult:
    """Per-problem results as one :class:`BatchResult` (``call_time_s`` set by the caller)."""
    col = lambda f, dt=float: np.array([getattr(r, f) for r in results], dtype=dt)  # noqa: E731
    n_sol = sols = rows = offs = None
    if traces and results:
        tr = [np.asarray(r.trace, dtype=float) for r in results]
        offs = np.concatenate([[0], np.cumsum([len(t) for t in tr])]).astype(np.int64)
        rows = np.concatenate(tr, axis=0)
    if any(r.solutions is not None for r in results):
        n_sol = np.array([0 if r.solutions is None else len(r.solutions) for r in results], dtype=np.int64)
        n = results[0].q.shape[0]
        sols = np.full((len(results), max(1, int(n_sol.max())), n), np.nan)
        for i, r in enumerate(results):
            if n_sol[i]:
                sols[i, : n_sol[i]] = r.solutions
    q = np.array([r.q for r in results], dtype=float).reshape(len(results), -1)
    return BatchResult(q=q, success=col("success", bool), stop_reason=col("stop_reason", np.int64),
                       iterations=col("iterations", np.int64), solve_time_s=col("solve_time_s"),
                       ik_time_s=col("ik_time_s"), position_error=col("position_error"),
                       orientation_error=col("orientation_error"), claimed_success=col("claimed_success", bool),
                       within_limits=col("within_limits", bool), call_time_s=0.0, length_unit=unit,
                       trace_rows=rows, trace_offsets=offs, solutions=sols, n_solutions=n_sol,
                       info=[r.info for r in results], call_times_s=col("call_time_s"))


def _restart(spec: Solver, prep: Prepared, Tg: np.ndarray, sc: Settings, seed: int, first: IKResult,
             t0: int) -> IKResult:
    """Random restarts after a failed search (``settings.restarts``, ``settings.time_budget``).

    Restart k starts uniformly in :meth:`Prepared.search_box` (a generator seeded by ``seed``, so
    restarts are reproducible) and stochastic methods get seed ``seed + k``. The result is the first
    success, else the search whose pose came closest (position error, then rotation angle), with
    ``iterations``, ``solve_time_s`` and ``ik_time_s`` summed over every search and
    ``info["restarts"]`` the number of restarts run.
    """
    try:
        box = prep.memo("restart_box", prep.search_box)
    except NotApplicableError:
        return first
    rng = np.random.default_rng([seed, 0x5EED])
    budget_ns = int(sc.time_budget * 1e9)
    best, iters, solve_s, ik_s = first, first.iterations, first.solve_time_s, first.ik_time_s
    k = 0
    while k < sc.restarts and (budget_ns <= 0 or clock_ns() - t0 < budget_ns):
        k += 1
        q0 = box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random(prep.n)
        res = finish(prep, Tg, spec.run(prep, Tg, q0, sc, seed + k), sc, q_start=q0)
        iters, solve_s, ik_s = iters + res.iterations, solve_s + res.solve_time_s, ik_s + res.ik_time_s
        if res.success or _closer(res, best):
            best = res
        if res.success:
            break
    info = {**best.info, "restarts": k}
    return replace(best, iterations=iters, solve_time_s=solve_s, ik_time_s=ik_s, info=info)


def _closer(a: IKResult, b: IKResult) -> bool:
    key = lambda r: (r.position_error if np.isfinite(r.position_error) else np.inf,  # noqa: E731
                     r.orientation_error if np.isfinite(r.orientation_error) else np.inf)
    return key(a) < key(b)


def warm_up(name: str, prep: Prepared, settings: Settings) -> None:
    """Compile (or load from numba's disk cache) a solver's kernels before the first timed solve."""
    from pipeline.kinematics import fk_htm

    q0 = np.clip(np.zeros(prep.n), prep.limits[:, 0], prep.limits[:, 1])
    T = fk_htm(prep.model.chain, q0 + 0.05)
    T[:3, 3] /= prep.goal_scale
    solve(name, prep, T, q0, settings)


def catalogue() -> list[dict]:
    """Every registered solver with its kind, source and settings rows (for the ``solvers`` verb)."""
    return [{"name": s.name, "title": s.title, "kind": s.kind, "source": s.source,
             "settings": s.settings.describe()} for s in _REGISTRY.values()]
