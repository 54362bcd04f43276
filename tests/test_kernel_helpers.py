"""The compiled helpers under the closed form's per-pose path: the inline ``atan2`` (``angle_of``)
and the reference-count-free array views (``borrowed``)."""

from __future__ import annotations

import math

import numba
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.solvers._kin import borrowed
from pipeline.solvers.subproblems import angle_of


@numba.njit(cache=False)
def _angles(Y, X, out):
    for i in range(Y.shape[0]):
        out[i] = angle_of(Y[i], X[i])


def _ulps(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(a - b) / np.spacing(np.maximum(np.abs(b), 1e-300))


def test_angle_of_within_a_few_ulps_of_libm_on_the_unit_circle_and_beyond():
    rng = np.random.default_rng(3)
    t = rng.uniform(-np.pi, np.pi, 200_000)
    r = 10.0 ** rng.uniform(-6, 6, t.size)
    for Y, X in ((np.sin(t), np.cos(t)), (r * np.sin(t), r * np.cos(t))):
        out = np.empty(Y.size)
        _angles(Y, X, out)
        ref = np.arctan2(Y, X)
        assert _ulps(out, ref).max() <= 4.0
        assert np.array_equal(np.signbit(out), np.signbit(ref))


def test_angle_of_edges_match_libm():
    """Zeros, infinities and NaN are libm's own answer; denormal and huge ratios within 4 ulps."""
    Y = np.array([0.0, -0.0, 0.0, -0.0, 1.0, -1.0, np.inf, -np.inf, np.nan, 1.0, 5e-324, -0.0, 1.0, 1.0])
    X = np.array([1.0, 1.0, -1.0, -1.0, 0.0, -0.0, 1.0, -np.inf, 1.0, np.nan, 1.0, -1.0, 1e300, -5e-324])
    out = np.empty(Y.size)
    _angles(Y, X, out)
    ref = np.arctan2(Y, X)
    exact = (Y == 0) | (X == 0) | ~np.isfinite(Y) | ~np.isfinite(X)
    assert np.array_equal(out[exact], ref[exact], equal_nan=True)
    assert _ulps(out[~exact], ref[~exact]).max() <= 4.0
    assert np.array_equal(np.signbit(out), np.signbit(ref))


finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=400, deadline=None)
@given(finite, finite)
def test_angle_of_any_finite_pair(y, x):
    out = np.empty(1)
    _angles(np.array([y]), np.array([x]), out)
    ref = math.atan2(y, x)
    assert abs(out[0] - ref) <= 4.0 * math.ulp(max(abs(ref), 1e-300)) or (ref == 0.0 and out[0] == 0.0)
    assert math.copysign(1.0, out[0]) == math.copysign(1.0, ref)


@numba.njit(cache=False)
def _write_through(a):
    b = borrowed(a)
    v = b[1:, :]  # a view of the borrowed view
    v[0, 0] = 7.0
    b[0, 1] = 5.0
    return b.shape[0] * 10 + b.shape[1], a[1, 0] + a[0, 1]


def test_borrowed_view_is_the_same_memory_and_shape():
    a = np.zeros((3, 2))
    shape, total = _write_through(a)
    assert shape == 32 and total == 12.0
    assert a[1, 0] == 7.0 and a[0, 1] == 5.0
