"""``analytic``: closed-form IK by subproblem decomposition, found from the arm's geometry.

Whatever the robot file's form, the joint axes at the zero pose decide the family
(:func:`pipeline.kinematics.geometry.classify`; ``python -m pipeline robot FILE`` prints it with its
evidence) and the family's module solves it, built on the subproblems of
:mod:`pipeline.solvers.closed_form.subproblems`:

- 6R, spherical wrist (or spherical shoulder, read from the tool back): all (up to 8) solutions
  (:mod:`~pipeline.solvers.closed_form.family_sph`);
- 6R, three parallel axes with the last two meeting (UR family, or reversed): up to 8
  (:mod:`~pipeline.solvers.closed_form.family_3p`);
- 6R, spherical wrist (or shoulder) on a general 3R positioner, and three parallel axes with the other two
  skew (or reversed): up to 8, joint 1 (or 6) from a quartic
  (:mod:`~pipeline.solvers.closed_form.family_gen3r`);
- 6R, axes 5 and 6 meeting (or 1 and 2) with a position case for the other end: a one-dimensional
  search (:mod:`~pipeline.solvers.closed_form.family_search`) over joint 4 (``search_samples`` grid
  points, sign changes of each branch's residual refined by regula falsi): up to 16 (the offset-wrist
  arms);
- 6R, no family: every solution by algebraic elimination (:mod:`pipeline.solvers.closed_form.general6r`, the
  solver ``general_6r``; Raghavan-Roth / Manocha-Canny), up to 16;
- 7R: one joint (chosen from the geometry, or ``free_joint``) held at the start's own value, at
  six values beside it (±0.05, ±0.15, ±0.3 rad: a warm start's nearest solution lies there) and at
  ``free_samples`` values evenly spread over its limits; the other six by the 6R closed form
  of their family. Solutions outside the joint limits are dropped (revolute joints moved by 2π
  into them where they fit).

Joints held at given values (``fixed_joints``, numbered from 1) are folded into the neighbouring links
first (:mod:`pipeline.solvers.core.fixed`): a 7R arm with one joint held is solved as the 6R arm it is,
by every path above (one in the search family by the general elimination where that applies). A 6R arm
that fits a better family only within ``near_tol`` (rounded angles in its file) is solved on the
nearest exact arm of that family, each candidate polished and checked on the real arm, and the real
arm's own path (``near_tol`` 0) adds its solutions (:mod:`pipeline.solvers.closed_form.near`). Both run
one pose per call (no batch kernel, no fused call).

Every candidate is checked by the forward kinematics of the joint lines (base and tool included)
against ``verify_position`` / ``verify_rotation``; ``solutions`` holds the valid ones, each once (two
within :data:`~pipeline.solvers.closed_form.analytic_kernels.DISTINCT_TOL` = 1e-6 rad in every joint,
wrapped, are one), nearest to the start first (wrapped joint distance, sum of squares); ``q`` is the first, unwrapped to lie within
π of ``q_start`` per joint for 6R arms (within the limits for 7R). At a singular wrist the free
angle is the start's. No valid candidate: ``NO_SOLUTION`` with ``q = q_start``. The trace has two
rows, the document's error ``[‖e‖, e, |Δp|]`` at ``q_start`` and at ``q``.

A robot whose geometry fits no family (and, for a 6R arm, whose elimination degenerates) is refused
in one line naming the geometry (e.g. "axes 4, 5 and 6 do not meet (closest common point 12.3 mm
off) ..."). The general path is one compiled call per pose (:func:`pipeline.solvers.closed_form.general6r.general_pose`;
the public call fused with the independent check, :func:`pipeline.solvers.closed_form.general6r.general_call`;
a batch on every core, :func:`pipeline.solvers.closed_form.general6r.batch_arrays`).

This module holds the settings, the registration and the Python side of the calls (the arm packed once,
the results built); the compiled kernels (one pose, the fused call, the batch) are in
:mod:`pipeline.solvers.closed_form.analytic_kernels`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from pipeline.kinematics import geometry
from pipeline.kinematics.nearfamily import NEAR_TOL
from pipeline.solvers.closed_form import continuum, lanes, near
from pipeline.solvers.closed_form import subproblems as sp
from pipeline.solvers.closed_form.analytic_kernels import kernels, scratch
from pipeline.solvers.closed_form.family_gen3r import FAM_3PO, FAM_SPH3R
from pipeline.solvers.kernels.kin import NO_SOLUTION, SUCCESS, TRACE_COLS
from pipeline.solvers.core import (BatchRaw, IKResult, InfoRows, Prepared, Raw, Settings, SettingsError, check_pack,
                                   fused_inputs, setting)
from pipeline.solvers.core import fixed
from pipeline.solvers.core.timing import clock_ns
from pipeline.solvers.core.driver import run_of
from pipeline.solvers.core.registry import Solver, register

SOURCE = ("Paden (1985) and Kahan's subproblems 1-4, as extended by IK-Geo (Elias & Wen 2022) and EAIK "
          "(Ostermeier, Külz & Althoff 2025); the decomposition found from the joint axes")


@dataclass(frozen=True)
class AnalyticSettings(Settings):
    geometry_tol: float = setting(1e-9, "axes meet when their closest distance is at most this times the arm's reach "
                                  "(the sum of its link lengths), and are parallel within this angle [rad]",
                                  above=0.0, maximum=1e-2)
    clip: float = setting(1e-9, "a cosine beyond ±1 by at most this is rounding at a boundary (clipped), beyond "
                          "it the branch does not exist", minimum=0.0, maximum=1e-3)
    search_samples: int = setting(64, "one-dimensional search (offset wrists): grid points over one turn of the "
                                  "searched joint (4 or 6)", minimum=8, maximum=65536)
    free_samples: int = setting(16, "7R arms: values of the free joint swept over its limits (the start's value "
                                "is tried too)", minimum=1, maximum=4096)
    refine: int = setting(8, "a one-dimensional search (6R) or a sweep (7R) that finds no solution within the "
                          "limits is run once more on a grid this many times finer (1 = never)", minimum=1, maximum=64)
    max_solutions: int = setting(16, "solutions returned per goal at most, the nearest to the start (a 7R sweep "
                                 "finds up to 8 per value of the free joint)", minimum=1, maximum=4096)
    free_joint: int = setting(0, "7R arms: the joint held as the free parameter (1-based); 0 = chosen from the "
                              "geometry", minimum=0, maximum=7)
    verify_position: float = setting(1e-9, "FK check of each closed-form solution: |Δp|", unit="m", above=0.0,
                                     length=True)
    verify_rotation: float = setting(1e-9, "FK check of each closed-form solution: rotation angle", unit="rad",
                                     above=0.0)
    fixed_joints: tuple = fixed.fixed_joints_setting()
    near_tol: float = setting(NEAR_TOL, "a 6R arm that fits a better family only within this tolerance (meet within "
                              "near_tol x reach, parallel within near_tol rad; rounded angles or lengths in its file) "
                              "is solved by that family's closed form on the nearest exact arm, each candidate "
                              "polished by Newton steps on the real arm and FK-checked there, joined by the real arm's "
                              "own path's solutions; 0 = never",
                              minimum=0.0, maximum=1e-2)

    def check(self, where: str) -> None:
        if self.fixed_joints and self.free_joint:
            raise SettingsError(f"{where}: field 'free_joint': must be 0 when fixed_joints is given (the free joint "
                                "of the arm left after folding the held joints is chosen from its geometry)")


def decomposition(prep: Prepared, s: AnalyticSettings) -> geometry.Decomposition:
    """The arm's family under ``s`` (once per job and settings)."""
    order = None if s.free_joint == 0 else [s.free_joint - 1]
    return prep.memo(("decomposition", s.geometry_tol, s.free_joint),
                     lambda: geometry.classify(prep.model.chain, s.geometry_tol, prep.unit, order))


def applies_to(prep: Prepared) -> str | None:
    """One-line reason why no closed form fits the arm's geometry (default settings), or None: a 6R arm
    that fits no subproblem family is solved by the general elimination (:mod:`general6r`) where it
    applies."""
    d = decomposition(prep, AnalyticSettings())
    if d.family or _near(prep, AnalyticSettings()) is not None:
        return None
    if prep.n != 6 or prep.prismatic.any():
        return d.reason
    from pipeline.solvers.closed_form import general6r  # (imported here: the registry lists it after the peers)

    why = general6r.degenerate(prep)
    return None if why is None else f"{d.reason}; {why}"


def _general(prep: Prepared, s: AnalyticSettings) -> bool:
    """The arm fits no subproblem family: the general 6R elimination solves it (:func:`applies_to`)."""
    return decomposition(prep, s).family is None


GENERAL = "general 6R (algebraic elimination)"


def _general_settings(s: AnalyticSettings):
    """general_6r's settings for a 6R arm that fits no family: the roots are kept by the FK check with
    this solver's verify_position / verify_rotation, as the other families' candidates."""
    from pipeline.solvers.closed_form import general6r

    return settings_as(general6r.General6RSettings, s, max_solutions=min(s.max_solutions, sp.MAX_SOL),
                       criterion="pos_orient", tol_pos=s.verify_position, tol_rot=s.verify_rotation)


def _bind_general(prep: Prepared, s: AnalyticSettings):
    """``run1`` of a 6R arm that fits no family: every solution by the general elimination, nearest to
    the start first (under ``require_limits`` the nearest within the limits first), in one compiled
    call (:func:`pipeline.solvers.closed_form.general6r.general_pose`), with this solver's trace (the document's
    error at the start and at ``q``) and ``info``."""
    from pipeline.solvers.closed_form import general6r

    solve1 = general6r.bind_pose(prep, _general_settings(s), bool(s.require_limits), True)

    def run1(T_goal: np.ndarray, q_start: np.ndarray, seed: int) -> Raw:
        (m, k, _, code, _, ns), S, q, trace = solve1(T_goal, q_start)
        return Raw(q=q, code=int(code), iterations=1, solve_ns=ns, trace=trace, solutions=S[:m],
                   info=_info(m, k, float(trace[1, 0]), GENERAL))

    return run1


def _two_rows_each(traces: np.ndarray, keep: bool):
    """A batch's kept traces (N, 2, 8) as ``BatchRaw``'s rows (2 N, 8) and offsets (N + 1,), or (None, None)."""
    if not keep:
        return None, None
    N = traces.shape[0]
    return traces.reshape(2 * N, TRACE_COLS), np.arange(0, 2 * N + 1, 2, dtype=np.int64)


def _batch_general(prep: Prepared, s: AnalyticSettings, goals: np.ndarray, starts: np.ndarray, keep_traces: bool):
    """:func:`batch` of a 6R arm that fits no family: :func:`pipeline.solvers.closed_form.general6r.batch_arrays`, the
    poses of ``run1`` (:func:`_bind_general`) on ``threads`` threads."""
    from pipeline.solvers.closed_form import general6r

    S, Q, traces, doc, out = general6r.batch_arrays(prep, _general_settings(s), goals, starts, keep_traces)
    N = len(Q)
    nsol = np.ascontiguousarray(out[:, 0])
    rows, offsets = _two_rows_each(traces, keep_traces)
    info = InfoRows(N, lambda i: _info(int(out[i, 0]), int(out[i, 1]), float(doc[i]), GENERAL))
    return BatchRaw(q=Q, code=np.ascontiguousarray(out[:, 3]), iterations=np.ones(N, np.int64),
                    solve_ns=np.ascontiguousarray(out[:, 5]), ik_ns=np.zeros(N, np.int64), trace_rows=rows,
                    trace_offsets=offsets, solutions=S, n_solutions=nsol, info=info)


def _bind_call_general(prep: Prepared, s: AnalyticSettings):
    """:func:`bind_call` of a 6R arm that fits no family: :func:`pipeline.solvers.closed_form.general6r.general_call`."""
    from pipeline.solvers.closed_form import general6r

    gs = _general_settings(s)
    E, _, lines, CK = general6r.pose_args(prep, gs)
    GC, scale, ms = check_pack(prep, s), float(prep.goal_scale), gs.max_solutions
    inputs, unit, pos_only, nan, empty = fused_inputs(prep, scaled=False), prep.unit, s.criterion == "position", \
        math.nan, np.empty
    kernel, heads = general6r.general_call, _info_heads(GENERAL, ms)

    def call(T_goal: np.ndarray, q_start: np.ndarray, seed: int, t0: int) -> IKResult:
        Tg, q0 = inputs(T_goal, q_start)
        S, q, trace = empty((ms, 6)), empty(6), empty((2, TRACE_COLS))
        m, k, ns, code, claimed, success, dp, ang, inside, doc = kernel(E, lines, CK, GC, scale, Tg, q0, S, q, trace)
        res = IKResult(q, success, code, 1, trace, ns * 1e-9, 0.0, dp, nan if pos_only else ang, claimed, inside,
                       nan, unit, S[:m], dict(heads[m], candidates=k, nfev=k, doc_error=doc))
        res.call_time_s = (clock_ns() - t0) * 1e-9
        return res

    return call


FAMILY_CODE = {"spherical_wrist": sp.FAM_SPH, "three_parallel": sp.FAM_3P, "two_intersecting_search": sp.FAM_SEARCH,
               "spherical_wrist_3r": FAM_SPH3R, "three_parallel_offset": FAM_3PO}


@dataclass(frozen=True)
class Packed:
    """The arm and the settings for the kernels: ``ints`` = n, family, position case, reversed, free
    joint (−1 for 6R), search samples, free samples, searched joint; ``G`` = the joint lines H (n, 3)
    and P (n, 3), the home pose RM (3, 3) and pM (3,), (clip, verify_position, verify_rotation) and
    the limits (n, 2), then (6, 2) of ±inf, flattened
    (:func:`~pipeline.solvers.closed_form.analytic_kernels.unpack` gives the views)."""

    ints: np.ndarray
    G: np.ndarray


def packed(prep: Prepared, s: AnalyticSettings) -> Packed:
    d = decomposition(prep, s)
    if d.family is None:
        from pipeline.solvers.core import NotApplicableError

        raise NotApplicableError(f"analytic: {d.reason}")
    L = geometry.joint_lines(prep.model.chain)
    ints = np.array([L.n, FAMILY_CODE[d.family], d.position_case, int(d.reversed),
                     -1 if d.free_joint is None else d.free_joint, s.search_samples, s.free_samples, d.searched,
                     s.max_solutions, s.refine], np.int64)
    G = np.concatenate([L.h.ravel(), L.p.ravel(), L.M[:3, :3].ravel(), L.M[:3, 3],
                        [s.clip, s.verify_position, s.verify_rotation], np.asarray(prep.limits, float).ravel(),
                        np.tile([-np.inf, np.inf], 6)])
    return Packed(ints, np.ascontiguousarray(G))


_MESSAGES = ["no valid closed-form solution"] + [f"{m} FK-verified solutions" for m in range(1, 4097)]


def most_solutions(ints: np.ndarray) -> int:
    """Solutions a pose can have at most: 8 for a 6R spherical wrist or three parallel axes, 16 for
    an offset wrist (the search), any number for a 7R sweep (``max_solutions`` bounds them)."""
    n, fam = int(ints[0]), int(ints[1])
    return sp.MAX_SOL if n == 6 and fam == sp.FAM_SEARCH else 8 if n == 6 else 2**31


def _info_heads(family: str, most: int) -> list:
    """``info`` of a fused call with m solutions, m = 0 … ``most``, the per-goal values left at 0: the
    call copies ``heads[m]`` with them filled in (``dict(heads[m], candidates=…)``: the keys in
    :func:`_info`'s order, in about half the time of building the dict anew)."""
    return [_info(m, 0, 0.0, family) for m in range(most + 1)]


def _info(m: int, tried: int, doc: float, family: str) -> dict:
    return {"n_solutions": m, "candidates": tried, "nfev": tried, "njev": 0, "doc_error": doc, "family": family,
            "message": _MESSAGES[m]}


def _family(prep: Prepared, s: AnalyticSettings) -> str:
    d = decomposition(prep, s)
    return d.family if d.free_joint is None else f"{d.family}, joint {d.free_joint + 1} free"


def bind(prep: Prepared, s: AnalyticSettings):
    """``run1(T_goal, q_start, seed) -> Raw`` with the geometry packed once (with ``fixed_joints``, this
    solver on the arm with those joints folded in: :mod:`pipeline.solvers.core.fixed`)."""
    if s.fixed_joints:
        return fixed.bind_held(prep, s, _bind_folded)
    sn = _near(prep, s)
    if sn is not None:
        return near.bind_near(prep, s, sn, bind, _info)
    if _general(prep, s):
        return _bind_general(prep, s)
    if _continuum(prep, s):
        return continuum.bind(prep, s, _info)
    k = packed(prep, s)
    n, fam = int(k.ints[0]), _family(prep, s)
    args = (k.ints, k.G)
    solve_pose = kernels(k.ints).solve_pose

    def run1(T_goal: np.ndarray, q_start: np.ndarray, seed: int) -> Raw:
        S = np.empty((min(s.max_solutions, most_solutions(k.ints)), n))
        q = np.empty(n)
        trace = np.empty((2, TRACE_COLS))
        m, tried, ns = solve_pose(*args, np.ascontiguousarray(T_goal, dtype=float),
                                  np.ascontiguousarray(q_start, dtype=float), *scratch(k.ints), S, q, trace,
                                  True, -1, 0)  # every argument given: numba's dispatch of omitted ones is slow
        return Raw(q=q, code=SUCCESS if m else NO_SOLUTION, iterations=1, solve_ns=ns, trace=trace,
                   solutions=S[:m], info=_info(m, tried, float(trace[1, 0]), fam))

    return run1


def _continuum(prep: Prepared, s: AnalyticSettings) -> bool:
    """Every goal of the arm is unreachable or a continuum (:mod:`pipeline.solvers.closed_form.continuum`)."""
    return decomposition(prep, s).family == geometry.CONTINUUM


def _near(prep: Prepared, s: AnalyticSettings):
    """The nearest exact arm of a better family (:mod:`pipeline.solvers.closed_form.near`), or None."""
    if s.near_tol <= 0.0 or prep.n != 6:
        return None
    return near.snapped(prep, s.geometry_tol, s.near_tol)


def _bind_folded(prep: Prepared, s: AnalyticSettings):
    """:func:`bind` of an arm with joints held (folded, :mod:`pipeline.solvers.core.fixed`): a 6R arm that
    falls in the one-dimensional search family goes to the general elimination where that applies (every
    root of a polynomial, not a sampled residual: a 7R arm with a joint held often lands in the search
    family with a residual the grid undersamples, e.g. the Gen3 with joint 7 held, 137 of 200 goals solved
    by the search against 200 by the elimination); where the elimination degenerates, the search runs on
    at least :data:`FOLDED_SEARCH_SAMPLES` grid points."""
    if prep.n == 6 and decomposition(prep, s).family == "two_intersecting_search":
        if applies_to_general(prep):
            return _bind_general(prep, s)
        s = replace(s, search_samples=max(s.search_samples, FOLDED_SEARCH_SAMPLES))
    return bind(prep, s)


# a held arm left to the search (the elimination degenerates on it) is searched on at least this many grid
# points: the Gen3 with joint 5 held, 2 000 goals, generating solution returned on 96.9 % with 64, on every
# one of 400 with 512
FOLDED_SEARCH_SAMPLES = 512


def applies_to_general(prep: Prepared) -> bool:
    """The general 6R elimination does not degenerate on this arm."""
    from pipeline.solvers.closed_form import general6r

    return prep.memo("general6r_ok", lambda: general6r.degenerate(prep) is None)


def batch(prep: Prepared, s: AnalyticSettings, goals: np.ndarray, starts: np.ndarray, seeds, keep_traces: bool):
    """N poses in one compiled call on every core (each pose writes only its own rows): the family's batch
    kernel (:func:`~pipeline.solvers.closed_form.analytic_kernels.kernels`), or for an arm that fits no family
    the general elimination's (:func:`_batch_general`); None with ``fixed_joints`` (one call per pose)."""
    if s.fixed_joints or _near(prep, s) is not None or _continuum(prep, s):
        return None
    if _general(prep, s):
        return _batch_general(prep, s, goals, starts, keep_traces)
    k = packed(prep, s)
    n, fam = int(k.ints[0]), _family(prep, s)
    goals = np.ascontiguousarray(goals, dtype=float)
    starts = np.ascontiguousarray(starts, dtype=float)
    N = goals.shape[0]
    S = np.empty((N, min(s.max_solutions, most_solutions(k.ints)), n))
    Q = np.empty((N, n))
    traces = np.empty((N if keep_traces else 0, 2, TRACE_COLS))
    doc = np.empty(N)
    nsol = np.zeros(N, np.int64)
    tried = np.zeros(N, np.int64)
    ns = np.zeros(N, np.int64)
    kernels(k.ints).batch(k.ints, k.G, goals, starts, S, Q, traces, doc, nsol, tried, ns,
                          lanes.applies(n, int(k.ints[1]), int(k.ints[3])))
    rows, offsets = _two_rows_each(traces, keep_traces)
    info = InfoRows(N, lambda i: _info(int(nsol[i]), int(tried[i]), float(doc[i]), fam))
    code = np.where(nsol > 0, SUCCESS, NO_SOLUTION).astype(np.int64)
    return BatchRaw(q=Q, code=code, iterations=np.ones(N, np.int64), solve_ns=ns, ik_ns=np.zeros(N, np.int64),
                    trace_rows=rows, trace_offsets=offsets, solutions=S, n_solutions=nsol, info=info)


def fused_kernel(prep: Prepared, s: AnalyticSettings) -> tuple:
    """What :func:`bind_call` hands its compiled call (an arm a family's closed form takes):
    ``(kernel, ints, GC, n, ms)``, called as ``kernel(ints, GC, T_goal, q_start, S, q, trace)`` with
    ``S`` (ms, n), ``q`` (n,) and ``trace`` (2, 8) float64 arrays to write
    (:func:`~pipeline.solvers.closed_form.analytic_kernels.call_pose`; ``benchmarks/call_budget.py`` times it
    alone)."""
    k = packed(prep, s)
    GC = np.concatenate([k.G, check_pack(prep, s), [prep.goal_scale]])
    return kernels(k.ints).call, k.ints, GC, int(k.ints[0]), min(s.max_solutions, most_solutions(k.ints))


def bind_call(prep: Prepared, s: AnalyticSettings):
    """The public single call fused (``Solver.bind_call``): closed form, independent FK check and limit
    record in one compiled call, the result built positionally; None under ``require_limits`` (the
    generic path then chooses among the solutions within the limits). Same values as ``bind`` +
    :func:`~pipeline.solvers.core.finish`, timings aside."""
    if s.require_limits or s.fixed_joints or _near(prep, s) is not None or _continuum(prep, s):
        return None
    if _general(prep, s):
        return _bind_call_general(prep, s)
    kernel, ints, GC, n, ms = fused_kernel(prep, s)
    fam, inputs, unit = _family(prep, s), fused_inputs(prep, scaled=False), prep.unit
    pos_only = s.criterion == "position"
    nan, empty = math.nan, np.empty
    heads, shape_S, shape_trace = _info_heads(fam, ms), (ms, n), (2, TRACE_COLS)

    def call(T_goal: np.ndarray, q_start: np.ndarray, seed: int, t0: int) -> IKResult:
        S = empty(shape_S)
        q = empty(n)
        trace = empty(shape_trace)
        try:  # the caller's arrays as they are when they are C-contiguous float64 (the kernel writes into neither)
            m, tried, ns, code, claimed, success, dp, ang, inside, doc = kernel(ints, GC, T_goal, q_start, S, q, trace)
        except TypeError:  # anything else: converted as every solver's inputs are (a wrong shape: SettingsError)
            Tg, q0 = inputs(T_goal, q_start)
            m, tried, ns, code, claimed, success, dp, ang, inside, doc = kernel(
                ints, GC, np.array(Tg, order="C"), np.array(q0, order="C"), S, q, trace)
        if m < 0:  # a shape the kernel refused
            inputs(T_goal, q_start)
            raise SettingsError(f"T_goal / q_start: expected shapes (4, 4) and ({n},)")
        res = IKResult(q, success, code, 1, trace, ns * 1e-9, 0.0, dp, nan if pos_only else ang, claimed, inside,
                       nan, unit, S if m == ms else S[:m], dict(heads[m], candidates=tried, nfev=tried, doc_error=doc))
        res.call_time_s = (clock_ns() - t0) * 1e-9
        return res

    return call


run = run_of(bind)


def settings_as(cls, s: Settings, **override):
    """``s`` (another solver's settings, already in the working unit) as ``cls``: the fields both have
    carried over (``override`` replacing some), the rest at their defaults."""
    from dataclasses import fields

    names = {f.name for f in fields(cls)}
    return cls(**{**{f.name: getattr(s, f.name) for f in fields(s) if f.name in names}, **override})


def as_analytic(s: Settings) -> AnalyticSettings:
    """``s`` (another closed form's settings) as this solver's: the base fields and the FK check's
    tolerances carried over, the rest at their defaults."""
    return settings_as(AnalyticSettings, s)


def alias_hooks(family: str, what: str, own_reason, own_bind, own_batch, own_bind_call) -> dict:
    """``applies_to``, ``bind``, ``batch`` and ``bind_call`` for a document's own closed form that runs
    its transcription where its DH test passes (the studies' tables) and this solver wherever else
    the joint axes give ``family``, whatever the robot file's form. A refusal names the geometry."""

    def own(prep: Prepared) -> bool:
        return prep.memo(("own_dh", what), lambda: own_reason(prep) is None)

    def applies(prep: Prepared) -> str | None:
        if own(prep):
            return None
        d = decomposition(prep, AnalyticSettings())
        if d.family == family and d.free_joint is None:
            return None
        if d.family is None:
            return f"not a {what} arm: {d.reason}"
        return f"not a {what} arm: its joint axes give {d.reason} (the solver `analytic` takes it)"

    def bind_(prep, s):
        return own_bind(prep, s) if own(prep) else bind(prep, as_analytic(s))

    def batch_(prep, s, goals, starts, seeds, keep_traces):
        if own(prep):
            return own_batch(prep, s, goals, starts, seeds, keep_traces)
        return batch(prep, as_analytic(s), goals, starts, seeds, keep_traces)

    def bind_call_(prep, s):
        return own_bind_call(prep, s) if own(prep) else bind_call(prep, as_analytic(s))

    return {"applies_to": applies, "bind": bind_, "batch": batch_, "bind_call": bind_call_, "run": run_of(bind_)}

register(Solver("analytic", "closed-form IK by subproblem decomposition found from the joint axes (spherical wrist, "
                "three parallel axes, offset wrists by a 1-D search; 7R arms through a swept free joint): every "
                "solution, nearest to the start", "analytic", AnalyticSettings, run, applies_to=applies_to,
                source=SOURCE, bind=bind, batch=batch, bind_call=bind_call))
