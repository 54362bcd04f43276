"""The nearest arm of a closed-form family to an arm that misses it by a little (rounded angles in a file).

A URDF that types its right angles as ``1.5708`` and ``3.1416`` has wrist axes that miss one common point
by a fraction of a micrometre: under the strict test of :func:`pipeline.kinematics.geometry.classify`
(``tol`` 1e-9) it fits no family, or a slower one, although it is a spherical-wrist arm in all but the
last digits. :func:`snap` finds the family under a looser tolerance ``near_tol`` and moves the joint
lines the family relates onto an exact instance of it:

- lines that must meet are moved parallel to themselves through one point (three wrist lines: their
  nearest common point, :func:`~pipeline.kinematics.geometry.common_point`; two lines: the midpoint of
  their common normal);
- lines that must be parallel take the first one's direction (sign kept), each turned about its own point.

The other lines and the tool pose stay as they are. The result says how far each moved: the largest
distance a line was moved [length] and the largest angle it was turned [rad]. The snapped arm is only a
source of candidates: its solver's candidates are polished on the real arm and checked there
(:mod:`pipeline.solvers.closed_form.near`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pipeline.kinematics.chain import Chain
from pipeline.kinematics.folding import lines_chain
from pipeline.kinematics.geometry import (CONTINUUM, FAMILIES, Decomposition, Lines, classify, common_point,
                                          joint_lines, line_relation, reverse_lines)

NEAR_TOL = 1e-3  # default: a right angle typed 1.571 (2e-4 rad off) or 1.5708 (4e-6), a length rounded to
#                   0.1 mm on a 1 m arm; far below any offset an arm is built with (a wrist offset of 1 % of the reach)
# every closed form of up to 8 solutions first, then the one-dimensional search, then none; never a continuum
RANK = {**{f: 1 if f == "two_intersecting_search" else 0 for f in FAMILIES}, None: 2, CONTINUUM: 3}


@dataclass(frozen=True)
class Snapped:
    """An arm moved onto the nearest exact geometry of a family.

    Attributes
    ----------
    chain : Chain                 the exact arm (general form, same joint values as the real arm)
    lines : Lines                 its joint lines
    decomposition : Decomposition its family under the strict tolerance
    moved : float                 the largest distance a joint line was moved [length]
    turned : float                the largest angle a joint line was turned [rad]
    """

    chain: Chain
    lines: Lines
    decomposition: Decomposition
    moved: float
    turned: float

    def describe(self, unit: str) -> str:
        """One line: the family and how far the arm is from it."""
        d = f"{self.moved * 1000:.3g} mm" if unit == "m" else f"{self.moved:.3g} {unit}"
        return (f"near {self.decomposition.family}: the joint lines moved by at most {d} and turned by at most "
                f"{self.turned:.3g} rad onto it")


def _meet(L: Lines, idx, h, p) -> float:
    """Lines ``idx`` moved through one point (their nearest common point, or for two lines the midpoint of
    their common normal): the largest distance moved."""
    if len(idx) == 2:
        _, _, x = line_relation(L.h[idx[0]], L.p[idx[0]], L.h[idx[1]], L.p[idx[1]])
        if x is None:
            return math.inf
    else:
        x, _ = common_point(L.h, L.p, idx)
    worst = 0.0
    for i in idx:
        r = x - p[i]
        off = r - (r @ h[i]) * h[i]
        worst = max(worst, float(np.linalg.norm(off)))
        p[i] = p[i] + off
    return worst


def _parallel(L: Lines, idx, h) -> float:
    """Lines ``idx[1:]`` given the direction of line ``idx[0]`` (sign kept): the largest angle turned."""
    ref = L.h[idx[0]]
    worst = 0.0
    for i in idx[1:]:
        new = ref if ref @ h[i] >= 0 else -ref
        worst = max(worst, math.acos(min(1.0, abs(float(new @ h[i])))))
        h[i] = new
    return worst


def _exact(L: Lines, d: Decomposition) -> tuple[Lines, float, float]:
    """The lines of the (possibly reversed) 6R chain ``L`` moved onto family ``d``: (lines, moved, turned)."""
    h, p = L.h.copy(), L.p.copy()
    moved = turned = 0.0
    if d.family in ("spherical_wrist", "spherical_wrist_3r"):  # the wrist's three lines meet
        moved = _meet(L, (3, 4, 5), h, p)
    elif d.family == "three_parallel":
        turned = _parallel(L, (1, 2, 3), h)
        moved = _meet(L, (4, 5), h, p)
    elif d.family == "three_parallel_offset":  # axes 2-4 parallel, the other end's pair skew
        turned = _parallel(L, (1, 2, 3), h)
    elif d.family == "two_intersecting_search":
        moved = _meet(L, (3, 4) if d.searched == 6 else (4, 5), h, p)
    case = d.position_case
    if case in (1, 2):
        moved = max(moved, _meet(L, (0, 1) if case == 1 else (1, 2), h, p))
    elif case in (3, 4):
        turned = max(turned, _parallel(L, (0, 1) if case == 3 else (1, 2), h))
    return Lines(h, p, L.M, L.prismatic, L.reach), moved, turned


def snap(chain: Chain, tol: float, near_tol: float) -> Snapped | None:
    """The nearest exact arm of a better family than ``chain``'s own, or None.

    Parameters
    ----------
    chain : Chain
        A 6R arm.
    tol : float
        The strict relative tolerance of the families (:func:`~pipeline.kinematics.geometry.classify`).
    near_tol : float
        How far the arm may be from a family: lines that meet within ``near_tol × reach`` and are parallel
        within ``near_tol`` rad count as meeting or parallel here.

    Returns
    -------
    Snapped or None
        None where the arm is not 6R revolute, where ``near_tol`` finds no family ranked above the strict
        one (:data:`RANK`: a closed form of up to 8 solutions, then the search, then none), or where the
        moved lines do not pass the strict test.
    """
    if chain.n != 6 or np.asarray(chain.prismatic).any() or near_tol <= tol:
        return None
    strict = classify(chain, tol)
    near = classify(chain, near_tol)
    if RANK[near.family] >= RANK[strict.family]:
        return None
    L = joint_lines(chain)
    Lr = reverse_lines(L) if near.reversed else L
    exact, moved, turned = _exact(Lr, near)
    if near.reversed:
        exact = reverse_lines(exact)
    out = lines_chain(exact)
    d = classify(out, tol)
    if d.family != near.family:
        return None
    return Snapped(out, exact, d, moved, turned)
