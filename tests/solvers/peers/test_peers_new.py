"""The peers of issue 43 (pipeline/solvers/peers/python_ik.py, qp_ik.py): pybullet, ikpy, pink, mink, placo.

Warm-start goals (as tests/test_peers.py) on the KUKA LWR (cm: unit conversion), the PUMA 560 (mm) and the
Franka Panda (7R, finite limits), judged by the registry's FK check; the peers' models are checked against
our FK when they are built (a mismatch refuses the robot); pybullet's documented default call stops
short of the goal (its documented behaviour, the default row), the tuned row reaches it; the QP loops
keep every answer within the limits; a library that cannot be imported is a one-line refusal.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from pipeline.kinematics import fk_htm
from pipeline.solvers import NotApplicableError, make_settings, names, prepare, solve
from tests.conftest import ROOT
from tests.solvers.peers.test_peers import _general_model, _goals, _robot, solved_goals

LIBRARY = {"pybullet_ik": "pybullet", "ikpy": "ikpy", "pink": "pink", "mink": "mink", "placo": "placo"}
TUNED = {"max_num_iterations": 100, "residual_threshold": 1e-6, "joint_damping": 0.01}
ROBOTS = ["kuka_lwr", "puma560", "franka_panda"]
GOALS = 20
MIN_SUCCESS = {"ikpy": 0.9, "pink": 0.9, "mink": 0.9, "pybullet_ik": 0.6}  # pybullet (tuned): DLS without limits
LIMIT_TOL = 1e-9  # [rad | length] a QP loop's iterate may sit on a limit up to rounding


def test_every_new_peer_is_registered():
    assert set(LIBRARY) <= set(names())


@pytest.mark.parametrize("robot", ROBOTS)
@pytest.mark.parametrize("solver", ["pybullet_ik", "ikpy", "pink", "mink"])
def test_warm_start_success(solver, robot):
    pytest.importorskip(LIBRARY[solver])
    model = _robot(robot)
    s = make_settings(solver, TUNED if solver == "pybullet_ik" else None)
    prep = prepare(solver, model, s)
    ok = 0
    for res in solved_goals(solver, prep, model, s, GOALS)[0]:
        ok += res.success
        if solver in ("pink", "mink"):  # the configuration limit keeps every iterate within the limits
            lim = model.limits
            assert np.all(res.q >= lim[:, 0] - LIMIT_TOL) and np.all(res.q <= lim[:, 1] + LIMIT_TOL)
    assert ok >= MIN_SUCCESS[solver] * GOALS, f"{solver} on {robot}: {ok}/{GOALS}"


def test_pybullet_default_call_stops_short():
    """pybullet's documented call (20 iterations, no damping) leaves the Panda's goals millimetres off:
    no success, and every answer is closer to the goal than the start was."""
    pytest.importorskip("pybullet")
    model = _robot("franka_panda")
    s = make_settings("pybullet_ik")
    prep = prepare("pybullet_ik", model, s)
    Q, Q0, T = _goals(model, GOALS)
    off = []
    for i in range(GOALS):
        res = solve("pybullet_ik", prep, T[i], Q0[i], s)
        off.append(np.linalg.norm(fk_htm(model.chain, res.q)[:3, 3] - T[i, :3, 3]))
        assert not res.success
    assert np.median(off) > 1e-4


@pytest.mark.parametrize("solver", ["pybullet_ik", "ikpy", "mink"])
def test_models_of_odd_chains(solver):
    """A general chain (tilted and negative axes, a prismatic joint, base and tool) is modelled exactly (the
    model build checks its FK against ours, or refuses) and solved from warm starts."""
    pytest.importorskip(LIBRARY[solver])
    model = _general_model()
    s = make_settings(solver, TUNED if solver == "pybullet_ik" else None)
    prep = prepare(solver, model, s)
    Q, Q0, T = _goals(model, 10, seed=3)
    assert sum(solve(solver, prep, T[i], Q0[i], s).success for i in range(10)) >= 5


def test_restarts_row_runs():
    pytest.importorskip("pink")
    model = _robot("franka_panda")
    s = make_settings("pink", {"require_limits": True, "restarts": 20})
    prep = prepare("pink", model, s)
    rng = np.random.default_rng(1)
    Q = rng.uniform(model.limits[:, 0], model.limits[:, 1], (5, model.n))
    starts = rng.uniform(model.limits[:, 0], model.limits[:, 1], (5, model.n))
    T = np.array([fk_htm(model.chain, q) for q in Q])
    res = [solve("pink", prep, T[i], starts[i], s, seed=i) for i in range(5)]
    assert sum(r.success for r in res) >= 4 and all(r.within_limits for r in res if r.success)


def test_placo_row_says_why():
    """placo 0.10.2 pins pin==3.8.0: beside this environment's pin 4.1.0 its rows are a one-line refusal."""
    try:
        import placo  # noqa: F401
    except ImportError:
        with pytest.raises(NotApplicableError, match="not installable beside pin 4.1.0") as exc:
            prepare("placo", _robot("ur5e"), make_settings("placo"))
        assert "\n" not in str(exc.value)
    else:
        pytest.skip("placo is installed here")


def test_missing_libraries_are_refusals_not_import_errors():
    """With the new peers' libraries hidden, importing pipeline.solvers works and each refuses in one line."""
    code = (
        "import sys\n"
        "for m in ('pybullet', 'ikpy', 'pink', 'mink', 'mujoco', 'qpsolvers', 'placo'):\n"
        "    sys.modules[m] = None\n"
        "from pipeline.robots import load_robot\n"
        "from pipeline.solvers import prepare, make_settings, NotApplicableError\n"
        "m = load_robot('data/robots/ur5e.yaml')\n"
        f"for s in {list(LIBRARY)!r}:\n"
        "    try:\n"
        "        prepare(s, m, make_settings(s))\n"
        "    except NotApplicableError as e:\n"
        "        assert '\\n' not in str(e); print(s, 'refused:', str(e).split(': ', 2)[-1])\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.count("refused:") == len(LIBRARY), out.stdout
