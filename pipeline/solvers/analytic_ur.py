"""Closed-form inverse kinematics of UR-type arms: all 8 solutions (004_957b32c2b06ea31d.txt §4.8).

Geometry (Hawkins 2013, "Analytic inverse kinematics for the Universal Robots UR-5/UR-10 arms"):
six revolute joints, standard DH, ``alpha = (π/2, 0, 0, π/2, −π/2, 0)``, ``a1 = a4 = a5 = a6 = 0``,
``a2, a3 ≠ 0``; any ``d`` and joint offsets (``d2 + d3 + d4`` act as one shoulder offset, since
joints 2-4 are parallel); base and tool transforms are stripped from the goal first
(:meth:`~pipeline.solvers.base.Prepared.bare_goal`). Any other robot is refused with one line.

Branches ``(shoulder ±) × (wrist ±) × (elbow ±)``, row ``4 i1 + 2 i5 + i3``:

θ1   the wrist-2 origin ``p05 = p − d6 z6`` satisfies ``p05 · z1 = d2 + d3 + d4`` with
     ``z1 = (sin θ1, −cos θ1, 0)``.
θ5   ``atan2(±|z6 × z1|, z6 · z1)`` (the classic ``acos((p · z1 − d4) / d6)`` loses half the digits
     near θ5 = 0).
θ6   from the base x/y axes seen in the tool frame, signed by sin θ5; at the wrist singularity
     (``|sin θ5| < wrist_eps``, joints 4 and 6 aligned) θ6 is free and is set to the start's θ6
     (θ4 absorbs the rest), so nothing is divided by ~0.
θ3, θ2, θ4  the planar 3R arm in frame 1 (``T14 = A1⁻¹ T A6⁻¹ A5⁻¹``; link transforms from
     :func:`pipeline.solvers._kin.forward_pose` on one-joint chains).

Unreachable branches (a cosine beyond ±1 by more than ``CLIP_TOL``) are clipped, computed to finite
numbers and marked invalid; cosines within ``CLIP_TOL`` of ±1 (stretched elbow, wrist on the shoulder
cylinder) are rounding at a boundary and are kept if the FK check passes. Every branch is checked by
the compiled FK of the whole chain (base and tool included) against ``verify_position`` /
``verify_rotation``. ``Raw.solutions`` holds the FK-valid branches wrapped to (−π, π]; ``q`` is the
one nearest ``q_start`` (wrapped joint distance), unwrapped to lie within π of ``q_start`` per joint.
No valid branch: ``NO_SOLUTION`` with ``q = q_start``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from pipeline.solvers import _kin
from pipeline.solvers.base import Prepared, Raw, Settings, StopReason, setting
from pipeline.solvers.optimizers import doc_error
from pipeline.solvers.registry import Solver, register

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


@numba.njit(cache=True)
def _wrap(x):
    """Angle wrapped to (-π, π]."""
    y = x - 2.0 * math.pi * math.floor((x + math.pi) / (2.0 * math.pi))
    if y <= -math.pi:
        return y + 2.0 * math.pi
    return y


@numba.njit(cache=True)
def _inv_rigid(A, out):
    for r in range(3):
        for c in range(3):
            out[r, c] = A[c, r]
    for r in range(3):
        out[r, 3] = -(A[0, r] * A[0, 3] + A[1, r] * A[1, 3] + A[2, r] * A[2, 3])
    out[3, 0] = 0.0
    out[3, 1] = 0.0
    out[3, 2] = 0.0
    out[3, 3] = 1.0


@numba.njit(cache=True)
def _link_inv(a, alpha, d, offs, prism, i, theta, I4, q1, A, Ai):
    """Inverse of link ``i``'s transform at DH angle ``theta`` into ``Ai`` (via a one-joint chain)."""
    q1[0] = theta - offs[i]
    _kin.forward_pose(a[i:i + 1], alpha[i:i + 1], d[i:i + 1], offs[i:i + 1], prism[i:i + 1], 0, I4, I4, q1, A)
    _inv_rigid(A, Ai)


@numba.njit(cache=True)
def ur_solve(a, alpha, d, offs, prism, base, tool, Tb, Tg, q_start, wrist_eps, tol_pos, tol_rot, Q, valid, err, q,
             clk):
    """All 8 branches into ``Q`` (8, 6) (joint values wrapped to (−π, π]), ``valid`` (8,), ``err``
    (8, 2) = (|Δp|, angle); the valid branch nearest ``q_start`` into ``q``.

    ``Tb`` is the bare-chain goal (base and tool stripped), ``Tg`` the goal of the whole chain.
    Returns (number valid, chosen row or −1, solve time [ns]).
    """
    t0 = _kin.now_ns(clk)
    n = 6
    d1 = d[0]
    a2 = a[1]
    a3 = a[2]
    dsh = d[1] + d[2] + d[3]
    d6 = d[5]
    px, py = Tb[0, 3], Tb[1, 3]
    p5x = px - d6 * Tb[0, 2]
    p5y = py - d6 * Tb[1, 2]
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
    phi = math.acos(c)
    I4 = np.eye(4)
    A = np.empty((4, 4))
    A1i = np.empty((4, 4))
    A5i = np.empty((4, 4))
    A6i = np.empty((4, 4))
    T = np.empty((4, 4))
    q1 = np.empty(1)
    qq = np.empty(6)
    nvalid = 0
    for i1 in range(2):
        th1 = psi + (phi if i1 == 0 else -phi) + 0.5 * math.pi
        s1, c1 = math.sin(th1), math.cos(th1)
        _link_inv(a, alpha, d, offs, prism, 0, th1, I4, q1, A, A1i)
        B1 = A1i @ Tb
        c5 = Tb[0, 2] * s1 - Tb[1, 2] * c1
        s5abs = math.sqrt(Tb[2, 2] * Tb[2, 2] + (Tb[0, 2] * c1 + Tb[1, 2] * s1) ** 2)
        for i5 in range(2):
            s5 = s5abs if i5 == 0 else -s5abs
            th5 = math.atan2(s5, c5)
            if s5abs < wrist_eps:
                th6 = q_start[5] + offs[5]
            else:
                sg = 1.0 if s5 > 0.0 else -1.0
                th6 = math.atan2(sg * (-Tb[0, 1] * s1 + Tb[1, 1] * c1), sg * (Tb[0, 0] * s1 - Tb[1, 0] * c1))
            _link_inv(a, alpha, d, offs, prism, 5, th6, I4, q1, A, A6i)
            _link_inv(a, alpha, d, offs, prism, 4, th5, I4, q1, A, A5i)
            B = (B1 @ A6i) @ A5i  # T14
            x, y = B[0, 3], B[1, 3]
            c3 = (x * x + y * y - a2 * a2 - a3 * a3) / (2.0 * a2 * a3)
            ok3 = ok1
            if c3 > 1.0 + CLIP_TOL or c3 < -1.0 - CLIP_TOL:
                ok3 = False
            c3 = min(1.0, max(-1.0, c3))
            th234 = math.atan2(B[1, 0], B[0, 0])
            for i3 in range(2):
                th3 = math.acos(c3) if i3 == 0 else -math.acos(c3)
                th2 = math.atan2(y, x) - math.atan2(a3 * math.sin(th3), a2 + a3 * math.cos(th3))
                th4 = th234 - th2 - th3
                row = 4 * i1 + 2 * i5 + i3
                qq[0] = _wrap(th1 - offs[0])
                qq[1] = _wrap(th2 - offs[1])
                qq[2] = _wrap(th3 - offs[2])
                qq[3] = _wrap(th4 - offs[3])
                qq[4] = _wrap(th5 - offs[4])
                qq[5] = _wrap(th6 - offs[5])
                for j in range(n):
                    Q[row, j] = qq[j]
                _kin.forward_pose(a, alpha, d, offs, prism, 0, base, tool, qq, T)
                dp = _kin.position_distance(Tg, T)
                ang = _kin.rotation_angle(Tg, T)
                err[row, 0] = dp
                err[row, 1] = ang
                good = ok3 and dp <= tol_pos and ang <= tol_rot
                valid[row] = good
                if good:
                    nvalid += 1
    best = -1
    bestd = 1e300
    for r in range(8):
        if not valid[r]:
            continue
        dist = 0.0
        for j in range(n):
            dj = _wrap(Q[r, j] - q_start[j])
            dist += dj * dj
        if dist < bestd:
            bestd = dist
            best = r
    for j in range(n):
        q[j] = q_start[j] if best < 0 else q_start[j] + _wrap(Q[best, j] - q_start[j])
    return nvalid, best, _kin.now_ns(clk) - t0


@numba.njit(cache=True)
def _doc_trace(a, alpha, d, offs, prism, modified, base, tool, Tg, X, out):
    """Rows [‖e‖, e (6), |Δp|] of the document's error at each row of ``X``."""
    T = np.empty((4, 4))
    e = np.empty(6)
    for k in range(X.shape[0]):
        q = X[k].copy()
        _kin.forward_pose(a, alpha, d, offs, prism, modified, base, tool, q, T)
        dp = doc_error(T, Tg, e)
        s = 0.0
        for r in range(6):
            out[k, 1 + r] = e[r]
            s += e[r] * e[r]
        out[k, 0] = math.sqrt(s)
        out[k, 7] = dp


def run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: AnalyticURSettings, seed: int) -> Raw:
    a, alpha, d, offs, prism, modified, base, tool = prep.args
    Tb = np.ascontiguousarray(prep.bare_goal(T_goal))
    Q = np.empty((8, 6))
    valid = np.zeros(8, dtype=np.bool_)
    err = np.empty((8, 2))
    q = np.empty(6)
    clk = np.zeros(2, np.int64)
    nv, best, ns = ur_solve(a, alpha, d, offs, prism, base, tool, Tb, T_goal, q_start, float(s.wrist_eps),
                            float(s.verify_position), float(s.verify_rotation), Q, valid, err, q, clk)
    nv, best = int(nv), int(best)
    trace = np.empty((2, 8))
    _doc_trace(*prep.args, T_goal, np.ascontiguousarray(np.vstack([q_start, q])), trace)
    code = StopReason.SUCCESS if best >= 0 else StopReason.NO_SOLUTION
    return Raw(q=q, code=int(code), iterations=1, solve_ns=int(ns), trace=trace, solutions=Q[valid].copy(),
               info={"n_solutions": nv, "branch": best, "nfev": 8, "njev": 0, "doc_error": float(trace[1, 0]),
                     "message": f"{nv} FK-verified solutions" if best >= 0 else "no valid closed-form solution"})


register(Solver("analytic_ur", "closed-form IK of UR-type arms, all 8 solutions (Hawkins 2013), nearest to the start",
                "analytic", AnalyticURSettings, run, applies_to=applies_to, source=SOURCE))
