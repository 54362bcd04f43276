"""The solver contract: what every registered IK method promises, checked on any machine.

:func:`contract` runs a property ``prop(case)`` over every registered solver (peer solvers whose
optional library is not installed are skipped, with the reason) x chain kind (one pytest case each)
x call path (``solve`` one problem at a time, ``solve_batch`` all at once) x settings variant
(``restarts`` on/off, ``require_limits`` on/off) (both inside each drawn example), on chains, goals
and starts that hypothesis draws for the kind:

``dh``          a standard-DH chain of 4, 6 or 7 revolute joints, random link parameters, base and tool
``mdh``         the same in the modified (Craig) convention
``general``     the general (URDF origin + axis) form: random origins and skew axes
``prismatic``   a chain of any of the three forms with one or two prismatic joints
``home``        the first catalogue arm the solver applies to (so the closed forms are exercised too),
                its lengths as shipped (``n = 0``) or scaled by 0.6 or 1.5 (``n = 1``), moved by a drawn base
                transform or not

Every goal is reachable by construction (joint values drawn within the limits, their forward
kinematics is the goal); each start is those joint values perturbed. A solver that does not fit a
drawn chain must say so with :class:`~pipeline.solvers.NotApplicableError` (a one-line message
naming it) from ``prepare`` and from the public call alike; that is then the whole case.

Only the public names of :mod:`pipeline.solvers`, :mod:`pipeline.kinematics` and
:mod:`pipeline.robots` are used; the checks recompute forward kinematics with
:func:`pipeline.kinematics.fk_htm`, never with the solver's own check.

A failure names its case, e.g. ``dls/solve/limits/dh n=6 seed=123 settings={'require_limits': True}``;
rebuild it with ``draw_case("dls", "dh", 6, 123, {"require_limits": True})``.
"""

from __future__ import annotations

import functools
import importlib.metadata
import json
import math
import zlib
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pipeline.kinematics import Chain, fk_htm
from pipeline.robots import RobotModel, load_robot
from pipeline.solvers import (IKResult, NotApplicableError, StopReason, catalogue, get, make_settings, names, prepare,
                              solve, solve_batch)
from tests.conftest import random_transform

ROOT = Path(__file__).resolve().parents[2]

PATHS = ("solve", "solve_batch")
# settings variants: restarts on/off x require_limits on/off (the Settings base's fields, every method has them)
VARIANTS = {"plain": {}, "restarts": {"restarts": 1}, "limits": {"require_limits": True},
            "limits_restarts": {"require_limits": True, "restarts": 1}}
KINDS = ("dh", "mdh", "general", "prismatic", "home")
DOFS = (4, 6, 7)  # few shapes: a kernel compiles per signature, a closed form per family and joint count
HOME_ARMS = ("kuka_lwr", "ur5", "puma560", "mariano_4dof", "scara")  # the first one a solver applies to is its home
N_GOALS = 3
LIMIT_TOL = 1e-6  # the one joint-limit tolerance the solvers document (Settings.require_limits, within_limits)
FK_SLACK = 1e-9   # rounding between the solver's FK check and fk_htm, far below any tolerance [m, rad]

# Methods whose runs are slow (SciPy optimisers, a swarm): fewer examples keep the file's time down.
SLOW = {"lbfgsb": 1, "nelder_mead": 1, "pso": 1}
GOALS = {"lbfgsb": 2, "pso": 2}  # goals per case where one solve takes a tenth of a second or more (N_GOALS otherwise)
# For the SLOW methods, which have no batch kernel (their solve_batch is one solve per problem, stacked), the
# properties run on the solve path alone but the batch property, which holds solve_batch equal to solve.
EXAMPLES = 2

# Not deterministic by design: the determinism and batch-equals-single properties do not apply (every
# other property does).
NOT_DETERMINISTIC = {
    "trac_ik": "TRAC-IK races two solvers on threads under a wall-time budget: which one wins depends on the machine",
}
# Settings every variant of a solver starts from: the iteration caps of the methods whose failed search
# takes a second or more cut (defaults 2000, 20000, 15000, 5000 and 5000), to keep the file's time down;
# the contract holds for any valid settings.
BASE = {"geometric_iterative": {"max_iterations": 200}, "zero_position": {"max_iterations": 1000},
        "lbfgsb": {"max_iterations": 1000}, "nelder_mead": {"max_iterations": 1000},
        "jpinv_descent": {"max_iterations": 1000}}

# Known contract failures: (solver, property name, kind or None) -> reason, marked xfail(strict=True) so that
# a fix shows up as an unexpected pass. None today (the rtb adapter's one is its own strict xfail,
# tests/solvers/test_contract.py::test_rtb_failed_call_is_repeatable).
KNOWN: dict = {}

TIMES = {"solve_time_s", "ik_time_s", "call_time_s", "cpu_time_s", "compiled", "compile_time_s"}


# ------------------------------------------------------------------------------------------------------
# chains, goals and starts


def _limits(rng: np.random.Generator, prismatic: np.ndarray) -> np.ndarray:
    """Finite limits (n, 2): revolute [-pi..-0.5, 0.5..pi] rad, prismatic [-0.3..0, 0.1..0.4] m."""
    n = prismatic.shape[0]
    lo = np.where(prismatic, rng.uniform(-0.3, 0.0, n), rng.uniform(-math.pi, -0.5, n))
    hi = np.where(prismatic, rng.uniform(0.1, 0.4, n), rng.uniform(0.5, math.pi, n))
    return np.stack([lo, hi], axis=1)


def random_model(kind: str, n: int, seed: int) -> RobotModel:
    """A drawn arm of ``kind`` (one of KINDS but ``home``) with ``n`` joints, in metres."""
    rng = np.random.default_rng(seed)
    conv = {"dh": "standard", "mdh": "modified", "general": "general"}.get(kind)
    prismatic = np.zeros(n, bool)
    if kind == "prismatic":
        conv = ("standard", "modified", "general")[int(rng.integers(3))]
        prismatic[rng.choice(n, size=int(rng.integers(1, 3)), replace=False)] = True
    base, tool = random_transform(rng, 0.3), random_transform(rng, 0.1)
    if conv == "general":
        z = np.zeros(n)
        origins = np.array([random_transform(rng, 0.3) for _ in range(n)])
        chain = Chain(z, z, z, z, prismatic, "general", base, tool, origins, rng.normal(size=(n, 3)))
    else:
        chain = Chain(rng.normal(scale=0.3, size=n), rng.uniform(-math.pi, math.pi, n), rng.normal(scale=0.3, size=n),
                      rng.uniform(-math.pi, math.pi, n), prismatic, conv, base, tool)
    return RobotModel(f"{kind}{n}_{seed}", "contract test", "m", chain, _limits(rng, prismatic))


@functools.lru_cache(maxsize=None)
def home_arm(solver: str) -> str | None:
    """The first of HOME_ARMS the solver applies to (None: none)."""
    s = make_settings(solver, {})
    for arm in HOME_ARMS:
        try:
            prepare(solver, _shipped(arm), s)
            return arm
        except NotApplicableError:
            continue
    return None


@functools.lru_cache(maxsize=None)
def _shipped(arm: str) -> RobotModel:
    return load_robot(ROOT / "data" / "robots" / f"{arm}.yaml").in_unit("m")


def home_model(arm: str, seed: int, scaled: bool) -> RobotModel:
    """Catalogue arm ``arm`` with its lengths as shipped or (``scaled``) scaled by 0.6 or 1.5, and a drawn base
    transform or its own."""
    rng = np.random.default_rng(seed)
    m = _shipped(arm)
    f = (0.6, 1.5)[int(rng.integers(2))] if scaled else 1.0
    c = m.chain.scaled(f)
    base = random_transform(rng, 0.3) if rng.random() < 0.5 else c.base
    chain = Chain(c.a, c.alpha, c.d, c.theta_offset, c.prismatic, c.convention, base, c.tool, c.origins, c.axes)
    lim = np.array(m.limits, dtype=float)
    lim[c.prismatic] *= f
    return RobotModel(f"{arm}_x{f}_{seed}", "contract test", "m", chain, lim)


def box(model: RobotModel) -> np.ndarray:
    """Joint box (n, 2) goals are drawn in: the limits, +-pi / +-0.3 m where a limit is infinite."""
    lim = np.array(model.limits, dtype=float)
    w = np.where(model.chain.prismatic, 0.3, math.pi)
    lim[:, 0] = np.where(np.isfinite(lim[:, 0]), lim[:, 0], -w)
    lim[:, 1] = np.where(np.isfinite(lim[:, 1]), lim[:, 1], w)
    return lim


def reach(model: RobotModel) -> float:
    """An upper bound of |p_tool - p_base| [m] over the joint box: every fixed translation of the chain in
    the general form plus the prismatic joints' largest travel."""
    origins, _, tool = model.chain.as_general()
    b = box(model)
    travel = np.abs(b[model.chain.prismatic]).max(axis=1).sum() if model.chain.prismatic.any() else 0.0
    return float(np.linalg.norm(origins[:, :3, 3], axis=1).sum() + np.linalg.norm(tool[:3, 3]) + travel)


_RUNS: dict = {}  # (solver, path, variant, "kind n=.. seed=..") -> the case's answers (shared by the properties)


@dataclass
class Case:
    """One drawn problem set for one solver, path and settings variant."""

    solver: str
    path: str
    variant: str
    kind: str
    model: RobotModel
    mapping: dict
    q_goal: np.ndarray  # (N, n) joint values the goals were made from
    goals: np.ndarray   # (N, 4, 4) [m]
    starts: np.ndarray  # (N, n)
    seeds: np.ndarray   # (N,)
    label: str
    _prep: object = None
    _settings: object = None

    @property
    def require_limits(self) -> bool:
        return bool(self.mapping.get("require_limits", False))

    def prepared(self):
        """The robot prepared for the solver (raises NotApplicableError when it does not fit), with the
        settings object the calls use (so that the binding is made once and cached on it)."""
        if self._prep is None:
            self._settings = make_settings(self.solver, self.mapping)
            self._prep = prepare(self.solver, self.model, self._settings)
        return self._prep

    def run(self, goals=None, starts=None, seeds=None, path: str | None = None, fresh: bool = False) -> list[IKResult]:
        """The solver's answers to ``goals`` from ``starts`` (default: the case's) through ``path``
        (default: the case's); ``fresh``: a new robot preparation and binding instead of the cached one."""
        path = path or self.path
        key = (self.label.split("/", 1)[0], path, self.variant, self.label.split("/", 3)[3])
        own = goals is None and starts is None and seeds is None and not fresh and self.variant
        if own and key in _RUNS:  # this case's answers, computed by another property of the same case
            return _RUNS[key]
        G = self.goals if goals is None else goals
        S = self.starts if starts is None else starts
        seeds = self.seeds[: len(G)] if seeds is None else seeds
        if fresh:
            robot, s = self.model, make_settings(self.solver, self.mapping)
        else:
            robot, s = self.prepared(), self._settings
        if path == "solve":
            out = [solve(self.solver, robot, G[i], S[i], s, seed=int(seeds[i])) for i in range(len(G))]
        else:
            b = solve_batch(self.solver, robot, G, S, s, seeds=seeds, traces=path != "solve_batch_notrace")
            out = [b.result(i) for i in range(len(b))]
        if own:
            _RUNS[key] = out
        return out

    def where(self, i: int | None = None) -> str:
        return self.label + ("" if i is None else f" goal {i}")


def draw_case(solver: str, kind: str, n: int, seed: int, mapping: dict | None = None, path: str = "solve",
              variant: str = "") -> Case:
    """The case ``(kind, n, seed)`` of ``solver`` (a failure message names these: the reproducer)."""
    if kind == "home":
        model = home_model(home_arm(solver) or HOME_ARMS[0], seed, scaled=bool(n))
    else:
        model = random_model(kind, n, seed)
    rng = np.random.default_rng([seed, 1])
    b = box(model)
    n_goals = GOALS.get(solver, N_GOALS)
    q = b[:, 0] + (b[:, 1] - b[:, 0]) * rng.random((n_goals, model.n))
    step = np.where(model.chain.prismatic, 0.02, 0.25)
    starts = q + rng.normal(size=q.shape) * step
    goals = np.array([fk_htm(model.chain, x, exact=True) for x in q])
    label = f"{solver}/{path}/{variant or 'custom'}/{kind} n={n} seed={seed} settings={mapping or {}}"
    return Case(solver, path, variant, kind, model, dict(mapping or {}), q, goals, starts,
                np.arange(n_goals, dtype=np.int64) + 1000, label)


# ------------------------------------------------------------------------------------------------------
# independent checks


def pose_errors(model: RobotModel, q: np.ndarray, T_goal: np.ndarray) -> tuple[float, float]:
    """|dp| [m] and rotation angle [rad] between fk_htm(q) and the goal."""
    T = fk_htm(model.chain, np.asarray(q, dtype=float))
    dp = float(np.linalg.norm(T[:3, 3] - T_goal[:3, 3]))
    # angle from the chord |R - R_goal|_F = 2 sqrt(2) sin(angle / 2): accurate near 0, unlike arccos
    chord = float(np.linalg.norm(T[:3, :3] - T_goal[:3, :3]))
    return dp, 2.0 * math.asin(min(1.0, chord / (2.0 * math.sqrt(2.0))))


def outside_limits(model: RobotModel, q: np.ndarray) -> list[int]:
    """Joints whose value lies beyond the limits by more than LIMIT_TOL (no wrapping: the results are
    returned wrapped into the limits, Settings.require_limits)."""
    lim = np.asarray(model.limits, dtype=float)
    return [j for j in range(model.n) if not (lim[j, 0] - LIMIT_TOL <= q[j] <= lim[j, 1] + LIMIT_TOL)]


def same_result(a: IKResult, b: IKResult, where: str, skip=()) -> None:
    """Every field of two results equal bit for bit, timings (and the compile record) and ``skip`` aside."""
    for f in fields(a):
        if f.name in TIMES or f.name in skip:
            continue
        x, y = getattr(a, f.name), getattr(b, f.name)
        if f.name == "info":
            x, y = ({k: v for k, v in dict(d or {}).items() if "time" not in k} for d in (x, y))
            assert json.dumps(x, sort_keys=True, default=str) == json.dumps(y, sort_keys=True, default=str), \
                f"{where}: info {x} != {y}"
        elif x is None or y is None:
            assert x is None and y is None, f"{where}: {f.name} {x!r} vs {y!r}"
        elif isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            x, y = np.asarray(x), np.asarray(y)
            assert x.shape == y.shape and np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), \
                f"{where}: {f.name} differs:\n{x!r}\n{y!r}"
        else:
            assert type(x) is type(y) and (x == y or (x != x and y != y)), f"{where}: {f.name} {x!r} != {y!r}"


# ------------------------------------------------------------------------------------------------------
# the decorator


@functools.lru_cache(maxsize=None)
def installed(solver: str) -> str | None:
    """Why a peer solver cannot run here (its library is not installed), or None."""
    lib = get(solver).library
    if lib == "ours":
        return None
    try:
        importlib.metadata.version(lib)
    except importlib.metadata.PackageNotFoundError:
        return f"{solver}: optional peer library {lib!r} not installed (pip install ik-pipeline[peers])"
    return None


def _solver_params(prop: str, kinds) -> list:
    """One pytest case per registered solver and chain kind (peers without their library skipped,
    KNOWN failures marked xfail strict)."""
    out = []
    registered = [row["name"] for row in catalogue()]
    assert registered == names()
    for name in registered:
        for kind in kinds:
            marks = []
            missing = installed(name)
            if missing:
                marks.append(pytest.mark.skip(reason=missing))
            for key in ((name, prop, kind), (name, prop, None)):
                if key in KNOWN:
                    marks.append(pytest.mark.xfail(strict=True, reason=KNOWN[key]))
                    break
            out.append(pytest.param(name, kind, marks=marks, id=f"{name}-{kind}"))
    return out


def contract(paths=PATHS, variants=tuple(VARIANTS), kinds=KINDS, deterministic_only: bool = False):
    """Run property ``prop(case)`` over every solver x ``paths`` x ``variants`` x ``kinds`` on drawn cases.

    One pytest case per solver and chain kind (a hypothesis run costs tens of milliseconds of its own:
    a case per path and variant too would multiply that by eight); each drawn example runs the property
    on every path and settings variant, and a failure names the path and variant (:attr:`Case.label`).
    The property receives a :class:`Case` whose solver fits the drawn chain (a solver that does not
    fit is checked to refuse it with a one-line NotApplicableError from ``prepare`` and from the
    public call, and that combination ends there). ``deterministic_only`` skips the solvers of
    NOT_DETERMINISTIC, with the reason. Hypothesis runs derandomized (the same examples on every
    run and machine, a stream per solver and kind shared by the properties, so that they check the same
    answers, computed once: ``_RUNS``), a few examples (SLOW solvers fewer), no deadline (a first
    call compiles).
    """

    def decorate(prop):
        def test(solver, kind):
            if deterministic_only and solver in NOT_DETERMINISTIC:
                pytest.skip(f"{solver} is not deterministic: {NOT_DETERMINISTIC[solver]}")
            mix = zlib.crc32(kind.encode())  # another chain per kind, the same for all solvers
            dofs = (0, 1) if kind == "home" else DOFS  # home: n = 0 the arm's lengths as shipped, 1 scaled

            @settings(max_examples=SLOW.get(solver, EXAMPLES), deadline=None, derandomize=True, database=None,
                      suppress_health_check=list(HealthCheck))
            @given(n=st.sampled_from(dofs), seed=st.integers(0, 2**31 - 1))
            def example(n, seed):
                for variant in variants:
                    mapping = {**BASE.get(solver, {}), **VARIANTS[variant]}
                    for path in paths:
                        if solver in SLOW and path == "solve_batch" and len(paths) > 1 and get(solver).batch is None:
                            continue
                        case = draw_case(solver, kind, n, (seed + mix) % 2**31, mapping, path, variant)
                        if _fits(case):
                            prop(case)

            example.hypothesis.inner_test._hypothesis_internal_add_digest = f"{solver}/{kind}".encode()
            example()

        test.__name__, test.__qualname__, test.__doc__ = prop.__name__, prop.__qualname__, prop.__doc__
        test.__module__ = prop.__module__
        test.prop = prop  # the bare property (tests/solvers/test_contract.py plants bugs under it)
        return pytest.mark.parametrize("solver,kind", _solver_params(prop.__name__, kinds))(test)

    return decorate


def _fits(case: Case) -> bool:
    """Whether the solver fits the case's chain; if not, the refusal must be a clear NotApplicableError
    from ``prepare`` and from the public call (never another exception, never an answer)."""
    try:
        case.prepared()
        return True
    except NotApplicableError as e:
        msg = str(e)
    assert msg and "\n" not in msg and case.solver in msg, f"{case.where()}: unclear refusal {msg!r}"
    with pytest.raises(NotApplicableError):
        case.run(fresh=True)
    return False


STOP_VALUES = {int(r) for r in StopReason}
