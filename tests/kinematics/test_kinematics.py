"""Kinematics: DQ vs HTM, the document's DQ operator, Jacobian vs finite differences, errors."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import (
    dh_transform,
    dq_from_dh,
    dq_from_transform,
    dq_to_transform,
    fk_dq,
    fk_htm,
    geometric_jacobian,
    orientation_error_angle,
    orientation_error_axis_angle,
    orientation_error_quat_vec,
    quat_from_matrix,
    matrix_from_quat,
    relative_dq_norm,
)
from pipeline.kinematics.htm import rot_x
from tests.conftest import chains, random_transform

POSE_TOL = 1e-12  # DQ and HTM chains are both exact up to a few rounding errors per link
FD_STEP = 1e-6  # central differences: truncation ~h^2, rounding ~eps/h -> ~1e-9 error
FD_TOL = 1e-7


def _scaled_tol(chain):
    # translations grow with the link lengths; compare relative to the chain's size
    size = 1 + np.abs(chain.a).sum() + np.abs(chain.d).sum() + 10
    return POSE_TOL * size


@settings(max_examples=60, deadline=None)
@given(chain=chains(), seed=st.integers(0, 2**32 - 1))
def test_dq_fk_equals_htm_fk(chain, seed):
    q = np.random.default_rng(seed).uniform(-2 * np.pi, 2 * np.pi, (4, chain.n))
    T = fk_htm(chain, q)
    T_dq = dq_to_transform(fk_dq(chain, q))
    assert np.abs(T_dq - T).max() < _scaled_tol(chain)


@settings(max_examples=40, deadline=None)
@given(chain=chains(), seed=st.integers(0, 2**32 - 1))
def test_batch_equals_loop(chain, seed):
    q = np.random.default_rng(seed).uniform(-np.pi, np.pi, (3, chain.n))
    batch = fk_htm(chain, q)
    for i in range(3):
        np.testing.assert_allclose(batch[i], fk_htm(chain, q[i]), atol=1e-14)
    J = geometric_jacobian(chain, q)
    for i in range(3):
        np.testing.assert_allclose(J[i], geometric_jacobian(chain, q[i]), atol=1e-14)


def test_eq62_operator_is_standard_dh():
    """Eq. 62 of 000 equals the DQ of Rz(θ)Tz(d)Tx(a)Rx(α), not of the modified form."""
    rng = np.random.default_rng(62)
    a, alpha, d, theta = rng.normal(size=(4, 50))
    Q = dq_from_dh(a, alpha, d, theta, "standard")
    np.testing.assert_allclose(dq_to_transform(Q), dh_transform(a, alpha, d, theta, "standard"), atol=1e-13)
    assert np.abs(dq_to_transform(Q) - dh_transform(a, alpha, d, theta, "modified")).max() > 0.1


def test_modified_dh_matches_craig_product():
    rng = np.random.default_rng(3)
    a, alpha, d, theta = rng.normal(size=4)
    Tx = np.eye(4)
    Tx[0, 3] = a
    Tz = np.eye(4)
    Tz[2, 3] = d
    Rz = np.eye(4)
    Rz[:2, :2] = [[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]]
    np.testing.assert_allclose(dh_transform(a, alpha, d, theta, "modified"), rot_x(alpha) @ Tx @ Rz @ Tz, atol=1e-14)


def test_lwr_straight_up(lwr):
    T = fk_htm(lwr.chain, np.zeros(7))
    np.testing.assert_allclose(T[:3, 3], [0, 0, 117.8], atol=1e-12)
    np.testing.assert_allclose(T[:3, :3], np.eye(3), atol=1e-12)


def _numeric_jacobian(chain, q):
    J = np.zeros((6, chain.n))
    R = fk_htm(chain, q)[:3, :3]
    for i in range(chain.n):
        dq = np.zeros(chain.n)
        dq[i] = FD_STEP
        Tp, Tm = fk_htm(chain, q + dq), fk_htm(chain, q - dq)
        J[:3, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * FD_STEP)
        W = (Tp[:3, :3] - Tm[:3, :3]) / (2 * FD_STEP) @ R.T  # skew(omega)
        J[3:, i] = [W[2, 1], W[0, 2], W[1, 0]]
    return J


@settings(max_examples=60, deadline=None)
@given(chain=chains(), seed=st.integers(0, 2**32 - 1))
def test_jacobian_matches_central_differences(chain, seed):
    q = np.random.default_rng(seed).uniform(-np.pi, np.pi, chain.n)
    np.testing.assert_allclose(geometric_jacobian(chain, q), _numeric_jacobian(chain, q), atol=FD_TOL * 10)


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_quaternion_round_trips(seed):
    rng = np.random.default_rng(seed)
    T = random_transform(rng, 10.0)
    q = quat_from_matrix(T)
    assert q[0] >= 0 and abs(np.linalg.norm(q) - 1) < 1e-14
    np.testing.assert_allclose(matrix_from_quat(q), T[:3, :3], atol=1e-14)
    np.testing.assert_allclose(dq_to_transform(dq_from_transform(T)), T, atol=1e-12)


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), angle=st.floats(0.0, 3.1))
def test_orientation_errors_agree(seed, angle):
    rng = np.random.default_rng(seed)
    T = random_transform(rng)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    R = np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
    Tg = T.copy()
    Tg[:3, :3] = R @ T[:3, :3]  # goal = current rotated by `angle` about `axis` (base frame)
    np.testing.assert_allclose(orientation_error_axis_angle(Tg, T), angle * axis, atol=1e-9)
    np.testing.assert_allclose(orientation_error_quat_vec(Tg, T), np.sin(angle / 2) * axis, atol=1e-12)
    assert abs(orientation_error_angle(Tg, T) - angle) < 1e-9


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_relative_dq_norm_closed_form(seed):
    rng = np.random.default_rng(seed)
    Ta, Tb = random_transform(rng, 5.0), random_transform(rng, 5.0)
    t = (Ta @ np.linalg.inv(Tb))[:3, 3]
    assert abs(relative_dq_norm(Ta, Tb) - np.sqrt(1 + t @ t / 4)) < 1e-12
    assert abs(relative_dq_norm(Ta, Ta) - 1) < 1e-14
