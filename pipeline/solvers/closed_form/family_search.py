"""The searched family: two meeting axes at one end, a position case at the other, and a one-dimensional
search for the joint between them (the offset-wrist arms).

mode 4: axes 5-6 meet at ``c``; for each θ4 on a grid, ``E_1 E_2 E_3 (E_4 c) = w`` by the position case (4
branches), residual ``h5 · (R_1 R_2 R_3 R_4)ᵀ g − h5 · h6`` with ``g = R_goal R_Mᵀ h6`` (zero exactly when
``R_5 R_6`` can make the remaining rotation); mode 6: axes 4-5 meet, θ6 searched, the same with the roles
turned. Sign changes along each branch are bracketed (also up to the grid point where a branch stops
existing, whose edge is found by bisection), a cell where the branch's joints 1-3 turn fast is sampled 8
times finer, a dip of |f| between grid points is searched by golden section (a close pair of roots), and
each bracket is refined by regula falsi (Illinois); the last two angles then by sp1. Up to 16 solutions.

No lane pass: a search's cost is its residual evaluations, not one latency-bound chain.

The stages are functions of their own (the grid, the sign changes, the dips, the regula falsi, the last
two joints, the duplicate test); the pose's fixed inputs travel as one tuple ``ctx``, unpacked by
:func:`_ev` which numba inlines (``inline="always"``) where the residual is evaluated: as a call of its
own, passing every array of the tuple, it cost 10-15 % on the offset-wrist arms.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from pipeline.solvers.closed_form.subproblems import (add, any_perp, back3, case_point, cis, dot, gm, meet_point,
                                                      pos3pair, rotz, row, sp1, sub, wrist_target)


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


@numba.njit(cache=True, error_model="numpy", inline="always")
def _ev(ctx, t, F1, V1, TH):
    """:func:`_search_eval` at ``t`` with the pose's fixed inputs ``ctx`` = (mode, case, H, P, RM, pM, Rg,
    pg, o, c, w, g, hh, clip, pref)."""
    mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, clip, pref = ctx
    _search_eval(mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, t, clip, pref, F1, V1, TH)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _signed(ctx, t, b, sg, F1, V1, TH):
    """``sg · f_b(t)``, or 1e300 where branch ``b`` does not exist at ``t``."""
    _ev(ctx, t, F1, V1, TH)
    return sg * F1[b] if V1[b] else 1e300


@numba.njit(cache=True, error_model="numpy")
def _dip(ctx, b, lo, hi, sg, F1, V1, TH):
    """Golden-section search for the minimum of ``sg · f_b`` on [lo, hi] (both ends of sign ``sg``),
    stopped as soon as it goes below 0: (found, where, f there). A close pair of roots (or one
    near a branch's edge) leaves no sign change on the grid; this finds the point between them."""
    gr = 0.6180339887498949
    x1 = hi - gr * (hi - lo)
    x2 = lo + gr * (hi - lo)
    y1 = _signed(ctx, x1, b, sg, F1, V1, TH)
    y2 = _signed(ctx, x2, b, sg, F1, V1, TH)
    for _ in range(24):
        if min(y1, y2) < 0.0:
            break
        if y1 < y2:
            hi, x2, y2 = x2, x1, y1
            x1 = hi - gr * (hi - lo)
            y1 = _signed(ctx, x1, b, sg, F1, V1, TH)
        else:
            lo, x1, y1 = x1, x2, y2
            x2 = lo + gr * (hi - lo)
            y2 = _signed(ctx, x2, b, sg, F1, V1, TH)
    if y1 < y2:
        return y1 < 0.0, x1, sg * y1
    return y2 < 0.0, x2, sg * y2


@numba.njit(cache=True, error_model="numpy")
def _edge(ctx, b, good, bad, fg, F1, V1, TH):
    """Where branch ``b`` stops existing between ``good`` (it exists, residual ``fg``) and ``bad`` (it
    does not), by 16 bisections: (the last point where it exists, its residual there, and a point nearer
    the edge with its residual: the same two unless a root lies between them).

    At the edge a sub-problem's two roots meet, and near it the residual moves like the square root of
    the distance to the edge, fast: a goal whose joints 1-3 sit next to that meeting has its root within
    the last 1/65 536 of the cell, past the bisection's last point. The value at the edge is extrapolated
    from the last two points along that square root; where it may have the other sign than the last
    point (twice the extrapolated change allowed), the edge is bisected to rounding
    (:data:`EDGE_BISECTIONS` more) until a point of the other sign turns up, returned as the third value
    (its bracket with the last point then holds the root)."""
    g2, f2 = good, fg
    for _ in range(16):
        m = 0.5 * (good + bad)
        _ev(ctx, m, F1, V1, TH)
        if V1[b]:
            g2, f2 = good, fg
            good, fg = m, F1[b]
        else:
            bad = m
    xr, fr = good, fg
    d1, d2 = math.sqrt(abs(good - bad)), math.sqrt(abs(g2 - bad))
    if d2 > d1:
        change = 2.0 * (f2 - fg) * d1 / (d2 - d1)  # edge to last point, along the square root, doubled
        if fg * (fg - change) > 0.0:
            return good, fg, xr, fr
    for _ in range(EDGE_BISECTIONS):
        m = 0.5 * (xr + bad)
        if m == xr or m == bad:
            break
        _ev(ctx, m, F1, V1, TH)
        if V1[b]:
            xr, fr = m, F1[b]
            if fr * fg < 0.0:
                break
        else:
            bad = m
    return good, fg, xr, fr


EDGE_BISECTIONS = 40  # after the first 16: a cell of 2π/64 to below 1e-16 rad


@numba.njit(cache=True, error_model="numpy")
def _push(BR, BB, nb, a0, f0, a1, f1, b):
    """Store the bracket (a0, f0, a1, f1) of branch ``b`` as number ``nb``; the new count."""
    BR[nb, 0], BR[nb, 1], BR[nb, 2], BR[nb, 3] = a0, f0, a1, f1
    BB[nb] = b
    return nb + 1


@numba.njit(cache=True, error_model="numpy")
def _grid(ctx, N, Fs, Vs, THs):
    """Every branch at the ``N`` grid angles -π + 2πi/N, row N a copy of row 0 (the circle closed)."""
    step = 2.0 * math.pi / N
    for i in range(N):
        _ev(ctx, -math.pi + i * step, Fs[i], Vs[i], THs[i])
    for b in range(4):
        Fs[N, b] = Fs[0, b]
        Vs[N, b] = Vs[0, b]
        for j in range(3):
            THs[N, b, j] = THs[0, b, j]


@numba.njit(cache=True, error_model="numpy")
def _fine_cell(ctx, b, a0, f0, f1, step, BR, BB, nb, F1, V1, TH):
    """A cell where the branch's joints 1-3 turn fast (a near-singular position sub-problem): the
    residual may cross zero and back between grid points, so sample it 8 times finer."""
    xa, fa_ = a0, f0
    for kk in range(1, 9):
        xb = a0 + step * kk / 8.0
        if kk < 8:
            _ev(ctx, xb, F1, V1, TH)
            if not V1[b]:
                break
            fb_ = F1[b]
        else:
            fb_ = f1
        if fa_ * fb_ < 0.0 and nb < 64:
            nb = _push(BR, BB, nb, xa, fa_, xb, fb_, b)
        xa, fa_ = xb, fb_
    return nb


@numba.njit(cache=True, error_model="numpy")
def _sign_changes(ctx, N, Fs, Vs, THs, BR, BB, F1, V1, TH):
    """Brackets (lo, f(lo), hi, f(hi)) of the sign changes of each branch along the grid, a branch's
    edge inside a cell found by :func:`_edge`; their count."""
    step = 2.0 * math.pi / N
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
                if v0:
                    a1, f1, xr, fr = _edge(ctx, b, a0, a1, f0, F1, V1, TH)
                    if fr * f1 < 0.0 and nb < 64:  # a root between the last point and the edge
                        nb = _push(BR, BB, nb, a1, f1, xr, fr, b)
                else:
                    a0, f0, xr, fr = _edge(ctx, b, a1, a0, f1, F1, V1, TH)
                    if fr * f0 < 0.0 and nb < 64:
                        nb = _push(BR, BB, nb, xr, fr, a0, f0, b)
            if f0 * f1 <= 0.0:
                if nb < 64 and not (f1 == 0.0 and v1 and i + 1 < N):  # a zero on a grid point: once
                    nb = _push(BR, BB, nb, a0, f0, a1, f1, b)
                continue
            if not (v0 and v1):
                continue
            fast = 0.0
            for j in range(3):
                fast = max(fast, abs(THs[i + 1, b, j] - THs[i, b, j]))
            if fast > 0.35:
                nb = _fine_cell(ctx, b, a0, f0, f1, step, BR, BB, nb, F1, V1, TH)
    return nb


@numba.njit(cache=True, error_model="numpy")
def _dips(ctx, N, Fs, Vs, BR, BB, nb, F1, V1, TH):
    """No sign change on the grid: a close pair of roots (or a pair near a branch's edge) hides where
    |f| has a local minimum; look there (:func:`_dip`) when the parabola through the neighbours says it
    may cross, and bracket both roots. The new bracket count."""
    step = 2.0 * math.pi / N
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
            found, xm, fm = _dip(ctx, b, ai - step, ai + step, sg, F1, V1, TH)
            if not found or nb + 3 > 64:
                continue
            # one root between a_i and xm; the other between xm and the far side (its grid point, or
            # the branch's last valid point before its edge)
            far = ai + step if xm > ai else ai - step
            vf = vr if xm > ai else vl
            ff = fr if xm > ai else fl
            if not vf:
                far, ff, xr, fr = _edge(ctx, b, xm, far, fm, F1, V1, TH)
                if fr * ff < 0.0 and nb < 64:
                    nb = _push(BR, BB, nb, far, ff, xr, fr, b)
            nb = _push(BR, BB, nb, ai, fi, xm, fm, b)
            if ff * fm <= 0.0:
                nb = _push(BR, BB, nb, xm, fm, far, ff, b)
    return nb


@numba.njit(cache=True, error_model="numpy")
def _root(ctx, b, a0, f0, a1, f1, F1, V1, TH):
    """The root of branch ``b`` in the bracket [a0, a1] by Illinois regula falsi (a midpoint where the
    branch stops existing)."""
    if f0 == 0.0:
        return a0
    if f1 == 0.0:
        return a1
    a, fa, bb, fb = a0, f0, a1, f1
    root = bb
    for _ in range(60):
        m = bb - fb * (bb - a) / (fb - fa)
        _ev(ctx, m, F1, V1, TH)
        if not V1[b]:
            m = 0.5 * (a + bb)
            _ev(ctx, m, F1, V1, TH)
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
    return root


@numba.njit(cache=True, error_model="numpy")
def _wrist_pair(mode, H, Rg, RM, g, e5, e6, pref, t):
    """The two joints the search leaves, by sp1, into ``t`` (its joints 1-3 and the searched one set):
    mode 4, ``R5 R6 = (R1..R4)ᵀ RgM`` (θ5 from h6, θ6 from e6); mode 6, ``R4 R5 = (R1 R2 R3)ᵀ RgM R6ᵀ``
    (θ4 from h5, θ5 from e5)."""
    h4, h5, h6 = row(H, 3), row(H, 4), row(H, 5)
    t1, t2, t3 = t[0], t[1], t[2]
    if mode == 4:
        zr = t[3]
        nh6 = rotz(h4, zr.conjugate(), back3(H, t1, t2, t3, g))
        t[4] = sp1(h5, h6, nh6, pref[4])
        y = rotz(h4, zr.conjugate(), back3(H, t1, t2, t3, gm(Rg, RM, e6)))
        y = rotz(h5, t[4].conjugate(), y)
        t[5] = sp1(h6, e6, y, pref[5])
    else:
        zr = t[5]
        nh5 = back3(H, t1, t2, t3, gm(Rg, RM, rotz(h6, zr.conjugate(), h5)))
        t[3] = sp1(h4, h5, nh5, pref[3])
        y = back3(H, t1, t2, t3, gm(Rg, RM, rotz(h6, zr.conjugate(), e5)))
        y = rotz(h4, t[3].conjugate(), y)
        t[4] = sp1(h5, e5, y, pref[4])


@numba.njit(cache=True, error_model="numpy")
def _keep(Q, n, t):
    """Append ``t`` to the first ``n`` rows of ``Q`` unless it is there already (a root on a grid point
    is found from both of its intervals); the new count (rows past ``Q``'s are counted, not stored)."""
    for k in range(min(n, Q.shape[0])):
        dd = 0.0
        for j in range(6):
            dd += abs(Q[k, j] - t[j])
        if dd < 1e-9:
            return n
    if n < Q.shape[0]:
        for j in range(6):
            Q[n, j] = t[j]
    return n + 1


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
    ctx = (mode, case, H, P, RM, pM, Rg, pg, o, c, w, g, hh, clip, pref)
    N = samples
    Fs = np.empty((N + 1, 4))
    Vs = np.zeros((N + 1, 4), np.bool_)
    TH = np.empty((4, 3), np.complex128)
    THs = np.empty((N + 1, 4, 3), np.complex128)
    F1 = np.empty(4)
    V1 = np.zeros(4, np.bool_)
    BR = np.empty((64, 4))
    BB = np.empty(64, np.int64)
    _grid(ctx, N, Fs, Vs, THs)
    nb = _sign_changes(ctx, N, Fs, Vs, THs, BR, BB, F1, V1, TH)
    nb = _dips(ctx, N, Fs, Vs, BR, BB, nb, F1, V1, TH)
    t = np.zeros(6, np.complex128)
    e5, e6 = any_perp(h5), any_perp(h6)  # the wrist pair's reference directions, once per pose
    n = 0
    for kb in range(nb):
        b = BB[kb]
        root = _root(ctx, b, BR[kb, 0], BR[kb, 1], BR[kb, 2], BR[kb, 3], F1, V1, TH)
        _ev(ctx, root, F1, V1, TH)
        if not V1[b]:
            continue
        t[0], t[1], t[2] = TH[b, 0], TH[b, 1], TH[b, 2]
        t[3 if mode == 4 else 5] = cis(root)
        _wrist_pair(mode, H, Rg, RM, g, e5, e6, pref, t)
        n = _keep(Q, n, t)
    return n


@numba.njit(cache=True, error_model="numpy")
def candidates(case, mode, H, P, RM, pM, Rg, pg, clip, pref, samples, Q, lim6):
    """:func:`solve_search` behind the families' one signature (the name ``FAMILY`` of
    :func:`pipeline.solvers.closed_form.analytic_kernels.core6`)."""
    return solve_search(mode, case, H, P, RM, pM, Rg, pg, clip, pref, samples, Q)
