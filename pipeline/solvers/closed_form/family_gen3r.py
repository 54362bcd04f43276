"""Two decompositions whose position part is a pair of sinusoid equations: a quartic, no search.

``spherical_wrist_3r`` (code :data:`FAM_SPH3R`)
    axes 4-6 meet at the wrist centre ``c`` and joints 1-3 are a general 3R positioner (no meeting or
    parallel pair among axes 1-2, 2-3). ``E_1 E_2 E_3 c = w`` (``w = T M⁻¹ c``). Rotation about axis 2
    keeps a point's height along h2 and its distance from any point p2 of axis 2, so with
    ``x = E_3 c`` and ``y = E_1⁻¹ w``::

        h2 · (x − p2) = h2 · (y − p2),      |x − p2|² = |y − p2|²,

    each side a sinusoid of one angle (θ3 on the left, θ1 on the right): two linear equations in
    (cos θ3, sin θ3) whose right sides are affine in (cos θ1, sin θ1). Their matrix on the θ3 side
    is singular only when axes 2 and 3 meet or are parallel (its rows are h2 and the common normal
    of axes 2 and 3 seen in the plane ⟂ h3), which the family excludes. Solved for (cos θ3, sin θ3),
    cos² + sin² = 1 is a trigonometric polynomial of degree 2 in θ1: up to 4 roots (:func:`trig2_roots`,
    a quartic). θ2 by sp1, the wrist by sp2 and sp1 (:func:`~pipeline.solvers.closed_form.family_sph.sph_wrist`):
    up to 8 solutions. This is the 3R position problem that IK-Geo solves by its subproblem 5.
``three_parallel_offset`` (code :data:`FAM_3PO`)
    axes 2, 3 and 4 parallel (direction h), axes 5 and 6 neither meeting nor parallel. The rotation
    ``R_2 R_3 R_4`` about h keeps h and every point's height along h, so with ``a = R_5ᵀ h`` and
    ``N = R_goal R_Mᵀ``::

        a · h6 = (R_1 h) · (N h6),       a · d56 = h · (p1 − p5) + (R_1 h) · (p_goal − p1 − N (p_M − p6)),

    (``d56 = p6 − p5``): the same pair, θ5 on the left, θ1 on the right; singular only when axes 5
    and 6 meet or are parallel or axis 5 is parallel to h. Then θ6 by sp1 (``R_6 (Nᵀ R_1 h) = a``),
    θ2 + θ3 + θ4 by sp1 and the planar 2R by sp3 and sp1
    (:func:`~pipeline.solvers.closed_form.family_3p.p3_last`): up to 8 solutions (IK-Geo's three-parallel
    case).

A goal on which the degree-2 polynomial vanishes identically has a continuum of solutions in θ1; the
start's θ1 is taken as its representative. Where the family's skew pair all but meets or is all but
parallel (:func:`weak_pair` below :data:`POLISH_BELOW`), the pair's linear solve amplifies rounding, and
each candidate gets :data:`POLISH_STEPS` Newton steps on the whole chain (:func:`polish`) before the
FK check.

No lane pass (the batch solves these arms one goal at a time).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from pipeline.solvers.closed_form.family_3p import p3_last
from pipeline.solvers.closed_form.family_sph import keep_wrists, sph_fixed, sph_goal, sph_wrist_at
from pipeline.solvers.closed_form.subproblems import (ONE, about, any_perp, cis, cross, dot, fits, gm9, lines, mtv9,
                                                      perp, rotz, sp1d, sub, t9, wrist9)
from pipeline.solvers.kernels.kin import small_svd

FAM_SPH3R, FAM_3PO = 4, 5
REAL_TOL = 1e-6  # a root t of the quartic whose imaginary part is below this × (1 + |t|) is taken as real
                 # (a double root splits by ~sqrt(eps)); every candidate is FK-checked afterwards
NEWTON = 2       # Newton steps polishing each real root on the real quartic (after two on the complex one)


# ---- the quartic ---------------------------------------------------------------------------------------
@numba.njit(cache=True, error_model="numpy")
def _cubic_root(a2, a1, a0):
    """The root of largest magnitude of m³ + a2 m² + a1 m + a0 (complex, Cardano)."""
    P = a1 - a2 * a2 / 3.0
    Q = 2.0 * a2 * a2 * a2 / 27.0 - a2 * a1 / 3.0 + a0
    D = np.sqrt(complex(Q * Q / 4.0 + P * P * P / 27.0))
    u3 = -Q / 2.0 + D if abs(-Q / 2.0 + D) >= abs(-Q / 2.0 - D) else -Q / 2.0 - D
    best = complex(-a2 / 3.0)
    if abs(u3) == 0.0:
        return best
    u = u3 ** (1.0 / 3.0)
    w = complex(-0.5, math.sqrt(3.0) / 2.0)
    bm = -1.0
    for _ in range(3):
        y = u - P / (3.0 * u)
        m = y - a2 / 3.0
        if abs(m) > bm:
            bm, best = abs(m), m
        u = u * w
    return best


@numba.njit(cache=True, error_model="numpy")
def quartic_roots(c4, c3, c2, c1, c0, out):
    """The 4 complex roots of c4 t⁴ + c3 t³ + c2 t² + c1 t + c0 (c4 ≠ 0) into ``out`` (4,), by Ferrari's
    resolvent cubic, each polished by two Newton steps on the polynomial."""
    a, b, c, d = c3 / c4, c2 / c4, c1 / c4, c0 / c4
    p = b - 3.0 * a * a / 8.0
    q = c - a * b / 2.0 + a * a * a / 8.0
    r = d - a * c / 4.0 + a * a * b / 16.0 - 3.0 * a * a * a * a / 256.0
    scale = 1.0 + abs(p) + math.sqrt(abs(r))
    if abs(q) <= 1e-14 * scale ** 1.5:  # biquadratic
        s = np.sqrt(complex(p * p - 4.0 * r))
        y1, y2 = np.sqrt((-p + s) / 2.0), np.sqrt((-p - s) / 2.0)
        out[0], out[1], out[2], out[3] = y1, -y1, y2, -y2
    else:
        m = _cubic_root(p, p * p / 4.0 - r, -q * q / 8.0)
        s = np.sqrt(2.0 * m)
        k = q / (2.0 * s)
        e1 = np.sqrt(s * s - 4.0 * (p / 2.0 + m + k))
        e2 = np.sqrt(s * s - 4.0 * (p / 2.0 + m - k))
        out[0], out[1] = (s + e1) / 2.0, (s - e1) / 2.0
        out[2], out[3] = (-s + e2) / 2.0, (-s - e2) / 2.0
    for i in range(4):
        t = out[i] - a / 4.0
        for _ in range(2):
            f = (((t + a) * t + b) * t + c) * t + d
            df = ((4.0 * t + 3.0 * a) * t + 2.0 * b) * t + c
            if df != 0.0:
                t = t - f / df
        out[i] = t


# the 8 shifts φ tried by trig2_roots: (cos φ, sin φ), φ = −π + j π/4
_SHIFTS = tuple((math.cos(-math.pi + j * math.pi / 4.0), math.sin(-math.pi + j * math.pi / 4.0)) for j in range(8))


@numba.njit(cache=True, error_model="numpy", inline="always")
def _rotated(k, c, s):
    """The coefficients of x ↦ f(φ + x) for cos φ = c, sin φ = s (f as in :func:`trig2_roots`)."""
    c2, s2 = c * c - s * s, 2.0 * s * c
    return k[0], k[1] * c + k[2] * s, -k[1] * s + k[2] * c, k[3] * c2 + k[4] * s2, -k[3] * s2 + k[4] * c2


@numba.njit(cache=True, error_model="numpy")
def trig2_roots(k, pref, X):
    """Every real root x of f(x) = k0 + k1 cos x + k2 sin x + k3 cos 2x + k4 sin 2x, as e^{ix} into ``X``
    (complex (4,)); their count. With t = tan((x − φ)/2), (1 + t²)² f is a quartic whose leading
    coefficient is f(φ + π): φ is the one of 8 angles where |f(φ + π)| is largest, so no root is lost at
    t = ∞. A root's real part polished by Newton steps on the real quartic; e^{ix} from t without a
    sine or cosine; a root found twice kept once. When f vanishes identically (a continuum), e^{i pref}
    is the one root returned."""
    scale = abs(k[0]) + abs(k[1]) + abs(k[2]) + abs(k[3]) + abs(k[4])
    if scale == 0.0 or not math.isfinite(scale):
        X[0] = cis(pref)
        return 1 if scale == 0.0 else 0
    best, jb = -1.0, 0
    for j in range(8):  # f(φ + π) = k0 − k1' + k3' of the rotated coefficients
        r = _rotated(k, _SHIFTS[j][0], _SHIFTS[j][1])
        v = abs(r[0] - r[1] + r[3])
        if v > best:
            best, jb = v, j
    if best <= 1e-13 * scale:  # f ≈ 0 at 8 points (a polynomial of degree 2 has at most 4 roots): a continuum
        X[0] = cis(pref)
        return 1
    cp, sp_ = _SHIFTS[jb][0], _SHIFTS[jb][1]
    k0, k1, k2, k3, k4 = _rotated(k, cp, sp_)
    c4, c3, c2, c1, c0 = k0 - k1 + k3, 2.0 * k2 - 4.0 * k4, 2.0 * k0 - 6.0 * k3, 2.0 * k2 + 4.0 * k4, k0 + k1 + k3
    T = np.empty(4, np.complex128)
    quartic_roots(c4, c3, c2, c1, c0, T)
    n = 0
    for i in range(4):
        t = T[i]
        if abs(t.imag) > REAL_TOL * (1.0 + abs(t)):
            continue
        x = t.real
        for _ in range(NEWTON):
            f = (((c4 * x + c3) * x + c2) * x + c1) * x + c0
            df = ((4.0 * c4 * x + 3.0 * c3) * x + 2.0 * c2) * x + c1
            if df == 0.0 or f == 0.0:
                break
            x -= f / df
        d = 1.0 + x * x
        z = complex(cp, sp_) * complex((1.0 - x * x) / d, 2.0 * x / d)
        dup = False
        for j in range(n):
            dup |= abs(z - X[j]) < 1e-10
        if not dup:
            X[n] = z
            n += 1
    return n


@numba.njit(cache=True, error_model="numpy", inline="always")
def _pair(A, B, b):
    """A z = B z1 + b (2 × 2 each, as 4-tuples row-major; b a 2-tuple) solved for z = U z1 + u0 (U as a
    4-tuple, u0 a 2-tuple) and |z|² − 1 as the coefficients of :func:`trig2_roots` in θ1."""
    det = A[0] * A[3] - A[1] * A[2]
    i00, i01, i10, i11 = A[3] / det, -A[1] / det, -A[2] / det, A[0] / det
    U = (i00 * B[0] + i01 * B[2], i00 * B[1] + i01 * B[3], i10 * B[0] + i11 * B[2], i10 * B[1] + i11 * B[3])
    u0 = (i00 * b[0] + i01 * b[1], i10 * b[0] + i11 * b[1])
    ucc = U[0] * U[0] + U[2] * U[2]
    uss = U[1] * U[1] + U[3] * U[3]
    ucs = U[0] * U[1] + U[2] * U[3]
    k = (0.5 * (ucc + uss) + u0[0] * u0[0] + u0[1] * u0[1] - 1.0, 2.0 * (u0[0] * U[0] + u0[1] * U[2]),
         2.0 * (u0[0] * U[1] + u0[1] * U[3]), 0.5 * (ucc - uss), ucs)
    return U, u0, k


@numba.njit(cache=True, error_model="numpy", inline="always")
def _other(U, u0, z1):
    """z = U z1 + u0 normalised (its nearest unit complex)."""
    x = U[0] * z1.real + U[1] * z1.imag + u0[0]
    y = U[2] * z1.real + U[3] * z1.imag + u0[1]
    r = math.sqrt(x * x + y * y)
    return complex(x / r, y / r) if r > 0.0 else ONE


@numba.njit(cache=True, error_model="numpy", inline="always")
def _sinusoid(h, p, a):
    """(R_h(θ) a) · p = s0 + sc cos θ + ss sin θ for the unit axis h: (s0, sc, ss)."""
    return dot(h, a) * dot(h, p), dot(perp(h, a), p), dot(cross(h, a), p)


# ---- spherical wrist on a general 3R positioner -----------------------------------------------------------
@numba.njit(cache=True, error_model="numpy")
def sph3r_fixed(H, P, RM, pM):
    """What the solve needs of the arm alone: (the spherical wrist's :func:`sph_fixed` tuple, A, e): the
    θ3 side of the pair, ``A (cos θ3, sin θ3) + e = (h2 · (x − p2), |x − p2|²)``, x = E_3 c."""
    fx = sph_fixed(0, H, P, RM, pM)
    hs, ps, c = fx[0], fx[1], fx[2]
    h2, h3, p3 = hs[1], hs[2], ps[2]
    d, g23 = sub(c, p3), sub(p3, ps[1])
    a0, ac, as_ = _sinusoid(h3, h2, d)
    b0, bc, bs = _sinusoid(h3, g23, d)
    A = (ac, as_, 2.0 * bc, 2.0 * bs)
    e = (dot(h2, g23) + a0, dot(g23, g23) + dot(d, d) + 2.0 * b0)
    return fx, A, e


@numba.njit(cache=True, error_model="numpy")
def sph3r_position(fx3, w):
    """The pair's θ1 side for the wrist centre's target ``w``: (U, u0, k) of :func:`_pair`."""
    fx, A, e = fx3
    hs, ps = fx[0], fx[1]
    h1, p1, h2, p2 = hs[0], ps[0], hs[1], ps[1]
    v, g12 = sub(w, p1), sub(p1, p2)
    a0, ac, as_ = _sinusoid(h1, v, h2)
    b0, bc, bs = _sinusoid(h1, v, g12)
    B = (ac, as_, 2.0 * bc, 2.0 * bs)
    b = (dot(h2, g12) + a0 - e[0], dot(g12, g12) + dot(v, v) + 2.0 * b0 - e[1])
    return _pair(A, B, b)


@numba.njit(cache=True, error_model="numpy")
def sph3r_joints23(fx3, w, U, u0, z1, dz2):
    """(z2, z3, free) of the root z1 = e^{iθ1}: θ3 from the pair, θ2 by sp1 (``dz2`` where it is free)."""
    fx = fx3[0]
    hs, ps, c = fx[0], fx[1], fx[2]
    z3 = _other(U, u0, z1)
    x = about(hs[2], ps[2], z3, c)
    y = about(hs[0], ps[0], z1.conjugate(), w)
    z2, free = sp1d(hs[1], sub(x, ps[1]), sub(y, ps[1]), dz2)
    return z2, z3, free


@numba.njit(cache=True, error_model="numpy")
def _store(Q, n, t1, t2, t3, t4, t5, t6):
    if n < Q.shape[0]:
        Q[n, 0], Q[n, 1], Q[n, 2], Q[n, 3], Q[n, 4], Q[n, 5] = t1, t2, t3, t4, t5, t6
    return n + 1


@numba.njit(cache=True, error_model="numpy")
def solve_sph3r(H, P, RM, pM, Rg, pg, clip, pref, Q, lim):
    """Spherical wrist on a general 3R positioner: up to 8 candidates into Q (complex e^{iθ} rows); a
    branch whose joints 1-3 (then 4-5) fall outside ``lim`` (6, 2) dropped early (a 7R sweep)."""
    fx3 = sph3r_fixed(H, P, RM, pM)
    fx = fx3[0]
    w, gh6, ge6 = sph_goal(fx, t9(Rg), (pg[0], pg[1], pg[2]))
    U, u0, k = sph3r_position(fx3, w)
    X = np.empty(4, np.complex128)
    nr = trig2_roots(k, pref[0], X)
    weak = min(weak_pair(H, P, RM, pM, 0, 1), weak_pair(H, P, RM, pM, 1, 2)) < POLISH_BELOW
    n = 0
    for i in range(nr):
        t1 = X[i]
        t2, t3, free = sph3r_joints23(fx3, w, U, u0, t1, ONE)
        if free:
            t2, t3, free = sph3r_joints23(fx3, w, U, u0, t1, cis(pref[1]))
        if not (fits(t1, lim, 0) and fits(t2, lim, 1) and fits(t3, lim, 2)):
            continue
        v = sph_wrist_at(fx, gh6, ge6, t1, t2, t3, clip, pref)
        if not v[6]:
            continue
        n0 = n
        n = keep_wrists(Q, n, t1, t2, t3, v, lim)
        if weak:
            for r in range(n0, min(n, Q.shape[0])):
                _polish_row(H, P, RM, pM, Rg, pg, Q, r)
    return n


@numba.njit(cache=True, error_model="numpy")
def candidates_sph3r(case, mode, H, P, RM, pM, Rg, pg, clip, pref, samples, Q, lim6):
    """:func:`solve_sph3r` behind the families' one signature (the name ``FAMILY`` of
    :func:`pipeline.solvers.closed_form.analytic_kernels.core6`)."""
    return solve_sph3r(H, P, RM, pM, Rg, pg, clip, pref, Q, lim6)


# ---- three parallel axes, axes 5 and 6 skew ------------------------------------------------------------
@numba.njit(cache=True, error_model="numpy")
def p3o_fixed(H, P, RM, pM):
    """What the solve needs of the arm alone: ((hs, ps, s3, s4) as
    :func:`~pipeline.solvers.closed_form.family_3p.p3_last`
    reads them, A, e, e2 ⟂ h, R_M, p_M): the θ5 side of the pair, ``A (cos θ5, sin θ5) + e =
    (a · h6, a · d56)``, a = R_5ᵀ h."""
    hs, ps = lines(H, P)
    h, h5, h6 = hs[1], hs[4], hs[5]
    s3 = 1.0 if dot(hs[2], h) > 0 else -1.0
    s4 = 1.0 if dot(hs[3], h) > 0 else -1.0
    d56 = sub(ps[5], ps[4])
    a0, ac, as_ = _sinusoid(h5, h, h6)
    b0, bc, bs = _sinusoid(h5, h, d56)
    return (hs, ps, s3, s4), (ac, as_, bc, bs), (a0, b0), any_perp(h), t9(RM), (pM[0], pM[1], pM[2])


@numba.njit(cache=True, error_model="numpy")
def p3o_position(fx, g, pg):
    """The pair's θ1 side for the goal (rotation ``g`` as :func:`t9`, position ``pg``): (U, u0, k)."""
    (hs, ps, _, _), A, e, m, pMt = fx[0], fx[1], fx[2], fx[4], fx[5]
    h, h1, p1 = hs[1], hs[0], ps[0]
    n6 = gm9(g, m, hs[5])
    m2 = sub(sub(pg, p1), gm9(g, m, sub(pMt, ps[5])))
    a0, ac, as_ = _sinusoid(h1, n6, h)
    b0, bc, bs = _sinusoid(h1, m2, h)
    b = (a0 - e[0], dot(h, sub(p1, ps[4])) + b0 - e[1])
    return _pair(A, (ac, as_, bc, bs), b)


@numba.njit(cache=True, error_model="numpy")
def p3o_wrist(fx, g, pg, U, u0, z1, dz6):
    """(z5, z6, free, e^{i(θ2+θ3+θ4)}, the planar 2R's target E_2 E_3 p4, its distance from axis 2) of
    the root z1 = e^{iθ1} (``dz6`` where θ6 is free)."""
    (hs, ps, _, _), e2, m, pMt = fx[0], fx[3], fx[4], fx[5]
    h, h1, h5, h6, p1, p5, p6 = hs[1], hs[0], hs[4], hs[5], ps[0], ps[4], ps[5]
    z5 = _other(U, u0, z1)
    a = rotz(h5, z5.conjugate(), h)
    v = mtv9(g, rotz(h1, z1, h))  # N^T R1 h = R_M R_goal^T R1 h
    v = (m[0] * v[0] + m[1] * v[1] + m[2] * v[2], m[3] * v[0] + m[4] * v[1] + m[5] * v[2],
         m[6] * v[0] + m[7] * v[1] + m[8] * v[2])
    z6, free = sp1d(h6, v, a, dz6)
    # R234 e2 = R1^T N R6^T R5^T e2
    y = rotz(h6, z6.conjugate(), rotz(h5, z5.conjugate(), e2))
    t234 = sp1d(h, e2, rotz(h1, z1.conjugate(), gm9(g, m, y)), ONE)[0]
    # E2 E3 p4 = E1^-1 T M^-1 E6^-1 E5^-1 p4 (E4 keeps p4)
    x = about(h6, p6, z6.conjugate(), about(h5, p5, z5.conjugate(), ps[3]))
    tgt = about(h1, p1, z1.conjugate(), wrist9(g, pg, m, pMt, x))
    dw = perp(h, sub(tgt, ps[1]))
    return z5, z6, free, t234, tgt, math.sqrt(dot(dw, dw))


@numba.njit(cache=True, error_model="numpy")
def solve_3po(H, P, RM, pM, Rg, pg, clip, pref, Q):
    """Three parallel axes (2-4), axes 5 and 6 skew: up to 8 candidates into Q."""
    fx = p3o_fixed(H, P, RM, pM)
    g, pgt = t9(Rg), (pg[0], pg[1], pg[2])
    U, u0, k = p3o_position(fx, g, pgt)
    X = np.empty(4, np.complex128)
    nr = trig2_roots(k, pref[0], X)
    h, h5 = (H[1, 0], H[1, 1], H[1, 2]), (H[4, 0], H[4, 1], H[4, 2])
    c = cross(h, h5)
    weak = min(weak_pair(H, P, RM, pM, 4, 5), math.sqrt(dot(c, c))) < POLISH_BELOW
    n = 0
    for i in range(nr):
        t1 = X[i]
        r = p3o_wrist(fx, g, pgt, U, u0, t1, ONE)
        if r[2]:
            r = p3o_wrist(fx, g, pgt, U, u0, t1, cis(pref[5]))
        t5, t6, t234, tgt, dd = r[0], r[1], r[3], r[4], r[5]
        for ic in range(2):
            d2 = ONE
            for _ in range(2):
                v = p3_last(fx[0], t234, tgt, dd, 1.0 - 2.0 * ic, clip, d2)
                if not v[4]:
                    break
                d2 = cis(pref[1])
            if v[3]:
                n = _store(Q, n, t1, v[0], v[1], v[2], t5, t6)
                if weak and n <= Q.shape[0]:
                    _polish_row(H, P, RM, pM, Rg, pg, Q, n - 1)
    return n


@numba.njit(cache=True, error_model="numpy")
def candidates_3po(case, mode, H, P, RM, pM, Rg, pg, clip, pref, samples, Q, lim6):
    """:func:`solve_3po` behind the families' one signature."""
    return solve_3po(H, P, RM, pM, Rg, pg, clip, pref, Q)


# ---- Newton polish where the pair's linear solve is ill-conditioned ------------------------------------
POLISH_BELOW = 1e-2  # a skew pair whose closest distance / scale times its angle's sine is below this: polish
POLISH_STEPS = 2     # Newton steps on the whole chain for each candidate of such an arm


@numba.njit(cache=True, error_model="numpy")
def weak_pair(H, P, RM, pM, i, j):
    """Closest distance of lines i and j times the sine of their angle, over the arm's length scale
    (its joint points and tool point in a row): small when the pair all but meets or is all but parallel,
    where the linear solve of the pair amplifies rounding by about its inverse."""
    hi, hj = (H[i, 0], H[i, 1], H[i, 2]), (H[j, 0], H[j, 1], H[j, 2])
    c = cross(hi, hj)
    s = math.sqrt(dot(c, c))
    r = (P[j, 0] - P[i, 0], P[j, 1] - P[i, 1], P[j, 2] - P[i, 2])
    dist = abs(dot(r, c)) / s if s > 0.0 else 0.0
    scale = 0.0
    for k in range(H.shape[0]):
        nxt = (pM[0], pM[1], pM[2]) if k == H.shape[0] - 1 else (P[k + 1, 0], P[k + 1, 1], P[k + 1, 2])
        d = sub(nxt, (P[k, 0], P[k, 1], P[k, 2]))
        scale += math.sqrt(dot(d, d))
    return dist * s / scale if scale > 0.0 else 0.0


@numba.njit(cache=True, error_model="numpy")
def _solve6(J, e, x):
    """x = J⁻¹ e (J (6, 6), e and x (6,)) through the kernels' small SVD
    (:func:`pipeline.solvers.kernels.kin.small_svd`): ``x = V S⁻¹ Uᵀ e``; False when J is singular
    (its smallest singular value below 1e-14 of its largest)."""
    U, S, Vt = small_svd(J)
    if not S[5] > 1e-14 * S[0]:
        return False
    x[:] = np.dot(np.dot(e, U) / S, Vt)  # (Uᵀ e / S) · Vt = V S⁻¹ Uᵀ e
    return True


@numba.njit(cache=True, error_model="numpy")
def polish(H, P, RM, pM, Rg, pg, Q, r, J, e, x):
    """Newton steps on the whole chain for candidate row ``r`` of Q (e^{iθ} (16, 6)): the pose error
    (position, and the rotation's small-angle vector) against the goal solved with the spatial Jacobian
    of the joint lines. ``J`` (6, 6), ``e`` and ``x`` (6,): scratch."""
    for _ in range(POLISH_STEPS):
        Ra = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
        ta = (0.0, 0.0, 0.0)
        for i in range(6):
            w = (Ra[0] * H[i, 0] + Ra[1] * H[i, 1] + Ra[2] * H[i, 2],
                 Ra[3] * H[i, 0] + Ra[4] * H[i, 1] + Ra[5] * H[i, 2],
                 Ra[6] * H[i, 0] + Ra[7] * H[i, 1] + Ra[8] * H[i, 2])
            q = (Ra[0] * P[i, 0] + Ra[1] * P[i, 1] + Ra[2] * P[i, 2] + ta[0],
                 Ra[3] * P[i, 0] + Ra[4] * P[i, 1] + Ra[5] * P[i, 2] + ta[1],
                 Ra[6] * P[i, 0] + Ra[7] * P[i, 1] + Ra[8] * P[i, 2] + ta[2])
            J[0, i], J[1, i], J[2, i] = q[0], q[1], q[2]  # the joint's point for now, its lever arm below
            J[3, i], J[4, i], J[5, i] = w[0], w[1], w[2]
            # acc <- acc E_i: the columns of Ra turned about w through q
            z = Q[r, i]
            c0 = rotz(w, z, (Ra[0], Ra[3], Ra[6]))
            c1 = rotz(w, z, (Ra[1], Ra[4], Ra[7]))
            c2 = rotz(w, z, (Ra[2], Ra[5], Ra[8]))
            ta = about(w, q, z, ta)
            Ra = (c0[0], c1[0], c2[0], c0[1], c1[1], c2[1], c0[2], c1[2], c2[2])
        pe = (Ra[0] * pM[0] + Ra[1] * pM[1] + Ra[2] * pM[2] + ta[0],
              Ra[3] * pM[0] + Ra[4] * pM[1] + Ra[5] * pM[2] + ta[1],
              Ra[6] * pM[0] + Ra[7] * pM[1] + Ra[8] * pM[2] + ta[2])
        for i in range(6):
            lever = cross((J[3, i], J[4, i], J[5, i]), sub(pe, (J[0, i], J[1, i], J[2, i])))
            J[0, i], J[1, i], J[2, i] = lever[0], lever[1], lever[2]
        # R = Ra RM; rotation error: half the vee of Rg Rᵀ − R Rgᵀ
        D = np.zeros((3, 3))
        for a in range(3):
            for b in range(3):
                s = 0.0
                for k in range(3):
                    rak = Ra[3 * a] * RM[0, k] + Ra[3 * a + 1] * RM[1, k] + Ra[3 * a + 2] * RM[2, k]
                    rbk = Ra[3 * b] * RM[0, k] + Ra[3 * b + 1] * RM[1, k] + Ra[3 * b + 2] * RM[2, k]
                    s += Rg[a, k] * rbk - rak * Rg[b, k]
                D[a, b] = s
        e[0], e[1], e[2] = pg[0] - pe[0], pg[1] - pe[1], pg[2] - pe[2]
        e[3], e[4], e[5] = 0.25 * (D[2, 1] - D[1, 2]), 0.25 * (D[0, 2] - D[2, 0]), 0.25 * (D[1, 0] - D[0, 1])
        if not _solve6(J, e, x):
            return
        for i in range(6):
            Q[r, i] = Q[r, i] * complex(math.cos(x[i]), math.sin(x[i]))


@numba.njit(cache=True, error_model="numpy")
def _polish_row(H, P, RM, pM, Rg, pg, Q, r):
    """:func:`polish` of row r with its own scratch (an ill-conditioned arm only)."""
    polish(H, P, RM, pM, Rg, pg, Q, r, np.empty((6, 6)), np.empty(6), np.empty(6))
