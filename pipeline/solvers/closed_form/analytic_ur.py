"""Closed-form inverse kinematics of UR-type arms: all 8 solutions (004_957b32c2b06ea31d.txt §4.8).

Geometry (Hawkins 2013, "Analytic inverse kinematics for the Universal Robots UR-5/UR-10 arms"):
six revolute joints, standard DH, ``alpha = (π/2, 0, 0, π/2, −π/2, 0)``, ``a1 = a4 = a5 = a6 = 0``,
``a2, a3 ≠ 0``; any ``d`` and joint offsets (``d2 + d3 + d4`` act as one shoulder offset, since
joints 2-4 are parallel); base and tool transforms are stripped from the goal first
(:meth:`~pipeline.solvers.core.Prepared.bare_goal`). Any other robot is refused with one line.

Branches ``(shoulder ±) × (wrist ±) × (elbow ±)``, row ``4 i1 + 2 i5 + i3``:

θ1   the wrist-2 origin ``p05 = p − d6 z6`` satisfies ``p05 · z1 = d2 + d3 + d4`` with
     ``z1 = (sin θ1, −cos θ1, 0)``.
θ5   ``atan2(±|z6 × z1|, z6 · z1)`` (the classic ``acos((p · z1 − d4) / d6)`` loses half the digits
     near θ5 = 0).
θ6   from the base x/y axes seen in the tool frame, signed by sin θ5; at the wrist singularity
     (``|sin θ5| < wrist_eps``, joints 4 and 6 aligned) θ6 is free and is set to the start's θ6
     (θ4 absorbs the rest), so nothing is divided by ~0.
θ3, θ2, θ4  the planar 3R arm in frame 1 (``T14 = A1⁻¹ T A6⁻¹ A5⁻¹``, rigid 3 × 4 products).

Unreachable branches (a cosine beyond ±1 by more than ``CLIP_TOL``) are clipped, computed to finite
numbers and marked invalid; cosines within ``CLIP_TOL`` of ±1 (stretched elbow, wrist on the shoulder
cylinder) are rounding at a boundary and are kept if the FK check passes. Every branch is checked by
the compiled FK of the whole chain (base and tool included) against ``verify_position`` /
``verify_rotation``. ``Raw.solutions`` holds the FK-valid branches wrapped to (−π, π]; ``q`` is the
one nearest ``q_start`` (wrapped joint distance), unwrapped to lie within π of ``q_start`` per joint.
No valid branch: ``NO_SOLUTION`` with ``q = q_start``. The trace has two rows, the document's
error ``[‖e‖, e, |Δp|]`` (``optimizers.doc_error``) at ``q_start`` and at ``q``.

Speed. :func:`ur_core` is allocation-free (3 × 4 blocks in one float workspace, the robot and the
settings packed once per job by :func:`packed`); the base and tool are stripped inside it with
precomputed inverses; the per-branch FK keeps ``base A1`` (per θ1) and ``A5 A6 tool`` (per θ1, θ5)
and reuses a sine/cosine wherever its angle is bitwise one already computed, so the check costs
what its distinct joint values need. ``bind`` gives the lean single call, :func:`bind_call` the
public call fused (closed form, independent FK check, limit record in one compiled call, the result
built positionally: ~5 us instead of ~8 us, the kernel being ~2.2 us), ``batch`` runs N poses on
every core (``numba.prange`` over chunks of poses; each pose writes only its own rows, so results
do not depend on the thread count) and returns per-pose ``info`` as :class:`InfoRows` (dicts built
on access). Results equal the reference transcription (the matrix-product version before the
batch kernel) to ~1e-13 rad; at the stretched elbow (cos θ3 = ±1) and within ~1e-9 of the wrist
singularity, where the closed form amplifies rounding, the branches may differ by up to ~1e-6
rad (and the nearer of two near-identical elbow branches may swap).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from pipeline.solvers.kernels.kin import NO_SOLUTION, SUCCESS, TRACE_COLS, now_ns
from pipeline.solvers.core import (BatchRaw, IKResult, InfoRows, Prepared, Raw, Settings, check_pack,
                                   finish_packed, fused_inputs, setting)
from pipeline.solvers.core.driver import run_of
from pipeline.solvers.closed_form.analytic import alias_hooks
from pipeline.solvers.closed_form.subproblems import wrap as _wrap
from pipeline.solvers.core.registry import Solver, register
from pipeline.solvers.core.timing import clock_ns

SOURCE = "004_957b32c2b06ea31d.txt (Nepomuceno 2024) §4.8; Hawkins (2013)"
UR_ALPHA = np.array([math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0])
UR_TOL = 1e-9  # the DH table must match the closed form's structure to this (typed decimals are exact)
CLIP_TOL = 1e-9


@dataclass(frozen=True)
class AnalyticURSettings(Settings):
    wrist_eps: float = setting(1e-10, "|sin θ5| below this = wrist singularity (θ6 := the start's θ6)", minimum=0.0)
    verify_position: float = setting(1e-9, "FK check of each closed-form solution: |Δp|", unit="m", above=0.0,
                                     length=True)
    verify_rotation: float = setting(1e-9, "FK check of each closed-form solution: rotation angle", unit="rad",
                                     above=0.0)


def applies_to(prep: Prepared) -> str | None:
    """One-line reason why the robot is not UR-type, or None."""
    c = prep.model.chain
    if c.n != 6:
        return f"not a UR-type arm: needs 6 joints, the robot has {c.n}"
    if c.prismatic.any():
        return "not a UR-type arm: needs 6 revolute joints (the robot has prismatic ones)"
    if c.general:
        return "needs a standard-DH table (the robot file is in the general URDF-style form)"
    if c.modified:
        return "not a UR-type arm: needs a standard-DH table (the robot file is modified DH)"
    if not np.allclose(c.alpha, UR_ALPHA, atol=UR_TOL):
        got = ", ".join(f"{v:.4g}" for v in c.alpha)
        return f"not a UR-type arm: needs alpha = (pi/2, 0, 0, pi/2, -pi/2, 0), got ({got})"
    if not np.allclose(c.a[[0, 3, 4, 5]], 0.0, atol=UR_TOL):
        return "not a UR-type arm: needs a1 = a4 = a5 = a6 = 0"
    if abs(c.a[1]) <= UR_TOL or abs(c.a[2]) <= UR_TOL:
        return "not a UR-type arm: needs a2 != 0 and a3 != 0"
    return None


# ---- packed parameters (once per job, :func:`packed`) -------------------------------------------
P_A, P_CA, P_SA, P_D, P_OFF = 0, 6, 12, 18, 24  # a, cos alpha, sin alpha, d, theta offsets (6 each)
P_BASE, P_TOOL, P_BINV, P_TINV = 30, 42, 54, 66  # rows 0-2 of base, tool and their inverses (12 each)
P_WEPS, P_TOLP, P_TOLR, P_PLAIN = 78, 79, 80, 81  # wrist_eps, verify_position, verify_rotation, base = tool = I
N_P = 82

# ---- workspace layout (one float array per call / per batch chunk) ------------------------------
W_TG, W_TB, W_TMP, W_B1, W_A1I, W_A5I, W_A6I, W_M = 0, 12, 24, 36, 48, 60, 72, 84  # 3 x 4 blocks
W_C0, W_S, W_S2, W_MID = 96, 108, 120, 132  # FK check: prefix, suffix (2), running product
W_Q8, W_T8, W_VALID = 150, 198, 294  # all 8 branches (8 x 6), their FK poses (8 x 12), valid flags (8)
N_W = 302
CHUNK = 64  # poses per work item of the batch kernel (one workspace each)



def rigid_rows(T: np.ndarray, inverse: bool = False) -> np.ndarray:
    """Rows 0-2 of a rigid transform (or of its inverse, as :meth:`Prepared.bare_goal` forms it), flattened (12,)."""
    T = np.asarray(T, dtype=float)
    if inverse:
        R = T[:3, :3].T
        return np.hstack([R, (-R @ T[:3, 3])[:, None]]).ravel()
    return np.ascontiguousarray(T[:3, :4]).ravel()


def packed(prep: Prepared, s: AnalyticURSettings) -> np.ndarray:
    """Everything the kernel needs of the robot and the settings, in one float array (see ``P_*``)."""
    a, alpha, d, offs, prism, form, base, tool = prep.args
    c = prep.model.chain
    P = np.zeros(N_P)
    P[P_A:P_A + 6] = a
    P[P_CA:P_CA + 6] = [math.cos(x) for x in alpha]  # libm, as the compiled kernels' cos
    P[P_SA:P_SA + 6] = [math.sin(x) for x in alpha]
    P[P_D:P_D + 6] = d
    P[P_OFF:P_OFF + 6] = offs
    P[P_BASE:P_BASE + 12] = rigid_rows(base)
    P[P_TOOL:P_TOOL + 12] = rigid_rows(tool)
    P[P_BINV:P_BINV + 12] = rigid_rows(c.base, inverse=True)
    P[P_TINV:P_TINV + 12] = rigid_rows(c.tool, inverse=True)
    P[P_WEPS] = s.wrist_eps
    P[P_TOLP] = s.verify_position
    P[P_TOLR] = s.verify_rotation
    P[P_PLAIN] = float(np.array_equal(base, np.eye(4)) and np.array_equal(tool, np.eye(4)))
    return P


# ---- allocation-free helpers on flat 3 x 4 blocks (row-major, row 3 = 0 0 0 1 implied) -----------
@numba.njit(cache=True, inline="always")
def mul34(A, ia, B, ib, C, ic):
    """``C[ic:ic+12] = A[ia:ia+12] B[ib:ib+12]`` (rigid 3 x 4 blocks; C must not overlap A or B)."""
    for r in range(3):
        a0, a1, a2, a3 = A[ia + 4 * r], A[ia + 4 * r + 1], A[ia + 4 * r + 2], A[ia + 4 * r + 3]
        for c in range(4):
            C[ic + 4 * r + c] = a0 * B[ib + c] + a1 * B[ib + 4 + c] + a2 * B[ib + 8 + c]
        C[ic + 4 * r + 3] += a3


@numba.njit(cache=True, inline="always")
def copy12(A, ia, C, ic):
    for k in range(12):
        C[ic + k] = A[ia + k]


@numba.njit(cache=True, inline="always")
def _link(W, o, ct, st, a, ca, sa, d):
    """``W[o:o+12]`` = standard-DH link Rz(theta) Tz(d) Tx(a) Rx(alpha) at cos/sin theta = ``ct``, ``st``
    (as ``_kin.link_transform``)."""
    W[o], W[o + 1], W[o + 2], W[o + 3] = ct, -st * ca, st * sa, a * ct
    W[o + 4], W[o + 5], W[o + 6], W[o + 7] = st, ct * ca, -ct * sa, a * st
    W[o + 8], W[o + 9], W[o + 10], W[o + 11] = 0.0, sa, ca, d


@numba.njit(cache=True, inline="always")
def _cs(t, t_known, c_known, s_known):
    """(cos t, sin t), reusing the known pair when ``t`` is bitwise the angle it belongs to."""
    if t == t_known:
        return c_known, s_known
    return math.cos(t), math.sin(t)


@numba.njit(cache=True, inline="always")
def _link_inv(W, o, ct, st, a, ca, sa, d):
    """``W[o:o+12]`` = the inverse of the link at cos/sin theta = ``ct``, ``st`` (``inv_rigid`` of it)."""
    l00, l01, l02, l03 = ct, -st * ca, st * sa, a * ct
    l10, l11, l12, l13 = st, ct * ca, -ct * sa, a * st
    l20, l21, l22, l23 = 0.0, sa, ca, d
    W[o], W[o + 1], W[o + 2] = l00, l10, l20
    W[o + 4], W[o + 5], W[o + 6] = l01, l11, l21
    W[o + 8], W[o + 9], W[o + 10] = l02, l12, l22
    W[o + 3] = -(l00 * l03 + l10 * l13 + l20 * l23)
    W[o + 7] = -(l01 * l03 + l11 * l13 + l21 * l23)
    W[o + 11] = -(l02 * l03 + l12 * l13 + l22 * l23)


@numba.njit(cache=True, inline="always")
def mul_link(W, o, ct, st, a, ca, sa, d):
    """``W[o:o+12] = W[o:o+12] · link`` in place, cos/sin theta = ``ct``, ``st`` (the product of ``_lean.fk``)."""
    for r in range(3):
        k = o + 4 * r
        c0, c1, c2, c3 = W[k], W[k + 1], W[k + 2], W[k + 3]
        x0 = c0 * ct + c1 * st
        y0 = c1 * ct - c0 * st
        W[k] = x0
        W[k + 1] = y0 * ca + c2 * sa
        W[k + 2] = c2 * ca - y0 * sa
        W[k + 3] = a * x0 + c2 * d + c3


@numba.njit(cache=True, inline="always")
def pose_errors(Tg, W, o):
    """(|Δp|, rotation angle) of the pose ``W[o:o+12]`` against ``Tg`` (as ``_kin.position_distance``
    and ``_kin.rotation_angle``)."""
    x = Tg[0, 3] - W[o + 3]
    y = Tg[1, 3] - W[o + 7]
    z = Tg[2, 3] - W[o + 11]
    dp = math.sqrt(x * x + y * y + z * z)
    r00 = Tg[0, 0] * W[o] + Tg[0, 1] * W[o + 1] + Tg[0, 2] * W[o + 2]
    r11 = Tg[1, 0] * W[o + 4] + Tg[1, 1] * W[o + 5] + Tg[1, 2] * W[o + 6]
    r22 = Tg[2, 0] * W[o + 8] + Tg[2, 1] * W[o + 9] + Tg[2, 2] * W[o + 10]
    r21 = Tg[2, 0] * W[o + 4] + Tg[2, 1] * W[o + 5] + Tg[2, 2] * W[o + 6]
    r12 = Tg[1, 0] * W[o + 8] + Tg[1, 1] * W[o + 9] + Tg[1, 2] * W[o + 10]
    r02 = Tg[0, 0] * W[o + 8] + Tg[0, 1] * W[o + 9] + Tg[0, 2] * W[o + 10]
    r20 = Tg[2, 0] * W[o] + Tg[2, 1] * W[o + 1] + Tg[2, 2] * W[o + 2]
    r10 = Tg[1, 0] * W[o] + Tg[1, 1] * W[o + 1] + Tg[1, 2] * W[o + 2]
    r01 = Tg[0, 0] * W[o + 4] + Tg[0, 1] * W[o + 5] + Tg[0, 2] * W[o + 6]
    s0, s1, s2 = r21 - r12, r02 - r20, r10 - r01
    ang = math.atan2(0.5 * math.sqrt(s0 * s0 + s1 * s1 + s2 * s2), 0.5 * (r00 + r11 + r22 - 1.0))
    return dp, ang


@numba.njit(cache=True, inline="always")
def _doc_row(Tg, W, o, out):
    """``out`` (8,) = [‖e‖, e (6), |Δp|] of the document's error (``optimizers.doc_error``) at the pose
    ``W[o:o+12]``."""
    for r in range(3):
        out[1 + r] = Tg[r, 3] - W[o + 4 * r + 3]
    ox = 0.0
    oy = 0.0
    oz = 0.0
    for i in range(3):
        cx, cy, cz = W[o + i], W[o + 4 + i], W[o + 8 + i]
        dx, dy, dz = Tg[0, i], Tg[1, i], Tg[2, i]
        ox += cy * dz - cz * dy
        oy += cz * dx - cx * dz
        oz += cx * dy - cy * dx
    out[4] = 0.5 * ox
    out[5] = 0.5 * oy
    out[6] = 0.5 * oz
    out[7] = math.sqrt(out[1] * out[1] + out[2] * out[2] + out[3] * out[3])
    s = 0.0
    for r in range(6):
        s += out[1 + r] * out[1 + r]
    out[0] = math.sqrt(s)


@numba.njit(cache=True, inline="always")
def _bare_goal(P, Tg, W):
    """The goal ``Tg`` into ``W[W_TG:]`` and the bare goal (base⁻¹ T tool⁻¹, as Prepared.bare_goal) into
    ``W[W_TB:]``, 3 × 4 blocks."""
    for r in range(3):
        for c in range(4):
            W[W_TG + 4 * r + c] = Tg[r, c]
    if P[P_PLAIN] != 0.0:
        copy12(W, W_TG, W, W_TB)
    else:
        mul34(P, P_BINV, W, W_TG, W, W_TMP)
        mul34(W, W_TMP, P, P_TINV, W, W_TB)


@numba.njit(cache=True, inline="always")
def _shoulder(P, W):
    """θ1's two branches as ψ ± φ + π/2 from the bare goal's wrist point p5 (``W[W_TB:]``): (ψ, φ, whether
    they exist: |cos φ| within 1 + CLIP_TOL and p5 off the base axis)."""
    dsh = P[P_D + 1] + P[P_D + 2] + P[P_D + 3]
    d6 = P[P_D + 5]
    b02, b03 = W[W_TB + 2], W[W_TB + 3]
    b12, b13 = W[W_TB + 6], W[W_TB + 7]
    p5x = b03 - d6 * b02
    p5y = b13 - d6 * b12
    r5 = math.sqrt(p5x * p5x + p5y * p5y)
    psi = math.atan2(p5y, p5x)
    ok1 = True
    if r5 < 1e-300:
        c = 0.0
        ok1 = False
    else:
        c = dsh / r5
    if c > 1.0 + CLIP_TOL or c < -1.0 - CLIP_TOL:
        ok1 = False
    c = min(1.0, max(-1.0, c))
    return psi, math.acos(c), ok1


@numba.njit(cache=True, inline="always")
def _t14(W):
    """Of T14 = A1⁻¹ T A6⁻¹ A5⁻¹ (``W[W_M:]`` = A1⁻¹ T A6⁻¹, ``W[W_A5I:]`` = A5⁻¹): entries (0, 0), (1, 0),
    (0, 3), (1, 3)."""
    m00, m01, m02, m03 = W[W_M], W[W_M + 1], W[W_M + 2], W[W_M + 3]
    m10, m11, m12, m13 = W[W_M + 4], W[W_M + 5], W[W_M + 6], W[W_M + 7]
    u0, u1, u2 = W[W_A5I], W[W_A5I + 4], W[W_A5I + 8]
    v0, v1, v2 = W[W_A5I + 3], W[W_A5I + 7], W[W_A5I + 11]
    t00 = m00 * u0 + m01 * u1 + m02 * u2
    t10 = m10 * u0 + m11 * u1 + m12 * u2
    x = m00 * v0 + m01 * v1 + m02 * v2 + m03
    y = m10 * v0 + m11 * v1 + m12 * v2 + m13
    return t00, t10, x, y


@numba.njit(cache=True, inline="always")
def _elbows(P, Tg, W, row0, ac3, aty, at3, th234, sn3, cs3, j0, j4, j5, suf, ok3):
    """The two elbow branches (rows ``row0`` and ``row0 + 1``) of one (θ1, θ5) branch: their joints into
    ``W[W_Q8:]``, their FK poses (prefix ``W[W_C0:]``, suffix ``W[suf:]``) into ``W[W_T8:]``, their
    verdicts into ``W[W_VALID:]``; returns how many are valid."""
    off1, off2, off3 = P[P_OFF + 1], P[P_OFF + 2], P[P_OFF + 3]
    tol_pos, tol_rot = P[P_TOLP], P[P_TOLR]
    nvalid = 0
    for i3 in range(2):
        th3 = ac3 if i3 == 0 else -ac3
        th2 = aty - (at3 if i3 == 0 else -at3)
        th4 = th234 - th2 - th3
        row = row0 + i3
        o = W_Q8 + 6 * row
        j1 = _wrap(th2 - off1)
        j2 = _wrap(th3 - off2)
        j3 = _wrap(th4 - off3)
        W[o], W[o + 1], W[o + 2], W[o + 3], W[o + 4], W[o + 5] = j0, j1, j2, j3, j4, j5
        copy12(W, W_C0, W, W_MID)
        t = off1 + j1
        mul_link(W, W_MID, math.cos(t), math.sin(t), P[P_A + 1], P[P_CA + 1], P[P_SA + 1], P[P_D + 1])
        ct, st = _cs(off2 + j2, th3, cs3, sn3 if i3 == 0 else -sn3)  # cos, sin are even, odd
        mul_link(W, W_MID, ct, st, P[P_A + 2], P[P_CA + 2], P[P_SA + 2], P[P_D + 2])
        t = off3 + j3
        mul_link(W, W_MID, math.cos(t), math.sin(t), P[P_A + 3], P[P_CA + 3], P[P_SA + 3], P[P_D + 3])
        ot = W_T8 + 12 * row
        mul34(W, W_MID, W, suf, W, ot)
        dp, ang = pose_errors(Tg, W, ot)
        good = ok3 and dp <= tol_pos and ang <= tol_rot
        W[W_VALID + row] = 1.0 if good else 0.0
        if good:
            nvalid += 1
    return nvalid


@numba.njit(cache=True, inline="always")
def _nearest_branch(W, q_start, S, q):
    """The valid branches (``W[W_VALID:]``) into the first rows of ``S`` (8, 6) in row order, NaN below;
    ``q`` the nearest to ``q_start`` (wrapped distance) moved by turns to within π of it, or ``q_start``;
    returns its branch row or −1."""
    best = -1
    bestd = 1e300
    k = 0
    for r in range(8):
        if W[W_VALID + r] == 0.0:
            continue
        dist = 0.0
        for j in range(6):
            S[k, j] = W[W_Q8 + 6 * r + j]
            dj = _wrap(S[k, j] - q_start[j])
            dist += dj * dj
        k += 1
        if dist < bestd:
            bestd = dist
            best = r
    for r in range(k, 8):
        for j in range(6):
            S[r, j] = math.nan
    for j in range(6):
        q[j] = q_start[j] if best < 0 else q_start[j] + _wrap(W[W_Q8 + 6 * best + j] - q_start[j])
    return best


@numba.njit(cache=True, inline="always")
def _ur_trace(P, Tg, q_start, W, trace, start_row, best, plain):
    """The trace (2, 8): the document's error at the start (FK of q_start; NaN when not ``start_row`` and a
    branch was found) and at q (the chosen branch's FK pose, ``best``)."""
    if not start_row and best >= 0:
        for c in range(8):
            trace[0, c] = math.nan
        _doc_row(Tg, W, W_T8 + 12 * best, trace[1])
        return
    copy12(P, P_BASE, W, W_MID)
    for j in range(6):
        t = P[P_OFF + j] + q_start[j]
        mul_link(W, W_MID, math.cos(t), math.sin(t), P[P_A + j], P[P_CA + j], P[P_SA + j], P[P_D + j])
    if plain:
        copy12(W, W_MID, W, W_TMP)
    else:
        mul34(W, W_MID, P, P_TOOL, W, W_TMP)
    _doc_row(Tg, W, W_TMP, trace[0])
    if best < 0:
        for c in range(8):
            trace[1, c] = trace[0, c]
    else:
        _doc_row(Tg, W, W_T8 + 12 * best, trace[1])


@numba.njit(cache=True)
def ur_core(P, Tg, q_start, W, clk, S, q, trace, start_row):
    """One pose: all 8 branches, their FK check, the choice, the trace.

    ``P`` from :func:`packed`; ``Tg`` (4, 4) the whole chain's goal (working unit); ``W`` (N_W,)
    and ``clk`` (2,) int64 scratch. Writes the FK-valid branches (row order, wrapped to (−π, π])
    into the first rows of ``S`` (8, 6) (NaN below), the returned angles into ``q`` (6,) and the
    document's error at ``q_start`` and ``q`` into ``trace`` (2, 8) (row 0 is NaN when not
    ``start_row`` and a branch was found: it costs one FK). Returns (number valid, chosen branch row
    or −1, solve time [ns], the trace excluded).
    """
    t0 = now_ns(clk)
    _bare_goal(P, Tg, W)
    a2 = P[P_A + 1]
    a3 = P[P_A + 2]
    off0, off4, off5 = P[P_OFF], P[P_OFF + 4], P[P_OFF + 5]
    wrist_eps = P[P_WEPS]
    plain = P[P_PLAIN] != 0.0
    b00, b01, b02 = W[W_TB], W[W_TB + 1], W[W_TB + 2]
    b10, b11, b12 = W[W_TB + 4], W[W_TB + 5], W[W_TB + 6]
    b22 = W[W_TB + 10]
    psi, phi, ok1 = _shoulder(P, W)
    nvalid = 0
    for i1 in range(2):
        th1 = psi + (phi if i1 == 0 else -phi) + 0.5 * math.pi
        s1, c1 = math.sin(th1), math.cos(th1)
        t1 = off0 + (th1 - off0)  # the angle the reference took through a one-joint chain
        ct, st = _cs(t1, th1, c1, s1)
        _link_inv(W, W_A1I, ct, st, P[P_A], P[P_CA], P[P_SA], P[P_D])
        mul34(W, W_A1I, W, W_TB, W, W_B1)
        c5 = b02 * s1 - b12 * c1
        s5abs = math.sqrt(b22 * b22 + (b02 * c1 + b12 * s1) ** 2)
        j0 = _wrap(th1 - off0)
        copy12(P, P_BASE, W, W_C0)  # FK check, prefix base · A1(j0) (shared by the 4 branches of i1)
        ct, st = _cs(off0 + j0, t1, ct, st)
        mul_link(W, W_C0, ct, st, P[P_A], P[P_CA], P[P_SA], P[P_D])
        for i5 in range(2):
            s5 = s5abs if i5 == 0 else -s5abs
            th5 = math.atan2(s5, c5)
            if s5abs < wrist_eps:
                th6 = q_start[5] + off5
            else:
                sg = 1.0 if s5 > 0.0 else -1.0
                th6 = math.atan2(sg * (-b01 * s1 + b11 * c1), sg * (b00 * s1 - b10 * c1))
            t6 = off5 + (th6 - off5)
            c6, s6 = math.cos(t6), math.sin(t6)
            _link_inv(W, W_A6I, c6, s6, P[P_A + 5], P[P_CA + 5], P[P_SA + 5], P[P_D + 5])
            t5 = off4 + (th5 - off4)
            c5t, s5t = math.cos(t5), math.sin(t5)
            _link_inv(W, W_A5I, c5t, s5t, P[P_A + 4], P[P_CA + 4], P[P_SA + 4], P[P_D + 4])
            mul34(W, W_B1, W, W_A6I, W, W_M)  # T14 = A1^-1 T A6^-1 A5^-1: columns 0 and 3 of rows 0, 1
            t00, t10, x, y = _t14(W)
            c3 = (x * x + y * y - a2 * a2 - a3 * a3) / (2.0 * a2 * a3)
            ok3 = ok1
            if c3 > 1.0 + CLIP_TOL or c3 < -1.0 - CLIP_TOL:
                ok3 = False
            c3 = min(1.0, max(-1.0, c3))
            th234 = math.atan2(t10, t00)
            ac3 = math.acos(c3)
            sn3, cs3 = math.sin(ac3), math.cos(ac3)
            aty = math.atan2(y, x)
            at3 = math.atan2(a3 * sn3, a2 + a3 * cs3)  # atan2 is odd in y: the other elbow branch is -at3
            j4 = _wrap(th5 - off4)
            j5 = _wrap(th6 - off5)
            # FK check, suffix A5(j4) A6(j5) tool (shared by the 2 branches of i3)
            ct, st = _cs(off4 + j4, t5, c5t, s5t)
            _link(W, W_S, ct, st, P[P_A + 4], P[P_CA + 4], P[P_SA + 4], P[P_D + 4])
            ct, st = _cs(off5 + j5, t6, c6, s6)
            mul_link(W, W_S, ct, st, P[P_A + 5], P[P_CA + 5], P[P_SA + 5], P[P_D + 5])
            suf = W_S
            if not plain:
                mul34(W, W_S, P, P_TOOL, W, W_S2)
                suf = W_S2
            nvalid += _elbows(P, Tg, W, 4 * i1 + 2 * i5, ac3, aty, at3, th234, sn3, cs3, j0, j4, j5, suf, ok3)
    best = _nearest_branch(W, q_start, S, q)
    ns = now_ns(clk) - t0
    _ur_trace(P, Tg, q_start, W, trace, start_row, best, plain)
    return nvalid, best, ns


@numba.njit(cache=True)
def ur_one(P, Tg, q_start, S, q, trace):
    """:func:`ur_core` with its own scratch (the single-pose call)."""
    W = np.empty(N_W)
    clk = np.zeros(2, np.int64)
    return ur_core(P, Tg, q_start, W, clk, S, q, trace, True)


@numba.njit(cache=True)
def ur_call(PC, Tg, q_start, S, q, trace):
    """The whole public single call in one compiled call: :func:`ur_core`, then the result rule of
    every finish (:func:`pipeline.solvers.core.finish_packed`: the independent FK check of the chosen
    ``q`` by the dual-quaternion FK, no code shared with the closed form's, its joint-limit record and
    the stop reason; without ``require_limits``).

    ``PC`` = :func:`packed` followed by :func:`~pipeline.solvers.core.check_pack`. Returns (number
    valid, chosen row or −1, solve time [ns] (ur_core's, the check excluded), stop reason, claimed
    success, success, |dp|, angle, within the limits, the document's error at ``q``).
    """
    W = np.empty(N_W)
    clk = np.zeros(2, np.int64)
    nv, best, ns = ur_core(PC[:N_P], Tg, q_start, W, clk, S, q, trace, True)
    code, claimed, success, dp, ang, inside = finish_packed(PC[N_P:], q, Tg, SUCCESS if best >= 0 else NO_SOLUTION)
    return nv, best, ns, code, claimed, success, dp, ang, inside, trace[1, 0]


@numba.njit(cache=True, parallel=True)
def ur_batch(P, goals, starts, S, Q, traces, nsol, best, ns, start_rows):
    """:func:`ur_core` for every row: ``goals`` (N, 4, 4), ``starts`` (N, 6) -> ``S`` (N, 8, 6),
    ``Q`` (N, 6), ``traces`` (N, 2, 8), ``nsol``/``best``/``ns`` (N,). Work items of ``CHUNK`` poses,
    one workspace each; every pose writes only its own rows (results independent of the thread count)."""
    N = goals.shape[0]
    for k in numba.prange((N + CHUNK - 1) // CHUNK):
        W = np.empty(N_W)
        clk = np.zeros(2, np.int64)
        for i in range(k * CHUNK, min(N, (k + 1) * CHUNK)):
            nv, b, t = ur_core(P, goals[i], starts[i], W, clk, S[i], Q[i], traces[i], start_rows)
            nsol[i] = nv
            best[i] = b
            ns[i] = t


_MESSAGES = [f"{k} FK-verified solutions" for k in range(9)]


def _info(nv: int, best: int, doc: float) -> dict:
    return {"n_solutions": nv, "branch": best, "nfev": 8, "njev": 0, "doc_error": doc,
            "message": _MESSAGES[nv] if best >= 0 else "no valid closed-form solution"}


def bind(prep: Prepared, s: AnalyticURSettings):
    """``run1(T_goal, q_start, seed) -> Raw`` with the robot and settings packed once (see :func:`packed`)."""
    P = packed(prep, s)

    def run1(T_goal: np.ndarray, q_start: np.ndarray, seed: int) -> Raw:
        S = np.empty((8, 6))
        q = np.empty(6)
        trace = np.empty((2, TRACE_COLS))
        nv, best, ns = ur_one(P, T_goal, q_start, S, q, trace)
        return Raw(q=q, code=SUCCESS if best >= 0 else NO_SOLUTION, iterations=1, solve_ns=ns, trace=trace,
                   solutions=S[:nv], info=_info(nv, best, float(trace[1, 0])))

    return run1


_NO_SOLUTION_TEXT = "no valid closed-form solution"


def bind_call(prep: Prepared, s: AnalyticURSettings):
    """The public single call fused: ``call(T_goal, q_start, seed, t0) -> IKResult`` (the registry's
    ``Solver.bind_call``), or None under ``require_limits`` (the registry's generic path then runs
    ``bind`` and :func:`~pipeline.solvers.core.finish`).

    Why it exists: the closed form costs ~2.2 us, but ``run1`` + ``finish`` around it cost ~5.5 us
    more (two compiled dispatches with 6 and 8 arguments, a :class:`Raw` and an :class:`IKResult`
    built by keyword, the FK check's arguments looked up per call), which put the call at 8 us in
    this VM's fast phase and 11-13 us in its slow one. Here the kernel, the choice, the independent
    FK check and the limit record are one compiled call (:func:`ur_call`, 6 array arguments, the
    robot, the settings and the check's model packed once into one array), and the result is built
    positionally. Its values are those of the generic path bit for bit (tests/solvers/closed_form/test_fastpath_ur.py).
    ``T_goal`` is in the robot file's unit (as the public call takes it); ``t0`` the caller's start
    on the call clock [ns], so ``call_time_s`` covers the whole call, result included.
    """
    if s.require_limits:
        return None
    PC = np.concatenate([packed(prep, s), check_pack(prep, s)])
    inputs, unit, pos_only = fused_inputs(prep), prep.unit, s.criterion == "position"
    nan, empty, messages = math.nan, np.empty, _MESSAGES

    def call(T_goal: np.ndarray, q_start: np.ndarray, seed: int, t0: int) -> IKResult:
        Tg, q0 = inputs(T_goal, q_start)
        S = empty((8, 6))
        q = empty(6)
        trace = empty((2, TRACE_COLS))
        nv, best, ns, code, claimed, success, dp, ang, inside, doc = ur_call(PC, Tg, q0, S, q, trace)
        info = {"n_solutions": nv, "branch": best, "nfev": 8, "njev": 0, "doc_error": doc,
                "message": messages[nv] if claimed else _NO_SOLUTION_TEXT}
        res = IKResult(q, success, code, 1, trace, ns * 1e-9, 0.0, dp,
                       nan if pos_only else ang, claimed, inside, nan, unit, S[:nv], info)
        res.call_time_s = (clock_ns() - t0) * 1e-9
        return res

    return call


run = run_of(bind)  # one pose (``T_goal`` in the working unit): ``bind(prep, s)(T_goal, q_start, seed)``


def batch(prep: Prepared, s: AnalyticURSettings, goals: np.ndarray, starts: np.ndarray, seeds, keep_traces: bool):
    """N poses in one compiled call (both cores).

    Returns a :class:`BatchRaw`: ``q`` (N, 6) the chosen branch (as the single call), ``code``
    SUCCESS / NO_SOLUTION, ``iterations`` 1, ``solve_ns`` per pose, ``ik_ns`` 0, ``solutions``
    (N, 8, 6) with the FK-valid branches in the first ``n_solutions[i]`` rows (NaN below),
    ``trace_rows`` (2 N, 8) / ``trace_offsets`` (2 rows per pose, when ``keep_traces``) and ``info``
    an :class:`InfoRows` (the single call's dict per pose, built on access).
    """
    P = packed(prep, s)
    N = goals.shape[0]
    S = np.empty((N, 8, 6))
    Q = np.empty((N, 6))
    traces = np.empty((N, 2, TRACE_COLS))
    nsol = np.zeros(N, np.int64)
    best = np.zeros(N, np.int64)
    ns = np.zeros(N, np.int64)
    ur_batch(P, goals, starts, S, Q, traces, nsol, best, ns, bool(keep_traces))
    doc = traces[:, 1, 0].copy()
    rows = traces.reshape(2 * N, 8) if keep_traces else None
    offsets = np.arange(0, 2 * N + 1, 2, dtype=np.int64) if keep_traces else None
    info = InfoRows(N, lambda i: _info(int(nsol[i]), int(best[i]), float(doc[i])))
    code = np.where(best >= 0, SUCCESS, NO_SOLUTION).astype(np.int64)
    return BatchRaw(q=Q, code=code, iterations=np.ones(N, np.int64),
                    solve_ns=ns, ik_ns=np.zeros(N, np.int64), trace_rows=rows, trace_offsets=offsets, solutions=S,
                    n_solutions=nsol, info=info)


# The transcription runs where its DH test passes (the studies' tables); on any other arm whose joint
# axes give the same family, whatever the file's form, the geometric closed form (pipeline.solvers.closed_form.analytic)
# runs under this name.
_hooks = alias_hooks("three_parallel", "UR-type (three parallel axes, the last two meeting)", applies_to, bind, batch, bind_call)
register(Solver("analytic_ur", "closed-form IK of UR-type arms, all 8 solutions (Hawkins 2013), nearest to the start", "analytic", AnalyticURSettings, _hooks["run"], applies_to=_hooks["applies_to"],
                source=SOURCE, bind=_hooks["bind"], batch=_hooks["batch"], bind_call=_hooks["bind_call"]))
