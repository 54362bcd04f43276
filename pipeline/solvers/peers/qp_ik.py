"""Peer differential-IK libraries built on a QP per step: pink, mink and placo, as registered baselines.

These libraries solve one *differential* IK step per call (a velocity that best serves weighted tasks
under limits, found by a quadratic program); reaching a pose means calling that step in a loop. Each
peer here runs the library's documented set-up (a frame task on the tool, the configuration limit,
the QP solved by ``daqp``) inside one fixed-step loop, the same for all three:

    for k in 0 .. max_iterations:
        e = task error at q (the library's own ``compute_error``: body twist, linear part first)
        stop (success) when |e_lin| <= pos_threshold [m] and |e_ang| <= ori_threshold [rad]
        stop (ITERATION_CAP) when k == max_iterations
        v = the library's solve_ik(configuration, [task], dt, solver, damping, limits)
        q = the library's integrate(q, v dt)

``dt`` = 1 s makes one step a full (damped, limit-constrained) Gauss-Newton step of the task, whose
gain is 1; the configuration limit then bounds a step to the library's gain times the distance to
the limits, so every iterate stays within the limits. The start is moved into the limits first
(pink refuses a start outside them; mink's limit QP would be infeasible). ``iterations`` = the steps
taken. When the library's QP solver finds no step (its ``NoSolutionFound``) the loop stops there:
``STALLED``. ``solve_time_s`` is the whole loop (the configuration's update at the start included); the
task, limits and configuration objects are built once per job.

``pink``
    pink (Caron et al., "Pink: Python inverse kinematics based on Pinocchio",
    https://github.com/stephane-caron/pink; PyPI ``pin-pink``): ``pink.Configuration`` on the
    Pinocchio model of ``pinocchio_clik`` (built in code from ``as_general()``) with the robot
    file's joint limits as ``lowerPositionLimit``/``upperPositionLimit`` (unbounded joints get
    Pinocchio's "no limit"), ``FrameTask("tool0", position_cost=1, orientation_cost=1)``,
    ``pink.solve_ik(..., solver="daqp")`` with pink's default limits (configuration limit, gain
    0.5; the velocity limit is empty: the robot files give no velocities), ``integrate_inplace``.
    pink installs no QP backend: the ``peers`` extra adds ``daqp``.
``mink``
    mink (Zakka, "mink: Python inverse kinematics based on MuJoCo", https://github.com/kevinzakka/mink):
    ``mink.Configuration`` on a MuJoCo model built in code with ``mujoco.MjSpec`` (one body per
    joint at ``base · origin_1`` then ``origin_i``, a hinge or slide joint on the axis with the
    robot file's range, a site ``tool0`` at the tool; angles in radians; FK checked against ours
    once), ``FrameTask("tool0", "site", position_cost=1, orientation_cost=1)``,
    ``mink.ConfigurationLimit`` (gain 0.95, mink's default), ``mink.solve_ik(..., solver="daqp")``,
    ``integrate_inplace``. Building the model in code keeps the tool frame that a URDF read by
    MuJoCo's compiler would fuse away.
``placo``
    placo (Rhoban, https://github.com/Rhoban/placo): placo 0.10.2 pins ``pin==3.8.0`` and cannot be
    installed beside this environment's ``pin`` 4.1.0 (which ``pinocchio_clik`` and ``pink`` use),
    so it is not in the lock; where it cannot be imported its rows say so. Where it can (an
    environment of its own): ``RobotWrapper`` of the exported URDF, ``KinematicsSolver`` with the
    floating base masked, ``add_frame_task("tool0", T)`` configured soft with weights 1 and 1, the
    loop above around ``solver.solve(True)`` and ``robot.update_kinematics()`` (placo's joint limits
    on by default). That path is written from placo's documentation and is untested here.
"""

from __future__ import annotations

import importlib
import math
import os
import tempfile
from dataclasses import dataclass

import numpy as np

from pipeline.kinematics import fk_htm
from pipeline.solvers.core import Prepared, Raw, Settings, SettingsError, StopReason, setting
from pipeline.solvers.core.driver import run_of
from pipeline.solvers.core.models import metric
from pipeline.solvers.core.registry import Solver, register
from pipeline.solvers.core.timing import clock_ns
from pipeline.solvers.peers.libraries import (TIME, library, model_applies, peer_code, pin_model, returned_angles,
                                              start_end_trace)

SOURCE_PINK = ("Caron et al., Pink: Python inverse kinematics based on Pinocchio (https://github.com/stephane-caron/"
               "pink); pin-pink 4.4.0 with the daqp QP solver")
SOURCE_MINK = ("Zakka, mink: Python inverse kinematics based on MuJoCo (https://github.com/kevinzakka/mink); mink 1.3.0 "
               "on mujoco 4.0.0 with the daqp QP solver")
SOURCE_PLACO = "Rhoban, placo (https://github.com/Rhoban/placo); placo 0.10.2 KinematicsSolver"
PLACO_REFUSAL = ("not installable beside pin 4.1.0: placo 0.10.2 pins pin==3.8.0 (pip install placo==0.10.2 in an "
                 "environment of its own)")
FK_MATCH_TOL = 1e-9  # [m, 1] mink's MuJoCo model must reproduce our FK to this
NO_LIMIT = np.finfo(float).max  # Pinocchio's "no limit" for a joint without one
_QS = np.random.default_rng(4343).uniform(-1.0, 1.0, (3, 64))


@dataclass(frozen=True)
class QPLoopSettings(Settings):
    """The fixed-step loop around a differential-IK library's step (the same for pink, mink, placo)."""

    max_iterations: int = setting(100, "cap on the loop's steps (each one QP)", minimum=1, maximum=100_000)
    pos_threshold: float = setting(1e-5, "stop when the task's linear error is at most this (a tenth of the FK "
                                   "check's default tol_pos)", unit="m", above=0.0)
    ori_threshold: float = setting(1e-4, "stop when the task's angular error is at most this (a tenth of the FK "
                                   "check's default tol_rot)", unit="rad", above=0.0)
    dt: float = setting(1.0, "integration step of the velocity: 1 s = one full Gauss-Newton step of the task",
                        unit="s", above=0.0)
    damping: float = setting(1e-12, "the library's Tikhonov damping of the QP (pink and mink default 1e-12)",
                             minimum=0.0)
    limits: bool = setting(True, "enforce the configuration limit (the libraries' default)")
    qp_solver: str = setting("daqp", "the QP solver (qpsolvers name; daqp is the one the lock installs)",
                             choices=("daqp", "quadprog", "proxqp"))


def _qp_solver(s: QPLoopSettings) -> str:
    """The settings' QP solver, refused in one line when qpsolvers does not find it installed."""
    have = importlib.import_module("qpsolvers").available_solvers
    if s.qp_solver not in have:
        raise SettingsError(f"field 'qp_solver': {s.qp_solver!r} is not installed (installed: {', '.join(have) or 'none'}; "
                            f"the lock installs daqp)")
    return str(s.qp_solver)


def _bounds(lim: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) of the limits (n, 2), ±inf where a joint has none (made once per job)."""
    return (np.where(np.isfinite(lim[:, 0]), lim[:, 0], -np.inf).copy(),
            np.where(np.isfinite(lim[:, 1]), lim[:, 1], np.inf).copy())


def _into_limits(q: np.ndarray, bounds: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """``q`` moved into the limits (np.clip costs ~10x more on a short vector)."""
    return np.minimum(np.maximum(q, bounds[0]), bounds[1])


def _loop(error, step, q0_update, it_max: int, pos_tol: float, ori_tol: float, qp_failed=()):
    """The fixed-step loop; returns (success, steps, |e_lin|, |e_ang|, QP failed)."""
    q0_update()
    k = 0
    while True:
        e = error()
        el, ea = float(np.linalg.norm(e[:3])), float(np.linalg.norm(e[3:]))
        if el <= pos_tol and ea <= ori_tol:
            return True, k, el, ea, False
        if k >= it_max or not (math.isfinite(el) and math.isfinite(ea)):
            return False, k, el, ea, False
        try:
            step()
        except qp_failed:  # the library's NoSolutionFound: its QP solver found no step
            return False, k, el, ea, True
        k += 1


def _loop_run1(prep: Prepared, s: QPLoopSettings, conf, target, error, step, failed):
    """run1(T_goal, q_start, seed) -> Raw of a fixed-step QP peer: the task's target set from the goal
    (``target(T)`` with T (4, 4) in metres), the start moved into the limits, then :func:`_loop` timed
    (its cap ``max_iterations``, its stop test ``pos_threshold`` / ``ori_threshold``)."""
    m = metric(prep)
    it_max, pos_tol, ori_tol = int(s.max_iterations), float(s.pos_threshold), float(s.ori_threshold)
    bounds = _bounds(m.limits)

    def run1(T_goal: np.ndarray, q_start: np.ndarray, seed: int) -> Raw:
        target(m.goal(T_goal))
        q0 = _into_limits(m.q_in(q_start), bounds)
        t0 = clock_ns()
        out = _loop(lambda: error(conf), step, lambda: conf.update(q0), it_max, pos_tol, ori_tol, failed)
        ns = clock_ns() - t0
        return _raw(prep, T_goal, q_start, s, np.array(conf.q), out, ns)
    return run1


def _raw(prep, T_goal, q_start, s, qm, out, ns) -> Raw:
    ok, k, el, ea, qp_failed = out
    m = metric(prep)
    q = returned_angles(prep, m.q_out(qm), s)
    code = peer_code(ok, StopReason.STALLED if qp_failed else StopReason.ITERATION_CAP)
    if not np.all(np.isfinite(q)):
        code = int(StopReason.NON_FINITE)
    return Raw(q=q, code=code, iterations=int(k), solve_ns=int(ns), trace=start_end_trace(prep, T_goal, q_start, q),
               info={"task_error_lin": el, "task_error_ang": ea, "qp_failed": bool(qp_failed), "peer_success": bool(ok)})


# ---- pink -------------------------------------------------------------------------------------
def _pink_model(prep: Prepared):
    """(pink, pin, configuration, frame task, limits or None) on the CLIK peer's model with the limits set."""
    pink = importlib.import_module("pink")
    from pink.tasks import FrameTask

    pin, model0, *_ = pin_model(prep)
    m = metric(prep)
    model = pin.Model(model0)
    lo = np.where(np.isfinite(m.limits[:, 0]), m.limits[:, 0], -NO_LIMIT)
    hi = np.where(np.isfinite(m.limits[:, 1]), m.limits[:, 1], NO_LIMIT)
    model.lowerPositionLimit, model.upperPositionLimit = lo, hi
    conf = pink.Configuration(model, model.createData(), np.clip(np.zeros(m.n), lo, hi))
    task = FrameTask("tool0", position_cost=1.0, orientation_cost=1.0)
    return pink, pin, conf, task


def _pink_applies(prep: Prepared) -> str | None:
    why = library("qpsolvers")
    if isinstance(why, str):
        return why
    if not importlib.import_module("qpsolvers").available_solvers:
        return "pink found no QP solver (pip install daqp)"
    return model_applies(prep, "pink", "pink", _pink_model, "pink could not build its configuration")


def _pink_bind(prep: Prepared, s: QPLoopSettings):
    """run1(T_goal, q_start, seed) -> Raw with the configuration, task and loop made once per job."""
    pink, pin, conf, task = prep.memo(("peers", "pink"), lambda: _pink_model(prep))
    limits = None if s.limits else []
    dt, solver, damping = float(s.dt), _qp_solver(s), float(s.damping)
    failed = importlib.import_module("pink.exceptions").NoSolutionFound
    solve_ik, error = pink.solve_ik, task.compute_error

    def step():
        conf.integrate_inplace(solve_ik(conf, [task], dt, solver=solver, damping=damping, limits=limits,
                                        safety_break=False), dt)

    return _loop_run1(prep, s, conf, lambda G: task.set_target(pin.SE3(G)), error, step, failed)


register(Solver("pink", "pink (Pinocchio differential IK: frame task, configuration limit, daqp QP) in a fixed-step "
                f"loop from the start (peer baseline; {TIME}, Python loop included)", "local", QPLoopSettings,
                run_of(_pink_bind), applies_to=_pink_applies, source=SOURCE_PINK, bind=_pink_bind, library="pin-pink"))


# ---- mink -------------------------------------------------------------------------------------
def mujoco_chain(mujoco, base: np.ndarray, origins: np.ndarray, axes: np.ndarray, prismatic: np.ndarray,
                 limits: np.ndarray, tool: np.ndarray):
    """A MuJoCo model of a serial chain, built with ``MjSpec``: one body per joint, a site ``tool0``.

    Parameters
    ----------
    mujoco : module
        The ``mujoco`` package.
    base : ndarray, shape (4, 4) [m]
        World to the chain's base frame.
    origins : ndarray, shape (n, 4, 4) [m]
        Fixed transform before each joint's motion (:meth:`Chain.as_general`).
    axes : ndarray, shape (n, 3) [1]
        Each joint's unit axis in its frame.
    prismatic : ndarray of bool, shape (n,)
    limits : ndarray, shape (n, 2) [rad | m]
        Joint ranges; a non-finite bound leaves the joint unlimited.
    tool : ndarray, shape (4, 4) [m]
        Last joint frame to the tool frame.

    Returns
    -------
    mujoco.MjModel
        Angles in radians (``compiler.degree`` off); each body has unit mass and a small diagonal
        inertia (MuJoCo requires mass on moving bodies; kinematics ignore it).
    """
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    body = spec.worldbody

    def quat(T):
        out = np.zeros(4)
        mujoco.mju_mat2Quat(out, np.ascontiguousarray(T[:3, :3], dtype=float).reshape(-1))
        return out

    for i in range(len(axes)):
        F = base @ origins[0] if i == 0 else origins[i]
        body = body.add_body(name=f"link{i + 1}", pos=F[:3, 3], quat=quat(F), mass=1.0, inertia=[1e-2] * 3,
                             explicitinertial=True)
        kind = mujoco.mjtJoint.mjJNT_SLIDE if prismatic[i] else mujoco.mjtJoint.mjJNT_HINGE
        j = body.add_joint(name=f"joint{i + 1}", type=kind, axis=np.asarray(axes[i], dtype=float))
        lo, hi = limits[i]
        if math.isfinite(lo) and math.isfinite(hi):
            j.range = [float(lo), float(hi)]
            j.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        else:
            j.limited = mujoco.mjtLimited.mjLIMITED_FALSE
    body.add_site(name="tool0", pos=tool[:3, 3], quat=quat(tool))
    return spec.compile()


def _mink_model(prep: Prepared):
    """(mink, configuration, frame task, configuration limit), the model's FK checked against ours."""
    mink = importlib.import_module("mink")
    mujoco = importlib.import_module("mujoco")
    m = metric(prep)
    model = mujoco_chain(mujoco, m.base, m.origins, m.axes, m.prismatic, m.limits, m.tool)
    conf = mink.Configuration(model)
    err = 0.0
    for row in _QS:
        q = row[: m.n].copy()
        q[m.prismatic] *= 0.1
        conf.update(q)
        T = conf.get_transform_frame_to_world("tool0", "site").as_matrix()
        err = max(err, float(np.abs(T - fk_htm(m.model.chain, q)).max()))
    if err > FK_MATCH_TOL:
        raise ValueError(f"mink's MuJoCo model differs from our FK by {err:.3g} m")
    task = mink.FrameTask("tool0", "site", position_cost=1.0, orientation_cost=1.0)
    return mink, conf, task, mink.ConfigurationLimit(model)


def _mink_applies(prep: Prepared) -> str | None:
    why = library("mujoco")
    if isinstance(why, str):
        return why
    return model_applies(prep, "mink", "mink", _mink_model, "mink could not build its configuration")


def _mink_bind(prep: Prepared, s: QPLoopSettings):
    """run1(T_goal, q_start, seed) -> Raw with the configuration, task, limits and loop made once per job."""
    mink, conf, task, climit = prep.memo(("peers", "mink"), lambda: _mink_model(prep))
    limits = [climit] if s.limits else []
    dt, solver, damping = float(s.dt), _qp_solver(s), float(s.damping)
    failed = importlib.import_module("mink.exceptions").NoSolutionFound
    solve_ik, error = mink.solve_ik, task.compute_error

    def step():
        conf.integrate_inplace(solve_ik(conf, [task], dt, solver, damping=damping, limits=limits), dt)

    return _loop_run1(prep, s, conf, lambda G: task.set_target(mink.SE3.from_matrix(G)), error, step, failed)


register(Solver("mink", "mink (MuJoCo differential IK: frame task, configuration limit, daqp QP) in a fixed-step loop "
                f"from the start (peer baseline; {TIME}, Python loop included)", "local", QPLoopSettings,
                run_of(_mink_bind), applies_to=_mink_applies, source=SOURCE_MINK, bind=_mink_bind, library="mink"))


# ---- placo ------------------------------------------------------------------------------------
def _placo_model(prep: Prepared):
    """(placo robot, solver, frame task, joint names) of the exported URDF (untested here: see above)."""
    placo = importlib.import_module("placo")
    from pipeline.urdf import to_urdf

    fd, path = tempfile.mkstemp(suffix=".urdf", prefix="ik_peer_")
    with os.fdopen(fd, "w") as f:
        f.write(to_urdf(metric(prep).model))
    try:
        robot = placo.RobotWrapper(path)
    finally:
        os.unlink(path)
    solver = placo.KinematicsSolver(robot)
    solver.mask_fbase(True)
    task = solver.add_frame_task("tool0", np.eye(4))
    task.configure("tool0", "soft", 1.0, 1.0)
    return robot, solver, task, list(robot.joint_names())


def _placo_applies(prep: Prepared) -> str | None:
    if isinstance(library("placo"), str):
        return PLACO_REFUSAL
    return model_applies(prep, "placo", "placo", _placo_model, "placo could not load the exported URDF")


def _placo_run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: QPLoopSettings, seed: int) -> Raw:
    robot, solver, task, names = prep.memo(("peers", "placo"), lambda: _placo_model(prep))
    m = metric(prep)
    Tm = m.goal(T_goal)
    task.T_world_frame = Tm
    bounds = _bounds(m.limits)
    q0 = _into_limits(m.q_in(q_start), bounds)

    def start():
        for name, v in zip(names, q0):
            robot.set_joint(name, float(v))
        robot.update_kinematics()

    def error():
        T = robot.get_T_world_frame("tool0")
        dp = Tm[:3, 3] - T[:3, 3]
        c = (np.trace(Tm[:3, :3] @ T[:3, :3].T) - 1.0) / 2.0
        return np.r_[dp, math.acos(min(1.0, max(-1.0, c))), 0.0, 0.0]

    def step():
        solver.solve(True)
        robot.update_kinematics()

    t0 = clock_ns()
    out = _loop(error, step, start, int(s.max_iterations), float(s.pos_threshold), float(s.ori_threshold))
    ns = clock_ns() - t0
    q = np.array([robot.get_joint(name) for name in names], dtype=float)
    return _raw(prep, T_goal, q_start, s, q, out, ns)


register(Solver("placo", "placo (Pinocchio QP kinematics solver: frame task, joint limits) in a fixed-step loop from "
                f"the start (peer baseline; {TIME}, Python loop included; {PLACO_REFUSAL.split(':')[0]})", "local",
                QPLoopSettings, _placo_run, applies_to=_placo_applies, source=SOURCE_PLACO, library="placo"))
