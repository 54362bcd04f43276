"""Solve a problem set with one registered solver: the loop every solve job runs.

Problems are solved in file order. A problem whose ``chain`` id is >= 0 and is not the first of
its chain starts from the angles the previous problem of that chain returned (when finite; else
from its own ``q_start``): this is how path following and trajectory warm starts are expressed
as problem sets. With ``repetitions`` > 1 each problem is solved that many times from the same
start (for timing); the chain continues from the first repetition's result.

Stochastic solvers get a per-(problem, repetition) seed derived from the set's seed, so that a
job's archive does not depend on which problems another job solved.
"""

from __future__ import annotations

from typing import Iterator

import numpy as np

from pipeline.problems import ProblemSet
from pipeline.robots import LENGTH_UNITS, RobotModel
from pipeline.solvers import IKResult, Settings, prepare, solve, warm_up


def problem_seed(set_seed: int, problem_id: int, repetition: int = 0) -> int:
    """A 31-bit seed for one solve of a stochastic method (independent of the other problems)."""
    return int(np.random.SeedSequence([int(set_seed), int(problem_id), int(repetition)]).generate_state(1)[0] >> 1)


def solve_set(method: str, settings: Settings, model: RobotModel, ps: ProblemSet, *, repetitions: int = 1,
              set_seed: int = 0, select=None) -> Iterator[tuple[int, int, np.ndarray, IKResult]]:
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
    """
    prep = prepare(method, model, settings)
    warm_up(method, prep, settings)  # compile / load cached kernels before the first timed solve
    T_goals = ps.goal_transforms()
    if ps.length_unit != model.length_unit:
        T_goals[:, :3, 3] *= LENGTH_UNITS[ps.length_unit] / LENGTH_UNITS[model.length_unit]
    idx = np.arange(len(ps)) if select is None else np.flatnonzero(np.isin(ps.problem_id, list(select)))
    last: dict[int, np.ndarray] = {}
    for i in idx:
        ch = int(ps.chain[i])
        q0 = ps.q_start[i]
        if ch >= 0 and ch in last and np.all(np.isfinite(last[ch])):
            q0 = last[ch]
        first = None
        for r in range(repetitions):
            res = solve(method, prep, T_goals[i], q0, settings, seed=problem_seed(set_seed, ps.problem_id[i], r))
            first = first or res
            yield int(i), r, q0, res
        if ch >= 0:
            last[ch] = first.q
