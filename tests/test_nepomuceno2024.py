"""nepomuceno2024 (004_957b32c2b06ea31d.txt): robots, kernels, closed-form UR IK, methods, motions."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import fk_htm, geometric_jacobian
from pipeline.robots import load_robot
from pipeline.studies.nepomuceno2024 import _jit
from pipeline.studies.nepomuceno2024.methods import (
    MethodError, Prepared, analytic_solutions, cost_params, goal_vector, pack_dh, solve_point)
from pipeline.studies.nepomuceno2024.trajectory import (
    build_motion, interpolate, load_motions, pose_from_spec, segment_count)

ROOT = Path(__file__).resolve().parent.parent
ROBOTS = ["ur5_nepomuceno", "ur5e"]
STUDY = yaml.safe_load((ROOT / "data/studies/nepomuceno2024.yaml").read_text())["study_settings"]

FK_TOL = 1e-12          # compiled FK vs numpy FK: same formula, rounding only
SANITY_TOL = 5e-6       # notes §3 sanity values are printed to 5-6 decimals
FD_TOL = 1e-6           # central differences with h = 1e-6 on O(1) lengths: truncation ~h²
IK_VERIFY = 1e-9        # closed-form solutions are exact up to rounding
ROUND_TOL = 1e-6        # start_joints are rounded to 1e-6 rad; the pose moves by < 1e-6 m per joint
AWAY = 1e-3            # |sin θ| above this = away from the wrist (θ5) / elbow (θ3) singularity
BOUND_SLACK = 1e-9      # tool-down poses put θ5 exactly on the L-BFGS-B bound π/2


def _model(name):
    return load_robot(ROOT / "data/robots" / f"{name}.yaml")


def _dh(name):
    return pack_dh(_model(name))


def _all_solutions(dh, T, q6_ref=0.0):
    Q = np.empty((8, 6))
    valid = np.zeros(8, dtype=np.bool_)
    err = np.empty((8, 2))
    nv = _jit.ur_ik_all(dh, np.ascontiguousarray(T), q6_ref, STUDY["methods"]["analytic"]["wrist_eps"], IK_VERIFY, IK_VERIFY,
                        Q, valid, err)
    return int(nv), Q, valid


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


# kernels ---------------------------------------------------------------------------------------

angles = st.lists(st.floats(-math.pi, math.pi, allow_nan=False), min_size=6, max_size=6).map(np.array)


@pytest.mark.parametrize("robot", ROBOTS)
@settings(max_examples=30, deadline=None)
@given(q=angles)
def test_compiled_fk_and_jacobian_match_numpy(robot, q):
    m = _model(robot)
    T = np.empty((4, 4))
    _jit.fk(pack_dh(m), q, T)
    assert np.allclose(T, fk_htm(m.chain, q), atol=FK_TOL)
    J = np.empty((6, 6))
    _jit.jacobian(pack_dh(m), q, J)
    assert np.allclose(J, geometric_jacobian(m.chain, q), atol=FK_TOL)


@settings(max_examples=20, deadline=None)
@given(q=angles)
def test_jacobian_linear_rows_are_central_differences(q):
    dh = _dh("ur5_nepomuceno")
    J = np.empty((6, 6))
    _jit.jacobian(dh, q, J)
    h = 1e-6
    Tp, Tm = np.empty((4, 4)), np.empty((4, 4))
    for j in range(6):
        dq = np.zeros(6)
        dq[j] = h
        _jit.fk(dh, q + dq, Tp)
        _jit.fk(dh, q - dq, Tm)
        assert np.allclose((Tp[:3, 3] - Tm[:3, 3]) / (2 * h), J[:3, j], atol=FD_TOL)


def test_pose_error_and_costs():
    dh = _dh("ur5_nepomuceno")
    q = np.array([0.1, -1.0, 1.0, 1.5, 1.5, 0.3])
    T = np.empty((4, 4))
    _jit.fk(dh, q, T)
    e = np.empty(6)
    assert _jit.pose_error(T, goal_vector(T), e) == 0.0 and np.allclose(e, 0.0, atol=1e-15)
    # a small rotation about z of the goal: ½Σc×d ≈ the rotation vector (base frame)
    a = 1e-4
    G = T.copy()
    G[:3, :3] = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]]) @ T[:3, :3]
    G[:3, 3] += [1e-3, 0, 0]
    _jit.pose_error(T, goal_vector(G), e)
    assert np.allclose(e, [1e-3, 0, 0, 0, 0, a], atol=1e-9)
    for name, (wp, wr) in {"A": (1.0, 1.0), "B": (1.0, 0.1)}.items():
        c = _jit.cost(q, cost_params(STUDY["costs"][name], goal_vector(G), dh))
        assert c == pytest.approx(wp * 1e-3 + wr * np.linalg.norm(T[:3, :3] - G[:3, :3]), rel=1e-12)


# closed-form UR IK -----------------------------------------------------------------------------

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
    nv, Q, valid = _all_solutions(pack_dh(m), T)
    assert nv == 8 and valid.all()
    for q in Q:  # independent check: numpy FK of every returned solution
        Tq = fk_htm(m.chain, q)
        assert np.linalg.norm(Tq[:3, 3] - T[:3, 3]) < 10 * IK_VERIFY
        assert np.linalg.norm(Tq[:3, :3] - T[:3, :3]) < 10 * IK_VERIFY
    assert len({tuple(np.round(q, 6)) for q in Q}) == 8  # eight distinct configurations


@pytest.mark.parametrize("robot", ROBOTS)
@settings(max_examples=40, deadline=None)
@given(q=angles)
def test_closed_form_recovers_the_generating_angles(robot, q):
    m = _model(robot)
    nv, Q, valid = _all_solutions(pack_dh(m), fk_htm(m.chain, q), q[5])
    assert np.all(np.isfinite(Q))
    dist = np.abs((Q[valid] - q + np.pi) % (2 * np.pi) - np.pi).max(axis=1)
    if abs(math.sin(q[4])) > AWAY and abs(math.sin(q[2])) > AWAY:  # away from wrist and elbow singularities
        assert nv >= 1 and dist.min() < 1e-6


@pytest.mark.parametrize("robot", ROBOTS)
@pytest.mark.parametrize("q5", [0.0, math.pi, -math.pi, 1e-13])
def test_wrist_singularity_gives_finite_fk_verified_solutions(robot, q5):
    m = _model(robot)
    q = np.array([0.4, -1.1, 1.2, 0.5, q5, 0.9])
    T = fk_htm(m.chain, q)
    nv, Q, valid = _all_solutions(pack_dh(m), T, q6_ref=0.9)
    assert np.all(np.isfinite(Q))
    assert nv >= 4
    assert np.sum(valid & (np.abs(np.sin(Q[:, 4])) < AWAY)) >= 2  # the singular branches are kept
    for k in np.flatnonzero(valid):
        Tq = fk_htm(m.chain, Q[k])
        assert np.linalg.norm(Tq[:3, 3] - T[:3, 3]) < 10 * IK_VERIFY
        if abs(math.sin(Q[k, 4])) < AWAY:  # this branch is singular (the other shoulder branch is not)
            assert Q[k, 5] == pytest.approx(0.9)  # θ6 taken from the reference, θ4 absorbs the rest
    # the method wrapper picks a finite solution next to the previous angles
    prep = Prepared(m, 1e-3, 1e-2)
    r = solve_point("analytic", STUDY["methods"]["analytic"], STUDY["costs"], prep, T, q)
    assert r.ik.success and np.all(np.isfinite(r.ik.q)) and np.abs(r.ik.q - q).max() < 1e-6


def test_unreachable_pose_gives_no_valid_solution_and_no_nan():
    dh = _dh("ur5_nepomuceno")
    T = pose_from_spec({"position": [3.0, 0.0, 0.2], "yaw_deg": 0})
    nv, Q, valid = _all_solutions(dh, T)
    assert nv == 0 and np.all(np.isfinite(Q))


def test_closed_form_rejects_non_ur_robots():
    with pytest.raises(MethodError, match="not a UR-type"):
        analytic_solutions(load_robot(ROOT / "data/robots/kuka_lwr.yaml"), np.eye(4))


def test_public_wrapper_equals_kernel():
    m = _model("ur5e")
    T = _ring_pose(0.5, 0.3, 0.1, 0.2, 0.1)
    Q, valid, _ = analytic_solutions(m, T)
    nv, Q2, valid2 = _all_solutions(pack_dh(m), T)
    assert np.array_equal(Q, Q2) and np.array_equal(valid, valid2) and nv == 8


# methods ---------------------------------------------------------------------------------------

TABLE_METHODS = ["pinv", "bfgs", "lbfgsb", "nelder_mead", "analytic"]


@pytest.mark.parametrize("method", TABLE_METHODS)
def test_each_method_solves_a_nearby_point(method):
    m = _model("ur5_nepomuceno")
    prep = Prepared(m, STUDY["success"]["position"], STUDY["success"]["orientation"])
    q_goal = np.array([0.43, -0.75, 0.95, 1.37, 1.5707963267948966, 1.48])
    T = fk_htm(m.chain, q_goal)
    q0 = q_goal + np.array([0.01, -0.01, 0.01, 0.0, 0.0, 0.01])
    r = solve_point(method, STUDY["methods"][method], STUDY["costs"], prep, T, q0)
    assert r.ik.success and r.ik.stop_reason == 1
    assert r.ik.position_error < STUDY["success"]["position"]
    assert r.ik.orientation_error < STUDY["success"]["orientation"]
    assert r.nfev > 0 and r.ik.trace.shape[1] == 8 and np.isfinite(r.doc_error)
    if method != "analytic":
        assert r.ik.iterations >= 1 and r.ik.trace.shape[0] >= 2


def test_descent_stops_below_tolerance_at_the_predicted_rate():
    m = _model("ur5_nepomuceno")
    cfg = STUDY["methods"]["pinv"]
    prep = Prepared(m, 1e-3, 1e-2)
    q_goal = np.array([0.1, -1.0, 1.0, 1.5, 1.5, 0.3])
    T = fk_htm(m.chain, q_goal)
    r = solve_point("pinv", cfg, STUDY["costs"], prep, T, q_goal + 1e-3)
    e0, eN = r.ik.trace[0, 0], r.ik.trace[-1, 0]
    assert eN < cfg["tolerance"] <= r.ik.trace[-2, 0]
    # exact Jacobian: the error shrinks by ~(1 - rate) per step (notes §4.5)
    predicted = math.log(cfg["tolerance"] / e0) / math.log(1 - cfg["rate"])
    assert abs(r.ik.iterations - predicted) < 0.1 * predicted


# motions ---------------------------------------------------------------------------------------

MOTIONS = load_motions(ROOT / "data" / STUDY["motions_file"])


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
    m = _model(STUDY["robot"])
    mp = build_motion(MOTIONS, motion, lambda q: fk_htm(m.chain, q), **STUDY["interpolation"]["full"])
    start = {"home": "above_box", "pick_and_place": "home"}[motion]
    assert np.allclose(fk_htm(m.chain, mp.q_start), pose_from_spec(MOTIONS["poses"][start]), atol=6 * ROUND_TOL)
    prep = Prepared(m, 1e-3, 1e-2)
    q = mp.q_start
    qs = []
    for T in mp.T:
        r = solve_point("analytic", STUDY["methods"]["analytic"], STUDY["costs"], prep, T, q)
        assert r.ik.success
        q = r.ik.q
        qs.append(q)
    qs = np.array(qs)
    b = np.array(STUDY["methods"]["lbfgsb"]["bounds"])
    assert np.all(qs >= b[:, 0] - BOUND_SLACK) and np.all(qs <= b[:, 1] + BOUND_SLACK)
    assert np.abs(np.diff(np.vstack([mp.q_start, qs]), axis=0)).max() < 0.05  # no branch flip
