"""EAIK and IK-Geo as registered peer solvers (pipeline/solvers/peers/geo.py).

On the PUMA 560 (mm), ABB IRB 120, KUKA KR 5 arc and UR5, goals from our FK of random within-limit
joint vectors: each peer reaches every goal (success judged by the registry's independent FK check),
lists the original joint vector among its solutions (modulo 2 pi), and every listed solution is
FK-valid. Robots a peer cannot solve are refused in one line; a missing library is the
"not installed" refusal. Tests of a peer are skipped when its library is not installed.
"""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from pipeline.kinematics import fk_htm
from pipeline.robots import RobotModel, load_robot
from pipeline.solvers import NotApplicableError, Prepared, StopReason, get, make_settings, names, prepare
from pipeline.solvers.core import registry
from tests.conftest import DATA

LIBRARY = {"eaik": "eaik", "ik_geo": "ik_geo"}
PEERS = list(LIBRARY)
ROBOTS = ["puma560", "abb_irb120", "kuka_kr5_arc", "ur5"]
SPH2, THREE = "6R-SPHERICAL_SECOND_TWO_PARALLEL", "6R-THREE_INNER_PARALLEL"
FAMILY = {("eaik", "puma560"): SPH2, ("eaik", "abb_irb120"): SPH2, ("eaik", "kuka_kr5_arc"): SPH2,
          ("eaik", "ur5"): THREE,
          ("ik_geo", "puma560"): "spherical_two_parallel", ("ik_geo", "abb_irb120"): "spherical_two_parallel",
          ("ik_geo", "kuka_kr5_arc"): "spherical_two_parallel", ("ik_geo", "ur5"): "three_parallel_two_intersecting"}
GOALS = 60
UNIT = {"m": 1.0, "cm": 1e-2, "mm": 1e-3}


def _robot(name: str) -> RobotModel:
    return load_robot(DATA / "robots" / f"{name}.yaml")


def _goals(model: RobotModel, n: int, seed: int = 7):
    """Random within-limit angles (+-pi where unbounded), their FK, and random starts in the same box."""
    rng = np.random.default_rng(seed)
    lim = np.where(np.isfinite(model.limits), model.limits, [[-math.pi, math.pi]])
    Q = rng.uniform(lim[:, 0], lim[:, 1], (n, model.n))
    Q0 = rng.uniform(lim[:, 0], lim[:, 1], (n, model.n))
    return Q, Q0, np.array([fk_htm(model.chain, q) for q in Q])


def _same_mod_2pi(a: np.ndarray, b: np.ndarray, tol: float = 1e-6) -> bool:
    d = np.mod(np.asarray(a) - np.asarray(b) + math.pi, 2 * math.pi) - math.pi
    return bool(np.abs(d).max() <= tol)


def test_both_peers_are_registered():
    assert set(PEERS) <= set(names())
    for p in PEERS:
        assert get(p).kind == "analytic"


@pytest.mark.parametrize("require_limits", [False, True])
@pytest.mark.parametrize("robot", ROBOTS)
@pytest.mark.parametrize("solver", PEERS)
def test_reaches_every_goal_and_lists_the_original(solver, robot, require_limits):
    pytest.importorskip(LIBRARY[solver])
    model = _robot(robot)
    s = make_settings(solver, {"require_limits": require_limits})
    prep = prepare(solver, model, s)
    Q, Q0, T = _goals(model, GOALS)
    to_m = UNIT[model.length_unit]
    for i in range(GOALS):
        res = registry.solve(solver, prep, T[i], Q0[i], s)
        assert res.success, f"{solver} on {robot}, goal {i}: stop {res.stop_reason}, |dp| {res.position_error}"
        assert res.stop_reason == StopReason.SUCCESS and res.iterations == 0
        assert res.info["family"] == FAMILY[solver, robot]
        assert res.solve_time_s > 0 and res.call_time_s >= res.solve_time_s
        # success by our own FK, in the robot file's unit
        assert np.linalg.norm(fk_htm(model.chain, res.q)[:3, 3] - T[i, :3, 3]) * to_m <= s.tol_pos * (1 + 1e-6)
        sols = res.solutions
        assert sols is not None and sols.shape[1] == model.n and res.info["n_solutions"] == len(sols) >= 1
        assert any(_same_mod_2pi(x, Q[i]) for x in sols), f"{solver} on {robot}, goal {i}: original not found"
        assert any(np.allclose(x, res.q) for x in sols) or not require_limits
        for x in sols:  # every listed solution is FK-valid (and within the limits under require_limits)
            Tx = fk_htm(model.chain, x)
            assert np.linalg.norm(Tx[:3, 3] - T[i, :3, 3]) * to_m <= s.tol_pos * (1 + 1e-6)
            if require_limits:
                assert np.all(x >= model.limits[:, 0] - 1e-9) and np.all(x <= model.limits[:, 1] + 1e-9)
        # q is the listed solution nearest the start: by wrapped joint distance, unwrapped to within pi of the
        # start; under require_limits by the distance of the representatives within the limits
        if not require_limits:
            d = lambda x: float(((np.mod(x - Q0[i] + math.pi, 2 * math.pi) - math.pi) ** 2).sum())  # noqa: E731
            assert np.abs(res.q - Q0[i]).max() <= math.pi + 1e-9
        else:
            d = lambda x: float(((x - Q0[i]) ** 2).sum())  # noqa: E731
            assert res.within_limits
        assert d(res.q) <= min(d(x) for x in sols) + 1e-9


@pytest.mark.parametrize("solver", PEERS)
def test_unreachable_goal_is_no_solution(solver):
    pytest.importorskip(LIBRARY[solver])
    model = _robot("ur5")
    T = np.eye(4)
    T[:3, 3] = (5.0, 0.0, 0.0)  # 5 m away: out of reach
    res = registry.solve(solver, model, T, np.zeros(6))
    assert not res.success and res.stop_reason == StopReason.NO_SOLUTION
    assert np.array_equal(res.q, np.zeros(6)) and len(res.solutions) == 0


@pytest.mark.parametrize("solver", PEERS)
def test_refuses_a_7dof_arm_in_one_line(solver):
    pytest.importorskip(LIBRARY[solver])
    with pytest.raises(NotApplicableError) as e:
        prepare(solver, _robot("franka_panda"), make_settings(solver))
    msg = str(e.value)
    assert "\n" not in msg and "7" in msg and f"solver '{solver}' does not apply" in msg


@pytest.mark.parametrize("solver", PEERS)
def test_refuses_a_4dof_arm_in_one_line(solver):
    """The SCARA (4 joints, one prismatic) for both; IK-Geo also refuses the all-revolute 4-DoF arm,
    which EAIK (1-6R) solves (test_eaik_solves_the_4r_arm)."""
    pytest.importorskip(LIBRARY[solver])
    for robot in (["scara", "mariano_4dof"] if solver == "ik_geo" else ["scara"]):
        with pytest.raises(NotApplicableError) as e:
            prepare(solver, _robot(robot), make_settings(solver))
        msg = str(e.value)
        assert "\n" not in msg and len(msg) < 300
        assert ("prismatic" in msg) if robot == "scara" else ("6R" in msg and "4 joints" in msg)


def test_eaik_solves_the_4r_arm():
    pytest.importorskip("eaik")
    model = _robot("mariano_4dof")  # cm
    s = make_settings("eaik")
    prep = prepare("eaik", model, s)
    Q, Q0, T = _goals(model, 30, seed=3)
    for i in range(30):
        res = registry.solve("eaik", prep, T[i], Q0[i], s)
        assert res.success and res.info["family"] == "4R-SECOND_THIRD_PARALLEL"
        assert any(_same_mod_2pi(x, Q[i]) for x in res.solutions)


@pytest.mark.parametrize("solver,module", [("eaik", "eaik.IK_Homogeneous"), ("ik_geo", "ik_geo")])
def test_missing_library_is_refused(solver, module, monkeypatch):
    monkeypatch.setitem(sys.modules, module, None)  # importing it now raises ImportError, installed or not
    prep = Prepared(_robot("ur5"), "m")
    with pytest.raises(NotApplicableError) as e:
        prepare(solver, prep, make_settings(solver))
    msg = str(e.value)
    assert "\n" not in msg and "not installed: pip install " in msg
    assert ("eaik" if solver == "eaik" else "ik-geo") in msg


def test_models_reproduce_our_fk_at_q0():
    """The POE model: joint points on the axes, p_nT to the tool, R_nT the tool rotation (base included)."""
    pytest.importorskip("ik_geo")
    from pipeline.solvers.core.models import poe as _poe

    for robot in ROBOTS:
        model = _robot(robot)
        prep = Prepared(model, "m")
        g = _poe(prep)
        T0 = fk_htm(prep.model.chain, np.zeros(model.n))
        assert np.allclose(g.P().sum(axis=0), T0[:3, 3], atol=1e-12)
        assert np.allclose(g.T0, T0, atol=1e-12)
        assert np.allclose(np.linalg.norm(g.H, axis=1), 1.0)


@pytest.mark.parametrize("robot", ["puma560", "ur5"])
@pytest.mark.parametrize("solver", PEERS)
def test_base_and_tool_are_in_the_model(solver, robot):
    """The same DH tables with a random base and tool (tilted): the family is unchanged, goals are reached."""
    pytest.importorskip(LIBRARY[solver])
    from pipeline.kinematics import Chain
    from tests.conftest import random_transform

    rng = np.random.default_rng(4)
    base = _robot(robot)
    c = base.chain
    scale = 1.0 / UNIT[base.length_unit]
    B, Tt = random_transform(rng, 0.5 * scale), random_transform(rng, 0.1 * scale)
    chain = Chain(np.array(c.a), np.array(c.alpha), np.array(c.d), np.array(c.theta_offset), np.array(c.prismatic),
                  c.convention, B, Tt)
    model = RobotModel(f"{robot}_moved", "test", base.length_unit, chain, np.array(base.limits))
    s = make_settings(solver)
    prep = prepare(solver, model, s)
    Q, Q0, T = _goals(model, 20, seed=9)
    for i in range(20):
        res = registry.solve(solver, prep, T[i], Q0[i], s)
        assert res.success and res.info["family"] == FAMILY[solver, robot]
        assert any(_same_mod_2pi(x, Q[i]) for x in res.solutions)


def test_importing_the_solvers_never_imports_these_peers():
    """With both libraries unimportable, pipeline.solvers imports and lists both, refusing them in one line."""
    import subprocess

    from tests.conftest import ROOT

    code = ("import sys\n"
            "for m in ('eaik', 'eaik.IK_Homogeneous', 'ik_geo'): sys.modules[m] = None\n"
            "import pipeline.solvers as s\n"
            f"assert set({PEERS!r}) <= set(s.names())\n"
            "from pipeline.robots import load_robot\n"
            "r = load_robot('data/robots/ur5.yaml')\n"
            f"for n in {PEERS!r}:\n"
            "    try:\n"
            "        s.prepare(n, r, s.make_settings(n))\n"
            "        raise SystemExit('no refusal: ' + n)\n"
            "    except s.NotApplicableError as e:\n"
            "        assert 'not installed' in str(e), e\n"
            "print('ok')\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]
