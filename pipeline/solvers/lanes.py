"""The closed forms of :mod:`pipeline.solvers.subproblems` for 8 goals at once, one goal per vector lane.

The batch (:func:`pipeline.solvers.analytic.solve_batch_kernel`) solves a 6R spherical-wrist or
three-parallel arm's goals in blocks of 8: each stage of the closed form (the first joint's branch,
the wrist, the planar 2R) runs as one pass over the 8 goals, which the compiler turns into vector
code, instead of one goal's branches one after another. A scalar goal is latency-bound (square
roots and divisions in a chain); 8 goals in lanes are not: on a Zen 4 the UR5's candidates take
about 0.35 µs a goal this way against 0.8 µs one at a time.

Same floats as the single call: each pass calls the branch-free stage functions the scalar solvers
call (:func:`~pipeline.solvers.subproblems.p3_first`, ``p3_mid``, ``p3_last``, ``pos3d``,
``sph_wrist``), with the same operands in the same order; a lane computes every branch and masks the
invalid ones where the scalar call skips them. A goal on which a stage reports a free angle (a
degenerate subproblem, whose default needs the start's sine and cosine) is left to the single call
(:func:`take` returns ``free``), so the batch's candidates equal the single call's bit for bit.

Why the code looks as it does (each was needed for the compiler to vectorize; checked with LLVM's
``-pass-remarks=loop-vectorize``): every value a pass reads or writes lies in one scratch array ``L``
at a constant offset from its lane (value ``k`` of lane ``l`` at ``L[8 k + l]``, indexed unsigned), as
a loop of 8 iterations gets no run-time overlap checks; the arm is read into tuples before the passes;
a pass holds no call into libm and no switch (the position case is chosen outside the pass).

Layout of ``L`` (:data:`SIZE` floats, values × 8 lanes): the goal's rotation (9, row-major) and
position (3); the first stage of branch sa = +1 and of sa = −1 (:data:`STAGE` values each); then the
8 candidates in the scalar solver's order (:data:`CAND` values each: 6 e^{iθ} as real and imaginary
parts, ok, free).
"""

from __future__ import annotations

import numba
import numpy as np

from pipeline.solvers import subproblems as sp

LANES = 8
GOAL = 12  # the goal's rotation (9) and position (3)
STAGE = 15  # a first stage: 3P (e^{-iθ1}, w1 (3), z5+, z6+, z5−, z6−, ok, free); sph (z1-z3, ok) × 2, free
CAND = 14  # a candidate: z1..z6 (12), ok, free
A0, A1 = GOAL, GOAL + STAGE  # the first stage of sa = +1, of sa = −1
C0 = GOAL + 2 * STAGE  # the first candidate
SIZE = LANES * (C0 + 8 * CAND)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _ld(L, k, u):
    return L[np.uint64(LANES * k) + u]


@numba.njit(cache=True, error_model="numpy", inline="always")
def _ldz(L, k, u):
    return complex(_ld(L, k, u), _ld(L, k + 1, u))


@numba.njit(cache=True, error_model="numpy", inline="always")
def _st(L, k, u, x):
    L[np.uint64(LANES * k) + u] = x


@numba.njit(cache=True, error_model="numpy", inline="always")
def _stz(L, k, u, z):
    _st(L, k, u, z.real)
    _st(L, k + 1, u, z.imag)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _goal(L, u):
    g = (_ld(L, 0, u), _ld(L, 1, u), _ld(L, 2, u), _ld(L, 3, u), _ld(L, 4, u), _ld(L, 5, u), _ld(L, 6, u),
         _ld(L, 7, u), _ld(L, 8, u))
    return g, (_ld(L, 9, u), _ld(L, 10, u), _ld(L, 11, u))


@numba.njit(cache=True, error_model="numpy", inline="always")
def _cand(L, b, u, z1, z2, z3, z4, z5, z6, ok, free):
    k = C0 + CAND * b
    _stz(L, k, u, z1)
    _stz(L, k + 2, u, z2)
    _stz(L, k + 4, u, z3)
    _stz(L, k + 6, u, z4)
    _stz(L, k + 8, u, z5)
    _stz(L, k + 10, u, z6)
    _st(L, k + 12, u, 1.0 if ok else 0.0)
    _st(L, k + 13, u, 1.0 if free else 0.0)


# ---- three parallel axes ----------------------------------------------------------------------------
@numba.njit(cache=True, error_model="numpy", inline="always")
def _p3_a(fx, clip, L, sa, a):
    for lane in range(LANES):
        u = np.uint64(lane)
        g, pg = _goal(L, u)
        tm, w1, a5, a6, b5, b6, ok, f = sp.p3_first(fx, g, pg, sa, clip, sp.ONE)
        _stz(L, a, u, tm)
        _st(L, a + 2, u, w1[0])
        _st(L, a + 3, u, w1[1])
        _st(L, a + 4, u, w1[2])
        _stz(L, a + 5, u, a5)
        _stz(L, a + 7, u, a6)
        _stz(L, a + 9, u, b5)
        _stz(L, a + 11, u, b6)
        _st(L, a + 13, u, 1.0 if ok else 0.0)
        _st(L, a + 14, u, 1.0 if f else 0.0)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _p3_b(fx, clip, L, a, sb, b):
    """Branch (sa, sb) from the first stage at ``a``: the candidates b (elbow +1) and b + 1 (−1)."""
    for lane in range(LANES):
        u = np.uint64(lane)
        g = _goal(L, u)[0]
        tm = _ldz(L, a, u)
        w1 = (_ld(L, a + 2, u), _ld(L, a + 3, u), _ld(L, a + 4, u))
        t5, t6 = _ldz(L, a + 5 + 4 * sb, u), _ldz(L, a + 7 + 4 * sb, u)
        ok, f = _ld(L, a + 13, u) != 0.0, _ld(L, a + 14, u) != 0.0
        t234, tgt, dd = sp.p3_mid(fx, g, tm, w1, t5, t6)
        v = sp.p3_last(fx, t234, tgt, dd, 1.0, clip, sp.ONE)
        _cand(L, b, u, tm.conjugate(), v[0], v[1], v[2], t5, t6, ok & v[3], f | v[4])
        v = sp.p3_last(fx, t234, tgt, dd, -1.0, clip, sp.ONE)
        _cand(L, b + 1, u, tm.conjugate(), v[0], v[1], v[2], t5, t6, ok & v[3], f | v[4])


@numba.njit(cache=True, error_model="numpy")
def _three_parallel(H, P, RM, pM, clip, L):
    fx = sp.p3_fixed(H, P, RM, pM)
    _p3_a(fx, clip, L, 1.0, A0)
    _p3_a(fx, clip, L, -1.0, A1)
    _p3_b(fx, clip, L, A0, 0, 0)
    _p3_b(fx, clip, L, A0, 1, 2)
    _p3_b(fx, clip, L, A1, 0, 4)
    _p3_b(fx, clip, L, A1, 1, 6)


# ---- spherical wrist ------------------------------------------------------------------------------
@numba.njit(cache=True, error_model="numpy", inline="always")
def _st_pos(L, a, u, r):
    """A position stage's result (:func:`~pipeline.solvers.subproblems.pos3d`) at ``a``."""
    _stz(L, a, u, r[0])
    _stz(L, a + 2, u, r[1])
    _stz(L, a + 4, u, r[2])
    _st(L, a + 6, u, 1.0 if r[3] else 0.0)
    _stz(L, a + 7, u, r[4])
    _stz(L, a + 9, u, r[5])
    _stz(L, a + 11, u, r[6])
    _st(L, a + 13, u, 1.0 if r[7] else 0.0)
    _st(L, a + 14, u, 1.0 if r[8] else 0.0)


# one pass per position case (a switch inside a pass keeps it scalar; one function with the case as an
# argument, inlined 4 times, took the compiler minutes)
@numba.njit(cache=True, error_model="numpy", inline="always")
def _sph_a1(fx, clip, L, sa, a):
    for lane in range(LANES):
        u = np.uint64(lane)
        g, pg = _goal(L, u)
        _st_pos(L, a, u, sp.pos_case1(fx[0], fx[1], fx[3], fx[2], sp.sph_goal(fx, g, pg)[0], sa, clip, sp.ONE))


@numba.njit(cache=True, error_model="numpy", inline="always")
def _sph_a2(fx, clip, L, sa, a):
    for lane in range(LANES):
        u = np.uint64(lane)
        g, pg = _goal(L, u)
        _st_pos(L, a, u, sp.pos_case2(fx[0], fx[1], fx[3], fx[2], sp.sph_goal(fx, g, pg)[0], sa, clip, sp.ONE))


@numba.njit(cache=True, error_model="numpy", inline="always")
def _sph_a3(fx, clip, L, sa, a):
    for lane in range(LANES):
        u = np.uint64(lane)
        g, pg = _goal(L, u)
        _st_pos(L, a, u, sp.pos_case3(fx[0], fx[1], fx[3], fx[2], sp.sph_goal(fx, g, pg)[0], sa, clip, sp.ONE))


@numba.njit(cache=True, error_model="numpy", inline="always")
def _sph_a4(fx, clip, L, sa, a):
    for lane in range(LANES):
        u = np.uint64(lane)
        g, pg = _goal(L, u)
        _st_pos(L, a, u, sp.pos_case4(fx[0], fx[1], fx[3], fx[2], sp.sph_goal(fx, g, pg)[0], sa, clip, sp.ONE))


@numba.njit(cache=True, error_model="numpy", inline="always")
def _sph_b(fx, clip, L, a, sb, b):
    """Branch (sa, sb) from the first stage at ``a``: the candidates b (wrist +1) and b + 1 (−1)."""
    k = a + 7 * sb
    for lane in range(LANES):
        u = np.uint64(lane)
        g, pg = _goal(L, u)
        _, gh6, ge6 = sp.sph_goal(fx, g, pg)
        t1, t2, t3 = _ldz(L, k, u), _ldz(L, k + 2, u), _ldz(L, k + 4, u)
        ok, f = _ld(L, k + 6, u) != 0.0, _ld(L, a + 14, u) != 0.0
        v = sp.sph_wrist(fx, gh6, ge6, t1, t2, t3, clip, sp.ONE, sp.ONE)
        ok, f = ok & v[6], f | v[7]
        _cand(L, b, u, t1, t2, t3, v[0], v[1], v[2], ok, f)
        _cand(L, b + 1, u, t1, t2, t3, v[3], v[4], v[5], ok, f)


@numba.njit(cache=True, error_model="numpy")
def _spherical(case, H, P, RM, pM, clip, L):
    fx = sp.sph_fixed(case, H, P, RM, pM)
    if case == 1:
        _sph_a1(fx, clip, L, 1.0, A0)
        _sph_a1(fx, clip, L, -1.0, A1)
    elif case == 2:
        _sph_a2(fx, clip, L, 1.0, A0)
        _sph_a2(fx, clip, L, -1.0, A1)
    elif case == 3:
        _sph_a3(fx, clip, L, 1.0, A0)
        _sph_a3(fx, clip, L, -1.0, A1)
    else:
        _sph_a4(fx, clip, L, 1.0, A0)
        _sph_a4(fx, clip, L, -1.0, A1)
    _sph_b(fx, clip, L, A0, 0, 0)
    _sph_b(fx, clip, L, A0, 1, 2)
    _sph_b(fx, clip, L, A1, 0, 4)
    _sph_b(fx, clip, L, A1, 1, 6)


# ---- the block ----------------------------------------------------------------------------------------
def applies(n: int, fam: int, rev: int) -> bool:
    """Whether a packed arm (:func:`pipeline.solvers.analytic.packed`) has lanes: a 6R arm of the spherical
    or three-parallel family read from the base (``rev`` 0)."""
    return n == 6 and rev == 0 and fam in (sp.FAM_SPH, sp.FAM_3P)


@numba.njit(cache=True, error_model="numpy")
def candidates8(fam, case, H, P, RM, pM, clip, goals, i0, L):
    """The closed form's candidates of goals ``i0 .. i0 + 7`` (``goals`` (N, 4, 4)) into ``L`` (:data:`SIZE`),
    for a 6R arm of family ``fam`` (:data:`~pipeline.solvers.subproblems.FAM_SPH` with position case
    ``case``, or ``FAM_3P``); read them with :func:`take`."""
    for lane in range(LANES):
        T = goals[i0 + lane]
        for r in range(3):
            for c in range(3):
                L[LANES * (3 * r + c) + lane] = T[r, c]
            L[LANES * (9 + r) + lane] = T[r, 3]
    if fam == sp.FAM_3P:
        _three_parallel(H, P, RM, pM, clip, L)
    else:
        _spherical(case, H, P, RM, pM, clip, L)


@numba.njit(cache=True, error_model="numpy")
def take(L, lane, Z):
    """Lane ``lane``'s valid candidates, in the single call's order, into ``Z`` (complex, row r joint j at
    ``Z[6 r + j]``): (count, free). ``free``: a stage took a default for a free angle, so the single
    call must solve this goal (its default depends on the start)."""
    k = 0
    free = False
    for b in range(8):
        o = C0 + CAND * b
        free |= L[LANES * (o + 13) + lane] != 0.0
        if L[LANES * (o + 12) + lane] != 0.0:
            for j in range(6):
                Z[6 * k + j] = complex(L[LANES * (o + 2 * j) + lane], L[LANES * (o + 2 * j + 1) + lane])
            k += 1
    return k, free
