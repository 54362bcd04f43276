"""The three-parallel family: axes 2-4 parallel, axes 5 and 6 meeting (the UR arms).

θ1 by sp4 (the component of ``E_1⁻¹ w`` along h2 is fixed), (θ5, θ6) by sp2 from
``h2ᵀ N = h2ᵀ R_5 R_6``, θ2 + θ3 + θ4 by sp1, then the planar 2R by sp3 and sp1: up to 8 solutions.

Its stages (:func:`p3_fixed`, :func:`p3_first`, :func:`p3_mid`, :func:`p3_last`: branch-free, the arm as
tuples), the single call (:func:`solve_3p`, and :func:`candidates` behind the families' one signature)
and the 8-goal lane pass of the batch (:func:`candidates8`, the scratch of
:mod:`pipeline.solvers.closed_form.lanes`), which calls the same stages inlined
(:func:`~pipeline.solvers.kernels.specialise.inlined_twin`), so that both give the same floats.
"""

from __future__ import annotations

import math
import sys

import numba
import numpy as np

from pipeline.solvers.closed_form.lanes import GOAL, LANES, W, cand, flags, goal, ld, ldz, load, st2, st2z
from pipeline.solvers.closed_form import subproblems
from pipeline.solvers.closed_form.subproblems import (ONE, about, any_perp, cis, dot, gm9, lines, meet_point,
                                                      mtv9, mv9, perp, rotz, sp1d, sp2paird, sp3, sp4, sub, t9,
                                                      wrist9)
from pipeline.solvers.kernels.specialise import inlined_twin


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
    """Three parallel axes (2-4) and axes 5-6 meeting: up to 8 candidates. The arm's stage and the
    last one (the planar 2R, 8 times a pose) are inlined (:data:`tw`, the same floats): 0.22 µs less a
    pose for about 1 s more compile. The first and middle stages stay calls: inlined as well they saved
    0.11 µs more for 4 s more compile. The retries where a free angle took its default (θ5 at the
    start's, then θ2; rare) are calls too."""
    fx = tw.p3_fixed(H, P, RM, pM)
    g, pgt = t9(Rg), (pg[0], pg[1], pg[2])
    n = 0
    for sa in (1.0, -1.0):
        r = p3_first(fx, g, pgt, sa, clip, ONE)
        if r[7]:
            r = p3_first(fx, g, pgt, sa, clip, cis(-pref[4]))
        if not r[6]:
            continue
        tm, w1 = r[0], r[1]
        for sb in range(2):
            t5, t6 = (r[2], r[3]) if sb == 0 else (r[4], r[5])
            t234, tgt, dd = p3_mid(fx, g, tm, w1, t5, t6)
            for ic in range(2):
                v = tw.p3_last(fx, t234, tgt, dd, 1.0 - 2.0 * ic, clip, ONE)
                if v[4]:
                    v = p3_last(fx, t234, tgt, dd, 1.0 - 2.0 * ic, clip, cis(pref[1]))
                if not v[3]:
                    continue
                if n < Q.shape[0]:
                    Q[n, 0], Q[n, 1], Q[n, 2], Q[n, 3], Q[n, 4], Q[n, 5] = tm.conjugate(), v[0], v[1], v[2], t5, t6
                n += 1
    return n


@numba.njit(cache=True, error_model="numpy")
def candidates(case, mode, H, P, RM, pM, Rg, pg, clip, pref, samples, Q, lim6):
    """:func:`solve_3p` behind the families' one signature (the name ``FAMILY`` of
    :func:`pipeline.solvers.closed_form.analytic_kernels.core6`)."""
    return solve_3p(H, P, RM, pM, Rg, pg, clip, pref, Q)


# ---- 8 goals in vector lanes ------------------------------------------------------------------------
# the stages inlined into each pass at numba's level (a pass with a call left in it is not vectorized);
# the single call above inlines the arm's stage and the last (solve_3p: far less for numba to compile)
tw = inlined_twin(subproblems, sys.modules[__name__])


@numba.njit(cache=True, error_model="numpy", inline="always")
def _p3_a(fx, clip, L):
    """θ1 (branch sa: slots 0-7 +1, 8-15 −1) and (θ5, θ6); the second branch's (θ5, θ6) in slots + 16."""
    for lane in range(2 * LANES):
        u = np.uint64(lane)
        g, pg = goal(L, u)
        tm, w1, a5, a6, b5, b6, ok, f = tw.p3_first(fx, g, pg, 1.0 if lane < LANES else -1.0, clip, tw.ONE)
        st2z(L, GOAL, u, tm, tm)
        st2(L, GOAL + 2, u, w1[0], w1[0])
        st2(L, GOAL + 3, u, w1[1], w1[1])
        st2(L, GOAL + 4, u, w1[2], w1[2])
        st2z(L, GOAL + 5, u, a5, b5)
        st2z(L, GOAL + 7, u, a6, b6)
        flags(L, u, ok, ok, f)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _p3_b(fx, clip, L):
    """Every (sa, sb) slot: θ2 + θ3 + θ4, then the candidates of elbow +1 (c 0) and −1 (c 1)."""
    for lane in range(W):
        u = np.uint64(lane)
        g = goal(L, u)[0]
        tm = ldz(L, GOAL, u)
        w1 = (ld(L, GOAL + 2, u), ld(L, GOAL + 3, u), ld(L, GOAL + 4, u))
        t5, t6 = ldz(L, GOAL + 5, u), ldz(L, GOAL + 7, u)
        ok, f = ld(L, GOAL + 9, u) != 0.0, ld(L, GOAL + 10, u) != 0.0
        t234, tgt, dd = tw.p3_mid(fx, g, tm, w1, t5, t6)
        v = tw.p3_last(fx, t234, tgt, dd, 1.0, clip, tw.ONE)
        cand(L, 0, u, tm.conjugate(), v[0], v[1], v[2], t5, t6, ok & v[3], f | v[4])
        v = tw.p3_last(fx, t234, tgt, dd, -1.0, clip, tw.ONE)
        cand(L, 1, u, tm.conjugate(), v[0], v[1], v[2], t5, t6, ok & v[3], f | v[4])


@numba.njit(cache=True, error_model="numpy")
def _three_parallel(H, P, RM, pM, clip, L):
    fx = tw.p3_fixed(H, P, RM, pM)
    _p3_a(fx, clip, L)
    _p3_b(fx, clip, L)


@numba.njit(cache=True, error_model="numpy")
def candidates8(case, H, P, RM, pM, clip, goals, i0, L):
    """:func:`pipeline.solvers.closed_form.family_sph.candidates8` for a 6R arm with three parallel axes
    (``case`` unused)."""
    load(goals, i0, L)
    _three_parallel(H, P, RM, pM, clip, L)
