"""Compilation is never timed as a solve (issue 40, item 5): a call during which numba compiled kernels (or
loaded them from its cache) is run again once they are ready and says so; a family's closed form
compiles on its own (item 1)."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from pipeline import kinematics, robots, solvers
from pipeline._numba_cache import compile_ns
from pipeline.solvers.closed_form import analytic_kernels as analytic
from pipeline.solvers.closed_form import subproblems as sp


def _goal(arm, seed=0):
    q = np.random.default_rng(seed).uniform(-1, 1, arm.chain.n if hasattr(arm.chain, "n") else 6)
    return kinematics.fk_htm(arm.chain, q)


def _fresh_kernel():
    """A kernel no earlier call compiled (no disk cache): its first call compiles."""

    @numba.njit(cache=False)
    def fresh(x):
        return x * 2.0 + 1.0

    return fresh


@pytest.mark.parametrize("method, settings", [("dls", {}), ("analytic", {}), ("analytic", {"require_limits": True})])
def test_a_call_that_compiles_is_run_again_and_says_so(method, settings):
    arm = robots.load_robot("ur5e")
    ik = solvers.bind(method, arm, settings)
    T, q0 = _goal(arm), np.zeros(6)
    warm = ik.solve(T, q0)  # whatever the method compiles or loads, now
    real, fresh, runs = ik._run, _fresh_kernel(), []

    def run(T_goal, q_start, seed, t0):
        runs.append(t0)
        if len(runs) == 1:
            fresh(1.0)  # compiles inside the call, as a method's first call does
        return real(T_goal, q_start, seed, t0)

    ik._run, ik.call = run, ik._own_time
    before = compile_ns()
    res = ik.solve(T, q0)
    spent = (compile_ns() - before) * 1e-9
    assert len(runs) == 2 and res.compiled and spent > 0
    assert res.compile_time_s == pytest.approx(spent) and "compile_time_s" not in res.info
    assert res.call_time_s < spent  # the run again: its own time, not the compile's
    assert np.array_equal(res.q, warm.q) and res.success == warm.success
    again = ik.solve(T, q0)
    assert not again.compiled and again.compile_time_s == 0.0 and len(runs) <= 3


def test_a_restart_that_compiles_after_warm_calls_is_run_again_and_says_so():
    """With ``restarts`` a warm fused call is watched only when its search failed: a restart that compiles
    then (the generic path's first use) is run again and marked, and the calls after it are not."""
    arm = robots.load_robot("ur5e")
    ik = solvers.bind("dls", arm, {"restarts": 2, "max_iterations": 5})
    T, q0 = _goal(arm), np.zeros(6)
    T[:3, 3] += 10.0  # out of reach: every search fails, the restarts run
    ik.solve(T, q0)
    first = ik.solve(T, q0)
    assert ik.call != ik._own_time and not first.compiled and first.info["restarts"] == 2  # the warm call
    real, fresh, runs = ik.run1, _fresh_kernel(), []

    def run1(Tg, q_start, seed):
        runs.append(seed)
        if len(runs) == 1:
            fresh(1.0)  # compiles inside a restart, as the generic path's first use does
        return real(Tg, q_start, seed)

    ik.run1 = run1
    before = compile_ns()
    res = ik.solve(T, q0)
    spent = (compile_ns() - before) * 1e-9
    assert res.compiled and res.compile_time_s == pytest.approx(spent) and res.call_time_s < spent
    assert not res.success and res.info["restarts"] == 2 and np.array_equal(res.q, first.q)
    again = ik.solve(T, q0)
    assert not again.compiled and again.compile_time_s == 0.0 and np.array_equal(again.q, first.q)


def test_a_warm_call_is_not_marked():
    arm = robots.load_robot("ur5e")
    T = _goal(arm, 3)
    solvers.solve("analytic", arm, T, np.zeros(6))
    res = solvers.solve("analytic", arm, T, np.zeros(6))
    assert not res.compiled and res.compile_time_s == 0.0
    batch = solvers.solve_batch("analytic", arm, np.stack([T] * 9), np.zeros((9, 6)))
    batch = solvers.solve_batch("analytic", arm, np.stack([T] * 9), np.zeros((9, 6)))
    assert not batch.compiled and batch.compile_time_s == 0.0


def test_compile_clock_counts_a_compile():
    before = compile_ns()
    _fresh_kernel()(2.0)
    assert compile_ns() > before


def test_each_family_has_its_own_kernels():
    """A robot binds its family's copies only: the other families' closed forms, and the other joint
    count's branches, are not what it compiles."""
    ks = {(c, n): analytic.kernels(np.array([n, c])) for c in (sp.FAM_SPH, sp.FAM_3P, sp.FAM_SEARCH) for n in (6, 7)}
    assert len({id(k.solve_pose) for k in ks.values()}) == 6
    family = {sp.FAM_SPH: "family_sph", sp.FAM_3P: "family_3p", sp.FAM_SEARCH: "family_search"}  # their modules
    for (c, n), k in ks.items():
        g = k.solve_pose.py_func.__globals__
        assert k.core6.py_func.__globals__["FAMILY"].py_func.__module__ == f"pipeline.solvers.closed_form.{family[c]}"
        assert g["CORE6"] is k.core6 and (g["FAM"], g["NJ"]) == (c, n)
        assert k.batch.py_func.__globals__["SOLVE_POSE"] is k.solve_pose
        assert k.solve_pose.py_func.__qualname__ == f"solve_pose__{analytic.FAMILY_NAMES[c]}_{n}r"
    assert analytic.kernels(np.array([6, sp.FAM_3P])) is ks[(sp.FAM_3P, 6)]  # made once per process


def test_batches_run_on_tbb_where_the_wheel_is_installed():
    """numba's TBB layer (pipeline._numba_cache._find_tbb): a parallel region does not wait for a
    descheduled thread on a busy machine."""
    import importlib.metadata
    import os
    import sys

    try:
        importlib.metadata.distribution("tbb")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("the tbb wheel is not installed here (it is a dependency on x86-64 Linux and Windows)")
    if os.environ.get("NUMBA_THREADING_LAYER") or not sys.platform.startswith("linux"):
        pytest.skip("a threading layer chosen by the user, or not Linux")
    arm = robots.load_robot("ur5e")
    solvers.solve_batch("analytic", arm, np.stack([_goal(arm)] * 16), np.zeros((16, 6)), threads=2)
    assert numba.threading_layer() == "tbb"
