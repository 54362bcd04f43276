"""A 6R arm whose axes 1-3 and 4-6 each meet in a point: every goal a continuum (representatives, said so)
or unreachable (a reported failure). The KUKA iiwa with its elbow held is one; random such arms another."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pipeline.kinematics import geometry
from pipeline.kinematics.folding import lines_chain
from pipeline.kinematics.htm import fk_htm
from pipeline.robots import load_robot
from pipeline.solvers import make_settings, solve
from pipeline.solvers.closed_form.continuum import FAMILY
from pipeline.solvers.core import Prepared
from tests.solvers.closed_form.family_arms import arm_from_lines, gap

ROOT = Path(__file__).resolve().parents[3]
ELBOW = -1.606  # [rad] the iiwa's joint 4, held


@pytest.fixture(scope="module")
def iiwa():
    return load_robot(ROOT / "data" / "robots" / "kuka_iiwa14.yaml")


def _random_pair_arm(rng):
    """A random 6R arm: axes 1-3 through one point, axes 4-6 through another."""
    h = rng.normal(size=(6, 3))
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    S, W = rng.normal(size=3) * 0.1, rng.normal(size=3) * 0.5
    p = np.array([S, S, S, W, W, W]) + h * rng.uniform(-0.2, 0.2, (6, 1))  # any point of each line
    return arm_from_lines(h, p, W + rng.normal(size=3) * 0.1, rng, "spherical pair")


def _check(model, T, r, tol=1e-6):
    assert r.success and r.info["continuum"] and r.info["family"].startswith(FAMILY)
    assert "continuum" in r.info["message"]
    for q in [r.q, *r.solutions]:
        Tq = fk_htm(model.chain, q)
        assert np.linalg.norm(Tq[:3, 3] - T[:3, 3]) < tol and np.abs(Tq[:3, :3] - T[:3, :3]).max() < tol


def test_iiwa_elbow_held_is_a_continuum(iiwa):
    held = lines_chain(geometry.fix_joint(geometry.joint_lines(iiwa.chain), 3, ELBOW))
    assert geometry.classify(held).family == FAMILY
    assert geometry.classify(iiwa.chain).family != FAMILY  # the 7R sweep frees another joint
    prep = Prepared(iiwa)
    s = make_settings("analytic", {"fixed_joints": {4: ELBOW}})
    rng = np.random.default_rng(7)
    lo, hi = prep.limits[:, 0], prep.limits[:, 1]
    for _ in range(20):
        q = rng.uniform(lo, hi)
        q[3] = ELBOW
        T = fk_htm(iiwa.chain, q)
        q0 = rng.uniform(lo, hi)
        q0[3] = ELBOW
        r = solve("analytic", prep, T, q0, s)
        _check(iiwa, T, r)
        assert r.q[3] == ELBOW and len(r.solutions) >= 8
        # the chosen one is the nearest the start among those returned (within the limits first)
        inside = [x for x in r.solutions if np.all((x >= lo - 1e-6) & (x <= hi + 1e-6))]
        if inside:
            assert np.sum((r.q - q0) ** 2) <= min(np.sum((x - q0) ** 2) for x in inside) + 1e-9
        # started at the generating vector, the answer is that vector
        assert gap([solve("analytic", prep, T, q, s).q], q) < 1e-6


def test_random_spherical_pair_arms():
    rng = np.random.default_rng(11)
    for _ in range(5):
        m = _random_pair_arm(rng)
        assert geometry.classify(m.chain).family == FAMILY
        prep = Prepared(m)
        s = make_settings("analytic", {})
        for _ in range(4):
            q = rng.uniform(-math.pi, math.pi, 6)
            T = fk_htm(m.chain, q)
            r = solve("analytic", prep, T, rng.uniform(-math.pi, math.pi, 6), s)
            _check(m, T, r)
            assert gap([solve("analytic", prep, T, q, s).q], q) < 1e-6


def test_off_the_sphere_is_a_reported_failure(iiwa):
    prep = Prepared(iiwa)
    s = make_settings("analytic", {"fixed_joints": {4: ELBOW}})
    q = np.zeros(7)
    q[3] = ELBOW
    T = fk_htm(iiwa.chain, q)
    T[:3, 3] *= 1.2
    r = solve("analytic", prep, T, q, s)
    assert not r.success and "off the sphere" in r.info["message"] and np.all(np.isfinite(r.q))
