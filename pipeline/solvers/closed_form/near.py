"""``analytic`` on an arm near a family (:mod:`pipeline.kinematics.nearfamily`): the family's closed form on
the nearest exact arm gives the candidates, Newton steps on the real arm polish them, the real arm's
forward kinematics checks them.

Each candidate of the exact arm lies within about the snap distance (``near_tol`` × reach, ``near_tol``
rad) of a solution of the real arm; :data:`POLISH_STEPS` Newton steps on the real joint lines (the
space Jacobian of the product of exponentials, a least-squares step on the position and rotation-vector
error) take it there to rounding, quadratically. The exact arm's own check is loosened to
:data:`LOOSE` (a goal of the real arm is reachable on the exact arm only to the snap distance), its
rounding margin ``clip`` to at least ``100 × near_tol`` (a branch at a tangency on one arm may miss it on
the other by that much); the strict check (``verify_position``, ``verify_rotation``) is on the real arm.
Polished candidates that meet are merged (one within
:data:`~pipeline.solvers.closed_form.analytic_kernels.DISTINCT_TOL` per joint, wrapped), the rest ranked
nearest the start first, as every analytic solution set.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from pipeline.kinematics.geometry import axis_rotation, joint_lines
from pipeline.kinematics.nearfamily import Snapped, snap
from pipeline.robots import RobotModel
from pipeline.solvers.closed_form.analytic_kernels import DISTINCT_TOL
from pipeline.solvers.closed_form.lines import doc_row
from pipeline.solvers.core import Prepared, Raw
from pipeline.solvers.core.timing import clock_ns
from pipeline.solvers.kernels.kin import NO_SOLUTION, SUCCESS, TRACE_COLS

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


def fk(h: np.ndarray, p: np.ndarray, M: np.ndarray, Q: np.ndarray):
    """Poses of the joint lines at the rows of ``Q`` and the space Jacobians there.

    Parameters
    ----------
    h, p : ndarray, shape (n, 3) [1], [length]
        The real arm's joint lines at q = 0.
    M : ndarray, shape (4, 4) [length]
        Its tool pose at q = 0.
    Q : ndarray, shape (k, n) [rad]

    Returns
    -------
    R : ndarray, shape (k, 3, 3)
    t : ndarray, shape (k, 3) [length]
    J : ndarray, shape (k, 6, n)
        Rows: the tool point's velocity [length/rad], then the angular velocity [1], world frame.
    """
    k, n = Q.shape
    R = np.tile(np.eye(3), (k, 1, 1))
    t = np.zeros((k, 3))
    W, Pt = np.empty((k, n, 3)), np.empty((k, n, 3))
    for i in range(n):
        W[:, i] = R @ h[i]
        Pt[:, i] = (R @ p[i]) + t
        E = np.array([axis_rotation(h[i], x) for x in Q[:, i]])
        t = t + np.einsum("kab,kb->ka", R, p[i] - E @ p[i])
        R = R @ E
    tool = (R @ M[:3, 3]) + t
    J = np.concatenate([np.cross(W, tool[:, None, :] - Pt), W], axis=2).transpose(0, 2, 1)
    return R @ M[:3, :3], tool, J


def _rotvec(Rd: np.ndarray) -> np.ndarray:
    """Rotation vectors (k, 3) of rotation matrices (k, 3, 3) (small angles exact enough for Newton)."""
    v = 0.5 * np.stack([Rd[:, 2, 1] - Rd[:, 1, 2], Rd[:, 0, 2] - Rd[:, 2, 0], Rd[:, 1, 0] - Rd[:, 0, 1]], axis=1)
    s = np.linalg.norm(v, axis=1)
    c = 0.5 * (np.trace(Rd, axis1=1, axis2=2) - 1.0)
    ang = np.arctan2(s, c)
    scale = np.where(s > 1e-300, ang / np.maximum(s, 1e-300), 1.0)
    return v * scale[:, None]


def polish(h, p, M, Tg: np.ndarray, Q: np.ndarray, steps: int = POLISH_STEPS) -> np.ndarray:
    """Newton steps on the real arm from the rows of ``Q`` (k, n) [rad] towards the goal ``Tg`` (4, 4):
    the polished rows (k, n) [rad], each stopped when its step is below 1e-15 rad."""
    Q = np.array(Q, dtype=float)
    live = np.ones(len(Q), bool)
    for _ in range(steps):
        if not live.any():
            break
        R, t, J = fk(h, p, M, Q[live])
        e = np.concatenate([Tg[:3, 3] - t, _rotvec(Tg[:3, :3] @ R.transpose(0, 2, 1))], axis=1)
        dq = np.array([np.linalg.lstsq(Ji, ei, rcond=None)[0] for Ji, ei in zip(J, e)])
        Q[live] += dq
        small = np.abs(dq).max(axis=1) < 1e-15
        idx = np.flatnonzero(live)
        live[idx[small]] = False
    return Q


def _kept(h, p, M, Tg, Q, tolp: float, tolr: float) -> np.ndarray:
    """The rows of Q whose pose on the real arm meets the goal within the tolerances, wrapped to (−π, π]."""
    if not len(Q):
        return Q
    R, t, _ = fk(h, p, M, Q)
    dp = np.linalg.norm(Tg[:3, 3] - t, axis=1)
    ang = np.linalg.norm(_rotvec(Tg[:3, :3] @ R.transpose(0, 2, 1)), axis=1)
    Q = np.angle(np.exp(1j * Q[(dp <= tolp) & (ang <= tolr)]))
    out = []
    for row in Q:  # merged: one within DISTINCT_TOL per joint, wrapped
        if not any(np.all(np.abs(np.angle(np.exp(1j * (row - o)))) <= DISTINCT_TOL) for o in out):
            out.append(row)
    return np.array(out).reshape(-1, Q.shape[1])


def bind_near(prep: Prepared, s, sn: Snapped, bind, info):
    """``run1`` of ``analytic`` on an arm near a family: ``bind`` (analytic's own) on the exact arm ``sn``
    with the loosened check, then :func:`polish` and the strict check on the real arm; ``info(m, tried,
    doc, family)`` builds the result's info."""
    exact = prep.memo(("near_prep", id(sn)), lambda: _exact_prep(prep, sn))
    L = joint_lines(prep.model.chain)
    h, p, M, reach = L.h, L.p, L.M, L.reach
    loose = replace(s, near_tol=0.0, verify_position=LOOSE * reach, verify_rotation=LOOSE,
                    clip=min(1e-3, max(s.clip, 100.0 * s.near_tol)), max_solutions=16)
    inner = bind(exact, loose)
    family = f"{sn.decomposition.family} (nearest exact arm, polished)"
    tolp, tolr, ms = s.verify_position, s.verify_rotation, s.max_solutions

    def run1(T_goal: np.ndarray, q_start: np.ndarray, seed: int) -> Raw:
        t0 = clock_ns()
        raw = inner(T_goal, q_start, seed)
        cand = raw.solutions if raw.solutions is not None else np.empty((0, 6))
        S = _kept(h, p, M, T_goal, polish(h, p, M, T_goal, cand), tolp, tolr)
        if len(S):
            d = np.angle(np.exp(1j * (S - q_start)))
            S = S[np.argsort((d * d).sum(axis=1), kind="stable")][:ms]
            q = q_start + np.angle(np.exp(1j * (S[0] - q_start)))
        else:
            q = np.array(q_start, dtype=float)
        trace = np.empty((2, TRACE_COLS))
        for row, x in ((0, q_start), (1, q)):
            R, t, _ = fk(h, p, M, np.asarray(x, float)[None])
            doc_row(np.ascontiguousarray(T_goal, dtype=float), np.ascontiguousarray(R[0]), t[0].copy(), trace[row])
        return Raw(q=q, code=SUCCESS if len(S) else NO_SOLUTION, iterations=1, solve_ns=clock_ns() - t0,
                   trace=trace, solutions=S, info=info(len(S), len(cand), float(trace[1, 0]), family))

    return run1
