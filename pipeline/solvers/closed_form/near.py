"""``analytic`` on an arm near a family (:mod:`pipeline.kinematics.nearfamily`): the family's closed form on
the nearest exact arm gives candidates, Newton steps on the real arm polish them, the real arm's forward
kinematics checks them; the real arm's own path (what ``analytic`` does with ``near_tol`` 0: the general
elimination or a search) runs beside it and its solutions join the set.

Each candidate of the exact arm lies within about the snap distance (``near_tol`` × reach, ``near_tol``
rad) of a solution of the real arm; :data:`POLISH_STEPS` Newton steps on the real joint lines
(:func:`~pipeline.solvers.closed_form.general6r_model.newton_polish`: the spatial twist error, the
geometric Jacobian) take it there to rounding, quadratically. The exact arm's own check is loosened to
:data:`LOOSE` (a goal of the real arm is reachable on the exact arm only to the snap distance), its
rounding margin ``clip`` to at least ``100 × near_tol`` (a branch at a tangency on one arm may miss it on
the other by that much); the strict check (``verify_position``, ``verify_rotation``) is on the real arm.

Why both: moving the lines onto the family moves every solution by about the snap distance, and where
two solutions of the real arm lie closer than that (a goal near a fold of the workspace) the exact arm
has the pair as a double root or not at all, and a polish from one candidate finds one of them or
neither. Of 600 random arms of the general generators (``benchmarks/bench_families_eaik.py``), 13 lie
within 4e-5-9e-4 × reach of the offset-wrist family; on 9 of their 130 goals the snapped form alone
lost 1-2 solutions that way, every one of which the elimination on the real arm returned. Nearer the
family (a URDF's rounded right angles, micrometres and microradians off) the elimination is the one that
loses solutions (its eliminant nearly degenerates) and the snapped closed form is complete; the union
holds in both regimes. The real arm's own path costs its usual time (60-100 µs for the elimination, a
search's 10-200 µs) on top; where it refuses the arm, the snapped closed form answers alone.

Solutions that meet are merged (one within
:data:`~pipeline.solvers.closed_form.analytic_kernels.DISTINCT_TOL` per joint, wrapped), the rest ranked
nearest the start first, as every analytic solution set.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numba
import numpy as np

from pipeline.kinematics.geometry import joint_lines
from pipeline.kinematics.nearfamily import Snapped, snap
from pipeline.robots import RobotModel
from pipeline.solvers.closed_form.analytic_kernels import DISTINCT_TOL
from pipeline.solvers.closed_form.general6r_model import chain_into, newton_polish
from pipeline.solvers.closed_form.lines import doc_row
from pipeline.solvers.core import NotApplicableError, Prepared, Raw
from pipeline.solvers.core.timing import clock_ns
from pipeline.solvers.kernels.kin import NO_SOLUTION, SUCCESS, TRACE_COLS, rotation_angle

POLISH_STEPS = 8  # Newton steps at most per candidate (from a snap of 1e-3 rad: 1e-6, 1e-12, rounding after 3)
LOOSE = 1e-2  # the exact arm's own check: |Δp| <= LOOSE × reach and angle <= LOOSE rad (the real check follows)


def snapped(prep: Prepared, tol: float, near_tol: float) -> Snapped | None:
    """The nearest exact arm of a better family (:func:`pipeline.kinematics.nearfamily.snap`), once per job."""
    return prep.memo(("near_family", tol, near_tol), lambda: snap(prep.model.chain, tol, near_tol))


def _exact_prep(prep: Prepared, sn: Snapped) -> Prepared:
    src = prep.model
    model = RobotModel(f"{src.name} (nearest {sn.decomposition.family})", src.source, prep.unit, sn.chain,
                       np.array(src.limits), src.path, src.notes, src.joint_names)
    return Prepared(model, prep.unit)


@numba.njit(cache=True, error_model="numpy")
def pose_into(H, P, M, q, A, T):
    """``T`` (4, 4) = E_1(q_1) ⋯ E_n(q_n) M, the tool pose of the joint lines ``H``, ``P`` (n, 3) at ``q``
    (``A`` (4, 4) scratch)."""
    chain_into(H, P, q, H.shape[0], A)
    for r in range(4):
        for c in range(4):
            T[r, c] = A[r, 0] * M[0, c] + A[r, 1] * M[1, c] + A[r, 2] * M[2, c] + A[r, 3] * M[3, c]


@numba.njit(cache=True, error_model="numpy")
def polish_kept(H, P, M, Tg, Q, steps, tolp, tolr, out):
    """Polish the rows of ``Q`` (k, 6) [rad] by at most ``steps`` Newton steps on the joint lines ``H``,
    ``P`` (6, 3) [1], [length] with tool ``M`` (4, 4) at q = 0 towards the goal ``Tg`` (4, 4); the rows
    whose polished pose meets the goal (|Δp| <= ``tolp`` [length], angle <= ``tolr`` [rad]) go to ``out``
    (k, 6), wrapped to (−π, π]. Returns how many."""
    A, T = np.empty((4, 4)), np.empty((4, 4))
    m = 0
    for r in range(Q.shape[0]):
        q = newton_polish(H, P, M, Tg, Q[r], steps)
        pose_into(H, P, M, q, A, T)
        dp = math.sqrt((Tg[0, 3] - T[0, 3]) ** 2 + (Tg[1, 3] - T[1, 3]) ** 2 + (Tg[2, 3] - T[2, 3]) ** 2)
        if dp <= tolp and rotation_angle(Tg, T) <= tolr:
            for j in range(q.shape[0]):
                out[m, j] = math.atan2(math.sin(q[j]), math.cos(q[j]))
            m += 1
    return m


def distinct(Q: np.ndarray) -> np.ndarray:
    """The rows of ``Q`` (k, n) [rad], each kept unless an earlier kept row is within ``DISTINCT_TOL`` of it
    in every joint (wrapped)."""
    close = (np.abs(np.angle(np.exp(1j * (Q[:, None, :] - Q[None, :, :])))) <= DISTINCT_TOL).all(axis=2)
    keep: list = []
    for i in range(len(Q)):
        if not close[i, keep].any():
            keep.append(i)
    return Q[keep]


def bind_near(prep: Prepared, s, sn: Snapped, bind, info):
    """``run1`` of ``analytic`` on an arm near a family: ``bind`` (analytic's own) on the exact arm ``sn``
    with the loosened check, then :func:`polish_kept` on the real arm, joined by ``bind`` on the real arm
    with ``near_tol`` 0; ``info(m, tried, doc, family)`` builds the result's info."""
    exact = prep.memo(("near_prep", id(sn)), lambda: _exact_prep(prep, sn))
    L = joint_lines(prep.model.chain)
    c = np.ascontiguousarray
    H, P, M, reach = c(L.h, dtype=float), c(L.p, dtype=float), c(L.M, dtype=float), L.reach
    loose = replace(s, near_tol=0.0, verify_position=LOOSE * reach, verify_rotation=LOOSE,
                    clip=min(1e-3, max(s.clip, 100.0 * s.near_tol)), max_solutions=16)
    inner = bind(exact, loose)
    try:
        own = bind(prep, replace(s, near_tol=0.0, max_solutions=16))
    except NotApplicableError:  # the real arm's own path refuses it: the snapped closed form alone
        own = None
    family = f"{sn.decomposition.family} (nearest exact arm, polished)"
    tolp, tolr, ms = s.verify_position, s.verify_rotation, s.max_solutions

    def run1(T_goal: np.ndarray, q_start: np.ndarray, seed: int) -> Raw:
        t0 = clock_ns()
        Tg = c(T_goal, dtype=float)
        raw = inner(T_goal, q_start, seed)
        cand = c(raw.solutions, dtype=float) if raw.solutions is not None else np.empty((0, 6))
        out = np.empty((len(cand), 6))
        S = out[:polish_kept(H, P, M, Tg, cand, POLISH_STEPS, tolp, tolr, out)]
        tried, fam = len(cand), family
        if own is not None:
            ro = own(T_goal, q_start, seed)
            tried += int(ro.info.get("candidates", 0))
            fam = f"{family} + {ro.info['family']} on the real arm"
            if ro.solutions is not None and len(ro.solutions):
                S = np.concatenate([S, np.angle(np.exp(1j * ro.solutions))])
        S = distinct(S)
        if len(S):
            d = np.angle(np.exp(1j * (S - q_start)))
            S = S[np.argsort((d * d).sum(axis=1), kind="stable")][:ms]
            q = q_start + np.angle(np.exp(1j * (S[0] - q_start)))
        else:
            q = np.array(q_start, dtype=float)
        trace = np.empty((2, TRACE_COLS))
        A, T = np.empty((4, 4)), np.empty((4, 4))
        for row, x in ((0, q_start), (1, q)):
            pose_into(H, P, M, c(x, dtype=float), A, T)
            doc_row(Tg, c(T[:3, :3]), T[:3, 3].copy(), trace[row])
        return Raw(q=q, code=SUCCESS if len(S) else NO_SOLUTION, iterations=1, solve_ns=clock_ns() - t0,
                   trace=trace, solutions=S, info=info(len(S), tried, float(trace[1, 0]), fam))

    return run1
