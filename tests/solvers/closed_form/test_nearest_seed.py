"""Warm starts: a closed form under ``require_limits`` returns, of its solutions, the one that moves the joints
least from the seed (each solution by whole turns to its value within the limits nearest the seed), and on
7R arms the sweep finds solutions beside the seed: the answer a user tracking a path needs."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline import robots, solvers
from pipeline.kinematics import fk_htm
from pipeline.studies.arm_benchmark import travel

CASES = [("ur3", "analytic"), ("ur3", "analytic_ur"), ("puma560", "analytic_puma"), ("abb_irb140", "analytic"),
         ("franka_panda", "analytic"), ("kinova_gen3", "analytic"), ("kuka_iiwa14", "analytic")]


def _warm(model, rng):
    box = np.clip(model.limits, -np.pi, np.pi)
    qg = rng.uniform(box[:, 0], box[:, 1])
    return qg, np.clip(qg + rng.uniform(-0.3, 0.3, model.n), model.limits[:, 0], model.limits[:, 1])


@pytest.mark.parametrize("name,method", CASES)
@given(seed=st.integers(0, 2**32 - 1))
@settings(max_examples=25, deadline=None)
def test_the_answer_is_the_solution_nearest_the_seed(name, method, seed):
    model = robots.load_robot(name)
    ik = solvers.bind(method, model, {"require_limits": True})
    qg, q0 = _warm(model, np.random.default_rng(seed))
    res = ik.solve(fk_htm(model.chain, qg), q0)
    assert res.success and res.within_limits
    np.testing.assert_allclose(fk_htm(model.chain, res.q), fk_htm(model.chain, qg), atol=1e-6)  # checked by FK
    lim, prism = model.limits, model.chain.prismatic
    near = min(travel(s, q0, lim, prism, True) for s in res.solutions)
    assert travel(res.q, q0, lim, prism, False) <= near + 1e-9
    if model.n == 6:  # every solution of a 6R arm is found: the goal's own angles are among them
        assert travel(res.q, q0, lim, prism, False) <= travel(qg, q0, lim, prism, False) + 1e-6


def test_a_narrow_joint_does_not_send_the_elbow_across_its_range():
    """UR3, seed with the elbow at -2.88 rad (limits ±π): the closed forms' first choice by wrapped angles
    had the elbow at +3.13 rad (a 6 rad move); the neighbouring solution is 0.42 rad from the seed."""
    model = robots.load_robot("ur3")
    q0 = np.array([-1.729, -4.853, -2.879, 2.32, -4.415, 5.736])
    goal = fk_htm(model.chain, np.array([-1.568, 1.449, -3.128, 2.091, 1.7, -0.474]))
    for method in ("analytic", "analytic_ur"):
        res = solvers.bind(method, model, {"require_limits": True}).solve(goal, q0)
        assert res.success and travel(res.q, q0, model.limits, model.chain.prismatic, False) < 0.5, (method, res.q)


@pytest.mark.parametrize("name", ["franka_panda", "kinova_gen3", "kuka_iiwa14"])
def test_7r_warm_starts_stay_beside_the_seed(name):
    model = robots.load_robot(name)
    ik = solvers.bind("analytic", model, {"require_limits": True})
    rng = np.random.default_rng(3)
    d = []
    for _ in range(200):
        qg, q0 = _warm(model, rng)
        res = ik.solve(fk_htm(model.chain, qg), q0)
        assert res.success
        d.append(travel(res.q, q0, model.limits, model.chain.prismatic, False))
    # the goal's own angles lie a median 0.45 rad from these seeds; a sweep that jumped along the self-motion
    # (or a continuous joint moved a turn) lay 0.6-4.5 rad away
    assert np.median(d) < 0.5 and np.mean(np.array(d) > 1.5) < 0.05
