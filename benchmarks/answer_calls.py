"""Every program to copy of a build's answer, run as written in a fresh process, against the bound call.

    python benchmarks/answer_calls.py [results] [--out benchmarks/results/answer_calls.txt]

For each distinct program of ``<results>/arm_benchmark/tables/answer.csv`` (one per arm and start set,
1 000 goals), runs it in a fresh interpreter exactly as written, then, in the same process and on the
same goals, the reference: ``bind(...).solve`` with the call's own clock (``IKResult.call_time_s``,
what the archives record). Prints per program the solved count, the program's median per call (its own
``time.perf_counter`` around ``ik.solve``), the reference median and their ratio, with the load average;
the issue's bar is a ratio within 2.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = """
ref = []
for T_goal, q_start in zip(goals, starts):
    ref.append(ik.solve(T_goal, q_start).call_time_s)
print(f"reference median {1e6 * np.median(ref):.2f} us")
"""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", nargs="?", default="results")
    ap.add_argument("--out", default=None, help="also write the table here")
    args = ap.parse_args(argv)
    ans = pd.read_csv(Path(args.results) / "arm_benchmark" / "tables" / "answer.csv", keep_default_na=False)
    rows = []
    for call, g in ans.groupby("call", sort=False):
        load = os.getloadavg()[0]
        proc = subprocess.run([sys.executable, "-c", call + REFERENCE], capture_output=True, text=True, cwd=ROOT)
        if proc.returncode:
            print(proc.stderr[-2000:], file=sys.stderr)
            return 1
        m = re.search(r"solved (\d+) of (\d+), median ([0-9.]+) us per call", proc.stdout)
        r = re.search(r"reference median ([0-9.]+) us", proc.stdout)
        rows.append({"arm x set": ", ".join(f"{a} {s}" for a, s in zip(g["robot"], g["problem set"])),
                     "label": g["recommendation"].iloc[0], "solved": f"{m.group(1)}/{m.group(2)}",
                     "program median [µs]": float(m.group(3)), "bind().solve median [µs]": float(r.group(1)),
                     "ratio": float(m.group(3)) / float(r.group(1)), "load 1 min": load})
        print(rows[-1], flush=True)
    out = pd.DataFrame(rows)
    text = out.to_string(index=False, float_format=lambda x: f"{x:.2f}")
    print(text)
    print(f"largest ratio {out['ratio'].max():.2f} (bar: 2)")
    if args.out:
        Path(args.out).write_text(text + f"\nlargest ratio {out['ratio'].max():.2f} (bar: 2)\n", encoding="utf-8")
    return 0 if out["ratio"].max() <= 2.0 else 1


if __name__ == "__main__":
    sys.exit(main())
