"""Seeded IK problem sets (pure: every random function takes a ``numpy.random.Generator``).

A study's ``problem_sets`` (data/studies/<id>.yaml) name a *kind*:

``random_joint_pairs``  start and goal angles uniform in ``[low, high)`` (000's protocol)
``warm_start``          goal angles uniform within the joint limits (``[low, high)`` where a joint
                        has none); start = goal + uniform noise of half-width ``spread`` [rad]
                        (``clip: true`` clips the start to the limits)
``within_limits``       start and goal angles independently uniform within the joint limits
                        (``[low, high)`` where a joint has none): cold starts
``generator``           a study's own function ``"pipeline.studies.<id>.<module>:<function>"``
                        with the signature of :data:`Generator`, one of the registry
                        :data:`GENERATORS` (no other import string is accepted)

Problems that share a ``chain`` id >= 0 are solved in file order, each starting from the previous
problem's returned angles (path following); ``chain = -1`` marks an independent problem.

Goal poses are the same bits on every machine: :func:`fk_poses` multiplies the 4x4 link transforms
with explicit element-wise products and sums (each entry ``((a0 b0 + a1 b1) + a2 b2) + a3 b3``, no
fused multiply-add), never through BLAS, whose kernels (chosen per CPU, e.g. ``OPENBLAS_CORETYPE``)
round differently in the last digits. ``tests/test_problem_determinism.py`` checks the problem-set
hashes under two OpenBLAS core types.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np

from pipeline.kinematics import fk_htm, matrix_from_quat, quat_from_matrix
from pipeline.robots import MAX_ANGLE, RobotModel

KINDS = ("random_joint_pairs", "warm_start", "within_limits", "generator")
# parameters of the built-in kinds (a generator's are its own): name -> kind of value
PARAMS = {
    "random_joint_pairs": {"low": "number", "high": "number"},
    "warm_start": {"spread": "number", "low": "number", "high": "number", "clip": "bool"},
    "within_limits": {"low": "number", "high": "number"},
}
MAX_RANGE = MAX_ANGLE  # |low|, |high|, spread [rad | length]: the robot files' own bound on angles


class ProblemSpecError(ValueError):
    """A problem-set specification cannot be used (one line naming the field)."""


@dataclass(frozen=True)
class ProblemSet:
    """A set of IK problems for one robot.

    Attributes
    ----------
    problem_id : ndarray of int, shape (m,)
    q_start, q_goal : ndarray, shape (m, n) [rad | length]   ``q_goal`` may be NaN (goal angles unknown)
    goal_position : ndarray, shape (m, 3) [length_unit]
    goal_quat : ndarray, shape (m, 4)   w-first
    robot, length_unit : str
    chain : ndarray of int, shape (m,)  -1 = independent; else warm-started from the previous problem of the chain
    """

    problem_id: np.ndarray
    q_start: np.ndarray
    q_goal: np.ndarray
    goal_position: np.ndarray
    goal_quat: np.ndarray
    robot: str
    length_unit: str
    chain: np.ndarray = field(default=None)

    def __post_init__(self):
        if self.chain is None:
            object.__setattr__(self, "chain", np.full(len(self.problem_id), -1, dtype=int))

    def __len__(self) -> int:
        return int(self.problem_id.shape[0])

    def goal_transforms(self) -> np.ndarray:
        """Goal poses ``T_base_ee``, shape (m, 4, 4)."""
        T = np.zeros((len(self), 4, 4))
        T[:, :3, :3] = matrix_from_quat(self.goal_quat)
        T[:, :3, 3] = self.goal_position
        T[:, 3, 3] = 1.0
        return T

    def head(self, m: int) -> "ProblemSet":
        return self.take(np.arange(min(m, len(self))))

    def take(self, idx) -> "ProblemSet":
        idx = np.asarray(idx, dtype=int)
        return replace(self, problem_id=self.problem_id[idx], q_start=self.q_start[idx], q_goal=self.q_goal[idx],
                       goal_position=self.goal_position[idx], goal_quat=self.goal_quat[idx], chain=self.chain[idx])


FILE_SUFFIXES = (".yaml", ".yml", ".csv", ".json", ".txt", ".gz")  # a generator parameter ending so names a file


def check_data_relative(value, field: str) -> str:
    """A file a problem set names (``files``, a generator's file parameter): a path relative to the data
    folder that cannot leave it (not absolute, no ``..``); else one line naming the field.

    Raises
    ------
    ProblemSpecError
    """
    parts = Path(str(value)).parts
    if not isinstance(value, str) or not value or Path(value).is_absolute() or ".." in parts or "\\" in value \
            or "\x00" in value:
        raise ProblemSpecError(f"{field}: {str(value)[:80]!r} is not a path inside the data folder (relative to it, "
                               f"without '..')")
    return value


def check_spec(spec: dict) -> None:
    """Refuse, in one line naming the field, parameters of a built-in kind that cannot be drawn from.

    Checks ``params`` of ``random_joint_pairs``, ``warm_start`` and ``within_limits``: known names
    only, finite numbers within :data:`MAX_RANGE`, ``low <= high``, ``spread >= 0``, boolean ``clip``.
    A generator checks its own parameters; its name must be in :data:`GENERATORS`.

    Raises
    ------
    ProblemSpecError
    """
    kind = spec.get("kind")
    if kind == "generator":
        check_generator(spec.get("generator"))
        for i, f in enumerate(spec.get("files") or []):
            check_data_relative(f, f"field 'files/{i}'")
        for name, value in (spec.get("params") or {}).items():
            if isinstance(value, str) and ("/" in value or value.endswith(FILE_SUFFIXES)):
                check_data_relative(value, f"field 'params/{name}'")
    if kind not in PARAMS:
        return
    params = spec.get("params") or {}
    if not isinstance(params, dict):
        raise ProblemSpecError(f"field 'params': expected a mapping, got {type(params).__name__}")
    for name, value in params.items():
        want = PARAMS[kind].get(name)
        where = f"field 'params/{name}'"
        if want is None:
            raise ProblemSpecError(f"{where}: unknown parameter of kind {kind} (allowed: {', '.join(PARAMS[kind])})")
        if want == "bool":
            if not isinstance(value, bool):
                raise ProblemSpecError(f"{where}: expected true or false, got {value!r}")
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ProblemSpecError(f"{where}: expected a number, got {str(value)[:40]!r}")
        if not math.isfinite(value):
            raise ProblemSpecError(f"{where}: must be finite, got {value!r}")
        if abs(value) > MAX_RANGE:
            raise ProblemSpecError(f"{where}: {value:g} is beyond the sane maximum {MAX_RANGE:g} in absolute value")
    if params.get("spread", 0.0) < 0:
        raise ProblemSpecError(f"field 'params/spread': must be >= 0, got {params['spread']!r}")
    low, high = params.get("low"), params.get("high")
    lo_d, hi_d = (0.0, 2 * np.pi) if kind == "random_joint_pairs" else (-np.pi, np.pi)
    lo, hi = (lo_d if low is None else low), (hi_d if high is None else high)
    if lo > hi:
        raise ProblemSpecError(f"field 'params/low': {lo:g} is above 'high' {hi:g}")


def fk_poses(chain, q: np.ndarray) -> np.ndarray:
    """End-effector poses ``T_base_ee`` of joint vectors ``q`` (m, n), bit-identical on every machine.

    :func:`pipeline.kinematics.fk_htm` with ``exact=True``: the link transforms by element-wise
    ``cos``/``sin``, chained by :func:`pipeline.kinematics.htm.mul4` instead of ``@`` (BLAS), one joint
    at a time (memory O(m), whatever n).

    Returns
    -------
    T : ndarray, shape (m, 4, 4) [length for the translation]
    """
    q = np.asarray(q, dtype=float)
    if q.ndim != 2 or q.shape[1] != chain.n:
        raise ValueError(f"expected joint vectors of shape (m, {chain.n}), got {q.shape}")
    return fk_htm(chain, q, exact=True)


def from_goal_angles(model: RobotModel, q_start: np.ndarray, q_goal: np.ndarray, chain=None) -> ProblemSet:
    """A problem set whose goal poses are FK of ``q_goal`` (m, n), by :func:`fk_poses`."""
    T = fk_poses(model.chain, q_goal)
    return ProblemSet(np.arange(q_goal.shape[0]), q_start, q_goal, T[:, :3, 3].copy(), quat_from_matrix(T),
                      model.name, model.length_unit, None if chain is None else np.asarray(chain, dtype=int))


def from_poses(model: RobotModel, q_start: np.ndarray, T_goal: np.ndarray, chain=None, q_goal=None) -> ProblemSet:
    """A problem set from goal poses (m, 4, 4) in the robot's unit; ``q_goal`` NaN unless given."""
    m = T_goal.shape[0]
    qg = np.full((m, model.n), np.nan) if q_goal is None else np.asarray(q_goal, float)
    return ProblemSet(np.arange(m), np.asarray(q_start, float), qg, T_goal[:, :3, 3].copy(), quat_from_matrix(T_goal),
                      model.name, model.length_unit, None if chain is None else np.asarray(chain, dtype=int))


def random_joint_pairs(model: RobotModel, count: int, rng: np.random.Generator,
                       low: float = 0.0, high: float = 2 * np.pi) -> ProblemSet:
    """Start and goal joint vectors drawn uniformly in ``[low, high)``; goal pose = FK(goal).

    This is the protocol of 000_7e3cb7ad5ee98ff0.txt §3.2 (``unifrnd(0, 2*pi)`` per joint).
    Start angles are drawn first (all problems), then goal angles, so that a larger ``count``
    with the same seed does not extend a smaller set: sets of different sizes are independent.

    Parameters
    ----------
    model : RobotModel
    count : int
    rng : numpy.random.Generator
    low, high : float [rad]

    Returns
    -------
    ProblemSet
    """
    if count < 1:
        raise ValueError(f"problem count must be >= 1, got {count}")
    n = model.n
    q_start = rng.uniform(low, high, size=(count, n))
    q_goal = rng.uniform(low, high, size=(count, n))
    return from_goal_angles(model, q_start, q_goal)


def _box(model: RobotModel, low: float, high: float) -> tuple[np.ndarray, np.ndarray]:
    """Per-joint sampling range: the limits, ``[low, high)`` where a joint has none."""
    lim = np.array(model.limits, dtype=float)
    return np.where(np.isfinite(lim[:, 0]), lim[:, 0], low), np.where(np.isfinite(lim[:, 1]), lim[:, 1], high)


def within_limits(model: RobotModel, count: int, rng: np.random.Generator, low: float = -np.pi,
                  high: float = np.pi) -> ProblemSet:
    """Cold starts: goal angles, then start angles, each uniform within the joint limits.

    Parameters
    ----------
    low, high : float [rad | length]
        Range of a joint without limits in the robot file.
    """
    if count < 1:
        raise ValueError(f"problem count must be >= 1, got {count}")
    lo, hi = _box(model, low, high)
    q_goal = lo + (hi - lo) * rng.random((count, model.n))
    q_start = lo + (hi - lo) * rng.random((count, model.n))
    return from_goal_angles(model, q_start, q_goal)


def warm_start(model: RobotModel, count: int, rng: np.random.Generator, spread: float = 0.3,
               low: float = -np.pi, high: float = np.pi, clip: bool = False) -> ProblemSet:
    """Goal angles uniform within the joint limits; start angles within ``spread`` of them.

    Parameters
    ----------
    spread : float [rad | length]
        Half-width of the uniform start noise around each goal angle (for prismatic joints in
        the robot's length unit).
    low, high : float [rad | length]
        Range of a joint without limits in the robot file.

    Notes
    -----
    Goals are drawn first, then the noise, so ``spread`` changes only the starts. Start angles are
    clipped to the limits only with ``clip`` (else a local method must cope with a start just
    outside them).
    """
    if count < 1:
        raise ValueError(f"problem count must be >= 1, got {count}")
    lo, hi = _box(model, low, high)
    q_goal = lo + (hi - lo) * rng.random((count, model.n))
    q_start = q_goal + rng.uniform(-spread, spread, size=(count, model.n))
    if clip:
        lim = np.array(model.limits, dtype=float)
        q_start = np.clip(q_start, lim[:, 0], lim[:, 1])
    return from_goal_angles(model, q_start, q_goal)


Generator = Callable[[RobotModel, int, np.random.Generator, dict, Path], ProblemSet]
"""``fn(model, count, rng, params, data_dir) -> ProblemSet`` of a ``generator`` problem set."""


GENERATORS = (
    "pipeline.studies.borges_kr6.problems:alpha_sweep",
    "pipeline.studies.borges_kr6.problems:points",
    "pipeline.studies.borges_kr6.problems:paths",
    "pipeline.studies.erthal1992.problems:test_goals",
    "pipeline.studies.erthal1992.problems:path_goals",
    "pipeline.studies.nepomuceno2024.problems:motion_points",
)
"""The registry of problem-set generators: the only values a study's ``generator`` may take (the
strings the study files write). A new generator is added here, so that a study file can never make
``make_problems`` import and call an arbitrary function (``pipeline.__main__:main`` ran the CLI)."""


def check_generator(ref) -> str:
    """Refuse a ``generator`` that is not in :data:`GENERATORS` (one line naming the field).

    Raises
    ------
    ProblemSpecError
    """
    if not isinstance(ref, str) or ref not in GENERATORS:
        raise ProblemSpecError(f"field 'generator': {str(ref)[:80]!r} is not a registered generator "
                               f"(pipeline.problems.GENERATORS: {', '.join(GENERATORS)})")
    return ref


def make_problem_set(spec: dict, model: RobotModel, count: int, rng: np.random.Generator,
                     data_dir: Path = Path("data"), scale: str = "full",
                     load: Callable[[str], Generator] | None = None) -> ProblemSet:
    """Draw one problem set of a study's ``problem_sets`` entry for one robot.

    A generator receives the set's ``params`` plus ``scale`` ("full" or "quick"). It is study code,
    a layer above this module, so the caller passes ``load`` (``pipeline.studies.generators.load_generator``)
    to turn a registered name into the function; this module only holds the names (:data:`GENERATORS`).
    """
    kind = spec["kind"]
    params = dict(spec.get("params") or {})
    if kind == "random_joint_pairs":
        return random_joint_pairs(model, count, rng, params.get("low", 0.0), params.get("high", 2 * np.pi))
    if kind == "warm_start":
        return warm_start(model, count, rng, params.get("spread", 0.3), params.get("low", -np.pi),
                          params.get("high", np.pi), bool(params.get("clip", False)))
    if kind == "within_limits":
        return within_limits(model, count, rng, params.get("low", -np.pi), params.get("high", np.pi))
    if kind == "generator":
        if load is None:
            raise ProblemSpecError(f"field 'generator': {spec['generator']!r} needs a generator loader "
                                   "(make_problem_set(..., load=pipeline.studies.generators.load_generator))")
        ps = load(check_generator(spec["generator"]))(model, count, rng, {"scale": scale, **params}, Path(data_dir))
        if not isinstance(ps, ProblemSet):
            raise ProblemSpecError(f"field 'generator': {spec['generator']} returned {type(ps).__name__}, not a ProblemSet")
        return ps
    raise ProblemSpecError(f"field 'kind': {kind!r} is not one of {', '.join(KINDS)}")
