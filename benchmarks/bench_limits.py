"""Limits-aware Jacobian searches (issue 43, item 2): success with and without ``search_limits``.

Usage::

    python benchmarks/bench_limits.py [--goals 500] [--robots franka_panda,kuka_iiwa14]
                                      [--methods dls,sdls,pseudoinverse,levenberg_marquardt]
                                      [--modes off,clamp,reflect]
                                      [--restart-modes off,clamp,reflect] [--out results.md]

Goals: ``arm_benchmark``'s cold set (seed 31, start and goal uniform within the limits), drawn as the
``make_problems`` verb draws it (the full 2 000) and its first ``--goals`` kept. Each method runs with
the study's own label settings (``dls``, ``dls_restarts``, ...: 100 iterations, SDLS 300, ``require_limits``,
restarts 20), once per ``search_limits`` mode; nothing else changes between the rows of one method, so
each row differs from ``off`` by the setting alone. Every success is the driver's FK-checked, within-limits
success (``IKResult.success``). One extra row per arm, ``dls`` ``reflect`` tuned (500 iterations, no growth
stop, damping 0.02), whose settings were chosen on another goal set (seed 777), never on these goals.

One process; per goal, every (method, mode, search) configuration is called in a shuffled order (seeded),
so that load lands on every row alike. Per row: success with its Wilson 95 % interval, the median and
95th percentile of the call time, and against ``off`` (same method, same search, same goals) the exact
two-sided McNemar test: b = goals only ``off`` solved, c = goals only the row solved, p = P(Binomial(b + c,
1/2) as extreme). The peers' rates quoted from issue 43 (ikpy, placo) were measured on 500 goals of the
same set in another build; against them the script gives an exact one-sided binomial p-value of the row's
count under the peer's rate, which is not a paired test.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
STUDY = ROOT / "data" / "studies" / "arm_benchmark.yaml"
# issue 43's measurements of the peers on 500 cold goals (single search; placo with restarts)
PEER_SINGLE = {"franka_panda": ("ikpy", 56.0), "kuka_iiwa14": ("ikpy", 77.0)}
PEER_RESTARTS = ("placo", 99.8)
TUNED = {"max_iterations": 500, "disable_grow": True, "damping": 0.02}  # chosen on seed-777 goals


def cold_goals(robot: str, count: int):
    """The first ``count`` goals of ``arm_benchmark``'s cold set for ``robot`` (as ``make_problems`` draws them)."""
    from pipeline.jobs.solve import problem_set_spec
    from pipeline.problems import make_problem_set
    from pipeline.robots import load_robot
    from pipeline.settings import load_study

    study = load_study(STUDY)
    spec = problem_set_spec(study, "cold")
    model = load_robot(ROOT / "data" / "robots" / f"{robot}.yaml")
    rng = np.random.default_rng([spec["seed"], sum(model.name.encode())])
    ps = make_problem_set(spec, model, study.count("cold", "full"), rng, ROOT / "data", "full")
    return model, ps.head(count)


def configurations(methods, modes, restart_modes) -> list[tuple[str, str, str, dict]]:
    """(row name, search, mode, settings mapping) per row: the study's labels with ``search_limits`` set
    (``modes`` for the single search, ``restart_modes`` with restarts)."""
    from pipeline.settings import load_study

    study = load_study(STUDY)
    rows = []
    for m in methods:
        for search, label in (("single", m), ("restarts", f"{m}_restarts")):
            base = {k: v for k, v in study.solvers[label].as_dict().items() if k != "method"}
            for mode in (modes if search == "single" else restart_modes):
                rows.append((m, search, mode, {**base, "search_limits": mode}))
            if m == "dls" and "reflect" in (modes if search == "single" else restart_modes):
                rows.append((m, search, "reflect tuned", {**base, **TUNED, "search_limits": "reflect"}))
    return rows


def mcnemar_two_sided(b: int, c: int) -> float:
    """Exact two-sided McNemar p-value from the discordant counts ``b``, ``c``."""
    n = b + c
    if n == 0:
        return 1.0
    k = min(b, c)
    tail = sum(math.comb(n, i) for i in range(k + 1)) / (1 << n)
    return min(1.0, 2.0 * tail)


def binom_p_at_least(k: int, n: int, p: float) -> float:
    """P(X >= k), X ~ Binomial(n, p): how unusual ``k`` successes are if the true rate were ``p``."""
    return float(sum(math.comb(n, i) * p ** i * (1 - p) ** (n - i) for i in range(k, n + 1)))


def run(robot: str, goals: int, rows, seed: int = 0) -> dict:
    """Every row on every goal, interleaved; returns per row the success flags and call times."""
    print(f"{robot}: {len(rows)} rows x {goals} goals", file=sys.stderr, flush=True)
    from pipeline import solvers

    model, ps = cold_goals(robot, goals)
    prep = solvers.Prepared(model)
    G = ps.goal_transforms()
    bound = []
    for name, search, mode, s in rows:
        b = solvers.bind(name, prep, solvers.make_settings(name, s))
        b.solve(G[0], ps.q_start[0])  # compile or load the kernels before any timed call
        bound.append(b)
    ok = np.zeros((len(rows), len(G)), bool)
    t = np.zeros((len(rows), len(G)))
    inside = np.ones((len(rows), len(G)), bool)
    rng = np.random.default_rng(seed)
    for i in range(len(G)):
        if i % 50 == 0:
            print(f"  goal {i}", file=sys.stderr, flush=True)
        for r in rng.permutation(len(rows)):
            res = bound[r].solve(G[i], ps.q_start[i])
            ok[r, i], t[r, i] = res.success, res.call_time_s
            if res.success:  # the FK check and the limits, once more, outside the driver
                inside[r, i] = bool(np.all(res.q >= prep.limits[:, 0] - 1e-6) and np.all(res.q <= prep.limits[:, 1] + 1e-6))
    return {"ok": ok, "t": t, "inside": inside}


def table(robot: str, rows, out: dict) -> list[str]:
    """Markdown rows of one robot."""
    from pipeline.studies.arm_answer import wilson

    ok, t = out["ok"], out["t"]
    n = ok.shape[1]
    ref = {(name, search): i for i, (name, search, mode, _) in enumerate(rows) if mode == "off"}
    lines = [f"\n### {robot} ({n} cold goals)\n",
             "| method | search | search_limits | success [%] (95 % CI) | call p50 [µs] | call p95 [µs] | "
             "only off / only this | McNemar p (two-sided) | against the peer |",
             "|---|---|---|---|---|---|---|---|---|"]
    for i, (name, search, mode, _) in enumerate(rows):
        k = int(ok[i].sum())
        lo, hi = wilson(k, n)
        j = ref.get((name, search))
        if j is None or j == i:
            disc, p = "", ""
        else:
            b, c = int((ok[j] & ~ok[i]).sum()), int((ok[i] & ~ok[j]).sum())
            disc, p = f"{b} / {c}", f"{mcnemar_two_sided(b, c):.2g}"
        peer, rate = PEER_SINGLE[robot] if search == "single" else PEER_RESTARTS
        vs = f"{peer} {rate} %: P(≥{k} \\| {rate} %) = {binom_p_at_least(k, n, rate / 100):.2g}"
        lines.append(f"| {name} | {search} | {mode} | {100 * k / n:.1f} ({100 * lo:.1f}-{100 * hi:.1f}) | "
                     f"{np.median(t[i]) * 1e6:.0f} | {np.percentile(t[i], 95) * 1e6:.0f} | {disc} | {p} | {vs} |")
    if not out["inside"].all():
        lines.append("\n**a success outside the limits** (must not happen): rows "
                     + ", ".join(str(i) for i in np.flatnonzero(~out["inside"].all(axis=1))))
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--goals", type=int, default=500)
    ap.add_argument("--robots", default="franka_panda,kuka_iiwa14")
    ap.add_argument("--methods", default="dls,sdls,pseudoinverse,levenberg_marquardt")
    ap.add_argument("--modes", default="off,clamp,reflect")
    ap.add_argument("--restart-modes", default="off,clamp,reflect", help="modes run with restarts")
    ap.add_argument("--out", help="write the tables (markdown) here as well as printing them")
    args = ap.parse_args()
    sys.path.insert(0, str(ROOT))  # this checkout's package, whatever is installed
    rows = configurations(args.methods.split(","), args.modes.split(","), args.restart_modes.split(","))
    text = []
    for robot in args.robots.split(","):
        t0 = time.process_time()
        out = run(robot, args.goals, rows)
        lines = table(robot, rows, out)
        lines.append(f"\n({time.process_time() - t0:.0f} s CPU for this arm)")
        print("\n".join(lines), flush=True)
        text += lines
    if args.out:
        Path(args.out).write_text("\n".join(text) + "\n")


if __name__ == "__main__":
    main()
