"""Iterative geometric method of Pinto & Bevilacqua [72] (001_7601717b50b5e768.txt §6.3f, Test 6).

The document describes [72] for planar arms: each joint, in isolation, is turned so that the line
from the joint to the effector points at the goal (position only, no orientation correction);
one iteration = one sweep over the joints. Its joint order, limits and stop rule are not given
(the study's reading: tip to base, no limits, stop at |dp| < tolerance).

Generalisation to any serial chain (sound: each joint step is the exact minimiser of the
distance to the goal over that joint alone, so the distance never grows). A revolute joint turns
about its axis ``u`` by the signed angle between the projections, onto the plane normal to ``u``,
of the joint-to-effector and joint-to-goal vectors: for a planar arm (parallel axes, goal in the
plane) this is the document's "point the line at the goal". A prismatic joint slides by
``(p_goal - p) . u``. The method is the position-only cyclic coordinate descent; it corrects no
orientation, so its settings accept ``criterion: position`` only.

Axes and points on them come from :func:`pipeline.solvers.kernels.kin.forward` (standard or modified DH,
prismatic joints, base and tool transforms).

Trace rows (one per sweep, row 0 = start): ``[|dp|, p_goal - p (3), 0, 0, 0, |dp|]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

import pipeline.solvers.kernels.kin as _kin
from pipeline.solvers.kernels.kin import NEVER, TRACE_DP
from pipeline.solvers.kernels.loop import iterate
from pipeline.solvers.core import Prepared, Raw, Settings, setting
from pipeline.solvers.core.driver import run_loop
from pipeline.solvers.core.registry import Solver, register

SOURCE = "001_7601717b50b5e768.txt (Erthal 1992) §6.3f / Test 6: iterative geometric method of Pinto & Bevilacqua [72]"
ORDERS = ("tip_to_base", "base_to_tip")
ZERO_LENGTH = 1e-12  # [length_unit] a projected vector shorter than this gives no direction (joint skipped)



@dataclass(frozen=True)
class GeometricSettings(Settings):
    """Settings of the iterative geometric method (position only)."""

    criterion: str = setting("position", "position only: the method corrects no orientation (|dp| <= tol_pos)",
                             choices=("position",))
    max_iterations: int = setting(2000, "stop code 4 after this many sweeps over the joints", minimum=1,
                                  maximum=10_000_000)
    order: str = setting("tip_to_base", "order of the joints in a sweep (the study's reading of [72]: tip to base)",
                         choices=ORDERS)


@numba.njit(cache=True)
def _fill(trace, row, Tg, T):
    s = 0.0
    for r in range(3):
        v = Tg[r, 3] - T[r, 3]
        trace[row, 1 + r] = v
        s += v * v
    dp = np.sqrt(s)
    trace[row, 0] = dp
    trace[row, 4], trace[row, 5], trace[row, 6] = 0.0, 0.0, 0.0
    trace[row, TRACE_DP] = dp
    return dp


@numba.njit(cache=True)
def _distance(problem, q, axes, origins, T):
    """FK at ``q`` (axes, origins, T); returns |p_goal - p|."""
    a, alpha, d, offs, prism, modified, base, tool, Tg, tol, reverse = problem
    _kin.forward(a, alpha, d, offs, prism, modified, base, tool, q, axes, origins, T)
    dx, dy, dz = Tg[0, 3] - T[0, 3], Tg[1, 3] - T[1, 3], Tg[2, 3] - T[2, 3]
    return np.sqrt(dx * dx + dy * dy + dz * dz)


@numba.njit(cache=True)
def _start(problem, q):
    """:func:`pipeline.solvers.kernels.loop.iterate`'s ``start``. State: ``(axes, origins, T, v1, v2, clk)``."""
    n = q.shape[0]
    state = (np.empty((n, 3)), np.empty((n, 3)), np.empty((4, 4)), np.empty(3), np.empty(3), np.zeros(2, np.int64))
    err = _distance(problem, q, state[0], state[1], state[2])
    return state, err, err <= problem[9], False


@numba.njit(cache=True)
def _turn(ux, uy, uz, v1, v2):
    """Signed angle about the unit axis u from v1 to v2 projected on the plane normal to u (0 when either
    projection is shorter than ZERO_LENGTH); ``v1``, ``v2`` (3,) are overwritten by their projections."""
    a1 = v1[0] * ux + v1[1] * uy + v1[2] * uz
    a2 = v2[0] * ux + v2[1] * uy + v2[2] * uz
    v1[0] -= a1 * ux
    v1[1] -= a1 * uy
    v1[2] -= a1 * uz
    v2[0] -= a2 * ux
    v2[1] -= a2 * uy
    v2[2] -= a2 * uz
    n1 = np.sqrt(v1[0] * v1[0] + v1[1] * v1[1] + v1[2] * v1[2])
    n2 = np.sqrt(v2[0] * v2[0] + v2[1] * v2[1] + v2[2] * v2[2])
    if n1 > ZERO_LENGTH and n2 > ZERO_LENGTH:
        cx = v1[1] * v2[2] - v1[2] * v2[1]
        cy = v1[2] * v2[0] - v1[0] * v2[2]
        cz = v1[0] * v2[1] - v1[1] * v2[0]
        return np.arctan2(cx * ux + cy * uy + cz * uz, v1[0] * v2[0] + v1[1] * v2[1] + v1[2] * v2[2]), True
    return 0.0, False


@numba.njit(cache=True)
def _step(problem, state, q, it):
    """``step``: one sweep over the joints; stops at the first joint after which the distance is non-finite
    or within ``tol``."""
    prism, Tg, tol, reverse = problem[4], problem[8], problem[9], problem[10]
    axes, origins, T, v1, v2, clk = state
    n = q.shape[0]
    t_ik = 0
    err = 0.0
    for k in range(n):
        i = n - 1 - k if reverse else k
        t0 = _kin.now_ns(clk)
        ux, uy, uz = axes[i, 0], axes[i, 1], axes[i, 2]
        if prism[i]:
            q[i] += (Tg[0, 3] - T[0, 3]) * ux + (Tg[1, 3] - T[1, 3]) * uy + (Tg[2, 3] - T[2, 3]) * uz
        else:
            for r in range(3):
                v1[r] = T[r, 3] - origins[i, r]
                v2[r] = Tg[r, 3] - origins[i, r]
            angle, turned = _turn(ux, uy, uz, v1, v2)
            if turned:
                q[i] += angle
        t_ik += _kin.now_ns(clk) - t0
        err = _distance(problem, q, axes, origins, T)
        if not np.isfinite(err) or err <= tol:
            break
    return err, err <= tol, False, t_ik


@numba.njit(cache=True)
def _record(problem, state, trace, row):
    _fill(trace, row, problem[8], state[2])


@numba.njit(cache=True)
def geometric_kernel(a, alpha, d, offs, prism, modified, base, tool, Tg, q0, max_iter, tol, reverse, q, trace,
                     times):
    """Position-only cyclic coordinate descent (:func:`pipeline.solvers.kernels.loop.iterate` with this
    module's sweep as its step); returns (stop code, sweeps)."""
    code, it, _ = iterate(_start, _step, _record, (a, alpha, d, offs, prism, modified, base, tool, Tg, tol, reverse),
                          q0, q, trace, times, NEVER, max_iter)
    return code, it


def run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: GeometricSettings, seed: int) -> Raw:
    q, trace, times, (code, iters) = run_loop(geometric_kernel, (*prep.args, T_goal, q_start, s.max_iterations,
                                                                 s.tol_pos, s.order == "tip_to_base"),
                                              q_start, s.max_iterations)
    return Raw(q=q, code=int(code), iterations=int(iters), solve_ns=int(times[0]), trace=trace, ik_ns=int(times[1]))


register(Solver("geometric_iterative", "iterative geometric method (Pinto & Bevilacqua): each joint in turn moved "
                "to bring the effector closest to the goal (position only; planar arms in the document, any chain here)",
                "local", GeometricSettings, run, source=SOURCE))
