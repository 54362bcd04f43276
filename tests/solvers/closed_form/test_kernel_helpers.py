"""The compiled helpers under the closed form's per-pose path: the inline ``atan2`` pass (``angles_of``),
the reference-count-free array views (``borrowed``), the 2-D views without numba's reshape (``grid``)
and the check of all candidates at once (``check_rows``)."""

from __future__ import annotations

import math

import numba
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.solvers.kernels.kin import borrowed, grid
from pipeline.solvers.closed_form.subproblems import angles_of


@numba.njit(cache=False)
def _angles(Y, X, out):
    """One pair at a time (a pass of length 1: the compiler's scalar code, never its vector loop)."""
    for i in range(Y.shape[0]):
        angles_of(Y[i:i + 1], X[i:i + 1], out[i:i + 1], 1)


def _ulps(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(a - b) / np.spacing(np.maximum(np.abs(b), 1e-300))


def test_angles_of_within_a_few_ulps_of_libm_on_the_unit_circle_and_beyond():
    rng = np.random.default_rng(3)
    t = rng.uniform(-np.pi, np.pi, 200_000)
    r = 10.0 ** rng.uniform(-6, 6, t.size)
    for Y, X in ((np.sin(t), np.cos(t)), (r * np.sin(t), r * np.cos(t))):
        out = np.empty(Y.size)
        _angles(Y, X, out)
        ref = np.arctan2(Y, X)
        assert _ulps(out, ref).max() <= 4.0
        assert np.array_equal(np.signbit(out), np.signbit(ref))


def test_angles_of_edges_match_libm():
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
def test_angles_of_any_finite_pair(y, x):
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


@numba.njit(cache=False)
def _angles_pass(Y, X, out, m):
    angles_of(Y, X, out, m)


def test_angles_of_vector_pass_is_the_scalar_one_bit_for_bit_edges_included():
    """The vectorized pass gives the values of one pair at a time (every pair, its length not a
    multiple of the vector width), the pairs it must hand to libm (zeros, infinities, NaN) among them."""
    rng = np.random.default_rng(5)
    t = rng.uniform(-np.pi, np.pi, 997)
    Y, X = 10.0 ** rng.uniform(-3, 3, t.size) * np.sin(t), np.cos(t)
    edges_y = np.array([0.0, -0.0, 0.0, -0.0, 1.0, np.inf, -np.inf, np.nan, 1.0, 5e-324])
    edges_x = np.array([1.0, -1.0, -0.0, 0.0, 0.0, 1.0, -np.inf, 1.0, np.nan, -1.0])
    Y, X = np.concatenate([Y[:500], edges_y, Y[500:]]), np.concatenate([X[:500], edges_x, X[500:]])
    one, many = np.empty(Y.size), np.full(Y.size + 3, -9.0)
    _angles(Y, X, one)
    _angles_pass(Y, X, many, Y.size)
    assert np.array_equal(one.view(np.int64), many[:Y.size].view(np.int64))  # bit for bit, NaN and -0.0 too
    assert np.all(many[Y.size:] == -9.0)  # nothing written past m


@numba.njit(cache=False)
def _grid_views(a):
    g = grid(borrowed(a)[3:], 2, 4)
    g[1, 2] = -1.0
    return g.shape[0], g.shape[1], g[0, 0], g[1, 3], grid(a, 3, 3).copy()


def test_grid_is_the_reshaped_view():
    a = np.arange(20.0)
    r, c, first, last, whole = _grid_views(a)
    assert (r, c, first, last) == (2, 4, 3.0, 10.0)
    assert a[9] == -1.0  # the view writes through to the same memory
    assert np.array_equal(whole, a[:9].reshape(3, 3))


def test_check_rows_agrees_with_the_one_row_check():
    """Every candidate row's verdict from the vectorized pass equals the scalar FK check's
    (``fk_linesz`` + ``pose_within``), for row counts around the vector width, valid and invalid rows."""
    from pipeline.solvers.closed_form import analytic_kernels as A
    from pipeline.solvers.closed_form.lines import fk_linesz, pose_within, twelve

    rng = np.random.default_rng(11)
    H = rng.normal(size=(6, 3))
    H /= np.linalg.norm(H, axis=1)[:, None]
    Pt = rng.normal(size=(6, 3))
    RM, pM = np.linalg.qr(rng.normal(size=(3, 3)))[0], rng.normal(size=3)
    for k in (1, 7, 8, 9, 16):
        th = rng.uniform(-np.pi, np.pi, (k, 6))
        Z = np.cos(th) + 1j * np.sin(th)
        goal = np.eye(4)
        R, p = np.empty((3, 3)), np.empty(3)
        fk_linesz(H, Pt, RM, pM, Z[0], R, p)
        goal[:3, :3], goal[:3, 3] = R, p
        th[k // 2] = th[0] + rng.normal(scale=1e-13, size=6)  # a second row on the goal, within tolerance
        Z = np.cos(th) + 1j * np.sin(th)
        tolp2, fmax = 1e-18, 8.0 * np.sin(0.5e-9) ** 2
        kv = (k + 7) // 8 * 8  # rows padded to whole vectors with the zero angle, as _joint_major pads them
        thp = np.vstack([th, np.zeros((kv - k, 6))])
        Cz, Sz = np.cos(thp).T.ravel().copy(), np.sin(thp).T.ravel().copy()  # joint-major: joint i of row r at i kv + r
        mask = A.check_rows(H, Pt, twelve(RM, pM), twelve(goal, goal[:, 3]), Cz, Sz, kv, tolp2, fmax)
        ok = [float((mask >> r) & 1) for r in range(k)]
        assert mask >> kv == 0  # no bit beyond the rows
        want = []
        for r in range(k):
            fk_linesz(H, Pt, RM, pM, Z[r], R, p)
            want.append(1.0 if pose_within(R, p, goal, tolp2, fmax) else 0.0)
        assert ok == want
        assert ok[0] == 1.0 and (k < 2 or ok[k // 2] == 1.0)
