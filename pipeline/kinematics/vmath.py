"""Elementary functions written so that a compiled loop over them vectorizes.

``math.sin``, ``math.cos`` and ``math.atan2`` are calls into libm: a loop that calls them stays
scalar. The cores here are branch-free polynomial evaluations (no call, no table but a gather, no
switch), so a loop over many poses or candidates runs 8 of them per AVX-512 instruction. Each core
returns, besides its value, whether its argument is ordinary; a caller takes libm's value for the
others (a NaN, an infinity, or an angle too large for the reduction here). Being our own arithmetic,
the results are also the same on every machine, whatever its libm.

Accuracy: within 2 units in the last place of libm's (``tests/kinematics/test_vmath.py`` for sin and cos,
``tests/solvers/closed_form/test_kernel_helpers.py`` for atan2).
"""

from __future__ import annotations

import math

import numba
import numpy as np

# ---- atan2 ----------------------------------------------------------------------------------------
# atan(j/8), j = 0..8, as nine constants picked by selects (:func:`_atan_eighth`), not a table: a table
# lookup in the vectorized loop is a gather, microcoded on AMD Zen 3 (48 angles 375-530 ns there with the
# table, 280-380 with the selects, the same floats)
_AT0, _AT1, _AT2, _AT3, _AT4, _AT5, _AT6, _AT7, _AT8 = (math.atan(j / 8.0) for j in range(9))
_PIO2_HI, _PIO2_LO = 1.5707963267948966, 6.123233995736766e-17  # π/2 = HI + LO (LO its rounding error)
_PI_HI, _PI_LO = 3.141592653589793, 1.2246467991473532e-16


@numba.njit(cache=True, error_model="numpy", inline="always")
def _atan_eighth(j):
    """atan(j/8) for the integer j in 0..8, branch-free."""
    a = _AT0
    a = _AT1 if j == 1 else a
    a = _AT2 if j == 2 else a
    a = _AT3 if j == 3 else a
    a = _AT4 if j == 4 else a
    a = _AT5 if j == 5 else a
    a = _AT6 if j == 6 else a
    a = _AT7 if j == 7 else a
    return _AT8 if j == 8 else a


@numba.njit(cache=True, error_model="numpy", inline="always")
def atan2_core(y, x):
    """(atan2(y, x), whether the pair is ordinary), branch-free so that a loop over it vectorizes.

    The ratio u = min/max of |x|, |y| (in [0, 1]) is split at its nearest eighth c = j/8:
    atan(u) = atan(c) + atan(v) with v = (u − c)/(1 + u c), |v| ≤ 1/16, and atan(v) is its odd series
    to v¹³ (truncation below 1e-18 relative); the octant is restored with π/2 and π each carried as
    two floats. A pair with a zero, infinite or NaN ratio part is not ordinary: its angle here is
    meaningless, and the callers take ``math.atan2``'s."""
    ax = abs(x)
    ay = abs(y)
    swap = ay > ax
    num = ax if swap else ay
    den = ay if swap else ax
    ok = (den > 0.0) & (den < math.inf) & (x == x) & (y == y)
    u = num / den if ok else 0.0
    j = int(u * 8.0 + 0.5)
    c = j * 0.125
    v = (u - c) / (1.0 + u * c)
    s = v * v
    a = _atan_eighth(j) + (v + v * s * (-1.0 / 3.0 + s * (0.2 + s * (-1.0 / 7.0 + s * (1.0 / 9.0 + s * (
        -1.0 / 11.0 + s / 13.0))))))
    a = ((_PIO2_HI - a) + _PIO2_LO) if swap else a
    a = ((_PI_HI - a) + _PI_LO) if x < 0.0 else a
    return math.copysign(a, y), ok


@numba.njit(cache=True, error_model="numpy", inline="always")
def atan2(y, x):
    """``atan2(y, x)`` [rad]: :func:`atan2_core`, or libm's for a pair that is not ordinary."""
    a, ok = atan2_core(y, x)
    return a if ok else math.atan2(y, x)


# ---- sin and cos ----------------------------------------------------------------------------------
# π/2 in three parts for the reduction r = x − k π/2 (the splits of FreeBSD's e_rem_pio2.c: the first two
# have 33 significant bits, so k times either is exact for |k| < 2^20)
_PIO2_1, _PIO2_2, _PIO2_2T = 1.57079632673412561417e+00, 6.07710050630396597660e-11, 2.02226624879595063154e-21
_TWO_OVER_PI = 6.36619772367581382433e-01
# minimax coefficients of sin and cos on [−π/4, π/4] (FreeBSD's k_sin.c and k_cos.c)
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11
SINCOS_MAX = 1.0e5  # |x| beyond this is not ordinary (the reduction's k stays far below 2^20)


@numba.njit(cache=True, error_model="numpy", inline="always")
def sincos_core(x):
    """(sin x, cos x, whether x is ordinary), branch-free so that a loop over it vectorizes.

    x = k π/2 + r with k the nearest integer and |r| ≤ π/4 (π/2 carried as three floats), then the
    minimax polynomials of sin and cos in r, and the quadrant k mod 4 restored by a swap and signs
    (arithmetic, not a switch: a switch keeps a loop scalar). Ordinary: |x| ≤ :data:`SINCOS_MAX`
    (a NaN is not); for the others the values here are meaningless and the callers take libm's."""
    ok = abs(x) <= SINCOS_MAX
    xx = x if ok else 0.0
    kf = math.floor(xx * _TWO_OVER_PI + 0.5)
    n = np.int64(kf)
    r = ((xx - kf * _PIO2_1) - kf * _PIO2_2) - kf * _PIO2_2T
    z = r * r
    sr = r + r * z * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))))
    hz = 0.5 * z
    w = 1.0 - hz
    cr = w + (((1.0 - w) - hz) + z * z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6))))))
    odd = (n & 1) != 0
    s = (cr if odd else sr) * (1.0 - np.float64(n & 2))  # quadrants 2, 3: −
    c = (sr if odd else cr) * (1.0 - np.float64((n + 1) & 2))  # quadrants 1, 2: −
    return s, c, ok


@numba.njit(cache=True, error_model="numpy", inline="always")
def sincos(x):
    """(sin x, cos x): :func:`sincos_core`, or libm's for an argument that is not ordinary."""
    s, c, ok = sincos_core(x)
    if not ok:
        s, c = math.sin(x), math.cos(x)
    return s, c
