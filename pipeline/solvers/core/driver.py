"""The one way to run a solve: a solver bound to a robot and its settings (:class:`Bound`).

Every registered method, iterative, analytic or peer, runs through this driver, for one problem
(:meth:`Bound.solve`, what :func:`pipeline.solvers.solve` and ``bind(...).solve`` call) and for N
(:meth:`Bound.solve_many`, what :func:`pipeline.solvers.solve_batch` and the runner call). The
driver owns the protocol around the method's own computation:

1. inputs: the goal converted to the working unit, the start checked (and its prismatic joints
   scaled), once per job the settings converted and the method's parameters packed (``Solver.bind``);
2. the method's computation: ``run1(T_goal, q_start, seed) -> Raw`` (one search: the method's
   compiled loop with its own stop rules, or its closed form, or a peer library's call), timed by
   the method on the monotonic clock (:mod:`pipeline.solvers.core.timing`);
3. the result: :func:`pipeline.solvers.core.finish` (the one result rule: independent FK check,
   joint limits and ``require_limits``, stop reason, success);
4. random restarts after a failed search (``restarts``, ``time_budget``): the same ``run1`` and
   ``finish`` from starts drawn in the joint box;
5. outputs: joint values back in the robot file's unit, the whole call's time.

For N problems the driver runs the method's batch kernel (``Solver.batch``: the Jacobian loop and
the closed forms, on ``threads`` cores) and :func:`pipeline.solvers.core.finish_batch` (the same
result rule per problem), or else steps 1-5 per problem; results are the same either way
(tests/solvers/core/test_fast_path.py, tests/solvers/test_contract.py).

Two fast paths stay, each measured (``python benchmarks/bench_fast.py --only paths``) and each held
equal to the path it replaces field by field (tests/solvers/core/test_driver_paths.py):

* ``Solver.batch`` (the N-problem kernels): 1.3x (Jacobian DLS, cerbaro2019 settings) to 3x (the
  closed forms) the throughput of per-problem calls on one thread, and the only path on several
  cores;
* ``Solver.bind_call`` (the fused single call of the analytic closed forms and of the four Jacobian
  methods: kernel, FK check and result in one compiled call, :func:`pipeline.solvers.core.finish_packed`):
  1.4x faster than ``run1`` + ``finish`` for the closed forms (UR5 5.1 us instead of 7.3, PUMA 560
  8.6 us instead of 11.7), 1.3x for the pseudoinverse with ``search_limits: reflect`` on the iiwa 14
  (median 17.5 us instead of 23.2, interleaved); with ``restarts`` the fused call is the first search
  and a failed one goes on to :meth:`Bound.restart`.

The loop buffers of an iterative method (the solution, one trace row per iterate up to the
iteration cap, the kernel's clock readings) are allocated by :func:`run_loop`, so that a method's
``run`` only names its compiled loop and that loop's arguments.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from pipeline.solvers.kernels.kin import TRACE_COLS
from pipeline.solvers.core import (BatchResult, IKResult, NotApplicableError, Prepared, Settings, SettingsError, finish,
                                   finish_batch)
from pipeline._numba_cache import COMPILE_CLOCK
from pipeline.solvers.core.timing import clock_ns


def converted(prep: Prepared, settings: Settings) -> Settings:
    """``settings`` in ``prep``'s working unit (converted once per prepared robot)."""
    return prep.memo(("settings", settings), settings.converted)


def run_loop(kernel, args: tuple, q_start: np.ndarray, max_iterations: int, clocks: int = 2):
    """Call an iterative method's compiled loop ``kernel(*args, q, trace, times)`` with its buffers.

    ``q`` (n,) receives the solution, ``trace`` (max_iterations + 1, TRACE_COLS) one row per iterate
    (zeros beyond the last; :func:`pipeline.solvers.core.finish` keeps rows ``0..iterations``),
    ``times`` (``clocks``,) the kernel's clock readings [ns] (``times[0]`` its solve time). Returns
    ``(q, trace, times, out)`` with ``out`` what the kernel returned (its stop code, iterations, ...).
    """
    q = np.empty_like(q_start)
    trace = np.zeros((max_iterations + 1, TRACE_COLS))
    times = np.zeros(clocks, np.int64)
    out = kernel(*args, q, trace, times)
    return q, trace, times, out


def run_of(bind):
    """A method's ``run(prep, T_goal, q_start, settings, seed) -> Raw`` from its ``bind(prep, settings) ->
    run1``: one search with the per-job work redone (a method with ``bind`` writes its search once)."""

    def run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, settings: Settings, seed: int):
        return bind(prep, settings)(np.ascontiguousarray(T_goal, dtype=float),
                                    np.ascontiguousarray(q_start, dtype=float), seed)

    return run


class Bound:
    """A solver bound to a prepared robot and its settings: what is done once per job, done once.

    Holds the validated settings converted to the working unit, the method's packed parameters
    (through ``Solver.bind``) and the FK check's model, so that :meth:`solve` costs the kernel plus a
    few microseconds. Obtain one with :func:`pipeline.solvers.bind`; :func:`pipeline.solvers.solve`
    uses a cached one when given a :class:`Prepared` robot and a :class:`Settings` object.

    ``call(T_goal, q_start, seed, t0)`` is what :func:`pipeline.solvers.solve` calls: the solver's
    fused call (``Solver.bind_call``) when it has one for these settings, else the generic path; it is
    called straight from the cache, one Python frame less per call.

    Compilation is never timed as a solve: a call during which numba compiled kernels or loaded them
    from its cache (:func:`pipeline._numba_cache.compile_ns`) is run again once they are ready, and
    returns that run's result with ``compiled`` True and ``compile_time_s`` the time it took. The fused
    call is watched until its first call that compiles nothing (it compiles nothing later); with
    ``restarts``, a fused call that hands a failed search on itself (``on_failure``, the Jacobian
    methods) is then watched only when its search failed (:meth:`_restart_watched`: the restarts' generic
    path may compile on its first use); the generic path, and any other fused call with restarts, on
    every call (a restart or a rare branch may compile later).
    """

    __slots__ = ("spec", "prep", "settings", "sc", "run1", "scaled", "shape", "may_restart", "fused", "call", "_run")

    def __init__(self, spec, prep: Prepared, settings: Settings):
        self.spec, self.prep, self.settings = spec, prep, settings
        self.sc = converted(prep, settings)
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
        if spec.bind_call is not None and spec.bind is not None and not self.scaled:
            self.fused = spec.bind_call(prep, self.sc)
        self._run = self._solve if self.fused is None else self._fused_restart if self.may_restart else self.fused
        self.call = self._own_time

    def _own_time(self, T_goal: np.ndarray, q_start: np.ndarray, seed: int = 0, t0: int | None = None) -> IKResult:
        """One call whose times are its own: run again if it compiled or loaded kernels (class docstring)."""
        clock = COMPILE_CLOCK
        c0 = clock[0]
        res = self._run(T_goal, q_start, seed, clock_ns() if t0 is None else t0)
        if clock[0] == c0:
            if self._run is self.fused:
                self.call = self.fused
            elif self._run == self._fused_restart and hasattr(self.fused, "on_failure"):
                self.call = self.fused.on_failure(self._restart_watched)  # watched again only after a failed search
            return res
        spent = clock[0] - c0
        for _ in range(3):  # the run again (a run that compiles once more, a later branch, again)
            c0 = clock[0]
            res = self._run(T_goal, q_start, seed, clock_ns())
            if clock[0] == c0:
                break
            spent += clock[0] - c0
        res.compiled, res.compile_time_s = True, spent * 1e-9
        return res

    def _fused_restart(self, T_goal: np.ndarray, q_start: np.ndarray, seed: int, t0: int) -> IKResult:
        """The fused call (``Solver.bind_call``), then :meth:`restart` when it failed: the same results as
        :meth:`_solve` with ``restarts``, the first search without the generic path's Python steps."""
        res = self.fused(T_goal, q_start, seed, t0)
        if res.success:
            return res
        res = self.restart(self.prep.working_goal(T_goal), int(seed), res, t0)
        res.call_time_s = (clock_ns() - t0) * 1e-9
        return res

    def _restart_watched(self, res: IKResult, T_goal: np.ndarray, q_start: np.ndarray, seed: int, t0: int) -> IKResult:
        """The restarts after a warm fused call's failed search ``res`` (the handler its ``on_failure`` hands
        it to), under :meth:`_own_time`'s watch: the generic path a restart takes may compile on its first
        use, and a call that compiled is run again whole and marked."""
        clock = COMPILE_CLOCK
        c0 = clock[0]
        out = self.restart(self.prep.working_goal(T_goal), int(seed), res, t0)
        if clock[0] != c0:  # it compiled: the whole call again, watched, with its own time
            spent = clock[0] - c0
            out = self._own_time(T_goal, q_start, seed, clock_ns())
            out.compiled, out.compile_time_s = True, out.compile_time_s + spent * 1e-9
            return out
        out.call_time_s = (clock_ns() - t0) * 1e-9
        return out

    def attempt(self, Tg: np.ndarray, q0: np.ndarray, seed: int) -> IKResult:
        """One search from ``q0`` (working unit) and its result: ``run1``, then :func:`finish`."""
        return finish(self.prep, Tg, self.run1(Tg, q0, seed), self.sc, q_start=q0)

    def solve(self, T_goal: np.ndarray, q_start: np.ndarray, seed: int = 0, t0: int | None = None) -> IKResult:
        """One problem (see :func:`pipeline.solvers.solve`); ``t0`` = the caller's start time on the call clock [ns]."""
        return self.call(T_goal, q_start, seed, clock_ns() if t0 is None else t0)

    def _solve(self, T_goal: np.ndarray, q_start: np.ndarray, seed: int, t0: int) -> IKResult:
        """The generic path of one problem: steps 1-5 of the module docstring."""
        prep = self.prep
        Tg = prep.working_goal(T_goal)
        q0 = np.ascontiguousarray(q_start, dtype=float)  # kernels never write into the start
        if q0.shape != self.shape:
            raise SettingsError(f"q_start: expected shape {self.shape}, got {q0.shape}")
        if self.scaled:
            q0 = q0.copy()
            q0[prep.prismatic] *= prep.goal_scale
        res = self.attempt(Tg, q0, seed)
        if self.may_restart and not res.success:
            res = self.restart(Tg, int(seed), res, t0)
        if self.scaled:  # joint values go back in the robot file's unit
            res.q[prep.prismatic] /= prep.goal_scale
        res.call_time_s = (clock_ns() - t0) * 1e-9
        return res

    def restart(self, Tg: np.ndarray, seed: int, first: IKResult, t0: int) -> IKResult:
        """Random restarts after a failed search (``settings.restarts``, ``settings.time_budget``).

        Restart k starts uniformly in :meth:`Prepared.search_box` (a generator seeded by ``seed``, so
        restarts are reproducible) and stochastic methods get seed ``seed + k``. The result is the first
        success, else the search whose pose came closest (position error, then rotation angle), with
        ``iterations``, ``solve_time_s`` and ``ik_time_s`` summed over every search and
        ``info["restarts"]`` the number of restarts run.
        """
        prep, sc = self.prep, self.sc
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
            res = self.attempt(Tg, box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random(prep.n), seed + k)
            iters, solve_s, ik_s = iters + res.iterations, solve_s + res.solve_time_s, ik_s + res.ik_time_s
            if res.success or _closer(res, best):
                best = res
            if res.success:
                break
        info = {**best.info, "restarts": k}
        return replace(best, iterations=iters, solve_time_s=solve_s, ik_time_s=ik_s, info=info)

    def solve_many(self, goals: np.ndarray, starts: np.ndarray, seeds=None, threads: int | None = None,
                   traces: bool = True, t0: int | None = None) -> BatchResult:
        """N problems (see :func:`pipeline.solvers.solve_batch`): the batch kernel and :func:`finish_batch`
        when the method has one for this robot and neither ``require_limits`` nor ``restarts`` is set,
        else :meth:`solve` per problem, stacked."""
        t0 = clock_ns() if t0 is None else t0
        c0 = COMPILE_CLOCK[0]
        prep, sc = self.prep, self.sc
        G = np.ascontiguousarray(goals, dtype=float)  # read only below: the caller's own arrays where they fit
        S = np.ascontiguousarray(starts, dtype=float)
        if G.ndim != 3 or G.shape[1:] != (4, 4):
            raise SettingsError(f"goals: expected shape (N, 4, 4), got {G.shape}")
        if S.shape != (G.shape[0], prep.n):
            raise SettingsError(f"starts: expected shape ({G.shape[0]}, {prep.n}), got {S.shape}")
        seeds = np.arange(len(G), dtype=np.int64) if seeds is None else np.asarray(seeds, dtype=np.int64)
        raw = None
        if self.spec.batch is not None and not (sc.require_limits or sc.restarts):
            Gk, Sk = G, S  # in the working unit
            if prep.goal_scale != 1.0:
                Gk = G.copy()
                Gk[:, :3, 3] *= prep.goal_scale
            if self.scaled:
                Sk = S.copy()
                Sk[:, prep.prismatic] *= prep.goal_scale
            with numba_threads(threads):  # the kernel and the check both on ``threads`` threads
                raw = self.spec.batch(prep, sc, Gk, Sk, seeds, traces)  # None: no batch kernel for this robot
                if raw is not None:
                    res = finish_batch(prep, Gk, raw, sc)
            if raw is not None and self.scaled:
                res.q[:, prep.prismatic] /= prep.goal_scale
        if raw is None:
            res = stack([self.solve(G[i], S[i], int(seeds[i])) for i in range(len(G))], prep.unit, traces)
        spent = COMPILE_CLOCK[0] - c0  # compiling or loading kernels: not the call's own time (per-problem
        res.call_time_s = (clock_ns() - t0 - spent) * 1e-9  # times are the kernel's own, or of calls run again)
        res.compiled, res.compile_time_s = spent > 0, spent * 1e-9
        return res


def _closer(a: IKResult, b: IKResult) -> bool:
    key = lambda r: (r.position_error if np.isfinite(r.position_error) else np.inf,  # noqa: E731
                     r.orientation_error if np.isfinite(r.orientation_error) else np.inf)
    return key(a) < key(b)


class numba_threads:
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


def stack(results: list[IKResult], unit: str, traces: bool) -> BatchResult:
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
