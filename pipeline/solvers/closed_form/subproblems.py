"""Compiled Paden-Kahan subproblems: the building blocks of the closed-form families.

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
:data:`pipeline.kinematics.geometry.POSITION_CASES`), each in a module of its own with its scalar stages,
its closed form and its 8-goal lane pass side by side: the spherical wrist
(:mod:`~pipeline.solvers.closed_form.family_sph`), three parallel axes
(:mod:`~pipeline.solvers.closed_form.family_3p`), two meeting axes and a one-dimensional search
(:mod:`~pipeline.solvers.closed_form.family_search`). This module holds what they build on: 3-vectors
as tuples, the subproblems, the position of a point by joints 1-3 (the four position cases), the
wrist's target, and angles moved into joint limits.
"""

from __future__ import annotations

import math

import numba

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


@numba.njit(cache=True, error_model="numpy", inline="always")
def _distance_pair(hA, pA, hB, pB, u, v, clip, pref_a):
    """Both branches of joint B (SP3: the point ``u`` about line B at the distance from line A that ``v``
    has), then joint A for each (SP1 taking the moved point to ``v``): ``tA+, tB+, ok+, tA-, tB-, ok-``."""
    dw = perp(hA, sub(v, pA))
    dd = math.sqrt(dot(dw, dw))
    tBa, oka = sp3(hB, sub(u, pB), sub(pA, pB), dd, 1.0, clip, True)
    tBb, okb = sp3(hB, sub(u, pB), sub(pA, pB), dd, -1.0, clip, True)
    tAa = sp1(hA, sub(about(hB, pB, tBa, u), pA), sub(v, pA), pref_a) if oka else ONE
    tAb = sp1(hA, sub(about(hB, pB, tBb, u), pA), sub(v, pA), pref_a) if okb else ONE
    return tAa, tBa, oka, tAb, tBb, okb


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
        t1a, t2a, oka, t1b, t2b, okb = _distance_pair(h1, p1, h2, p2, x3, w, clip, pref[0])
        return t1a, t2a, t3, oka, t1b, t2b, t3, okb
    tm, ok = sp4(h2, h1, sub(w, p1), dot(h2, x) - dot(h2, p1), sa, clip)
    if not ok:
        return z
    t1 = tm.conjugate()
    w1 = about(h1, p1, t1.conjugate(), w)
    t2a, t3a, oka, t2b, t3b, okb = _distance_pair(h2, p2, h3, p3, x, w1, clip, pref[1])
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


# ---- angles within joint limits ------------------------------------------------------------------
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

