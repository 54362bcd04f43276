"""Jacobian IK loop: compiled kernel vs numpy reference, stop codes, FK-verified success."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import fk_htm, geometric_jacobian
from pipeline.robots import parse_robot
from pipeline.solvers import Prepared, SettingsError, StopReason, make_settings, solve
from pipeline.solvers.kernels import kin as _kin, pose as _jit
from pipeline.solvers.iterative.jacobian import DLSSettings, packed
from tests.conftest import chains

KERNEL_TOL = 1e-12  # same formulas, different evaluation order


@settings(max_examples=30, deadline=None)
@given(chain=chains(), seed=st.integers(0, 2**32 - 1))
def test_kernel_fk_and_jacobian_match_numpy(chain, seed):
    q = np.random.default_rng(seed).uniform(-np.pi, np.pi, chain.n)
    n = chain.n
    axes, origins, T, J = np.empty((n, 3)), np.empty((n, 3)), np.empty((4, 4)), np.empty((6, n))
    _kin.forward(chain.a, chain.alpha, chain.d, chain.theta_offset, chain.prismatic, chain.modified,
                 chain.base, chain.tool, q, axes, origins, T)
    _kin.jacobian(chain.prismatic, axes, origins, T[:3, 3].copy(), J)
    np.testing.assert_allclose(T, fk_htm(chain, q), atol=KERNEL_TOL * 100)
    np.testing.assert_allclose(J, geometric_jacobian(chain, q), atol=KERNEL_TOL * 100)


def _planar(n=3):
    return parse_robot({"name": "planar", "source": "test", "length_unit": "m", "convention": "standard",
                        "joints": [{"type": "revolute", "a": 1.0, "alpha": 0, "d": 0, "theta_offset": 0}] * n})


# Jacobian transpose converges slowly (linear rate); the others are Newton-like
@pytest.mark.parametrize("method,min_ok", [("dls", 9), ("pseudoinverse", 9), ("sdls", 9), ("jacobian_transpose", 6)])
def test_methods_solve_reachable_lwr_targets(lwr, method, min_ok):
    rng = np.random.default_rng(11)
    s = make_settings(method, dict(criterion="pos_orient", tol_pos=1e-4, tol_rot=1e-4, orientation_error="axis_angle",
                                   max_iterations=3000, length_unit="m", grow_limit=50))
    m = lwr.in_unit("m")
    ok = 0
    for _ in range(10):
        qg = rng.uniform(0, 2 * np.pi, 7)
        q0 = qg + rng.normal(scale=0.3, size=7)
        res = solve(method, m, fk_htm(m.chain, qg), q0, s)
        ok += res.success
        if res.success:
            assert res.position_error <= 1e-4 and res.orientation_error <= 1e-4
    assert ok >= min_ok


def test_dls_step_on_planar_arm_by_hand():
    """One DLS step of a 2R arm at q = (0, pi/2) for e = (0.1, 0, 0, 0, 0, 0), λ = 0.1."""
    m = _planar(2)
    J = geometric_jacobian(m.chain, np.array([0.0, np.pi / 2]))
    # tip at (1, 1): columns z x (p - o) = (-1, 1) and (-1, 0) in x, y
    np.testing.assert_allclose(J[:2], [[-1, -1], [1, 0]], atol=1e-15)
    e = np.array([0.1, 0, 0, 0, 0, 0])
    ip, fp = packed("dls", DLSSettings(damping=0.1))
    dq = _jit.step(2, J, e, ip, fp)
    Jr = J[[0, 1, 5]]
    expect = Jr.T @ np.linalg.solve(Jr @ Jr.T + 0.01 * np.eye(3), np.array([0.1, 0, 0]))
    np.testing.assert_allclose(dq, expect, atol=1e-12)


def test_unreachable_target_is_a_reported_failure():
    m = _planar(3)
    T = np.eye(4)
    T[0, 3] = 10.0  # reach is 3 m
    res = solve("dls", m, T, np.zeros(3), {"criterion": "pos_orient"})
    assert not res.success and res.stop_reason in (2, 3, 4)
    assert np.all(np.isfinite(res.q)) and np.isfinite(res.position_error) and res.position_error > 6.9


def test_claimed_success_contradicted_by_fk(lwr):
    """A kernel that says "success" for wrong angles must not produce a success flag."""

    from dataclasses import replace

    from pipeline.solvers import Raw, get
    from pipeline.solvers.core import registry

    def lying_run(prep, T_goal, q_start, settings, seed):
        return Raw(q=q_start.copy(), code=StopReason.SUCCESS, iterations=1, solve_ns=1)

    registry._REGISTRY["liar"] = replace(get("dls"), name="liar", run=lying_run, bind=None, batch=None)
    try:
        qg = np.full(7, 0.5)
        res = solve("liar", lwr, fk_htm(lwr.chain, qg), np.zeros(7))
    finally:
        del registry._REGISTRY["liar"]
    assert res.claimed_success and not res.success and res.stop_reason == StopReason.FK_CHECK_FAILED


def test_same_problem_same_result(lwr):
    rng = np.random.default_rng(5)
    T = fk_htm(lwr.chain, rng.uniform(0, 6, 7))
    q0 = rng.uniform(0, 6, 7)
    a, b = (solve("sdls", lwr, T, q0) for _ in range(2))
    assert a.iterations == b.iterations and a.stop_reason == b.stop_reason
    assert np.array_equal(a.q, b.q) and np.array_equal(a.trace, b.trace)


@pytest.mark.parametrize("field,value,expect", [
    ("criterion", "newton", "field 'criterion'"),
    ("max_iterations", 1.5, "field 'max_iterations'"),
    ("max_iterations", 0, "field 'max_iterations'"),
    ("damping", float("nan"), "field 'damping'"),
    ("tol_dq", 0.5, "tol_dq"),
    ("nonsense", 1, "field 'nonsense': unknown setting"),
])
def test_settings_errors_name_the_field(field, value, expect):
    with pytest.raises(SettingsError, match=expect):
        make_settings("dls", {field: value}, "study.yaml: solvers/x")


def test_prepared_robot_unit_conversion(lwr):
    prep = Prepared(lwr, "m")
    assert prep.model.length_unit == "m" and prep.args[2][0] == pytest.approx(0.31)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_verify_matches_reference_error_helpers(seed, lwr):
    from pipeline.kinematics import orientation_error_angle, relative_dq_norm
    from pipeline.solvers import verify

    rng = np.random.default_rng(seed)
    Tg = fk_htm(lwr.chain, rng.uniform(0, 6, 7))
    q = rng.uniform(0, 6, 7)
    T = fk_htm(lwr.chain, q)
    norm = float(relative_dq_norm(Tg, T))
    ok, dp, ang = verify(lwr, Tg, q, make_settings("dls", {"criterion": "dq_norm", "tol_dq": norm * (1 + 1e-9)}))
    assert ok and abs(dp - np.linalg.norm(Tg[:3, 3] - T[:3, 3])) < 1e-12
    assert abs(ang - orientation_error_angle(Tg, T)) < 1e-9
    assert not verify(lwr, Tg, q, make_settings("dls", {"criterion": "dq_norm", "tol_dq": norm * (1 - 1e-9)}))[0]


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), m=st.integers(1, 7), n=st.integers(1, 8), rank_drop=st.integers(0, 2))
def test_small_svd_matches_lapack(seed, m, n, rank_drop):
    rng = np.random.default_rng(seed)
    J = rng.normal(size=(m, n))
    k = min(m, n)
    if rank_drop and k > rank_drop:  # exact rank deficiency, as at a singular configuration
        J = rng.normal(size=(m, k - rank_drop)) @ rng.normal(size=(k - rank_drop, n))
    U, S, Vt = _kin.small_svd(J)
    assert U.shape == (m, k) and S.shape == (k,) and Vt.shape == (k, n)
    np.testing.assert_allclose(S, np.linalg.svd(J, compute_uv=False), atol=1e-12 * (1 + S[0]))
    np.testing.assert_allclose(U @ np.diag(S) @ Vt, J, atol=1e-12 * (1 + S[0]))
    big = S > 1e-10 * (1 + S[0])
    np.testing.assert_allclose(U[:, big].T @ U[:, big], np.eye(big.sum()), atol=1e-10)
    np.testing.assert_allclose(Vt[big] @ Vt[big].T, np.eye(big.sum()), atol=1e-10)


@settings(max_examples=30, deadline=None)
@given(chain=chains(), seed=st.integers(0, 2**32 - 1))
def test_kernel_pose_only_fk_and_pose_distances_match_numpy(chain, seed):
    from pipeline.kinematics import orientation_error_angle
    from pipeline.solvers.kernels import kin as _kin

    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, chain.n)
    T = np.empty((4, 4))
    _kin.forward_pose(chain.a, chain.alpha, chain.d, chain.theta_offset, chain.prismatic, chain.modified,
                      chain.base, chain.tool, q, T)
    ref = fk_htm(chain, q)
    np.testing.assert_allclose(T, ref, atol=1e-10)
    other = fk_htm(chain, rng.uniform(-np.pi, np.pi, chain.n))
    assert abs(_kin.position_distance(ref, other) - np.linalg.norm(ref[:3, 3] - other[:3, 3])) < 1e-12
    assert abs(_kin.rotation_angle(ref, other) - orientation_error_angle(ref, other)) < 1e-7


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(-3, 3))
def test_within_limits_wraps_revolute_joints_by_2pi(seed, k):
    from pipeline.solvers import within_limits

    rng = np.random.default_rng(seed)
    lo = rng.uniform(-3, 0, 4)
    hi = lo + rng.uniform(0.1, 3, 4)
    lim = np.stack([lo, hi], axis=1)
    prism = np.array([False, False, False, True])
    q = rng.uniform(lo, hi)
    shifted = q + np.where(prism, 0.0, 2 * np.pi * k)
    assert within_limits(shifted, lim, prism)
    outside = q.copy()
    outside[3] = hi[3] + 0.01  # a prismatic joint is never wrapped
    assert not within_limits(outside, lim, prism)


def test_settings_are_si_whatever_the_working_unit(lwr):
    """tol_pos is written in m; computed in cm it is the same physical tolerance."""
    s_m = make_settings("dls", {"tol_pos": 1e-4}).converted()
    s_cm = make_settings("dls", {"tol_pos": 1e-4, "length_unit": "cm"}).converted()
    assert s_m.tol_pos == pytest.approx(1e-4) and s_cm.tol_pos == pytest.approx(1e-2)
    rng = np.random.default_rng(3)
    qg = rng.uniform(-1, 1, 7)
    T = fk_htm(lwr.chain, qg)  # cm, the robot file's unit
    a = solve("dls", lwr, T, qg + 0.1, {"length_unit": "m"})
    b = solve("dls", lwr, T, qg + 0.1, {"length_unit": "cm"})
    assert a.success and b.success and a.length_unit == "m" and b.length_unit == "cm"
    assert a.position_error <= 1e-4 and b.position_error <= 1e-2


def test_results_carry_both_times_and_limits(lwr):
    qg = np.full(7, 0.4)
    res = solve("dls", lwr, fk_htm(lwr.chain, qg), qg + 0.1)
    assert 0 < res.solve_time_s <= res.call_time_s
    assert res.within_limits and res.success


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 8), conv=st.sampled_from(["standard", "modified"]))
def test_batch_chain_kernels_match_numpy(seed, n, conv):
    """The HTM and dual-quaternion batch FK of the host timing (003) against the numpy reference."""
    from pipeline.solvers.kernels import kin as _kin
    from tests.conftest import random_chain

    rng = np.random.default_rng(seed)
    c = random_chain(rng, n, conv, with_base_tool=False)
    Q = rng.uniform(-np.pi, np.pi, (20, n))
    ref = fk_htm(c, Q)[:, :3, 3]
    for kern in (_kin.fk_htm_batch, _kin.fk_dq_batch):
        out = np.empty((20, 3))
        kern(np.array(c.a), np.array(c.alpha), np.array(c.d), np.array(c.theta_offset), np.array(c.prismatic),
             c.modified, Q, out)
        np.testing.assert_allclose(out, ref, atol=1e-9)
