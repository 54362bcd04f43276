"""Compiled Paden-Kahan subproblems and the closed-form families built on them.

Pure numerics (numba, no allocation in the hot path): vectors are 3-tuples of floats, an arm is
its joint lines at the zero pose (:mod:`pipeline.kinematics.geometry`): directions ``H`` (6, 3),
points ``P`` (6, 3) and the tool pose ``M`` (rotation ``RM`` (3, 3), position ``pM`` (3,)), so
``T(q) = E_1(q_1) ... E_6(q_6) M`` with ``E_i`` the rotation by ``q_i`` about line i.

Angles are unit complex numbers ``z = e^{iθ}`` (``cis``) everywhere inside: a rotation takes
``z.real``, ``z.imag`` as its cosine and sine, a subproblem returns a normalised vector pair or an
``acos`` branch as a product of unit complex numbers, and −θ is ``z.conjugate()``. No sine, cosine
or arctangent is evaluated inside the closed forms; the caller turns solutions into angles (one
``atan2`` per joint) and checks them by FK from the same cosines and sines.

Subproblems (written from their definitions: Paden 1985; the forms of IK-Geo, Elias & Wen 2022):

``sp1(k, p, q, d)``          e^{iθ} with ``rot(k, θ) p = q`` (least squares: the projections on the
                             plane ⟂ k); e^{i d} when p or q lies on the axis
``sp2pair(ka, kb, u, v, ..)`` both (e^{iθa}, e^{iθb}) with ``u = rot(ka, θa) rot(kb, θb) v`` (|u| = |v|)
``sp3(k, p, q, d, s, ..)``   e^{iθ} with ``|rot(k, θ) p − q| = d`` (in the plane ⟂ k when ``planar``),
                             branch s = ±1
``sp4(h, k, p, d, s, ..)``   e^{iθ} with ``h · rot(k, θ) p = d``, branch s = ±1

Every "± acos" is clipped when its argument is beyond ±1 by at most ``clip`` (a rounding at a
boundary: the stretched elbow, a wrist on its cylinder) and is invalid beyond.

Families (codes :data:`FAM_SPH`, :data:`FAM_3P`, :data:`FAM_SEARCH`; position cases 1-4 as
:data:`pipeline.kinematics.geometry.POSITION_CASES`):

spherical wrist
    wrist centre ``c`` (axes 4-6 meet), ``w = T M⁻¹ c = E_1 E_2 E_3 c`` solved by the position case
    (2 × 2 branches), then ``R_4 R_5 R_6 = (R_1 R_2 R_3)ᵀ R_goal R_Mᵀ`` by sp2 (2 branches) and sp1.
three parallel
    axes 2-4 parallel, 5-6 meet at ``c``: θ1 by sp4 (the component of ``E_1⁻¹ w`` along h2 is fixed),
    (θ5, θ6) by sp2 from ``h2ᵀ N = h2ᵀ R_5 R_6``, θ2 + θ3 + θ4 by sp1, then the planar 2R by
    sp3 and sp1.
two intersecting, searched
    mode 4: axes 5-6 meet at ``c``; for each θ4 on a grid, ``E_1 E_2 E_3 (E_4 c) = w`` by the
    position case (4 branches), residual ``h5 · (R_1 R_2 R_3 R_4)ᵀ g − h5 · h6`` with
    ``g = R_goal R_Mᵀ h6`` (zero exactly when ``R_5 R_6`` can make the remaining rotation); mode 6:
    axes 4-5 meet, θ6 searched, the same with the roles turned. Sign changes along each branch are
    bracketed (also up to the grid point where a branch stops existing, whose edge is found by
    bisection), a cell where the branch's joints 1-3 turn fast is sampled 8 times finer, a dip of
    |f| between grid points is searched by golden section (a close pair of roots), and each bracket
    is refined by regula falsi (Illinois); the last two angles then by sp1.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from pipeline.kinematics.vmath import atan2_core as _atan2_core
from pipeline.solvers.kernels.kin import LIMIT_TOL

FAM_SPH, FAM_3P, FAM_SEARCH = 1, 2, 3
MAX_SOL = 16


# ---- 3-vectors as tuples ------------------------------------------------------------------------
@numba.njit(cache=True, error_model="numpy", inline="always")
def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@numba.njit(cache=True, error_model="numpy", inline="always")
def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@numba.njit(cache=True, error_model="numpy", inline="always")
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@numba.njit(cache=True, error_model="numpy", inline="always")
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@numba.njit(cache=True, error_model="numpy", inline="always")
def scl(s, a):
    return (s * a[0], s * a[1], s * a[2])


@numba.njit(cache=True, error_model="numpy", inline="always")
def perp(k, a):
    """``a`` minus its component along the unit vector ``k``."""
    t = dot(k, a)
    return (a[0] - t * k[0], a[1] - t * k[1], a[2] - t * k[2])


@numba.njit(cache=True, error_model="numpy", inline="always")
def rot(k, c, s, v):
    """``rot(k, θ) v`` at cos θ = c, sin θ = s (Rodrigues)."""
    kv = cross(k, v)
    t = dot(k, v) * (1.0 - c)
    return (c * v[0] + s * kv[0] + t * k[0], c * v[1] + s * kv[1] + t * k[1], c * v[2] + s * kv[2] + t * k[2])


@numba.njit(cache=True, error_model="numpy", inline="always")
def rotz(k, z, v):
    """``rot(k, θ) v`` for the unit complex ``z = e^{iθ}``."""
    return rot(k, z.real, z.imag, v)


@numba.njit(cache=True, error_model="numpy", inline="always")
def cis(t):
    """``e^{it}`` (an angle as the unit complex the subproblems compute with)."""
    return complex(math.cos(t), math.sin(t))


@numba.njit(cache=True, error_model="numpy", inline="always")
def row(A, i):
    return (A[i, 0], A[i, 1], A[i, 2])


@numba.njit(cache=True, error_model="numpy", inline="always")
def matTvec(R, v):
    """``Rᵀ v`` for the rotation block of a 3 × 3 or 4 × 4 array."""
    return (R[0, 0] * v[0] + R[1, 0] * v[1] + R[2, 0] * v[2],
            R[0, 1] * v[0] + R[1, 1] * v[1] + R[2, 1] * v[2],
            R[0, 2] * v[0] + R[1, 2] * v[1] + R[2, 2] * v[2])


@numba.njit(cache=True, error_model="numpy")
def any_perp(k):
    """A unit vector ⟂ the unit vector ``k``."""
    if abs(k[0]) < 0.9:
        a = cross(k, (1.0, 0.0, 0.0))
    else:
        a = cross(k, (0.0, 1.0, 0.0))
    n = math.sqrt(dot(a, a))
    return scl(1.0 / n, a)


# ---- angles -------------------------------------------------------------------------------------
@numba.njit(cache=True, error_model="numpy")
def angles_of(Y, X, A, m):
    """``A[i] = atan2(Y[i], X[i])`` [rad] for i < m, within a few units in the last place of libm's:
    one branch-free pass of :func:`_atan2_core` the compiler vectorizes (a closed form turns up to 96
    cosines and sines a pose into angles; about six times faster than one scalar call each), then
    ``math.atan2`` itself for the pairs that are not ordinary (zeros, infinities, NaN)."""
    special = 0
    for i in range(m):
        a, ok = _atan2_core(Y[i], X[i])
        A[i] = a
        special += not ok
    if special:
        for i in range(m):
            if not _atan2_core(Y[i], X[i])[1]:
                A[i] = math.atan2(Y[i], X[i])


# ---- subproblems --------------------------------------------------------------------------------
ONE = complex(1.0, 0.0)


@numba.njit(cache=True, error_model="numpy")
def sp1d(k, p, q, dz):
    """(e^{iθ} with rot(k, θ) p = q in the plane ⟂ k, or ``dz`` when p or q lies on the axis; whether it
    did). Branch-free: the same floats in a vector lane as in a scalar call."""
    pp = perp(k, p)
    qp = perp(k, q)
    x = dot(pp, qp)
    y = dot(k, cross(pp, qp))
    r2 = x * x + y * y
    deg = r2 < 1e-28 * (dot(p, p) * dot(q, q) + 1e-300)
    r = math.sqrt(r2)
    z = complex(x / r, y / r)
    return (dz if deg else z), deg


@numba.njit(cache=True, error_model="numpy")
def sp1(k, p, q, default):
    """e^{iθ} with rot(k, θ) p = q in the plane ⟂ k; e^{i default} (``default`` an angle [rad]) when p
    or q lies on the axis (its sine and cosine taken only then)."""
    z, deg = sp1d(k, p, q, ONE)
    if deg:
        return cis(default)
    return z


@numba.njit(cache=True, error_model="numpy")
def acos_branch(x, y, D, s, clip):
    """e^{iθ} with x cos θ + y sin θ = D, branch s = ±1 (θ = atan2(y, x) ± acos(D / ρ)), and validity
    (the cosine clipped within ``clip`` of ±1); (1, False) when invalid. Branch-free (selects), so it
    runs in vector lanes (:mod:`pipeline.solvers.closed_form.lanes`) with the floats of a scalar call."""
    rho = math.sqrt(x * x + y * y)
    c = D / rho
    bad = (rho <= 0.0) | (c > 1.0 + clip) | (c < -1.0 - clip)
    c = 1.0 if c > 1.0 else c
    c = -1.0 if c < -1.0 else c
    sa = s * math.sqrt(max(0.0, 1.0 - c * c))
    z = complex(x / rho, y / rho) * complex(c, sa)
    return (ONE if bad else z), not bad


@numba.njit(cache=True, error_model="numpy")
def sp4(h, k, p, d, s, clip):
    """e^{iθ} with h · rot(k, θ) p = d (branch s = ±1)."""
    return acos_branch(dot(h, perp(k, p)), dot(h, cross(k, p)), d - dot(h, k) * dot(k, p), s, clip)


@numba.njit(cache=True, error_model="numpy")
def sp3(k, p, q, d, s, clip, planar):
    """e^{iθ} with |rot(k, θ) p − q| = d (in the plane ⟂ k when ``planar``), branch s = ±1."""
    pp = perp(k, p)
    qp = perp(k, q)
    dz = dot(k, p) - dot(k, q)
    extra = 0.0 if planar else dz * dz
    D = 0.5 * (dot(pp, pp) + dot(qp, qp) + extra - d * d)
    return acos_branch(dot(pp, qp), dot(cross(k, pp), qp), D, s, clip)


@numba.njit(cache=True, error_model="numpy")
def sp2paird(ka, kb, u, v, clip, dza):
    """(za+, zb+, za−, zb−, ok, free) = both branches of e^{iθa}, e^{iθb} with u = rot(ka, θa) rot(kb, θb) v
    (|u| = |v|); where θa is free (u on ka) ``za = dza.conjugate()`` and ``free`` is set (θb free: 0).
    Branch-free: the same floats in a vector lane as in a scalar call; ones when not ``ok``."""
    c = dot(ka, kb)
    den = 1.0 - c * c
    a1 = dot(ka, u)
    a2 = dot(kb, v)
    al = (a1 - c * a2) / den
    be = (a2 - c * a1) / den
    n = cross(ka, kb)
    y0 = add(scl(al, ka), scl(be, kb))
    g2 = (dot(u, u) - dot(y0, y0)) / den
    scale = dot(u, u) + 1e-300
    bad = g2 < -clip * scale
    g2 = 0.0 if g2 < 0.0 else g2
    g = math.sqrt(g2)
    yp = add(y0, scl(g, n))
    ym = add(y0, scl(-g, n))
    ap, fp = sp1d(ka, u, yp, dza)
    am, fm = sp1d(ka, u, ym, dza)
    bp = sp1d(kb, v, yp, ONE)[0]  # θb's default: e^{i0}
    bm = sp1d(kb, v, ym, ONE)[0]
    if bad:
        return ONE, ONE, ONE, ONE, False, False
    return ap.conjugate(), bp, am.conjugate(), bm, True, fp | fm


@numba.njit(cache=True, error_model="numpy")
def sp2pair(ka, kb, u, v, clip, def_a):
    """(za, zb) = (e^{iθa}, e^{iθb}) with u = rot(ka, θa) rot(kb, θb) v (|u| = |v|), both branches:
    (za+, zb+, za−, zb−, ok); ``def_a`` [rad] for θa when it is free (its sine and cosine taken only then)."""
    r = sp2paird(ka, kb, u, v, clip, ONE)
    if r[5]:
        r = sp2paird(ka, kb, u, v, clip, cis(-def_a))
    return r[0], r[1], r[2], r[3], r[4]


# ---- lines ------------------------------------------------------------------------------------------
@numba.njit(cache=True, error_model="numpy")
def meet_point(h1, p1, h2, p2):
    """Midpoint of the common normal of two non-parallel lines."""
    r = sub(p2, p1)
    b = dot(h1, h2)
    d1 = dot(h1, r)
    d2 = dot(h2, r)
    den = 1.0 - b * b
    t1 = (d1 - b * d2) / den
    t2 = (b * d1 - d2) / den
    return scl(0.5, add(add(p1, scl(t1, h1)), add(p2, scl(t2, h2))))


# ---- position of a point by joints 1-3 ----------------------------------------------------------
# Each stage below is branch-free (selects, no early return, no libm call), and reads the arm as tuples
# of floats: the same function runs in a scalar call and in a vector lane of the batch
# (:mod:`pipeline.solvers.closed_form.lanes`), so both give the same floats. A stage takes the e^{iθ} an angle
# gets where it is free (``dz``) and reports whether that was used (``free``): the scalar callers call
# it with ``ONE`` and again with the true default only then (its sine and cosine only then).
@numba.njit(cache=True, error_model="numpy", inline="always")
def lines(H, P):
    """The 6 joint lines as tuples: ((h_1 .. h_6), (p_1 .. p_6))."""
    return ((row(H, 0), row(H, 1), row(H, 2), row(H, 3), row(H, 4), row(H, 5)),
            (row(P, 0), row(P, 1), row(P, 2), row(P, 3), row(P, 4), row(P, 5)))


@numba.njit(cache=True, error_model="numpy", inline="always")
def about(h, p, z, x):
    """``p + rot(h, θ) (x − p)``: x turned by e^{iθ} = ``z`` about the line (h, p)."""
    return add(p, rotz(h, z, sub(x, p)))


@numba.njit(cache=True, error_model="numpy")
def pos_case1(hs, ps, o, x, w, sa, clip, dz):
    """Position case 1 (axes 1-2 meet at ``o``) as one branch-free stage: see :func:`pos3d`."""
    h1, h2, h3, p3 = hs[0], hs[1], hs[2], ps[2]
    d = math.sqrt(dot(sub(w, o), sub(w, o)))
    t3, ok = sp3(h3, sub(x, p3), sub(o, p3), d, sa, clip, False)
    x3 = about(h3, p3, t3, x)
    a1, a2, b1, b2, ok2, f = sp2paird(h1, h2, sub(w, o), sub(x3, o), clip, dz)
    ok = ok & ok2
    return a1, a2, t3, ok, b1, b2, t3, ok, f & ok


@numba.njit(cache=True, error_model="numpy")
def pos_case2(hs, ps, o, x, w, sa, clip, dz):
    """Position case 2 (axes 2-3 meet at ``o``): see :func:`pos3d`."""
    h1, h2, h3, p1 = hs[0], hs[1], hs[2], ps[0]
    d = math.sqrt(dot(sub(x, o), sub(x, o)))
    tm, ok = sp3(h1, sub(w, p1), sub(o, p1), d, sa, clip, False)
    t1 = tm.conjugate()
    w1 = about(h1, p1, t1.conjugate(), w)
    a2, a3, b2, b3, ok2, f = sp2paird(h2, h3, sub(w1, o), sub(x, o), clip, dz)
    ok = ok & ok2
    return t1, a2, a3, ok, t1, b2, b3, ok, f & ok


@numba.njit(cache=True, error_model="numpy")
def planar2(ha, pa, hb, pb, x, tgt, ok, clip, dz):
    """The 2R of two parallel joints a, b (lines (ha, pa), (hb, pb)) turning x onto tgt: θb by sp3 (the
    distance of x from axis a), both branches, then θa by sp1: (za, zb, ok) for branch +1, the same for
    −1, free (a valid branch took ``dz`` for θa); ``ok`` the earlier stage's."""
    dw = perp(ha, sub(tgt, pa))
    dd = math.sqrt(dot(dw, dw))
    tba, oka = sp3(hb, sub(x, pb), sub(pa, pb), dd, 1.0, clip, True)
    tbb, okb = sp3(hb, sub(x, pb), sub(pa, pb), dd, -1.0, clip, True)
    taa, fa = sp1d(ha, sub(about(hb, pb, tba, x), pa), sub(tgt, pa), dz)
    tab, fb = sp1d(ha, sub(about(hb, pb, tbb, x), pa), sub(tgt, pa), dz)
    oka, okb = ok & oka, ok & okb
    return taa, tba, oka, tab, tbb, okb, (fa & oka) | (fb & okb)


@numba.njit(cache=True, error_model="numpy")
def pos_case3(hs, ps, o, x, w, sa, clip, dz):
    """Position case 3 (axes 1 ∥ 2): see :func:`pos3d`."""
    h1, h2, h3 = hs[0], hs[1], hs[2]
    p1, p2, p3 = ps[0], ps[1], ps[2]
    t3, ok = sp4(h1, h3, sub(x, p3), dot(h1, w) - dot(h1, p3), sa, clip)
    t1a, t2a, oka, t1b, t2b, okb, f = planar2(h1, p1, h2, p2, about(h3, p3, t3, x), w, ok, clip, dz)
    return t1a, t2a, t3, oka, t1b, t2b, t3, okb, f


@numba.njit(cache=True, error_model="numpy")
def pos_case4(hs, ps, o, x, w, sa, clip, dz):
    """Position case 4 (axes 2 ∥ 3): see :func:`pos3d`."""
    h1, h2, h3 = hs[0], hs[1], hs[2]
    p1, p2, p3 = ps[0], ps[1], ps[2]
    tm, ok = sp4(h2, h1, sub(w, p1), dot(h2, x) - dot(h2, p1), sa, clip)
    t1 = tm.conjugate()
    t2a, t3a, oka, t2b, t3b, okb, f = planar2(h2, p2, h3, p3, x, about(h1, p1, t1.conjugate(), w), ok, clip, dz)
    return t1, t2a, t3a, oka, t1, t2b, t3b, okb, f


@numba.njit(cache=True, error_model="numpy")
def pos3d(case, hs, ps, o, x, w, sa, clip, dz):
    """Joints 1-3 placing x at w, for position case ``case``, as one branch-free stage
    (:func:`pos_case1` .. :func:`pos_case4`): (z1, z2, z3, ok) for the second-stage branch +1, the same
    for −1, then ``free`` (a valid branch took ``dz`` for its free angle: θ1 in cases 1 and 3, θ2 in 2
    and 4)."""
    if case == 1:
        return pos_case1(hs, ps, o, x, w, sa, clip, dz)
    if case == 2:
        return pos_case2(hs, ps, o, x, w, sa, clip, dz)
    if case == 3:
        return pos_case3(hs, ps, o, x, w, sa, clip, dz)
    return pos_case4(hs, ps, o, x, w, sa, clip, dz)


@numba.njit(cache=True, error_model="numpy")
def pos3d_call(case, hs, ps, o, x, w, sa, clip, dz):
    """:func:`pos3d` as a call (for the rare second pass: not inlined twice)."""
    return pos3d(case, hs, ps, o, x, w, sa, clip, dz)


@numba.njit(cache=True, error_model="numpy")
def pos_default(case, pref):
    """e^{iθ} of the angle :func:`pos3d` takes where one is free: −θ1 (case 1, conjugated inside sp2),
    −θ2 (2), θ1 (3), θ2 (4), θ from ``pref`` [rad]."""
    if case == 1:
        return cis(-pref[0])
    if case == 2:
        return cis(-pref[1])
    if case == 3:
        return cis(pref[0])
    return cis(pref[1])


@numba.njit(cache=True, error_model="numpy")
def pos3pair(case, H, P, o, x, w, sa, clip, pref):
    """(z1, z2, z3) = e^{iθ} of joints 1-3 with E_1 E_2 E_3 x = w, for position case ``case`` (1: axes
    1-2 meet at ``o``; 2: 2-3 meet at ``o``; 3: 1 ∥ 2; 4: 2 ∥ 3): the first stage on branch ``sa``,
    both second-stage branches: (z1, z2, z3, ok) for +1, then for −1. ``pref`` [rad] the angles used
    where one is free. The search's form of :func:`pos3d` (the same floats): it meets many goals
    where a branch does not exist, and returns as soon as one fails (1.5 times faster there than the
    branch-free stages, which compute every branch)."""
    h1, h2, h3 = row(H, 0), row(H, 1), row(H, 2)
    p1, p2, p3 = row(P, 0), row(P, 1), row(P, 2)
    z = (ONE, ONE, ONE, False, ONE, ONE, ONE, False)
    if case == 1:
        d = math.sqrt(dot(sub(w, o), sub(w, o)))
        t3, ok = sp3(h3, sub(x, p3), sub(o, p3), d, sa, clip, False)
        if not ok:
            return z
        x3 = about(h3, p3, t3, x)
        a1, a2, b1, b2, ok = sp2pair(h1, h2, sub(w, o), sub(x3, o), clip, pref[0])
        return a1, a2, t3, ok, b1, b2, t3, ok
    if case == 2:
        d = math.sqrt(dot(sub(x, o), sub(x, o)))
        tm, ok = sp3(h1, sub(w, p1), sub(o, p1), d, sa, clip, False)
        if not ok:
            return z
        t1 = tm.conjugate()
        w1 = about(h1, p1, t1.conjugate(), w)
        a2, a3, b2, b3, ok = sp2pair(h2, h3, sub(w1, o), sub(x, o), clip, pref[1])
        return t1, a2, a3, ok, t1, b2, b3, ok
    if case == 3:
        t3, ok = sp4(h1, h3, sub(x, p3), dot(h1, w) - dot(h1, p3), sa, clip)
        if not ok:
            return z
        x3 = about(h3, p3, t3, x)
        dw = perp(h1, sub(w, p1))
        dd = math.sqrt(dot(dw, dw))
        t2a, oka = sp3(h2, sub(x3, p2), sub(p1, p2), dd, 1.0, clip, True)
        t2b, okb = sp3(h2, sub(x3, p2), sub(p1, p2), dd, -1.0, clip, True)
        t1a = sp1(h1, sub(about(h2, p2, t2a, x3), p1), sub(w, p1), pref[0]) if oka else ONE
        t1b = sp1(h1, sub(about(h2, p2, t2b, x3), p1), sub(w, p1), pref[0]) if okb else ONE
        return t1a, t2a, t3, oka, t1b, t2b, t3, okb
    tm, ok = sp4(h2, h1, sub(w, p1), dot(h2, x) - dot(h2, p1), sa, clip)
    if not ok:
        return z
    t1 = tm.conjugate()
    w1 = about(h1, p1, t1.conjugate(), w)
    dw = perp(h2, sub(w1, p2))
    dd = math.sqrt(dot(dw, dw))
    t3a, oka = sp3(h3, sub(x, p3), sub(p2, p3), dd, 1.0, clip, True)
    t3b, okb = sp3(h3, sub(x, p3), sub(p2, p3), dd, -1.0, clip, True)
    t2a = sp1(h2, sub(about(h3, p3, t3a, x), p2), sub(w1, p2), pref[1]) if oka else ONE
    t2b = sp1(h2, sub(about(h3, p3, t3b, x), p2), sub(w1, p2), pref[1]) if okb else ONE
    return t1, t2a, t3a, oka, t1, t2b, t3b, okb


@numba.njit(cache=True, error_model="numpy")
def case_point(case, H, P):
    """The meeting point the position case needs (zeros when it needs none)."""
    if case == 1:
        return meet_point(row(H, 0), row(P, 0), row(H, 1), row(P, 1))
    if case == 2:
        return meet_point(row(H, 1), row(P, 1), row(H, 2), row(P, 2))
    return (0.0, 0.0, 0.0)


@numba.njit(cache=True, error_model="numpy", inline="always")
def t9(R):
    """The rotation block of a 3 × 3 or 4 × 4 array as 9 floats, row-major."""
    return (R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1], R[2, 2])


@numba.njit(cache=True, error_model="numpy", inline="always")
def mv9(m, v):
    """``R v`` for R as 9 floats (:func:`t9`)."""
    return (m[0] * v[0] + m[1] * v[1] + m[2] * v[2],
            m[3] * v[0] + m[4] * v[1] + m[5] * v[2],
            m[6] * v[0] + m[7] * v[1] + m[8] * v[2])


@numba.njit(cache=True, error_model="numpy", inline="always")
def mtv9(m, v):
    """``Rᵀ v`` for R as 9 floats (:func:`t9`)."""
    return (m[0] * v[0] + m[3] * v[1] + m[6] * v[2],
            m[1] * v[0] + m[4] * v[1] + m[7] * v[2],
            m[2] * v[0] + m[5] * v[1] + m[8] * v[2])


@numba.njit(cache=True, error_model="numpy", inline="always")
def gm9(g, m, v):
    """``R_goal R_Mᵀ v`` with both rotations as 9 floats (:func:`t9`)."""
    return mv9(g, mtv9(m, v))


@numba.njit(cache=True, error_model="numpy", inline="always")
def gm(Rg, RM, v):
    """``R_goal R_Mᵀ v`` (``Rg`` may be the 4 × 4 goal: only its rotation block is read)."""
    return gm9(t9(Rg), t9(RM), v)


@numba.njit(cache=True, error_model="numpy", inline="always")
def back3t(hs, z1, z2, z3, v):
    """``(R_1 R_2 R_3)ᵀ v`` (``hs`` the joint directions as tuples)."""
    v = rotz(hs[0], z1.conjugate(), v)
    v = rotz(hs[1], z2.conjugate(), v)
    return rotz(hs[2], z3.conjugate(), v)


@numba.njit(cache=True, error_model="numpy")
def back3(H, z1, z2, z3, v):
    """``(R_1 R_2 R_3)ᵀ v``."""
    return back3t((row(H, 0), row(H, 1), row(H, 2)), z1, z2, z3, v)


@numba.njit(cache=True, error_model="numpy")
def wrist9(g, pg, m, pM, c):
    """w = T M⁻¹ c with the rotations as 9 floats (:func:`t9`), ``pg`` and ``pM`` 3-tuples."""
    local = mtv9(m, sub(c, pM))
    return (g[0] * local[0] + g[1] * local[1] + g[2] * local[2] + pg[0],
            g[3] * local[0] + g[4] * local[1] + g[5] * local[2] + pg[1],
            g[6] * local[0] + g[7] * local[1] + g[8] * local[2] + pg[2])


@numba.njit(cache=True, error_model="numpy")
def wrist_target(Rg, pg, RM, pM, c):
    """w = T M⁻¹ c."""
    return wrist9(t9(Rg), (pg[0], pg[1], pg[2]), t9(RM), (pM[0], pM[1], pM[2]), c)


# ---- the families ---------------------------------------------------------------------------------
@numba.njit(cache=True, error_model="numpy")
def wrap(x):
    """Angle wrapped to (-π, π]."""
    if -3.0 < x < 3.0:  # the formula below returns x itself here (floor of a value in (0, 1)); skip it
        return x
    y = x - 2.0 * math.pi * math.floor((x + math.pi) / (2.0 * math.pi))
    if y <= -math.pi:
        return y + 2.0 * math.pi
    return y


@numba.njit(cache=True, error_model="numpy", inline="always")
def into_limits(x, lo, hi):
    """(x moved by 2π multiples into [lo, hi] where that fits, else x; whether the result lies within
    the limits up to the one joint-limit tolerance ``LIMIT_TOL``). Unbounded limits keep x."""
    if lo <= x <= hi or not (math.isfinite(lo) and math.isfinite(hi)):
        return x, lo <= x <= hi
    w = lo + ((x - lo) % (2.0 * math.pi))
    if w <= hi:
        return w, True
    return x, lo - LIMIT_TOL <= x <= hi + LIMIT_TOL


@numba.njit(cache=True, error_model="numpy")
def near_limits(x, ref, lo, hi):
    """(x moved by 2π multiples to lie nearest ``ref`` within [lo, hi] where one such value exists,
    else :func:`into_limits`'s answer; whether the result lies within the limits). A tracking user
    wants a joint of range wider than one turn (±2π, continuous joints) to stay beside its seed, not
    jump a turn: the representative within π of ``ref`` first, then the one a turn towards the limits."""
    y = ref + wrap(x - ref)
    if lo <= y <= hi:
        return y, True
    z = y + 2.0 * math.pi if y < lo else y - 2.0 * math.pi
    if lo <= z <= hi:
        return z, True
    return into_limits(x, lo, hi)


@numba.njit(cache=True, error_model="numpy", inline="always")
def fits(z, lim, j):
    """The angle of ``z``, moved by 2π multiples, lies within ``lim[j]`` (±inf: always, no atan2)."""
    lo, hi = lim[j, 0], lim[j, 1]
    if lo == -math.inf and hi == math.inf:
        return True
    return into_limits(math.atan2(z.imag, z.real), lo, hi)[1]


@numba.njit(cache=True, error_model="numpy")
def sph_fixed(case, H, P, RM, pM):
    """What a spherical-wrist solve needs of the arm alone, as tuples: (hs, ps, wrist centre c, the
    position case's point o, e6 ⟂ h6, R_M (:func:`t9`), p_M)."""
    hs, ps = lines(H, P)
    return (hs, ps, meet_point(hs[3], ps[3], hs[4], ps[4]), case_point(case, H, P), any_perp(hs[5]), t9(RM),
            (pM[0], pM[1], pM[2]))


@numba.njit(cache=True, error_model="numpy")
def sph_goal(fx, g, pg):
    """What it needs of the goal (rotation ``g`` as :func:`t9`, position ``pg``): (w, R_goal R_Mᵀ h6,
    R_goal R_Mᵀ e6)."""
    hs, c, e6, m = fx[0], fx[2], fx[4], fx[5]
    return wrist9(g, pg, m, fx[6], c), gm9(g, m, hs[5]), gm9(g, m, e6)


@numba.njit(cache=True, error_model="numpy")
def sph_wrist(fx, gh6, ge6, t1, t2, t3, clip, d4, d6):
    """Joints 4-6 of one arm branch (θ1-θ3): (z4, z5, z6) on the sp2 branch +1, then −1, ok, free
    (a free angle took ``d4`` = e^{−iθ4} or ``d6`` = e^{iθ6}). Branch-free."""
    hs, e6 = fx[0], fx[4]
    h4, h5, h6 = hs[3], hs[4], hs[5]
    u = back3t(hs, t1, t2, t3, gh6)  # R4 R5 h6 = (R1 R2 R3)ᵀ R_goal R_Mᵀ h6
    y0 = back3t(hs, t1, t2, t3, ge6)
    a4, a5, b4, b5, ok, f = sp2paird(h4, h5, u, h6, clip, d4)
    # rot(h6, θ6) e6 = R5ᵀ R4ᵀ Rw e6
    a6, fa = sp1d(h6, e6, rotz(h5, a5.conjugate(), rotz(h4, a4.conjugate(), y0)), d6)
    b6, fb = sp1d(h6, e6, rotz(h5, b5.conjugate(), rotz(h4, b4.conjugate(), y0)), d6)
    return a4, a5, a6, b4, b5, b6, ok, (f | fa | fb) & ok


@numba.njit(cache=True, error_model="numpy")
def solve_sph(case, H, P, RM, pM, Rg, pg, clip, pref, Q, lim):
    """Spherical wrist: up to 8 candidate solutions into Q; returns their count. A branch whose
    joints 1-3 (then 4-5) fall outside ``lim`` (6, 2) is dropped before the rest is computed (a 7R
    sweep passes the limits; a 6R arm ±inf: every solution)."""
    fx = sph_fixed(case, H, P, RM, pM)
    hs, ps, c, o = fx[0], fx[1], fx[2], fx[3]
    w, gh6, ge6 = sph_goal(fx, t9(Rg), (pg[0], pg[1], pg[2]))
    n = 0
    for sa in (1.0, -1.0):
        r = pos3d(case, hs, ps, o, c, w, sa, clip, ONE)
        if r[8]:  # once more with the true default only where a free angle took it
            r = pos3d_call(case, hs, ps, o, c, w, sa, clip, pos_default(case, pref))
        for sb in range(2):
            t1, t2, t3, ok = (r[0], r[1], r[2], r[3]) if sb == 0 else (r[4], r[5], r[6], r[7])
            if not ok or not (fits(t1, lim, 0) and fits(t2, lim, 1) and fits(t3, lim, 2)):
                continue
            d4, d6 = ONE, ONE
            for _ in range(2):
                v = sph_wrist(fx, gh6, ge6, t1, t2, t3, clip, d4, d6)
                if not v[7]:
                    break
                d4, d6 = cis(-pref[3]), cis(pref[5])
            if not v[6]:
                continue
            for sc in range(2):
                t4, t5, t6 = (v[0], v[1], v[2]) if sc == 0 else (v[3], v[4], v[5])
                if not (fits(t4, lim, 3) and fits(t5, lim, 4)):
                    continue
                if n < Q.shape[0]:
                    Q[n, 0], Q[n, 1], Q[n, 2], Q[n, 3], Q[n, 4], Q[n, 5] = t1, t2, t3, t4, t5, t6
                n += 1
    return n


@numba.njit(cache=True, error_model="numpy")
def p3_fixed(H, P, RM, pM):
    """What a three-parallel solve needs of the arm alone, as tuples: (hs, ps, s3, s4 (the signs of
    h3 · h2 and h4 · h2), c (axes 5-6 meet), e2 ⟂ h2, R_M (:func:`t9`), p_M)."""
    hs, ps = lines(H, P)
    h2 = hs[1]
    s3 = 1.0 if dot(hs[2], h2) > 0 else -1.0
    s4 = 1.0 if dot(hs[3], h2) > 0 else -1.0
    return (hs, ps, s3, s4, meet_point(hs[4], ps[4], hs[5], ps[5]), any_perp(h2), t9(RM),
            (pM[0], pM[1], pM[2]))


@numba.njit(cache=True, error_model="numpy")
def p3_first(fx, g, pg, sa, clip, d5):
    """θ1 on branch ``sa`` by sp4, then (θ5, θ6) on both sp2 branches from ``h2ᵀ N = h2ᵀ R_5 R_6``:
    (e^{−iθ1}, w1 = E_1⁻¹ w, z5+, z6+, z5−, z6−, ok, free) (``d5`` = e^{−iθ5} where θ5 is free)."""
    hs, ps, c, m = fx[0], fx[1], fx[4], fx[6]
    h1, h2, p1 = hs[0], hs[1], ps[0]
    w = wrist9(g, pg, m, fx[7], c)
    tm, ok = sp4(h2, h1, sub(w, p1), dot(h2, c) - dot(h2, p1), sa, clip)
    t1 = tm.conjugate()
    w1 = about(h1, p1, tm, w)
    v = mv9(m, mtv9(g, rotz(h1, t1, h2)))  # N = R1ᵀ RgM; v = Nᵀ h2
    a5, a6, b5, b6, ok2, f = sp2paird(hs[4], hs[5], h2, v, clip, d5)
    ok = ok & ok2
    return tm, w1, a5, a6, b5, b6, ok, f & ok


@numba.njit(cache=True, error_model="numpy")
def p3_mid(fx, g, tm, w1, t5, t6):
    """θ2 + θ3 + θ4 by sp1 and the planar 2R's target: (e^{i(θ2+θ3+θ4)}, target of E2 E3 p4, its
    distance from axis 2)."""
    hs, ps, c, e2, m = fx[0], fx[1], fx[4], fx[5], fx[6]
    h2 = hs[1]
    # R234 e2 = N R6ᵀ R5ᵀ e2
    y = rotz(hs[4], t5.conjugate(), e2)
    y = rotz(hs[5], t6.conjugate(), y)
    y = rotz(hs[0], tm, gm9(g, m, y))
    t234 = sp1d(h2, e2, y, ONE)[0]  # free: e^{i0}
    # E2 E3 p4 = w1 − R234 (c − p4)
    tgt = sub(w1, rotz(h2, t234, sub(c, ps[3])))
    dw = perp(h2, sub(tgt, ps[1]))
    return t234, tgt, math.sqrt(dot(dw, dw))


@numba.njit(cache=True, error_model="numpy")
def p3_last(fx, t234, tgt, dd, s, clip, d2):
    """The planar 2R on elbow branch ``s`` and θ4: (z2, z3, z4, ok, free) (``d2`` = e^{iθ2} where free)."""
    hs, ps, s3, s4 = fx[0], fx[1], fx[2], fx[3]
    h2, h3, p2, p3, p4 = hs[1], hs[2], ps[1], ps[2], ps[3]
    t3, ok = sp3(h3, sub(p4, p3), sub(p2, p3), dd, s, clip, True)
    x3 = about(h3, p3, t3, p4)
    t2, f = sp1d(h2, sub(x3, p2), sub(tgt, p2), d2)
    # θ4 = s4 (θ234 − θ2 − s3 θ3)
    t4 = t234 * t2.conjugate() * (t3.conjugate() if s3 > 0 else t3)
    t4 = t4.conjugate() if s4 < 0 else t4
    return t2, t3, t4, ok, f & ok


@numba.njit(cache=True, error_model="numpy")
def solve_3p(H, P, RM, pM, Rg, pg, clip, pref, Q):
    """Three parallel axes (2-4) and axes 5-6 meeting: up to 8 candidates."""
    fx = p3_fixed(H, P, RM, pM)
    g, pgt = t9(Rg), (pg[0], pg[1], pg[2])
    n = 0
    for sa in (1.0, -1.0):
        d5 = ONE
        for _ in range(2):
            r = p3_first(fx, g, pgt, sa, clip, d5)
            if not r[7]:
                break
            d5 = cis(-pref[4])
        if not r[6]:
            continue
        tm, w1 = r[0], r[1]
        for sb in range(2):
            t5, t6 = (r[2], r[3]) if sb == 0 else (r[4], r[5])
            t234, tgt, dd = p3_mid(fx, g, tm, w1, t5, t6)
            for ic in range(2):
                d2 = ONE
                for _ in range(2):
                    v = p3_last(fx, t234, tgt, dd, 1.0 - 2.0 * ic, clip, d2)
                    if not v[4]:
                        break
                    d2 = cis(pref[1])
                if not v[3]:
                    continue
                if n < Q.shape[0]:
                    Q[n, 0], Q[n, 1], Q[n, 2], Q[n, 3], Q[n, 4], Q[n, 5] = tm.conjugate(), v[0], v[1], v[2], t5, t6
                n += 1
    return n


@numba.njit(cache=True, error_model="numpy")
def _search_eval(mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, t, clip, pref, F, V, TH):
    """The four branches at the searched angle ``t``: residual F[b], validity V[b], (θ1, θ2, θ3) TH[b].

    mode 4: axes 5-6 meet at ``c``, θ4 = t searched, ``w = T M⁻¹ c``, ``g = R_goal R_Mᵀ h6``,
            residual ``(R_1 R_2 R_3 R_4 h5) · g − h5 · h6``;
    mode 6: axes 4-5 meet at ``c``, θ6 = t searched, ``w = T M⁻¹ E_6(−t) c``,
            residual ``h4 · (R_1 R_2 R_3)ᵀ R_goal R_Mᵀ R_6ᵀ h5 − h4 · h5``.
    """
    zt = cis(t)
    if mode == 4:
        p4 = row(P, 3)
        x = add(p4, rotz(row(H, 3), zt, sub(c, p4)))
        wt = w
    else:
        x = c
        p6 = row(P, 5)
        wt = wrist_target(Rg, pg, RM, pM, add(p6, rotz(row(H, 5), zt.conjugate(), sub(c, p6))))
        gv = gm(Rg, RM, rotz(row(H, 5), zt.conjugate(), row(H, 4)))
    b = 0
    for sa in (1.0, -1.0):
        r = pos3pair(case, H, P, o, x, wt, sa, clip, pref)
        for sb in range(2):
            t1, t2, t3, ok = (r[0], r[1], r[2], r[3]) if sb == 0 else (r[4], r[5], r[6], r[7])
            V[b] = ok
            if ok:
                if mode == 4:
                    v = rotz(row(H, 3), zt, row(H, 4))
                    v = rotz(row(H, 2), t3, v)
                    v = rotz(row(H, 1), t2, v)
                    v = rotz(row(H, 0), t1, v)
                    F[b] = dot(v, g) - hh
                else:
                    v = back3(H, t1, t2, t3, gv)
                    F[b] = dot(row(H, 3), v) - hh
                TH[b, 0], TH[b, 1], TH[b, 2] = t1, t2, t3
            b += 1


@numba.njit(cache=True, error_model="numpy")
def _dip(mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, clip, pref, b, lo, hi, sg, F1, V1, TH):
    """Golden-section search for the minimum of ``sg · f_b`` on [lo, hi] (both ends of sign ``sg``),
    stopped as soon as it goes below 0: (found, where, f there). A close pair of roots (or one
    near a branch's edge) leaves no sign change on the grid; this finds the point between them."""
    gr = 0.6180339887498949
    x1 = hi - gr * (hi - lo)
    x2 = lo + gr * (hi - lo)
    _search_eval(mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, x1, clip, pref, F1, V1, TH)
    y1 = sg * F1[b] if V1[b] else 1e300
    _search_eval(mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, x2, clip, pref, F1, V1, TH)
    y2 = sg * F1[b] if V1[b] else 1e300
    for _ in range(24):
        if min(y1, y2) < 0.0:
            break
        if y1 < y2:
            hi, x2, y2 = x2, x1, y1
            x1 = hi - gr * (hi - lo)
            _search_eval(mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, x1, clip, pref, F1, V1, TH)
            y1 = sg * F1[b] if V1[b] else 1e300
        else:
            lo, x1, y1 = x1, x2, y2
            x2 = lo + gr * (hi - lo)
            _search_eval(mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, x2, clip, pref, F1, V1, TH)
            y2 = sg * F1[b] if V1[b] else 1e300
    if y1 < y2:
        return y1 < 0.0, x1, sg * y1
    return y2 < 0.0, x2, sg * y2


@numba.njit(cache=True, error_model="numpy")
def solve_search(mode, case, H, P, RM, pM, Rg, pg, clip, pref, samples, Q):
    """Position case for joints 1-3 and a one-dimensional search: mode 4, axes 5-6 meet and θ4 is
    searched; mode 6, axes 4-5 meet and θ6 is searched (see :func:`_search_eval`). Up to 16."""
    h4, h5, h6 = row(H, 3), row(H, 4), row(H, 5)
    if mode == 4:
        c = meet_point(h5, row(P, 4), h6, row(P, 5))
        hh = dot(h5, h6)
    else:
        c = meet_point(h4, row(P, 3), h5, row(P, 4))
        hh = dot(h4, h5)
    w = wrist_target(Rg, pg, RM, pM, c)
    o = case_point(case, H, P)
    g = gm(Rg, RM, h6)
    e6 = any_perp(h6)
    e5 = any_perp(h5)
    N = samples
    Fs = np.empty((N + 1, 4))
    Vs = np.zeros((N + 1, 4), np.bool_)
    TH = np.empty((4, 3), np.complex128)
    THs = np.empty((N + 1, 4, 3), np.complex128)
    F1 = np.empty(4)
    V1 = np.zeros(4, np.bool_)
    step = 2.0 * math.pi / N
    for i in range(N):
        _search_eval(mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, -math.pi + i * step, clip, pref, Fs[i], Vs[i],
                     THs[i])
    for b in range(4):
        Fs[N, b] = Fs[0, b]
        Vs[N, b] = Vs[0, b]
        for j in range(3):
            THs[N, b, j] = THs[0, b, j]
    # brackets (lo, f(lo), hi, f(hi)) of sign changes per branch
    BR = np.empty((64, 4))
    BB = np.empty(64, np.int64)
    nb = 0
    for b in range(4):
        for i in range(N):
            a0 = -math.pi + i * step
            a1 = a0 + step
            v0, v1 = Vs[i, b], Vs[i + 1, b]
            if not v0 and not v1:
                continue
            f0, f1 = Fs[i, b], Fs[i + 1, b]
            if v0 != v1:  # the branch ends inside: find its edge by bisection, evaluate there
                good, bad = (a0, a1) if v0 else (a1, a0)
                fg = f0 if v0 else f1
                for _ in range(16):
                    m = 0.5 * (good + bad)
                    _search_eval(mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, m, clip, pref, F1, V1, TH)
                    if V1[b]:
                        good = m
                        fg = F1[b]
                    else:
                        bad = m
                if v0:
                    a1, f1 = good, fg
                else:
                    a0, f0 = good, fg
            if f0 * f1 <= 0.0:
                if nb < 64 and not (f1 == 0.0 and v1 and i + 1 < N):  # a zero on a grid point: once
                    BR[nb, 0], BR[nb, 1], BR[nb, 2], BR[nb, 3] = a0, f0, a1, f1
                    BB[nb] = b
                    nb += 1
                continue
            if not (v0 and v1):
                continue
            # the branch's joints 1-3 turn fast across this cell (a near-singular position sub-problem):
            # the residual may cross zero and back between grid points; sample the cell finer
            fast = 0.0
            for j in range(3):
                fast = max(fast, abs(THs[i + 1, b, j] - THs[i, b, j]))
            if fast > 0.35:
                xa, fa_ = a0, f0
                for kk in range(1, 9):
                    xb = a0 + step * kk / 8.0
                    if kk < 8:
                        _search_eval(mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, xb, clip, pref, F1, V1, TH)
                        if not V1[b]:
                            break
                        fb_ = F1[b]
                    else:
                        fb_ = f1
                    if fa_ * fb_ < 0.0 and nb < 64:
                        BR[nb, 0], BR[nb, 1], BR[nb, 2], BR[nb, 3] = xa, fa_, xb, fb_
                        BB[nb] = b
                        nb += 1
                    xa, fa_ = xb, fb_
    # no sign change on the grid: a close pair of roots (or a pair near a branch's edge) hides where
    # |f| has a local minimum; look there when the parabola through the neighbours says it may cross
    for b in range(4):
        for i in range(N):
            if not Vs[i, b]:
                continue
            fi = Fs[i, b]
            il, ir = (i - 1) % N, i + 1
            vl, vr = Vs[il, b], Vs[ir, b]
            fl, fr = Fs[il, b], Fs[ir, b]
            if (vl and fl * fi <= 0.0) or (vr and fr * fi <= 0.0) or (not vl and not vr):
                continue
            if (vl and abs(fl) < abs(fi)) or (vr and abs(fr) < abs(fi)):
                continue
            if vl and vr:
                curv = fr - 2.0 * fi + fl
                if curv == 0.0:
                    continue
                fv = fi - (fr - fl) ** 2 / (8.0 * curv)
                if fv * fi > 0.0 and abs(fv) > 0.5 * abs(fi):
                    continue
            sg = 1.0 if fi > 0.0 else -1.0
            ai = -math.pi + i * step
            found, xm, fm = _dip(mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, clip, pref, b, ai - step,
                                 ai + step, sg, F1, V1, TH)
            if not found or nb + 2 > 64:
                continue
            # one root between a_i and xm; the other between xm and the far side (its grid point, or
            # the branch's last valid point before its edge)
            far = ai + step if xm > ai else ai - step
            vf = vr if xm > ai else vl
            ff = fr if xm > ai else fl
            if not vf:
                good, bad = xm, far
                ff = fm
                for _ in range(16):
                    mm = 0.5 * (good + bad)
                    _search_eval(mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, mm, clip, pref, F1, V1, TH)
                    if V1[b]:
                        good = mm
                        ff = F1[b]
                    else:
                        bad = mm
                far = good
            BR[nb, 0], BR[nb, 1], BR[nb, 2], BR[nb, 3] = ai, fi, xm, fm
            BB[nb] = b
            nb += 1
            if ff * fm <= 0.0:
                BR[nb, 0], BR[nb, 1], BR[nb, 2], BR[nb, 3] = xm, fm, far, ff
                BB[nb] = b
                nb += 1
    t = np.zeros(6, np.complex128)
    n = 0
    for kb in range(nb):
        b = BB[kb]
        a0, f0, a1, f1 = BR[kb, 0], BR[kb, 1], BR[kb, 2], BR[kb, 3]
        if True:
            if f0 == 0.0:
                root = a0
            elif f1 == 0.0:
                root = a1
            else:
                # Illinois regula falsi on [a0, a1]
                a, fa, bb, fb = a0, f0, a1, f1
                root = bb
                for _ in range(60):
                    m = bb - fb * (bb - a) / (fb - fa)
                    _search_eval(mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, m, clip, pref, F1, V1, TH)
                    if not V1[b]:
                        m = 0.5 * (a + bb)
                        _search_eval(mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, m, clip, pref, F1, V1, TH)
                        if not V1[b]:
                            break
                    fm = F1[b]
                    if fm * fb < 0.0:
                        a, fa = bb, fb
                    else:
                        fa *= 0.5
                    bb, fb = m, fm
                    root = m
                    if abs(fm) < 1e-15 or abs(bb - a) < 1e-14:
                        break
            _search_eval(mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, root, clip, pref, F1, V1, TH)
            if not V1[b]:
                continue
            t1, t2, t3 = TH[b, 0], TH[b, 1], TH[b, 2]
            t[0], t[1], t[2] = t1, t2, t3
            zr = cis(root)
            if mode == 4:
                t[3] = zr
                # R5 R6 = (R1..R4)ᵀ RgM: θ5 from h6, θ6 from e6
                nh6 = rotz(h4, zr.conjugate(), back3(H, t1, t2, t3, g))
                t[4] = sp1(h5, h6, nh6, pref[4])
                y = rotz(h4, zr.conjugate(), back3(H, t1, t2, t3, gm(Rg, RM, e6)))
                y = rotz(h5, t[4].conjugate(), y)
                t[5] = sp1(h6, e6, y, pref[5])
            else:
                t[5] = zr
                # R4 R5 = (R1 R2 R3)ᵀ RgM R6ᵀ: θ4 from h5, θ5 from e5
                nh5 = back3(H, t1, t2, t3, gm(Rg, RM, rotz(h6, zr.conjugate(), h5)))
                t[3] = sp1(h4, h5, nh5, pref[3])
                y = back3(H, t1, t2, t3, gm(Rg, RM, rotz(h6, zr.conjugate(), e5)))
                y = rotz(h4, t[3].conjugate(), y)
                t[4] = sp1(h5, e5, y, pref[4])
            # a root on a grid point is found from both of its intervals: keep it once
            dup = False
            for k in range(min(n, Q.shape[0])):
                dd = 0.0
                for j in range(6):
                    dd += abs(Q[k, j] - t[j])
                if dd < 1e-9:
                    dup = True
            if not dup:
                if n < Q.shape[0]:
                    for j in range(6):
                        Q[n, j] = t[j]
                n += 1
    return n
