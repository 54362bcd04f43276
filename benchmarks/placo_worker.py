"""placo's side of ``benchmarks/bench_placo.py``: run in placo's own venv (``benchmarks/placo_env.sh``).

Usage (the benchmark calls it; by hand only to debug)::

    /tmp/placo-venv/bin/python benchmarks/placo_worker.py IN.npz OUT.npz

Imports numpy and placo only (not the project: its lock's pin 4.1.0 is not this venv's pin 3.8.0).

``IN.npz`` holds ``urdf`` (the arm's URDF text, from the project's ``to_urdf``), ``joints`` (its moving
joints' names in the chain's order), ``tip`` (the tool frame's name), ``goals`` (N, 4, 4) [m],
``starts`` (N, n) [rad | m], ``restart_starts`` (N, R, n) [rad | m], ``max_iterations``,
``pos_threshold`` [m], ``ori_threshold`` [rad], ``seed`` (the order of the two calls per goal) and
``fk_q`` (M, n) [rad | m] (joint vectors whose tool pose placo returns as ``fk_T`` (M, 4, 4) [m]).

placo's documented kinematics-solver set-up (placo.readthedocs.io, "Kinematics / Getting started" and
"Joint and velocity limits"): ``RobotWrapper`` of the URDF, ``KinematicsSolver`` with the floating base
masked, ``add_frame_task(tip, T)`` configured ``"soft"`` with position and orientation weights 1, joint
limits on (placo's default), velocity limits off (placo's default). Around it the fixed-step loop of
``pipeline/solvers/peers/qp_ik.py``:

    set the start, update_kinematics()
    for k in 0 .. max_iterations:
        e_lin = |p_goal - p_tip| [m], e_ang = rotation angle of R_goal R_tipᵀ [rad]
        stop (converged) when e_lin <= pos_threshold and e_ang <= ori_threshold
        stop (cap) when k == max_iterations
        solver.solve(True); robot.update_kinematics()      (a QP error stops the loop: stalled)

Two calls per goal, in a seeded order: ``single`` (the loop from the goal's start) and ``restarts``
(the loop from the start, then from each restart start in turn until one converges; R restarts at
most). Each call is timed whole (setting the target and starts, every loop, reading the angles back)
by this thread's CPU clock (``CLOCK_THREAD_CPUTIME_ID``) and by the monotonic clock. After the timed
call, placo's bare steps are timed alone (``bare_cpu_s``): the same starts, each with the number of
steps the loop took, no stop test (placo is deterministic, so the replay ends on the same angles;
``replay_dq`` is the largest difference).

``OUT.npz``: per call kind ``{single,restarts}_q`` (N, n), ``_converged`` (N,) placo's own stop test,
``_iterations`` (N,) steps over all starts, ``_stalled`` (N,), ``_cpu_s``, ``_wall_s``, ``_bare_cpu_s`` (N,) [s],
``_replay_dq`` (N,) [rad | m]; ``restarts_used`` (N,);
``versions`` (placo, pin, numpy, python).
"""

from __future__ import annotations

import importlib.metadata as md
import math
import os
import platform
import sys
import tempfile
import time

import numpy as np


def build(urdf: str, tip: str):
    """(robot, solver, task) of placo's documented set-up on the URDF text."""
    import placo

    fd, path = tempfile.mkstemp(suffix=".urdf", prefix="placo_arm_")
    with os.fdopen(fd, "w") as f:
        f.write(urdf)
    try:
        robot = placo.RobotWrapper(path)
    finally:
        os.unlink(path)
    solver = placo.KinematicsSolver(robot)
    solver.mask_fbase(True)
    solver.enable_joint_limits(True)  # placo's default, written out
    task = solver.add_frame_task(tip, np.eye(4))
    task.configure(tip, "soft", 1.0, 1.0)
    return robot, solver, task


def loop(robot, solver, tip, joints, goal, q0, it_max, pos_tol, ori_tol):
    """The fixed-step loop from ``q0`` to ``goal`` (:func:`goal_lists`); returns (converged, steps, stalled).

    The stop test is plain Python on the tip's pose as a list (numpy's small-array calls cost 7.9 µs a
    step here against placo's own step of 3 µs; this costs about 2 µs)."""
    (gx, gy, gz), R = goal
    for name, v in zip(joints, q0):
        robot.set_joint(name, float(v))
    robot.update_kinematics()
    k = 0
    while True:
        F = robot.get_T_world_frame(tip).tolist()
        F0, F1, F2 = F[0], F[1], F[2]
        el = math.sqrt((gx - F0[3]) ** 2 + (gy - F1[3]) ** 2 + (gz - F2[3]) ** 2)
        tr = (R[0] * F0[0] + R[1] * F0[1] + R[2] * F0[2] + R[3] * F1[0] + R[4] * F1[1] + R[5] * F1[2]
              + R[6] * F2[0] + R[7] * F2[1] + R[8] * F2[2])  # trace(R_goal R_tipᵀ)
        ea = math.acos(min(1.0, max(-1.0, (tr - 1.0) / 2.0)))
        if el <= pos_tol and ea <= ori_tol:
            return True, k, False
        if k >= it_max or not (math.isfinite(el) and math.isfinite(ea)):
            return False, k, False
        try:
            solver.solve(True)
        except RuntimeError:  # placo's QP found no solution
            return False, k, True
        robot.update_kinematics()
        k += 1


def goal_lists(T: np.ndarray):
    """((x, y, z), R row-major as 9 floats) of a goal (4, 4) [m], for the loop's plain-Python stop test."""
    t = T.tolist()
    return (t[0][3], t[1][3], t[2][3]), [*t[0][:3], *t[1][:3], *t[2][:3]]


def replay(robot, solver, joints, runs) -> None:
    """placo's bare steps of a call: from each start, its recorded number of steps, no stop test."""
    for q0, k in runs:
        for name, v in zip(joints, q0):
            robot.set_joint(name, float(v))
        robot.update_kinematics()
        for _ in range(k):
            solver.solve(True)
            robot.update_kinematics()


def main() -> None:
    src, dst = sys.argv[1], sys.argv[2]
    d = np.load(src, allow_pickle=False)
    tip, joints = str(d["tip"]), [str(j) for j in d["joints"]]
    G, S, RS = d["goals"], d["starts"], d["restart_starts"]
    it_max, pos_tol, ori_tol = int(d["max_iterations"]), float(d["pos_threshold"]), float(d["ori_threshold"])
    robot, solver, task = build(str(d["urdf"]), tip)
    lo = np.array([robot.get_joint_limits(j)[0] for j in joints])
    hi = np.array([robot.get_joint_limits(j)[1] for j in joints])
    N, n = S.shape
    floats, ints = ("q", "cpu_s", "wall_s", "bare_cpu_s", "replay_dq"), ("converged", "iterations", "stalled")
    out = {f"{kind}_{f}": np.zeros((N, n) if f == "q" else N, dtype=float if f in floats else int)
           for kind in ("single", "restarts") for f in floats + ints}
    out["restarts_used"] = np.zeros(N, dtype=int)

    def call(i: int, kind: str) -> None:
        c0, w0 = time.thread_time_ns(), time.perf_counter_ns()
        task.T_world_frame = G[i]
        goal = goal_lists(G[i])
        starts = [S[i]] if kind == "single" else [S[i], *RS[i]]
        runs = []
        for q0 in starts:
            q0 = np.minimum(np.maximum(q0, lo), hi)
            ok, k, stalled = loop(robot, solver, tip, joints, goal, q0, it_max, pos_tol, ori_tol)
            runs.append((q0, k))
            if ok:
                break
        q = np.array([robot.get_joint(j) for j in joints])
        c1, w1 = time.thread_time_ns(), time.perf_counter_ns()
        replay(robot, solver, joints, runs)
        c2 = time.thread_time_ns()
        q_again = np.array([robot.get_joint(j) for j in joints])
        out[f"{kind}_q"][i] = q
        out[f"{kind}_converged"][i], out[f"{kind}_stalled"][i] = ok, stalled
        out[f"{kind}_iterations"][i] = sum(k for _, k in runs)
        out[f"{kind}_cpu_s"][i], out[f"{kind}_wall_s"][i] = (c1 - c0) * 1e-9, (w1 - w0) * 1e-9
        out[f"{kind}_bare_cpu_s"][i] = (c2 - c1) * 1e-9
        out[f"{kind}_replay_dq"][i] = float(np.abs(q_again - q).max())
        if kind == "restarts":
            out["restarts_used"][i] = len(runs) - 1

    fk = np.empty((len(d["fk_q"]), 4, 4))  # placo's FK of the model as loaded, for the caller to check
    for r, q in enumerate(d["fk_q"]):
        for name, v in zip(joints, q):
            robot.set_joint(name, float(v))
        robot.update_kinematics()
        fk[r] = robot.get_T_world_frame(tip)
    out["fk_T"] = fk
    call(0, "single")  # first call outside the record (first-touch allocations)
    rng = np.random.default_rng(int(d["seed"]))
    for i in range(N):
        for kind in (("single", "restarts") if rng.random() < 0.5 else ("restarts", "single")):
            call(i, kind)
    out["versions"] = np.array([f"placo {md.version('placo')}", f"pin {md.version('pin')}", f"numpy {np.__version__}",
                                f"python {platform.python_version()}"])
    np.savez(dst, **out)


if __name__ == "__main__":
    main()
