"""Closed-form IK of PUMA-type arms (Fu, Gonzalez & Lee [02]; ``cin_inv_PUMA()`` of A5.3 of
001_7601717b50b5e768.txt): all (up to 8) solutions, the one nearest the start returned.

Geometry it fits (:func:`applies_to`): 6 revolute joints, standard DH, alpha1 = +-90 deg,
alpha2 = 0 (shoulder and elbow axes parallel), alpha3, alpha4, alpha5 = +-90 deg, a4 = a5 = d5 = 0
(spherical wrist: axes 4, 5, 6 meet at the wrist centre), a2 != 0 and a3, d4 not both 0. a1, d1,
d2 + d3 (the shoulder offset), a3, d4, and the last link (a6, alpha6, d6) are free; base and tool
transforms are stripped with :meth:`Prepared.bare_goal`. The PUMA 560 of Fu et al.
(data/robots/puma560.yaml) is alpha = (-90, 0, 90, -90, 90, 0) deg.

Solution: wrist centre ``p_w`` = origin of the last frame moved back through link 6; theta1 from
the shoulder offset ``d2 + d3`` (two branches, ARM), theta2/theta3 from the planar two-link problem
with the forearm ``L = sqrt(a3^2 + d4^2)`` (two branches, ELBOW), theta4..6 from
``R36 = R03^T R06`` (two branches, WRIST). At the wrist degeneracy (sin theta5 = 0) theta4 = 0
and theta6 takes the sum, as the document's program does; theta6 always comes from the residual
rotation ``(R4 R5)^T R36 = Rz(theta6)``, exact even when the theta4/theta6 split is ill-conditioned.

Flags (``Raw.info['branches']``, one word per row of ``solutions``, e.g. ``"++-"``, ``d`` appended at
the wrist degeneracy): ``arm`` = + for the first theta1 branch
(theta1 = phi - asin(d/r) for the PUMA 560), ``elbow`` = sign of the elbow angle
(theta3 - atan2(sigma3 d4, a3)), ``wrist`` = sign of sin theta5, ``d`` when sin theta5 = 0
(theta4 := 0). These are branch labels of ours: the document's flag names
(OMBRO_ESQUERDO/DIREITO, COTOVELO_BAIXO/ALTO, PULSO_BAIXO/ALTO) are not defined numerically in
the surviving text (Fig. A5.9 is missing).

Every solution is checked by compiled forward kinematics of the whole chain (homogeneous
matrices, base and tool included; the errors and the settings' criterion and tolerances as
:func:`pipeline.solvers.core.verify` computes them, which the numpy version called);
``info`` holds the counts (``solutions_found``, ``solutions_valid``, ``degenerate_wrist``,
``distinct_branches``), the largest FK errors over all solutions, ``valid`` (one 0/1 per row of
``solutions``) and ``chosen`` (row returned as ``q``, -1 if none passed). ``solutions`` holds
every solution found (valid or not, as ``valid`` says).

Speed. :func:`puma_core` does the closed form, the checks and the choice in one allocation-free
compiled call (the bare goal ``base^-1 T tool^-1`` with precomputed inverses; the FK keeps
``base A1`` and ``base A1 A2 A3`` between solutions that share those joints); the ``branches`` /
``valid`` strings come from small caches keyed by the kernel's packed codes. ``bind`` gives the
lean single call, :func:`bind_call` the public call fused (closed form, independent FK check, limit
record in one compiled call, the result built positionally), ``batch`` N poses on every core
(per-pose ``info`` as :class:`~pipeline.solvers.closed_form.analytic_ur.InfoRows`, built on access). Results
equal the reference (numpy-checked) version to ~1e-13; within ~1e-9 of the wrist degeneracy the
θ4/θ6 split is ill-conditioned and the solutions may differ by up to ~1e-4 rad (at sin θ5 = 0
exactly, θ6 = ±π may flip sign with the sign of a rounding-level zero, and which of the two wrist
branches is nearest the start may swap).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from pipeline.kinematics.fkcheck import meets
from pipeline.solvers.kernels.kin import NO_SOLUTION, SUCCESS, TRACE_DP, now_ns
from pipeline.solvers.closed_form.analytic_ur import InfoRows, copy12, mul34, mul_link, pose_errors, rigid_rows
from pipeline.solvers.core import (CRITERION_CODE, TRACE_COLS, BatchRaw, IKResult, Prepared, Raw, Settings,
                                   check_pack, finish_packed, fused_inputs)
from pipeline.solvers.core.driver import run_of
from pipeline.solvers.closed_form.analytic import alias_hooks
from pipeline.solvers.core.registry import Solver, register
from pipeline.solvers.core.timing import clock_ns

SOURCE = "001_7601717b50b5e768.txt (Erthal 1992) A5.3 cin_inv_PUMA(), after Fu, Gonzalez & Lee [02]"
DEGENERATE_S5 = 1e-12  # |sin theta5| below this: wrist degeneracy (theta4 := 0)
REACH_SLACK = 1e-12    # |cos(elbow)| up to 1 + this is clipped to 1 (stretched arm)
ANGLE_TOL = 1e-9       # [rad] a DH twist is "+-90" / "0" within this
LENGTH_TOL = 1e-9      # [length_unit] a DH length is zero within this


@dataclass(frozen=True)
class AnalyticPumaSettings(Settings):
    """Settings of the PUMA closed form: only the base fields. ``tol_pos`` / ``tol_rot`` are the
    tolerances of every solution's FK check (the closed form itself has none; it is exact to
    rounding, ~1e-12 of the arm's size)."""


def _geometry_reason(prep: Prepared) -> str | None:
    c = prep.model.chain
    al = np.asarray(c.alpha, dtype=float)
    right = lambda x: abs(abs(x) - math.pi / 2) <= ANGLE_TOL  # noqa: E731
    if prep.n != 6:
        return f"needs 6 joints (PUMA-type arm), the robot has {prep.n}"
    if c.general:
        return "needs a DH table (the robot file is in the general URDF-style form)"
    if bool(c.modified):
        return "standard DH only (the closed form is written for standard DH)"
    if prep.prismatic.any():
        return "needs 6 revolute joints (PUMA-type arm)"
    if not (right(al[0]) and abs(al[1]) <= ANGLE_TOL and right(al[2]) and right(al[3]) and right(al[4])):
        deg = ", ".join(f"{v:g}" for v in np.round(np.degrees(al[:5]), 3))
        return f"not a PUMA-type arm: needs alpha1..5 = +-90, 0, +-90, +-90, +-90 deg, has {deg}"
    if abs(c.a[3]) > LENGTH_TOL or abs(c.a[4]) > LENGTH_TOL or abs(c.d[4]) > LENGTH_TOL:
        return "no spherical wrist: needs a4 = a5 = d5 = 0"
    if abs(c.a[1]) <= LENGTH_TOL or math.hypot(c.a[2], c.d[3]) <= LENGTH_TOL:
        return "needs a2 != 0 and a forearm (a3, d4) != 0"
    return None


def applies_to(prep: Prepared) -> str | None:
    return _geometry_reason(prep)


def geometry(prep: Prepared) -> np.ndarray:
    """Parameters of the closed form (once per job): a1 d1 d23 a2 a3 d4 a6 d6 al6 s1 s3 s4 s5 off1..6."""
    c = prep.model.chain
    sg = np.sign(np.asarray(c.alpha, dtype=float))
    return np.array([c.a[0], c.d[0], c.d[1] + c.d[2], c.a[1], c.a[2], c.d[3], c.a[5], c.d[5], c.alpha[5],
                     sg[0], sg[2], sg[3], sg[4], *c.theta_offset], dtype=float)


# ---- packed parameters (once per job, :func:`packed`) -------------------------------------------
P_G = 0  # geometry(): a1 d1 d23 a2 a3 d4 a6 d6 al6 s1 s3 s4 s5 off1..6 (19)
P_CA, P_SA = 19, 24  # cos / sin of alpha1..5
P_CA6, P_SA6, P_L, P_BETA = 29, 30, 31, 32  # cos / sin alpha6, forearm length, its angle
P_BINV, P_TINV, P_PLAIN = 33, 45, 57  # rows 0-2 of base^-1 and tool^-1 (12 each); 1 when both are I
P_CRIT, P_TOLP, P_TOLR, P_TOLDQ = 58, 59, 60, 61  # the FK check's criterion code and tolerances
P_A, P_LCA, P_LSA, P_D, P_OFF = 62, 68, 74, 80, 86  # the FK check's chain: a, cos / sin alpha, d, offsets (6 each)
P_BASE, P_TOOL = 92, 104  # rows 0-2 of base and tool (working unit)
N_P = 116
# per-pose integer outputs (``iv``)
I_FOUND, I_VALID, I_CHOSEN, I_DEG, I_DISTINCT, I_BKEY, I_VKEY = range(7)
N_I = 7
CHUNK = 64  # poses per work item of the batch kernel



def packed(prep: Prepared, s: AnalyticPumaSettings) -> np.ndarray:
    """The closed form's parameters, the bare-goal transforms and the FK check's settings in one array."""
    c = prep.model.chain
    g = prep.memo("analytic_puma_geometry", lambda: geometry(prep))
    al = np.asarray(c.alpha, dtype=float)
    P = np.zeros(N_P)
    P[P_G:P_G + 19] = g
    P[P_CA:P_CA + 5] = [math.cos(x) for x in al[:5]]  # libm, as the compiled kernels' cos
    P[P_SA:P_SA + 5] = [math.sin(x) for x in al[:5]]
    P[P_CA6], P[P_SA6] = math.cos(g[8]), math.sin(g[8])
    P[P_L] = math.hypot(g[4], g[5])
    P[P_BETA] = math.atan2(g[10] * g[5], g[4])
    P[P_BINV:P_BINV + 12] = rigid_rows(c.base, inverse=True)
    P[P_TINV:P_TINV + 12] = rigid_rows(c.tool, inverse=True)
    P[P_PLAIN] = float(np.array_equal(c.base, np.eye(4)) and np.array_equal(c.tool, np.eye(4)))
    P[P_CRIT] = CRITERION_CODE[s.criterion]
    P[P_TOLP], P[P_TOLR], P[P_TOLDQ] = s.tol_pos, s.tol_rot, s.tol_dq
    a, alpha, d, offs, prism, form, base, tool = prep.args
    P[P_A:P_A + 6] = a
    P[P_LCA:P_LCA + 6] = [math.cos(x) for x in alpha]
    P[P_LSA:P_LSA + 6] = [math.sin(x) for x in alpha]
    P[P_D:P_D + 6] = d
    P[P_OFF:P_OFF + 6] = offs
    P[P_BASE:P_BASE + 12] = rigid_rows(base)
    P[P_TOOL:P_TOOL + 12] = rigid_rows(tool)
    return P


@numba.njit(cache=True, inline="always")
def _rz_rx(P, t, i):
    """Rotation part of Rz(t) Rx(alpha_i) (i < 5), row-major 9-tuple."""
    ct, st, ca, sa = math.cos(t), math.sin(t), P[P_CA + i], P[P_SA + i]
    return ct, -st * ca, st * sa, st, ct * ca, -ct * sa, 0.0, sa, ca


W_C1, W_C3, W_C, W_T, W_CODES = 36, 48, 60, 72, 84  # FK check blocks (3 x 4), branch codes (8)
N_W = 92


@numba.njit(cache=True)
def _check(P, sols, k, Tg, W, crit):
    """FK check of solution ``k`` (whole chain, base and tool included) against ``Tg``: (meets the
    settings' criterion, |dp|, rotation angle), as :func:`pipeline.solvers.core.verify` computes them.

    The products base A1 and base A1 A2 A3 are kept in ``W`` from the previous solution when its
    first joint values are bitwise the same (solutions come in arm / elbow / wrist order)."""
    same1 = k > 0 and sols[k, 0] == sols[k - 1, 0]
    same3 = same1 and sols[k, 1] == sols[k - 1, 1] and sols[k, 2] == sols[k - 1, 2]
    if not same1:
        copy12(P, P_BASE, W, W_C1)
        t = P[P_OFF] + sols[k, 0]
        mul_link(W, W_C1, math.cos(t), math.sin(t), P[P_A], P[P_LCA], P[P_LSA], P[P_D])
    if not same3:
        copy12(W, W_C1, W, W_C3)
        for j in range(1, 3):
            t = P[P_OFF + j] + sols[k, j]
            mul_link(W, W_C3, math.cos(t), math.sin(t), P[P_A + j], P[P_LCA + j], P[P_LSA + j], P[P_D + j])
    copy12(W, W_C3, W, W_C)
    for j in range(3, 6):
        t = P[P_OFF + j] + sols[k, j]
        mul_link(W, W_C, math.cos(t), math.sin(t), P[P_A + j], P[P_LCA + j], P[P_LSA + j], P[P_D + j])
    mul34(W, W_C, P, P_TOOL, W, W_T)
    o = W_T
    dp, ang = pose_errors(Tg, W, o)
    # |t| of T_goal T^-1: p_goal - R_goal R^T p
    px, py, pz = W[o + 3], W[o + 7], W[o + 11]
    u0 = W[o] * px + W[o + 4] * py + W[o + 8] * pz
    u1 = W[o + 1] * px + W[o + 5] * py + W[o + 9] * pz
    u2 = W[o + 2] * px + W[o + 6] * py + W[o + 10] * pz
    tx = Tg[0, 3] - (Tg[0, 0] * u0 + Tg[0, 1] * u1 + Tg[0, 2] * u2)
    ty = Tg[1, 3] - (Tg[1, 0] * u0 + Tg[1, 1] * u1 + Tg[1, 2] * u2)
    tz = Tg[2, 3] - (Tg[2, 0] * u0 + Tg[2, 1] * u1 + Tg[2, 2] * u2)
    ok = meets(crit, P[P_TOLP], P[P_TOLR], P[P_TOLDQ], dp, ang, math.sqrt(tx * tx + ty * ty + tz * tz))
    return ok, dp, ang


@numba.njit(cache=True, inline="always")
def _bare_goal(P, Tg, W):
    """``W[0:12]`` the goal's rows, ``W[12:24]`` the bare goal (base⁻¹ T tool⁻¹, as Prepared.bare_goal),
    ``W[24:36]`` scratch."""
    for r in range(3):
        for c in range(4):
            W[4 * r + c] = Tg[r, c]
    if P[P_PLAIN] != 0.0:
        copy12(W, 0, W, 12)
    else:
        mul34(P, P_BINV, W, 0, W, 24)
        mul34(W, 24, P, P_TINV, W, 12)


@numba.njit(cache=True, inline="always")
def _wrist_centre(P, W):
    """The wrist centre of the bare goal ``W[12:24]``: the origin of frame 5 = T06 (Tz(d6) Tx(a6) Rx(al6))⁻¹ 0."""
    a6, d6, ca6, sa6 = P[6], P[7], P[P_CA6], P[P_SA6]
    o = 12
    pw0 = W[o + 3] - a6 * W[o] - d6 * (sa6 * W[o + 1] + ca6 * W[o + 2])
    pw1 = W[o + 7] - a6 * W[o + 4] - d6 * (sa6 * W[o + 5] + ca6 * W[o + 6])
    pw2 = W[o + 11] - a6 * W[o + 8] - d6 * (sa6 * W[o + 9] + ca6 * W[o + 10])
    return pw0, pw1, pw2


@numba.njit(cache=True, inline="always")
def _r06(W, ca6, sa6):
    """R06 Rx(al6)ᵀ of the bare goal ``W[12:24]``, row-major 9-tuple."""
    o = 12
    n00 = W[o]
    n01 = W[o + 1] * ca6 - W[o + 2] * sa6
    n02 = W[o + 1] * sa6 + W[o + 2] * ca6
    n10 = W[o + 4]
    n11 = W[o + 5] * ca6 - W[o + 6] * sa6
    n12 = W[o + 5] * sa6 + W[o + 6] * ca6
    n20 = W[o + 8]
    n21 = W[o + 9] * ca6 - W[o + 10] * sa6
    n22 = W[o + 9] * sa6 + W[o + 10] * ca6
    return n00, n01, n02, n10, n11, n12, n20, n21, n22


@numba.njit(cache=True, inline="always")
def _dot3(a_, b_):
    """a · b of two 3-tuples (a0 b0 + a1 b1 + a2 b2, in that order)."""
    return a_[0] * b_[0] + a_[1] * b_[1] + a_[2] * b_[2]


@numba.njit(cache=True, inline="always")
def _mat3(a_, b_):
    """The product of two 3 × 3 matrices as row-major 9-tuples."""
    a00, a01, a02, a10, a11, a12, a20, a21, a22 = a_
    b00, b01, b02, b10, b11, b12, b20, b21, b22 = b_
    return (a00 * b00 + a01 * b10 + a02 * b20, a00 * b01 + a01 * b11 + a02 * b21, a00 * b02 + a01 * b12 + a02 * b22,
            a10 * b00 + a11 * b10 + a12 * b20, a10 * b01 + a11 * b11 + a12 * b21, a10 * b02 + a11 * b12 + a12 * b22,
            a20 * b00 + a21 * b10 + a22 * b20, a20 * b01 + a21 * b11 + a22 * b21, a20 * b02 + a21 * b12 + a22 * b22)


@numba.njit(cache=True, inline="always")
def _r03(P, a_, th2, th3):
    """R03 = Rz(th1) Rx(al1) Rz(th2) Rx(al2) Rz(th3) Rx(al3), the first factor given (``a_``,
    :func:`_rz_rx` of th1), row-major 9-tuple."""
    return _mat3(_mat3(a_, _rz_rx(P, th2, 1)), _rz_rx(P, th3, 2))


@numba.njit(cache=True, inline="always")
def _wrists(P, f, n, th1, th2, th3, code0, sols, W, m):
    """Both wrist branches of one arm / elbow branch (R03 ``f``, R06 Rx(al6)ᵀ ``n``) into rows m, m + 1 of
    ``sols`` with their branch codes (``code0`` + wrist, + 8 where θ5 is degenerate) into ``W[W_CODES:]``;
    returns m + 2."""
    s4, s5 = P[11], P[12]
    f0, f1, f2 = (f[0], f[3], f[6]), (f[1], f[4], f[7]), (f[2], f[5], f[8])  # R03's columns
    n0, n2 = (n[0], n[3], n[6]), (n[2], n[5], n[8])
    # R = R03^T R06r: columns 0 and 2
    r00, r10, r20 = _dot3(f0, n0), _dot3(f1, n0), _dot3(f2, n0)
    r02, r12, r22 = _dot3(f0, n2), _dot3(f1, n2), _dot3(f2, n2)
    hyp = math.hypot(r02, r12)
    for wr in range(2):
        w = 1.0 if wr == 0 else -1.0
        th5 = math.atan2(w * hyp, -s4 * s5 * r22)
        deg = hyp < DEGENERATE_S5
        th4 = 0.0 if deg else math.atan2(s5 * w * r12, s5 * w * r02)
        # th6 from (R4 R5)^T R = Rz(th6): column 0 of R45^T R
        b = _rz_rx(P, th4, 3)
        c = _rz_rx(P, th5, 4)
        c0, c1 = (c[0], c[3], c[6]), (c[1], c[4], c[7])
        b0, b1, b2 = (b[0], b[1], b[2]), (b[3], b[4], b[5]), (b[6], b[7], b[8])
        h0 = (_dot3(b0, c0), _dot3(b1, c0), _dot3(b2, c0))  # R4 R5: columns 0 and 1
        h1 = (_dot3(b0, c1), _dot3(b1, c1), _dot3(b2, c1))
        th6 = math.atan2(_dot3(h1, (r00, r10, r20)), _dot3(h0, (r00, r10, r20)))
        sols[m, 0] = th1 - P[13]
        sols[m, 1] = th2 - P[14]
        sols[m, 2] = th3 - P[15]
        sols[m, 3] = th4 - P[16]
        sols[m, 4] = th5 - P[17]
        sols[m, 5] = th6 - P[18]
        W[W_CODES + m] = code0 + wr + (8 if deg else 0)  # branch word code
        m += 1
    return m


@numba.njit(cache=True, inline="always")
def _check_all(P, Tg, q_start, W, sols, q, iv, fv, m):
    """Every one of the m solutions FK-checked (:func:`_check`), the nearest valid one (wrapped distance)
    into ``q`` (or ``q_start``), NaN below the m rows of ``sols``, the counts into ``iv`` (``I_*``) and
    the largest FK errors into ``fv``."""
    crit = int(P[P_CRIT])
    nvalid = 0
    ndeg = 0
    bkey = m
    vkey = m
    maxdp = math.nan
    maxang = math.nan
    best = -1
    bestd = 1e300
    seen = 0
    for k in range(m):
        ok, dp, ang = _check(P, sols, k, Tg, W, crit)
        if k == 0 or dp > maxdp:  # Python's max(): the first value, then any larger one
            maxdp = dp
        if k == 0 or ang > maxang:
            maxang = ang
        code = int(W[W_CODES + k])
        bkey |= code << (4 + 4 * k)
        ndeg += code >> 3
        seen |= 1 << (code & 7)
        if ok:
            nvalid += 1
            vkey |= 1 << (4 + k)
            dist = 0.0
            for j in range(6):
                dj = (sols[k, j] - q_start[j] + math.pi) % (2 * math.pi) - math.pi
                dist += dj * dj
            if dist < bestd:
                bestd = dist
                best = k
    ndist = 0
    for b in range(8):
        ndist += (seen >> b) & 1
    for r in range(m, 8):
        for j in range(6):
            sols[r, j] = math.nan
    for j in range(6):
        q[j] = q_start[j] if best < 0 else sols[best, j]
    iv[I_FOUND], iv[I_VALID], iv[I_CHOSEN], iv[I_DEG], iv[I_DISTINCT] = m, nvalid, best, ndeg, ndist
    iv[I_BKEY], iv[I_VKEY] = bkey, vkey
    fv[0], fv[1] = maxdp, maxang


@numba.njit(cache=True)
def puma_core(P, Tg, q_start, W, clk, sols, q, iv, fv):
    """One pose: every closed-form solution, each checked by the compiled FK, the choice.

    ``P`` from :func:`packed`; ``Tg`` (4, 4) the whole chain's goal; ``W`` (N_W,) and ``clk`` (2,)
    int64 scratch. Writes the solutions
    found into the first rows of ``sols`` (8, 6) (NaN below), the returned angles into ``q`` (6,),
    the counts into ``iv`` (see ``I_*``) and the largest FK errors into ``fv`` (2,). Returns the
    closed form's time [ns] (the checks excluded, as before).
    """
    t0 = now_ns(clk)
    _bare_goal(P, Tg, W)
    a1, d1, d23, a2 = P[0], P[1], P[2], P[3]
    s1 = P[9]
    ca6, sa6, L, beta = P[P_CA6], P[P_SA6], P[P_L], P[P_BETA]
    pw0, pw1, pw2 = _wrist_centre(P, W)
    r_xy = math.hypot(pw0, pw1)
    m = 0
    if r_xy >= abs(d23):
        phi = math.atan2(pw1, pw0)
        asn = math.asin(s1 * d23 / r_xy)
        n = _r06(W, ca6, sa6)
        for arm in range(2):
            th1 = phi + asn if arm == 0 else phi - math.pi - asn
            c1, sn1 = math.cos(th1), math.sin(th1)
            X = c1 * pw0 + sn1 * pw1 - a1
            Y = s1 * (pw2 - d1)
            cg = (X * X + Y * Y - a2 * a2 - L * L) / (2 * a2 * L)
            if abs(cg) > 1 + REACH_SLACK:
                continue
            cg = max(-1.0, min(1.0, cg))
            acg = math.acos(cg)
            sg, cgg = math.sin(acg), math.cos(acg)
            aty = math.atan2(Y, X)
            a_ = _rz_rx(P, th1, 0)
            for el in range(2):
                elbow = 1.0 if el == 0 else -1.0
                gam = elbow * acg
                th2 = aty - math.atan2(L * (elbow * sg), a2 + L * cgg)  # sin is odd, cos even
                th3 = gam + beta
                f = _r03(P, a_, th2, th3)
                m = _wrists(P, f, n, th1, th2, th3, 4 * arm + 2 * el, sols, W, m)
    ns = now_ns(clk) - t0
    _check_all(P, Tg, q_start, W, sols, q, iv, fv, m)
    return ns


@numba.njit(cache=True)
def puma_one(P, Tg, q_start, sols, q, iv, fv):
    """:func:`puma_core` with its own scratch (the single-pose call)."""
    W = np.empty(N_W)
    clk = np.zeros(2, np.int64)
    return puma_core(P, Tg, q_start, W, clk, sols, q, iv, fv)


@numba.njit(cache=True)
def puma_call(PC, Tg, q_start, sols, q, iv, fv, trace):
    """The whole public single call in one compiled call: :func:`puma_core`, then the result rule of
    every finish (:func:`pipeline.solvers.core.finish_packed`: the independent FK check of the chosen
    ``q`` by the dual-quaternion FK, no code shared with the closed form's, its joint-limit record and
    the stop reason; without ``require_limits``), and the one-row trace :func:`pipeline.solvers.core.finish`
    gives a result without one.

    ``PC`` = :func:`packed` followed by :func:`~pipeline.solvers.core.check_pack`; ``trace`` (1, 8)
    gets NaN but |dp|. Returns (solve time [ns] (puma_core's, the check excluded), stop reason,
    claimed success, success, |dp|, angle, within the limits).
    """
    W = np.empty(N_W)
    clk = np.zeros(2, np.int64)
    ns = puma_core(PC[:N_P], Tg, q_start, W, clk, sols, q, iv, fv)
    code, claimed, success, dp, ang, inside = finish_packed(PC[N_P:], q, Tg,
                                                           SUCCESS if iv[I_CHOSEN] >= 0 else NO_SOLUTION)
    for c in range(7):
        trace[0, c] = math.nan
    trace[0, TRACE_DP] = dp
    return ns, code, claimed, success, dp, ang, inside


@numba.njit(cache=True, parallel=True)
def puma_batch(P, goals, starts, S, Q, IV, FV, ns):
    """:func:`puma_core` for every row (work items of ``CHUNK`` poses, one workspace each; every pose
    writes only its own rows, so results do not depend on the thread count)."""
    N = goals.shape[0]
    for k in numba.prange((N + CHUNK - 1) // CHUNK):
        W = np.empty(N_W)
        clk = np.zeros(2, np.int64)
        for i in range(k * CHUNK, min(N, (k + 1) * CHUNK)):
            ns[i] = puma_core(P, goals[i], starts[i], W, clk, S[i], Q[i], IV[i], FV[i])


# ---- info (the single call's keys; strings from small caches keyed by the kernel's packed codes) --
_WORDS = ["".join("+" if not c & b else "-" for b in (4, 2, 1)) + ("d" if c & 8 else "") for c in range(16)]
_BRANCHES: dict = {}
_VALID: dict = {}


def _branches(key: int) -> str:
    s = _BRANCHES.get(key)
    if s is None:
        s = _BRANCHES[key] = " ".join(_WORDS[(key >> (4 + 4 * k)) & 15] for k in range(key & 15))
    return s


def _valid(key: int) -> str:
    s = _VALID.get(key)
    if s is None:
        s = _VALID[key] = "".join("1" if key >> (4 + k) & 1 else "0" for k in range(key & 15))
    return s


def _info(iv: list, maxdp: float, maxang: float) -> dict:
    return {"solutions_found": iv[I_FOUND], "solutions_valid": iv[I_VALID], "max_position_error": maxdp,
            "max_orientation_error": maxang, "degenerate_wrist": iv[I_DEG], "distinct_branches": iv[I_DISTINCT],
            "branches": _branches(iv[I_BKEY]), "valid": _valid(iv[I_VKEY]), "chosen": iv[I_CHOSEN]}


def bind(prep: Prepared, s: AnalyticPumaSettings):
    """``run1(T_goal, q_start, seed) -> Raw`` with the geometry, bare-goal transforms and FK check packed once."""
    P = packed(prep, s)

    def run1(T_goal: np.ndarray, q_start: np.ndarray, seed: int) -> Raw:
        sols = np.empty((8, 6))
        q = np.empty(6)
        iv = np.empty(N_I, np.int64)
        fv = np.empty(2)
        ns = puma_one(P, T_goal, q_start, sols, q, iv, fv)
        v = iv.tolist()
        return Raw(q=q, code=SUCCESS if v[I_CHOSEN] >= 0 else NO_SOLUTION, iterations=0, solve_ns=ns, ik_ns=ns,
                   solutions=sols[:v[I_FOUND]], info=_info(v, float(fv[0]), float(fv[1])))

    return run1


def bind_call(prep: Prepared, s: AnalyticPumaSettings):
    """The public single call fused: ``call(T_goal, q_start, seed, t0) -> IKResult`` (the registry's
    ``Solver.bind_call``), or None under ``require_limits`` (the generic ``bind`` + ``finish`` path).

    Why it exists: as for :func:`pipeline.solvers.closed_form.analytic_ur.bind_call`, ``run1`` + ``finish``
    (two compiled dispatches, a :class:`Raw` and an :class:`IKResult` built by keyword) cost ~5 us
    around a ~6 us kernel; here the kernel, the independent FK check and the limit record are one
    compiled call (:func:`puma_call`) and the result is built positionally, with the generic path's
    values bit for bit (tests/solvers/closed_form/test_fastpath_ur.py). ``T_goal`` in the robot file's unit; ``t0`` the
    caller's start on the call clock [ns].
    """
    if s.require_limits:
        return None
    PC = np.concatenate([packed(prep, s), check_pack(prep, s)])
    inputs, unit, pos_only = fused_inputs(prep), prep.unit, s.criterion == "position"
    nan, empty, int64 = math.nan, np.empty, np.int64

    def call(T_goal: np.ndarray, q_start: np.ndarray, seed: int, t0: int) -> IKResult:
        Tg, q0 = inputs(T_goal, q_start)
        sols = empty((8, 6))
        q = empty(6)
        iv = empty(N_I, int64)
        fv = empty(2)
        trace = empty((1, TRACE_COLS))
        ns, code, claimed, success, dp, ang, inside = puma_call(PC, Tg, q0, sols, q, iv, fv, trace)
        v = iv.tolist()
        t = ns * 1e-9
        res = IKResult(q, success, code, 0, trace, t, t, dp, nan if pos_only else ang,
                       claimed, inside, nan, unit, sols[:v[I_FOUND]], _info(v, float(fv[0]), float(fv[1])))
        res.call_time_s = (clock_ns() - t0) * 1e-9
        return res

    return call


run = run_of(bind)  # one pose (``T_goal`` in the working unit): ``bind(prep, s)(T_goal, q_start, seed)``


def batch(prep: Prepared, s: AnalyticPumaSettings, goals: np.ndarray, starts: np.ndarray, seeds, keep_traces: bool):
    """N poses in one compiled call (both cores).

    Returns a :class:`BatchRaw`: ``q`` (N, 6), ``code`` SUCCESS / NO_SOLUTION, ``iterations`` 0,
    ``solve_ns`` = ``ik_ns`` per pose, ``solutions`` (N, 8, 6) with the solutions found in the first
    ``n_solutions[i]`` rows (as the single call: every closed-form solution, its FK verdict in
    ``info[i]["valid"]``; NaN below), no traces (the closed form has none), and ``info`` an
    :class:`~pipeline.solvers.closed_form.analytic_ur.InfoRows` (the single call's dict per pose, built on access).
    """
    P = packed(prep, s)
    N = goals.shape[0]
    S = np.empty((N, 8, 6))
    Q = np.empty((N, 6))
    IV = np.zeros((N, N_I), np.int64)
    FV = np.empty((N, 2))
    ns = np.zeros(N, np.int64)
    puma_batch(P, goals, starts, S, Q, IV, FV, ns)
    info = InfoRows(N, lambda i: _info(IV[i].tolist(), float(FV[i, 0]), float(FV[i, 1])))
    return BatchRaw(q=Q, code=np.where(IV[:, I_CHOSEN] >= 0, SUCCESS, NO_SOLUTION).astype(np.int64),
                    iterations=np.zeros(N, np.int64), solve_ns=ns, ik_ns=ns.copy(), solutions=S,
                    n_solutions=IV[:, I_FOUND].copy(), info=info)


# The transcription runs where its DH test passes (the studies' tables); on any other arm whose joint
# axes give the same family, whatever the file's form, the geometric closed form (pipeline.solvers.closed_form.analytic)
# runs under this name.
_hooks = alias_hooks("spherical_wrist", "PUMA-type (spherical wrist)", applies_to, bind, batch, bind_call)
register(Solver("analytic_puma", "closed-form IK of PUMA-type arms (spherical wrist): all 8 solutions, the one "
                "nearest the start returned", "analytic", AnalyticPumaSettings, _hooks["run"], applies_to=_hooks["applies_to"],
                source=SOURCE, bind=_hooks["bind"], batch=_hooks["batch"], bind_call=_hooks["bind_call"]))
