"""Speed of the geometric closed form (``analytic``) against EAIK, IK-Geo and TRAC-IK, on the same
poses, interleaved in one process.

Usage::

    python benchmarks/closed_form.py [--poses 2000] [--batch 200000] [--only eaik,batch,search,general,seven]
                                     [--json out.json]

Sections (times per pose; medians and 95th percentiles over the poses):

``eaik``    every 6R catalogue arm EAIK solves (spherical wrists, three parallel axes): ``--poses``
            goals = FK of joint angles uniform within the limits (seed 7), starts likewise. Our public
            call ``pipeline.solvers.solve('analytic', ...)`` (registry defaults: every solution,
            FK-checked, the independent FK check of the chosen one, the result object), timed around
            the whole call, against EAIK's and IK-Geo's library call alone (``solve_time_s`` of the
            ``eaik`` / ``ik_geo`` peers: ``robot.IK(T)`` / ``get_ik(R, p)`` and reading its answers).
            Interleaved by blocks of 100 poses, so a slow phase of the machine hits every method alike.
            Verdict per arm: our median <= EAIK's; also the solutions per goal of each.
``batch``   ``pipeline.solvers.solve_batch('analytic', ...)`` on ``--batch`` poses of the UR5 and the
            PUMA 560 (``traces=False``), after 5 warm-up calls of the same size, 5 calls on 2 threads, then
            5 on 1: poses per second of the whole batch call, the best call and the median one (the
            verdict, >= 1 M on 2 threads, is read on the median). The first calls in a process are
            slower: while its memory grows, the kernel's system time per call is 80-240 ms (huge-page
            compaction; 5-12 ms once grown) for the same page-fault count.
``search``  the offset-wrist arms (one-dimensional search): the method's own time per pose
            (``solve_time_s``, compiled) and the public call, over ``--poses`` goals.
``general`` four random general 6R arms (no meeting or parallel axes; standard and modified DH, m and
            mm; seeds 100-103), solved by ``analytic`` through the general elimination: the method's own
            time per pose (``solve_time_s``) and the public call over ``--poses`` / 4 goals, success,
            and on 10 goals per arm the solution set against a dense Newton search (600 starts).
``seven``   the 7R arms: our public call against TRAC-IK's (default 5 ms budget) on the same goals
            (``--poses`` / 4 of them), interleaved by blocks of 25: success within limits and
            median call time, and their ratio.

The machine is shared: a verdict is a ratio of medians measured in the same blocks. CPU time of
the process (``time.process_time``) is printed beside wall time for each section. The run begins
with the machine (CPU model, the compiler's target, cores, versions, the load average) and ends with
the load average: the same code compiles to other vector code on another CPU, so the verdicts are
this machine's (an Intel and an AMD Zen 4 machine disagree on three of them; benchmarks/results/closed_forms.md).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

from pipeline.kinematics import fk_htm
from pipeline.kinematics.geometry import classify
from pipeline.robots import load_robot, parse_robot
from pipeline.solvers import make_settings, solve
from pipeline.solvers.closed_form import general6r, general6r_model
from pipeline.solvers.core import NotApplicableError, Prepared
from pipeline.solvers.core.models import metric as _metric
from pipeline.solvers.core.registry import get, solve_batch

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ROOT / "data" / "robots"
SIX = ["abb_irb120", "abb_irb140", "abb_irb2400", "fanuc_lrmate200id", "staubli_tx2_60", "kuka_kr5_arc",
       "kuka_kr6_r700_sixx", "puma560", "ur3", "ur5", "ur10", "ur3e", "ur5e", "ur10e", "ur16e", "ur5e_urdf"]
OFFSET = ["ufactory_xarm6", "kinova_gen3_lite", "fanuc_crx10ia"]
SEVEN = ["franka_panda", "kuka_iiwa14", "kinova_gen3", "ufactory_xarm7", "rethink_sawyer"]


def problems(model, n: int, seed: int):
    rng = np.random.default_rng(seed)
    lim = np.where(np.isfinite(model.limits), model.limits, np.array([-np.pi, np.pi]))
    q = rng.uniform(lim[:, 0], lim[:, 1], (n, model.n))
    q0 = rng.uniform(lim[:, 0], lim[:, 1], (n, model.n))
    return np.array([fk_htm(model.chain, x) for x in q]), q0


def stats(x) -> dict:
    x = np.asarray(x, dtype=float)
    return {"p50": float(np.median(x)), "p95": float(np.percentile(x, 95))}


def _applies(name, prep) -> bool:
    return get(name).refusal(prep) is None


def section_eaik(n: int) -> dict:
    out = {}
    for robot in SIX:
        model = load_robot(ROBOTS / f"{robot}.yaml")
        prep = Prepared(model)
        peers = [p for p in ("eaik", "ik_geo") if _applies(p, prep)]
        if "eaik" not in peers:
            print(f"{robot:18s} EAIK does not apply ({get('eaik').refusal(prep)})")
            continue
        T, q0 = problems(model, n, 7)
        st = {name: make_settings(name, {}) for name in ["analytic", *peers]}
        for name in st:  # compile / build once
            solve(name, prep, T[0], q0[0], st[name])
        ours, lib = [], {p: [] for p in peers}
        nsol = {name: [] for name in st}
        ok = {name: 0 for name in st}
        c0 = time.process_time()
        for b in range(0, n, 100):
            for i in range(b, min(n, b + 100)):
                t0 = time.perf_counter_ns()
                r = solve("analytic", prep, T[i], q0[i], st["analytic"])
                ours.append((time.perf_counter_ns() - t0) * 1e-3)
                nsol["analytic"].append(len(r.solutions))
                ok["analytic"] += r.success
            for p in peers:
                for i in range(b, min(n, b + 100)):
                    r = solve(p, prep, T[i], q0[i], st[p])
                    lib[p].append(r.solve_time_s * 1e6)
                    nsol[p].append(len(r.solutions) if r.solutions is not None else 0)
                    ok[p] += r.success
        cpu = time.process_time() - c0
        row = {"family": classify(model.chain).family, "ours_public_us": stats(ours),
               **{f"{p}_library_us": stats(lib[p]) for p in peers},
               "solutions_per_goal": {k: float(np.mean(v)) for k, v in nsol.items()},
               "success": {k: v / n for k, v in ok.items()}, "cpu_s": cpu}
        row["ours_le_eaik"] = row["ours_public_us"]["p50"] <= row["eaik_library_us"]["p50"]
        out[robot] = row
        print(f"{robot:18s} ours public {row['ours_public_us']['p50']:6.2f} us | EAIK library "
              f"{row['eaik_library_us']['p50']:6.2f} us" +
              (f" | IK-Geo library {row['ik_geo_library_us']['p50']:6.2f} us" if "ik_geo" in peers else "") +
              f" | solutions/goal ours {row['solutions_per_goal']['analytic']:.2f} EAIK "
              f"{row['solutions_per_goal']['eaik']:.2f} | success ours {row['success']['analytic']:.4f} "
              f"EAIK {row['success']['eaik']:.4f} | ours <= EAIK: {row['ours_le_eaik']}")
    return out


def section_batch(n: int) -> dict:
    out = {}
    for robot in ("ur5", "puma560"):
        model = load_robot(ROBOTS / f"{robot}.yaml")
        T1, q1 = problems(model, 2000, 8)
        reps = max(1, n // 2000)
        T, q0 = np.tile(T1, (reps, 1, 1)), np.tile(q1, (reps, 1))
        st = make_settings("analytic", {})
        for _ in range(5):  # warm-up: compiled code loaded, the process's memory grown to this size
            solve_batch("analytic", model, T, q0, st, traces=False)
        took = {2: [], 1: []}
        for threads in took:
            for _ in range(5):
                t0 = time.perf_counter()
                res = solve_batch("analytic", model, T, q0, st, threads=threads, traces=False)
                took[threads].append(time.perf_counter() - t0)
        for threads, t in took.items():
            best, med = len(T) / min(t), len(T) / float(np.median(t))
            out[f"{robot}_threads{threads}_poses_per_s"] = med
            out[f"{robot}_threads{threads}_poses_per_s_best"] = best
            print(f"batch {robot:8s} {threads} thread(s): {med / 1e6:.2f} M poses/s median of 5 calls, best "
                  f"{best / 1e6:.2f} ({len(T)} poses, success {np.mean(res.success):.4f})")
    return out


def timed_calls(prep, T, q0):
    """``analytic``'s public call on each goal (after one call to compile): the method's own times and
    the whole calls' [µs], the successes and the solution counts."""
    st = make_settings("analytic", {})
    solve("analytic", prep, T[0], q0[0], st)
    kern, pub, ok, nsol = [], [], 0, []
    for i in range(len(T)):
        t0 = time.perf_counter_ns()
        r = solve("analytic", prep, T[i], q0[i], st)
        pub.append((time.perf_counter_ns() - t0) * 1e-3)
        kern.append(r.solve_time_s * 1e6)
        ok += r.success
        nsol.append(len(r.solutions))
    return kern, pub, ok, nsol


def section_search(n: int) -> dict:
    out = {}
    for robot in OFFSET:
        model = load_robot(ROBOTS / f"{robot}.yaml")
        prep = Prepared(model)
        T, q0 = problems(model, n, 9)
        kern, pub, ok, _ = timed_calls(prep, T, q0)
        out[robot] = {"solve_us": stats(kern), "public_us": stats(pub), "success": ok / n}
        print(f"search {robot:18s} method {out[robot]['solve_us']['p50']:7.1f} us (p95 "
              f"{out[robot]['solve_us']['p95']:.1f}) | public {out[robot]['public_us']['p50']:7.1f} us | "
              f"success {ok / n:.4f}")
    return out


def general_arm(seed: int, conv: str, unit: str):
    """A random 6R arm with no meeting or parallel axes (random DH lengths and twists)."""
    rng = np.random.default_rng(seed)
    f = 1000.0 if unit == "mm" else 1.0
    sign = lambda: rng.choice([-1.0, 1.0], 6)  # noqa: E731
    a, alpha, d = rng.uniform(0.05, 0.6, 6) * sign() * f, rng.uniform(0.3, np.pi - 0.3, 6) * sign(), \
        rng.uniform(0.05, 0.6, 6) * sign() * f
    joints = [{"type": "revolute", "a": float(a[i]), "alpha": float(alpha[i]), "d": float(d[i]),
               "theta_offset": float(rng.uniform(-np.pi, np.pi)), "limits": [-np.pi, np.pi]} for i in range(6)]
    return parse_robot({"name": f"general_{seed}", "source": "random test arm", "length_unit": unit,
                        "convention": conv, "joints": joints})


def _dense_count(m6, T, starts) -> set:
    """Distinct solutions a Newton search reaches from ``starts`` (rounded keys)."""
    found = []
    for s0 in starts:
        x = general6r_model.newton_polish(m6.H, m6.P, m6.T0, T, s0, 40)
        if np.all(np.isfinite(x)) and np.abs(general6r_model.fk_model(m6, x) - T).max() < 1e-10:
            x = (x + np.pi) % (2 * np.pi) - np.pi
            if all(np.abs((x - y + np.pi) % (2 * np.pi) - np.pi).max() > 1e-6 for y in found):
                found.append(x)
    return found


def section_general(n: int) -> dict:
    out = {}
    for k, (conv, unit) in enumerate([("standard", "m"), ("modified", "m"), ("standard", "mm"), ("modified", "mm")]):
        model = general_arm(100 + k, conv, unit)
        prep = Prepared(model)
        T, q0 = problems(model, n, 11)
        kern, pub, ok, nsol = timed_calls(prep, T, q0)
        m6, rng, agree = general6r.model(prep), np.random.default_rng(k), 0
        for i in range(10):
            Tm = _metric(prep).goal(T[i])
            ours = general6r.candidates(m6, Tm, general6r.General6RSettings())
            ours = [x for x in ours if np.abs(general6r_model.fk_model(m6, x) - Tm).max() < 1e-9]
            dense = _dense_count(m6, Tm, rng.uniform(-np.pi, np.pi, (600, 6)))
            agree += len(ours) == len(dense) and all(
                min(np.abs((y - x + np.pi) % (2 * np.pi) - np.pi).max() for x in ours) < 1e-6 for y in dense)
        name = f"general_{100 + k} ({conv}, {unit})"
        out[name] = {"solve_us": stats(kern), "public_us": stats(pub), "success": ok / n,
                     "solutions_per_goal": float(np.mean(nsol)), "same_set_as_dense_search_of_10": agree,
                     "eaik": get("eaik").refusal(prep) or "applies"}
        print(f"general {name:28s} method {out[name]['solve_us']['p50']:6.1f} us (p95 "
              f"{out[name]['solve_us']['p95']:.1f}) | public {out[name]['public_us']['p50']:6.1f} us | success "
              f"{ok / n:.4f} | {np.mean(nsol):.2f} solutions/goal | same set as a dense search: {agree}/10 | "
              f"EAIK: {out[name]['eaik'][:60]}")
    return out


def section_seven(n: int) -> dict:
    out = {}
    for robot in SEVEN:
        model = load_robot(ROBOTS / f"{robot}.yaml")
        prep = Prepared(model)
        T, q0 = problems(model, n, 10)
        st = {name: make_settings(name, {"require_limits": True}) for name in ("analytic", "trac_ik")}
        try:
            for name in st:
                solve(name, prep, T[0], q0[0], st[name])
        except NotApplicableError as exc:
            print(f"{robot}: {exc}")
            continue
        t = {name: [] for name in st}
        ok = {name: 0 for name in st}
        for b in range(0, n, 25):
            for name in st:
                for i in range(b, min(n, b + 25)):
                    t0 = time.perf_counter_ns()
                    r = solve(name, prep, T[i], q0[i], st[name])
                    t[name].append((time.perf_counter_ns() - t0) * 1e-3)
                    ok[name] += r.success
        row = {name: {"call_us": stats(t[name]), "success": ok[name] / n} for name in st}
        row["trac_ik_over_ours"] = row["trac_ik"]["call_us"]["p50"] / row["analytic"]["call_us"]["p50"]
        out[robot] = row
        print(f"7R {robot:16s} ours {row['analytic']['success']:.3f} in {row['analytic']['call_us']['p50']:7.1f} us | "
              f"TRAC-IK {row['trac_ik']['success']:.3f} in {row['trac_ik']['call_us']['p50']:7.1f} us | "
              f"TRAC-IK / ours {row['trac_ik_over_ours']:.1f}x")
    return out


def machine() -> dict:
    """What the verdicts depend on besides the code: the CPU (model, the compiler's target, cores),
    the library versions and the load average (1 min) when the run starts. The same code compiles
    to other vector code on other CPUs (a loop the compiler vectorizes for one may stay scalar for
    another), so a speed verdict is a verdict on this machine."""
    import llvmlite.binding as llvm
    import numba

    info = Path("/proc/cpuinfo")
    lines = info.read_text().splitlines() if info.exists() else []
    model = next((ln.split(":", 1)[1].strip() for ln in lines if ln.startswith("model name")), platform.processor())
    return {"cpu": model, "llvm_cpu": llvm.get_host_cpu_name(), "cores": os.cpu_count(),
            "numpy": np.__version__, "numba": numba.__version__, "load_1min_start": os.getloadavg()[0]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=2000)
    ap.add_argument("--batch", type=int, default=200000)
    ap.add_argument("--only", default="eaik,batch,search,general,seven")
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    only = set(a.only.split(","))
    res = {"machine": machine()}
    print("machine: " + ", ".join(f"{k} {v}" for k, v in res["machine"].items()))
    if "eaik" in only:
        res["eaik"] = section_eaik(a.poses)
    if "batch" in only:
        res["batch"] = section_batch(a.batch)
    if "search" in only:
        res["search"] = section_search(a.poses)
    if "general" in only:
        res["general"] = section_general(max(25, a.poses // 4))
    if "seven" in only:
        res["seven"] = section_seven(max(25, a.poses // 4))
    res["machine"]["load_1min_end"] = os.getloadavg()[0]
    print(f"load average (1 min) at the end: {res['machine']['load_1min_end']:.2f}")
    if a.json:
        Path(a.json).write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
