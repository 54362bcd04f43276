"""The closed forms of :mod:`pipeline.solvers.closed_form.subproblems` for 8 goals at once, one goal per vector lane.

The batch (:func:`pipeline.solvers.closed_form.analytic.solve_batch_kernel`) solves a 6R spherical-wrist or
three-parallel arm's goals in blocks of 8: each stage of the closed form (the first joint's branch,
the wrist, the planar 2R) runs as one pass over the 8 goals and their branches, which the compiler
turns into vector code, instead of one goal's branches one after another. One goal is latency-bound
(square roots and divisions in a chain); 8 goals in lanes are not: on a Zen 4 the UR5's candidates
take 0.18 µs a goal this way against 0.69 µs one at a time, the PUMA 560's 0.20 against 0.79.

Same floats as the single call: each pass calls the branch-free stage functions the scalar solvers
call (:func:`~pipeline.solvers.closed_form.subproblems.p3_first`, ``p3_mid``, ``p3_last``, ``pos3d``,
``sph_wrist``), with the same operands in the same order; a lane computes every branch and masks the
invalid ones where the scalar call skips them. A goal on which a stage reports a free angle (a
degenerate subproblem, whose default needs the start's sine and cosine) is left to the single call
(:func:`take` returns ``free``), so the batch's candidates equal the single call's bit for bit.

Why the code looks as it does (each was needed for the compiler to vectorize; checked with LLVM's
``-pass-remarks=loop-vectorize``): every value a pass reads or writes lies in one scratch array ``L``
at a constant offset from its lane, indexed unsigned (a short loop gets no run-time overlap checks);
the arm is read into tuples before the passes; a pass holds no call into libm and no switch (the
position case is chosen outside the pass). And for the compiler's own time: numba inlines each stage
at the numba level (:func:`~pipeline.solvers.kernels.specialise.inlined_twin`; the single call does not) once
per pass, so the branches are lanes too, not passes of their own: the first
stage runs once over 16 lanes (8 goals × sa), the rest once over 32 (× sb), both candidates of the
last branch in the same pass. Written as one pass per branch, the spherical-wrist passes took numba
120 s to compile, against 38 s now, with the same speed.

Layout of ``L`` (:data:`SIZE` floats): rows of :data:`W` = 32 slots, slot ``16 sb + 8 ia + l`` for goal
l, first-stage branch sa = +1 (ia 0) or −1 (ia 1) and second-stage branch sb = +1 (0) or −1 (1): the
goal's rotation (9 rows, row-major) and position (3 rows), each goal in its 4 slots; the first stage
(:data:`STAGE` rows, written by the 16-lane pass into both sb slots); the two candidates of the last
branch (:data:`CAND` rows each: 6 e^{iθ} as real and imaginary parts, ok, free). :func:`take` reads a
goal's 8 in the single call's order.
"""

from __future__ import annotations

import numba
import numpy as np

from pipeline.solvers.closed_form import subproblems
from pipeline.solvers.kernels.specialise import inlined_twin

# the stage functions inlined into each pass at numba's level (a pass with a call left in it is not
# vectorized); the single call uses the same functions uninlined (far less for numba to compile)
sp = inlined_twin(subproblems)

LANES = 8
W = 4 * LANES  # a row of L: the 8 goals × (first-stage branch sa) × (second-stage branch sb)
GOAL = 12  # rows: the goal's rotation (9) and position (3), each goal in its 4 slots
STAGE = 11  # rows: the first stage for its second branch (3P: e^{-iθ1}, w1, z5, z6; sph: z1-z3), ok, free
CAND = 14  # rows: a candidate's z1..z6 (12), ok, free; two candidates (the last branch) a slot
C0 = GOAL + STAGE
SIZE = W * (C0 + 2 * CAND)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _ld(L, k, u):
    return L[np.uint64(W * k) + u]


@numba.njit(cache=True, error_model="numpy", inline="always")
def _ldz(L, k, u):
    return complex(_ld(L, k, u), _ld(L, k + 1, u))


@numba.njit(cache=True, error_model="numpy", inline="always")
def _st(L, k, u, x):
    L[np.uint64(W * k) + u] = x


@numba.njit(cache=True, error_model="numpy", inline="always")
def _stz(L, k, u, z):
    _st(L, k, u, z.real)
    _st(L, k + 1, u, z.imag)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _st2(L, k, u, x0, x1):
    """x0 into slot u (second branch +1), x1 into slot u + 16 (−1)."""
    _st(L, k, u, x0)
    _st(L, k, u + np.uint64(2 * LANES), x1)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _st2z(L, k, u, z0, z1):
    """:func:`_st2` of two e^{iθ} (real parts, then imaginary parts)."""
    _st2(L, k, u, z0.real, z1.real)
    _st2(L, k + 1, u, z0.imag, z1.imag)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _goal(L, u):
    g = (_ld(L, 0, u), _ld(L, 1, u), _ld(L, 2, u), _ld(L, 3, u), _ld(L, 4, u), _ld(L, 5, u), _ld(L, 6, u),
         _ld(L, 7, u), _ld(L, 8, u))
    return g, (_ld(L, 9, u), _ld(L, 10, u), _ld(L, 11, u))


@numba.njit(cache=True, error_model="numpy", inline="always")
def _cand(L, c, u, z1, z2, z3, z4, z5, z6, ok, free):
    k = C0 + CAND * c
    _stz(L, k, u, z1)
    _stz(L, k + 2, u, z2)
    _stz(L, k + 4, u, z3)
    _stz(L, k + 6, u, z4)
    _stz(L, k + 8, u, z5)
    _stz(L, k + 10, u, z6)
    _st(L, k + 12, u, 1.0 if ok else 0.0)
    _st(L, k + 13, u, 1.0 if free else 0.0)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _flags(L, u, ok0, ok1, free):
    """The first stage's ok of each second branch and its free flag (both slots)."""
    _st2(L, GOAL + 9, u, 1.0 if ok0 else 0.0, 1.0 if ok1 else 0.0)
    _st2(L, GOAL + 10, u, 1.0 if free else 0.0, 1.0 if free else 0.0)


# ---- three parallel axes ----------------------------------------------------------------------------
@numba.njit(cache=True, error_model="numpy", inline="always")
def _p3_a(fx, clip, L):
    """θ1 (branch sa: slots 0-7 +1, 8-15 −1) and (θ5, θ6); the second branch's (θ5, θ6) in slots + 16."""
    for lane in range(2 * LANES):
        u = np.uint64(lane)
        g, pg = _goal(L, u)
        tm, w1, a5, a6, b5, b6, ok, f = sp.p3_first(fx, g, pg, 1.0 if lane < LANES else -1.0, clip, sp.ONE)
        _st2z(L, GOAL, u, tm, tm)
        _st2(L, GOAL + 2, u, w1[0], w1[0])
        _st2(L, GOAL + 3, u, w1[1], w1[1])
        _st2(L, GOAL + 4, u, w1[2], w1[2])
        _st2z(L, GOAL + 5, u, a5, b5)
        _st2z(L, GOAL + 7, u, a6, b6)
        _flags(L, u, ok, ok, f)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _p3_b(fx, clip, L):
    """Every (sa, sb) slot: θ2 + θ3 + θ4, then the candidates of elbow +1 (c 0) and −1 (c 1)."""
    for lane in range(W):
        u = np.uint64(lane)
        g = _goal(L, u)[0]
        tm = _ldz(L, GOAL, u)
        w1 = (_ld(L, GOAL + 2, u), _ld(L, GOAL + 3, u), _ld(L, GOAL + 4, u))
        t5, t6 = _ldz(L, GOAL + 5, u), _ldz(L, GOAL + 7, u)
        ok, f = _ld(L, GOAL + 9, u) != 0.0, _ld(L, GOAL + 10, u) != 0.0
        t234, tgt, dd = sp.p3_mid(fx, g, tm, w1, t5, t6)
        v = sp.p3_last(fx, t234, tgt, dd, 1.0, clip, sp.ONE)
        _cand(L, 0, u, tm.conjugate(), v[0], v[1], v[2], t5, t6, ok & v[3], f | v[4])
        v = sp.p3_last(fx, t234, tgt, dd, -1.0, clip, sp.ONE)
        _cand(L, 1, u, tm.conjugate(), v[0], v[1], v[2], t5, t6, ok & v[3], f | v[4])


@numba.njit(cache=True, error_model="numpy")
def _three_parallel(H, P, RM, pM, clip, L):
    fx = sp.p3_fixed(H, P, RM, pM)
    _p3_a(fx, clip, L)
    _p3_b(fx, clip, L)


# ---- spherical wrist ------------------------------------------------------------------------------
@numba.njit(cache=True, error_model="numpy", inline="always")
def _st_pos(L, u, r):
    """A position stage's result (:func:`~pipeline.solvers.closed_form.subproblems.pos3d`): its branch +1 in slot u,
    −1 in slot u + 16."""
    _st2z(L, GOAL, u, r[0], r[4])
    _st2z(L, GOAL + 2, u, r[1], r[5])
    _st2z(L, GOAL + 4, u, r[2], r[6])
    _flags(L, u, r[3], r[7], r[8])


def _first_pass(pos):
    """The spherical wrist's first-stage pass for one position case (``pos``, one of
    :func:`~pipeline.solvers.closed_form.subproblems.pos_case1` .. ``pos_case4``): branch sa +1 in slots 0-7, −1 in
    8-15. One pass per case: a switch inside a pass keeps it scalar, and one pass with the case as an
    argument, inlined once per case, took the compiler minutes."""

    @numba.njit(cache=True, error_model="numpy", inline="always")
    def first(fx, clip, L):
        for lane in range(2 * LANES):
            u = np.uint64(lane)
            g, pg = _goal(L, u)
            w, sa = sp.sph_goal(fx, g, pg)[0], 1.0 if lane < LANES else -1.0
            _st_pos(L, u, pos(fx[0], fx[1], fx[3], fx[2], w, sa, clip, sp.ONE))

    return first


_sph_a1, _sph_a2, _sph_a3, _sph_a4 = (_first_pass(f) for f in (sp.pos_case1, sp.pos_case2, sp.pos_case3,
                                                               sp.pos_case4))


@numba.njit(cache=True, error_model="numpy", inline="always")
def _sph_b(fx, clip, L):
    """Every (sa, sb) slot: joints 4-6, the candidates of wrist branch +1 (c 0) and −1 (c 1)."""
    for lane in range(W):
        u = np.uint64(lane)
        g, pg = _goal(L, u)
        _, gh6, ge6 = sp.sph_goal(fx, g, pg)
        t1, t2, t3 = _ldz(L, GOAL, u), _ldz(L, GOAL + 2, u), _ldz(L, GOAL + 4, u)
        ok, f = _ld(L, GOAL + 9, u) != 0.0, _ld(L, GOAL + 10, u) != 0.0
        v = sp.sph_wrist(fx, gh6, ge6, t1, t2, t3, clip, sp.ONE, sp.ONE)
        ok, f = ok & v[6], f | v[7]
        _cand(L, 0, u, t1, t2, t3, v[0], v[1], v[2], ok, f)
        _cand(L, 1, u, t1, t2, t3, v[3], v[4], v[5], ok, f)


@numba.njit(cache=True, error_model="numpy")
def _spherical(case, H, P, RM, pM, clip, L):
    fx = sp.sph_fixed(case, H, P, RM, pM)
    if case == 1:
        _sph_a1(fx, clip, L)
    elif case == 2:
        _sph_a2(fx, clip, L)
    elif case == 3:
        _sph_a3(fx, clip, L)
    else:
        _sph_a4(fx, clip, L)
    _sph_b(fx, clip, L)


# ---- the block ----------------------------------------------------------------------------------------
def applies(n: int, fam: int, rev: int) -> bool:
    """Whether a packed arm (:func:`pipeline.solvers.closed_form.analytic.packed`) has lanes: a 6R arm of the spherical
    or three-parallel family read from the base (``rev`` 0)."""
    return n == 6 and rev == 0 and fam in (sp.FAM_SPH, sp.FAM_3P)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _load(goals, i0, L):
    """Goals ``i0 .. i0 + 7`` of ``goals`` (N, 4, 4) into the lanes of ``L``."""
    for lane in range(LANES):
        T = goals[i0 + lane]
        for r in range(3):
            for c in range(3):
                for k in range(4):
                    L[W * (3 * r + c) + LANES * k + lane] = T[r, c]
            for k in range(4):
                L[W * (9 + r) + LANES * k + lane] = T[r, 3]


@numba.njit(cache=True, error_model="numpy")
def candidates8_sph(case, H, P, RM, pM, clip, goals, i0, L):
    """The closed form's candidates of goals ``i0 .. i0 + 7`` (``goals`` (N, 4, 4)) into ``L`` (:data:`SIZE`),
    for a 6R arm with a spherical wrist and position case ``case``; read them with :func:`take`."""
    _load(goals, i0, L)
    _spherical(case, H, P, RM, pM, clip, L)


@numba.njit(cache=True, error_model="numpy")
def candidates8_3p(case, H, P, RM, pM, clip, goals, i0, L):
    """:func:`candidates8_sph` for a 6R arm with three parallel axes (``case`` unused)."""
    _load(goals, i0, L)
    _three_parallel(H, P, RM, pM, clip, L)


def candidates8(fam, case, H, P, RM, pM, clip, goals, i0, L):
    """:func:`candidates8_sph` or :func:`candidates8_3p` by family code ``fam`` (a Python call: the batch
    kernel of each family calls its own, :func:`pipeline.solvers.closed_form.analytic.kernels`)."""
    (candidates8_3p if fam == sp.FAM_3P else candidates8_sph)(case, H, P, RM, pM, clip, goals, i0, L)


@numba.njit(cache=True, error_model="numpy")
def no_lanes(case, H, P, RM, pM, clip, goals, i0, L):
    """A family without lanes (:func:`applies` is False for it): never called."""
    return


@numba.njit(cache=True, error_model="numpy")
def take(L, lane, Z):
    """Goal ``lane``'s valid candidates, in the single call's order (sa, sb, last branch), into ``Z``
    (complex, row r joint j at ``Z[6 r + j]``): (count, free). ``free``: a stage took a default for a
    free angle, so the single call must solve this goal (its default depends on the start)."""
    k = 0
    free = False
    for ia in range(2):
        for sb in range(2):
            slot = 2 * LANES * sb + LANES * ia + lane
            for c in range(2):
                o = C0 + CAND * c
                free |= L[W * (o + 13) + slot] != 0.0
                if L[W * (o + 12) + slot] != 0.0:
                    for j in range(6):
                        Z[6 * k + j] = complex(L[W * (o + 2 * j) + slot], L[W * (o + 2 * j + 1) + slot])
                    k += 1
    return k, free
