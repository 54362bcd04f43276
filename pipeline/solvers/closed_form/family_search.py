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

:func:`solve_search` is one function of about 200 lines, an exception to the 80-line rule: split into
helpers (the grid, the brackets, the dips, the regula falsi, the last two joints; inlined or not), the
same floats came 12-25 % slower on the offset-wrist arms (xarm6 58-62 µs against 50-52 µs a goal, crx10ia
61-66 against 51-55; the cause was not found), and kept whole it is as fast as before.
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


@numba.njit(cache=True, error_model="numpy")
def candidates(case, mode, H, P, RM, pM, Rg, pg, clip, pref, samples, Q, lim6):
    """:func:`solve_search` behind the families' one signature (the name ``FAMILY`` of
    :func:`pipeline.solvers.closed_form.analytic_kernels.core6`)."""
    return solve_search(mode, case, H, P, RM, pM, Rg, pg, clip, pref, samples, Q)
