"""What a method's first call costs in a fresh process with an empty numba cache.

Usage::

    python benchmarks/first_call.py [--cases ur5e:analytic,kuka_kr6_r700_sixx:analytic,...] [--json out.json]
    python benchmarks/first_call.py --readme        # the README's library example instead, twice

Each case runs in its own process (``python -c``, this checkout's package) with ``NUMBA_CACHE_DIR`` set to a
new empty folder, so every kernel the call needs compiles: load the shipped robot, bind the method with its
defaults, one call, then 200 more on other goals. Printed per case: the process's wall time and CPU time
(user + system, of the child, from ``resource.getrusage``), the first call's ``call_time_s`` and
``compiled`` flag, and the median of the 200 calls after it. ``--readme`` runs the README's library example
as written, once from an empty cache and once more with the cache it left. The load average is printed
beside each line: CPU time is what load does not move much; wall time is.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CASES = ["ur5e:analytic", "kuka_kr6_r700_sixx:analytic", "kinova_gen3:analytic", "ur5e:dls", "ur5e:levenberg_marquardt"]

CALL = """
import sys, time, numpy as np
from pipeline import kinematics, robots, solvers
arm = robots.load_robot(sys.argv[1])
ik = solvers.bind(sys.argv[2], arm)
n = len(arm.limits)
rng = np.random.default_rng(0)
goals = [kinematics.fk_htm(arm.chain, q) for q in rng.uniform(-1, 1, (201, n))]
first = ik.solve(goals[0], np.zeros(n))
times = [ik.solve(T, np.zeros(n)).call_time_s for T in goals[1:]]
print(f"RESULT first_call_us={first.call_time_s * 1e6:.0f} compiled={first.compiled} "
      f"median_us={np.median(times) * 1e6:.1f}")
"""


def readme_example() -> str:
    text = (ROOT / "README.md").read_text()
    i = text.index("## Use it as a library")
    s = text.index("```python", i) + len("```python")
    return text[s:text.index("```", s)]


def child(code: str, args: list[str], cache: str) -> dict:
    env = {**os.environ, "NUMBA_CACHE_DIR": cache, "PIPELINE_COMPILE_NOTICE": "0"}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", code, *args], cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode:
        raise SystemExit(f"{args}: exit {p.returncode}\n{p.stderr[-2000:]}")
    return {"wall_s": wall, "user_s": after.ru_utime - before.ru_utime, "sys_s": after.ru_stime - before.ru_stime,
            "stdout": p.stdout.strip().splitlines()[-1], "load": os.getloadavg()[0]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", default=",".join(CASES), help="ROBOT:METHOD,... (shipped robots)")
    ap.add_argument("--readme", action="store_true", help="the README's library example, first and second process")
    ap.add_argument("--json", type=Path)
    a = ap.parse_args(argv)
    rows = []
    if a.readme:
        with tempfile.TemporaryDirectory() as cache:
            for k in ("first process, empty cache", "second process"):
                r = child(readme_example(), [], cache)
                rows.append({"case": f"README example, {k}", **r})
    else:
        for case in a.cases.split(","):
            robot, method = case.split(":")
            with tempfile.TemporaryDirectory() as cache:
                r = child(CALL, [robot, method], cache)
            m = dict(re.findall(r"(\w+)=(\S+)", r["stdout"]))
            rows.append({"case": case, **r, **m})
    for r in rows:
        cpu = r["user_s"] + r["sys_s"]
        print(f"{r['case']:40s} wall {r['wall_s']:7.1f} s  CPU {cpu:7.1f} s ({r['user_s']:.1f} user + {r['sys_s']:.1f} "
              f"system)  load {r['load']:.2f}  | {r['stdout']}")
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
