"""Per-solve time of the iterative methods (their own ``solve_time_s``), to compare two builds of the loop.

Usage::

    python benchmarks/loop_speed.py [--methods dls,newton_raphson] [--problems 200] [--passes 5] [--json out.json]

For each method and robot (KUKA LWR 7-DoF, UR5e), ``--problems`` seeded problems (goal uniform in the
search box, start near it), each solved ``--passes`` times (passes 0.2 s apart; a problem's fastest
time stands for it, as ``timeit`` advises on this shared machine); prints the median over the problems
of that fastest time and of the thread CPU time where the method reports it, and the median
iterations. Run the same command on each build alternately, several times, and compare medians.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DEFAULT = ("jacobian_transpose,pseudoinverse,dls,sdls,newton_raphson,zero_position,geometric_iterative,"
           "levenberg_marquardt,inverse_jacobian_fd")


def main() -> int:
    sys.path.insert(0, str(ROOT))
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from loop_identity import problems
    from pipeline.robots import load_robot
    from pipeline.solvers import NotApplicableError, SettingsError, bind, make_settings, prepare, warm_up

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--methods", default=DEFAULT)
    ap.add_argument("--robots", default="kuka_lwr,ur5e")
    ap.add_argument("--problems", type=int, default=200)
    ap.add_argument("--passes", type=int, default=5)
    ap.add_argument("--json")
    a = ap.parse_args()
    out = {}
    for r in a.robots.split(","):
        model = load_robot(ROOT / "data" / "robots" / f"{r}.yaml")
        goals, starts = problems(model, a.problems, 3)
        for name in a.methods.split(","):
            mapping = {"criterion": "position"} if name == "geometric_iterative" else {}
            try:
                s = make_settings(name, mapping)
                prep = prepare(name, model, s)
            except (SettingsError, NotApplicableError):
                continue
            warm_up(name, prep, s)
            b = bind(name, prep, s)
            wall = np.empty((a.passes, a.problems))
            cpu = np.full((a.passes, a.problems), np.nan)
            iters = np.empty(a.problems)
            for p in range(a.passes):
                for i in range(a.problems):
                    res = b.solve(goals[i], starts[i], i)
                    wall[p, i] = res.solve_time_s
                    cpu[p, i] = res.info.get("cpu_time_s", np.nan)
                    iters[i] = res.iterations
                time.sleep(0.2)
            best = wall.min(axis=0)
            out[f"{name}/{r}"] = {"p50_us": float(np.median(best)) * 1e6, "p50_all_us": float(np.median(wall)) * 1e6,
                                  "cpu_p50_us": float(np.median(np.nanmin(cpu, axis=0))) * 1e6
                                  if np.isfinite(cpu).any() else None,
                                  "iterations_p50": float(np.median(iters))}
            v = out[f"{name}/{r}"]
            print(f"{name:22s} {r:10s} best p50 {v['p50_us']:9.2f} us  all p50 {v['p50_all_us']:9.2f} us  "
                  f"iters {v['iterations_p50']:.0f}  load {os.getloadavg()[0]:.2f}", flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
