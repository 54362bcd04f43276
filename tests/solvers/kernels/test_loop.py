"""The one loop of the iterative methods (pipeline.solvers.kernels.loop.iterate, issue 41 item 2): its stop rule,
cap, growth count, trace rows and clocks on a toy method, and every method that runs in it stopping at its
start on a non-finite goal."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from pipeline import kinematics, robots, solvers
from pipeline.io.layout import StopReason
from pipeline.solvers.kernels.kin import NEVER, TRACE_COLS
from pipeline.solvers.kernels.loop import iterate

LOOP_METHODS = ("jacobian_transpose", "pseudoinverse", "dls", "sdls", "inverse_jacobian_fd", "levenberg_marquardt",
                "pso", "jpinv_descent", "zero_position", "newton_raphson", "geometric_iterative")


# a toy method: q <- q * factor; error |q|; success below tol; "stall" when |q| hits a given value
@numba.njit
def _start(problem, q):
    m = np.empty(1)
    m[0] = np.abs(q).sum()
    return (m,), m[0], m[0] < problem[1], False


@numba.njit
def _step(problem, state, q, it):
    factor, tol, stall_at = problem
    for i in range(q.shape[0]):
        q[i] *= factor
    m = state[0]
    m[0] = np.abs(q).sum()
    return m[0], m[0] < tol, m[0] == stall_at, 7


@numba.njit
def _record(problem, state, trace, row):
    trace[row, :] = row
    trace[row, 0] = state[0][0]


@numba.njit
def _toy(q0, factor, tol, stall_at, grow_limit, max_iter, q, trace, times):
    code, it, state = iterate(_start, _step, _record, (factor, tol, stall_at), q0, q, trace, times, grow_limit,
                              max_iter)
    return code, it


def _run(q0, factor, tol=1e-3, stall_at=-1.0, grow_limit=NEVER, max_iter=50, rows=60, clocks=3):
    q, trace, times = np.empty(len(q0)), np.full((rows, TRACE_COLS), -1.0), np.zeros(clocks, np.int64)
    code, it = _toy(np.asarray(q0, float), factor, tol, stall_at, grow_limit, max_iter, q, trace, times)
    return int(code), int(it), q, trace, times


def test_success_cap_growth_stall_and_non_finite():
    code, it, q, trace, times = _run([1.0, -1.0], 0.5)
    assert code == StopReason.SUCCESS and it == 11 and np.allclose(q, [0.5 ** 11, -0.5 ** 11])
    assert np.array_equal(trace[: it + 1, 0], 2.0 * 0.5 ** np.arange(it + 1)) and np.all(trace[it + 1:] == -1.0)
    assert times[0] > 0 and times[1] == 7 * it and times[2] > 0
    assert _run([1.0], 1.0, max_iter=9)[:2] == (StopReason.ITERATION_CAP, 9)
    assert _run([1.0], 2.0, grow_limit=3)[:2] == (StopReason.DIVERGING, 3)
    assert _run([1.0], 0.5, stall_at=0.125)[:2] == (StopReason.STALLED, 3)
    assert _run([1.0], np.inf)[:2] == (StopReason.NON_FINITE, 1)
    assert _run([np.nan], 0.5)[:2] == (StopReason.NON_FINITE, 0)  # tested at the start too
    assert _run([1e-4], 0.5)[:2] == (StopReason.SUCCESS, 0)


def test_rows_past_the_trace_are_not_written_and_two_clocks_are_enough():
    code, it, q, trace, times = _run([1.0], 1.0, max_iter=20, rows=4, clocks=2)
    assert (code, it) == (StopReason.ITERATION_CAP, 20) and trace.shape == (4, TRACE_COLS)
    assert np.array_equal(trace[:, 1], np.arange(4.0)) and times[1] == 7 * 20


@pytest.mark.parametrize("method", LOOP_METHODS)
def test_a_non_finite_goal_stops_every_loop_method_at_its_start(method):
    arm = robots.load_robot("ur5e")
    T = kinematics.fk_htm(arm.chain, np.full(6, 0.3))
    T[0, 3] = np.nan
    settings = {"criterion": "position"} if method == "geometric_iterative" else {}
    r = solvers.solve(method, arm, T, np.zeros(6), settings)
    assert r.stop_reason == StopReason.NON_FINITE and r.iterations == 0 and len(r.trace) == 1 and not r.success
