"""A 6R arm whose every goal has a continuum of solutions: representatives, said so.

When axes 1, 2 and 3 meet in one point ``S`` (a spherical shoulder) and axes 4, 5 and 6 meet in one
point ``W`` (a spherical wrist), the wrist centre can only move on the sphere about ``S`` through
``W``: the arm has at most 5 independent motions. A goal whose wrist centre lies off that sphere is
unreachable; one on it is reached by a one-parameter family of joint vectors, the arm turning about
the line from ``S`` to the goal's wrist centre (the swivel angle φ). A 7R arm with its elbow held
(the KUKA iiwa with joint 4 fixed) is such an arm.

No finite solution set exists, so the solver returns representatives and says so
(``info["continuum"]``): for each of :data:`SWIVEL_SAMPLES` swivel angles the shoulder's rotation
is fixed, joints 1-3 and 4-6 follow by subproblems 2 and 1 (Paden 1985), up to 4 joint vectors per
angle; the chosen ``q`` is the representative nearest the start, its swivel angle refined by a
golden-section search on the wrapped joint distance. Every representative is FK-checked on the arm
(``verify_position``, ``verify_rotation``).

Geometry: ``T(q) = E_1(q_1) ... E_6(q_6) M`` (:mod:`pipeline.kinematics.geometry`). Rotations 4-6
fix ``W`` and 1-3 fix ``S``, so the goal's wrist centre is ``w = T_goal M⁻¹ W`` and
``w - S = R_1 R_2 R_3 (W - S)``; the wrist's rotation is ``R_4 R_5 R_6 = (R_1 R_2 R_3)ᵀ R_goal R_Mᵀ``.
"""

from __future__ import annotations

import math

import numpy as np

from pipeline.kinematics import geometry
from pipeline.kinematics.geometry import axis_rotation
from pipeline.solvers.kernels.kin import LIMIT_TOL, NO_SOLUTION, SUCCESS, TRACE_COLS
from pipeline.solvers.core import Prepared, Raw, nearest_rep, pose_errors
from pipeline.solvers.core.models import wrap_angles

FAMILY = "spherical_pair"
SWIVEL_SAMPLES = 8  # representatives: this many swivel angles, evenly spaced, up to 4 joint vectors each
GRID = 32  # swivel angles tried for the one nearest the start, before the golden-section refinement
GOLDEN_STEPS = 30
FINE_GRID = 720  # swivel angles tried where the coarse grid meets no reachable shoulder rotation
OUTSIDE = 1e6  # [rad²] added to the distance of a joint vector outside the limits (one within them is preferred)


def _cross(a, b) -> np.ndarray:
    """a × b of two 3-vectors (numpy's ``cross`` is several times slower on single vectors)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _sp1(p: np.ndarray, q: np.ndarray, k: np.ndarray) -> float:
    """Subproblem 1: the angle [rad] about unit ``k`` (through the origin) taking ``p`` towards ``q``."""
    pp, qq = p - (k @ p) * k, q - (k @ q) * k
    return math.atan2(k @ _cross(pp, qq), pp @ qq)


def _sp2(p: np.ndarray, q: np.ndarray, k1: np.ndarray, k2: np.ndarray) -> list[tuple[float, float]]:
    """Subproblem 2: every (θ1, θ2) [rad] with ``Rot(k1, θ1) Rot(k2, θ2) p = q`` (unit axes through the
    origin, not parallel); an empty list when none exists (beyond a rounding margin)."""
    c12 = float(k1 @ k2)
    den = c12 * c12 - 1.0
    a = (c12 * (k2 @ p) - k1 @ q) / den
    b = (c12 * (k1 @ q) - k2 @ p) / den
    x = _cross(k1, k2)
    g2 = (p @ p - a * a - b * b - 2.0 * a * b * c12) / (x @ x)
    if g2 < -1e-9 * max(p @ p, 1e-300):
        return []
    g = math.sqrt(max(g2, 0.0))
    out = []
    for s in ((1.0,) if g == 0.0 else (1.0, -1.0)):
        c = a * k1 + b * k2 + s * g * x
        out.append((_sp1(c, q, k1), _sp1(p, c, k2)))
    return out


def _euler(R: np.ndarray, h: np.ndarray) -> list[np.ndarray]:
    """Every (θ1, θ2, θ3) [rad] with ``Rot(h0, θ1) Rot(h1, θ2) Rot(h2, θ3) = R`` (``h`` (3, 3) unit axes
    through one point, consecutive ones not parallel)."""
    v = _cross(h[2], [1.0, 0.0, 0.0])
    if v @ v < 1e-6:
        v = _cross(h[2], [0.0, 1.0, 0.0])
    v /= np.linalg.norm(v)
    out = []
    for t1, t2 in _sp2(h[2], R @ h[2], h[0], h[1]):
        R3 = (axis_rotation(h[0], t1) @ axis_rotation(h[1], t2)).T @ R
        out.append(np.array([t1, t2, _sp1(v, R3 @ v, h[2])]))
    return out


class Continuum:
    """The arm's shoulder and wrist points and the solver of one goal (:func:`bind`).

    Parameters
    ----------
    prep : Prepared
        A 6R arm whose axes 1-3 and 4-6 each meet in a point (:func:`fits`).
    verify_position : float [working length unit]
    verify_rotation : float [rad]
        The FK test every representative passes.
    """

    def __init__(self, prep: Prepared, verify_position: float, verify_rotation: float):
        L = geometry.joint_lines(prep.model.chain)
        self.model, self.h, self.M = prep.model, L.h, L.M
        self.S = geometry.common_point(L.h, L.p, (0, 1, 2))[0]
        self.W = geometry.common_point(L.h, L.p, (3, 4, 5))[0]
        self.r = float(np.linalg.norm(self.W - self.S))
        self.u0 = (self.W - self.S) / self.r if self.r > 0 else np.array([0.0, 0.0, 1.0])
        self.Minv = np.linalg.inv(self.M)
        self.tol_p, self.tol_r = verify_position, verify_rotation
        self.lim = np.ascontiguousarray(prep.limits, dtype=float)
        self.prism = np.zeros(6, np.bool_)  # a continuum arm is 6R (:func:`fits`)

    def into_limits(self, q: np.ndarray, q0: np.ndarray) -> tuple[np.ndarray, bool]:
        """(``q`` with each joint moved by whole turns to its value within the limits nearest ``q0``
        (:func:`pipeline.solvers.core.nearest_rep`), True), or where a joint fits no turn (``q`` moved to lie
        within π of ``q0``, False) [rad]."""
        out = np.empty(len(q))
        if math.isfinite(nearest_rep(np.ascontiguousarray(q, dtype=float), q0, self.lim, self.prism, LIMIT_TOL, out)):
            return out, True
        return wrap_near(q, q0), False

    def wrist_centre(self, Tg: np.ndarray) -> np.ndarray:
        """The goal's wrist centre ``T_goal M⁻¹ W`` (3,) [length]."""
        return (Tg @ self.Minv @ np.append(self.W, 1.0))[:3]

    def off_sphere(self, Tg: np.ndarray) -> float:
        """How far [length] the goal's wrist centre lies from the sphere it must lie on."""
        return abs(float(np.linalg.norm(self.wrist_centre(Tg) - self.S)) - self.r)

    def frame(self, Tg: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(u, R_min, R_goal R_Mᵀ) of a goal: the unit direction from ``S`` to its wrist centre, the least
        rotation taking ``W``'s direction there, and the rotation joints 1-6 must make together."""
        d = self.wrist_centre(Tg) - self.S
        u = d / np.linalg.norm(d) if self.r > 0 else self.u0
        axis = _cross(self.u0, u)
        s, c = float(np.linalg.norm(axis)), float(self.u0 @ u)
        if s > 1e-12:
            Rmin = axis_rotation(axis / s, math.atan2(s, c))
        elif c > 0:
            Rmin = np.eye(3)
        else:  # opposite: a half turn about any axis normal to u0
            n = _cross(self.u0, [1.0, 0.0, 0.0])
            n = n if n @ n > 1e-6 else _cross(self.u0, [0.0, 1.0, 0.0])
            Rmin = axis_rotation(n / np.linalg.norm(n), math.pi)
        return u, Rmin, Tg[:3, :3] @ self.M[:3, :3].T

    def at(self, F: tuple, phi: float) -> list[np.ndarray]:
        """The joint vectors (6,) [rad] at swivel angle ``phi`` [rad] (up to 4) of a goal's :meth:`frame`
        ``F``, unchecked."""
        u, Rmin, Rall = F
        R123 = axis_rotation(u, phi) @ Rmin
        R456 = R123.T @ Rall
        return [np.concatenate([a, b]) for a in _euler(R123, self.h[:3]) for b in _euler(R456, self.h[3:])]

    def swivel_of(self, F: tuple, q: np.ndarray) -> float:
        """The swivel angle [rad] whose shoulder rotation is nearest ``q``'s ``R_1 R_2 R_3`` (about the
        goal's direction ``u`` of :meth:`frame` ``F``)."""
        u, Rmin, _ = F
        R = axis_rotation(self.h[0], q[0]) @ axis_rotation(self.h[1], q[1]) @ axis_rotation(self.h[2], q[2])
        v = _cross(self.u0, [1.0, 0.0, 0.0])
        v = v if v @ v > 1e-6 else _cross(self.u0, [0.0, 1.0, 0.0])
        return _sp1(Rmin @ v, R @ v, u)

    def valid(self, q: np.ndarray, Tg: np.ndarray) -> bool:
        """``q`` reaches ``Tg`` within the FK test (:func:`pipeline.solvers.core.pose_errors`)."""
        dp, ang, _ = pose_errors(self.model, Tg, q)
        return dp <= self.tol_p and ang <= self.tol_r

    def nearest(self, F: tuple, q0: np.ndarray) -> tuple[np.ndarray | None, float]:
        """The joint vector nearest ``q0`` over the swivel angle (of a goal's :meth:`frame` ``F``), and its
        angle: each joint moved by whole turns into its limits where it fits (else within π of ``q0``), a
        vector within the limits preferred, then the least sum of squared joint distances [rad²]."""
        def best(phi):
            qs = [self.into_limits(q, q0) for q in self.at(F, phi)]
            if not qs:
                return None, math.inf
            d = [float(np.sum((q - q0) ** 2)) + (0.0 if inside else OUTSIDE) for q, inside in qs]
            k = int(np.argmin(d))
            return qs[k][0], d[k]

        # the grid and the start's own swivel angle (exact when the start is a solution)
        step = 2 * math.pi / GRID
        grid = np.append(step * np.arange(GRID), self.swivel_of(F, q0))
        dist = [best(p)[1] for p in grid]
        k = int(np.argmin(dist))
        if not math.isfinite(dist[k]):  # the feasible swivel angles fall between the grid's: a fine grid
            step = 2 * math.pi / FINE_GRID
            grid = step * np.arange(FINE_GRID)
            dist = [best(p)[1] for p in grid]
            k = int(np.argmin(dist))
            if not math.isfinite(dist[k]):
                return None, math.nan
        lo, hi = grid[k] - step, grid[k] + step
        g = (math.sqrt(5.0) - 1.0) / 2.0
        a, b = hi - g * (hi - lo), lo + g * (hi - lo)
        fa, fb = best(a)[1], best(b)[1]
        for _ in range(GOLDEN_STEPS):
            if fa <= fb:
                hi, b, fb = b, a, fa
                a = hi - g * (hi - lo)
                fa = best(a)[1]
            else:
                lo, a, fa = a, b, fb
                b = lo + g * (hi - lo)
                fb = best(b)[1]
        phi = min((grid[k], dist[k]), (a, fa), (b, fb), key=lambda t: t[1])[0]
        return best(phi)[0], float(phi)

    def samples(self, F: tuple) -> np.ndarray:
        """:data:`SWIVEL_SAMPLES` swivel angles [rad] spread over those where joints 1-3 reach the shoulder
        rotation (every angle for orthogonal-enough axes; an interval or two for others), from a grid of
        :data:`FINE_GRID`."""
        grid = 2 * math.pi * np.arange(FINE_GRID) / FINE_GRID
        ok = grid if self._all_feasible(F) else np.array([p for p in grid if self.at(F, float(p))])
        if len(ok) <= SWIVEL_SAMPLES:
            return ok
        return ok[np.linspace(0, len(ok) - 1, SWIVEL_SAMPLES).round().astype(int)]

    def _all_feasible(self, F: tuple) -> bool:
        return all(self.at(F, float(p)) for p in 2 * math.pi * np.arange(GRID) / GRID)

    def solve(self, Tg: np.ndarray, q0: np.ndarray, max_solutions: int) -> tuple[np.ndarray | None, np.ndarray]:
        """(q nearest ``q0`` or None, representatives (m, 6) [rad], the nearest first), each FK-valid;
        none when the goal's wrist centre is off the sphere by more than ``verify_position``."""
        if self.off_sphere(Tg) > self.tol_p:
            return None, np.empty((0, 6))
        F = self.frame(Tg)
        q, _ = self.nearest(F, q0)
        reps = [] if q is None or not self.valid(q, Tg) else [q]
        for phi in self.samples(F):
            for r in self.at(F, float(phi)):
                r = self.into_limits(r, q0)[0]
                if len(reps) < max_solutions and self.valid(r, Tg) and not any(
                        np.max(np.abs(wrap_angles(r - x))) < 1e-9 for x in reps):
                    reps.append(r)
        if not reps:
            return None, np.empty((0, 6))
        return reps[0], np.array(reps)


def wrap_near(q: np.ndarray, q0: np.ndarray) -> np.ndarray:
    """``q`` moved by whole turns to lie within π of ``q0`` joint by joint [rad]."""
    return q0 + wrap_angles(q - q0)


def fits(lines: geometry.Lines, tol: float) -> bool:
    """A 6R arm whose axes 1-3 and 4-6 each meet in one point (every goal a continuum or unreachable)."""
    return lines.n == 6 and not lines.prismatic.any() and geometry.spherical_pair(lines, tol)


MESSAGE = ("a one-parameter continuum of solutions (axes 1-3 and 4-6 each meet in a point: the arm turns about the "
           "line through them); {m} representatives at {k} swivel angles, q the one nearest the start")


def bind(prep: Prepared, s, info_of):
    """``run1(T_goal, q_start, seed) -> Raw`` of a continuum arm (module docstring): ``info_of(m, tried,
    doc, family)`` the calling solver's info, to which ``continuum`` (True) and the message are added."""
    from pipeline.solvers.core.timing import clock_ns

    c = Continuum(prep, s.verify_position, s.verify_rotation)

    def run1(T_goal: np.ndarray, q_start: np.ndarray, seed: int) -> Raw:
        t0 = clock_ns()
        Tg, q0 = np.asarray(T_goal, float), np.ascontiguousarray(q_start, dtype=float)
        q, reps = c.solve(Tg, q0, s.max_solutions)
        ns = clock_ns() - t0
        m = len(reps)
        trace = np.full((2, TRACE_COLS), np.nan)
        info = info_of(m, m, math.nan, FAMILY + " (continuum)")
        info.update(continuum=True, message=MESSAGE.format(m=m, k=SWIVEL_SAMPLES) if m else
                    f"the goal's wrist centre is {c.off_sphere(Tg):.3g} off the sphere every solution's lies on "
                    "(axes 1-3 and 4-6 each meet in a point): unreachable")
        return Raw(q=q0.copy() if q is None else q, code=SUCCESS if m else NO_SOLUTION, iterations=1, solve_ns=ns,
                   trace=trace, solutions=reps, info=info)

    return run1
