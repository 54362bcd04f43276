"""TRAC-IK's cold-start solve rate on the Panda and the iiwa 14, against its published table.

Usage::

    python benchmarks/trac_ik_rates.py [--goals 300] [--robots franka_panda,kuka_iiwa14] [--json out.json]

The goals are ``arm_benchmark``'s cold set (seed 31, start and goal uniform within the limits), the
first ``--goals`` of it, written by the ``make_problems`` verb exactly as the build writes them.
Each robot is solved with the study's two TRAC-IK labels (``trac_ik``: 5 ms, ``trac_ik_20ms``) with
``require_limits``, through the same runner as the build. Printed per label: FK-verified success with
its Wilson 95 % interval; how many returned solutions lie beyond a limit by more than 1e-9 rad but
within the one tolerance 1e-6 rad (``LIMIT_TOL``: the float32 rounding of TRAC-IK's limits), i.e. the
successes the old 1e-9 test refused; and the job's CPU share (CPU / wall time of the solving), since
TRAC-IK's budget is wall time and a busy machine lowers its rate. Published (Beeson & Ames 2015,
TRAC-IK's README table, 5 ms): Panda 99.7 %, iiwa 14 99.84 %.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
PUBLISHED = {"franka_panda": 99.7, "kuka_iiwa14": 99.84}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--goals", type=int, default=300)
    ap.add_argument("--robots", default="franka_panda,kuka_iiwa14")
    ap.add_argument("--json")
    args = ap.parse_args()
    from pipeline.io.problems import read_problems
    from pipeline.robots import load_robot
    from pipeline.runner import solve_set_batches
    from pipeline.settings import load_study
    from pipeline.solvers.core import within_limits
    from pipeline.studies.arm_benchmark import wilson

    study = load_study(ROOT / "data" / "studies" / "arm_benchmark.yaml")
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for robot in args.robots.split(","):
            path = Path(tmp) / f"{robot}.csv.gz"
            subprocess.run([sys.executable, "-m", "pipeline", "make_problems", "--study",
                            str(ROOT / "data" / "studies" / "arm_benchmark.yaml"), "--problem-set", "cold", "--robot",
                            str(ROOT / "data" / "robots" / f"{robot}.yaml"), "--out", str(path)], check=True,
                           cwd=ROOT, capture_output=True)
            ps, _ = read_problems(path)
            ps = ps.head(args.goals)
            model = load_robot(ROOT / "data" / "robots" / f"{robot}.yaml")
            for label in ("trac_ik", "trac_ik_20ms"):
                entry = study.solvers[label]
                ok = tight = 0
                c0, w0 = time.process_time(), time.perf_counter()
                for rows, _, _, res in solve_set_batches(entry.method, entry.settings, model, ps, set_seed=31):
                    ok += int(res.success.sum())
                    for q, s in zip(res.q, res.success):
                        if s and not within_limits(q, model.limits, model.chain.prismatic, tol=1e-9):
                            tight += 1
                share = (time.process_time() - c0) / (time.perf_counter() - w0)
                lo, hi = wilson(ok, len(ps))
                row = {"robot": robot, "label": label, "goals": len(ps), "success_pct": 100 * ok / len(ps),
                       "ci95": [100 * lo, 100 * hi], "successes_beyond_1e-9_within_1e-6": tight,
                       "cpu_share": share, "published_pct_5ms": PUBLISHED.get(robot)}
                out.append(row)
                print(f"{robot:14s} {label:13s} {row['success_pct']:6.2f} % of {len(ps)} (95 % CI {100 * lo:.1f}-"
                      f"{100 * hi:.1f}); {tight} successes beyond a limit by 1e-9..1e-6 rad; CPU share {share:.2f}; "
                      f"published (5 ms) {PUBLISHED.get(robot)} %", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
