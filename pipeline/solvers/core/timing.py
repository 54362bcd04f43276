"""The one timing definition of every solve (written down once; docs/solvers.md "Timing, one definition" says the same).

``solve_time_s``
    The method's own computation for one problem: from its first to its last operation, excluding
    the conversion of inputs and the independent FK check, on the monotonic clock
    (``CLOCK_MONOTONIC``). Compiled methods read the clock inside the kernel
    (:func:`pipeline.solvers.kernels.kin.now_ns`); methods whose loop is a library call (SciPy's
    optimisers) read it around that call with :func:`clock_ns`, which is the same clock on Linux.
    It is wall time on one core: a job runs one solve at a time with one BLAS thread.
``ik_time_s``
    The part of ``solve_time_s`` spent in the method's update step (the "IK block" of
    000_7e3cb7ad5ee98ff0.txt) where a method measures it, else 0.
``call_time_s``
    The whole :func:`pipeline.solvers.solve` call as a user sees it: settings lookup, unit
    conversion, the kernel, the FK check and building the result.

``cpu_time_s``
    The CPU time of the solving thread: read by the Jacobian loop's kernel around the same work as
    ``solve_time_s`` (:func:`pipeline.solvers.kernels.kin.thread_cpu_ns`, ``CLOCK_THREAD_CPUTIME_ID``), else by the
    runner around each call (of the whole process for a method with threads of its own, TRAC-IK), or
    the process's around another batch kernel, shared out over its problems by their solve times.
    Time the thread waits for a core is not counted, so this is the measure machine load does not
    move: with the load average at 6.8 on 2 cores, 20 000 solves of 14 µs had a mean wall time of
    54 µs (CV 15.7, scheduler outliers up to 57 ms) and a mean thread CPU time of 13.6 µs (CV 0.15;
    ``benchmarks/cpu_clock.py``). The document studies' time tables and claims use it. Σ cpu / Σ
    call over a job is its CPU share; below 0.9 the job did not get a core to itself and its
    wall-clock times (and any wall-clock budget, TRAC-IK's) are suspect
    (:mod:`pipeline.studies.arm_benchmark` flags it).

Every archive's ``/ik/solve`` records carry all four (``cpu_time_s`` from format 5's field 24 on;
older archives read NaN); tables say which one they use.
"""

from __future__ import annotations

import time

clock_ns = time.perf_counter_ns  # CLOCK_MONOTONIC on Linux, like the kernels' now_ns
