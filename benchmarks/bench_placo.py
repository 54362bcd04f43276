"""placo against the project's limits-aware Jacobian searches, paired on the same goals (issue 43).

Usage (the project's venv; placo's own venv made first by ``bash benchmarks/placo_env.sh``)::

    python benchmarks/bench_placo.py [--goals 500] [--robots franka_panda,kuka_iiwa14]
                                     [--placo-python /tmp/placo-venv/bin/python] [--out results.md]

Goals: the first ``--goals`` of ``arm_benchmark``'s cold set per arm (``bench_limits.cold_goals``: seed 31,
start and goal uniform within the limits). placo 0.10.2 pins ``pin==3.8.0`` and cannot share the
project's venv (pin 4.1.0), so it runs in a subprocess of its own venv (``benchmarks/placo_worker.py``):
the arm goes over as the URDF the project exports (``pipeline.urdf.to_urdf``, tool frame ``tool0``), the
goals, starts and restart starts as a ``.npz``, and each goal's joint vector comes back.

placo's loop is the one ``pipeline/solvers/peers/qp_ik.py`` states for its placo path (cap
``max_iterations`` 100, stop at 1e-5 m and 1e-4 rad, placo's documented frame-task set-up with joint
limits on); ``restarts`` runs it from the goal's start, then from up to 20 restart starts until it
converges. The restart starts are the very ones our driver draws for the same goal and seed (uniform
in ``Prepared.search_box``, the limits, from ``default_rng([seed, 0x5EED])``; seed = the goal's index for
both sides), so both sides search from the same points. Every placo answer is judged by our forward
kinematics at the benchmark's tolerances (``bench_limits.peer_success``: 0.1 mm, 1e-3 rad, within the
limits); placo's own stop test decides nothing.

Ours: the study's labels ``dls_reflect``, ``levenberg_marquardt_reflect``, ``pseudoinverse_reflect`` and
their ``_restarts``, bound once, every label called on every goal in a seeded shuffled order, success =
the driver's FK-checked, within-limits success. Paired test per (our label, placo with the same search):
the exact two-sided McNemar test (``bench_limits.mcnemar_two_sided``; b = goals only placo solved,
c = goals only ours solved). Times per call: the thread's CPU time around the whole call (ours here,
placo's inside its process) and the monotonic wall time; medians and 95th percentiles. "Search's own"
time: ours, the result's ``solve_time_s`` (the search kernel without the FK check and the result; the
monotonic clock, the only one a single result carries); placo's, its bare steps replayed alone, thread
CPU (the worker's ``bare_cpu_s``: no Python stop test).
"""

from __future__ import annotations

import argparse
import importlib.metadata as md
import platform
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # this checkout's package, whatever is installed
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench_limits import STUDY, cold_goals, mcnemar_two_sided, peer_success  # noqa: E402

OURS = ("dls_reflect", "levenberg_marquardt_reflect", "pseudoinverse_reflect")
LOOP = {"max_iterations": 100, "pos_threshold": 1e-5, "ori_threshold": 1e-4}  # qp_ik.QPLoopSettings' defaults
RESTARTS = 20  # the study's restart budget (dls_reflect_restarts and the others)
WORKER = ROOT / "benchmarks" / "placo_worker.py"


def placo_inputs(model, prep, ps, G, restarts: int) -> dict:
    """The worker's inputs: URDF text, moving joints' names, goals, starts and the driver's restart starts."""
    from pipeline.urdf import to_urdf

    assert prep.goal_scale == 1.0, "arm not in metres"
    urdf = to_urdf(model)
    joints = [j.get("name") for j in ET.fromstring(urdf).iter("joint") if j.get("type") != "fixed"]
    assert len(joints) == model.n, joints
    box = prep.search_box()
    RS = np.empty((len(G), restarts, model.n))
    for i in range(len(G)):  # as Driver.restart draws them for seed i
        rng = np.random.default_rng([i, 0x5EED])
        for k in range(restarts):
            RS[i, k] = box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random(prep.n)
    return {"urdf": np.array(urdf), "joints": np.array(joints), "tip": np.array("tool0"), "goals": G,
            "starts": np.asarray(ps.q_start, dtype=float), "restart_starts": RS, "seed": np.array(7),
            "fk_q": RS[:, 0],
            **{k: np.array(v) for k, v in LOOP.items()}}


def run_placo(python: str, inputs: dict) -> dict:
    """The worker on ``inputs`` in placo's venv; its outputs as a dict of arrays."""
    with tempfile.TemporaryDirectory() as tmp:
        src, dst = Path(tmp) / "in.npz", Path(tmp) / "out.npz"
        np.savez(src, **inputs)
        proc = subprocess.run([python, str(WORKER), str(src), str(dst)], capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"placo worker failed ({proc.returncode}): {proc.stderr.strip()[-2000:]}")
        with np.load(dst, allow_pickle=False) as d:
            return {k: d[k] for k in d.files}


def run_ours(prep, G, ps, seed: int = 0) -> dict:
    """Every label on every goal (seed = goal index), interleaved; success, thread CPU and wall time per call."""
    from pipeline import solvers
    from pipeline.settings import load_study

    study = load_study(STUDY)
    labels = [f"{m}{suffix}" for m in OURS for suffix in ("", "_restarts")]
    binds = []
    for label in labels:
        s = {k: v for k, v in study.solvers[label].as_dict().items() if k != "method"}
        assert int(s.get("restarts", 0)) in (0, RESTARTS), (label, s)
        method = study.solvers[label].as_dict()["method"]
        b = solvers.bind(method, prep, solvers.make_settings(method, s))
        b.solve(G[0], ps.q_start[0])  # compile or load the kernels before any timed call
        binds.append(b)
    N = len(G)
    ok = np.zeros((len(labels), N), bool)
    cpu, wall, kernel = (np.zeros((len(labels), N)) for _ in range(3))
    rng = np.random.default_rng(seed)
    for i in range(N):
        for r in rng.permutation(len(labels)):
            c0 = time.thread_time_ns()
            res = binds[r].solve(G[i], ps.q_start[i], i)
            cpu[r, i] = (time.thread_time_ns() - c0) * 1e-9
            wall[r, i], kernel[r, i] = res.call_time_s, res.solve_time_s
            ok[r, i] = res.success
            if res.success:  # the limits once more, outside the driver
                assert np.all(res.q >= prep.limits[:, 0] - 1e-6) and np.all(res.q <= prep.limits[:, 1] + 1e-6)
    return {"labels": labels, "ok": ok, "cpu": cpu, "wall": wall, "kernel": kernel}


def arm(robot: str, goals: int, python: str, passes: int = 1) -> tuple[list[str], list[str]]:
    """One arm: placo's run and ours on the same goals; (markdown lines, placo side's versions). With
    ``passes`` > 1 the two alternate (placo, ours, placo, ours, ...), and each goal's times are its fastest
    pass on each side, so that a slow phase of the shared machine does not land on one side only (placo
    runs in a process of its own, so the two cannot be interleaved goal by goal)."""
    from pipeline import solvers
    from pipeline.kinematics import fk_htm

    model, ps = cold_goals(robot, goals)
    prep = solvers.Prepared(model)
    G = np.ascontiguousarray(ps.goal_transforms(), dtype=float)
    inputs = placo_inputs(model, prep, ps, G, RESTARTS)
    pl = ours = None
    for k in range(passes):
        print(f"{robot}: placo on {len(G)} goals (pass {k + 1} of {passes})", file=sys.stderr, flush=True)
        w0 = time.perf_counter()
        p = run_placo(python, inputs)
        p["subprocess_wall_s"] = time.perf_counter() - w0
        print(f"{robot}: ours (pass {k + 1} of {passes})", file=sys.stderr, flush=True)
        o = run_ours(prep, G, ps)
        pl = p if pl is None else {**pl, **{key: np.minimum(pl[key], p[key]) for key in pl if key.endswith(
            ("_cpu_s", "_wall_s")) and key != "subprocess_wall_s"}}
        ours = o if ours is None else {**ours, **{key: np.minimum(ours[key], o[key]) for key in ("cpu", "wall",
                                                                                              "kernel")}}
    pl["fk_max_diff"] = max(float(np.abs(pl["fk_T"][r] - fk_htm(model.chain, q)).max())
                            for r, q in enumerate(inputs["fk_q"]))
    placo_ok = {kind: np.array([peer_success(model, G[i], pl[f"{kind}_q"][i]) for i in range(len(G))])
                for kind in ("single", "restarts")}
    lines = [f"\n### {robot} ({len(G)} cold goals)\n", *table(pl, placo_ok, ours), "", note(pl, placo_ok)]
    return lines, [str(v) for v in pl["versions"]]


def table(pl: dict, placo_ok: dict, ours: dict) -> list[str]:
    """The paired table: placo's row, then each of our labels with the same search against it."""
    from pipeline.studies.arm_answer import wilson

    n = len(placo_ok["single"])
    us = lambda x, q=50: f"{np.percentile(x, q) * 1e6:.0f}"  # noqa: E731

    def pct(k):
        lo, hi = wilson(k, n)
        return f"{100 * k / n:.1f} ({100 * lo:.1f}-{100 * hi:.1f})"

    lines = ["| solver | search | success [%] (95 % CI) | CPU p50 [µs] | CPU p95 [µs] | wall p50 [µs] | "
             "search's own p50 [µs] | only placo / only ours | McNemar p (exact, two-sided) | "
             "CPU p50 ours / placo (whole calls) | ours / placo (searches' own) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for kind in ("single", "restarts"):
        cpu, bare = pl[f"{kind}_cpu_s"], pl[f"{kind}_bare_cpu_s"]
        lines.append(f"| placo 0.10.2 | {kind} | {pct(int(placo_ok[kind].sum()))} | {us(cpu)} | {us(cpu, 95)} | "
                     f"{us(pl[f'{kind}_wall_s'])} | {us(bare)} |  |  |  |  |")
        for r, label in enumerate(ours["labels"]):
            if label.endswith("_restarts") != (kind == "restarts"):
                continue
            o = ours["ok"][r]
            b, c = int((placo_ok[kind] & ~o).sum()), int((o & ~placo_ok[kind]).sum())
            lines.append(f"| `{label}` | {kind} | {pct(int(o.sum()))} | {us(ours['cpu'][r])} | {us(ours['cpu'][r], 95)} | "
                         f"{us(ours['wall'][r])} | {us(ours['kernel'][r])} | {b} / {c} | {mcnemar_two_sided(b, c):.2g} | "
                         f"{np.median(ours['cpu'][r]) / np.median(cpu):.3f} | "
                         f"{np.median(ours['kernel'][r]) / np.median(bare):.3f} |")
    return lines


def note(pl: dict, placo_ok: dict) -> str:
    """What placo's run did: its own stop test against our FK check, QP failures, restarts, steps, replay."""
    n = len(placo_ok["single"])
    conv = {kind: int(pl[f"{kind}_converged"].sum()) for kind in placo_ok}
    agree = {kind: int((pl[f"{kind}_converged"].astype(bool) == placo_ok[kind]).sum()) for kind in placo_ok}
    dq = max(pl["single_replay_dq"].max(), pl["restarts_replay_dq"].max())
    return (f"placo's own stop test passed on {conv['single']} (single) and {conv['restarts']} (restarts) goals; our FK "
            f"check agrees with it on {agree['single']} and {agree['restarts']} of {n}. QP failures: "
            f"{int(pl['single_stalled'].sum())} / {int(pl['restarts_stalled'].sum())}. Restarts placo used: mean "
            f"{pl['restarts_used'].mean():.2f}, max {int(pl['restarts_used'].max())}. Steps per call, median "
            f"{np.median(pl['single_iterations']):.0f} (single) / {np.median(pl['restarts_iterations']):.0f} (restarts); "
            f"the bare replay's largest angle difference {dq:.1g}. placo's FK of the exported URDF against ours on "
            f"{len(pl['fk_T'])} joint vectors (the first restart starts): largest entry difference "
            f"{pl['fk_max_diff']:.1g} m. placo subprocess {pl['subprocess_wall_s']:.1f} s wall.")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--goals", type=int, default=500)
    ap.add_argument("--robots", default="franka_panda,kuka_iiwa14")
    ap.add_argument("--placo-python", default="/tmp/placo-venv/bin/python",
                    help="the python of placo's venv (bash benchmarks/placo_env.sh makes it)")
    ap.add_argument("--passes", type=int, default=3,
                    help="placo's run and ours alternate this many times; each goal's times are its fastest pass")
    ap.add_argument("--out", help="write the tables (markdown) here as well as printing them")
    args = ap.parse_args()
    if not Path(args.placo_python).is_file():
        sys.exit(f"bench_placo.py: --placo-python {args.placo_python}: no such file (make placo's venv first: "
                 "bash benchmarks/placo_env.sh)")
    text = []
    for robot in args.robots.split(","):
        lines, versions = arm(robot, args.goals, args.placo_python, max(1, args.passes))
        print("\n".join(lines), flush=True)
        text += lines
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout
    text.append(f"\nplaco side: {', '.join(versions)}. Our side: python {platform.python_version()}, numpy "
                f"{np.__version__}, numba {md.version('numba')}, commit {commit.strip() or '?'}.")
    print(text[-1])
    if args.out:
        Path(args.out).write_text("\n".join(text) + "\n")


if __name__ == "__main__":
    main()
