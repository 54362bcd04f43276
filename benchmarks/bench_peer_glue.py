"""Each peer label's call against the peer library's bare call on the same goals (issue 43, item 3).

    PYTHONPATH=. python benchmarks/bench_peer_glue.py [--goals 200] [--out benchmarks/results/peer_glue.md]

For every peer label, on one robot it applies to, warm-start goals (our FK of random within-limit
angles, starts within 0.3 rad): per goal, interleaved in one process, (a) the library's bare call
with its model built beforehand (the same object the label uses) and its arguments made beforehand (metres,
the library's own types; for pink and mink the loop written on the library's objects), timed with ``time.perf_counter_ns`` around the call alone; (b) the label's
bound call ``bind(label, robot, settings).solve(T_goal, q_start)``: its ``solve_time_s`` (the timed
region the archives call the solve time) and its ``call_time_s`` (the whole public call: unit
conversion, the FK check of every returned solution, the result). Medians over the goals; the ratios
are call / bare and solve / bare (issue 43's bar: call within 1.2x of bare). A peer whose library is
missing is listed as such. The machine is shared: the load average is printed with the table.
"""

from __future__ import annotations

import argparse
import importlib
import math
import os
import time
from pathlib import Path

import numpy as np

from pipeline.kinematics import fk_htm, quat_from_matrix
from pipeline.robots import load_robot
from pipeline.solvers import NotApplicableError, bind
from pipeline.solvers.core.models import metric

ROOT = Path(__file__).resolve().parents[1]
ROBOT = {"eaik": "ur5e", "ik_geo": "ur5e", "ur_analytic_ik": "ur5e"}  # the rest: the Panda (a 7R arm)
SLOW = {"ikpy": 40, "pybullet_ik": None}  # goals for slow peers (None = all)
TUNED = {"max_num_iterations": 100, "residual_threshold": 1e-6, "joint_damping": 0.01}


def _goals(model, n: int, seed: int = 43):
    rng = np.random.default_rng(seed)
    lim = np.where(np.isfinite(model.limits), model.limits, [[-math.pi, math.pi]])
    Q = rng.uniform(lim[:, 0], lim[:, 1], (n, model.n))
    Q0 = np.clip(Q + rng.uniform(-0.3, 0.3, Q.shape), lim[:, 0], lim[:, 1])
    return [fk_htm(model.chain, q) for q in Q], Q0


# ---- the bare calls: (prep, settings) -> setup(T_goal [m], q_start) -> thunk: the library's call with its
# arguments made (outside the clock); the thunk is what is timed (a lambda call adds ~0.05 µs) ----
def _bare_eaik(prep, s):
    robot, _ = prep.memo(("peers_geo", "eaik"), None)
    return lambda T, q0: (lambda: robot.IK(T))


def _bare_ik_geo(prep, s):
    robot, _, transposed, R_T6 = prep.memo(("peers_geo", "ik_geo"), None)

    def call(T, q0):
        R = T[:3, :3] @ R_T6
        R, p = (np.ascontiguousarray(R.T) if transposed else R), np.ascontiguousarray(T[:3, 3])
        return lambda: robot.get_ik(R, p)
    return call


def _bare_ur(prep, s):
    from pipeline.solvers.core import inv_rigid
    lib = importlib.import_module("ur_analytic_ik")
    name, _ = prep.memo(("peers", "ur_match"), None)
    mod, m = getattr(lib, name), metric(prep)
    B, Ti = inv_rigid(m.base), inv_rigid(np.array(m.model.chain.tool, dtype=float))

    def call(T, q0):
        Tb = np.ascontiguousarray(B @ T @ Ti)
        return lambda: mod.inverse_kinematics(Tb)
    return call


def _bare_rtb(prep, s):
    ets = prep.memo(("peers", "rtb_ets"), None)
    tol = 0.5 * min(s.tol_pos, s.tol_rot) ** 2
    return lambda T, q0: (lambda: ets.ik_LM(T, q0=q0, ilimit=int(s.ilimit), slimit=int(s.slimit), tol=tol,
                                            joint_limits=bool(s.joint_limits), k=float(s.k), method=s.damping))


def _bare_pybullet(prep, s):
    from pipeline.solvers.peers.python_ik import pybullet_arguments
    pb, cid, body, ee = prep.memo(("peers", "pybullet"), None)
    kw = pybullet_arguments(s, prep.n)

    def call(T, q0):
        w, x, y, z = (float(v) for v in quat_from_matrix(T))
        pos, orn, start = T[:3, 3].tolist(), [x, y, z, w], q0.tolist()
        return lambda: pb.calculateInverseKinematics(body, ee, pos, orn, currentPositions=start, physicsClientId=cid,
                                                     **kw)
    return call


def _bare_ikpy(prep, s):
    chain, act, n_links, lim = prep.memo(("peers", "ikpy"), None)

    def call(T, q0):
        init = np.zeros(n_links)
        init[act] = np.clip(q0, lim[:, 0], lim[:, 1])
        pos, rot = T[:3, 3].copy(), T[:3, :3].copy()
        return lambda: chain.inverse_kinematics(pos, rot, orientation_mode="all", initial_position=init)
    return call


def _bare_qp(lib_name: str):
    """The documented loop written directly on the library's objects (the label's own, built once)."""
    def make(prep, s):
        lib = importlib.import_module(lib_name)
        if lib_name == "pink":
            _, pin, conf, task = prep.memo(("peers", "pink"), None)
            target, kw = (lambda T: pin.SE3(T)), {"solver": "daqp", "safety_break": False}
        else:
            _, conf, task, climit = prep.memo(("peers", "mink"), None)
            target, kw = lib.SE3.from_matrix, {"limits": [climit]}

        def loop(T, q0):
            task.set_target(target(T))
            conf.update(q0)
            for _ in range(s.max_iterations):
                e = task.compute_error(conf)
                if np.linalg.norm(e[:3]) <= s.pos_threshold and np.linalg.norm(e[3:]) <= s.ori_threshold:
                    break
                v = lib.solve_ik(conf, [task], 1.0, *(["daqp"] if lib_name == "mink" else []), **kw)
                conf.integrate_inplace(v, 1.0)
        return lambda T, q0: (lambda: loop(T, q0))
    return make


PEERS = [("eaik", None, _bare_eaik), ("ik_geo", None, _bare_ik_geo), ("ur_analytic_ik", None, _bare_ur),
         ("rtb_ik_lm", None, _bare_rtb), ("pybullet_ik", None, _bare_pybullet), ("pybullet_ik", TUNED, _bare_pybullet),
         ("ikpy", None, _bare_ikpy), ("pink", None, _bare_qp("pink")), ("mink", None, _bare_qp("mink"))]


def measure(label: str, settings, make_bare, n: int) -> dict:
    """Medians [µs] of the bare call, the label's solve time and call time on the same ``n`` goals."""
    robot = load_robot(ROOT / "data" / "robots" / f"{ROBOT.get(label, 'franka_panda')}.yaml")
    try:
        b = bind(label, robot, settings)
    except NotApplicableError as exc:
        return {"label": label, "robot": robot.name, "note": str(exc).split(": ", 2)[-1]}
    m = metric(b.prep)
    n = SLOW.get(label, n) or n
    goals, starts = _goals(robot, n)
    bare = make_bare(b.prep, b.settings)
    for T, q0 in zip(goals[:3], starts[:3]):  # warm both paths up
        bare(m.goal(T), m.q_in(q0))()
        b.solve(T, q0)
    t_bare, t_solve, t_call, ok = [], [], [], 0
    for i, (T, q0) in enumerate(zip(goals, starts)):
        thunk = bare(m.goal(T), m.q_in(q0))  # the bare call's arguments, made before its clock starts
        for first in ((0, 1) if i % 2 else (1, 0)):  # alternate the order
            if first == 0:
                t0 = time.perf_counter_ns()
                thunk()
                t_bare.append(time.perf_counter_ns() - t0)
            else:
                r = b.solve(T, q0)
                t_solve.append(r.solve_time_s * 1e9)
                t_call.append(r.call_time_s * 1e9)
                ok += bool(r.success)
    med = {k: float(np.median(v)) / 1e3 for k, v in (("bare", t_bare), ("solve", t_solve), ("call", t_call))}
    return {"label": label, "robot": robot.name, "n": n, "solved": ok, **med,
            "solve/bare": med["solve"] / med["bare"], "call/bare": med["call"] / med["bare"]}


def table(rows: list[dict]) -> str:
    out = ["| label | settings | robot | goals | solved | bare call p50 [µs] | solve time p50 [µs] | "
           "call time p50 [µs] | solve / bare | call / bare |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if "note" in r:
            out.append(f"| {r['label']} | {r['settings']} | {r['robot']} | - | - | - | - | - | - | {r['note']} |")
            continue
        out.append(f"| {r['label']} | {r['settings']} | {r['robot']} | {r['n']} | {r['solved']} | {r['bare']:.1f} | "
                   f"{r['solve']:.1f} | {r['call']:.1f} | {r['solve/bare']:.2f} | {r['call/bare']:.2f} |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--goals", type=int, default=200)
    ap.add_argument("--only", nargs="*", help="labels to run (default: every peer)")
    ap.add_argument("--out", default=None, help="also write the table here (markdown)")
    args = ap.parse_args(argv)
    rows = []
    for label, settings, make in PEERS:
        if args.only and label not in args.only:
            continue
        r = measure(label, settings, make, args.goals)
        r["settings"] = "default" if not settings else ", ".join(f"{k}={v}" for k, v in settings.items())
        rows.append(r)
        print(table([r]).splitlines()[-1], flush=True)
    text = table(rows) + f"\n\nload average {os.getloadavg()}\n"
    print(text)
    if args.out:
        Path(args.out).write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
