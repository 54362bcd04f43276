"""A batch of goals against the same goals solved one bound call at a time, interleaved in one process.

Usage::

    python benchmarks/batch_vs_single.py [--goals 500] [--rounds 9] [--method analytic]
                                         [--robots kuka_kr6_r700_sixx,ur5e,fanuc_crx10ia,kinova_gen3,general_100]
                                         [--json out.json]

For each arm (by default one per closed-form family: a spherical wrist, three parallel axes (UR), an
offset wrist solved by a one-dimensional search, a 7R arm through its swept joint, and ``general_N``: the
random 6R arm of seed N of ``benchmarks/closed_form.py``, which no family fits, solved by the general
elimination), ``--goals`` goals
(FK of joint angles uniform within the limits, seed 11) and starts (likewise) are solved

* ``single``: one bound call per goal (``ik = pipeline.solvers.bind(method, arm)``, ``ik.solve``), the
  loop a user writes;
* ``batch t=1`` and ``batch t=2``: ``pipeline.solvers.solve_batch(method, arm, goals, starts,
  threads=...)``, the public call with its default traces.

Each is called once untimed first (compilation, loading the kernels). Then ``--rounds`` rounds, each
running the three in an order shuffled per round (seed 5), so that a slow phase of the machine hits
each alike; per round the time of the whole loop or call divided by the goals: wall time
(``perf_counter``) and the process's CPU time (``process_time``, every thread). Reported: the first
timed round, the median and the 90th percentile over the rounds, and per arm the verdict on the
medians of wall time: batch per goal below the single call's (at 1 thread, and at 2). The batch and
the single calls agree on every goal's success and joint values (checked each run).

The machine is shared; the load average is printed at the start and the end.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from pipeline import kinematics, robots, solvers

DEFAULT_ROBOTS = ["kuka_kr6_r700_sixx", "ur5e", "fanuc_crx10ia", "kinova_gen3", "general_100"]


def problems(arm, n: int, seed: int = 11):
    """``n`` goals (n, 4, 4) in the robot file's unit and starts (n, joints), uniform within the limits."""
    lim = np.where(np.isfinite(arm.limits), arm.limits, np.array([-np.pi, np.pi]))
    rng = np.random.default_rng(seed)
    q = rng.uniform(lim[:, 0], lim[:, 1], (n, len(lim)))
    q0 = rng.uniform(lim[:, 0], lim[:, 1], (n, len(lim)))
    return np.array([kinematics.fk_htm(arm.chain, x) for x in q]), q0


def run(robot: str, method: str, goals: int, rounds: int) -> dict:
    if robot.startswith("general_"):  # a random 6R arm no family fits (benchmarks/closed_form.py, seed N)
        from closed_form import general_arm

        arm = general_arm(int(robot.split("_")[1]), "standard", "m")
    else:
        arm = robots.load_robot(robot)
    G, S = problems(arm, goals)
    ik = solvers.bind(method, arm)

    def single():
        return [ik.solve(G[i], S[i]) for i in range(goals)]

    def batch1():
        return solvers.solve_batch(method, arm, G, S, threads=1)

    def batch2():
        return solvers.solve_batch(method, arm, G, S, threads=2)

    ways = {"single": single, "batch t=1": batch1, "batch t=2": batch2}
    first = {k: f() for k, f in ways.items()}  # untimed: compiles or loads the kernels
    one, many = first["single"], first["batch t=1"]
    agree = bool(np.array_equal([r.success for r in one], many.success)
                 and np.allclose(np.array([r.q for r in one]), many.q, rtol=0, atol=1e-12))
    rng = np.random.default_rng(5)
    wall = {k: [] for k in ways}
    cpu = {k: [] for k in ways}
    names = list(ways)
    for _ in range(rounds):
        for k in rng.permutation(names):
            c0, t0 = time.process_time(), time.perf_counter()
            ways[k]()
            wall[k].append((time.perf_counter() - t0) / goals * 1e6)
            cpu[k].append((time.process_time() - c0) / goals * 1e6)
    out = {"robot": robot, "method": method, "goals": goals, "rounds": rounds, "agree": agree,
           "family": one[0].info.get("family", ""), "solved": int(sum(r.success for r in one))}
    for k in names:
        out[k] = {"wall_us_per_goal": {"first": wall[k][0], "p50": float(np.median(wall[k])),
                                       "p90": float(np.percentile(wall[k], 90))},
                  "cpu_us_per_goal": {"first": cpu[k][0], "p50": float(np.median(cpu[k])),
                                      "p90": float(np.percentile(cpu[k], 90))}}
    s = out["single"]["wall_us_per_goal"]["p50"]
    out["batch_t1_below_single"] = out["batch t=1"]["wall_us_per_goal"]["p50"] < s
    out["batch_t2_below_single"] = out["batch t=2"]["wall_us_per_goal"]["p50"] < s
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--goals", type=int, default=500)
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--method", default="analytic")
    ap.add_argument("--robots", default=",".join(DEFAULT_ROBOTS))
    ap.add_argument("--json", type=Path)
    a = ap.parse_args(argv)
    print(f"load average at start: {os.getloadavg()}; cores: {os.cpu_count()}")
    rows = []
    for robot in a.robots.split(","):
        r = run(robot, a.method, a.goals, a.rounds)
        rows.append(r)
        print(f"\n{robot} ({r['family']}), {a.method}, {a.goals} goals, solved {r['solved']}, batch = single "
              f"call on every goal: {r['agree']}")
        print(f"  {'':10s} {'wall µs/goal: first':>20s} {'p50':>8s} {'p90':>8s}   {'CPU µs/goal: first':>19s} "
              f"{'p50':>8s} {'p90':>8s}")
        for k in ("single", "batch t=1", "batch t=2"):
            w, c = r[k]["wall_us_per_goal"], r[k]["cpu_us_per_goal"]
            print(f"  {k:10s} {w['first']:20.2f} {w['p50']:8.2f} {w['p90']:8.2f}   {c['first']:19.2f} "
                  f"{c['p50']:8.2f} {c['p90']:8.2f}")
        print(f"  batch below single (median wall): t=1 {r['batch_t1_below_single']}, t=2 {r['batch_t2_below_single']}")
    print(f"\nload average at end: {os.getloadavg()}")
    if a.json:
        a.json.write_text(json.dumps({"load_end": os.getloadavg(), "rows": rows}, indent=1))
    return 0 if all(r["batch_t1_below_single"] and r["batch_t2_below_single"] and r["agree"] for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
