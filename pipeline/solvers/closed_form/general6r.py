"""``general_6r``: every real solution of a 6R arm by algebraic elimination, whatever its geometry.

The subproblem closed forms (:mod:`pipeline.solvers.closed_form.analytic`) need intersecting or parallel axes.
An arm with neither is the general 6R problem, which has at most 16 solutions (Lee & Liang 1988;
Raghavan & Roth 1993). This solver follows the elimination of Raghavan and Roth in the matrix form
of Manocha and Canny (1994, "Efficient inverse kinematics for general 6R manipulators", IEEE Trans.
Robotics and Automation 10(5)), written here on the joint lines of the arm (product of
exponentials: ``E_i(θ)`` the rotation by θ about joint line i, ``T = E_1 ⋯ E_6 M``), so any robot
file form works:

1. With ``c`` a point on axis 6 and ``h_6`` its direction, ``E_6`` leaves both alone, so
   ``E_3 E_4 E_5 (c, h_6) = E_2⁻¹ E_1⁻¹ (w, g)`` with ``w = T M⁻¹ c`` and ``g = R_T R_Mᵀ h_6``.
   Measured from a point on axis 3, the point ``p`` and direction ``l`` of each side give the 14
   quantities of Raghavan and Roth: ``l``, ``p``, ``p·p``, ``l·p``, ``l × p`` and
   ``(p·p) l − 2 (l·p) p``. On the left they are linear in the nine products
   ``(s4, c4, 1) ⊗ (s5, c5, 1)`` with coefficients linear in ``(s3, c3, 1)``; on the right linear in
   ``(s1, c1, 1) ⊗ (s2, c2, 1)``. Both coefficient sets are found exactly by evaluating the
   quantities on a 3 × 3 (× 3) grid of angles and solving the (Kronecker) system: no symbolic
   expansion. The left set depends on the arm only (once per robot), the right one on the goal.
2. The 8 products of joints 1-2 are eliminated: the 6 rows of the left null space of their 14 × 8
   coefficient matrix give 6 equations in joints 3-5 only (a Householder QR with column pivoting,
   each row first scaled by a power of two to unit size: the 14 quantities have different units,
   and an unscaled null space leaves rounding of the large rows in the small ones).
3. Half-angle tangents ``x_i = tan(θ_i / 2)`` (each joint shifted by a fixed offset first, so that
   no solution sits at θ = π where ``x`` is infinite) turn them into 6 equations in the 9 monomials
   ``x4^i x5^j`` (i, j ≤ 2), quadratic in ``x3``; with the same equations times ``x4`` they are 12 in
   12 monomials, ``(M2 x3² + M1 x3 + M0) m = 0``. A Möbius change of variable (``_MOBIUS``) makes
   its leading matrix well conditioned. Its 24 × 24 companion matrix has 8 eigenvalues at ±i whatever
   the goal (the factor ``(1 + x3²)⁴`` of Raghavan and Roth's degree-24 polynomial); they are
   deflated (:func:`deflate`) and the real eigenvalues of the remaining 16 × 16 (:func:`eig_hess`,
   LAPACK ``dgeev`` its fallback) give joint 3; the null vector ``m`` (one step of inverse iteration)
   joints 4 and 5, the 14 equations joints 1 and 2 (least squares on the eliminated products) and the pose joint 6. The
   whole goal is one compiled call (:func:`_all_roots`).
4. Each root is polished by ``polish_steps`` Newton steps on the full pose and kept when the FK check
   (the compiled dual-quaternion check every result gets, with the settings' tolerances) passes;
   duplicates (a double root) are merged. ``q`` is the kept solution nearest ``q_start``, as for
   the other all-solution methods (:func:`pipeline.solvers.peers.geo._result`).

Near a singular configuration two roots merge: the eigenvalue turns slightly complex or the null
space of ``M(x3)`` two-dimensional, the root is then inaccurate or missed, and the Newton polish and
the FK check decide; a goal on the boundary of the workspace may lose its double root (measured:
the 40 most singular of 6 000 random configurations of each of 4 random arms, σ_min/σ_max down to
5e-7, all solved, the configuration itself among the solutions). Arms with
special geometry (a spherical wrist, parallel axes) can make the 12 × 12 pencil singular for every
``x3`` (their solutions are not isolated in this formulation: a spherical wrist's four solutions of
each elbow share one ``x3``). Once per robot three goals of the
arm's own configurations are solved, and when a configuration is not among its goal's roots the
next way of setting up the elimination is tried: the chain read from the tool back
(``T⁻¹ = T0⁻¹ E_6(−θ6) ⋯ E_1(−θ1)``: joint k of that chain is the arm's joint 7 − k, its line moved by
``T0⁻¹``), then the loop split the other way (:data:`SPLITS`: joints 2-4 on the left, the point on
axis 5, joints 1 and 6 on the right with the goal between them), on each chain. With these, every
general 6R arm tried here is solved, and 16 of the catalogue's 22 6R arms (UR arms, offset wrists,
some spherical wrists; ``analytic`` uses its subproblems for them: on 200 goals of each the two gave
the same solution sets on every goal). Where every way degenerates the arm is refused in one line
(measured: the PUMA 560, ABB IRB 120, Stäubli TX2-60 and the UR5e's URDF, each of which the
subproblems solve; an earlier SVD null space "solved" them through rounding noise of an exactly
singular pencil), as is an arm with two joint axes on one line (its joints are not independent).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numba.np.linalg import ensure_lapack

from pipeline.kinematics.fkcheck import check_one
from pipeline.solvers.kernels.kin import NO_SOLUTION, SUCCESS, TRACE_COLS, now_ns
from pipeline.solvers.closed_form.eigen import deflate, eig_hess, eigvals, mm, qr_split
from pipeline.solvers.closed_form.general6r_model import (KRON_OF, SHIFT, ArmModel, build_model, chain_into,
                                                         fk_model, fourteen_into, gauss_solve, newton_polish,
                                                         times_motion)
from pipeline.solvers.closed_form.lines import doc_row, fk_lines
from pipeline.solvers.core import (Prepared, Raw, Settings, unpack_check, check_fields, check_pack,
                                   finish_packed, setting)
from pipeline.solvers.core.driver import run_of
from pipeline.solvers.core.models import metric, six_revolute, wrap_angles
from pipeline.solvers.core.registry import Solver, register
from pipeline.solvers.closed_form.subproblems import wrap

ensure_lapack()

SOURCE = ("Raghavan & Roth (1993), Inverse kinematics of the general 6R manipulator and related linkages, ASME J. "
          "Mech. Des. 115; Manocha & Canny (1994), Efficient inverse kinematics for general 6R manipulators, IEEE "
          "Trans. Robot. Autom. 10(5) (their matrix formulation, written on the joint lines)")
_CHECK_Q = np.random.default_rng(606).uniform(-math.pi, math.pi, (3, 6))  # the arm's own test configurations


@dataclass(frozen=True)
class General6RSettings(Settings):
    max_solutions: int = setting(16, "solutions returned per goal at most, the nearest to the start", minimum=1,
                                 maximum=16)
    polish_steps: int = setting(4, "Newton steps on the full pose for each root of the eigenproblem", minimum=0,
                                maximum=50)
    real_tol: float = setting(1e-6, "an eigenvalue x3 counts as real when |Im x3| <= this times (1 + |x3|)",
                              above=0.0, maximum=1e-1)


_MOBIUS = (0.0, 0.25 * math.pi, 0.5 * math.pi, 0.75 * math.pi)  # x3 = tan(atan(y) + φ), tried in this order


@numba.njit(cache=True, error_model="numpy")
def _pencil(o, T0, Ps, Pc, P1, Rinv, RL, RC, RH, C, kron_of, T, mobius):
    """The goal's eliminated system: (ok, companion (24, 24), (a, b, c, d) of the change of variable
    ``x3 = (a y + b) / (c y + d)``, N (3, 12, 12) the pencil in ``y`` (N0, N1, N2), Qp (8, 14) the
    pseudo-inverse of the products of the right pair, P1 (14, 9) with the goal's constant folded in).
    ``o`` (3,): the point the quantities are measured from (on the left's first axis); the right side
    on the grid is ``RL[k] · G · (RC[k], RH[k])``, G = T M⁻¹."""
    R0, p0 = T0[:3, :3], T0[:3, 3]
    G = np.empty((3, 4))
    for r in range(3):
        for c_ in range(3):
            G[r, c_] = T[r, 0] * R0[c_, 0] + T[r, 1] * R0[c_, 1] + T[r, 2] * R0[c_, 2]
        G[r, 3] = T[r, 3] - (G[r, 0] * p0[0] + G[r, 1] * p0[1] + G[r, 2] * p0[2])
    Y = np.empty((9, 14))
    w, g, pr, lr = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    for k in range(9):
        for r in range(3):
            w[r] = G[r, 0] * RC[k, 0] + G[r, 1] * RC[k, 1] + G[r, 2] * RC[k, 2] + G[r, 3]
            g[r] = G[r, 0] * RH[k, 0] + G[r, 1] * RH[k, 1] + G[r, 2] * RH[k, 2]
        for r in range(3):
            pr[r] = RL[k, r, 0] * w[0] + RL[k, r, 1] * w[1] + RL[k, r, 2] * w[2] + RL[k, r, 3] - o[r]
            lr[r] = RL[k, r, 0] * g[0] + RL[k, r, 1] * g[1] + RL[k, r, 2] * g[2]
        fourteen_into(pr, lr, Y[k])
    coef = mm(Rinv, Y)  # (9, 14), Kronecker order of (s1, c1, 1) ⊗ (s2, c2, 1)
    Q = np.empty((14, 8))
    P1m = P1.copy()
    for t in range(9):
        for r in range(14):
            if t < 8:
                Q[r, t] = coef[kron_of[t], r]
            else:
                P1m[r, 8] -= coef[kron_of[t], r]
    pen = np.zeros((3, 12, 12))
    comp = np.zeros((24, 24))
    Qp = np.zeros((8, 14))
    Nl = np.empty((6, 14))  # the left null space of Q
    if not qr_split(Q, Qp, Nl):
        return False, comp, (1.0, 0.0, 0.0, 1.0), pen, Qp, P1m
    Ss, Sc, S1 = mm(Nl, Ps), mm(Nl, Pc), mm(Nl, P1m)
    A0, A1, A2 = mm(S1 + Sc, C), mm(2.0 * Ss, C), mm(S1 - Sc, C)  # x3^0, x3^1, x3^2: (6, 9) each
    M = np.zeros((3, 12, 12))
    for k, Ak in enumerate((A0, A1, A2)):
        for i in range(3):
            for j in range(3):
                for r in range(6):
                    M[k, r, 3 * i + j] = Ak[r, 3 * i + j]
                    M[k, 6 + r, 3 * (i + 1) + j] = Ak[r, 3 * i + j]
    # x3 = (a y + b) / (c y + d): (c y + d)² M(x3) = N2 y² + N1 y + N0, N2 = c² M(a / c) well conditioned
    for phi in mobius:
        a, b, c_, d = math.cos(phi), math.sin(phi), -math.sin(phi), math.cos(phi)
        pen[2] = a * a * M[2] + a * c_ * M[1] + c_ * c_ * M[0]
        pen[1] = 2.0 * a * b * M[2] + (a * d + b * c_) * M[1] + 2.0 * c_ * d * M[0]
        pen[0] = b * b * M[2] + b * d * M[1] + d * d * M[0]
        X, ok = gauss_solve(pen[2].copy(), np.hstack((pen[0], pen[1])))  # N2⁻¹ (N0 | N1): (12, 24)
        big = 0.0
        for r in range(12):
            for c2 in range(24):
                big = max(big, abs(X[r, c2]))
        if ok and big <= 1e10:  # N2 well conditioned enough: the companion's entries stay moderate (NaN fails too)
            for r in range(12):
                comp[r, 12 + r] = 1.0
                for c2 in range(24):
                    comp[12 + r, c2] = -X[r, c2]
            return True, comp, (a, b, c_, d), pen, Qp, P1m
    return False, comp, (1.0, 0.0, 0.0, 1.0), pen, Qp, P1m


@numba.njit(cache=True, error_model="numpy", inline="always")
def _null_monomials(pen, y, rhs12, Ny, Nw, z0, mono):
    """The null vector of the pencil at ``y`` (its monomials x4^i x5^j, i <= 3, j <= 2, into ``mono``
    (4, 3)) by one step of inverse iteration from ``rhs12`` (12,), the matrix nudged off exact
    singularity by a relative 1e-13 on its diagonal; on a zero pivot (a monomial no equation holds, on
    special arms) the SVD's null vector. ``Ny``, ``Nw`` (12, 12), ``z0`` (12, 1): scratch."""
    big = 0.0
    for r in range(12):
        for c2 in range(12):
            x_ = pen[2, r, c2] * (y * y) + pen[1, r, c2] * y + pen[0, r, c2]
            Ny[r, c2] = x_
            big = max(big, abs(x_))
    for r in range(12):
        Ny[r, r] += 1e-13 * big
    for r in range(12):
        z0[r, 0] = rhs12[r]
        for c2 in range(12):
            Nw[r, c2] = Ny[r, c2]
    z, ok = gauss_solve(Nw, z0)
    if ok:
        for r in range(12):
            mono[r // 3, r % 3] = z[r, 0]
    else:
        vt = np.linalg.svd(Ny)[2]
        for r in range(12):
            mono[r // 3, r % 3] = vt[11, r]


@numba.njit(cache=True, error_model="numpy", inline="always")
def _point_joint(H, P, T0, T, q, jp, A, B, Bs, R6, RG, Rs, us):
    """The angle [rad] of joint ``jp`` (the one whose axis carries the point) from the others' in ``q``:
    R_jp = R_Aᵀ R_G R_Bᵀ (A the joints before jp, B those after it, R_G = R_T R_0ᵀ), read as the turn
    of a unit vector ⟂ its axis. ``A``, ``B``, ``Bs`` (4, 4), ``R6``, ``RG``, ``Rs`` (3, 3), ``us`` (3,):
    scratch."""
    chain_into(H, P, q, jp, A)  # the joints before jp (q[jp] not read)
    for r in range(4):
        for cc in range(4):
            B[r, cc] = 1.0 if r == cc else 0.0
    for i2 in range(jp + 1, 6):  # the joints after it
        times_motion(B, H[i2], P[i2], q[i2], Rs, us, Bs)
    for r in range(3):
        for cc in range(3):
            g = T[r, 0] * T0[cc, 0] + T[r, 1] * T0[cc, 1] + T[r, 2] * T0[cc, 2]
            RG[r, cc] = g
    for r in range(3):
        for cc in range(3):
            acc = 0.0
            for k2 in range(3):
                for k3 in range(3):
                    acc += A[k2, r] * RG[k2, k3] * B[cc, k3]
            R6[r, cc] = acc
    hp = H[jp]
    ux, uy, uz = (1.0, 0.0, 0.0) if abs(hp[0]) < 0.9 else (0.0, 1.0, 0.0)
    u0, u1, u2 = hp[1] * uz - hp[2] * uy, hp[2] * ux - hp[0] * uz, hp[0] * uy - hp[1] * ux
    un = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
    u0, u1, u2 = u0 / un, u1 / un, u2 / un
    Ru = (R6[0, 0] * u0 + R6[0, 1] * u1 + R6[0, 2] * u2, R6[1, 0] * u0 + R6[1, 1] * u1 + R6[1, 2] * u2,
          R6[2, 0] * u0 + R6[2, 1] * u1 + R6[2, 2] * u2)
    cr = (u1 * Ru[2] - u2 * Ru[1], u2 * Ru[0] - u0 * Ru[2], u0 * Ru[1] - u1 * Ru[0])
    return math.atan2(hp[0] * cr[0] + hp[1] * cr[1] + hp[2] * cr[2], u0 * Ru[0] + u1 * Ru[1] + u2 * Ru[2])


@numba.njit(cache=True, error_model="numpy", inline="always")
def _new_root(qp, out, k):
    """``qp`` (6,) wrapped to (−π, π] in place: whether it is finite and not within 1e-7 (every joint,
    wrapped) of one of the first k rows of ``out``."""
    new = True
    for r in range(6):
        x = qp[r]
        if not math.isfinite(x):
            new = False
        qp[r] = wrap(x)
    for r in range(k):
        far = 0.0
        for t in range(6):
            far = max(far, abs(wrap(qp[t] - out[r, t])))
        if far <= 1e-7:
            new = False
    return new


@numba.njit(cache=True, error_model="numpy")
def _roots(H, P, T0, T, Ps, Pc, P1m, Qp, abcd, pen, ys, shift, steps, roles):
    """Joint values of each real eigenvalue ``y`` of the pencil, polished by ``steps`` Newton steps and
    wrapped to (−π, π], duplicates merged: (k, 6) [rad]. ``roles``: the right pair, the left
    triple and the joint whose axis carries the point (:data:`SPLITS`)."""
    a, b, c_, d = abcd
    out = np.empty((ys.shape[0], 6))
    k = 0
    A, B, Bs, R6, RG, Rs, us = (np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4)), np.empty((3, 3)),
                                np.empty((3, 3)), np.empty((3, 3)), np.empty(3))
    q = np.empty(6)
    v9 = np.empty(9)
    rhs12 = np.empty(12)
    for r in range(12):  # a fixed start vector with no special structure
        rhs12[r] = 1.0 + 0.1 * r * (-1.0) ** r
    Ny, Nw, z0, mono, v = np.empty((12, 12)), np.empty((12, 12)), np.empty((12, 1)), np.empty((4, 3)), np.empty(8)
    for y in ys:
        _null_monomials(pen, y, rhs12, Ny, Nw, z0, mono)
        j, i = 0, 0
        for r in range(3):
            if abs(mono[0, r]) > abs(mono[0, j]):
                j = r
        for r in range(4):
            if abs(mono[r, 0]) > abs(mono[i, 0]):
                i = r
        if mono[0, j] == 0.0 or mono[i, 0] == 0.0:
            continue
        den = c_ * y + d
        f3 = 2.0 * math.atan2(a * y + b, den)  # 2 atan(x3), up to a whole turn
        f4, f5 = 2.0 * math.atan(mono[1, j] / mono[0, j]), 2.0 * math.atan(mono[i, 1] / mono[i, 0])
        s4, c4, s5, c5 = math.sin(f4), math.cos(f4), math.sin(f5), math.cos(f5)
        v9[0], v9[1], v9[2], v9[3], v9[4], v9[5], v9[6], v9[7], v9[8] = (s4 * s5, s4 * c5, c4 * s5, c4 * c5, s4, c4,
                                                                           s5, c5, 1.0)
        s3, c3 = math.sin(f3), math.cos(f3)
        v[:] = 0.0
        for r in range(14):
            rhs = 0.0
            for t in range(9):
                rhs += (Ps[r, t] * s3 + Pc[r, t] * c3 + P1m[r, t]) * v9[t]
            for t in range(8):
                v[t] += Qp[t, r] * rhs
        q[roles[0]], q[roles[1]] = math.atan2(v[4], v[5]), math.atan2(v[6], v[7])
        q[roles[2]], q[roles[3]], q[roles[4]] = f3 + shift[0], f4 + shift[1], f5 + shift[2]
        jp = roles[5]
        q[jp] = _point_joint(H, P, T0, T, q, jp, A, B, Bs, R6, RG, Rs, us)
        qp = newton_polish(H, P, T0, T, q, steps)
        if _new_root(qp, out, k):
            out[k] = qp
            k += 1
    return out[:k].copy()


@numba.njit(cache=True, error_model="numpy")
def _all_roots(T, rev, o, T0, Ps, Pc, P1, Rinv, RL, RC, RH, C, kron_of, mobius, H, P, shift, steps, roles, real_tol):
    """:func:`candidates` in one compiled call: the pencil, the eigenvalues (the companion deflated of
    its ±i block where the checks pass, else whole), the real ones' roots polished; (k, 6) [rad]."""
    for r in range(4):
        for c in range(4):
            if not math.isfinite(T[r, c]):
                return np.empty((0, 6))  # a goal with NaN or infinity has no solution (NO_SOLUTION, as elsewhere)
    Tg = np.zeros((4, 4))
    Tg[3, 3] = 1.0
    for r in range(3):
        for c in range(3):
            Tg[r, c] = T[c, r] if rev else T[r, c]
    for r in range(3):
        Tg[r, 3] = -(T[0, r] * T[0, 3] + T[1, r] * T[1, 3] + T[2, r] * T[2, 3]) if rev else T[r, 3]
    ok, comp, abcd, pen, Qp, P1m = _pencil(o, T0, Ps, Pc, P1, Rinv, RL, RC, RH, C, kron_of, Tg, mobius)
    if not ok:
        return np.empty((0, 6))
    wr, wi = np.empty(24), np.empty(24)
    B = np.empty((16, 16))
    A = B if deflate(pen, comp, B) else comp
    n = A.shape[0]
    if not eig_hess(A.copy(), wr[:n], wi[:n]) and eigvals(A, wr[:n], wi[:n]) != 0:
        return np.empty((0, 6))
    ys = np.empty(n)
    k = 0
    for i in range(n):
        if abs(wi[i]) <= real_tol * (1.0 + math.hypot(wr[i], wi[i])):
            ys[k] = wr[i]
            k += 1
    roots = _roots(H, P, T0, Tg, Ps, Pc, P1m, Qp, abcd, pen, ys[:k], shift, steps, roles)
    if rev:  # back to the arm's joints: θ_k = −(reversed joint 7 − k), wrapped to (−π, π]
        out = np.empty_like(roots)
        for r in range(roots.shape[0]):
            for c in range(6):
                out[r, c] = wrap(-roots[r, 5 - c])
        return out
    return roots


_TURNS = (0.0, -2.0 * math.pi, 2.0 * math.pi, -4.0 * math.pi, 4.0 * math.pi)  # nearest the start first


@numba.njit(cache=True, error_model="numpy", inline="always")
def _nearest_order(roots, q_start):
    """The roots (k, 6) wrapped to (−π, π] in place, and their order by wrapped distance (sum of squares)
    to ``q_start``, ties in root order (a stable sort)."""
    k = roots.shape[0]
    dist = np.empty(k)
    for i in range(k):
        d = 0.0
        for j in range(6):
            roots[i, j] = wrap(roots[i, j])
            e = wrap(roots[i, j] - q_start[j])
            d += e * e
        dist[i] = d
    return np.argsort(dist, kind="mergesort")


@numba.njit(cache=True, error_model="numpy", inline="always")
def _listed(kept, nk, q_start, limits_on, lim):
    """The kept roots as listed (nk, 6): with ``limits_on`` each one's representative within the limits
    ``lim`` (6, 2) nearest the start (by whole turns, joint by joint), those with none dropped; else as
    they are. (listed, their count, the one nearest the start or -1)."""
    listed = np.empty((nk, 6))
    nl, best, bd = 0, -1, math.inf
    for i in range(nk):
        inside = True
        dd = 0.0
        for j in range(6):
            y = q_start[j] + wrap(kept[i, j] - q_start[j])
            if limits_on:
                found = False
                for t in _TURNS:
                    if lim[j, 0] - 1e-9 <= y + t <= lim[j, 1] + 1e-9:
                        y += t
                        found = True
                        break
                inside &= found
                listed[nl, j] = y
            else:
                listed[nl, j] = kept[i, j]
            dd += (y - q_start[j]) ** 2
        if inside:
            if dd < bd:
                bd, best = dd, nl
            nl += 1
    return listed, nl, best


@numba.njit(cache=True, error_model="numpy", inline="always")
def _chosen_q(q, listed, nl, best, kept, nk, q_start, limits_on):
    """``q``: the nearest listed root (moved by whole turns to within π of the start without limits);
    under limits with none listed, the nearest kept root's representative near the start; else the start."""
    if nl > 0:
        for j in range(6):
            q[j] = listed[best, j] if limits_on else q_start[j] + wrap(listed[best, j] - q_start[j])
    elif nk > 0:  # under limits_on: FK-valid, none within the limits
        bd2, b2 = math.inf, 0
        for i in range(nk):
            dd = 0.0
            for j in range(6):
                dd += wrap(kept[i, j] - q_start[j]) ** 2
            if dd < bd2:
                bd2, b2 = dd, i
        for j in range(6):
            q[j] = q_start[j] + wrap(kept[b2, j] - q_start[j])
    else:
        for j in range(6):
            q[j] = q_start[j]


@numba.njit(cache=True, error_model="numpy")
def general_pose(E, Tg, to_m, L, CK, limits_on, q_start, S, q, trace, start_row):
    """A goal solved whole in one compiled call, as
    :func:`pipeline.solvers.closed_form.analytic_kernels.solve_pose` does for the subproblem families.

    Every root (:func:`_all_roots`, ``E`` its arm arguments after the goal) wrapped to (−π, π], in
    order of wrapped distance to ``q_start`` (ties in root order); each kept when the dual-quaternion
    FK check passes under ``CK`` (:func:`~pipeline.solvers.core.check_pack` of the criterion and
    tolerances that decide a root, its limits with it). Without ``limits_on`` the kept roots go to
    ``S`` as they are and ``q`` is the first moved by whole turns to within π of the start; with it
    each kept root's representative within the limits nearest the start (by whole turns, joint by
    joint) goes to ``S``, the nearest of them first and ``q``; a kept root with none is dropped (when
    every kept root is, ``q`` is the nearest kept root's representative near the start, reported as a
    success for the finish to mark out of the limits). At most S's rows, NaN after. A start with a
    non-finite value has no distance to any root: no solution (as the subproblem families). ``trace``: the
    document's error at the start (when ``start_row`` or no solution) and at ``q``, by the joint
    lines ``L`` = (H (6, 3), P (6, 3), RM (3, 3), pM (3,)). ``Tg`` (4, 4) in the working unit,
    ``to_m`` its length factor to metres.

    Returns (solutions in S, roots, kept roots, code SUCCESS or NO_SOLUTION, the index of q's row
    among the listed ones before it was moved first, solve time [ns])."""
    clk = np.empty(2, np.int64)
    t0 = now_ns(clk)
    H, P, RM, pM = L
    Tm = Tg.copy()
    for r in range(3):
        Tm[r, 3] *= to_m
    roots = _all_roots(Tm, *E)
    for j in range(6):
        if not math.isfinite(q_start[j]):  # no distance to a NaN start: no solution, as the other families
            roots = roots[:0]
    k = roots.shape[0]
    F, prism, crit, tolp, tolr, toldq = check_fields(CK, 6)
    K, axis, offset, lim, buf = unpack_check(F, 6)
    order = _nearest_order(roots, q_start)
    kept = np.empty((k, 6))
    nk = 0
    for i in order:
        ok = True
        for j in range(6):
            ok &= math.isfinite(roots[i, j])
        if ok and check_one(K, axis, offset, prism, roots[i], Tg, crit, tolp, tolr, toldq, buf)[0]:
            kept[nk] = roots[i]
            nk += 1
    listed, nl, best = _listed(kept, nk, q_start, limits_on, lim)
    code = SUCCESS if nk > 0 else NO_SOLUTION
    _chosen_q(q, listed, nl, best, kept, nk, q_start, limits_on)
    m = min(nl, S.shape[0])
    for a in range(m):  # the chosen row first, then the others in their order
        src = best if a == 0 else (a - 1 if a <= best else a)
        for j in range(6):
            S[a, j] = listed[src, j]
    for a in range(m, S.shape[0]):
        for j in range(6):
            S[a, j] = math.nan
    ns = now_ns(clk) - t0
    R, p, cs, Zf = np.empty((3, 3)), np.empty(3), np.full((6, 3), math.nan), np.empty(6, np.complex128)
    if start_row or nl == 0:
        fk_lines(H, P, RM, pM, q_start, R, p, cs, Zf)
        doc_row(Tg, R, p, trace[0])
    if nl == 0:
        for c in range(trace.shape[1]):
            trace[1, c] = trace[0, c]
    else:
        fk_lines(H, P, RM, pM, q, R, p, cs, Zf)
        doc_row(Tg, R, p, trace[1])
    return m, k, nk, code, best, ns


@numba.njit(cache=True, error_model="numpy")
def general_call(E, L, CK, GC, scale, Tg, q_start, S, q, trace):
    """The whole public single call of a general arm in one compiled call (as
    :func:`pipeline.solvers.closed_form.analytic_kernels.call_pose`), without limits: the goal scaled to the
    working unit by ``scale``, :func:`general_pose` (roots decided by ``CK``), then the independent FK check of
    ``q`` (:func:`~pipeline.solvers.core.finish_packed` on ``GC``, the solver's own criterion)."""
    Tw = Tg.copy()
    for r in range(3):
        Tw[r, 3] *= scale
    m, k, nk, code, best, ns = general_pose(E, Tw, 1.0, L, CK, False, q_start, S, q, trace, True)
    code, claimed, success, dp, ang, inside = finish_packed(GC, q, Tw, code)
    return m, k, ns, code, claimed, success, dp, ang, inside, trace[1, 0]


@numba.njit(cache=True, error_model="numpy", nogil=True)
def general_rows(E, to_m, L, CK, goals, starts, S, Qo, traces, doc, out, lo, hi):
    """:func:`general_pose` (without limits) for rows ``lo .. hi - 1`` of ``goals`` (N, 4, 4, working unit)
    and ``starts`` (N, 6), without the GIL (:func:`batch_arrays` runs row ranges on threads); each pose
    writes only its own rows, so the results do not depend on the split: ``S[i]`` (m, 6) its solutions,
    ``Qo[i]`` (6,) ``q``, ``traces[i]`` (2, 8) its trace (``traces`` (0, 2, 8): none kept, the row at the
    start unwritten), ``doc[i]`` the document's error at ``q``, ``out[i]`` (solutions, roots, kept roots,
    code, chosen, solve time [ns]). (Not a ``prange``: numba's parallel loops do not take the arm's
    argument tuple ``E``.)"""
    keep = traces.shape[0] == goals.shape[0]
    scratch = np.empty((2, TRACE_COLS))
    for i in range(lo, hi):
        tr = traces[i] if keep else scratch
        m, k, nk, code, best, ns = general_pose(E, goals[i], to_m, L, CK, False, starts[i], S[i], Qo[i], tr, keep)
        doc[i] = tr[1, 0]
        out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4], out[i, 5] = m, k, nk, code, best, ns


def batch_arrays(prep: Prepared, s: General6RSettings, goals: np.ndarray, starts: np.ndarray, keep_traces: bool):
    """N goals by :func:`general_rows`, in as many row ranges on as many threads as numba's thread count
    (the ``threads`` of :func:`pipeline.solvers.solve_batch`; ranges of 16 rows at least): (S (N,
    max_solutions, 6), q (N, 6), traces (N or 0, 2, 8), doc (N,), out (N, 6) int)."""
    E, to_m, lines, CK = pose_args(prep, s)
    N = goals.shape[0]
    S = np.empty((N, s.max_solutions, 6))
    Q = np.empty((N, 6))
    traces = np.empty((N if keep_traces else 0, 2, TRACE_COLS))
    doc = np.empty(N)
    out = np.zeros((N, 6), np.int64)
    args = (E, to_m, lines, CK, np.ascontiguousarray(goals, dtype=float), np.ascontiguousarray(starts, dtype=float), S,
            Q, traces, doc, out)
    k = max(1, min(numba.get_num_threads(), N // 16))
    cut = [N * j // k for j in range(k + 1)]
    if k == 1:
        general_rows(*args, 0, N)
    else:
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(k) as pool:
            for f in [pool.submit(general_rows, *args, cut[j], cut[j + 1]) for j in range(k)]:
                f.result()
    return S, Q, traces, doc, out


def lines_of(prep: Prepared) -> tuple:
    """The arm's joint lines in the working unit for :func:`general_pose`'s trace: (H, P, RM, pM)."""
    def make():
        from pipeline.kinematics import geometry

        L = geometry.joint_lines(prep.model.chain)
        c = np.ascontiguousarray
        return c(L.h, dtype=float), c(L.p, dtype=float), c(L.M[:3, :3], dtype=float), c(L.M[:3, 3], dtype=float)

    return prep.memo(("general_6r", "lines"), make)


def elimination_args(m: ArmModel, s: General6RSettings) -> tuple:
    """The arm's arguments of :func:`_all_roots` after the goal (``E`` of :func:`general_pose`)."""
    return (m.reversed, m.eP[m.roles[2]], m.eT0, *m.left, m.right_inv, m.right_L, m.right_c, m.right_h, m.C,
            KRON_OF, _MOBIUS, m.eH, m.eP, SHIFT, s.polish_steps, m.roles, s.real_tol)


def pose_args(prep: Prepared, s: General6RSettings) -> tuple:
    """(``E``, metres per working unit, the joint lines, the check pack that keeps a root under ``s``'s
    criterion and tolerances): :func:`general_pose`'s arm arguments, built once per job."""
    return elimination_args(model(prep), s), metric(prep).to_m, lines_of(prep), check_pack(prep, s)


def bind_pose(prep: Prepared, s: General6RSettings, limits_on: bool, start_row: bool):
    """``solve1(T_goal, q_start) -> ((solutions, roots, kept roots, code, chosen, ns), S, q, trace)``:
    :func:`general_pose` with its arm arguments (:func:`pose_args`) built once; ``S`` holds
    ``s.max_solutions`` rows."""
    E, to_m, lines, CK = pose_args(prep, s)
    ms, c, empty = s.max_solutions, np.ascontiguousarray, np.empty

    def solve1(T_goal: np.ndarray, q_start: np.ndarray):
        S, q, trace = empty((ms, 6)), empty(6), empty((2, TRACE_COLS))
        out = general_pose(E, c(T_goal, dtype=float), to_m, lines, CK, limits_on, c(q_start, dtype=float), S, q,
                           trace, start_row)
        return out, S, q, trace

    return solve1


def candidates(m: ArmModel, T: np.ndarray, s: General6RSettings) -> np.ndarray:
    """Every root of the elimination for the goal ``T`` (4, 4) [m], polished: (k, 6) [rad], k <= 16
    (not yet FK-checked; duplicates merged)."""
    return _all_roots(np.ascontiguousarray(T, dtype=float), *elimination_args(m, s))


def _found_all(m: ArmModel) -> bool:
    """The roots of the poses of three configurations of the arm contain each configuration."""
    s = General6RSettings()
    for q in _CHECK_Q:
        roots = candidates(m, fk_model(m, q), s)
        if not any(np.abs(wrap_angles(q - r)).max() < 1e-6 for r in roots):
            return False
    return True


def _choice(prep: Prepared) -> tuple[ArmModel, str | None]:
    """(the model to solve with, why the elimination does not apply or None), once per robot: the first
    of split 0 on the arm's chain, on the chain read from the tool back, then split 1 on each (:data:`SPLITS`)
    that finds every test configuration. One can degenerate where another does not (axes 1 and 2
    parallel: split 0 from the tool; a spherical wrist or three parallel axes: split 1)."""

    def choose():
        first = build_model(prep)
        for m in (first, build_model(prep, True), build_model(prep, False, 1), build_model(prep, True, 1)):
            if _found_all(m):
                return m, None
        return first, ("the general 6R elimination degenerates for this geometry, whichever way the loop is split "
                       "(a configuration of the arm is not among the roots of its own pose, as with two axes on "
                       "one line)")

    return prep.memo(("general_6r", "model"), choose)


def model(prep: Prepared) -> ArmModel:
    return _choice(prep)[0]


def degenerate(prep: Prepared) -> str | None:
    """Why the elimination does not solve this 6R revolute arm (one line), or None: once per robot, the
    goals of three configurations of the arm are solved and each configuration must be among the
    roots, on the arm's chain or on the chain read from the tool back. Arms with intersecting or
    parallel axes make the pencil singular for every ``x3``."""
    return _choice(prep)[1]


def applies_to(prep: Prepared) -> str | None:
    why = six_revolute(prep, "general_6r")
    if why:
        return why
    why = degenerate(prep)
    return None if why is None else f"{why}; `analytic` solves such arms by subproblems where a family fits"


def bind(prep: Prepared, s: General6RSettings):
    """``run1``: every FK-valid solution, nearest to the start first (under ``require_limits`` those with
    a representative within the limits, the nearest of them first), in one compiled call
    (:func:`general_pose`)."""
    solve1 = bind_pose(prep, s, bool(s.require_limits), False)

    def run1(T_goal: np.ndarray, q_start: np.ndarray, seed: int) -> Raw:
        (m, k, nk, code, best, ns), S, q, _ = solve1(T_goal, q_start)
        return Raw(q=q, code=int(code), iterations=0, solve_ns=int(ns), solutions=S[:m],
                   info={"roots": k, "n_solutions": m, "n_returned": k, "n_least_squares": 0, "n_fk_valid": nk,
                         "chosen": best})

    return run1


run = run_of(bind)


register(Solver("general_6r", "every real solution of any 6R arm by algebraic elimination (Raghavan-Roth, "
                "Manocha-Canny: a 24 x 24 companion deflated to 16 x 16, roots polished by Newton and FK-checked), "
                "nearest to the start", "analytic", General6RSettings, run, applies_to=applies_to, source=SOURCE,
                bind=bind))
