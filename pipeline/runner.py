"""Solve a problem set with one registered solver: the loop every solve job runs.

Problems are solved in file order. A problem whose ``chain`` id is >= 0 and is not the first of
its chain starts from the angles the previous problem of that chain returned (when finite; else
from its own ``q_start``): this is how path following and trajectory warm starts are expressed
as problem sets. With ``repetitions`` > 1 each problem is solved that many times from the same
start (for timing); the chain continues from the first repetition's result.

Every solve's CPU time is measured beside its wall time: the calling thread's CPU time
(``thread_time_ns``) read around each call, or the whole process's (``process_time_ns``) for a method
that runs threads of its own (``Solver.own_threads``: TRAC-IK's two racing solvers both count); for a
batch kernel, the process's CPU time around the batch call shared out over its problems in
proportion to their kernel-measured solve times, unless the kernel reads each solve's thread CPU
time itself (the Jacobian loop of ``pipeline.solvers.iterative.lean`` does: ``BatchResult.cpu_times_s``). Summed over a job's
solves, CPU / wall time is its CPU share: below 0.9 the job did not get a core to itself.

With ``timing_runs`` > 1 every solve is run that many times (a batch call that many times, a single
solve that many times from the same start) and keeps the first run's result with the times (CPU,
solve, IK block, call) of its fastest run by CPU time: the fastest of several runs is the time of
an uninterrupted run, which machine load does not move the way it moves one run's time (another
process's time slice or its cache traffic lands on some runs, not on all). Every run must give
the same result bit for bit (else RuntimeError): the methods it is used with are deterministic.

Stochastic solvers get a per-(problem, repetition) seed derived from the set's seed, so that a
job's archive does not depend on which problems another job solved.
"""

from __future__ import annotations

import time
from typing import Iterator

import numpy as np

from pipeline.problems import ProblemSet
from pipeline.robots import LENGTH_UNITS, RobotModel
from pipeline.solvers import BatchResult, IKResult, Settings, bind, get, prepare, solve_batch, warm_up
from pipeline.solvers.core.driver import stack

BATCH = 2000  # problems per batch call (progress is reported between batches)


def problem_seed(set_seed: int, problem_id: int, repetition: int = 0) -> int:
    """A 31-bit seed for one solve of a stochastic method (independent of the other problems)."""
    return int(np.random.SeedSequence([int(set_seed), int(problem_id), int(repetition)]).generate_state(1)[0] >> 1)


def model_goals(ps: ProblemSet, model: RobotModel) -> np.ndarray:
    """The set's goal poses in the robot file's length unit, shape (m, 4, 4): what the solvers are
    given (and what an archive's re-derivation must give them again, bit for bit)."""
    T_goals = ps.goal_transforms()
    if ps.length_unit != model.length_unit:
        T_goals[:, :3, 3] *= LENGTH_UNITS[ps.length_unit] / LENGTH_UNITS[model.length_unit]
    return T_goals


def solve_set(method: str, settings: Settings, model: RobotModel, ps: ProblemSet, *, repetitions: int = 1,
              set_seed: int = 0, select=None, threads: int = 1) -> Iterator[tuple[int, int, np.ndarray, IKResult]]:
    """Yield ``(row index, repetition, q_start used, result)`` for every solve of the set.

    Parameters
    ----------
    method : str                registered solver name
    settings : Settings         that solver's settings
    model : RobotModel          the robot of the problem set (``ps.robot``)
    ps : ProblemSet             goal poses in ``ps.length_unit``
    repetitions : int
    set_seed : int              the problem set's seed (stochastic solvers)
    select : iterable of int, optional
        Problem ids to solve (default all); chains are followed only within the selection.
    threads : int               compiled threads of a batch kernel (results do not depend on it)
    """
    for rows, reps, starts, res in solve_set_batches(method, settings, model, ps, repetitions=repetitions,
                                                     set_seed=set_seed, select=select, threads=threads):
        for k in range(len(rows)):
            yield int(rows[k]), int(reps[k]), starts[k], res.result(k)


def solve_set_batches(method: str, settings: Settings, model: RobotModel, ps: ProblemSet, *, repetitions: int = 1,
                      set_seed: int = 0, select=None, threads: int = 1, timing_runs: int = 1
                      ) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray, BatchResult]]:
    """:func:`solve_set` in batches: yield ``(row indices (k,), repetitions (k,), starts (k, n), BatchResult)``.

    Independent problems (no chain continues, one repetition) of a method with a batch kernel go
    through :func:`pipeline.solvers.solve_batch`, :data:`BATCH` problems per call on ``threads``
    threads; everything else is solved one call at a time (in file order, following chains) and
    stacked into batches of the same size. Both ways give the same results (tests/test_runner.py).
    ``timing_runs``: see the module docstring.
    """
    prep = prepare(method, model, settings)
    warm_up(method, prep, settings)  # compile / load cached kernels before the first timed solve
    T_goals = model_goals(ps, model)
    idx = np.arange(len(ps)) if select is None else np.flatnonzero(np.isin(ps.problem_id, list(select)))
    chains = ps.chain[idx]
    independent = repetitions == 1 and len(np.unique(chains[chains >= 0])) == int((chains >= 0).sum())
    spec = get(method)
    if independent and spec.batch is not None:
        for lo in range(0, len(idx), BATCH):
            part = idx[lo:lo + BATCH]
            # every problem its own seed, as in the one-call-at-a-time path (stochastic methods and
            # random restarts draw from it): a solve does not depend on its place in the batch, so
            # an archived solve can be re-run alone (pipeline.io.archive.derive)
            seeds = np.array([problem_seed(set_seed, ps.problem_id[i], 0) for i in part], dtype=np.int64)
            res = None
            for _ in range(timing_runs):
                c0 = time.process_time_ns()
                run = solve_batch(method, prep, T_goals[part], ps.q_start[part], settings, seeds=seeds, threads=threads)
                if run.cpu_times_s is None:  # the kernel does not read each solve's thread CPU time itself
                    run.cpu_times_s = _shared((time.process_time_ns() - c0) * 1e-9, run.solve_time_s)
                res = run if res is None else _fastest(res, run, method)
            yield part, np.zeros(len(part), np.int64), ps.q_start[part], res
        return
    b = bind(method, prep, settings)
    cpu_clock = time.process_time_ns if spec.own_threads else time.thread_time_ns
    last: dict[int, np.ndarray] = {}
    rows, reps, starts, results, cpu = [], [], [], [], []
    for i in idx:
        ch = int(ps.chain[i])
        q0 = ps.q_start[i]
        if ch >= 0 and ch in last and np.all(np.isfinite(last[ch])):
            q0 = last[ch]
        first = None
        for r in range(repetitions):
            seed = problem_seed(set_seed, ps.problem_id[i], r)
            res, t_cpu = _timed_solve(b, T_goals[i], q0, seed, cpu_clock, timing_runs, method)
            cpu.append(t_cpu)
            first = first or res
            rows.append(int(i)), reps.append(r), starts.append(q0), results.append(res)
        if ch >= 0:
            last[ch] = first.q
        if len(results) >= BATCH:
            yield _batch_of(rows, reps, starts, results, cpu, prep.unit)
            rows, reps, starts, results, cpu = [], [], [], [], []
    if results:
        yield _batch_of(rows, reps, starts, results, cpu, prep.unit)


def _same_result(q_a, q_b, it_a, it_b, method: str) -> None:
    if not (np.array_equal(q_a, q_b, equal_nan=True) and np.array_equal(it_a, it_b)):
        raise RuntimeError(f"timing_runs: {method} gave another result on a second run of the same problems "
                           "(the fastest of several runs needs a deterministic method)")


def _timed_solve(b, T_goal, q0, seed, clock, runs: int, method: str) -> tuple[IKResult, float]:
    """One solve run ``runs`` times: (the first run's result with the times of its fastest run, that
    run's CPU time [s] on ``clock``)."""
    res = best = None
    for _ in range(runs):
        c0 = clock()
        run = b.solve(T_goal, q0, seed)
        t_cpu = (clock() - c0) * 1e-9
        if res is None:
            res, best = run, t_cpu
            continue
        _same_result(res.q, run.q, res.iterations, run.iterations, method)
        if t_cpu < best:
            best = t_cpu
            res.solve_time_s, res.ik_time_s, res.call_time_s = run.solve_time_s, run.ik_time_s, run.call_time_s
    return res, best


def _fastest(a: BatchResult, b: BatchResult, method: str) -> BatchResult:
    """``a`` (the first run) with each problem's times (CPU, solve, IK block, call) taken from ``b``
    where ``b``'s CPU time is smaller; ``b`` must hold the same results."""
    _same_result(a.q, b.q, a.iterations, b.iterations, method)
    faster = b.cpu_times_s < a.cpu_times_s
    a.cpu_times_s = np.where(faster, b.cpu_times_s, a.cpu_times_s)
    a.solve_time_s = np.where(faster, b.solve_time_s, a.solve_time_s)
    a.ik_time_s = np.where(faster, b.ik_time_s, a.ik_time_s)
    if a.call_times_s is not None and b.call_times_s is not None:
        a.call_times_s = np.where(faster, b.call_times_s, a.call_times_s)
    a.call_time_s = min(a.call_time_s, b.call_time_s)
    return a


def _shared(total_s: float, weights: np.ndarray) -> np.ndarray:
    """``total_s`` shared out over the problems of a batch in proportion to ``weights`` (N,) [s]."""
    w = np.maximum(np.nan_to_num(np.asarray(weights, dtype=float)), 0.0)
    return total_s * w / w.sum() if w.sum() > 0 else np.full(len(w), total_s / max(1, len(w)))


def _batch_of(rows, reps, starts, results, cpu, unit) -> tuple:
    res = stack(results, unit, traces=True)
    res.call_time_s = float(np.sum(res.call_times_s))
    res.cpu_times_s = np.array(cpu, dtype=float)
    return np.array(rows, dtype=np.int64), np.array(reps, dtype=np.int64), np.array(starts, dtype=float), res
