"""The solver contract on any machine (issue 41, item 4): properties every registered method keeps.

Each test below is one property, run by :func:`tests.solvers.contract.contract` over every solver x
{``solve``, ``solve_batch``} x {restarts, ``require_limits``} x drawn chains (standard DH, modified
DH, general form, prismatic joints, the solver's home catalogue arm), with derandomized hypothesis
examples, so CI on any CPU crosses restarts, ``require_limits`` and the batch (what the golden
snapshot, exact to the bit on one CPU only, used to be the only test of).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from pipeline.kinematics import fk_htm
from pipeline.solvers import StopReason, solve
from tests.solvers.contract import (FK_SLACK, STOP_VALUES, Case, contract, outside_limits, pose_errors, reach,
                            same_result)

SUCCESS = int(StopReason.SUCCESS)


def _tolerances(case: Case) -> tuple[float, float]:
    """The solver's success test as position and angle bounds [m, rad] (its defaults: pos_orient, or
    position only for geometric_iterative; the variants change neither the test nor the unit)."""
    s = case._settings
    assert s.criterion in ("pos_orient", "position") and s.length_unit == "m", (s.criterion, s.length_unit)
    return s.tol_pos + FK_SLACK, (s.tol_rot + FK_SLACK if s.criterion == "pos_orient" else math.inf)


@contract()
def test_success_is_real(case: Case):
    """(a) A reported success is a real one: fk_htm of the returned joints meets the goal within the
    solver's tolerances, and lies within the joint limits when ``require_limits`` is on."""
    results = case.run()
    tol_pos, tol_rot = _tolerances(case)
    assert len(results) == len(case.goals)
    for i, r in enumerate(results):
        if not r.success:
            continue
        dp, ang = pose_errors(case.model, r.q, case.goals[i])
        assert dp <= tol_pos and ang <= tol_rot, \
            f"{case.where(i)}: success reported, fk_htm says |dp| {dp:.3g} m, angle {ang:.3g} rad; q={r.q.tolist()}"
        if case.require_limits:
            bad = outside_limits(case.model, r.q)
            assert not bad, (f"{case.where(i)}: success under require_limits, joints {bad} outside "
                             f"{case.model.limits[bad].tolist()}: q={r.q[bad].tolist()}")


@contract()
def test_results_finite_or_reported_failure(case: Case):
    """(b) Every result is finite or a reported failure: a success has finite joints and errors; any
    result has a stop reason of the one enum, and success exactly when that reason is SUCCESS."""
    for i, r in enumerate(case.run()):
        q = np.asarray(r.q)
        assert q.shape == (case.model.n,), f"{case.where(i)}: q of shape {q.shape}"
        assert r.stop_reason in STOP_VALUES, f"{case.where(i)}: stop reason {r.stop_reason!r} not a StopReason"
        assert bool(r.success) == (r.stop_reason == SUCCESS), \
            f"{case.where(i)}: success {r.success} with stop reason {r.stop_reason}"
        if r.success or not np.isfinite(q).all():
            assert np.isfinite(q).all() and math.isfinite(r.position_error), \
                f"{case.where(i)}: success {r.success}, stop {r.stop_reason}, q={q.tolist()}, |dp|={r.position_error}"


@contract(paths=("solve_batch",), deterministic_only=True)
def test_batch_equals_single_calls(case: Case):
    """(c) ``solve_batch`` on N goals gives what N ``solve`` calls give, every field bit for bit but the
    timings (the driver's promise: pipeline/solvers/core/driver.py, tests/solvers/core/test_driver_paths.py); without
    traces, every field but the trace."""
    batch = case.run(path="solve_batch")
    bare = case.run(path="solve_batch_notrace")
    single = case.run(path="solve")
    assert len(batch) == len(bare) == len(single) == len(case.goals)
    for i, (b, s) in enumerate(zip(batch, single)):
        same_result(b, s, case.where(i))
        same_result(bare[i], s, case.where(i) + " (no traces)", skip={"trace"})


@contract(deterministic_only=True)
def test_same_inputs_same_output(case: Case):
    """(d) The same inputs and seeds give the same output, through a fresh preparation and binding."""
    first = case.run()  # (computed by another property of this case, often: then many calls ago)
    fresh = case.run(fresh=True)
    for i in range(len(first)):
        same_result(first[i], fresh[i], case.where(i) + " (fresh binding)")


@contract()
def test_unreachable_goal_is_reported_failure(case: Case):
    """(e) A goal three times the chain's reach away from its base is a reported failure (no success,
    no exception). With a prismatic joint and no ``require_limits`` a joint may travel beyond its
    limits, so there a success is allowed only if it is a real one."""
    rng = np.random.default_rng(len(case.label))
    u = rng.normal(size=3)
    G = case.goals[:1].copy()
    G[0, :3, 3] = case.model.chain.base[:3, 3] + 3.0 * max(reach(case.model), 0.1) * u / np.linalg.norm(u)
    (r,) = case.run(goals=G, starts=case.starts[:1])
    bounded = case.require_limits or not case.model.chain.prismatic.any()
    if r.success and not bounded:
        tol_pos, tol_rot = _tolerances(case)
        dp, ang = pose_errors(case.model, r.q, G[0])
        assert dp <= tol_pos and ang <= tol_rot, f"{case.where(0)}: false success at an unreachable goal"
        return
    assert not r.success and r.stop_reason != SUCCESS and r.stop_reason in STOP_VALUES, \
        f"{case.where(0)}: unreachable goal reported as success {r.success}, stop {r.stop_reason}, q={r.q.tolist()}"


@pytest.mark.parametrize("solver", ["rtb_ik_lm", "rtb_ik_nr", "rtb_ik_gn"])
def test_rtb_failed_call_is_repeatable(solver, ur5):
    """The same failed call twice returns the same joint values: a failed rtb call returns a configuration
    drawn from the C library's rand(), which the adapter seeds before every call (it once did so only for
    slimit > 1, and this test found it)."""
    pytest.importorskip("roboticstoolbox")
    q = np.array([0.3, -1.0, 1.2, -0.5, 0.8, 0.2])
    T = fk_htm(ur5.chain, q)
    T[:3, 3] = [5.0, 0.0, 0.0]  # out of the UR5's reach: every search fails
    a, b = solve(solver, ur5, T, q, seed=1), solve(solver, ur5, T, q, seed=1)
    assert not a.success and not b.success
    assert np.array_equal(a.q, b.q), f"{solver}: {a.q.tolist()} then {b.q.tolist()}"


# ---------------------------------------------------------------------------------------------------------------
# each property can fail: a planted bug in the answers (solve and solve_batch wrapped) trips it


def _planted(bug: str, real_solve, real_batch):
    """solve / solve_batch stand-ins whose answers carry ``bug``."""
    calls = [0]

    def spoil(r, i=0):
        calls[0] += 1
        if bug == "false_success" and r.success:
            r = replace(r, q=r.q + 1e-2)
        elif bug == "nan_success" and r.success:
            r = replace(r, q=np.full_like(r.q, np.nan))
        elif bug == "unstable":
            r = replace(r, q=r.q + 1e-12 * calls[0])
        elif bug == "unreachable_success" and r.position_error > 1.0:
            r = replace(r, success=True, stop_reason=SUCCESS)
        return r

    def solve_(*a, **k):
        return spoil(real_solve(*a, **k))

    class _Batch:
        def __init__(self, b):
            self.b = b

        def __len__(self):
            return len(self.b)

        def result(self, i):
            r = self.b.result(i)
            if bug == "batch_differs":
                r = replace(r, iterations=r.iterations + 1)
            return spoil(r)

    def batch_(*a, **k):
        return _Batch(real_batch(*a, **k))

    return solve_, batch_


@pytest.mark.parametrize("bug,prop,says", [
    ("false_success", test_success_is_real, "success reported, fk_htm says"),
    ("nan_success", test_results_finite_or_reported_failure, "success True"),
    ("batch_differs", test_batch_equals_single_calls, "iterations"),
    ("unstable", test_same_inputs_same_output, "fresh binding"),
    ("unreachable_success", test_unreachable_goal_is_reported_failure, "unreachable goal reported as success")])
def test_each_property_catches_a_planted_bug(bug, prop, says, monkeypatch):
    """Each property fails on answers carrying the bug it is about (on dls, a 6-joint DH arm)."""
    import tests.solvers.contract as c

    monkeypatch.setattr(c, "_RUNS", {})
    s, b = _planted(bug, c.solve, c.solve_batch)
    monkeypatch.setattr(c, "solve", s)
    monkeypatch.setattr(c, "solve_batch", b)
    path = "solve_batch" if bug == "batch_differs" else "solve"
    case = c.draw_case("dls", "dh", 6, 11, {}, path, "plain")
    assert case.prepared() is not None
    with pytest.raises(AssertionError, match=says):
        prop.prop(case)
