"""Wall time against thread CPU time of the same short compiled work, to see what machine load moves.

    python benchmarks/cpu_clock.py [--solves 20000] [--work 1500]

Runs ``--solves`` calls of a fixed compiled loop (``--work`` sines, about 14 µs here), each timed
inside compiled code with both clocks the solver kernels use (``pipeline.solvers.kernels.kin``: the
monotonic clock of ``solve_time_s`` and the thread CPU clock of ``cpu_time_s``), and prints the load
average and percentiles of both. Run it once on a quiet machine and once while a build loads it:
the wall-clock mean and tail follow the load, the CPU-time ones should not.
"""

from __future__ import annotations

import argparse
import os

import numba
import numpy as np

from pipeline.solvers.kernels.kin import CLOCK_MONOTONIC, CLOCK_THREAD_CPUTIME_ID, _clock_gettime, _data_ptr


@numba.njit
def _clock(buf, which):
    _clock_gettime(which, _data_ptr(buf))
    return buf[0] * 1000000000 + buf[1]


@numba.njit
def _work(n, x):
    s = 0.0
    for i in range(n):
        s += np.sin(x + i * 1e-3)
    return s


@numba.njit
def _run(m, n, out):
    buf = np.zeros(2, np.int64)
    acc = 0.0
    for k in range(m):
        w0 = _clock(buf, CLOCK_MONOTONIC)
        c0 = _clock(buf, CLOCK_THREAD_CPUTIME_ID)
        acc += _work(n, k * 1.0)
        c1 = _clock(buf, CLOCK_THREAD_CPUTIME_ID)
        w1 = _clock(buf, CLOCK_MONOTONIC)
        out[k, 0] = w1 - w0
        out[k, 1] = c1 - c0
    return acc


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--solves", type=int, default=20000, help="timed calls (default 20 000)")
    ap.add_argument("--work", type=int, default=1500, help="sines per call (default 1 500, about 14 µs)")
    args = ap.parse_args()
    out = np.zeros((args.solves, 2), np.int64)
    _run(10, args.work, out[:10])  # compile
    _run(args.solves, args.work, out)
    print(f"load average (1, 5, 15 min): {', '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for name, x in (("wall", out[:, 0] / 1e3), ("thread CPU", out[:, 1] / 1e3)):
        pct = ", ".join(f"p{p:g} {np.percentile(x, p):.2f}" for p in (1, 50, 90, 99, 99.9))
        print(f"{name:>10} [µs]: {pct}, max {x.max():.1f}, mean {x.mean():.3f}, CV {x.std() / x.mean():.3f}")


if __name__ == "__main__":
    main()
