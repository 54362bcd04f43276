"""The scratch of the closed forms' 8-goal lane passes, one goal per vector lane, and its readers and writers.

The batch (:func:`pipeline.solvers.closed_form.analytic_kernels.solve_batch_kernel`) solves a 6R spherical-wrist or
three-parallel arm's goals in blocks of 8: each stage of the closed form (the first joint's branch,
the wrist, the planar 2R) runs as one pass over the 8 goals and their branches, which the compiler
turns into vector code, instead of one goal's branches one after another. One goal is latency-bound
(square roots and divisions in a chain); 8 goals in lanes are not: on a Zen 4 the UR5's candidates
take 0.18 µs a goal this way against 0.69 µs one at a time, the PUMA 560's 0.20 against 0.79.

The passes live beside their family's scalar stages (``candidates8`` of
:mod:`~pipeline.solvers.closed_form.family_sph` and :mod:`~pipeline.solvers.closed_form.family_3p`); this module
holds what they share. Same floats as the single call: each pass calls the branch-free stage functions
the scalar solvers call (:func:`~pipeline.solvers.closed_form.family_3p.p3_first`, ``p3_mid``, ``p3_last``,
:func:`~pipeline.solvers.closed_form.subproblems.pos3d`, :func:`~pipeline.solvers.closed_form.family_sph.sph_wrist`),
with the same operands in the same order; a lane computes every branch and masks the
invalid ones where the scalar call skips them. A goal on which a stage reports a free angle (a
degenerate subproblem, whose default needs the start's sine and cosine) is left to the single call
(:func:`take` returns ``free``), so the batch's candidates equal the single call's bit for bit.

Why the code looks as it does (each was needed for the compiler to vectorize; checked with LLVM's
``-pass-remarks=loop-vectorize``): every value a pass reads or writes lies in one scratch array ``L``
at a constant offset from its lane, indexed unsigned (a short loop gets no run-time overlap checks);
the arm is read into tuples before the passes; a pass holds no call into libm and no switch (the
position case is chosen outside the pass). And for the compiler's own time: numba inlines each stage
at the numba level (:func:`~pipeline.solvers.kernels.specialise.inlined_twin`; the single calls
inline a few of the same twins, where that pays for its compile time) once per pass, so the branches
are lanes too, not passes of their own: the first stage runs once over 16 lanes (8 goals × sa), the
rest once over 32 (× sb), both candidates of the last branch in the same pass. Written as one pass per branch, the spherical-wrist passes took numba
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

from pipeline.solvers.closed_form.subproblems import FAM_3P, FAM_SPH

LANES = 8
W = 4 * LANES  # a row of L: the 8 goals × (first-stage branch sa) × (second-stage branch sb)
GOAL = 12  # rows: the goal's rotation (9) and position (3), each goal in its 4 slots
STAGE = 11  # rows: the first stage for its second branch (3P: e^{-iθ1}, w1, z5, z6; sph: z1-z3), ok, free
CAND = 14  # rows: a candidate's z1..z6 (12), ok, free; two candidates (the last branch) a slot
C0 = GOAL + STAGE
SIZE = W * (C0 + 2 * CAND)


@numba.njit(cache=True, error_model="numpy", inline="always")
def ld(L, k, u):
    return L[np.uint64(W * k) + u]


@numba.njit(cache=True, error_model="numpy", inline="always")
def ldz(L, k, u):
    return complex(ld(L, k, u), ld(L, k + 1, u))


@numba.njit(cache=True, error_model="numpy", inline="always")
def st(L, k, u, x):
    L[np.uint64(W * k) + u] = x


@numba.njit(cache=True, error_model="numpy", inline="always")
def stz(L, k, u, z):
    st(L, k, u, z.real)
    st(L, k + 1, u, z.imag)


@numba.njit(cache=True, error_model="numpy", inline="always")
def st2(L, k, u, x0, x1):
    """x0 into slot u (second branch +1), x1 into slot u + 16 (−1)."""
    st(L, k, u, x0)
    st(L, k, u + np.uint64(2 * LANES), x1)


@numba.njit(cache=True, error_model="numpy", inline="always")
def st2z(L, k, u, z0, z1):
    """:func:`st2` of two e^{iθ} (real parts, then imaginary parts)."""
    st2(L, k, u, z0.real, z1.real)
    st2(L, k + 1, u, z0.imag, z1.imag)


@numba.njit(cache=True, error_model="numpy", inline="always")
def goal(L, u):
    g = (ld(L, 0, u), ld(L, 1, u), ld(L, 2, u), ld(L, 3, u), ld(L, 4, u), ld(L, 5, u), ld(L, 6, u),
         ld(L, 7, u), ld(L, 8, u))
    return g, (ld(L, 9, u), ld(L, 10, u), ld(L, 11, u))


@numba.njit(cache=True, error_model="numpy", inline="always")
def cand(L, c, u, z1, z2, z3, z4, z5, z6, ok, free):
    k = C0 + CAND * c
    stz(L, k, u, z1)
    stz(L, k + 2, u, z2)
    stz(L, k + 4, u, z3)
    stz(L, k + 6, u, z4)
    stz(L, k + 8, u, z5)
    stz(L, k + 10, u, z6)
    st(L, k + 12, u, 1.0 if ok else 0.0)
    st(L, k + 13, u, 1.0 if free else 0.0)


@numba.njit(cache=True, error_model="numpy", inline="always")
def flags(L, u, ok0, ok1, free):
    """The first stage's ok of each second branch and its free flag (both slots)."""
    st2(L, GOAL + 9, u, 1.0 if ok0 else 0.0, 1.0 if ok1 else 0.0)
    st2(L, GOAL + 10, u, 1.0 if free else 0.0, 1.0 if free else 0.0)


# ---- the block ----------------------------------------------------------------------------------------
def applies(n: int, fam: int, rev: int) -> bool:
    """Whether a packed arm (:func:`pipeline.solvers.closed_form.analytic.packed`) has lanes: a 6R arm of the spherical
    or three-parallel family read from the base (``rev`` 0)."""
    return n == 6 and rev == 0 and fam in (FAM_SPH, FAM_3P)


@numba.njit(cache=True, error_model="numpy", inline="always")
def load(goals, i0, L):
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
