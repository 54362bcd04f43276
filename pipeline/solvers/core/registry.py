"""The solver registry: a name -> settings type, applicability test and kernel call.

Every method of the five studies registers here under one name (``python -m pipeline solvers``
lists them). A method module defines a :class:`~pipeline.solvers.core.Settings` subclass and a
``run(prep, T_goal, q_start, settings, seed) -> Raw`` function and calls :func:`register`; the
registry validates settings and applicability, and the one driver (:mod:`pipeline.solvers.core.driver`)
does the rest the same way for all of them (unit conversion, restarts, FK check, limits, result,
timing of the whole call), for one problem and for N.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable

import numpy as np

from pipeline.robots import RobotModel
from pipeline.solvers.core import BatchResult, IKResult, NotApplicableError, Prepared, Settings, SettingsError
from pipeline.solvers.core import fixed
from pipeline.solvers.core.driver import Bound
from pipeline.solvers.core.timing import clock_ns

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
    run : callable                  ``run(prep, T_goal, q_start, settings, seed) -> Raw`` (one search;
                                    :func:`pipeline.solvers.core.driver.run_of` derives it from ``bind``)
    applies_to : callable           ``applies_to(prep) -> str | None``: why the method does not fit
                                    the robot (None = it does)
    source : str                    where the method comes from (document, section, reference)
    bind : callable, optional       ``bind(prep, settings) -> run1(T_goal, q_start, seed) -> Raw``:
                                    ``run`` with everything per job (packed settings, robot arrays)
                                    done once; the public call uses it when given
    batch : callable, optional      ``batch(prep, settings, goals, starts, seeds, threads, traces) ->
                                    BatchRaw``: N problems in one compiled call (see
                                    :func:`solve_batch`), or None where the method has no batch kernel
                                    for this robot; without one a batch runs ``run`` per problem
    own_threads : bool              the method runs threads of its own (TRAC-IK's two racing solvers): its
                                    CPU time is the process's, not the calling thread's
    library : str                   "ours" (this package's own implementation) or the peer library's
                                    package name (tables and figures read it from here or from the
                                    archive's metadata, never from a setting)
    bind_call : callable, optional  ``bind_call(prep, settings) -> call(T_goal, q_start, seed, t0) ->
                                    IKResult`` or None: the whole public call fused (kernel, FK check,
                                    limits and result in one compiled call; ``T_goal`` in the robot
                                    file's unit, ``t0`` the call's start [ns]), for methods whose
                                    kernel is so short that ``bind`` + :func:`finish` would cost more
                                    than it (the analytic closed forms). It must give what ``bind`` +
                                    :func:`finish` give, bit for bit, timings aside; used only with
                                    ``bind``, and not for scaled prismatic joints; with ``restarts`` it
                                    is the first search and the driver restarts after a failed one (a
                                    ``call`` with an ``on_failure(handler)`` attribute returns the same
                                    call handing its failed result to ``handler(res, T_goal, q_start,
                                    seed, t0)`` itself: the Jacobian methods); None = the generic path
                                    for these settings
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
    library: str = "ours"
    own_threads: bool = False

    @property
    def peer(self) -> bool:
        """A peer library's method (a baseline), not this package's own implementation."""
        return self.library != "ours"

    def refusal(self, prep: Prepared) -> str | None:
        """Why this solver does not apply to the prepared robot, or None."""
        if self.applies_to is None:
            return None
        return prep.memo(("applies", self.name), lambda: self.applies_to(prep))


_REGISTRY: dict[str, Solver] = {}


def register(solver: Solver) -> Solver:
    """Add a method to the registry (each method module calls this once at import).

    Parameters
    ----------
    solver : Solver
        The method: its name, settings type, applicability test and kernel call.

    Returns
    -------
    Solver
        ``solver`` itself.

    Raises
    ------
    ValueError
        An unknown ``kind``, a name registered twice, or a setting called ``method``.
    """
    if solver.kind not in KINDS:
        raise ValueError(f"solver {solver.name}: kind {solver.kind!r} not in {KINDS}")
    if solver.name in _REGISTRY:
        raise ValueError(f"solver {solver.name!r} registered twice")
    if "method" in {f.name for f in dataclasses.fields(solver.settings)}:
        raise ValueError(f"solver {solver.name}: a setting may not be called 'method' (it names the registered solver)")
    _REGISTRY[solver.name] = solver
    return solver


def names() -> list[str]:
    """The registered solver names, in registration order (the order of ``python -m pipeline solvers``).

    Returns
    -------
    list of str
    """
    return list(_REGISTRY)


def get(name: str) -> Solver:
    """The registered solver ``name``.

    Parameters
    ----------
    name : str
        A registered solver name (:func:`names`).

    Returns
    -------
    Solver

    Raises
    ------
    SettingsError
        No solver of that name (the message lists the registered ones).
    """
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
    """The robot prepared for ``settings.length_unit``; raises NotApplicableError if the solver does not fit
    (with ``fixed_joints``, the arm with those joints held: :mod:`pipeline.solvers.core.fixed`)."""
    spec = get(name)
    prep = robot if isinstance(robot, Prepared) and robot.unit == settings.length_unit else Prepared(robot, settings.length_unit)
    pairs = fixed.held(settings)
    why = spec.refusal(fixed.folded(prep, pairs)[0] if pairs else prep)
    if why and pairs:
        why = f"with joint{'s' if len(pairs) > 1 else ''} {', '.join(str(k) for k, _ in pairs)} held: {why}"
    if why:
        raise NotApplicableError(f"{prep.source.path or prep.source.name}: solver '{name}' does not apply: {why}")
    return prep


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


_BY_VALUE: dict = {}  # (name, id(robot), settings items) -> (robot, Bound): solve() with a mapping, cached
_BY_VALUE_MAX = 64


def _bound_by_value(name: str, robot, settings) -> Bound:
    """:func:`bind` for ``solve(name, robot, T, q0, {...})``: the binding of a robot object and a settings
    mapping (or None) is kept, keyed by the robot's identity and the mapping's items, so the call a user
    writes first costs what a bound call costs after its first use (a joint map such as ``fixed_joints``
    keyed by its items). A mapping with other unhashable values (lists) is bound afresh each call. Robot
    models are treated as immutable (they are frozen)."""
    try:
        key = (name, id(robot), None if settings is None else tuple(sorted(
            (k, tuple(sorted(v.items())) if isinstance(v, dict) else v) for k, v in settings.items())))
        hash(key)
    except TypeError:
        return bind(name, robot, settings)
    hit = _BY_VALUE.get(key)
    if hit is not None and hit[0] is robot:
        return hit[1]
    b = bind(name, robot, settings)
    if len(_BY_VALUE) >= _BY_VALUE_MAX:
        _BY_VALUE.pop(next(iter(_BY_VALUE)))
    _BY_VALUE[key] = (robot, b)
    return b


def solve(name: str, robot: RobotModel | Prepared, T_goal: np.ndarray, q_start: np.ndarray,
          settings: Settings | dict | None = None, *, seed: int = 0) -> IKResult:
    """Solve one IK problem with a registered method.

    Parameters
    ----------
    name : str
        A registered solver (``python -m pipeline solvers``).
    robot : RobotModel or Prepared
        The binding of :func:`bind` is cached, so repeated calls are cheap: for a Prepared robot with
        a Settings object, and for a robot model with a settings mapping or None.
    T_goal : ndarray, shape (4, 4) [robot file's length unit]
        Goal pose (homogeneous transform; rotation part unitless).
    q_start : ndarray, shape (n,) [rad | robot file's length unit]
        Start joint values.
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
        hit = robot._last.get(name)  # the method's binding of the last call: no key to build (0.13-0.15 µs a
        if hit is not None and hit.settings is settings:  # call less amid other work, benchmarks/call_budget.py)
            return hit.call(T_goal, q_start, seed, t0)
        hit = robot._bound.get((name, id(settings)))
        if hit is not None and hit.settings is settings:
            robot._last[name] = hit
            return hit.call(T_goal, q_start, seed, t0)
    return _bound(name, robot, settings).call(T_goal, q_start, seed, t0)


def _bound(name: str, robot: RobotModel | Prepared, settings: Settings | dict | None) -> Bound:
    """The binding :func:`solve` and :func:`solve_batch` use: cached for a Prepared robot with a Settings
    object (:func:`bind`) and for a robot object with a settings mapping or None (:func:`_bound_by_value`)."""
    if settings is None or type(settings) is dict:
        return _bound_by_value(name, robot, settings)
    return bind(name, robot, settings)


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
        A registered solver (``python -m pipeline solvers``).
    robot : RobotModel or Prepared
        The robot (see :func:`solve` for the cached binding).
    goals : ndarray, shape (N, 4, 4) [robot file's length unit]
        Goal poses.
    starts : ndarray, shape (N, n) [rad | robot file's length unit]
        Start joint values, one row per goal.
    settings : Settings, mapping or None
        The solver's settings (SI units); None = the registered defaults.
    seeds : array_like of int, shape (N,), optional
        Per-problem seeds (stochastic methods); default 0..N-1.
    threads : int, optional
        Compiled threads (default: numba's, i.e. every core).
    traces : bool
        Keep every problem's per-iteration trace.

    Returns
    -------
    BatchResult
        ``call_time_s`` is the whole call; per-problem ``solve_time_s`` is measured inside the kernel.

    The binding is kept as :func:`solve` keeps it (a Prepared robot with a Settings object, or a robot
    object with a settings mapping), so a repeated batch does not pack the solver again.
    """
    t0 = clock_ns()
    return _bound(name, robot, settings).solve_many(goals, starts, seeds, threads, traces, t0)


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
