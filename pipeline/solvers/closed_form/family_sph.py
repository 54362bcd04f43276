"""The spherical-wrist family: axes 4-6 meet at the wrist centre.

The wrist centre ``c`` (axes 4-6 meet) gives ``w = T M⁻¹ c = E_1 E_2 E_3 c``, solved by the position case
(:func:`~pipeline.solvers.closed_form.subproblems.pos3d`, 2 × 2 branches); then
``R_4 R_5 R_6 = (R_1 R_2 R_3)ᵀ R_goal R_Mᵀ`` by sp2 (2 branches) and sp1: up to 8 solutions.

Its stages (:func:`sph_fixed`, :func:`sph_goal`, :func:`sph_wrist`: branch-free, the arm as tuples), the
single call (:func:`solve_sph`, and :func:`candidates` behind the families' one signature) and the 8-goal
lane pass of the batch (:func:`candidates8`, the scratch of :mod:`pipeline.solvers.closed_form.lanes`),
which calls the same stages inlined (:func:`~pipeline.solvers.kernels.specialise.inlined_twin`), so that
both give the same floats.
"""

from __future__ import annotations

import sys

import numba
import numpy as np

from pipeline.solvers.closed_form.lanes import GOAL, LANES, W, cand, flags, goal, ld, ldz, load, st2z
from pipeline.solvers.closed_form import subproblems
from pipeline.solvers.closed_form.subproblems import (ONE, any_perp, back3t, case_point, cis, fits, gm9, lines,
                                                      meet_point, pos3d, pos3d_call, pos_default, rotz, sp1d,
                                                      sp2paird, t9, wrist9)
from pipeline.solvers.kernels.specialise import inlined_twin


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


@numba.njit(cache=True, error_model="numpy", inline="always")
def sph_wrist_at(fx, gh6, ge6, t1, t2, t3, clip, pref):
    """:func:`sph_wrist` for joints 1-3 at (t1, t2, t3): first with the free angles' defaults at zero,
    once more with the start's θ4 and θ6 (``pref``, rad) where the wrist is singular and took them
    (``v[7]``)."""
    d4, d6 = ONE, ONE
    v = sph_wrist(fx, gh6, ge6, t1, t2, t3, clip, d4, d6)
    if v[7]:
        v = sph_wrist(fx, gh6, ge6, t1, t2, t3, clip, cis(-pref[3]), cis(pref[5]))
    return v


@numba.njit(cache=True, error_model="numpy", inline="always")
def keep_wrists(Q, n, t1, t2, t3, v, lim):
    """Append to ``Q`` (rows e^{iθ}, 6 columns) after its ``n`` rows the two wrist branches of ``v``
    (:func:`sph_wrist`'s result) with joints 1-3 at (t1, t2, t3), each whose θ4 and θ5 fit ``lim``
    (6, 2); the new count (rows past ``Q``'s counted, not stored)."""
    for sc in range(2):
        t4, t5, t6 = (v[0], v[1], v[2]) if sc == 0 else (v[3], v[4], v[5])
        if fits(t4, lim, 3) and fits(t5, lim, 4):
            if n < Q.shape[0]:
                Q[n, 0], Q[n, 1], Q[n, 2], Q[n, 3], Q[n, 4], Q[n, 5] = t1, t2, t3, t4, t5, t6
            n += 1
    return n


@numba.njit(cache=True, error_model="numpy")
def solve_sph(case, H, P, RM, pM, Rg, pg, clip, pref, Q, lim):
    """Spherical wrist: up to 8 candidate solutions into Q; returns their count. A branch whose
    joints 1-3 (then 4-5) fall outside ``lim`` (6, 2) is dropped before the rest is computed (a 7R
    sweep passes the limits; a 6R arm ±inf: every solution).

    The arm's and the goal's stages are inlined (:data:`tw`, the same floats): the arm's tuple then
    does not go through memory into every later call, 0.17 µs less a pose for about 1 s more compile.
    The position and wrist stages stay calls: inlined as well they saved 0.07 µs more for 4.5 s more
    compile (a third more for the README example's first call)."""
    fx = tw.sph_fixed(case, H, P, RM, pM)
    hs, ps, c, o = fx[0], fx[1], fx[2], fx[3]
    w, gh6, ge6 = tw.sph_goal(fx, t9(Rg), (pg[0], pg[1], pg[2]))
    n = 0
    for sa in (1.0, -1.0):
        r = pos3d(case, hs, ps, o, c, w, sa, clip, ONE)
        if r[8]:  # once more with the true default only where a free angle took it
            r = pos3d_call(case, hs, ps, o, c, w, sa, clip, pos_default(case, pref))
        for sb in range(2):
            t1, t2, t3, ok = (r[0], r[1], r[2], r[3]) if sb == 0 else (r[4], r[5], r[6], r[7])
            if not ok or not (fits(t1, lim, 0) and fits(t2, lim, 1) and fits(t3, lim, 2)):
                continue
            v = sph_wrist_at(fx, gh6, ge6, t1, t2, t3, clip, pref)
            if v[6]:
                n = keep_wrists(Q, n, t1, t2, t3, v, lim)
    return n


@numba.njit(cache=True, error_model="numpy")
def candidates(case, mode, H, P, RM, pM, Rg, pg, clip, pref, samples, Q, lim6):
    """:func:`solve_sph` behind the families' one signature (the name ``FAMILY`` of
    :func:`pipeline.solvers.closed_form.analytic_kernels.core6`)."""
    return solve_sph(case, H, P, RM, pM, Rg, pg, clip, pref, Q, lim6)


# ---- 8 goals in vector lanes ------------------------------------------------------------------------
# the stages inlined into each pass at numba's level (a pass with a call left in it is not vectorized);
# the single call above inlines the arm's and the goal's stages only (solve_sph: far less to compile)
tw = inlined_twin(subproblems, sys.modules[__name__])


@numba.njit(cache=True, error_model="numpy", inline="always")
def _st_pos(L, u, r):
    """A position stage's result (:func:`~pipeline.solvers.closed_form.subproblems.pos3d`): its branch +1 in slot u,
    −1 in slot u + 16."""
    st2z(L, GOAL, u, r[0], r[4])
    st2z(L, GOAL + 2, u, r[1], r[5])
    st2z(L, GOAL + 4, u, r[2], r[6])
    flags(L, u, r[3], r[7], r[8])


def _first_pass(pos):
    """The spherical wrist's first-stage pass for one position case (``pos``, one of
    :func:`~pipeline.solvers.closed_form.subproblems.pos_case1` .. ``pos_case4``): branch sa +1 in slots 0-7, −1 in
    8-15. One pass per case: a switch inside a pass keeps it scalar, and one pass with the case as an
    argument, inlined once per case, took the compiler minutes."""

    @numba.njit(cache=True, error_model="numpy", inline="always")
    def first(fx, clip, L):
        for lane in range(2 * LANES):
            u = np.uint64(lane)
            g, pg = goal(L, u)
            w, sa = tw.sph_goal(fx, g, pg)[0], 1.0 if lane < LANES else -1.0
            _st_pos(L, u, pos(fx[0], fx[1], fx[3], fx[2], w, sa, clip, tw.ONE))

    return first


_sph_a1, _sph_a2, _sph_a3, _sph_a4 = (_first_pass(f) for f in (tw.pos_case1, tw.pos_case2, tw.pos_case3,
                                                               tw.pos_case4))


@numba.njit(cache=True, error_model="numpy", inline="always")
def _sph_b(fx, clip, L):
    """Every (sa, sb) slot: joints 4-6, the candidates of wrist branch +1 (c 0) and −1 (c 1)."""
    for lane in range(W):
        u = np.uint64(lane)
        g, pg = goal(L, u)
        _, gh6, ge6 = tw.sph_goal(fx, g, pg)
        t1, t2, t3 = ldz(L, GOAL, u), ldz(L, GOAL + 2, u), ldz(L, GOAL + 4, u)
        ok, f = ld(L, GOAL + 9, u) != 0.0, ld(L, GOAL + 10, u) != 0.0
        v = tw.sph_wrist(fx, gh6, ge6, t1, t2, t3, clip, tw.ONE, tw.ONE)
        ok, f = ok & v[6], f | v[7]
        cand(L, 0, u, t1, t2, t3, v[0], v[1], v[2], ok, f)
        cand(L, 1, u, t1, t2, t3, v[3], v[4], v[5], ok, f)


@numba.njit(cache=True, error_model="numpy")
def _spherical(case, H, P, RM, pM, clip, L):
    fx = tw.sph_fixed(case, H, P, RM, pM)
    if case == 1:
        _sph_a1(fx, clip, L)
    elif case == 2:
        _sph_a2(fx, clip, L)
    elif case == 3:
        _sph_a3(fx, clip, L)
    else:
        _sph_a4(fx, clip, L)
    _sph_b(fx, clip, L)


@numba.njit(cache=True, error_model="numpy")
def candidates8(case, H, P, RM, pM, clip, goals, i0, L):
    """The closed form's candidates of goals ``i0 .. i0 + 7`` (``goals`` (N, 4, 4)) into ``L``
    (:data:`~pipeline.solvers.closed_form.lanes.SIZE` floats), for a 6R arm with a spherical wrist and
    position case ``case``; read them with :func:`~pipeline.solvers.closed_form.lanes.take`."""
    load(goals, i0, L)
    _spherical(case, H, P, RM, pM, clip, L)
