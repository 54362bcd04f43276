"""The periodic CPU charge in the Jacobian batch kernel's per-solve times, before and after the fix.

Usage::

    python benchmarks/periodic_charge.py [--problems 2000] [--runs 3] [--method dls] [--json out.json]

An audit of a full cerbaro2019 build found 1.3-1.5 % of solves carrying ~170 µs more thread CPU time,
every 65-66 problems, at the same positions in every 2 000-problem batch and for every method. The
suspect: the batch's trace buffer, N x (max_iterations + 1) x 8 float64 (501 x 64 B = 32 064 B per
problem at cerbaro's 500-iteration cap), is allocated by ``np.empty`` and first written inside the
timed solves. numpy asks the kernel for transparent huge pages on large arrays (``madvise``), so the
first write into each 2 MiB page faults and zeroes the whole page (~170 µs), charged to the thread
that wrote it: every 2 MiB / 32 064 B = 65.4 problems.

The script solves ``--problems`` cerbaro2019 problems (the study's random set, seed 20191125) with
its ``--method`` settings through ``pipeline.solvers.solve_batch``, ``--runs`` times each way,
interleaved:

* ``before``: the kernel writing into a fresh ``np.empty`` trace buffer, as before issue 45 (the
  script wraps the kernel to do so);
* ``as built``: the kernel as the pipeline calls it, on a trace buffer written once before the timed
  solves (``pipeline/solvers/iterative/jacobian.py`` since issue 45).

Per way: the median and the 99th percentile of the per-solve CPU time, the share of solves more than
100 µs above the median of their problem over the runs' fastest, and the positions (mod 2 MiB of trace)
where the excess sits. The machine's load is printed at the start and the end.
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problems", type=int, default=2000)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--method", default="dls", help="a cerbaro2019 solver label")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)

    import pipeline.solvers.iterative.lean as lean
    from pipeline.problems import random_joint_pairs
    from pipeline.robots import load_robot
    from pipeline.runner import model_goals
    from pipeline.settings import load_study
    from pipeline.solvers import prepare, solve_batch, warm_up

    print(f"load at start: {os.getloadavg()}")
    study = load_study(ROOT / "data" / "studies" / "cerbaro2019.yaml")
    entry = study.solvers[args.method]
    model = load_robot(ROOT / "data" / "robots" / "kuka_lwr.yaml")
    ps = random_joint_pairs(model, args.problems, np.random.default_rng(20191125))
    goals, starts = model_goals(ps, model), ps.q_start
    prep = prepare(entry.method, model, entry.settings)
    warm_up(entry.method, prep, entry.settings)
    original = lean.solve_batch

    def untouched(*a):
        """The kernel on a fresh ``np.empty`` trace buffer (as before issue 45), copied back afterwards."""
        fresh = np.empty(a[-1].shape)
        out = original(*a[:-1], fresh)
        a[-1][...] = fresh
        return out

    ways = {"before": untouched, "as built": original}
    cpu = {w: [] for w in ways}
    try:
        for r in range(args.runs):
            for w in (list(ways) if r % 2 == 0 else list(ways)[::-1]):
                lean.solve_batch = ways[w]
                res = solve_batch(entry.method, prep, goals, starts, entry.settings, seeds=np.zeros(len(goals), np.int64))
                cpu[w].append(np.asarray(res.cpu_times_s) * 1e6)
    finally:
        lean.solve_batch = original
    per_problem = 32064 if entry.settings.max_iterations == 500 else 8 * 8 * (entry.settings.max_iterations + 1)
    out = {}
    best = np.minimum.reduce([np.min(cpu[w], axis=0) for w in ways])  # each problem's undisturbed time
    for w in ways:
        t = np.array(cpu[w])
        excess = t - best
        spikes = excess > 100.0
        pos = (np.nonzero(spikes)[1] * per_problem) % (2 * 2**20) if spikes.any() else np.array([])
        out[w] = {"median_us": float(np.median(t)), "p99_us": float(np.percentile(t, 99)),
                  "share_above_100us_pct": 100 * float(spikes.mean()),
                  "mean_excess_of_spikes_us": float(excess[spikes].mean()) if spikes.any() else 0.0,
                  "spike_problem_indices_run0": [int(i) for i in np.nonzero(spikes[0])[0][:12]],
                  "spike_offsets_in_2MiB_page_B_median": float(np.median(pos)) if len(pos) else None,
                  "cv_pct": 100 * float(np.mean([np.std(x, ddof=1) / np.mean(x) for x in t]))}
        print(f"{w:9s} median {out[w]['median_us']:.1f} µs, p99 {out[w]['p99_us']:.1f} µs, "
              f"{out[w]['share_above_100us_pct']:.2f} % of solves > 100 µs above their fastest "
              f"(mean excess {out[w]['mean_excess_of_spikes_us']:.0f} µs), CV {out[w]['cv_pct']:.0f} %, "
              f"first spikes at problems {out[w]['spike_problem_indices_run0']}")
    print(f"load at end: {os.getloadavg()}")
    if args.json:
        args.json.write_text(json.dumps({"method": args.method, "problems": args.problems, "runs": args.runs,
                                         "ways": out}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
