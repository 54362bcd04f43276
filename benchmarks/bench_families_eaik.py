"""``analytic`` against EAIK per geometry family, on random arms of each (tests/solvers/closed_form/family_arms.py).

Usage::

    PYTHONPATH=$PWD python benchmarks/bench_families_eaik.py [--arms 200] [--goals 10] [--dense 50]
                                                             [--kinds sph_general,...] [--out FILE.md]

For every family of :data:`tests.solvers.closed_form.family_arms.FAMILIES`, ``--arms`` random arms (seeded: arm k of family f
from ``default_rng(10_000 f + k)``) and ``--goals`` goals each (FK of random joint vectors):

- completeness: whether our public call ``pipeline.solvers.solve('analytic', ...)`` returns the
  generating joint vector (within 1e-7 rad, mod 2π) and every solution FK-valid, whether it refuses the
  arm, and the same for EAIK where it applies; on the first ``--dense`` arms (one goal each) the
  solution count of each against a dense Levenberg-Marquardt search from 400 random starts
  (:func:`tests.solvers.closed_form.family_arms.dense_search`, a lower bound of the true count);
- speed, paired and interleaved: on each goal our whole public call (timed around ``solve``: the closed
  form, every candidate's FK check, the independent check of the chosen one, the result object) and
  EAIK's library call alone (``robot.IK(T)`` and reading its answers: the peer's ``solve_time_s``), in
  alternating order goal by goal, so a slow phase of the shared machine hits both. Reported: the
  medians over all goals of the family and the median of the per-goal ratio ours / EAIK.

CPU time of the process is printed with each family; the load average at the start and the end.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pipeline.solvers import make_settings, solve  # noqa: E402
from pipeline.solvers.core import NotApplicableError, Prepared  # noqa: E402
from pipeline.solvers.core.registry import get  # noqa: E402
from tests.solvers.closed_form import family_arms as fa  # noqa: E402

MATCH_TOL = 1e-7  # the generating joint vector is among the solutions [rad]


def _solves(prep, T, q0, st, name):
    """(result or None when refused, wall time of the public call [µs])."""
    t0 = time.perf_counter_ns()
    try:
        r = solve(name, prep, T, q0, st)
    except NotApplicableError:
        return None, math.nan
    return r, (time.perf_counter_ns() - t0) * 1e-3


def _arm_rows(kind: int, k: int, kname: str, goals: int, dense: bool, st: dict) -> dict:
    rng = np.random.default_rng(10_000 * kind + k)
    m = fa.arm(kname, rng)
    prep = Prepared(m)
    Q, Ts = fa.goals(m, rng, goals)
    q0 = rng.uniform(-math.pi, math.pi, (goals, 6))
    eaik = get("eaik").refusal(prep) is None
    out = {"ours_us": [], "eaik_us": [], "ratio": [], "ours_found": 0, "eaik_found": 0, "ours_refused": 0,
           "eaik_applies": int(eaik), "goals": goals, "ours_nsol": [], "eaik_nsol": [], "dense": [],
           "ours_family": None}
    r, _ = _solves(prep, Ts[0], q0[0], st["analytic"], "analytic")  # compile / bind once
    if r is None:
        out["ours_refused"] = 1
    else:
        out["ours_family"] = r.info.get("family")
    if eaik:
        solve("eaik", prep, Ts[0], q0[0], st["eaik"])
    for i in range(goals):
        first_ours = i % 2 == 0
        for who in (("analytic", "eaik") if first_ours else ("eaik", "analytic")):
            if who == "analytic" and r is not None:
                ro, us = _solves(prep, Ts[i], q0[i], st["analytic"], "analytic")
                out["ours_us"].append(us)
                out["ours_found"] += fa.gap(ro.solutions, Q[i]) < MATCH_TOL and ro.success
                out["ours_nsol"].append(len(ro.solutions))
            elif who == "eaik" and eaik:
                re_ = solve("eaik", prep, Ts[i], q0[i], st["eaik"])
                out["eaik_us"].append(re_.solve_time_s * 1e6)
                out["eaik_found"] += fa.gap(re_.solutions, Q[i]) < MATCH_TOL
                out["eaik_nsol"].append(len(re_.solutions))
        if r is not None and eaik:
            out["ratio"].append(out["ours_us"][-1] / out["eaik_us"][-1])
    if dense:
        found = fa.dense_search(m, Ts[0], rng)
        out["dense"].append((len(found), out["ours_nsol"][0] if out["ours_nsol"] else -1,
                             out["eaik_nsol"][0] if out["eaik_nsol"] else -1))
    return out


def family(kind: int, kname: str, arms: int, goals: int, dense: int) -> dict:
    st = {"analytic": make_settings("analytic", {}), "eaik": make_settings("eaik", {})}
    c0 = time.process_time()
    rows = [_arm_rows(kind, k, kname, goals, k < dense, st) for k in range(arms)]
    agg = {key: sum(r[key] for r in rows) for key in ("ours_found", "eaik_found", "ours_refused", "eaik_applies")}
    cat = {key: [x for r in rows for x in r[key]] for key in ("ours_us", "eaik_us", "ratio", "dense")}
    fams = sorted({str(r["ours_family"]) for r in rows})
    ours_goals = sum(len(r["ours_us"]) for r in rows)
    eaik_goals = sum(len(r["eaik_us"]) for r in rows)
    d = np.array(cat["dense"]).reshape(-1, 3)
    return {"kind": kname, "arms": arms, "goals": goals, "families": fams, **agg, "ours_goals": ours_goals,
            "eaik_goals": eaik_goals, "ours_p50": float(np.median(cat["ours_us"])) if cat["ours_us"] else math.nan,
            "eaik_p50": float(np.median(cat["eaik_us"])) if cat["eaik_us"] else math.nan,
            "ratio_p50": float(np.median(cat["ratio"])) if cat["ratio"] else math.nan,
            "dense_n": len(d), "ours_eq_dense": int((d[:, 1] == d[:, 0]).sum()) if len(d) else 0,
            "eaik_eq_dense": int(((d[:, 2] == d[:, 0]) & (d[:, 2] >= 0)).sum()) if len(d) else 0,
            "ours_lt_dense": int((d[:, 1] < d[:, 0]).sum()) if len(d) else 0,
            "cpu_s": time.process_time() - c0}


def table(rows: list, head: str) -> str:
    lines = [head, "", "| family (generator) | `analytic` family | arms | ours refused | ours: generating solution "
             "returned | EAIK applies (arms) | EAIK: generating returned | counts = dense search (ours / EAIK / "
             "sample) | ours median [µs] | EAIK median [µs] | median ratio ours/EAIK |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['kind']} | {', '.join(r['families'])} | {r['arms']} | {r['ours_refused']} | "
                     f"{r['ours_found']}/{r['ours_goals']} | {r['eaik_applies']} | "
                     f"{r['eaik_found']}/{r['eaik_goals']} | "
                     f"{r['ours_eq_dense']} / {r['eaik_eq_dense']} / {r['dense_n']} | {r['ours_p50']:.2f} | "
                     f"{r['eaik_p50']:.2f} | {r['ratio_p50']:.2f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--arms", type=int, default=200)
    ap.add_argument("--goals", type=int, default=10)
    ap.add_argument("--dense", type=int, default=50)
    ap.add_argument("--kinds", default=",".join(fa.FAMILIES))
    ap.add_argument("--out")
    a = ap.parse_args(argv)
    load0 = os.getloadavg()[0]
    rows = []
    kinds = list(fa.FAMILIES)
    for kname in a.kinds.split(","):
        r = family(kinds.index(kname), kname, a.arms, a.goals, a.dense)
        rows.append(r)
        print(f"{kname:28s} ours {r['ours_found']}/{r['ours_goals']} (refused {r['ours_refused']}) | EAIK "
              f"{r['eaik_found']}/{r['eaik_goals']} on {r['eaik_applies']} arms | dense = ours {r['ours_eq_dense']}"
              f"/{r['dense_n']} (fewer {r['ours_lt_dense']}), EAIK {r['eaik_eq_dense']} | ours {r['ours_p50']:.2f} us "
              f"EAIK {r['eaik_p50']:.2f} us ratio {r['ratio_p50']:.2f} | cpu {r['cpu_s']:.0f} s", flush=True)
    head = (f"Random arms per family (tests/solvers/closed_form/family_arms.py), {a.arms} arms x {a.goals} goals, dense-search sample "
            f"{a.dense} arms x 1 goal; load average (1 min) {load0:.2f} at the start, {os.getloadavg()[0]:.2f} at "
            f"the end; {os.cpu_count()} cores.")
    text = table(rows, head)
    print(text)
    if a.out:
        Path(a.out).write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
