"""Registered solver ``analytic_4dof`` (closed form of the 4-DOF arm of 003): round trips on the
document's arm and on random members of the family (standard/modified DH, alpha1 = +-pi/2, joint
offsets, lateral offsets, base/tool, other length units), refusals, unreachable goals."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from tests.conftest import random_transform as _rigid
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import fk_htm
from pipeline.kinematics.chain import Chain
from pipeline.robots import RobotModel, load_robot
from pipeline.solvers import NotApplicableError, StopReason, solve
from pipeline.solvers.core import Prepared, pose_errors

ROOT = Path(__file__).resolve().parents[3]
ARM = load_robot(ROOT / "data/robots/mariano_4dof.yaml")
POS_TOL = 1e-9   # relative to the arm's reach: closed form in double precision
ROT_TOL = 1e-7   # rad; near-stretched arms lose ~sqrt(eps) in theta3 (beta close to 1)
angles = st.floats(-math.pi, math.pi, allow_nan=False)




def family_member(seed: int) -> RobotModel:
    """A random robot of the family: standard or modified DH, alpha1 = +-pi/2, offsets, base/tool."""
    rng = np.random.default_rng(seed)
    s = rng.choice([-1.0, 1.0])
    d1, a1, a2, a3, a4 = rng.uniform(0.05, 0.5, 5) * rng.choice([-1.0, 1.0], 5)
    lateral = rng.uniform(-0.1, 0.1, 3) if seed % 3 else np.zeros(3)
    off = rng.uniform(-math.pi, math.pi, 4) if seed % 2 else np.zeros(4)
    base = _rigid(rng, 0.5) if seed % 4 else np.eye(4)
    tool = _rigid(rng, 0.2) if seed % 5 else np.eye(4)
    if seed % 2:   # modified DH: alpha_0, a_0 a fixed pre-transform; the last length goes into the tool
        a0, al0 = rng.uniform(-0.3, 0.3), rng.uniform(-math.pi, math.pi)
        tx = np.eye(4)
        tx[0, 3] = a4
        chain = Chain([a0, a1, a2, a3], [al0, s * math.pi / 2, 0, 0], [d1, *lateral], off, [False] * 4, "modified",
                      base, tx @ tool)
    else:
        chain = Chain([a1, a2, a3, a4], [s * math.pi / 2, 0, 0, 0], [d1, *lateral], off, [False] * 4, "standard",
                      base, tool)
    unit = ("m", "cm", "mm")[seed % 3]
    f = {"m": 1.0, "cm": 100.0, "mm": 1000.0}[unit]
    lim = np.tile([-math.pi, math.pi], (4, 1))
    return RobotModel(f"family_{seed}", "test", unit, chain.scaled(f), lim)


def _reach(model: RobotModel) -> float:
    c = model.chain
    return float(np.sum(np.abs(c.a)) + np.sum(np.abs(c.d)) + np.abs(c.tool[:3, 3]).sum()) or 1.0


def _check_roundtrip(model: RobotModel, q: np.ndarray, q_start: np.ndarray):
    T = fk_htm(model.chain, q)
    r = solve("analytic_4dof", model, T, q_start)
    assert r.success and r.stop_reason == StopReason.SUCCESS
    assert 1 <= len(r.solutions) <= 2   # full 6-D goal: theta1 and the pitch fixed, two elbows
    prep = Prepared(model, model.length_unit)
    for sol in r.solutions:   # every returned solution reaches the goal (independent numpy FK)
        dp, ang, _ = pose_errors(prep.model, T, sol)
        assert dp <= POS_TOL * _reach(model) and ang <= ROT_TOL
    # the generating angles are among the solutions (mod 2 pi)
    diff = np.abs(np.angle(np.exp(1j * (r.solutions - q))))
    assert np.min(np.max(diff, axis=1)) < 1e-6
    # the chosen one is the nearest the start
    dist = np.sum((r.solutions - q_start) ** 2, axis=1)
    assert np.allclose(r.q, r.solutions[np.argmin(dist)])
    assert np.all(np.abs(r.q - q_start) <= math.pi + 1e-12)
    return r


@settings(max_examples=200, deadline=None)
@given(st.tuples(angles, angles, angles, angles))
def test_roundtrip_document_arm(q):
    q = np.array(q)
    _check_roundtrip(ARM, q, q + 0.2)


@pytest.mark.parametrize("seed", range(24))
def test_roundtrip_family_members(seed):
    model = family_member(seed)
    rng = np.random.default_rng(100 + seed)
    for q in rng.uniform(-math.pi, math.pi, size=(40, 4)):
        _check_roundtrip(model, q, q + rng.uniform(-0.5, 0.5, 4))


def test_start_on_a_solution_returns_it():
    q = np.array([0.4, 1.0, -1.2, 0.3])
    T = fk_htm(ARM.chain, q)
    r = solve("analytic_4dof", ARM, T, q)
    assert np.allclose(r.q, q, atol=1e-9)
    other = r.solutions[np.argmax(np.sum((r.solutions - q) ** 2, axis=1))]
    r2 = solve("analytic_4dof", ARM, T, other)
    assert np.allclose(r2.q, other, atol=1e-12)


def test_start_far_away_gives_angles_near_it():
    q = np.array([0.4, 1.0, -1.2, 0.3])
    r = solve("analytic_4dof", ARM, fk_htm(ARM.chain, q), q + 4 * math.pi)
    assert r.success and np.allclose(r.q, q + 4 * math.pi, atol=1e-9)


@pytest.mark.parametrize("robot", ["kuka_lwr", "ur5_nepomuceno", "scara", "puma560"])
def test_refuses_other_geometries(robot):
    model = load_robot(ROOT / "data/robots" / f"{robot}.yaml")
    with pytest.raises(NotApplicableError, match="analytic_4dof' does not apply: needs") as e:
        solve("analytic_4dof", model, np.eye(4), np.zeros(model.n))
    assert "\n" not in str(e.value)


def test_refuses_wrong_alphas_and_zero_links():
    c = ARM.chain
    bad_alpha = RobotModel("x", "t", "cm", Chain(c.a, [math.pi / 2, 0.1, 0, 0], c.d, c.theta_offset, c.prismatic),
                           ARM.limits)
    with pytest.raises(NotApplicableError, match="alpha"):
        solve("analytic_4dof", bad_alpha, np.eye(4), np.zeros(4))
    zero_link = RobotModel("x", "t", "cm", Chain([1.5, 12.0, 0.0, 7.0], c.alpha, c.d, c.theta_offset, c.prismatic),
                           ARM.limits)
    with pytest.raises(NotApplicableError, match="non-zero lengths"):
        solve("analytic_4dof", zero_link, np.eye(4), np.zeros(4))


def test_unreachable_position_is_no_solution():
    T = fk_htm(ARM.chain, np.zeros(4))
    T[:3, 3] = [100.0, 0.0, 8.0]   # beyond the 30.5 cm reach
    q0 = np.array([0.1, 0.2, -0.3, 0.4])
    r = solve("analytic_4dof", ARM, T, q0)
    assert not r.success and r.stop_reason == StopReason.NO_SOLUTION
    assert np.array_equal(r.q, q0) and r.solutions.shape == (0, 4)


@pytest.mark.parametrize("seed", range(10))
def test_orientation_the_arm_cannot_take_is_no_solution(seed):
    rng = np.random.default_rng(seed)
    q = rng.uniform(-math.pi, math.pi, 4)
    T = fk_htm(ARM.chain, q)
    tilt = np.eye(4)
    tilt[:3, :3] = _rigid(rng, 0.0)[:3, :3]
    T[:3, :3] = tilt[:3, :3] @ T[:3, :3]   # same position, a random orientation
    if abs(T[2, 2]) < 1e-3:                 # tool z still horizontal: skip the rare achievable draw
        return
    r = solve("analytic_4dof", ARM, T, q)
    assert r.stop_reason == StopReason.NO_SOLUTION and np.all(np.isfinite(r.q))


def test_non_finite_goal_is_no_solution():
    T = np.full((4, 4), np.nan)
    r = solve("analytic_4dof", ARM, T, np.zeros(4))
    assert r.stop_reason == StopReason.NO_SOLUTION and np.all(np.isfinite(r.q))


def test_position_only_adds_the_back_branch():
    q = np.array([0.7, 0.9, -1.1, 0.2])
    T = fk_htm(ARM.chain, q)
    r = solve("analytic_4dof", ARM, T, q, {"criterion": "position"})
    assert r.success and np.isnan(r.orientation_error)
    assert len(r.solutions) >= 2
    Tp = fk_htm(ARM.chain, r.solutions)
    assert np.allclose(Tp[:, :3, 3], T[:3, 3], atol=1e-9)
    assert np.any(np.abs(np.angle(np.exp(1j * (r.solutions[:, 0] - q[0])))) > 3.0)   # theta1 + pi: behind the base


def test_document_units_and_settings_checked():
    from pipeline.solvers import SettingsError

    q = np.array([0.2, 0.8, -0.9, 0.4])
    T = fk_htm(ARM.chain, q)
    r = solve("analytic_4dof", ARM, T, q, {"length_unit": "mm", "tol_pos": 1e-6})
    assert r.success and r.length_unit == "mm"
    with pytest.raises(SettingsError, match="reach_tol"):
        solve("analytic_4dof", ARM, T, q, {"reach_tol": -1.0})


def test_elbow_setting_keeps_one_branch():
    q = np.array([0.3, 0.7, -1.0, 0.5])   # sin(theta3) < 0
    T = fk_htm(ARM.chain, q)
    pos = solve("analytic_4dof", ARM, T, q, {"elbow": "positive"})
    neg = solve("analytic_4dof", ARM, T, q, {"elbow": "negative"})
    assert pos.success and neg.success and len(pos.solutions) == len(neg.solutions) == 1
    assert math.sin(pos.q[2]) > 0 and np.allclose(neg.q, q, atol=1e-9)
    both = solve("analytic_4dof", ARM, T, q)
    assert len(both.solutions) == 2


@pytest.mark.parametrize("criterion", ["pos_orient", "position", "dq_norm", "dq_norm_body"])
@pytest.mark.parametrize("seed", [0, 1, 5, 7])
def test_every_criterion_on_family_members(criterion, seed):
    model = family_member(seed)
    rng = np.random.default_rng(7 + seed)
    prep = Prepared(model, model.length_unit)
    for q in rng.uniform(-math.pi, math.pi, size=(20, 4)):
        T = fk_htm(model.chain, q)
        r = solve("analytic_4dof", model, T, q, {"criterion": criterion})
        assert r.success, (criterion, seed, q)
        for sol in r.solutions:
            dp, ang, _ = pose_errors(prep.model, T, sol)
            assert dp <= POS_TOL * _reach(model)
            if criterion in ("pos_orient", "dq_norm"):
                assert ang <= ROT_TOL


def test_modified_dh_refusal_names_the_convention():
    c = family_member(1).chain   # modified DH member
    bad = RobotModel("x", "t", "m", Chain(c.a, [c.alpha[0], 0.3, 0, 0], c.d, c.theta_offset, c.prismatic, "modified"),
                     np.tile([-math.pi, math.pi], (4, 1)))
    with pytest.raises(NotApplicableError, match="modified DH"):
        solve("analytic_4dof", bad, np.eye(4), np.zeros(4))
