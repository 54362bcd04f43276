"""The driver's fast paths equal its generic path field by field (pipeline/solvers/core/driver.py).

A fast path stays only where it is measurably faster (see the driver's docstring) and equal to the
path it replaces: the N-problem kernels (``Solver.batch`` + ``finish_batch``) against one
``Bound.solve`` per problem, and the closed forms' fused single call (``Solver.bind_call``) against
``run1`` + ``finish``. Timings aside, every field must be the same bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pipeline.problems import random_joint_pairs
from pipeline.robots import load_robot
from pipeline.solvers import NotApplicableError, get, make_settings, names, prepare
from pipeline.solvers.core.driver import Bound
from tests.solvers.contract import same_result

ROOT = Path(__file__).resolve().parents[3]
ROBOTS = ("kuka_lwr", "ur5", "puma560", "mariano_4dof")


def _cases(attr: str):
    out = []
    for name in names():
        if getattr(get(name), attr) is None:
            continue
        for r in ROBOTS:
            model = load_robot(ROOT / "data" / "robots" / f"{r}.yaml")
            try:
                prepare(name, model, make_settings(name))
            except NotApplicableError:
                continue
            out.append((name, r))
            break
    return out


def _problems(model, n=40, seed=5):
    ps = random_joint_pairs(model, n, np.random.default_rng(seed), low=-math.pi, high=math.pi)
    return ps.goal_transforms(), ps.q_start


@pytest.mark.parametrize("name,robot", _cases("batch"))
@pytest.mark.parametrize("mapping", [{}, {"criterion": "position"}, {"length_unit": "mm"}])
def test_batch_kernel_equals_one_solve_per_problem(name, robot, mapping):
    model = load_robot(ROOT / "data" / "robots" / f"{robot}.yaml")
    s = make_settings(name, mapping)
    prep = prepare(name, model, s)
    T, S = _problems(model)
    fast = Bound(get(name), prep, s).solve_many(T, S, threads=2)
    slow = Bound(replace(get(name), batch=None), prep, s).solve_many(T, S)
    assert len(fast) == len(slow) == len(T)
    for i in range(len(T)):
        same_result(fast.result(i), slow.result(i), f"{name} {robot} problem {i}")


@pytest.mark.parametrize("name,robot", _cases("bind_call"))
@pytest.mark.parametrize("mapping", [{}, {"criterion": "position"}, {"criterion": "dq_norm"}, {"length_unit": "mm"}])
def test_fused_call_equals_run1_and_finish(name, robot, mapping):
    model = load_robot(ROOT / "data" / "robots" / f"{robot}.yaml")
    s = make_settings(name, mapping)
    prep = prepare(name, model, s)
    fused, generic = Bound(get(name), prep, s), Bound(replace(get(name), bind_call=None), prep, s)
    assert fused.fused is not None and generic.fused is None
    T, S = _problems(model, seed=6)
    T[3, :3, 3] *= 100.0  # one goal out of reach
    for i in range(len(T)):
        same_result(fused.solve(T[i], S[i], i), generic.solve(T[i], S[i], i), f"{name} {robot} problem {i}")


JACOBIAN = ("jacobian_transpose", "pseudoinverse", "dls", "sdls")


@pytest.mark.parametrize("name", JACOBIAN)
@pytest.mark.parametrize("robot", ["franka_panda", "ur5"])
@pytest.mark.parametrize("mapping", [{"require_limits": True}, {"require_limits": True, "search_limits": "reflect"},
                                     {"require_limits": True, "restarts": 3, "max_iterations": 30}])
def test_fused_jacobian_call_under_limits_equals_generic(name, robot, mapping):
    """The Jacobian methods' fused call under ``require_limits`` (the arm benchmark's labels): the angles moved
    into the limits by turns and the limit test inside the compiled call, the generic path's values."""
    model = load_robot(ROOT / "data" / "robots" / f"{robot}.yaml")
    s = make_settings(name, mapping)
    prep = prepare(name, model, s)
    fused, generic = Bound(get(name), prep, s), Bound(replace(get(name), bind_call=None), prep, s)
    assert fused.fused is not None and generic.fused is None
    T, S = _problems(model, n=30, seed=9)
    T[2, :3, 3] *= 100.0  # one goal out of reach
    outside = 0
    for i in range(len(T)):
        a, b = fused.solve(T[i], S[i], i), generic.solve(T[i], S[i], i)
        same_result(a, b, f"{name} {robot} {mapping} problem {i}")
        outside += not a.within_limits
    assert outside < len(T)


@pytest.mark.parametrize("fused", [True, False])
def test_restarts_run_the_bound_search(lwr, fused):
    """A restart is the same attempt as the first search (the bound run1 + finish), not another path; with a
    fused call (``Solver.bind_call``) the first search is that call, and the result is the generic path's."""
    s = make_settings("dls", {"restarts": 3, "max_iterations": 2})
    spec = get("dls") if fused else replace(get("dls"), bind_call=None)
    b = Bound(spec, prepare("dls", lwr, s), s)
    assert (b.fused is not None) == fused
    T, S = _problems(lwr, 1)
    b.solve(T[0], S[0], 10)  # kernels compiled or loaded (a call that compiles is run again)
    calls = []
    run1 = b.run1
    b.run1 = lambda Tg, q0, seed: calls.append(seed) or run1(Tg, q0, seed)
    res = b.solve(T[0], S[0], 10)
    skip = 1 if fused else 0  # the fused first search does not go through run1
    assert calls == [10, 11, 12, 13][skip: 1 + res.info.get("restarts", 0)] and res.info["restarts"] >= 1
    generic = Bound(replace(get("dls"), bind_call=None), b.prep, s)
    same_result(res, generic.solve(T[0], S[0], 10), "dls restarts, fused first search against generic")


@pytest.mark.parametrize("name", JACOBIAN)
def test_fused_jacobian_call_takes_any_array(lwr, name):
    """Read-only, Fortran-ordered, integer or list inputs reach the fused call's conversion (the kernel is
    compiled for C-contiguous float64 only) and give the generic path's result; a wrong shape is one line."""
    s = make_settings(name, {"require_limits": True})
    prep = prepare(name, lwr, s)
    fused, generic = Bound(get(name), prep, s), Bound(replace(get(name), bind_call=None), prep, s)
    T, S = _problems(lwr, 3, seed=4)
    ro_T, ro_q = T[0].copy(), S[0].copy()
    ro_T.setflags(write=False)
    ro_q.setflags(write=False)
    for goal, start in ((ro_T, ro_q), (np.asfortranarray(T[1]), S[1].tolist()), (T[2], np.round(S[2]).astype(int))):
        same_result(fused.solve(goal, start, 0), generic.solve(np.array(goal, float), np.array(start, float), 0),
                    f"{name} {type(start).__name__}")
    with pytest.raises(Exception, match="q_start"):
        fused.solve(T[0], S[0][:3], 0)
