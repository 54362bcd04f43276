"""Solver speed benchmark: per-solve time of each Jacobian method on random LWR problems.

Usage: python benchmarks/bench_solve.py [--problems 2000] [--seed 1]

Prints, per method, the median and the 5th/95th/99th percentiles of the per-solve time (measured
inside the compiled kernel with a monotonic clock), time per iteration, and the wall time of the
Python loop around the kernel (overhead of result handling and the independent FK check).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from pipeline.problems import random_joint_pairs
from pipeline.robots import load_robot
from pipeline.solvers import PreparedRobot, SolverSettings, solve

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--problems", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    model = load_robot(ROOT / "data" / "robots" / "kuka_lwr.yaml")
    ps = random_joint_pairs(model, args.problems, np.random.default_rng(args.seed))
    T = ps.goal_transforms()
    print(f"{'method':20s} {'success':>8s} {'p50 [us]':>9s} {'p5':>8s} {'p95':>8s} {'p99':>8s} {'us/iter p50':>11s} {'wall/solve [us]':>15s}")
    for method in ("jacobian_transpose", "pseudoinverse", "dls", "sdls"):
        s = SolverSettings(method=method)
        prep = PreparedRobot(model)
        solve(prep, T[0], ps.q_start[0], s)  # compile / load cache
        t0 = time.perf_counter()
        res = [solve(prep, T[i], ps.q_start[i], s) for i in range(len(ps))]
        wall = (time.perf_counter() - t0) / len(ps) * 1e6
        t = np.array([r.solve_time_s for r in res]) * 1e6
        per_it = t / np.maximum([r.iterations for r in res], 1)
        p5, p50, p95, p99 = np.percentile(t, [5, 50, 95, 99])
        ok = np.mean([r.success for r in res]) * 100
        print(f"{method:20s} {ok:7.1f}% {p50:9.1f} {p5:8.1f} {p95:8.1f} {p99:8.1f} {np.median(per_it):11.2f} {wall:15.1f}")


if __name__ == "__main__":
    main()
