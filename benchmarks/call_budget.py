"""Where ``analytic``'s public single call spends its time, against EAIK's library call on the same goals.

Usage::

    PYTHONPATH=$PWD python benchmarks/call_budget.py [--kinds sph_case,three_parallel] [--arm 3] [--reps 2000]
                                                     [--out FILE.md]

For one random arm of each family (``tests/solvers/closed_form/family_arms.py``, arm ``--arm``: the same
seeds as ``bench_families_eaik.py``) and its 10 goals, warm, each part below timed ``--reps`` times per goal,
the parts interleaved goal by goal in one process in a shuffled order (seeded); medians [µs]:

- ``solve``: the public call ``pipeline.solvers.solve('analytic', ...)``; ``fused``: the bound fused call
  it dispatches to (:func:`pipeline.solvers.closed_form.analytic.bind_call`); ``kernel``: its compiled
  kernel alone with the output arrays given (:func:`~pipeline.solvers.closed_form.analytic.fused_kernel`);
  ``dispatch``: the same kernel handed a (3, 3) goal, which it refuses at once: numba's dispatch, the
  arguments' unboxing and the returned tuple; ``eaik``: EAIK's ``robot.IK(T)`` and reading its answers.
- in a compiled loop over the same goals (no dispatch): ``solve_pose`` (the closed form, the FK check of
  every candidate, the ranking and the trace rows), ``core6`` (the closed form alone), ``finish`` (the
  independent FK check of the answer) and ``scratch`` (the kernel's four scratch arrays).
- ``three arrays``: the call's three ``np.empty``; ``IKResult``: building the result with its info dict.

So ``fused - kernel`` is the Python layer around the kernel, ``solve - fused`` the public call's lookup of
the bound call, ``kernel - dispatch`` the compiled work.
"""

from __future__ import annotations

import argparse
import math
import os
import random
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pipeline.solvers import bind, make_settings, solve  # noqa: E402
from pipeline.solvers.core import IKResult, Prepared  # noqa: E402
from pipeline.solvers.closed_form import analytic  # noqa: E402
from pipeline.solvers.closed_form import analytic_kernels as ak  # noqa: E402
from pipeline.solvers.closed_form.analytic_kernels import _views, finish_packed, scratch, unpack  # noqa: E402
from pipeline.solvers.kernels.kin import borrowed, grid, now_ns  # noqa: E402
from pipeline.solvers.kernels.specialise import specialise  # noqa: E402
from pipeline.solvers.peers.geo import metric  # noqa: E402
from tests.solvers.closed_form import family_arms as fa  # noqa: E402

SOLVE_POSE = CORE6 = None  # _loop's kernels, bound per family by compiled_loop (as in analytic_kernels)


def _loop(ints, GC, goals, starts, S, q, trace, part, reps):
    """Mean ns per pose of one part of the kernel (0 solve_pose, 1 core6, 2 finish, 3 scratch); a template
    whose ``SOLVE_POSE`` and ``CORE6`` :func:`compiled_loop` binds to a family's kernels."""
    n = ints[0]
    ng = 8 * n + 27
    clk = np.zeros(2, np.int64)
    Sc, W, Z, I = scratch(ints)
    H, P, RM, pM, par, lim = unpack(ints, GC[:ng])
    Q, Qr, qrow, Zf, R, p, dist, cs, Wf, Wr, Wa = _views(n, Sc.shape[0], W, Z, I)
    nolim = grid(GC[8 * n + 15:], 6, 2)
    acc = 0
    t0 = now_ns(clk)
    for r in range(reps):
        i = r % goals.shape[0]
        Tg = goals[i]
        if part == 0:
            acc += SOLVE_POSE(ints, GC[:ng], Tg, starts[i], Sc, W, Z, I, S, q, trace)[0]
        elif part == 1:
            acc += CORE6(ints[2], ints[3], ints[7], H, P, RM, pM, Tg, (Tg[0, 3], Tg[1, 3], Tg[2, 3]),
                         par[0], starts[i], ints[5], Q, nolim, Wr, Qr)
        elif part == 2:
            acc += finish_packed(borrowed(GC)[ng:], borrowed(starts[i]), Tg, 0)[0]
        else:
            acc += scratch(ints)[0].shape[0]
    return (now_ns(clk) - t0) / reps, acc


def compiled_loop(K):
    """:func:`_loop` compiled against this family's kernels (uncached: a benchmark's own code)."""
    return specialise(_loop, "call_budget", {"error_model": "numpy"}, SOLVE_POSE=K.solve_pose, CORE6=K.core6)


def budget(kind: str, arm: int, reps: int) -> dict:
    rng = np.random.default_rng(10_000 * list(fa.FAMILIES).index(kind) + arm)
    m = fa.arm(kind, rng)
    prep = Prepared(m)
    _, goals = fa.goals(m, rng, 10)
    starts = rng.uniform(-math.pi, math.pi, (10, 6))
    goals, starts = np.ascontiguousarray(goals, dtype=float), np.ascontiguousarray(starts)
    Tl, ql = [g.copy() for g in goals], [s.copy() for s in starts]
    st, se = make_settings("analytic", {}), make_settings("eaik", {})
    solve("analytic", prep, Tl[0], ql[0], st)
    solve("eaik", prep, Tl[0], ql[0], se)
    b = bind("analytic", prep, st)
    fused = b.fused
    kernel, ints, GC, n, ms = analytic.fused_kernel(prep, b.sc)
    S, q, trace = np.empty((ms, n)), np.empty(n), np.empty((2, ak.TRACE_COLS))
    bad = np.eye(3)
    robot, _ = prep.memo(("peers_geo", "eaik"), None)
    to_eaik = metric(prep)
    Tm = [to_eaik.goal(T) for T in Tl]
    empty, shape_S, shape_t, nan = np.empty, (ms, n), (2, ak.TRACE_COLS), math.nan

    def three_arrays(i):
        empty(shape_S), empty(n), empty(shape_t)

    def result(i):
        IKResult(q, True, 0, 1, trace, 1e-6, 0.0, 1e-9, 1e-9, True, True, nan, "m", S,
                 {"n_solutions": 8, "candidates": 8, "nfev": 8, "njev": 0, "doc_error": 0.1, "family": "x",
                  "message": "y"})

    def eaik(i):
        sol = robot.IK(Tm[i])
        sol.Q, sol.is_LS

    parts = {"solve": lambda i: solve("analytic", prep, Tl[i], ql[i], st),
             "fused": lambda i: fused(Tl[i], ql[i], 0, 0),
             "kernel": lambda i: kernel(ints, GC, Tl[i], ql[i], S, q, trace),
             "dispatch": lambda i: kernel(ints, GC, bad, ql[i], S, q, trace),
             "eaik": eaik, "three arrays": three_arrays, "IKResult": result}
    for f in parts.values():
        f(0)
    times = {name: [] for name in parts}
    pc = time.perf_counter_ns
    order = list(parts.items())
    shuffle = random.Random(0).shuffle
    for rep in range(reps):
        for i in range(10):
            shuffle(order)  # each part after any other: a fixed or rotated order keeps neighbours, which warm each other
            for name, f in order:
                t = pc()
                f(i)
                times[name].append(pc() - t)
    out = {name: float(np.median(v)) * 1e-3 for name, v in times.items()}
    loop = compiled_loop(ak.kernels(ints))
    for part, name in enumerate(("solve_pose", "core6", "finish", "scratch")):
        loop(ints, GC, goals, starts, S, q, trace, part, 10)
        out[name] = min(loop(ints, GC, goals, starts, S, q, trace, part, 20 * reps)[0] for _ in range(5)) * 1e-3
    out["family"] = solve("analytic", prep, Tl[0], ql[0], st).info["family"]
    out["case"] = int(ints[2])
    return out


ROWS = [("solve", "public call `solve(...)`"), ("eaik", "EAIK library call, same goals"),
        ("fused", "the bound fused call"), ("kernel", "its kernel alone, output arrays given"),
        ("dispatch", "- the kernel refusing a (3, 3) goal at once: dispatch, unboxing, returned tuple"),
        ("solve_pose", "- compiled loop: `solve_pose` (closed form, FK check of every candidate, ranking, trace rows)"),
        ("core6", "- compiled loop: the closed form alone (`core6`)"),
        ("finish", "- compiled loop: the independent FK check of the answer (`finish_packed`)"),
        ("scratch", "- compiled loop: the kernel's scratch (4 arrays)"),
        ("three arrays", "the call's three `np.empty`"), ("IKResult", "`IKResult` with its info dict")]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kinds", default="sph_case,three_parallel")
    ap.add_argument("--arm", type=int, default=3)
    ap.add_argument("--reps", type=int, default=2000)
    ap.add_argument("--out")
    a = ap.parse_args(argv)
    load0 = os.getloadavg()[0]
    kinds = a.kinds.split(",")
    res = [budget(k, a.arm, a.reps) for k in kinds]
    lines = [f"Arm {a.arm} of each generator, 10 goals, {a.reps} warm calls per goal and part, interleaved in a shuffled order; medians "
             f"[µs]; load average (1 min) {load0:.2f} at the start, {os.getloadavg()[0]:.2f} at the end.", "",
             "| part [µs] | " + " | ".join(f"{k} ({r['family']}, case {r['case']})" for k, r in zip(kinds, res)) + " |",
             "|---|" + "---|" * len(kinds)]
    for key, label in ROWS:
        lines.append(f"| {label} | " + " | ".join(f"{r[key]:.2f}" for r in res) + " |")
    derived = [("Python layer around the kernel (fused - kernel)", lambda r: r["fused"] - r["kernel"]),
               ("the public call's lookup (solve - fused)", lambda r: r["solve"] - r["fused"]),
               ("compiled work (kernel - dispatch)", lambda r: r["kernel"] - r["dispatch"]),
               ("ratio solve / EAIK", lambda r: r["solve"] / r["eaik"])]
    for label, f in derived:
        lines.append(f"| {label} | " + " | ".join(f"{f(r):.2f}" for r in res) + " |")
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        Path(a.out).write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
