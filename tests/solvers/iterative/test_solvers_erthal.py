"""Registered solvers of 001 (Erthal 1992): zero_position, newton_raphson, geometric_iterative,
analytic_puma. Warm starts on the LWR (cm, 7 DoF) and the UR5, a planar arm, random standard and
modified DH chains with prismatic joints and base/tool transforms, unreachable goals (reported,
not raised), one-line refusals, and the zero-position description against the compiled layer."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from tests.conftest import random_transform as _rigid
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import fk_htm
from pipeline.kinematics.chain import Chain
from pipeline.kinematics.zero_position import pz_axes, pz_fk, pz_from_dh
from pipeline.problems import warm_start
from pipeline.robots import RobotModel, load_robot
from pipeline.solvers import NotApplicableError, SettingsError, StopReason, make_settings, prepare, solve
from pipeline.solvers.kernels import kin as _kin
from pipeline.solvers.iterative.zero_position import strategy_weights

ROOT = Path(__file__).resolve().parents[3]
ROBOTS = ROOT / "data" / "robots"
LWR = load_robot(ROBOTS / "kuka_lwr.yaml")
UR5 = load_robot(ROBOTS / "ur5_nepomuceno.yaml")
PUMA = load_robot(ROBOTS / "puma560.yaml")
PLANAR3R = load_robot(ROBOTS / "planar3r.yaml")
FK_TOL = 1e-9         # two exact FK formulations agree to rounding (relative to ~1 m)
WARM_RATE = 0.99      # the registry's warm-start target (0.1 mm / 1e-3 rad)
ZP_WARM_RATE = 0.95   # ZP's measured default rate is ~0.98-0.99: linear convergence of one-joint steps
ITERATIVE = ("zero_position", "newton_raphson", "geometric_iterative")




def random_robot(seed: int) -> RobotModel:
    """6-joint chain, standard or modified DH, one prismatic joint on odd seeds, base and tool, in m."""
    rng = np.random.default_rng(seed)
    n = 6
    prism = np.zeros(n, bool)
    if seed % 2:
        prism[rng.integers(0, n)] = True
    chain = Chain(rng.uniform(-0.3, 0.3, n), rng.uniform(-math.pi, math.pi, n), rng.uniform(-0.3, 0.3, n),
                  rng.uniform(-math.pi, math.pi, n), prism, ("standard", "modified")[seed % 3 == 0],
                  _rigid(rng, 0.5), _rigid(rng, 0.1))
    return RobotModel(f"random{seed}", "test", "m", chain, np.full((n, 2), [-np.inf, np.inf]))


def _rate(method, model, count, seed, s=None):
    ps = warm_start(model, count, np.random.default_rng(seed))
    st_ = make_settings(method, s or {})
    prep = prepare(method, model, st_)
    T = ps.goal_transforms()
    res = [solve(method, prep, T[k], ps.q_start[k], st_) for k in range(count)]
    return float(np.mean([r.success for r in res])), res


# --- warm starts on the LWR (cm, redundant) and the UR5 -----------------------------------------

@pytest.mark.parametrize("model", [LWR, UR5], ids=["kuka_lwr", "ur5"])
def test_newton_raphson_defaults_solve_warm_starts(model):
    rate, res = _rate("newton_raphson", model, 200, 11)
    assert rate >= WARM_RATE
    assert all(r.stop_reason in (1, 2, 4) for r in res)


@pytest.mark.parametrize("model", [LWR, UR5], ids=["kuka_lwr", "ur5"])
def test_zero_position_defaults_solve_most_warm_starts(model):
    rate, res = _rate("zero_position", model, 60, 12)
    assert rate >= ZP_WARM_RATE
    assert all(r.stop_reason in (1, 4) for r in res)


@pytest.mark.parametrize("model", [LWR, UR5], ids=["kuka_lwr", "ur5"])
def test_geometric_solves_position_warm_starts(model):
    rate, res = _rate("geometric_iterative", model, 100, 13)
    assert rate >= WARM_RATE
    assert all(math.isnan(r.orientation_error) for r in res)  # position-only criterion


def test_lwr_results_in_file_unit():
    ps = warm_start(LWR, 1, np.random.default_rng(3))
    r = solve("newton_raphson", LWR, ps.goal_transforms()[0], ps.q_start[0])
    assert r.success and r.length_unit == "m"
    T = fk_htm(LWR.chain, r.q)  # q in the file's unit; FK in cm
    assert np.linalg.norm(T[:3, 3] - ps.goal_position[0]) <= 1e-2  # 0.1 mm in cm


# --- any DH chain ---------------------------------------------------------------------------------

@pytest.mark.parametrize("method", ["zero_position", "newton_raphson"])
@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_full_pose_methods_on_random_chains(method, seed):
    """Standard/modified DH, prismatic joint, base and tool: a goal 0.1 rad away is solved."""
    model = random_robot(seed)
    rng = np.random.default_rng(seed)
    q_goal = rng.uniform(-2, 2, 6)
    q0 = q_goal + rng.uniform(-0.1, 0.1, 6)
    r = solve(method, model, fk_htm(model.chain, q_goal), q0)
    if r.success:
        assert r.position_error <= 1e-4 and r.orientation_error <= 1e-3
    else:  # a random chain may be singular at the goal; failure must be a reported stop, never a raise
        assert r.stop_reason in (StopReason.STALLED, StopReason.ITERATION_CAP)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_geometric_on_random_chains_never_increases_distance(seed):
    model = random_robot(seed)
    rng = np.random.default_rng(seed)
    q0 = rng.uniform(-2, 2, 6)
    T = fk_htm(model.chain, rng.uniform(-2, 2, 6))
    r = solve("geometric_iterative", model, T, q0, {"max_iterations": 50})
    d = r.trace[:, 0]
    assert np.all(np.diff(d) <= 1e-12 * (1 + d[:-1]))  # each joint step is an exact minimiser of |dp|


def test_planar_arm_geometric_zero_position_and_nr():
    """Planar 3R (mm), position-only goal inside the reach: every iterative method converges."""
    T = np.eye(4)
    T[:3, 3] = [294.0, 382.0, 0.0]  # Table 6.15 point 3
    q0 = np.radians([90.0, -90.0, 90.0])
    for method in ITERATIVE:
        r = solve(method, PLANAR3R, T, q0, {"criterion": "position", "tol_pos": 1e-6})
        assert r.success, method
        assert np.linalg.norm(fk_htm(PLANAR3R.chain, r.q)[:3, 3] - T[:3, 3]) <= 1e-3


def test_planar_geometric_matches_the_document_reading():
    """On a planar arm the generalised step is the document's "point the joint-effector line at the goal"."""
    T = np.eye(4)
    T[:3, 3] = [6.0, 482.0, 0.0]
    q0 = np.radians([90.0, -90.0, 90.0])
    r = solve("geometric_iterative", PLANAR3R, T, q0, {"max_iterations": 1, "tol_pos": 1e-9})
    # one sweep by hand, tip to base, in the plane
    q = q0.copy()
    from pipeline.kinematics import fk_frames

    for i in (2, 1, 0):
        F = fk_frames(PLANAR3R.chain, q)
        o, p = F[i][:2, 3], F[-1][:2, 3]
        v1, v2 = p - o, T[:2, 3] - o
        q[i] += math.atan2(v1[0] * v2[1] - v1[1] * v2[0], v1 @ v2)
    np.testing.assert_allclose(r.q, q, atol=1e-9)


def test_nr_least_squares_step_on_fewer_joints_than_six():
    """Planar 3R with a full-pose goal: J is 6 x 3; NR takes the least-squares step, reports, does not raise."""
    T = fk_htm(PLANAR3R.chain, np.array([0.3, -0.4, 0.2]))
    r = solve("newton_raphson", PLANAR3R, T, np.array([0.4, -0.3, 0.1]))
    assert r.success


# --- unreachable goals are reported, not raised ---------------------------------------------------

@pytest.mark.parametrize("method, settings_, codes", [
    ("zero_position", {"max_iterations": 50}, {StopReason.ITERATION_CAP}),
    ("newton_raphson", {}, {StopReason.STALLED, StopReason.ITERATION_CAP}),
    ("geometric_iterative", {"max_iterations": 50}, {StopReason.ITERATION_CAP}),
])
@pytest.mark.parametrize("model", [LWR, UR5, PLANAR3R], ids=["kuka_lwr", "ur5", "planar3r"])
def test_unreachable_goal_is_reported(method, settings_, codes, model):
    T = np.eye(4)
    T[:3, 3] = [1e4, 0, 0]  # far beyond every arm's reach (in the file's unit)
    r = solve(method, model, T, np.zeros(model.n), settings_)
    assert not r.success and r.stop_reason in codes
    assert np.all(np.isfinite(r.q))


def test_analytic_puma_unreachable_is_no_solution():
    T = np.eye(4)
    T[:3, 3] = [5000.0, 0, 0]
    r = solve("analytic_puma", PUMA, T, np.zeros(6))
    assert not r.success and r.stop_reason == StopReason.NO_SOLUTION
    assert np.all(r.q == 0) and r.info["solutions_found"] == 0


# --- refusals are one line ------------------------------------------------------------------------

@pytest.mark.parametrize("model", [LWR, UR5, load_robot(ROBOTS / "stanford.yaml"), PLANAR3R],
                         ids=["kuka_lwr", "ur5", "stanford", "planar3r"])
def test_analytic_puma_refuses_other_geometries_in_one_line(model):
    with pytest.raises(NotApplicableError) as exc:
        solve("analytic_puma", model, np.eye(4), np.zeros(model.n))
    msg = str(exc.value)
    assert "\n" not in msg and "analytic_puma" in msg and "does not apply" in msg


def test_settings_errors_are_one_line():
    for method, bad, field in (("geometric_iterative", {"criterion": "pos_orient"}, "criterion"),
                               ("zero_position", {"strategy": 11}, "strategy"),
                               ("newton_raphson", {"step_halvings": -1}, "step_halvings")):
        with pytest.raises(SettingsError) as exc:
            make_settings(method, bad)
        assert "\n" not in str(exc.value) and f"field '{field}'" in str(exc.value)
    with pytest.raises(SettingsError, match="field 'strategy'"):
        strategy_weights(0, np.zeros(3, bool))


# --- analytic PUMA --------------------------------------------------------------------------------

def puma_family(seed: int) -> RobotModel:
    """PUMA-type arm: alpha signs, a1, d1, d3, last link, offsets, base/tool, in mm."""
    rng = np.random.default_rng(seed)
    s = rng.choice([-1.0, 1.0], 4)
    alpha = [s[0] * math.pi / 2, 0.0, s[1] * math.pi / 2, s[2] * math.pi / 2, s[3] * math.pi / 2,
             rng.uniform(-3, 3) if seed % 2 else 0.0]
    a = [rng.uniform(-100, 100), rng.uniform(200, 500), rng.uniform(-100, 100), 0.0, 0.0,
         rng.uniform(-50, 50) if seed % 3 else 0.0]
    d = [rng.uniform(-300, 300), rng.uniform(-200, 200), rng.uniform(-100, 100), rng.uniform(100, 500), 0.0,
         rng.uniform(0, 100)]
    chain = Chain(a, alpha, d, rng.uniform(-math.pi, math.pi, 6) if seed % 2 else np.zeros(6), np.zeros(6, bool),
                  "standard", _rigid(rng, 500.0), _rigid(rng, 100.0))
    return RobotModel(f"puma_family{seed}", "test", "mm", chain, np.full((6, 2), [-np.inf, np.inf]))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 100_000), q=st.lists(st.floats(-math.pi, math.pi), min_size=6, max_size=6))
def test_analytic_puma_family_round_trip(seed, q):
    model = puma_family(seed)
    q = np.array(q)
    T = fk_htm(model.chain, q)
    r = solve("analytic_puma", model, T, q, {"tol_pos": 1e-8, "tol_rot": 1e-7})
    assert r.success and r.solutions.shape[1] == 6
    assert r.info["solutions_valid"] == r.info["solutions_found"] >= 1
    wrapped = np.angle(np.exp(1j * (r.solutions - q)))
    sing = abs(math.sin(q[4] + model.chain.theta_offset[4])) < 1e-6
    if not sing:  # away from the wrist degeneracy the true angles are one of the solutions
        assert np.abs(wrapped).max(axis=1).min() < 1e-6
    for sol in r.solutions:
        np.testing.assert_allclose(fk_htm(model.chain, sol), T, atol=1e-6)


def test_analytic_puma_eight_solutions_on_the_puma560():
    rng = np.random.default_rng(5)
    for _ in range(20):
        q = rng.uniform(-math.pi, math.pi, 6)
        r = solve("analytic_puma", PUMA, fk_htm(PUMA.chain, q), q)
        assert r.success and len(r.solutions) == 8 and r.info["distinct_branches"] == 8
        np.testing.assert_allclose(np.angle(np.exp(1j * (r.q - q))), 0, atol=1e-6)  # nearest = the true one


# --- zero-position description = what the compiled layer gives the ZP step -------------------------

@pytest.mark.parametrize("name", ["scara", "stanford", "puma560", "artropoidal", "planar3r", "elbow", "kuka_lwr",
                                  "ur5_nepomuceno", "cartesiano"])
@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_pz_description_equals_compiled_axes(name, seed):
    model = load_robot(ROBOTS / f"{name}.yaml")
    rng = np.random.default_rng(seed)
    model = replace(model, chain=replace(model.chain, base=_rigid(rng, 100.0), tool=_rigid(rng, 10.0)))
    q0, q = rng.uniform(-1, 1, model.n), rng.uniform(-1.5, 1.5, model.n)
    pz = pz_from_dh(model.chain, q0)
    c = model.chain
    axes, origins, T = np.empty((model.n, 3)), np.empty((model.n, 3)), np.empty((4, 4))
    _kin.forward(np.asarray(c.a, float), np.asarray(c.alpha, float), np.asarray(c.d, float),
                 np.asarray(c.theta_offset, float), np.asarray(c.prismatic), bool(c.modified), np.asarray(c.base, float),
                 np.asarray(c.tool, float), q, axes, origins, T)
    scale = 1 + np.abs(T[:3, 3]).max()
    np.testing.assert_allclose(pz_fk(pz, q), T, atol=FK_TOL * scale)
    u, o = pz_axes(pz, q)
    np.testing.assert_allclose(u, axes, atol=FK_TOL)
    # the points may differ along the axis: compare the axis lines
    for k in range(model.n):
        diff = o[k] - origins[k]
        np.testing.assert_allclose(diff - (diff @ axes[k]) * axes[k], 0, atol=FK_TOL * scale)


def test_modified_dh_chain_pz_round_trip():
    model = random_robot(3)  # seed % 3 == 0: modified DH
    assert model.chain.modified
    q = np.random.default_rng(0).uniform(-1, 1, 6)
    pz = pz_from_dh(model.chain, np.zeros(6))
    np.testing.assert_allclose(pz_fk(pz, q), fk_htm(model.chain, q), atol=FK_TOL)


def test_zp_document_stop_test_is_unit_free_with_length_scale():
    """delta_sum with L = 1 mm: the same solve whether the method computes in mm or in m."""
    T = fk_htm(PUMA.chain, np.radians([80, -50, 170, 10, -40, 80]))
    q0 = np.radians([90, -60, 180, 0, -30, 90])
    s = {"strategy": 5, "stop_test": "delta_sum", "epsilon": 1e-4, "length_unit": "mm", "length_scale": 0.001,
         "tol_pos": 1e-5, "tol_rot": 0.01, "max_iterations": 1000}
    a = solve("zero_position", PUMA, T, q0, s)
    b = solve("zero_position", PUMA, T, q0, {**s, "length_unit": "m"})
    assert a.success and b.success and a.trace[a.iterations, 0] < 1e-4
    assert a.iterations == b.iterations
    np.testing.assert_allclose(a.q, b.q, atol=1e-9)
