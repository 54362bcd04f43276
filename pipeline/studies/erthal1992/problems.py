"""Problem-set generators of study erthal1992 (``problem_sets`` of data/studies/erthal1992.yaml).

Signature (see :data:`pipeline.problems.Generator`): ``fn(model, count, rng, params, data_dir) ->
ProblemSet``. The document's problems are fixed points, so ``rng`` is unused and ``count`` must equal
the number of problems the parameters define (a mismatch is a one-line error).

* :func:`test_goals`  — the goals of an IK test (Tests 1, 2, 3, 6): every goal from the test's start
  configuration, or (``chain: true``) each from the previous goal's solution.
* :func:`path_goals`  — a path task (TAREFA, §5.2.3): the frames solved along the path, one chain:
  the segment endpoints (joint interpolation) or every interpolated frame (Cartesian interpolation;
  a segment's first frame is the previous segment's last and is not solved again).

Goals are written in the robot file's frame and unit: the document's goals are in the robot's base
frame at its mounting surface (A4.2), which ``data/erthal1992/robot_bases.yaml`` places relative to
DH frame 0 of the robot file, so a goal ``T`` becomes ``B^-1 T`` (``B`` = that placement).
Goal angles are unknown (NaN).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pipeline.kinematics import quat_from_matrix
from pipeline.problems import ProblemSet, ProblemSpecError
from pipeline.robots import RobotModel

from pipeline.studies.erthal1992.inputs import RunError, goal_frame, q_from_settings, robot_base
from pipeline.studies.erthal1992.tasks import Task, cartesian_points, load_task

INTERPOLATIONS = ("joint", "cartesian")


def placement(data_dir: Path, robot: str) -> np.ndarray:
    """``B`` (4, 4): DH frame 0 of the robot file in the document's base frame (identity if not listed)."""
    B = np.eye(4)
    pos = robot_base(data_dir, robot)
    if pos is not None:
        B[:3, 3] = pos
    return B


def _problem_set(model: RobotModel, q_start: np.ndarray, goals: np.ndarray, chain: bool) -> ProblemSet:
    m = len(goals)
    return ProblemSet(np.arange(m), np.tile(q_start, (m, 1)), np.full((m, model.n), np.nan), goals[:, :3, 3].copy(),
                      quat_from_matrix(goals[:, :3, :3]), model.name, model.length_unit,
                      np.zeros(m, dtype=int) if chain else np.full(m, -1, dtype=int))


def _check_count(count: int, m: int, what: str) -> None:
    if count != m:
        raise ProblemSpecError(f"field 'count': {what} defines {m} problems, count says {count}")


def test_goals(model: RobotModel, count: int, rng: np.random.Generator, params: dict, data_dir: Path) -> ProblemSet:
    """Goals of one IK test.

    params
    ------
    q_start : list [deg | mm]       start configuration (Tables 6.5, 6.8, 6.15)
    goals : list of {point, p, u_a?, u_t?} [mm]   z = u_a, y = u_t (A5.1-A5.6); ``p`` only: identity
                                    orientation (a position-only goal, solved with ``criterion: position``)
    chain : bool                    each goal from the previous goal's solution (default false)
    """
    try:
        q0 = q_from_settings(model, params["q_start"])
        goals = np.array([goal_frame(g) for g in params["goals"]])
    except KeyError as exc:
        raise ProblemSpecError(f"field 'params/{exc.args[0]}': missing") from None
    except RunError as exc:
        raise ProblemSpecError(f"field 'params/q_start': {exc}") from None
    _check_count(count, len(goals), "params/goals")
    B_inv = np.linalg.inv(placement(data_dir, model.name))
    return _problem_set(model, q0, B_inv @ goals, bool(params.get("chain", False)))


def path_layout(task: Task, interpolation: str) -> np.ndarray:
    """Frames solved along a path (w.r.t. the auxiliary frame), in solve order, shape (m, 4, 4).

    joint: the segment endpoints 0..S (the RES rows in between are interpolated in joint space);
    cartesian: all k frames of segment 0, then frames 1..k-1 of every later segment (frame 0 of a
    segment is the previous segment's last, already solved).
    """
    if interpolation == "joint":
        return np.array(task.points)
    if interpolation != "cartesian":
        raise ProblemSpecError(f"field 'params/interpolation': {interpolation!r} is not one of {list(INTERPOLATIONS)}")
    k = task.points_per_segment
    frames = []
    for s in range(task.segments):
        frames += list(cartesian_points(task.points[s], task.points[s + 1], k)[0 if s == 0 else 1:])
    return np.array(frames)


def path_task(params: dict, data_dir: Path, robot: str) -> Task:
    """The task file of a path set with the set's per-robot overrides (auxiliary frame position)."""
    from dataclasses import replace

    try:
        task = load_task(Path(data_dir) / "erthal1992" / params["task"])
    except KeyError:
        raise ProblemSpecError("field 'params/task': missing") from None
    aux = (params.get("auxiliary_position") or {}).get(robot)
    if aux is not None:
        T_aux = task.T_aux.copy()
        T_aux[:3, 3] = aux
        task = replace(task, T_aux=T_aux)
    return task


def path_goals(model: RobotModel, count: int, rng: np.random.Generator, params: dict, data_dir: Path) -> ProblemSet:
    """The IK problems of a path task, one chain (each from the previous solution).

    params
    ------
    task : str                      task file under data/erthal1992/
    interpolation : joint | cartesian
    initial_position : {robot: list [deg | mm]}     replaces the task's start (Table 6.13)
    auxiliary_position : {robot: [x, y, z] mm}     replaces the auxiliary frame origin (Table 6.14)
    """
    task = path_task(params, data_dir, model.name)
    frames = path_layout(task, params.get("interpolation", "joint"))
    _check_count(count, len(frames), f"task {params['task']} with {params.get('interpolation', 'joint')} interpolation")
    init = (params.get("initial_position") or {}).get(model.name)
    try:
        q0 = q_from_settings(model, init) if init is not None else np.asarray(task.q_start, dtype=float)
    except RunError as exc:
        raise ProblemSpecError(f"field 'params/initial_position': {exc}") from None
    if len(q0) != model.n:
        raise ProblemSpecError(f"field 'params/initial_position': {len(q0)} values, {model.name} has {model.n} joints")
    B_inv = np.linalg.inv(placement(data_dir, model.name))
    goals = np.array([B_inv @ task.goal_in_base(T) for T in frames])
    return _problem_set(model, q0, goals, chain=True)
