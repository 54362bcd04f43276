"""The joint axes of a serial arm as lines, and the closed-form decomposition they allow.

Whatever the robot file's form (standard or modified DH, the general URDF-style form, base and
tool, any length unit), the arm at its zero pose is a list of joint lines: a unit direction
``h_i`` and a point ``p_i`` per joint, in the world frame, and the tool pose ``M = T(0)``. In this
product-of-exponentials form ``T(q) = E_1(q_1) ... E_n(q_n) M`` with ``E_i`` the rotation by ``q_i``
about line i; the file's own joint angles are kept (offsets are folded into the lines and ``M``).

Which lines meet or are parallel decides the decomposition into the Paden-Kahan subproblems
(Paden 1985; Kahan's subproblems; their extensions in IK-Geo, Elias & Wen 2022, and EAIK,
Ostermeier, Külz & Althoff 2025). The families this project solves, for 6R arms
(:mod:`pipeline.solvers.closed_form.analytic`):

``spherical_wrist``
    axes 4, 5 and 6 meet in one point (the wrist centre); the first three joints place it in
    closed form when axes 1 and 2 meet, 2 and 3 meet, 1 and 2 are parallel or 2 and 3 are
    parallel (the "position case"); the wrist's orientation by subproblems 2 and 1. Up to 8
    solutions. Also found reversed: axes 1, 2 and 3 meet (a spherical shoulder), the chain
    read from the tool back (``reversed``).
``three_parallel``
    axes 2, 3 and 4 are parallel and axes 5 and 6 meet (the UR family), or reversed (axes 3, 4,
    5 parallel and 1, 2 meet). Up to 8 solutions.
``spherical_wrist_3r``
    axes 4, 5 and 6 meet and joints 1-3 are a general positioner (axes 1-2 and 2-3 neither meet nor
    are parallel): the wrist centre placed by a quartic in joint 1 (IK-Geo's subproblem 5 problem),
    the wrist as above. Up to 8 solutions. Also reversed.
``three_parallel_offset``
    axes 2, 3 and 4 are parallel and axes 5 and 6 are skew: joints 1 and 5 by a quartic, then 6 and
    the planar joints 2-4 by subproblems. Up to 8 solutions. Also reversed (axes 3, 4, 5 parallel,
    1 and 2 skew).
``spherical_pair``
    axes 1, 2 and 3 meet in one point and axes 4, 5 and 6 in another: the wrist centre moves on a
    sphere, the arm has at most 5 independent motions, and a reachable goal has a continuum of
    solutions (:mod:`pipeline.solvers.closed_form.continuum` returns representatives and says so).
    Only a 6R arm (a 7R arm with its elbow held, e.g. the KUKA iiwa).
``two_intersecting_search``
    axes 5 and 6 meet and the first three joints have a position case, but no closed form:
    a one-dimensional search over joint 4 whose residual is the wrist's orientation condition
    (offset-wrist arms: UFactory xArm6, Kinova Gen3 lite, Fanuc CRX). Up to 16 solutions.

A 7R arm is solved through a free joint: held at a value, the other six joints must form one of
the families above (for every value of it, which holds when the family's relations do not
involve the lines on both sides of the free joint; checked at two values).

Tolerances are relative: two lines meet when their closest distance is at most
``tol × reach`` (``reach`` = the sum of the distances between consecutive joint points and to
the tool, the arm's length scale), and are parallel when the angle between them is at most
``tol`` rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pipeline.kinematics.chain import Chain

DEFAULT_TOL = 1e-9
FAMILIES = ("spherical_wrist", "three_parallel", "spherical_wrist_3r", "three_parallel_offset",
            "two_intersecting_search")
# axes 1-3 and 4-6 each meet in a point: no finite solution set (representatives of the continuum); never a
# 7R arm's family through a swept joint
CONTINUUM = "spherical_pair"
# the quartic families (spherical_wrist_3r, three_parallel_offset) need their skew pairs clearly skew: the
# linear solve inside them is conditioned by the pair's closest distance / reach and its angle [rad]
SKEW_MIN = 1e-5
POSITION_CASES = ("1-2 meet", "2-3 meet", "1-2 parallel", "2-3 parallel")  # codes 1..4 (0 = none)


@dataclass(frozen=True)
class Lines:
    """Joint lines at the zero pose, world frame.

    Attributes
    ----------
    h : ndarray, shape (n, 3)     unit joint directions (revolute: rotation axis)
    p : ndarray, shape (n, 3)     a point on each line [length]
    M : ndarray, shape (4, 4)     the tool pose at q = 0 (base and tool included) [length]
    prismatic : ndarray of bool, shape (n,)
    reach : float                 the arm's length scale [length]
    """

    h: np.ndarray
    p: np.ndarray
    M: np.ndarray
    prismatic: np.ndarray
    reach: float

    @property
    def n(self) -> int:
        return self.h.shape[0]


def joint_lines(chain: Chain) -> Lines:
    """The joint lines of ``chain`` at q = 0 (exact for every file form: :meth:`Chain.as_general`)."""
    origins, axes, tool = chain.as_general()
    T = np.array(chain.base, dtype=float)
    n = chain.n
    h, p = np.zeros((n, 3)), np.zeros((n, 3))
    for i in range(n):
        T = T @ origins[i]
        h[i] = T[:3, :3] @ axes[i]
        h[i] /= np.linalg.norm(h[i])
        p[i] = T[:3, 3]
    M = T @ tool
    pts = np.vstack([chain.base[:3, 3][None], p, M[:3, 3][None]])
    reach = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
    return Lines(h, p, M, np.asarray(chain.prismatic, dtype=bool), reach if reach > 0 else 1.0)


def line_relation(h1, p1, h2, p2) -> tuple[float, float, np.ndarray | None]:
    """Angle between two lines, their closest distance and the midpoint of their common normal.

    Parameters
    ----------
    h1, h2 : array_like, shape (3,) [1]
        Unit directions.
    p1, p2 : array_like, shape (3,) [length]
        A point of each line.

    Returns
    -------
    angle : float
        [rad], in [0, pi/2].
    distance : float
        [length].
    midpoint : ndarray, shape (3,), or None
        [length]; None when the lines are parallel.
    """
    h1, h2 = np.asarray(h1, float), np.asarray(h2, float)
    c = np.cross(h1, h2)
    s = float(np.linalg.norm(c))
    ang = math.atan2(s, abs(float(h1 @ h2)))
    r = np.asarray(p2, float) - np.asarray(p1, float)
    if s < 1e-12:
        return ang, float(np.linalg.norm(r - (r @ h1) * h1)), None
    dist = abs(float(r @ c)) / s
    # closest points p1 + t1 h1, p2 + t2 h2
    b = float(h1 @ h2)
    d1, d2 = float(h1 @ r), float(h2 @ r)
    den = s * s
    t1 = (d1 - b * d2) / den
    t2 = (b * d1 - d2) / den
    mid = 0.5 * (np.asarray(p1, float) + t1 * h1 + np.asarray(p2, float) + t2 * h2)
    return ang, dist, mid


def common_point(h, p, idx) -> tuple[np.ndarray, float]:
    """The point nearest (least squares) to the lines ``idx`` and its largest distance to them.

    Parameters
    ----------
    h : ndarray, shape (n, 3) [1]
        Unit line directions.
    p : ndarray, shape (n, 3) [length]
        A point of each line.
    idx : sequence of int
        The lines to use.

    Returns
    -------
    x : ndarray, shape (3,) [length]
    worst : float
        [length].
    """
    A = np.zeros((3, 3))
    b = np.zeros(3)
    for i in idx:
        P = np.eye(3) - np.outer(h[i], h[i])
        A += P
        b += P @ p[i]
    x = np.linalg.lstsq(A, b, rcond=None)[0]
    worst = max(float(np.linalg.norm((np.eye(3) - np.outer(h[i], h[i])) @ (x - p[i]))) for i in idx)
    return x, worst


@dataclass(frozen=True)
class Pair:
    """How two joint lines relate (1-based joint numbers)."""

    i: int
    j: int
    angle: float      # rad
    distance: float   # length
    meet: bool
    parallel: bool


@dataclass(frozen=True)
class Decomposition:
    """The closed-form family of an arm (or why there is none).

    Attributes
    ----------
    family : str or None          one of :data:`FAMILIES`, None when no family fits
    reversed : bool               the family holds on the chain read from the tool back
    position_case : int           0 or 1..4 (:data:`POSITION_CASES`) of the (possibly reversed) chain
    free_joint : int or None      7R arms: the joint (0-based) swept as the free parameter
    searched : int                the search family's searched joint of the (possibly reversed)
                                  chain: 4 (axes 5-6 meet) or 6 (axes 4-5 meet); 0 otherwise
    reason : str                  one line: the evidence for the family, or the refusal
    evidence : list[str]          one line per consecutive pair and per triple (for ``robot``)
    """

    family: str | None
    reversed: bool = False
    position_case: int = 0
    free_joint: int | None = None
    reason: str = ""
    evidence: list = field(default_factory=list)
    searched: int = 0


def pairs(lines: Lines, tol: float = DEFAULT_TOL) -> dict:
    """Every pair of joint lines -> :class:`Pair` (keys (i, j), 0-based, i < j)."""
    out = {}
    for i in range(lines.n):
        for j in range(i + 1, lines.n):
            ang, dist, _ = line_relation(lines.h[i], lines.p[i], lines.h[j], lines.p[j])
            par = ang <= tol
            meet = (not par) and dist <= tol * lines.reach
            out[(i, j)] = Pair(i + 1, j + 1, ang, dist, meet, par)
    return out


def _meet3(lines: Lines, idx, tol) -> tuple[bool, float]:
    x, worst = common_point(lines.h, lines.p, idx)
    par = all(line_relation(lines.h[a], lines.p[a], lines.h[b], lines.p[b])[0] <= tol
              for a, b in ((idx[0], idx[1]), (idx[1], idx[2])))
    return (not par) and worst <= tol * lines.reach, worst


def _position_case(pr: dict) -> int:
    """Position case of joints 1-3 (0-based pairs) or 0."""
    if pr[(0, 1)].meet:
        return 1
    if pr[(1, 2)].meet:
        return 2
    if pr[(0, 1)].parallel and not pr[(1, 2)].parallel:
        return 3
    if pr[(1, 2)].parallel and not pr[(0, 1)].parallel:
        return 4
    return 0


def reverse_lines(lines: Lines) -> Lines:
    """The chain read from the tool back: ``T⁻¹ = E'_1(−q_n) ... E'_n(−q_1) M⁻¹`` with the lines
    moved by ``M⁻¹`` (see :func:`pipeline.solvers.closed_form.analytic`'s packing)."""
    Mi = np.linalg.inv(lines.M)
    R, t = Mi[:3, :3], Mi[:3, 3]
    h = (lines.h[::-1] @ R.T).copy()
    p = (lines.p[::-1] @ R.T + t).copy()
    return Lines(h, p, Mi, lines.prismatic[::-1].copy(), lines.reach)


def _fmt_len(x: float, unit: str) -> str:
    if unit == "m":
        return f"{x * 1000:.4g} mm"
    return f"{x:.4g} {unit}"


def _skew(p: Pair, lines: Lines) -> bool:
    """Two lines clearly neither meeting nor parallel (:data:`SKEW_MIN`)."""
    return p.angle > SKEW_MIN and p.distance > SKEW_MIN * lines.reach


def spherical_pair(lines: Lines, tol: float) -> bool:
    """Axes 1-3 meet in one point and axes 4-6 in another (a 6R chain): the wrist centre moves on a sphere
    about the shoulder point, so every goal is unreachable or reached by a continuum of joint vectors."""
    return _meet3(lines, (0, 1, 2), tol)[0] and _meet3(lines, (3, 4, 5), tol)[0]


def _classify6(lines: Lines, tol: float) -> tuple[str | None, bool, int, int]:
    """(family, reversed, position case, searched joint 4/6 or 0) of a 6R chain, or (None, ...)."""
    if spherical_pair(lines, tol):
        return CONTINUUM, False, 0, 0
    for rev in (False, True):
        L = reverse_lines(lines) if rev else lines
        pr = pairs(L, tol)
        case = _position_case(pr)
        if _meet3(L, (3, 4, 5), tol)[0] and case:
            return "spherical_wrist", rev, case, 0
        if (pr[(1, 2)].parallel and pr[(2, 3)].parallel and pr[(4, 5)].meet
                and not pr[(0, 1)].parallel):
            return "three_parallel", rev, 0, 0
    for rev in (False, True):  # the quartic families (pipeline.solvers.closed_form.family_gen3r)
        L = reverse_lines(lines) if rev else lines
        pr = pairs(L, tol)
        if _meet3(L, (3, 4, 5), tol)[0] and _skew(pr[(0, 1)], L) and _skew(pr[(1, 2)], L):
            return "spherical_wrist_3r", rev, 0, 0
        if (pr[(1, 2)].parallel and pr[(2, 3)].parallel and _skew(pr[(4, 5)], L) and pr[(0, 1)].angle > SKEW_MIN
                and pr[(1, 4)].angle > SKEW_MIN):
            return "three_parallel_offset", rev, 0, 0
    # one-dimensional search: the best-conditioned variant first (a position case whose first
    # subproblem does not move the target: 1-2 meet, 2-3 parallel, 1-2 parallel; then 2-3 meet)
    found = []
    for rev in (False, True):
        L = reverse_lines(lines) if rev else lines
        pr = pairs(L, tol)
        case = _position_case(pr)
        if not case:
            continue
        for searched, pair in ((6, (3, 4)), (4, (4, 5))):
            if pr[pair].meet:
                found.append(((case == 2), rev, searched != 6, case, searched))
    if found:
        _, rev, _, case, searched = min(found)
        return "two_intersecting_search", rev, case, searched
    return None, False, 0, 0


def fix_joint(lines: Lines, k: int, value: float) -> Lines:
    """The (n−1)-joint chain with joint ``k`` (0-based) held at ``value`` [rad]: the lines after
    it and ``M`` moved by the rotation about line k."""
    R = axis_rotation(lines.h[k], value)
    t = lines.p[k] - R @ lines.p[k]
    keep = [i for i in range(lines.n) if i != k]
    h = lines.h.copy()
    p = lines.p.copy()
    h[k + 1:] = lines.h[k + 1:] @ R.T
    p[k + 1:] = lines.p[k + 1:] @ R.T + t
    E = np.eye(4)
    E[:3, :3], E[:3, 3] = R, t
    return Lines(h[keep], p[keep], E @ lines.M, lines.prismatic[keep], lines.reach)


def axis_rotation(h, angle: float) -> np.ndarray:
    """Rotation matrix by ``angle`` about the unit vector ``h`` (Rodrigues).

    Parameters
    ----------
    h : array_like, shape (3,) [1]
        Unit rotation axis.
    angle : float
        [rad].

    Returns
    -------
    R : ndarray, shape (3, 3)
    """
    h = np.asarray(h, float)
    K = np.array([[0, -h[2], h[1]], [h[2], 0, -h[0]], [-h[1], h[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * (K @ K)


def evidence(lines: Lines, tol: float, unit: str) -> list[str]:
    """One line per consecutive pair and per consecutive triple: angle, closest distance, verdict."""
    out = []
    pr = pairs(lines, tol)
    for i in range(lines.n - 1):
        p = pr[(i, i + 1)]
        verdict = "parallel" if p.parallel else ("meet" if p.meet else "skew")
        out.append(f"axes {p.i} and {p.j}: angle {math.degrees(p.angle):.4g} deg, closest distance "
                   f"{_fmt_len(p.distance, unit)} ({verdict})")
    for i in range(lines.n - 2):
        ok, worst = _meet3(lines, (i, i + 1, i + 2), tol)
        out.append(f"axes {i + 1}, {i + 2} and {i + 3}: {'meet in one point' if ok else 'do not meet in one point'}"
                   f" (farthest line {_fmt_len(worst, unit)} from their nearest common point)")
    return out


def _pair_text(p: Pair, unit: str) -> str:
    if p.parallel:
        return f"axes {p.i} and {p.j} are parallel ({_fmt_len(p.distance, unit)} apart)"
    if p.meet:
        return f"axes {p.i} and {p.j} meet"
    return f"axes {p.i} and {p.j} do not meet (closest distance {_fmt_len(p.distance, unit)})"


def _refusal6(lines: Lines, tol: float, unit: str) -> str:
    ok, worst = _meet3(lines, (3, 4, 5), tol)
    pr = pairs(lines, tol)
    wrist = ("axes 4, 5 and 6 meet" if ok else
             f"axes 4, 5 and 6 do not meet in one point (the farthest is {_fmt_len(worst, unit)} from their nearest "
             f"common point)")
    for i in range(3):
        if all(pr[(k, k + 1)].parallel for k in range(i, i + 3)):
            return (f"axes {i + 1} to {i + 4} are parallel: the arm has at most 5 independent motions (the twists of "
                    "four parallel axes span 3 dimensions), so no goal has a finite set of solutions")
    return (f"no closed-form family fits: {wrist}; {_pair_text(pr[(3, 4)], unit)}; {_pair_text(pr[(4, 5)], unit)}; "
            f"{_pair_text(pr[(0, 1)], unit)}; {_pair_text(pr[(1, 2)], unit)}; axes 2, 3, 4 are "
            f"{'' if pr[(1, 2)].parallel and pr[(2, 3)].parallel else 'not '}all parallel (nor does any family "
            f"fit the chain read from the tool back)")

def classify(chain: Chain, tol: float = DEFAULT_TOL, unit: str = "m", free_order=None) -> Decomposition:
    """The decomposition family of ``chain`` (6R, or 7R through a free joint).

    Parameters
    ----------
    chain : Chain
    tol : float                 relative tolerance (see the module docstring)
    unit : str                  the chain's length unit (for the evidence text)
    free_order : sequence of int, optional
        7R arms: the joints (0-based) tried as the free parameter, in order (default: every
        joint, the middle one last: 2, 4, 1, 5, 0, 6, 3). The middle joint of an anthropomorphic 7R
        arm is its elbow, which sets the shoulder-wrist distance that the goal all but fixes: swept,
        it finds solutions only in a narrow band of its values, far along the self-motion from a
        seed (Franka Panda warm starts, start within 0.3 rad of the goal: median 0.56 rad from the
        seed, 26 % beyond 1 rad, with joint 4 free; 0.45 rad and 8 % with joint 7 free, at the same
        speed); any other joint moves the arm along its self-motion smoothly.
    """
    lines = joint_lines(chain)
    ev = evidence(lines, tol, unit)
    n = lines.n
    if lines.prismatic.any():
        pj = [str(i + 1) for i in np.flatnonzero(lines.prismatic)]
        which = f"joint {pj[0]} is" if len(pj) == 1 else f"joints {', '.join(pj)} are"
        return Decomposition(None, reason=f"no closed form here: {which} prismatic (the closed forms take 6 or 7 "
                             "revolute joints)", evidence=ev)
    if n == 6:
        fam, rev, case, searched = _classify6(lines, tol)
        if fam is None:
            return Decomposition(None, reason=_refusal6(lines, tol, unit), evidence=ev)
        return Decomposition(fam, rev, case, None, _describe(fam, rev, case, searched), ev, searched)
    if n == 7:
        order = list(free_order) if free_order is not None else [2, 4, 1, 5, 0, 6, 3]
        found = {}
        for k in order:
            got = [_classify6(fix_joint(lines, k, v), tol) for v in (0.0, 1.0)]
            if got[0][0] is not None and got[0] == got[1]:
                found.setdefault(got[0][0], (k, got[0]))
        for fam in FAMILIES:  # a closed form per value of the free joint before a search per value
            if fam in found:
                k, (fam, rev, case, searched) = found[fam]
                return Decomposition(fam, rev, case, k,
                                     f"joint {k + 1} swept as the free parameter; the other six: "
                                     + _describe(fam, rev, case, searched, k), ev, searched)
        return Decomposition(None, reason="no closed-form family fits any six of the seven joints with the "
                             "seventh held (tried each joint as the free parameter)", evidence=ev)
    return Decomposition(None, reason=f"no closed form here: the arm has {n} joints (the closed forms take "
                         "6 revolute joints, or 7 through a free joint)", evidence=ev)


def _describe(fam: str, rev: bool, case: int, searched: int = 0, free: int | None = None) -> str:
    """One line naming the family in the joint numbering of the robot file (for a 7R arm, the six
    joints other than ``free``, 0-based)."""
    def j(i):  # joint i (1-based) of the (possibly reversed) six -> the file's numbering
        k = 7 - i if rev else i
        return k + 1 if free is not None and k - 1 >= free else k

    def axes(*idx):
        v = sorted(j(i) for i in idx)
        return ", ".join(str(x) for x in v[:-1]) + f" and {v[-1]}"

    if fam == CONTINUUM:
        return (f"{fam}: axes {axes(1, 2, 3)} meet and axes {axes(4, 5, 6)} meet: every reachable goal has a "
                "one-parameter continuum of solutions (the arm turns about the line through the two points); "
                "representatives are returned")
    if fam == "spherical_wrist":
        trip = f"axes {axes(4, 5, 6)} meet (spherical {'shoulder' if rev else 'wrist'})"
    elif fam == "three_parallel":
        trip = f"axes {axes(2, 3, 4)} parallel and axes {axes(5, 6)} meet"
    elif fam == "spherical_wrist_3r":
        return (f"{fam}: axes {axes(4, 5, 6)} meet (spherical {'shoulder' if rev else 'wrist'}); axes "
                f"{axes(1, 2, 3)} a general positioner (neither meeting nor parallel pairwise), the point placed "
                "by a quartic")
    elif fam == "three_parallel_offset":
        return (f"{fam}: axes {axes(2, 3, 4)} parallel; axes {axes(5, 6)} skew (joints "
                f"{j(1)} and {j(5)} by a quartic)")
    else:
        a, b = (4, 5) if searched == 6 else (5, 6)
        trip = f"axes {axes(a, b)} meet; one-dimensional search over joint {j(searched)}"
    if not case:
        return f"{fam}: {trip}"
    x, y = {1: (1, 2), 2: (2, 3), 3: (1, 2), 4: (2, 3)}[case]
    rel = "meet" if case in (1, 2) else "are parallel"
    return f"{fam}: {trip}; axes {axes(x, y)} {rel} (the point they carry placed in closed form)"

def report(chain: Chain, tol: float = DEFAULT_TOL, unit: str = "m") -> str:
    """The family and its evidence as text (the ``robot`` verb's closed-form section)."""
    d = classify(chain, tol, unit)
    lines = joint_lines(chain)
    head = (f"CLOSED-FORM FAMILY (joint axes at q = 0; meet within {tol:g} x reach = "
            f"{_fmt_len(tol * lines.reach, unit)}, parallel within {tol:g} rad)")
    verdict = d.reason if d.family else f"none: {d.reason}"
    return "\n".join([head, verdict, *d.evidence]) + "\n"
