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

Every solution is checked by the independent numpy FK (:func:`pipeline.solvers.base.verify`,
the settings' tolerances); ``info`` holds the counts (``solutions_found``, ``solutions_valid``,
``degenerate_wrist``, ``distinct_branches``), the largest FK errors over all solutions, ``valid``
(one 0/1 per row of ``solutions``) and ``chosen`` (row returned as ``q``, -1 if none passed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from pipeline.solvers import _kin
from pipeline.solvers.base import Prepared, Raw, Settings, StopReason, verify
from pipeline.solvers.registry import Solver, register

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


@numba.njit(cache=True)
def _rz_rx(t, al, out):
    """Rotation part of Rz(t) Rx(al) into out (3, 3)."""
    ct, st, ca, sa = np.cos(t), np.sin(t), np.cos(al), np.sin(al)
    out[0, 0], out[0, 1], out[0, 2] = ct, -st * ca, st * sa
    out[1, 0], out[1, 1], out[1, 2] = st, ct * ca, -ct * sa
    out[2, 0], out[2, 1], out[2, 2] = 0.0, sa, ca


@numba.njit(cache=True)
def puma_kernel(T06, g, a, alpha, d, offs, sols, flags):
    """All closed-form solutions of the bare-chain goal ``T06``; returns their count (rows of ``sols``, ``flags``)."""
    a1, d1, d23, a2, a3, d4, a6, d6, al6 = g[0], g[1], g[2], g[3], g[4], g[5], g[6], g[7], g[8]
    s1, s3, s4, s5 = g[9], g[10], g[11], g[12]
    # wrist centre: the origin of frame 5 = T06 (Tz(d6) Tx(a6) Rx(al6))^-1 0
    pw = np.empty(3)
    sa6, ca6 = np.sin(al6), np.cos(al6)
    for r in range(3):
        pw[r] = T06[r, 3] - a6 * T06[r, 0] - d6 * (sa6 * T06[r, 1] + ca6 * T06[r, 2])
    r_xy = np.hypot(pw[0], pw[1])
    m = 0
    if r_xy < abs(d23):
        return m
    phi = np.arctan2(pw[1], pw[0])
    asn = np.arcsin(s1 * d23 / r_xy)
    L = np.hypot(a3, d4)
    beta = np.arctan2(s3 * d4, a3)
    R06r = np.empty((3, 3))  # R06 Rx(al6)^T
    for i in range(3):
        R06r[i, 0] = T06[i, 0]
        R06r[i, 1] = T06[i, 1] * ca6 - T06[i, 2] * sa6
        R06r[i, 2] = T06[i, 1] * sa6 + T06[i, 2] * ca6
    A = np.empty((3, 3))
    B = np.empty((3, 3))
    R03 = np.empty((3, 3))
    R = np.empty((3, 3))
    R45 = np.empty((3, 3))
    for arm in range(2):
        th1 = phi + asn if arm == 0 else phi - np.pi - asn
        c1, sn1 = np.cos(th1), np.sin(th1)
        X = c1 * pw[0] + sn1 * pw[1] - a1
        Y = s1 * (pw[2] - d1)
        cg = (X * X + Y * Y - a2 * a2 - L * L) / (2 * a2 * L)
        if abs(cg) > 1 + REACH_SLACK:
            continue
        cg = max(-1.0, min(1.0, cg))
        for el in range(2):
            elbow = 1.0 if el == 0 else -1.0
            gam = elbow * np.arccos(cg)
            th2 = np.arctan2(Y, X) - np.arctan2(L * np.sin(gam), a2 + L * np.cos(gam))
            th3 = gam + beta
            # R03 = Rz(th1) Rx(al1) Rz(th2) Rx(al2) Rz(th3) Rx(al3)
            _rz_rx(th1, alpha[0], A)
            _rz_rx(th2, alpha[1], B)
            R03[:, :] = A @ B
            _rz_rx(th3, alpha[2], A)
            R03[:, :] = R03 @ A
            R[:, :] = R03.T @ R06r
            hyp = np.hypot(R[0, 2], R[1, 2])
            for wr in range(2):
                w = 1.0 if wr == 0 else -1.0
                th5 = np.arctan2(w * hyp, -s4 * s5 * R[2, 2])
                deg = hyp < DEGENERATE_S5
                th4 = 0.0 if deg else np.arctan2(s5 * w * R[1, 2], s5 * w * R[0, 2])
                _rz_rx(th4, alpha[3], A)
                _rz_rx(th5, alpha[4], B)
                R45[:, :] = A @ B
                Rr = R45.T @ R
                th6 = np.arctan2(Rr[1, 0], Rr[0, 0])
                sols[m, 0] = th1 - offs[0]
                sols[m, 1] = th2 - offs[1]
                sols[m, 2] = th3 - offs[2]
                sols[m, 3] = th4 - offs[3]
                sols[m, 4] = th5 - offs[4]
                sols[m, 5] = th6 - offs[5]
                flags[m, 0] = 1 - 2 * arm
                flags[m, 1] = int(elbow)
                flags[m, 2] = int(w)
                flags[m, 3] = 1 if deg else 0
                m += 1
    return m


@numba.njit(cache=True)
def timed_kernel(T06, g, a, alpha, d, offs, sols, flags, times):
    clk = np.zeros(2, np.int64)
    t0 = _kin.now_ns(clk)
    m = puma_kernel(T06, g, a, alpha, d, offs, sols, flags)
    times[0] = _kin.now_ns(clk) - t0
    return m


def run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: AnalyticPumaSettings, seed: int) -> Raw:
    g = prep.memo("analytic_puma_geometry", lambda: geometry(prep))
    a, alpha, d, offs = prep.args[:4]
    T06 = np.ascontiguousarray(prep.bare_goal(T_goal))
    sols = np.empty((8, 6))
    flags = np.zeros((8, 4), np.int64)
    times = np.zeros(1, np.int64)
    m = int(timed_kernel(T06, g, a, alpha, d, offs, sols, flags, times))
    sols = sols[:m].copy()
    checks = [verify(prep.model, T_goal, q, s) for q in sols]
    valid = np.array([ok for ok, _, _ in checks], dtype=bool)
    f = flags[:m]
    info = {"solutions_found": m, "solutions_valid": int(valid.sum()),
            "max_position_error": max((dp for _, dp, _ in checks), default=float("nan")),
            "max_orientation_error": max((ang for _, _, ang in checks), default=float("nan")),
            "degenerate_wrist": int(f[:, 3].sum()),
            "distinct_branches": len({tuple(r[:3]) for r in f.tolist()}),
            "branches": " ".join("".join("+" if v > 0 else "-" for v in r[:3]) + ("d" if r[3] else "") for r in f.tolist()),
            "valid": "".join("1" if v else "0" for v in valid)}
    if valid.any():
        cand = np.flatnonzero(valid)
        diff = sols[cand] - q_start[None, :]
        diff = (diff + np.pi) % (2 * np.pi) - np.pi  # revolute joints: nearest modulo 2 pi
        best = int(cand[np.argmin(np.einsum("ij,ij->i", diff, diff))])
        return Raw(q=sols[best].copy(), code=int(StopReason.SUCCESS), iterations=0, solve_ns=int(times[0]),
                   ik_ns=int(times[0]), solutions=sols, info={**info, "chosen": best})
    return Raw(q=np.array(q_start, dtype=float), code=int(StopReason.NO_SOLUTION), iterations=0,
               solve_ns=int(times[0]), ik_ns=int(times[0]), solutions=sols, info={**info, "chosen": -1})


register(Solver("analytic_puma", "closed-form IK of PUMA-type arms (spherical wrist): all 8 solutions, the one "
                "nearest the start returned", "analytic", AnalyticPumaSettings, run, applies_to=applies_to,
                source=SOURCE))
