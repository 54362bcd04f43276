"""The vectorizable elementary functions (``pipeline.kinematics.vmath``) and the check that runs 8 poses
as vector lanes (``fkcheck.pose_check8``): accuracy against libm, and the same floats as the one-pose
check bit for bit, whatever the chain form, joint kind or row (NaN, huge and unreachable rows included)."""

from __future__ import annotations

import math

import numba
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import fk_htm
from pipeline.kinematics.fkcheck import CHECK8_SCRATCH, check_model, pose_check, pose_check8
from pipeline.kinematics.vmath import SINCOS_MAX, sincos, sincos_core
from pipeline.solvers.core import pose_errors
from tests.solvers.core.test_fast_path import _chain


@numba.njit(cache=False)
def _sincos_pass(X, S, C):
    """One pass over X (the compiler's vector loop, as the check runs it)."""
    for i in range(X.shape[0]):
        S[i], C[i] = sincos(X[i])


@numba.njit(cache=False)
def _sincos_one(X, S, C):
    """One argument per call (a pass of length 1: never the vector loop)."""
    for i in range(X.shape[0]):
        _sincos_pass(X[i:i + 1], S[i:i + 1], C[i:i + 1])


def _ulps(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(a - b) / np.spacing(np.maximum(np.abs(b), 1e-300))


def test_sincos_within_two_ulps_of_libm():
    rng = np.random.default_rng(5)
    X = np.concatenate([rng.uniform(-4, 4, 100_000), rng.uniform(-SINCOS_MAX, SINCOS_MAX, 100_000),
                        np.arange(-64, 65) * (np.pi / 2), np.arange(-64, 65) * (np.pi / 4), [0.0, -0.0, 1e-300]])
    S, C = np.empty_like(X), np.empty_like(X)
    _sincos_pass(X, S, C)
    # relative to the magnitude near zeros of sin/cos (x a float near k π/2: the value itself is tiny)
    assert _ulps(S, np.sin(X)).max() <= 2.0
    assert _ulps(C, np.cos(X)).max() <= 2.0
    assert np.abs(S - np.sin(X)).max() <= 2.3e-16 and np.abs(C - np.cos(X)).max() <= 2.3e-16


def test_sincos_unusual_arguments_are_libms():
    X = np.array([np.nan, np.inf, -np.inf, SINCOS_MAX * 1.0000001, -3e7, 1e300])
    S, C = np.empty_like(X), np.empty_like(X)
    _sincos_pass(X, S, C)
    with np.errstate(invalid="ignore"):
        assert np.array_equal(S, np.sin(X), equal_nan=True) and np.array_equal(C, np.cos(X), equal_nan=True)
    assert not any(sincos_core(x)[2] for x in X)


def test_sincos_vector_pass_is_the_scalar_one_bit_for_bit():
    X = np.random.default_rng(6).uniform(-50, 50, 4099)
    S1, C1, S8, C8 = (np.empty_like(X) for _ in range(4))
    _sincos_pass(X, S8, C8)
    _sincos_one(X, S1, C1)
    assert np.array_equal(S1, S8) and np.array_equal(C1, C8)


def _rows(chain, N: int, seed: int):
    rng = np.random.default_rng(seed)
    Q = rng.uniform(-np.pi, np.pi, (N, chain.n))
    goals = np.array([fk_htm(chain, q + rng.normal(scale=0.3, size=chain.n) * (i % 3 > 0)) for i, q in enumerate(Q)])
    return Q, goals


def _both(chain, Q, goals):
    K, axis, offset, prism = check_model(chain)
    one = np.array([pose_check(K, axis, offset, prism, q, g, np.empty(8)) for q, g in zip(Q, goals)])
    eight = np.empty_like(one)
    W, out = np.empty(CHECK8_SCRATCH + 8 * chain.n), np.empty((3, 8))
    for k in range(0, len(Q), 8):
        pose_check8(K, axis, offset, prism, Q, goals, k, W, out)
        eight[k:k + 8] = out.T
    return one, eight


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 8), form=st.sampled_from(["standard", "modified", "general"]))
def test_eight_rows_at_once_are_the_one_row_check_bit_for_bit(seed, n, form):
    """Any chain (prismatic joints among them): pose_check8 = pose_check, and both = the numpy check."""
    c = _chain(seed, n, form)
    Q, goals = _rows(c, 16, seed)
    one, eight = _both(c, Q, goals)
    assert np.array_equal(one, eight)
    want = np.array([pose_errors(type("M", (), {"chain": c}), g, q) for q, g in zip(Q, goals)])
    scale = 1.0 + np.abs(goals[:, :3, 3]).max()
    np.testing.assert_allclose(one, want, atol=1e-12 * scale)


def test_unusual_rows_among_eight():
    """A NaN or an infinite joint value gives that row NaNs; a huge finite one (libm's sine and cosine)
    its true errors; the other rows stay as they are; an exact pose gives angle 0."""
    c = _chain(11, 6, "general")
    Q, goals = _rows(c, 16, 11)
    Q[1, 2], Q[4, 0], Q[6, 5] = np.nan, np.inf, 3e6
    goals[9] = fk_htm(c, Q[9])
    one, eight = _both(c, Q, goals)
    assert np.array_equal(one, eight, equal_nan=True)
    assert np.isnan(eight[[1, 4]]).all() and np.isfinite(np.delete(eight, [1, 4], axis=0)).all()
    want = pose_errors(type("M", (), {"chain": c}), goals[6], Q[6])
    np.testing.assert_allclose(eight[6], want, atol=1e-9)
    assert eight[9, 0] < 1e-12 and eight[9, 1] < 1e-7
    # an unreachable goal: large errors, not NaN
    goals[12, :3, 3] += 1e3
    one, eight = _both(c, Q, goals)
    assert np.array_equal(one, eight, equal_nan=True) and eight[12, 0] > 900


def test_angle_of_an_exact_rotation_is_zero():
    c = _chain(3, 6, "standard")
    q = np.zeros(6)
    K, axis, offset, prism = check_model(c)
    dp, ang, t = pose_check(K, axis, offset, prism, q, fk_htm(c, q), np.empty(8))
    assert dp < 1e-12 and ang < 1e-7 and t < 1e-12 and math.isfinite(ang)


def test_half_turn_and_small_rotation_errors():
    """Rotation errors of π (the pair (0, −1) of atan2, libm's) and of 1e-9 rad come out as such, in
    one row and eight alike."""
    c = _chain(4, 6, "general")
    Q, goals = _rows(c, 8, 4)
    Rz = lambda a: np.array([[np.cos(a), -np.sin(a), 0, 0], [np.sin(a), np.cos(a), 0, 0], [0, 0, 1, 0],  # noqa: E731
                             [0, 0, 0, 1]])
    for k, a in enumerate((np.pi, 1e-9, np.pi / 2, -2.0)):
        goals[k] = fk_htm(c, Q[k]) @ Rz(a)
    one, eight = _both(c, Q, goals)
    assert np.array_equal(one, eight)
    np.testing.assert_allclose(eight[:4, 1], [np.pi, 1e-9, np.pi / 2, 2.0], rtol=1e-7, atol=1e-12)
    assert (eight[:4, 0] < 1e-9).all()  # a rotation about the tool's own z moves no point of the flange
