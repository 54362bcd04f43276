"""nepomuceno2024 (004_957b32c2b06ea31d.txt): robots, the study's registered solvers and their
document constants, closed-form UR IK on the study's robots, motions. The solvers themselves are
tested in tests/solvers/iterative/test_solvers_optimizers.py."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import fk_htm
from pipeline.robots import load_robot
from pipeline.settings import load_study
from pipeline.solvers import NotApplicableError, prepare, solve
from pipeline.solvers.iterative.optimizers import parse_bounds
from pipeline.studies.nepomuceno2024.problems import set_motion
from pipeline.studies.nepomuceno2024.trajectory import (
    build_motion, interpolate, load_motions, pose_from_spec, segment_count)

ROOT = Path(__file__).resolve().parents[2]
ROBOTS = ["ur5_nepomuceno", "ur5e"]
STUDY_DOC = load_study(ROOT / "data/studies/nepomuceno2024.yaml")
STUDY = STUDY_DOC.settings

SANITY_TOL = 5e-6       # notes §3 sanity values are printed to 5-6 decimals
IK_VERIFY = 1e-9        # closed-form solutions are exact up to rounding
ROUND_TOL = 1e-6        # start_joints are rounded to 1e-6 rad; the pose moves by < 1e-6 m per joint
AWAY = 1e-3            # |sin θ| above this = away from the wrist (θ5) / elbow (θ3) singularity
BOUND_SLACK = 1e-9      # tool-down poses put θ5 exactly on the L-BFGS-B bound π/2


def _model(name):
    return load_robot(ROOT / "data/robots" / f"{name}.yaml")


def _solver(method):
    """(registered name, settings) of a solver label of the study."""
    e = STUDY_DOC.solvers[method]
    return e.method, e.settings


# robots ----------------------------------------------------------------------------------------

def test_ur5_sanity_values_of_the_notes():
    m = _model("ur5_nepomuceno")
    T0 = fk_htm(m.chain, np.zeros(6))
    assert np.allclose(T0[:3, 3], [-0.81725, -0.36225, -0.00549], atol=SANITY_TOL)
    assert np.allclose(T0[:3, :3], [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-12)
    T = fk_htm(m.chain, np.array([0.1, -1.2, 1.5, -1.9, -1.57, 0.3]))
    assert np.allclose(T[:3, 3], [-0.61666, -0.17177, 0.11913], atol=SANITY_TOL)


def test_robot_files_cite_sources_and_values():
    ur5, ur5e = _model("ur5_nepomuceno"), _model("ur5e")
    assert "Apêndice A" in ur5.source and "FAQ 45257" in ur5e.source
    assert ur5.chain.d[5] == pytest.approx(0.0903 + 0.1628)
    assert np.allclose(ur5e.chain.d, [0.1625, 0, 0, 0.1333, 0.0997, 0.0996])
    assert np.allclose(ur5e.chain.a, [0, -0.425, -0.3922, 0, 0, 0])
    rtb = load_robot(ROOT / "data/nepomuceno2024/ur5_rtb_jacobian.yaml")  # the listing's Jacobian model
    assert np.allclose(rtb.chain.d, [0.089459, 0, 0, 0.10915, 0.09465, 0.0823])
    assert np.array_equal(rtb.chain.a, ur5.chain.a) and np.array_equal(rtb.chain.alpha, ur5.chain.alpha)


# the study's settings ---------------------------------------------------------------------------

def test_every_method_is_a_registered_solver_with_the_documents_constants():
    names = {m: _solver(m)[0] for m in STUDY_DOC.solvers}
    assert names == {"pinv": "jpinv_descent", "bfgs": "bfgs", "lbfgsb": "lbfgsb", "nelder_mead": "nelder_mead",
                     "analytic": "analytic_ur", "pinv_rtb_jacobian": "jpinv_descent", "bfgs_squared_cost": "bfgs"}
    assert set(STUDY["methods"]) == set(STUDY_DOC.solvers)  # every label has its table name
    for m in STUDY_DOC.solvers:
        s = _solver(m)[1]
        assert (s.tol_pos, s.tol_rot) == (0.001, 0.01)  # the study's success test (1 mm, 0.01 rad)
    p = _solver("pinv")[1]
    assert (p.rate, p.tolerance, p.max_iterations, p.damping, p.halvings, p.stop_at_tolerance) == (0.05, 1e-6, 5000, 0, 0, False)
    b = _solver("bfgs")[1]
    assert (b.position_weight, b.rotation_weight, b.squared, b.gradient, b.gtol) == (1.0, 1.0, False, "2-point", 1e-6)
    lb = _solver("lbfgsb")[1]
    assert (lb.rotation_weight, lb.ftol, lb.gtol, lb.max_iterations) == (0.1, 1e-6, 0.0, 5000)
    box = [(-np.pi, np.pi), (-np.pi / 2, np.pi / 2), (-np.pi / 2, np.pi / 2), (-np.pi, np.pi), (-np.pi / 2, np.pi / 2),
           (-np.pi, np.pi)]
    assert parse_bounds(lb.bounds) == box  # Apêndice C, bit-exact
    nm = _solver("nelder_mead")[1]
    assert (nm.xatol, nm.fatol, nm.adaptive, nm.max_iterations, nm.simplex_step) == (1e-4, 1e-4, False, 1200, 0.0)


def test_study_descent_with_the_listings_jacobian_model_resolves_its_robot_file():
    name, s = _solver("pinv_rtb_jacobian")
    assert (ROOT / s.jacobian_robot).is_file()
    m = _model("ur5_nepomuceno")
    q_goal = np.array([0.1, -1.0, 1.0, 1.5, 1.5, 0.3])
    r = solve(name, m, fk_htm(m.chain, q_goal), q_goal + 0.01, s)
    assert r.success and r.stop_reason == 1


# closed-form UR IK on the study's robots ---------------------------------------------------------

def _ring_pose(r, phi, z, yaw, tilt):
    """A TCP pose in the pick-and-place workspace: tool roughly pointing down."""
    T = pose_from_spec({"position": [r * math.cos(phi), r * math.sin(phi), z], "yaw_deg": math.degrees(yaw)})
    c, s = math.cos(tilt), math.sin(tilt)
    T[:3, :3] = T[:3, :3] @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    return T


@pytest.mark.parametrize("robot", ROBOTS)
@settings(max_examples=40, deadline=None)
@given(r=st.floats(0.40, 0.55), phi=st.floats(-math.pi, math.pi), z=st.floats(0.0, 0.25),
       yaw=st.floats(-math.pi, math.pi), tilt=st.floats(-0.3, 0.3))
def test_closed_form_returns_8_fk_verified_solutions(robot, r, phi, z, yaw, tilt):
    m = _model(robot)
    T = _ring_pose(r, phi, z, yaw, tilt)
    res = solve("analytic_ur", m, T, np.zeros(6), _solver("analytic")[1])
    Q = res.solutions
    assert res.success and Q.shape == (8, 6) and res.info["n_solutions"] == 8
    for q in Q:  # independent check: numpy FK of every returned solution
        Tq = fk_htm(m.chain, q)
        assert np.linalg.norm(Tq[:3, 3] - T[:3, 3]) < 10 * IK_VERIFY
        assert np.linalg.norm(Tq[:3, :3] - T[:3, :3]) < 10 * IK_VERIFY
    assert len({tuple(np.round(q, 6)) for q in Q}) == 8  # eight distinct configurations


@pytest.mark.parametrize("robot", ROBOTS)
@pytest.mark.parametrize("q5", [0.0, math.pi, -math.pi, 1e-13])
def test_wrist_singularity_gives_finite_fk_verified_solutions(robot, q5):
    m = _model(robot)
    q = np.array([0.4, -1.1, 1.2, 0.5, q5, 0.9])
    T = fk_htm(m.chain, q)
    r = solve("analytic_ur", m, T, q, _solver("analytic")[1])
    Q = r.solutions
    assert np.all(np.isfinite(Q)) and len(Q) >= 4
    assert np.sum(np.abs(np.sin(Q[:, 4])) < AWAY) >= 2  # the singular branches are kept
    for qs in Q:
        Tq = fk_htm(m.chain, qs)
        assert np.linalg.norm(Tq[:3, 3] - T[:3, 3]) < 10 * IK_VERIFY
        if abs(math.sin(qs[4])) < AWAY:  # this branch is singular (the other shoulder branch is not)
            assert qs[5] == pytest.approx(0.9)  # θ6 taken from the start, θ4 absorbs the rest
    # the chosen solution is finite and next to the previous angles
    assert r.success and np.all(np.isfinite(r.q)) and np.abs(r.q - q).max() < 1e-6


def test_closed_form_refuses_non_ur_robots():
    s = _solver("analytic")[1]
    with pytest.raises(NotApplicableError, match="not a UR-type"):
        prepare("analytic_ur", load_robot(ROOT / "data/robots/kuka_lwr.yaml"), s)


# methods ---------------------------------------------------------------------------------------

TABLE_METHODS = ["pinv", "bfgs", "lbfgsb", "nelder_mead", "analytic"]


@pytest.mark.parametrize("method", TABLE_METHODS)
def test_each_method_solves_a_nearby_point(method):
    m = _model("ur5_nepomuceno")
    name, s = _solver(method)
    q_goal = np.array([0.43, -0.75, 0.95, 1.37, 1.5707963267948966, 1.48])
    T = fk_htm(m.chain, q_goal)
    q0 = q_goal + np.array([0.01, -0.01, 0.01, 0.0, 0.0, 0.01])
    r = solve(name, m, T, q0, s)
    assert r.success and r.stop_reason == 1
    assert r.position_error < s.tol_pos and r.orientation_error < s.tol_rot
    assert r.info["nfev"] > 0 and r.trace.shape[1] == 8 and np.isfinite(r.info["doc_error"])
    if method != "analytic":
        assert r.iterations >= 1 and r.trace.shape[0] >= 2


def test_descent_stops_below_tolerance_at_the_predicted_rate():
    m = _model("ur5_nepomuceno")
    name, s = _solver("pinv")
    q_goal = np.array([0.1, -1.0, 1.0, 1.5, 1.5, 0.3])
    T = fk_htm(m.chain, q_goal)
    r = solve(name, m, T, q_goal + 1e-3, s)
    e0, eN = r.trace[0, 0], r.trace[-1, 0]
    assert eN < s.tolerance <= r.trace[-2, 0]
    # exact Jacobian: the error shrinks by ~(1 - rate) per step (notes §4.5)
    predicted = math.log(s.tolerance / e0) / math.log(1 - s.rate)
    assert abs(r.iterations - predicted) < 0.1 * predicted


# motions ---------------------------------------------------------------------------------------

MOTIONS = load_motions(ROOT / "data/nepomuceno2024/motions.yaml")


def test_interpolation_hits_the_waypoints_and_counts_points():
    T0 = pose_from_spec({"position": [-0.4, -0.1, 0.35], "yaw_deg": 0})
    T1 = pose_from_spec({"position": [-0.5, -0.35, 0.2], "yaw_deg": 30})
    n = segment_count(np.linalg.norm(T1[:3, 3] - T0[:3, 3]), 300, 80)
    assert n == int(300 * np.linalg.norm(T1[:3, 3] - T0[:3, 3]) + 80)
    P = interpolate(T0, T1, n, z_raise=0.1)
    assert P.shape == (n, 4, 4) and np.allclose(P[-1], T1, atol=1e-12)
    R = P[:, :3, :3]
    assert np.allclose(R @ np.swapaxes(R, 1, 2), np.eye(3), atol=1e-12)
    assert np.allclose(P[:, :3, 2], [0, 0, -1], atol=1e-12)  # tool keeps pointing down


@pytest.mark.parametrize("motion", ["home", "pick_and_place"])
def test_designed_motions_start_where_stated_and_stay_in_the_lbfgsb_box(motion):
    """motions.yaml claims: start_joints reach the first pose; one closed-form branch stays inside
    the L-BFGS-B bounds of Apêndice C along the whole full-scale path."""
    m = _model("ur5_nepomuceno")
    mp = set_motion(STUDY_DOC, motion, "full")
    assert len(mp) == len(build_motion(MOTIONS, motion, lambda q: fk_htm(m.chain, q), points_per_metre=300,
                                       min_points=80))
    start = {"home": "above_box", "pick_and_place": "home"}[motion]
    assert np.allclose(fk_htm(m.chain, mp.q_start), pose_from_spec(MOTIONS["poses"][start]), atol=6 * ROUND_TOL)
    name, s = _solver("analytic")
    prep = prepare(name, m, s)
    q = mp.q_start
    qs = []
    for T in mp.T:
        r = solve(name, prep, T, q, s)
        assert r.success
        q = r.q
        qs.append(q)
    qs = np.array(qs)
    b = np.array(parse_bounds(_solver("lbfgsb")[1].bounds))
    assert np.all(qs >= b[:, 0] - BOUND_SLACK) and np.all(qs <= b[:, 1] + BOUND_SLACK)
    assert np.abs(np.diff(np.vstack([mp.q_start, qs]), axis=0)).max() < 0.05  # no branch flip
