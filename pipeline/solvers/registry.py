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
from pipeline.solvers.base import IKResult, NotApplicableError, Prepared, Raw, Settings, SettingsError, finish
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
    """

    name: str
    title: str
    kind: str
    settings: type
    run: Callable
    applies_to: Callable | None = None
    source: str = ""

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


def solve(name: str, robot: RobotModel | Prepared, T_goal: np.ndarray, q_start: np.ndarray,
          settings: Settings | dict | None = None, *, seed: int = 0) -> IKResult:
    """Solve one IK problem with a registered method.

    Parameters
    ----------
    name : str                          a registered solver (``python -m pipeline solvers``)
    robot : RobotModel or Prepared      a Prepared robot (from :func:`prepare`) saves the
                                        conversion when solving many problems
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
    spec = get(name)
    s = settings if isinstance(settings, spec.settings) else make_settings(name, settings)
    prep = prepare(name, robot, s)
    sc = _converted(prep, s)
    Tg = prep.working_goal(T_goal)
    q0 = np.array(q_start, dtype=float, order="C")
    if q0.shape != (prep.n,):
        raise SettingsError(f"q_start: expected shape ({prep.n},), got {q0.shape}")
    scaled = prep.goal_scale != 1.0 and bool(prep.prismatic.any())
    if scaled:
        q0[prep.prismatic] *= prep.goal_scale
    raw: Raw = spec.run(prep, Tg, q0, sc, int(seed))
    res = finish(prep, Tg, raw, sc, q_start=q0)
    if sc.restarts and not res.success and spec.kind != "analytic":
        res = _restart(spec, prep, Tg, sc, int(seed), res, t0)
    if scaled:  # joint values go back in the robot file's unit
        res.q[prep.prismatic] /= prep.goal_scale
    object.__setattr__(res, "call_time_s", (clock_ns() - t0) * 1e-9)
    return res


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
