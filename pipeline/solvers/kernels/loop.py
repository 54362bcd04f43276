"""The one compiled loop of the iterative IK methods: :func:`iterate` (issue 41, item 2).

The loop owns what every iterative method shares: the clocks (solve time, IK-block time, the
thread's CPU time), the copy of the start into ``q``, the first forward kinematics and trace row,
the stop rule (:func:`pipeline.solvers.kernels.kin.stop_rule`: non-finite error, success, stall,
growth, iteration cap), and the trace rows. A method supplies three compiled functions and its own
state (a tuple of scratch arrays it allocates):

``start(problem, q) -> (state, err, ok, stalled)``
    allocate the method's scratch, run the first forward kinematics at ``q`` (n,) and its error;
    ``err`` the scalar error the stop rule tests for finiteness and growth, ``ok`` the method's
    success test, ``stalled`` its stall test (a method whose start can already stall, else False).
``step(problem, state, q, it) -> (err, ok, stalled, ik_ns)``
    iteration ``it`` (1, 2, ...): update ``q`` in place, the forward kinematics and error at the new
    ``q``; ``ik_ns`` the nanoseconds of the IK block the method times (0 when it does not).
``record(problem, state, trace, row)``
    write trace row ``row`` (``TRACE_COLS`` floats) from the state.

``problem`` is the method's read-only input as one tuple (chain arrays, goal, packed settings): the
kernel's own arguments, which its caller keeps alive. A method's kernel is a few lines: it builds
``problem`` and calls :func:`iterate`, e.g. ``code, it, state = iterate(_start, _step, _record, problem,
q0, q, trace, times, NEVER, max_iter)``; ``state`` is returned for the method's own counters.

Compiled form. :func:`iterate` is inlined into each method's kernel (``inline="always"``): numba then
compiles one loop per method that calls the method's functions directly, and caches it on disk (a
compiled function passed as an argument to a function that is not inlined cannot be cached). The
step and record see ``problem`` and ``state`` as borrowed views (:func:`borrowed_tuple`): unpacking a
tuple of arrays otherwise costs two atomic reference-count operations per array per call, which made
a Jacobian-transpose iteration 0.25 us (80 %) slower; without them every method runs faster than its
hand-written loop did (benchmarks/loop_speed.py). Results are bit-identical to those loops
(benchmarks/loop_identity.py).
"""

from __future__ import annotations

import numba
import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from pipeline.solvers.kernels.kin import NEVER, TRACE_DP, now_ns, stop_rule, thread_cpu_ns


@numba.njit(cache=True, inline="always")
def iterate(start, step, record, problem, q0, q, trace, times, grow_limit, max_iter):
    """Run one iterative search from ``q0`` (n,) to a stop code.

    Writes the last iterate into ``q`` (n,), trace rows ``0..iterations`` into ``trace`` (k, TRACE_COLS)
    (rows past k are not written; k >= 1), and ``times`` (2,) or (3,) [ns]: the solve time (scratch
    allocation included), the IK-block time the step reports, and with three slots the thread's CPU
    time over the solve. ``grow_limit``: stop (DIVERGING) after the error grew this many iterations in
    a row (:data:`pipeline.solvers.kernels.kin.NEVER` to turn it off); ``max_iter``: the iteration cap.
    Returns ``(stop code, iterations, state)``.
    """
    clk = np.zeros(2, np.int64)
    cpu = times.shape[0] > 2
    c_start = thread_cpu_ns(clk) if cpu else 0
    t_start = now_ns(clk)
    for i in range(q0.shape[0]):
        q[i] = q0[i]
    own, err, ok, stalled = start(problem, q)
    state = borrowed_tuple(own)
    prob = borrowed_tuple(problem)
    record(prob, state, trace, 0)
    code = stop_rule(err, ok, stalled, 0, NEVER, 0, NEVER)
    rows = trace.shape[0]
    it = 0
    grew = 0
    t_ik = 0
    while code == 0:
        it += 1
        prev = err
        err, ok, stalled, dt = step(prob, state, q, it)
        t_ik += dt
        if it < rows:
            record(prob, state, trace, it)
        grew = grew + 1 if err > prev else 0
        code = stop_rule(err, ok, stalled, grew, grow_limit, it, max_iter)
    times[0] = now_ns(clk) - t_start
    times[1] = t_ik
    if cpu:
        times[2] = thread_cpu_ns(clk) - c_start
    keep_alive(problem)
    return code, it, own


@intrinsic
def borrowed_tuple(typingctx, tup):
    """``tup`` with every array in it as a view that carries no reference count (see
    :func:`pipeline.solvers.kernels.kin.borrowed`): unpacking a state tuple in a step then costs no
    atomic reference-count operations per array and iteration. Valid while the arrays' owners live."""
    if not isinstance(tup, types.BaseTuple):
        return None

    def codegen(context, builder, signature, args):
        val = args[0]
        for i, ty in enumerate(signature.args[0].types):
            if isinstance(ty, types.Array):
                ary = context.make_array(ty)(context, builder, builder.extract_value(val, i))
                ary.meminfo = cgutils.get_null_value(ary.meminfo.type)
                val = builder.insert_value(val, ary._getvalue(), i)
        return val

    return tup(tup), codegen


@intrinsic
def keep_alive(typingctx, x):
    """A use of ``x`` that does nothing: numba keeps ``x`` (and what it owns) alive until this point."""

    def codegen(context, builder, signature, args):
        return context.get_dummy_value()

    return types.none(x), codegen


# ---- trace rows the methods share (TRACE_COLS = 8 columns) -------------------------------------
@numba.njit(cache=True, inline="always")
def error_row(trace, row, err, e, dp):
    """Trace row ``row`` := ``[err, e (6), dp]``: a scalar error, the error 6-vector, |dp| [length unit]."""
    trace[row, 0] = err
    for r in range(6):
        trace[row, 1 + r] = e[r]
    trace[row, TRACE_DP] = dp


@numba.njit(cache=True)
def pose_row(trace, row, err, Tg, T, rv, pose):
    """Trace row ``row`` := ``[err, p_goal - p (3), rv (3) (0 when not pose), |p_goal - p|]`` of the pose
    ``T`` (4, 4) against the goal ``Tg``; ``rv`` (3,) the rotation vector the method computed."""
    trace[row, 0] = err
    trace[row, 1], trace[row, 2], trace[row, 3] = Tg[0, 3] - T[0, 3], Tg[1, 3] - T[1, 3], Tg[2, 3] - T[2, 3]
    if pose:
        trace[row, 4], trace[row, 5], trace[row, 6] = rv[0], rv[1], rv[2]
    else:
        trace[row, 4], trace[row, 5], trace[row, 6] = 0.0, 0.0, 0.0
    dx, dy, dz = trace[row, 1], trace[row, 2], trace[row, 3]
    trace[row, TRACE_DP] = np.sqrt(dx * dx + dy * dy + dz * dz)
