"""Solver speed benchmark: per-solve time of registered methods on seeded problems.

Usage: python benchmarks/bench_solve.py [--robot data/robots/kuka_lwr.yaml] [--problems 2000]
       [--kind warm_start|random_joint_pairs] [--seed 1] [--solvers dls sdls ...]

Prints, per solver: FK-verified success, the median and 5th/95th/99th percentiles of the per-solve
time (the method's own computation, pipeline/solvers/core/timing.py), the median time per iteration,
and the median time of the whole ``solve()`` call (Python overhead, conversion and FK check
included). Registry defaults are used; a solver that does not apply to the robot is skipped with
its one-line reason.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from pipeline.problems import random_joint_pairs, warm_start
from pipeline.robots import load_robot
from pipeline.solvers import NotApplicableError, get, make_settings, names, prepare, solve, warm_up

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robot", default=str(ROOT / "data" / "robots" / "kuka_lwr.yaml"))
    ap.add_argument("--problems", type=int, default=2000)
    ap.add_argument("--kind", choices=["warm_start", "random_joint_pairs"], default="warm_start")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--solvers", nargs="*", default=None, help="registered names (default: all)")
    args = ap.parse_args()
    model = load_robot(args.robot)
    rng = np.random.default_rng(args.seed)
    ps = warm_start(model, args.problems, rng) if args.kind == "warm_start" else random_joint_pairs(model, args.problems, rng)
    T = ps.goal_transforms()
    print(f"{model.name}, {len(ps)} {args.kind} problems")
    print(f"{'solver':22s} {'success':>8s} {'p50 [us]':>9s} {'p5':>8s} {'p95':>9s} {'p99':>9s} {'us/iter p50':>11s} {'call p50 [us]':>13s}")
    for name in args.solvers or names():
        s = make_settings(name)
        try:
            prep = prepare(name, model, s)
        except NotApplicableError as exc:
            print(f"{name:22s} skipped: {exc}")
            continue
        warm_up(name, prep, s)
        res = [solve(name, prep, T[i], ps.q_start[i], s, seed=i) for i in range(len(ps))]
        t = np.array([r.solve_time_s for r in res]) * 1e6
        call = np.array([r.call_time_s for r in res]) * 1e6
        per_it = t / np.maximum([r.iterations for r in res], 1)
        p5, p50, p95, p99 = np.percentile(t, [5, 50, 95, 99])
        ok = np.mean([r.success for r in res]) * 100
        print(f"{name:22s} {ok:7.1f}% {p50:9.1f} {p5:8.1f} {p95:9.1f} {p99:9.1f} {np.median(per_it):11.2f} "
              f"{np.median(call):13.1f}  [{get(name).kind}]", flush=True)


if __name__ == "__main__":
    main()
