"""Closed-form IK of the 4-DOF arm of 003_8b306f4736fa5051.txt (Mariano & Lima 2019, eqs. 29-32).

The family: four revolute joints, a yaw joint followed by a planar 3R arm whose joint axes are
parallel and perpendicular to the yaw axis. In standard DH: ``alpha = (+-pi/2, 0, 0, 0)``, any
``d1``, ``a1`` (the document's ``d``), ``a4``, ``a2 != 0``, ``a3 != 0``; ``d2 + d3 + d4`` is a
lateral offset of the arm plane (0 in the document, handled here). Modified DH fits when
``alpha = (any, +-pi/2, 0, 0)`` (``alpha_0`` and ``a_0`` are a fixed pre-transform, the last link
length lives in the tool). Joint offsets are subtracted. Base and tool are stripped with
:meth:`~pipeline.solvers.core.Prepared.bare_goal`. Every parameter is read from the robot's chain.

With ``s = sin(alpha1)`` and ``psi = theta2 + theta3 + theta4`` the bare tool pose is
``R = Rz(theta1) Rx(alpha1) Rz(psi)``, ``p = Rz(theta1) (a1 + u, -s L, 0) + (0, 0, d1 + s v)``
with ``(u, v)`` the planar arm's tip. So, for a goal the arm can reach:

* ``theta1`` from the tool z axis ``(s sin theta1, -s cos theta1, 0)``; for goals whose orientation
  is ignored (criterion ``position`` / ``dq_norm_body``) also the two position branches
  ``atan2(y, x) - atan2(-s L, +-sqrt(x^2 + y^2 - L^2))`` (eq. 29 and its back solution; they
  place the flange, so they reach the goal point only when the tool has no translation);
* ``psi`` from the tool x axis: ``atan2(s x_z, cos theta1 x_x + sin theta1 x_y)`` (the document's
  pitch ``phi = -psi``, eqs. 4 and 26, over the full circle);
* the two elbows of the planar 2R wrist point (eqs. 30-31: ``beta = cos theta3``), ``theta4 = psi -
  theta2 - theta3`` (eq. 32).

Every candidate is checked by the compiled FK (:func:`pipeline.solvers.kernels.kin.forward_pose`, full
chain with base and tool) against the goal with the settings' success test; the FK-valid ones are
the solutions (duplicates removed; setting ``elbow`` may keep one branch only), the one nearest the
start angles is returned. A goal out of
reach, or an orientation the 4-DOF arm cannot take, gives NO_SOLUTION (q = the start angles).
``solve_time_s`` is the kernel (candidates, FK checks, choice) on ``_kin.now_ns``; stripping base
and tool (``Prepared.bare_goal``, numpy) happens before it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

import pipeline.solvers.kernels.kin as _kin
from pipeline.solvers.core import CRITERION_CODE, Prepared, Raw, Settings, StopReason, setting
from pipeline.solvers.core.registry import Solver, register

SOURCE = "003_8b306f4736fa5051.txt (Mariano & Lima 2019) eqs. 29-32, derived from the DH chain"
ANGLE_TOL = 1e-9   # alpha within this of its required value [rad]
LENGTH_TOL = 1e-12  # a2, a3 must exceed this relative to the chain's size
MAX_CAND = 6       # 1 orientation + 2 position branches of theta1, times 2 elbows
ELBOWS = ("both", "positive", "negative")


@dataclass(frozen=True)
class Analytic4DofSettings(Settings):
    """Settings of the 4-DOF closed form (the success test fields come from the base)."""

    reach_tol: float = setting(1e-9, "beta = cos(theta3) (eq. 31) up to 1 + this is a stretched or folded arm "
                               "(clipped to +-1); beyond it the wrist point is out of reach", minimum=0.0,
                               maximum=1e-3)
    elbow: str = setting("both", "elbow branches returned: both, or only the one with sin(theta3) >= 0 (positive) "
                         "or <= 0 (negative), the sign of the square root of eq. 30", choices=ELBOWS)
    dedupe_tol: float = setting(1e-9, "two candidates closer than this in every joint (angles wrapped) are one "
                                "solution", unit="rad", above=0.0, maximum=1e-3)


@dataclass(frozen=True)
class Geometry:
    """Canonical parameters of the arm (working unit) and the fixed pre-transform of modified DH."""

    g: np.ndarray            # (11,): s = sin(alpha1), d1, a1, L (lateral), a2, a3, a4, 4 joint offsets
    pre_inv: np.ndarray | None


def _rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def _near(x: float, want: float) -> bool:
    return abs(math.remainder(x - want, 2 * math.pi)) <= ANGLE_TOL


def _fmt(v) -> str:
    return "(" + ", ".join(f"{float(x):.4g}" for x in v) + ")"


def geometry(prep: Prepared) -> Geometry | str:
    """The canonical geometry of ``prep``'s chain, or a one-line reason why it is not the family."""
    c = prep.model.chain
    if c.n != 4:
        return f"needs 4 joints (a yaw joint then a planar 3R arm, 003), the robot has {c.n}"
    if c.prismatic.any():
        return f"needs 4 revolute joints, joint {int(np.argmax(c.prismatic)) + 1} is prismatic"
    if c.general:
        return "needs a DH table (the robot file is in the general URDF-style form)"
    a, al, d, off = (np.asarray(x, dtype=float) for x in (c.a, c.alpha, c.d, c.theta_offset))
    if c.modified:
        need = "alpha = (any, +-pi/2, 0, 0) in modified DH"
        ok = (_near(abs(math.remainder(al[1], 2 * math.pi)), math.pi / 2) and _near(al[2], 0) and _near(al[3], 0))
        s1, d1, a1, a2, a3, a4, lateral = math.sin(al[1]), d[0], a[1], a[2], a[3], 0.0, d[1] + d[2] + d[3]
        pre = _rot_x(al[0])
        pre[0, 3] = a[0]
    else:
        need = "alpha = (+-pi/2, 0, 0, 0) in standard DH"
        ok = _near(abs(math.remainder(al[0], 2 * math.pi)), math.pi / 2) and all(_near(x, 0) for x in al[1:])
        s1, d1, a1, a2, a3, a4, lateral = math.sin(al[0]), d[0], a[0], a[1], a[2], a[3], d[1] + d[2] + d[3]
        pre = None
    if not ok:
        return f"needs {need} (joints 2-4 parallel, perpendicular to joint 1), the robot has alpha = {_fmt(al)}"
    size = float(np.sum(np.abs(a)) + np.sum(np.abs(d))) or 1.0
    if abs(a2) <= LENGTH_TOL * size or abs(a3) <= LENGTH_TOL * size:
        return (f"needs non-zero lengths of links 2 and 3 (planar 2R wrist-point solution), the robot has "
                f"{a2:.4g}, {a3:.4g}")
    g = np.array([1.0 if s1 > 0 else -1.0, d1, a1, lateral, a2, a3, a4, *off], dtype=float)
    pre_inv = None
    if pre is not None and not np.allclose(pre, np.eye(4), atol=0, rtol=0):
        pre_inv = np.eye(4)
        pre_inv[:3, :3] = pre[:3, :3].T
        pre_inv[:3, 3] = -pre[:3, :3].T @ pre[:3, 3]
    return Geometry(g, pre_inv)


def applies_to(prep: Prepared) -> str | None:
    geo = geometry(prep)
    return geo if isinstance(geo, str) else None


@numba.njit(cache=True)
def _wrap(x):
    """Angle in [-pi, pi)."""
    return x - 2.0 * math.pi * math.floor((x + math.pi) / (2.0 * math.pi))


@numba.njit(cache=True, inline="always")
def _first_joint(Tb, s, lat, crit):
    """theta1's candidates for the bare goal ``Tb``: (up to 3 of them [rad], how many). From the tool z
    axis (s sin th1, -s cos th1, 0) where it is not vertical; where the orientation is ignored, also
    eq. 29 and the back branch."""
    x, y = Tb[0, 3], Tb[1, 3]
    th1 = np.empty(3)
    n1 = 0
    hz = math.sqrt(Tb[0, 2] * Tb[0, 2] + Tb[1, 2] * Tb[1, 2])
    if hz > 1e-12:                                   # tool z axis = (s sin th1, -s cos th1, 0)
        th1[n1] = math.atan2(s * Tb[0, 2], -s * Tb[1, 2])
        n1 += 1
    if crit == _kin.CRIT_POSITION or crit == _kin.CRIT_DQ_BODY:  # orientation ignored: eq. 29 and the back branch
        r2 = x * x + y * y - lat * lat
        if r2 >= 0.0:
            r = math.sqrt(r2)
            base_ang = math.atan2(y, x)
            th1[n1] = base_ang - math.atan2(-s * lat, r)
            th1[n1 + 1] = base_ang - math.atan2(-s * lat, -r)
            n1 += 2
    return th1, n1


@numba.njit(cache=True, inline="always")
def _is_new(sols, nsol, q, dedupe_tol):
    """``q`` differs from each of the first ``nsol`` rows of ``sols`` by more than ``dedupe_tol`` in some
    joint (wrapped)."""
    for m in range(nsol):
        same = True
        for j in range(4):
            if abs(_wrap(sols[m, j] - q[j])) > dedupe_tol:
                same = False
                break
        if same:
            return False
    return True


@numba.njit(cache=True, inline="always")
def _nearest(sols, nsol, q_start):
    """The row of ``sols`` (of the first ``nsol``) nearest ``q_start`` (sum of squares), or -1."""
    best = -1
    best_dist = np.inf
    for m in range(nsol):
        dist = 0.0
        for j in range(4):
            dist += (sols[m, j] - q_start[j]) ** 2
        if dist < best_dist:
            best_dist = dist
            best = m
    return best


@numba.njit(cache=True)
def solve_kernel(a, alpha, d, offs, prism, modified, base, tool, Tb, T_goal, q_start, g, crit, tol_pos, tol_rot,
                 tol_dq, reach_tol, elbow, dedupe_tol, sols, info):
    """Every FK-valid closed-form solution of ``Tb`` (the bare goal) into ``sols`` (MAX_CAND, 4).

    ``elbow``: 0 both branches, 1 only sin(theta3) >= 0, 2 only sin(theta3) <= 0.
    Returns (number of solutions, index of the one nearest ``q_start`` or -1, solve ns);
    ``info[0]`` = candidates tried (real wrist-point solutions).
    """
    buf = np.zeros(2, np.int64)
    t0 = _kin.now_ns(buf)
    s, d1, a1, lat, a2, a3, a4 = g[0], g[1], g[2], g[3], g[4], g[5], g[6]
    x, y, z = Tb[0, 3], Tb[1, 3], Tb[2, 3]
    th1, n1 = _first_joint(Tb, s, lat, crit)
    q = np.empty(4)
    T = np.empty((4, 4))
    nsol = 0
    ncand = 0
    den = 2.0 * a2 * a3
    for k in range(n1):
        t1 = th1[k]
        c1, s1 = math.cos(t1), math.sin(t1)
        psi = math.atan2(s * Tb[2, 0], c1 * Tb[0, 0] + s1 * Tb[1, 0])      # pitch -phi (eqs. 4, 26)
        u = c1 * x + s1 * y - a1 - a4 * math.cos(psi)                      # wrist point in the arm plane (31)
        v = s * (z - d1) - a4 * math.sin(psi)
        beta = (u * u + v * v - a2 * a2 - a3 * a3) / den                  # cos theta3 (31)
        if not (abs(beta) <= 1.0 + reach_tol):                            # also catches NaN
            continue
        if beta > 1.0:
            beta = 1.0
        elif beta < -1.0:
            beta = -1.0
        sb = math.sqrt(1.0 - beta * beta)
        for e in range(2):
            if (elbow == 1 and e == 1) or (elbow == 2 and e == 0):
                continue
            s3 = sb if e == 0 else -sb
            t3 = math.atan2(s3, beta)                                      # (30)
            t2 = math.atan2(v, u) - math.atan2(a3 * s3, a2 + a3 * beta)    # (31)
            t4 = psi - t2 - t3                                             # (32)
            ncand += 1
            q[0], q[1], q[2], q[3] = t1, t2, t3, t4
            for j in range(4):   # joint value nearest the start (revolute: 2 pi periodic)
                q[j] = q_start[j] + _wrap(q[j] - offs[j] - q_start[j])
            _kin.forward_pose(a, alpha, d, offs, prism, modified, base, tool, q, T)
            if not _kin.meets(crit, T_goal, T, tol_pos, tol_rot, tol_dq):
                continue
            if _is_new(sols, nsol, q, dedupe_tol):
                sols[nsol, :] = q
                nsol += 1
    info[0] = ncand
    return nsol, _nearest(sols, nsol, q_start), _kin.now_ns(buf) - t0


def _geometry_cached(prep: Prepared) -> Geometry:
    return prep.memo(("analytic_4dof", "geometry"), lambda: geometry(prep))


def run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: Analytic4DofSettings, seed: int) -> Raw:
    geo = _geometry_cached(prep)
    Tb = prep.bare_goal(T_goal)
    if geo.pre_inv is not None:
        Tb = geo.pre_inv @ Tb
    Tb = np.ascontiguousarray(Tb)
    q0 = np.where(np.isfinite(q_start), q_start, 0.0)
    sols = np.zeros((MAX_CAND, 4))
    info = np.zeros(1, np.int64)
    nsol, best, ns = solve_kernel(*prep.args, Tb, np.ascontiguousarray(T_goal), q0, geo.g, CRITERION_CODE[s.criterion],
                                  s.tol_pos, s.tol_rot, s.tol_dq, s.reach_tol, ELBOWS.index(s.elbow), s.dedupe_tol,
                                  sols, info)
    if best >= 0:
        q, code = sols[best].copy(), int(StopReason.SUCCESS)
    else:
        q, code = q0.copy(), int(StopReason.NO_SOLUTION)
    return Raw(q=q, code=code, iterations=0, solve_ns=int(ns), solutions=sols[:nsol].copy(),
               info={"candidates": int(info[0]), "solutions": int(nsol)})


register(Solver("analytic_4dof", "closed form of the 4-DOF arm (yaw + planar 3R): both elbows, FK-checked, "
                "nearest the start", "analytic", Analytic4DofSettings, run, applies_to=applies_to, source=SOURCE))
