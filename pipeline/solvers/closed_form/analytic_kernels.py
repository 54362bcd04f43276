"""The compiled kernels of ``analytic`` (:mod:`pipeline.solvers.closed_form.analytic`): one pose, a batch.

:func:`solve_pose` solves one goal whole (the family's candidates, read from the tool back where the arm
is reversed, or swept over a 7R arm's free joint; the vectorized FK check of every candidate; the valid
ones nearest the start first; the trace rows); :func:`call_pose` is the public single call fused with
the independent check; :func:`solve_batch_kernel` runs :func:`solve_pose` on every core, the closed form
of 8 goals at a time in vector lanes where the family has them. Each is a template compiled once per
family and joint count (:func:`kernels`, :class:`Kernels`), with the family's closed form bound in.

The arm comes packed (:func:`pipeline.solvers.closed_form.analytic.packed`: ``ints`` and the floats ``G``,
:func:`unpack` gives the views); every scratch array is allocated by the caller (:func:`scratch`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from pipeline.solvers.closed_form import family_3p, family_gen3r, family_search, family_sph, lanes
from pipeline.solvers.closed_form import subproblems as sp
from pipeline.solvers.closed_form.lines import (EYE_ACC, doc_row, fk_lines, fk_linesz, joint_line, poe_step,
                                                pose_within, times_home, twelve, within_goal)
from pipeline.solvers.core import finish_packed
from pipeline.solvers.kernels.kin import NO_SOLUTION, SUCCESS, TRACE_COLS, borrowed, grid, now_ns

# ---- compiled: one pose ---------------------------------------------------------------------------


@numba.njit(cache=True, error_model="numpy")
def check_rows(H, P, m, g, Cz, Sz, k, tolp2, f_max):
    """FK check of the closed form's k candidate rows at once, one candidate per vector lane: bit r of
    the returned int is set where row r's pose lies within the tolerances of the goal ``g``
    (:func:`within_goal`). ``Cz``, ``Sz``: each joint's cos and sin, joint-major (joint i of row r at
    ``i k + r``), k a multiple of 8 below 64 (:func:`_joint_major` pads the rows); ``m`` the home pose
    (12 floats). Written so that the compiler vectorizes the rows on every CPU: the six factors
    written out, not looped over; the verdicts OR-ed into one integer, not stored (with no store in
    the loop no run-time check that the rows and the verdicts do not overlap is needed: on a Zen 4
    the cost of those checks made the compiler keep the stored-verdict loop scalar, 570-640 ns for
    8 rows); each joint's cos and sin a view indexed by an unsigned row number (no wrap-around
    select, so contiguous vector loads); the rows in blocks of 8 (a constant trip count, so no
    scalar remainder). 8 rows take 150-190 ns there."""
    l0, l1, l2 = joint_line(H, P, 0), joint_line(H, P, 1), joint_line(H, P, 2)
    l3, l4, l5 = joint_line(H, P, 3), joint_line(H, P, 4), joint_line(H, P, 5)
    c0, c1, c2, c3, c4, c5 = Cz[0:k], Cz[k:2 * k], Cz[2 * k:3 * k], Cz[3 * k:4 * k], Cz[4 * k:5 * k], Cz[5 * k:6 * k]
    s0, s1, s2, s3, s4, s5 = Sz[0:k], Sz[k:2 * k], Sz[2 * k:3 * k], Sz[3 * k:4 * k], Sz[4 * k:5 * k], Sz[5 * k:6 * k]
    ok = 0
    for b in range(0, k, 8):
        for lane in range(8):  # a constant trip count: one vector of 8 rows, no scalar remainder
            r = np.uint64(b + lane)
            a = poe_step(EYE_ACC, l0, c0[r], s0[r])
            a = poe_step(a, l1, c1[r], s1[r])
            a = poe_step(a, l2, c2[r], s2[r])
            a = poe_step(a, l3, c3[r], s3[r])
            a = poe_step(a, l4, c4[r], s4[r])
            a = poe_step(a, l5, c5[r], s5[r])
            ok |= np.int64(within_goal(times_home(a, m), g, tolp2, f_max)) << r
    return ok


# ---- compiled: one family's closed form ---------------------------------------------------------------
# The three families behind one signature (case, mode, H, P, RM, pM, Rg, pg, clip, pref, samples, Q, lim6):
# ``candidates`` of family_sph, family_3p, family_search. Each kernel below (core6, solve_pose, call_pose,
# solve_batch_kernel) is compiled per family, with the name FAMILY bound to one of these (:func:`kernels`),
# so that a robot's first call compiles its own family's closed form only.


# the names the templates below call, bound per family by :func:`kernels` (never called as they are here),
# and the constants of each copy: its family code and joint count
FAMILY = CORE6 = SOLVE_POSE = LANES8 = None
FAM, NJ = 0, 0


def core6(case, rev, mode, H, P, RM, pM, Rg, pg, clip, pref, samples, Q, lim6, Wr, Qr):
    """Candidates of a 6R chain of this copy's family into Q (complex (16, 6): rows of e^{iθ} of THIS
    chain's joints); ``pref`` (6,) the angles [rad] taken where one is free; ``lim6`` (6, 2) the
    limits a spherical-wrist branch must fit (±inf: every solution). ``Wr`` (75,) and ``Qr`` (16, 6):
    scratch for a chain read from the tool back. A template: :func:`kernels` compiles it per family."""
    if rev == 0:
        return FAMILY(case, mode, H, P, RM, pM, Rg, pg, clip, pref, samples, Q, lim6)
    # read from the tool back: lines moved by M⁻¹ in reverse order, home M⁻¹, goal T⁻¹, angles −θ
    Hr, Pr, RMr = grid(Wr, 6, 3), grid(Wr[18:], 6, 3), grid(Wr[36:], 3, 3)
    pMr, Rgr, prefr, limr = Wr[45:48], grid(Wr[48:], 3, 3), Wr[57:63], grid(Wr[63:], 6, 2)
    for i in range(6):
        j = 5 - i
        hv = sp.matTvec(RM, (H[j, 0], H[j, 1], H[j, 2]))
        pv = sp.matTvec(RM, sp.sub((P[j, 0], P[j, 1], P[j, 2]), (pM[0], pM[1], pM[2])))
        Hr[i, 0], Hr[i, 1], Hr[i, 2] = hv[0], hv[1], hv[2]
        Pr[i, 0], Pr[i, 1], Pr[i, 2] = pv[0], pv[1], pv[2]
    pMv = sp.scl(-1.0, sp.matTvec(RM, (pM[0], pM[1], pM[2])))
    pMr[0], pMr[1], pMr[2] = pMv[0], pMv[1], pMv[2]
    for r in range(3):
        for k in range(3):
            RMr[r, k] = RM[k, r]
            Rgr[r, k] = Rg[k, r]
    pgr = sp.scl(-1.0, sp.matTvec(Rg, pg))
    for i in range(6):
        prefr[i] = -pref[5 - i]
        limr[i, 0], limr[i, 1] = -lim6[5 - i, 1], -lim6[5 - i, 0]
    k = FAMILY(case, mode, Hr, Pr, RMr, pMr, Rgr, pgr, clip, prefr, samples, Qr, limr)
    for r in range(min(k, Q.shape[0])):
        for i in range(6):
            Q[r, i] = Qr[r, 5 - i].conjugate()
    return k


@numba.njit(cache=True, error_model="numpy")
def _fix(H, P, RM, pM, k, v, H6, P6, RM6, pM6):
    """The 6R chain with joint k held at v (lines after k and M moved by E_k(v))."""
    hk = (H[k, 0], H[k, 1], H[k, 2])
    pk = (P[k, 0], P[k, 1], P[k, 2])
    c, s_ = math.cos(v), math.sin(v)
    r = 0
    for i in range(H.shape[0]):
        if i == k:
            continue
        h = (H[i, 0], H[i, 1], H[i, 2])
        p = (P[i, 0], P[i, 1], P[i, 2])
        if i > k:
            h = sp.rot(hk, c, s_, h)
            p = sp.add(pk, sp.rot(hk, c, s_, sp.sub(p, pk)))
        H6[r, 0], H6[r, 1], H6[r, 2] = h[0], h[1], h[2]
        P6[r, 0], P6[r, 1], P6[r, 2] = p[0], p[1], p[2]
        r += 1
    for j in range(3):
        col = sp.rot(hk, c, s_, (RM[0, j], RM[1, j], RM[2, j]))
        RM6[0, j], RM6[1, j], RM6[2, j] = col[0], col[1], col[2]
    pm = sp.add(pk, sp.rot(hk, c, s_, sp.sub((pM[0], pM[1], pM[2]), pk)))
    pM6[0], pM6[1], pM6[2] = pm[0], pm[1], pm[2]


@numba.njit(cache=True, error_model="numpy", inline="always")
def unpack(ints, G):
    """Views of the packed geometry ``G`` (:func:`pipeline.solvers.closed_form.analytic.packed`): H (n, 3),
    P (n, 3), RM (3, 3), pM (3,),
    par (3,), lim (n, 2)."""
    n = ints[0]
    o = 6 * n
    return (grid(G, n, 3), grid(G[3 * n:], n, 3), grid(G[o:], 3, 3), G[o + 9:o + 12], G[o + 12:o + 15],
            grid(G[o + 15:], n, 2))


@numba.njit(cache=True, error_model="numpy", inline="always")
def _views(n, cap, W, Z, I):
    """:func:`solve_pose`'s views of its scratch (:func:`scratch`): the closed form's rows Q and a reversed
    chain's Qr (complex (16, 6) each), each candidate's row of Q, fk_lines' e^{iθ} of each joint; R (3, 3),
    p, the candidates' distances (``cap``), each joint's last angle with its cos and sin (n, 3, set to
    NaN); the blocks of :func:`_w_blocks`: a 7R sweep's fixed chain, a reversed chain's, the angles."""
    Q, Qr, qrow = grid(Z, sp.MAX_SOL, 6), grid(Z[6 * sp.MAX_SOL:], sp.MAX_SOL, 6), I[2:2 + sp.MAX_SOL]
    Zf = Z[12 * sp.MAX_SOL:]
    R, p, dist = grid(W, 3, 3), W[9:12], W[12:12 + cap]
    cs = grid(W[12 + cap:], n, 3)
    cs[:] = math.nan
    o, o_rev, _, o_ang = _w_blocks(n, cap)
    return (Q, Qr, qrow, Zf, R, p, dist, cs, W[o:o + W_FIXED], W[o_rev:o_rev + W_REVERSED],
            W[o_ang:o_ang + W_ANGLES])


@numba.njit(cache=True, error_model="numpy", inline="always")
def _limits6(lim, free):
    """A 7R arm's limits (7, 2) without the free joint's: (6, 2)."""
    lim6 = np.empty((6, 2))
    r_ = 0
    for i in range(7):
        if i != free:
            lim6[r_, 0], lim6[r_, 1] = lim[i, 0], lim[i, 1]
            r_ += 1
    return lim6


@numba.njit(cache=True, error_model="numpy", inline="always")
def _collect6(H, P, m12, g12, Q, k, Wa, tolp2, f_max, search, lim, q_start, Sc, qrow, dist, cap):
    """A 6R arm's k closed-form candidates (rows of Q) FK-checked and turned into angles, both in
    vectorized passes over the candidates; the valid ones (wrapped to (−π, π]) into ``Sc`` with their
    row of Q (``qrow``) and distance from the start (``dist``), in the closed form's order: (count, how
    many lie within the limits, counted for a search only: only a search refines when none does)."""
    Cz, Sz, Ang, kv = _joint_major(Q, k, Wa)
    okv = check_rows(H, P, m12, g12, Cz, Sz, kv, tolp2, f_max)
    sp.angles_of(Sz, Cz, Ang, 6 * kv)
    nc = 0
    inlim = 0
    for r in range(k):
        if not (okv >> r) & 1:
            continue
        if nc >= cap:
            break
        qrow[nc] = r
        d = 0.0
        inside = True
        for j in range(6):
            x = Ang[j * kv + r]
            Sc[nc, j] = x
            if search and not sp.into_limits(x, lim[j, 0], lim[j, 1])[1]:
                inside = False
            e = sp.wrap(x - q_start[j])
            d += e * e
        dist[nc] = d
        nc += 1
        inlim += inside
    return nc, inlim


@numba.njit(cache=True, error_model="numpy", inline="always")
def _sweep_range(q_start, free, lim, pref, n):
    """A 7R sweep's start: the other joints' start angles into ``pref`` (6,) (the angles a free one takes),
    and the free joint's range swept (one turn at most; (−π, π) where unbounded)."""
    r_ = 0
    for i in range(n):
        if i != free:
            pref[r_] = q_start[i]
            r_ += 1
    lo, hi = lim[free, 0], lim[free, 1]
    if not (math.isfinite(lo) and math.isfinite(hi)):
        lo, hi = -math.pi, math.pi
    if hi - lo > 2.0 * math.pi:  # one turn: v and v + 2π give the same solutions
        hi = lo + 2.0 * math.pi
    return lo, hi


@numba.njit(cache=True, error_model="numpy", inline="always")
def _free_value(it, attempt, q_start, free, lim, lo, hi, nfree):
    """The free joint's value ``it`` of a 7R sweep: the start's value, then values beside it (a tracking
    user's answer lies there; not on the finer second attempt), then the grid: (value [rad], tried)."""
    if attempt == 1 and it <= N_NEAR:
        return 0.0, False
    if it == 0:
        return q_start[free], True
    if it <= N_NEAR:
        v = q_start[free] + NEAR[it - 1]
        return v, lim[free, 0] <= v <= lim[free, 1]
    return lo + (hi - lo) * (it - N_NEAR - 0.5) / nfree, True


@numba.njit(cache=True, error_model="numpy", inline="always")
def _collect7(Q, k, Wa, n, free, v, q_start, lim, Sc, dist, nc, cap):
    """The k candidates of the 6 other joints (rows of Q) at the free joint's value ``v``, each joint moved
    by turns to lie nearest the start within its limits (:func:`~pipeline.solvers.closed_form.subproblems.near_limits`);
    those that fit into ``Sc`` from row ``nc`` with their distance from the start: (count, those added)."""
    Cz, Sz, Ang, kv = _joint_major(Q, k, Wa)
    sp.angles_of(Sz, Cz, Ang, 6 * kv)
    added = 0
    for r in range(k):
        if nc >= cap:
            break
        c_ = 0
        inside = True
        d = 0.0
        for j in range(n):
            if j == free:
                x = v
            else:
                x = Ang[c_ * kv + r]
                c_ += 1
            x, ok = sp.near_limits(x, q_start[j], lim[j, 0], lim[j, 1])
            if not ok:
                inside = False
                break
            Sc[nc, j] = x
            e = x - q_start[j]
            d += e * e
        if inside:
            dist[nc] = d
            nc += 1
            added += 1
    return nc, added


# two solutions whose joints differ by at most this, each (wrapped by turns), are one [rad]: far above the
# spread of one root computed along two branches (1e-12 .. 1e-9: the FK check passes at 1e-9), below any
# two distinct solutions a closed form resolves (a subproblem's two roots closer than this sit at a
# tangency whose discriminant is below 1e-12, i.e. within the rounding ``clip`` forgives)
DISTINCT_TOL = 1e-6


@numba.njit(cache=True, error_model="numpy", inline="always")
def _same(a, b, n):
    """Rows a and b (n angles [rad]) are one solution: every joint within DISTINCT_TOL, wrapped."""
    for j in range(n):
        if abs(sp.wrap(a[j] - b[j])) > DISTINCT_TOL:
            return False
    return True


@numba.njit(cache=True, error_model="numpy", inline="always")
def _repeats(S, m, row, n):
    """``row`` is one of the m solutions in S already (:func:`_same`)."""
    for i in range(m):
        if _same(S[i], row, n):
            return True
    return False


@numba.njit(cache=True, error_model="numpy", inline="always")
def _distinct6(Sc, dist, nc):
    """A 6R arm's checked candidates: a repeat of an earlier one (:func:`_same`) is dropped (its distance
    set to inf, which :func:`_rank6` never takes)."""
    for i in range(1, nc):
        for j in range(i):
            if dist[j] < math.inf and _same(Sc[i], Sc[j], 6):
                dist[i] = math.inf
                break


@numba.njit(cache=True, error_model="numpy", inline="always")
def _retry(inlim, refine, n, fam, samples, nfree):
    """(whether a second attempt runs, its search samples, its free-joint values): only where nothing
    was within the limits and the arm searches (6R search family) or sweeps (7R), ``refine`` times finer."""
    if inlim > 0 or refine <= 1 or (n == 6 and fam != sp.FAM_SEARCH):
        return False, samples, nfree
    return True, samples * refine, nfree * refine


@numba.njit(cache=True, error_model="numpy", inline="always")
def _seen(vals, k, v):
    """A 7R sweep's free-joint value ``v`` [rad] was tried already in this attempt (equal limits, or the
    start's value on the grid): within 1e-12 rad, wrapped."""
    for i in range(k):
        if abs(sp.wrap(vals[i] - v)) <= 1e-12:
            return True
    return False


@numba.njit(cache=True, error_model="numpy", inline="always")
def _rank6(Sc, dist, qrow, nc, max_sol, S):
    """A 6R arm's checked candidates into ``S`` nearest first: each one's place among them by distance,
    ties in candidate order (the order of a selection nearest first), without a data-dependent branch;
    (count, the row of Q the nearest came from)."""
    m = 0
    chosen = -1
    for i in range(nc):
        di = dist[i]
        rk = 0
        for j in range(nc):
            dj = dist[j]
            rk += (dj < di) | ((dj == di) & (j < i))
        if di < math.inf and rk < max_sol:  # (a NaN distance, from a NaN start, is never taken)
            for j in range(6):
                S[rk, j] = Sc[i, j]
            if rk == 0:
                chosen = qrow[i]
            m += 1
    return m, chosen


@numba.njit(cache=True, error_model="numpy", inline="always")
def _select7(H, P, RM, pM, Sc, dist, nc, max_sol, S, R, p, cs, Zf, Tg, tolp2, f_max, n):
    """A 7R sweep's candidates nearest first: select, FK-check, keep, until ``max_sol`` pass; the count."""
    m = 0
    for _ in range(nc):
        if m >= max_sol:
            break
        best = -1
        bd = math.inf
        for r in range(nc):
            if dist[r] < bd:
                bd = dist[r]
                best = r
        if best < 0:
            break
        dist[best] = math.inf
        if _repeats(S, m, Sc[best], n):
            continue
        fk_lines(H, P, RM, pM, Sc[best], R, p, cs, Zf)
        if pose_within(R, p, Tg, tolp2, f_max):
            for j in range(n):
                S[m, j] = Sc[best, j]
            m += 1
    return m


@numba.njit(cache=True, error_model="numpy", inline="always")
def _chosen(S, q, m, n, q_start):
    """The rows of ``S`` past the m solutions set to NaN; ``q`` the nearest (a 6R arm's unwrapped to lie
    within π of the start per joint), or the start when there is none."""
    for a_ in range(m, S.shape[0]):
        for j in range(n):
            S[a_, j] = math.nan
    if m == 0:
        for j in range(n):
            q[j] = q_start[j]
    elif n == 6:
        for j in range(n):
            q[j] = q_start[j] + sp.wrap(S[0, j] - q_start[j])
    else:
        for j in range(n):
            q[j] = S[0, j]


@numba.njit(cache=True, error_model="numpy", inline="always")
def _trace_rows(H, P, RM, pM, q_start, q, Qc, Tg, R, p, cs, Zf, trace, start_row, m, n):
    """The trace's rows: the document's error at the start (when ``start_row`` or no solution) and at ``q``
    (a 6R arm's pose from the chosen candidate's own cos/sin ``Qc``: q differs from it by turns only)."""
    if start_row or m == 0:
        fk_lines(H, P, RM, pM, q_start, R, p, cs, Zf)
        doc_row(Tg, R, p, trace[0])
    if m == 0:
        for c in range(TRACE_COLS):
            trace[1, c] = trace[0, c]
    else:
        if n == 6:
            fk_linesz(H, P, RM, pM, Qc, R, p)
        else:
            fk_lines(H, P, RM, pM, q, R, p, cs, Zf)
        doc_row(Tg, R, p, trace[1])


def solve_pose(ints, G, Tg, q_start, Sc, W, Z, I, S, q, trace, start_row=True, given=-1, given_ns=0):
    """The FK-valid solutions of one pose, nearest to ``q_start`` first (wrapped joint distance, sum of
    squares), at most ``max_solutions`` into ``S``; ``q`` the chosen one. ``Sc`` (:func:`scratch`
    rows) holds the candidates: 6R, every closed-form candidate wrapped to (−π, π]; 7R, every
    candidate of every swept value (the start's value first) moved by turns to lie nearest the start
    within the joint limits (:func:`pipeline.solvers.closed_form.subproblems.near_limits`: a continuous joint does
    not jump a turn away from the seed; those that do not fit are dropped).
    Candidates are FK-checked nearest first until ``max_solutions`` pass or none is left, so a 7R
    sweep checks about as many as it returns. ``W``, ``Z``, ``I``: the float, complex and int scratch of
    :func:`scratch` (the caller allocates them once, for a batch once per work item). ``start_row``
    False: the trace's row at ``q_start`` is left unwritten unless no solution is found (a batch
    that keeps no traces needs only the row at ``q``). ``given`` >= 0: a 6R arm's closed-form candidates
    are in Z's first rows already, that many (the batch's lanes, :mod:`pipeline.solvers.closed_form.lanes`), and
    ``given_ns`` [ns] their share of the time. Returns (solutions, candidates, solve time [ns])."""
    # every array below is a borrowed view: no atomic reference counting on the per-pose path
    ints, G, Tg, q_start, Sc, W, Z, I, S, q, trace = (
        borrowed(ints), borrowed(G), borrowed(Tg), borrowed(q_start), borrowed(Sc), borrowed(W), borrowed(Z),
        borrowed(I), borrowed(S), borrowed(q), borrowed(trace))
    clk = I[0:2]
    t0 = now_ns(clk)
    H, P, RM, pM, par, lim = unpack(ints, G)
    n, fam = NJ, FAM  # this copy's constants (:func:`kernels`): the other arm's and family's branches not compiled
    case, rev, free, samples, nfree, mode = ints[2], ints[3], ints[4], ints[5], ints[6], ints[7]
    max_sol = min(ints[8], S.shape[0])
    clip, tolp, tolr = par[0], par[1], par[2]
    tolp2, f_max = tolp * tolp, 8.0 * math.sin(0.5 * tolr) ** 2
    m12, g12 = twelve(RM, pM), twelve(Tg, Tg[:, 3])  # the home pose and the goal, 12 floats each
    Rg, pg = Tg, (Tg[0, 3], Tg[1, 3], Tg[2, 3])  # Rg: its rotation block is read
    cap = Sc.shape[0]
    Q, Qr, qrow, Zf, R, p, dist, cs, Wf, Wr, Wa = _views(n, cap, W, Z, I)
    nc, tried, inlim, refine = 0, 0, 0, ints[9]  # candidates in Sc, tried, within the limits; refine factor
    nolim = grid(G[8 * n + 15:], 6, 2)  # ±inf: a 6R arm's closed form keeps every branch
    lim6 = _limits6(lim, free) if n == 7 else nolim
    for attempt in range(2):
        if attempt == 1:
            # nothing within the limits: the search (6R) or the sweep (7R) once more on a finer grid
            go, samples, nfree = _retry(inlim, refine, n, fam, samples, nfree)
            if not go:
                break
            nc = 0  # a 6R search finds its earlier candidates again; a 7R sweep kept none
        inlim = 0
        if n == 6:
            # every candidate is checked (in the order the closed form gives them: shared angles reuse
            # their sine and cosine); the valid ones compete by distance below
            if given >= 0:
                k = given
            else:
                k = min(CORE6(case, rev, mode, H, P, RM, pM, Rg, pg, clip, q_start, samples, Q, nolim, Wr, Qr),
                        sp.MAX_SOL)
            tried += k
            nc, inlim = _collect6(H, P, m12, g12, Q, k, Wa, tolp2, f_max, fam == sp.FAM_SEARCH, lim, q_start, Sc,
                                  qrow, dist, cap)
        else:
            H6, P6 = grid(Wf, 6, 3), grid(Wf[18:], 6, 3)
            RM6, pM6, pref = grid(Wf[36:], 3, 3), Wf[45:48], Wf[48:54]
            lo, hi = _sweep_range(q_start, free, lim, pref, n)
            seen = np.empty(nfree + 1 + N_NEAR)  # the values tried in this attempt
            ns_ = 0
            for it in range(nfree + 1 + N_NEAR):
                v, use = _free_value(it, attempt, q_start, free, lim, lo, hi, nfree)
                if not use or _seen(seen, ns_, v):
                    continue
                seen[ns_] = v
                ns_ += 1
                _fix(H, P, RM, pM, free, v, H6, P6, RM6, pM6)
                k = min(CORE6(case, rev, mode, H6, P6, RM6, pM6, Rg, pg, clip, pref, samples, Q, lim6, Wr, Qr),
                        sp.MAX_SOL)
                tried += k
                nc, added = _collect7(Q, k, Wa, n, free, v, q_start, lim, Sc, dist, nc, cap)
                inlim += added
    chosen = -1  # 6R: the row of Q the chosen solution came from
    if n == 6:  # every candidate is checked already
        _distinct6(Sc, dist, nc)
        m, chosen = _rank6(Sc, dist, qrow, nc, max_sol, S)
    else:  # 7R: nearest first, select, FK-check, keep, until max_solutions pass
        m = _select7(H, P, RM, pM, Sc, dist, nc, max_sol, S, R, p, cs, Zf, Tg, tolp2, f_max, n)
    _chosen(S, q, m, n, q_start)
    ns = now_ns(clk) - t0 + given_ns
    _trace_rows(H, P, RM, pM, q_start, q, Q[max(chosen, 0)], Tg, R, p, cs, Zf, trace, start_row, m, n)
    return m, tried, ns


def solve_batch_kernel(ints, G, goals, starts, S, Qo, traces, doc, nsol, tried, ns, use_lanes):
    """:func:`solve_pose` for every row, on every core: work items of 32 poses, one scratch each;
    every pose writes only its own rows (results independent of the thread count). ``doc`` (N,):
    the document's error at each ``q``; ``traces`` (N, 2, 8) the trace rows, or (0, 2, 8) when no
    trace is kept (each pose's rows then go to its work item's scratch, the row at the start unwritten).
    ``use_lanes`` (:func:`pipeline.solvers.closed_form.lanes.applies`): the closed form's candidates of 8 poses at a
    time in vector lanes (:func:`candidates8`; the same floats as the single
    call), each pose's time its share of the block's; a pose whose closed form takes a default, and
    the poses past a work item's last 8, solved alone."""
    N = goals.shape[0]
    chunk = 32
    keep = traces.shape[0] == N
    gb, sb, Sb, Qb, tb = borrowed(goals), borrowed(starts), borrowed(S), borrowed(Qo), borrowed(traces)
    ib, Gb = borrowed(ints), borrowed(G)  # shared by the threads: no count updates on one cache line
    case = ints[2]
    H, P, RM, pM, par, _ = unpack(ib, Gb)
    clip = par[0]
    for c in numba.prange((N + chunk - 1) // chunk):
        Sc, W, Z, I = scratch(ints)
        own = np.empty((2, TRACE_COLS))
        L = np.empty(lanes.SIZE)
        Scb, Wb, Zb, Ib, ob, Lb = borrowed(Sc), borrowed(W), borrowed(Z), borrowed(I), borrowed(own), borrowed(L)
        hi = min(N, (c + 1) * chunk)
        for i8 in range(c * chunk, hi, lanes.LANES):
            block = use_lanes and i8 + lanes.LANES <= hi
            share = 0
            if block:
                t0 = now_ns(Ib)
                LANES8(case, H, P, RM, pM, clip, gb, i8, Lb)
                share = (now_ns(Ib) - t0) // lanes.LANES
            for i in range(i8, min(hi, i8 + lanes.LANES)):
                given = -1
                if block:
                    k, free = lanes.take(Lb, i - i8, Zb)
                    if not free:
                        given = k
                tr = tb[i] if keep else ob
                m, t, dt = SOLVE_POSE(ib, Gb, gb[i], sb[i], Scb, Wb, Zb, Ib, Sb[i], Qb[i], tr, keep, given,
                                      share if given >= 0 else 0)
                doc[i] = tr[1, 0]
                nsol[i] = m
                tried[i] = t
                ns[i] = dt
        # the work item's scratch read after its last borrowed use (numba frees a local after its last use)
        I[0] = Sc.shape[0] + W.shape[0] + Z.shape[0] + own.shape[0] + L.shape[0]


@numba.njit(cache=True, error_model="numpy")
def _capacity(ints):
    """Scratch rows per pose: 16 for 6R, 16 per swept value for 7R."""
    return sp.MAX_SOL if ints[0] == 6 else sp.MAX_SOL * (ints[6] + 1 + N_NEAR)


# 7R: the free joint's values tried beside the start's before the grid [rad] (a warm start's nearest
# solution usually lies on the self-motion within a few tenths of a radian of the seed's value)
NEAR = np.array([-0.05, 0.05, -0.15, 0.15, -0.3, 0.3])
N_NEAR = len(NEAR)


# the float scratch W: R (9) and p (3) of a pose, the candidates' distances (capacity), each joint's
# last angle with its cos and sin (3 n), then these blocks
W_FIXED = 54  # a 7R sweep's fixed 6R chain: H (18), P (18), RM (9), pM (3), the start's other angles (6)
W_REVERSED = 75  # a chain read from the tool back (core6): H, P, RM, pM, the goal's R, pref (6), limits (12)
W_GOAL = 16  # the goal (4, 4) scaled to the working unit (call_pose)
W_ANGLES = 18 * sp.MAX_SOL  # up to MAX_SOL candidate rows: their cosines, sines and angles (6 each, _joint_major)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _w_blocks(n, cap):
    """Offsets in W of the fixed-chain, reversed-chain, goal and angle blocks."""
    o = 12 + cap + 3 * n
    return o, o + W_FIXED, o + W_FIXED + W_REVERSED, o + W_FIXED + W_REVERSED + W_GOAL


@numba.njit(cache=True, error_model="numpy", inline="always")
def _joint_major(Q, k, Wa):
    """(Cz, Sz, Ang, kv): views of W's angle block ``Wa``, with the cos and sin of the 6 joints of Q's
    first k rows written joint-major into Cz and Sz (joint i of row r at ``i kv + r``), for the passes
    over all candidates at once (:func:`check_rows`, :func:`~pipeline.solvers.closed_form.subproblems.angles_of`
    into Ang). The rows are padded to kv, k rounded up to a multiple of 8 with the zero angle: a
    vector pass then has no scalar remainder (one of 7 rows took 2.6 times as long per row as 8)."""
    kv = (k + 7) // 8 * 8
    Cz, Sz, Ang = Wa[0:6 * sp.MAX_SOL], Wa[6 * sp.MAX_SOL:12 * sp.MAX_SOL], Wa[12 * sp.MAX_SOL:18 * sp.MAX_SOL]
    for r in range(kv):
        for i in range(6):
            z = Q[r, i] if r < k else 1.0 + 0.0j
            Cz[i * kv + r] = z.real
            Sz[i * kv + r] = z.imag
    return Cz, Sz, Ang, kv


@numba.njit(cache=True, error_model="numpy")
def scratch(ints):
    """The scratch of :func:`solve_pose`: candidates ``Sc`` (capacity, n); floats ``W`` (the pose's R
    and p, the candidates' distances, each joint's last cos/sin, then the blocks of :func:`_w_blocks`);
    complex ``Z`` (the closed form's e^{iθ} rows, 16 × 6 its own and 16 × 6 a reversed chain's, then 7
    for :func:`fk_lines`); ints ``I`` (the clock buffer, each candidate's row)."""
    n = ints[0]
    cap = _capacity(ints)
    return (np.empty((cap, n)), np.empty(_w_blocks(n, cap)[3] + W_ANGLES),
            np.empty(12 * sp.MAX_SOL + 7, np.complex128),
            np.zeros(2 + sp.MAX_SOL, np.int64))


def call_pose(ints, GC, Tg, q_start, S, q, trace):
    """The whole public single call in one compiled call: :func:`solve_pose`, then the result rule of
    every finish (:func:`pipeline.solvers.core.finish_packed`: the independent FK check of the chosen
    ``q`` by the dual-quaternion FK, the limit record, the stop reason; without ``require_limits``).
    ``GC`` = :func:`~pipeline.solvers.closed_form.analytic.packed`'s ``G``, then
    :func:`~pipeline.solvers.core.check_pack`, then the goal's
    unit factor (the robot file's unit to the working unit: ``Tg`` is scaled here, not in Python).
    Solutions ``-1`` (and nothing written) when ``Tg`` is not (4, 4) or ``q_start`` not (n,)."""
    n = ints[0]
    if Tg.shape[0] != 4 or Tg.shape[1] != 4 or q_start.shape[0] != n:
        return -1, 0, 0, NO_SOLUTION, False, False, math.nan, math.nan, False, math.nan
    ng = 8 * n + 27
    Sc, W, Z, I = scratch(ints)
    scale = GC[GC.shape[0] - 1]
    if scale != 1.0:  # the goal in the working unit (W's goal block)
        o_goal = _w_blocks(n, Sc.shape[0])[2]
        Tw = grid(W[o_goal:], 4, 4)
        for r in range(4):
            for c in range(4):
                Tw[r, c] = Tg[r, c] * scale if c == 3 and r < 3 else Tg[r, c]
        Tg = Tw
    m, tried, ns = SOLVE_POSE(ints, GC[:ng], Tg, q_start, Sc, W, Z, I, S, q, trace)
    # the check on borrowed views (no atomic reference counting in its calls); Tg itself, which may be a
    # view of this function's scratch (a borrowed view of it would outlive the scratch's last use)
    code, claimed, success, dp, ang, inside = finish_packed(borrowed(GC)[ng:], borrowed(q), Tg,
                                                            SUCCESS if m > 0 else NO_SOLUTION)
    return m, tried, ns, code, claimed, success, dp, ang, inside, trace[1, 0]


_CALL_SIGNATURE = (numba.types.int64[::1], numba.types.float64[::1], numba.types.float64[:, ::1],
                   numba.types.float64[::1], numba.types.float64[:, ::1], numba.types.float64[::1],
                   numba.types.float64[:, ::1])


FAMILY_NAMES = {sp.FAM_SPH: "spherical_wrist", sp.FAM_3P: "three_parallel", sp.FAM_SEARCH: "search",
                family_gen3r.FAM_SPH3R: "spherical_wrist_3r", family_gen3r.FAM_3PO: "three_parallel_offset"}
# each family's closed form behind the one signature of core6
FAMILY_CANDIDATES = {sp.FAM_SPH: family_sph.candidates, sp.FAM_3P: family_3p.candidates,
                     sp.FAM_SEARCH: family_search.candidates, family_gen3r.FAM_SPH3R: family_gen3r.candidates_sph3r,
                     family_gen3r.FAM_3PO: family_gen3r.candidates_3po}
_OPTIONS = {"cache": True, "error_model": "numpy"}


class Kernels:
    """One family's compiled kernels for arms of ``n`` joints (:func:`kernels`): ``core6``, ``solve_pose``,
    ``batch`` (:func:`solve_batch_kernel`) and ``call`` (:func:`call_pose` for its one signature), each
    compiled at its first use."""

    def __init__(self, code: int, n: int):
        from pipeline.solvers.kernels.specialise import specialise

        tag = f"{FAMILY_NAMES[code]}_{n}r"
        fam = FAMILY_CANDIDATES[code]
        lanes8 = LANES8_OF.get(code, lanes.no_lanes)
        self.core6 = specialise(core6, FAMILY_NAMES[code], _OPTIONS, FAMILY=fam)
        self.solve_pose = specialise(solve_pose, tag, _OPTIONS, CORE6=self.core6, FAM=code, NJ=n)
        self.batch = specialise(solve_batch_kernel, tag, {**_OPTIONS, "parallel": True}, SOLVE_POSE=self.solve_pose,
                                LANES8=lanes8)
        self._call = specialise(call_pose, tag, _OPTIONS, SOLVE_POSE=self.solve_pose)

    @property
    def call(self):
        """:func:`call_pose` compiled for its one signature (C-contiguous float64 arrays) and closed to any
        other: the fused call hands it the caller's arrays without checking them in Python (about 0.2 µs
        a call), and any other array (another dtype or layout, read-only, a list) is a TypeError on
        which the call converts its inputs first."""
        from pipeline.solvers.kernels.specialise import closed_to

        return closed_to(self._call, _CALL_SIGNATURE)


_KERNELS: dict[tuple[int, int], Kernels] = {}


def kernels(ints: np.ndarray) -> Kernels:
    """The compiled kernels of a packed arm's family and joint count
    (:func:`~pipeline.solvers.closed_form.analytic.packed`'s ``ints``), made once
    per process: each template above (:func:`core6`, :func:`solve_pose`, :func:`solve_batch_kernel`,
    :func:`call_pose`) with the family's closed form and the joint count bound in
    (:func:`pipeline.solvers.kernels.specialise.specialise`), so that a robot's first call compiles what its
    arm needs only (a UR arm's first call: its closed form, not the spherical wrist's nor the search's,
    and not the 7R sweep)."""
    key = (int(ints[1]), int(ints[0]))
    k = _KERNELS.get(key)
    if k is None:
        k = _KERNELS[key] = Kernels(*key)
    return k


LANES8_OF = {sp.FAM_SPH: family_sph.candidates8, sp.FAM_3P: family_3p.candidates8}  # the families with lanes


def candidates8(fam, case, H, P, RM, pM, clip, goals, i0, L):
    """The 8-goal lane pass of family ``fam`` (a Python call: the batch kernel of each family calls its own,
    :func:`kernels`): the closed form's candidates of goals ``i0 .. i0 + 7`` (``goals`` (N, 4, 4)) into
    ``L`` (:data:`pipeline.solvers.closed_form.lanes.SIZE` floats)."""
    LANES8_OF[fam](case, H, P, RM, pM, clip, goals, i0, L)
