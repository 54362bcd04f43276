"""Replay archived solves as a Foxglove-viewable MCAP (``python -m pipeline replay``).

The archive holds every solve's start, goal and returned joint values, not the iterates in
between; a replay re-runs the chosen problems from the archive's metadata (registered method,
settings, robot, seed) and writes, per frame, the arm in Foxglove's well-known schemas
(foxglove-sdk, protobuf):

=====================  =========================  ==============================================
topic                  schema                     content (lengths in metres, angles in rad)
=====================  =========================  ==============================================
``/tf``                ``foxglove.FrameTransform``  ``world -> base``, ``world -> link_1`` ...
                                                  ``world -> link_n``, ``world -> tool`` (FK)
``/arm``               ``foxglove.SceneUpdate``   entity ``arm``: a line strip through the joint
                                                  origins, a sphere per joint, a text label
``/goal``              ``foxglove.PoseInFrame``   the problem's goal pose (frame ``world``)
``/reached``           ``foxglove.PoseInFrame``   the tool pose of the frame's joint values
``/joint_states``      ``foxglove.JointStates``   joint values (revolute rad, prismatic m)
``/replay/frame``      ``ik_pipeline.ReplayFrame``  JSON: problem id, iteration, errors of the frame
=====================  =========================  ==============================================

Frames
------
``iterations`` (default for single problems): frame k shows the joint values the method returns
when re-run with ``max_iterations = k``, for k = 0 (the start) ... the archived iteration count,
at most ``max_frames`` evenly spaced values of k per problem. For the deterministic iterative
methods of this package that is their k-th iterate (a capped search returns its last iterate);
the solvers are not changed to record iterates. Methods without ``max_iterations`` (analytic
ones), stochastic ones (PSO), and runs that used random restarts show two frames: start and
solution. ``solutions`` (default for ``--all`` on a path study, where each problem starts from the
previous solution): the start of the path, then one frame per problem, its solution, so the arm
follows the path. The last frame of every problem shows the *archived* ``q_solution``; the re-run
is checked against it (to 1e-9) and a difference is reported, not hidden.

Log times: frame f (counted over the whole replay, problems one after the other) at f x ``dt``
(0.05 s), so a viewer's timeline animates the solve. The file is deterministic: the same archive
and options give the same bytes.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pipeline.io.archive import AtomicMcap
from pipeline.names import is_name

TOL = 1e-9  # re-run vs archived q_solution [rad | robot length unit]
# seconds between frames: from 1 us (log times are whole nanoseconds) to one hour, so that every frame's
# log time fits MCAP's unsigned 64-bit nanoseconds (MAX_FRAMES x problems x 3600 s stays far below 584 years)
DT_RANGE = (1e-6, 3600.0)
MAX_FRAMES = 100_000  # iterate frames per problem at most (--max-frames)
FRAME_SCHEMA = {
    "title": "ik_pipeline.ReplayFrame",
    "description": "one replay frame: which problem and iterate the arm shows, and its errors",
    "type": "object",
    "properties": {
        "problem_id": {"type": "integer"}, "solver": {"type": "string"}, "method": {"type": "string"},
        "iteration": {"type": "integer", "description": "iterate shown (0 = start)"},
        "iterations": {"type": "integer", "description": "the archived solve's iteration count"},
        "frame": {"type": "integer"},
        "position_error_m": {"type": ["number", "null"], "description": "|p_goal - p(q)| [m]"},
        "orientation_error_rad": {"type": ["number", "null"], "description": "rotation angle goal vs q [rad]"},
        "success": {"type": "boolean", "description": "the archived solve's FK-verified success"},
        "stop_reason": {"type": "integer"},
        "q": {"type": "array", "items": {"type": "number"}, "description": "joint values [rad | m]"},
    },
}


class ReplayError(ValueError):
    """A replay cannot be made (one line: the archive or robot and why)."""


@dataclass
class ReplaySummary:
    out: Path
    problems: list[int]
    frames: int
    frames_per_problem: dict[int, int]
    mode: str
    mismatches: list[str] = field(default_factory=list)
    topics: dict[str, str] = field(default_factory=dict)


def settings_from_archive(meta: dict, where: str):
    """(method, Settings) from an archive's ``method`` and ``settings`` (JSON of ``{"method", **settings}``)."""
    from pipeline.solvers import SettingsError, make_settings

    try:
        mapping = json.loads(meta["settings"])
    except (KeyError, ValueError) as exc:
        raise ReplayError(f"{where}: metadata field 'settings' is not JSON ({exc})") from None
    if not isinstance(mapping, dict):
        raise ReplayError(f"{where}: metadata field 'settings' is not a mapping")
    method = meta.get("method") or mapping.get("method")
    if not method:
        raise ReplayError(f"{where}: metadata names no registered method ('method'); cannot re-run")
    mapping = {k: v for k, v in mapping.items() if k != "method"}
    try:
        return method, make_settings(method, mapping, f"{where}: metadata field 'settings'")
    except SettingsError as exc:
        raise ReplayError(str(exc)) from None


def _select(arch, problem: int | None, failed: bool) -> list[dict]:
    recs = [r for r in arch.solves if int(r.get("repetition", 0)) == 0]
    if problem is not None:
        recs = [r for r in recs if int(r["problem_id"]) == int(problem)]
        if not recs:
            raise ReplayError(f"{arch.path}: problem {problem} is not in the archive")
    elif failed:
        recs = [r for r in recs if not r["success"]]
        if not recs:
            raise ReplayError(f"{arch.path}: no failed solves to replay")
    if not recs:
        raise ReplayError(f"{arch.path}: no solve records to replay")
    return recs


def _quat_xyzw(T: np.ndarray) -> tuple[float, float, float, float]:
    from pipeline.kinematics import quat_from_matrix

    w, x, y, z = (float(v) for v in quat_from_matrix(T))
    return x, y, z, w


def _rot_angle(Ra: np.ndarray, Rb: np.ndarray) -> float:
    c = (np.trace(Ra.T @ Rb) - 1.0) / 2.0
    return float(math.acos(min(1.0, max(-1.0, c))))


class _Writer(AtomicMcap):
    """The replay file: mcap writer, foxglove-sdk schemas, one channel per topic."""

    def __init__(self, path: Path, metadata: dict[str, str]):
        import foxglove.messages as fm

        self.fm = fm
        super().__init__(path, f"ik-pipeline replay {metadata.get('package_version', '')}")
        self._w.add_metadata("replay", metadata)
        self.channels: dict[str, int] = {}
        self.topics: dict[str, str] = {}
        for topic, cls in (("/tf", fm.FrameTransform), ("/arm", fm.SceneUpdate), ("/goal", fm.PoseInFrame),
                           ("/reached", fm.PoseInFrame), ("/joint_states", fm.JointStates)):
            s = cls.get_schema()
            sid = self._w.register_schema(s.name, s.encoding, bytes(s.data))
            self.channels[topic] = self._w.register_channel(topic, "protobuf", sid)
            self.topics[topic] = s.name
        sid = self._w.register_schema(FRAME_SCHEMA["title"], "jsonschema", json.dumps(FRAME_SCHEMA).encode())
        self.channels["/replay/frame"] = self._w.register_channel("/replay/frame", "json", sid)
        self.topics["/replay/frame"] = FRAME_SCHEMA["title"]
        self._seq = 0

    def add(self, topic: str, t_ns: int, data: bytes) -> None:
        self._w.add_message(self.channels[topic], log_time=t_ns, publish_time=t_ns, sequence=self._seq, data=data)
        self._seq += 1


def _write_frame(w: _Writer, t_ns: int, model_m, q_m: np.ndarray, goal_m: np.ndarray, info: dict,
                 names: list[str]) -> tuple[float, float]:
    """One frame: transforms, wireframe, goal and reached poses, joint states, frame record."""
    from pipeline.kinematics import fk_frames

    fm = w.fm
    ts = fm.Timestamp(t_ns // 1_000_000_000, t_ns % 1_000_000_000)
    frames = fk_frames(model_m.chain, q_m)
    tool = frames[-1] @ model_m.chain.tool
    all_frames = list(frames) + [tool]
    child = ["base"] + [f"link_{i}" for i in range(1, model_m.n + 1)] + ["tool"]

    def pose(T):
        x, y, z, qw = _quat_xyzw(T)
        return fm.Pose(position=fm.Vector3(x=float(T[0, 3]), y=float(T[1, 3]), z=float(T[2, 3])),
                       orientation=fm.Quaternion(x=x, y=y, z=z, w=qw))

    for name, T in zip(child, all_frames):
        x, y, z, qw = _quat_xyzw(T)
        w.add("/tf", t_ns, fm.FrameTransform(
            timestamp=ts, parent_frame_id="world", child_frame_id=name,
            translation=fm.Vector3(x=float(T[0, 3]), y=float(T[1, 3]), z=float(T[2, 3])),
            rotation=fm.Quaternion(x=x, y=y, z=z, w=qw)).encode())
    pts = [fm.Point3(x=float(T[0, 3]), y=float(T[1, 3]), z=float(T[2, 3])) for T in all_frames]
    reach = float(max(np.linalg.norm(np.diff(np.array([T[:3, 3] for T in all_frames]), axis=0), axis=1).sum(), 0.1))
    r = 0.02 * reach
    ok = info["success"]
    color = fm.Color(r=0.2, g=0.6, b=1.0, a=1.0) if ok else fm.Color(r=1.0, g=0.4, b=0.2, a=1.0)
    ident = fm.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
    spheres = [fm.SpherePrimitive(pose=fm.Pose(position=fm.Vector3(x=float(T[0, 3]), y=float(T[1, 3]),
                                                                   z=float(T[2, 3])), orientation=ident),
                                  size=fm.Vector3(x=2 * r, y=2 * r, z=2 * r), color=color) for T in all_frames[:-1]]
    label = (f"problem {info['problem_id']}  iteration {info['iteration']}/{info['iterations']}  "
             f"|dp| {info['position_error_m']:.3g} m")
    T_tool = all_frames[-1]
    text = fm.TextPrimitive(pose=fm.Pose(position=fm.Vector3(x=float(T_tool[0, 3]), y=float(T_tool[1, 3]),
                                                             z=float(T_tool[2, 3]) + 3 * r), orientation=ident),
                            billboard=True, font_size=14.0, scale_invariant=True,
                            color=fm.Color(r=1.0, g=1.0, b=1.0, a=1.0), text=label)
    entity = fm.SceneEntity(timestamp=ts, frame_id="world", id="arm", lines=[fm.LinePrimitive(
        type=fm.LinePrimitiveLineType.LineStrip, thickness=0.5 * r, points=pts, color=color)],
        spheres=spheres, texts=[text])
    w.add("/arm", t_ns, fm.SceneUpdate(entities=[entity]).encode())
    w.add("/goal", t_ns, fm.PoseInFrame(timestamp=ts, frame_id="world", pose=pose(goal_m)).encode())
    w.add("/reached", t_ns, fm.PoseInFrame(timestamp=ts, frame_id="world", pose=pose(T_tool)).encode())
    w.add("/joint_states", t_ns, fm.JointStates(timestamp=ts, joints=[
        fm.JointState(name=nm, position=float(v)) for nm, v in zip(names, q_m)]).encode())
    import orjson

    w.add("/replay/frame", t_ns, orjson.dumps({**info, "q": [float(v) for v in q_m]}))
    return info["position_error_m"], info["orientation_error_rad"]


def _check_frame_args(frames: str, max_frames: int, dt: float) -> None:
    """The frame options of :func:`replay` within their ranges, else a one-line :class:`ReplayError`."""
    if frames not in ("auto", "iterations", "solutions"):
        raise ReplayError(f"frames: {frames!r} is not one of auto, iterations, solutions")
    if not 2 <= max_frames <= MAX_FRAMES:
        raise ReplayError(f"max_frames: must lie in [2, {MAX_FRAMES}], got {max_frames}")
    if not (DT_RANGE[0] <= dt <= DT_RANGE[1]):  # log times are whole nanoseconds in an unsigned 64-bit field
        raise ReplayError(f"dt: must lie in [{DT_RANGE[0]:g}, {DT_RANGE[1]:g}] s (frame log times are nanoseconds), "
                          f"got {dt}")


def _replay_robot(arch, robot: str | Path | None, data: str | Path):
    """The archive's robot, from ``robot`` or ``<data>/robots/<name>.yaml``: ``(model, robot file)``."""
    from pipeline.robots import load_robot

    meta = arch.metadata
    if not robot and not is_name(meta.get("robot")):  # a name, not a path: the robot file is read from --data
        raise ReplayError(f"{arch.path}: metadata field 'robot': {str(meta.get('robot'))[:80]!r} is not a robot name "
                          "(give the robot file with --robot)")
    robot_path = Path(robot) if robot else Path(data) / "robots" / f"{meta['robot']}.yaml"
    if not robot_path.is_file():
        raise ReplayError(f"{arch.path}: robot {meta['robot']!r}: no robot file {robot_path} (use --data or --robot)")
    model = load_robot(robot_path)
    if model.name != meta["robot"]:
        raise ReplayError(f"{robot_path}: robot {model.name!r}, the archive's is {meta['robot']!r}")
    return model, robot_path


def _replay_metadata(arch, model, robot_path: Path, method: str, mode: str, max_frames: int, dt: float) -> dict:
    """The replay file's metadata record: its source archive, robot, solver and frame settings."""
    import pipeline

    meta = arch.metadata
    return {"source_archive": str(arch.path), "study": meta.get("study", ""), "robot": model.name,
             "robot_file": str(robot_path), "solver": meta.get("solver", ""), "method": method,
             "settings": meta["settings"], "seed": str(meta.get("seed", "")), "frames": mode,
             "max_frames": str(max_frames), "dt_s": repr(dt), "length_unit": "m",
             "package_version": pipeline.__version__,
             "source_format_version": meta.get("format_version", ""),
             "note": "frame k of a problem = the joint values the method returns with max_iterations = k "
                     "(iterations mode); the last frame of a problem = the archived q_solution"}


def _frame_points(mode: str, iterate: bool, its: int, q0: np.ndarray, q_arch: np.ndarray, last_q, max_frames: int,
                  capped_iterate) -> list[tuple[int, np.ndarray]]:
    """The ``(iteration, q)`` frames of one problem (q: (n,) float array, rad or length unit): start and
    archived solution (``solutions`` mode: the start only where the chain does not continue from
    ``last_q``), or up to ``max_frames`` iterates evenly spaced, iterate k re-run with ``capped_iterate(k)``
    (None where the cap is below the method's minimum)."""
    if mode == "solutions":
        qs = ([] if last_q is not None and np.array_equal(last_q, q0) else [(0, q0)]) + [(its, q_arch)]
    elif iterate and its > 0:
        ks = np.unique(np.round(np.linspace(0, its, min(its + 1, max_frames))).astype(int))
        qs = []
        for k in ks.tolist():
            if k == 0:
                qs.append((0, q0))
            elif k == its:
                qs.append((its, q_arch))
            else:
                qk = capped_iterate(k)
                if qk is not None:
                    qs.append((k, qk))
    else:
        qs = [(0, q0), (its, q_arch)]
    return qs


def _mismatch(pid: int, q_rerun: np.ndarray, q_arch: np.ndarray) -> str | None:
    """The summary line for a re-run solution (n,) that differs from the archived one (n,) by more than
    :data:`TOL` or in which values are NaN; None when they agree."""
    diff = np.abs(q_rerun - q_arch)
    same_nan = np.isnan(q_rerun) == np.isnan(q_arch)
    if not same_nan.all() or np.nanmax(np.where(same_nan, diff, np.inf), initial=0.0) > TOL:
        d = float(np.nanmax(diff)) if np.isfinite(diff).any() else float("nan")
        return (f"problem {pid}: the re-run's q_solution differs from the archived one by {d:.3g} (more than "
                f"{TOL:g}); frames are the re-run's, the last one the archive's")
    return None


def _goal_poses(rec: dict, to_model: float, to_m: float) -> tuple[np.ndarray, np.ndarray]:
    """A record's goal as (4, 4) poses: in the model's length unit (``to_model``: archive unit -> model
    unit) and in metres (``to_m``: archive unit -> m)."""
    from pipeline.io.archive import goal_from_record
    from pipeline.kinematics import matrix_from_quat

    p, quat = goal_from_record(rec["goal"])
    T_goal = np.eye(4)
    T_goal[:3, :3] = matrix_from_quat(quat)
    T_goal[:3, 3] = p * to_model
    goal_m = T_goal.copy()
    goal_m[:3, 3] = p * to_m
    return T_goal, goal_m


def _write_problem_frames(w, qs: list, qs_m: list, model_m, goal_m: np.ndarray, names: list, rec: dict, meta: dict,
                          method: str, f: int, dt: float, summary) -> int:
    """Write the frames of one problem (``qs``: (iteration, q); ``qs_m``: each q in metres, (n,) float) from
    frame number ``f``; a non-finite iterate is skipped. Returns the next frame number."""
    from pipeline.kinematics import fk_htm

    pid, its = int(rec["problem_id"]), int(rec["iterations"])
    for (k, _), q_m in zip(qs, qs_m):
        T = fk_htm(model_m.chain, q_m) if np.all(np.isfinite(q_m)) else None
        dp = float(np.linalg.norm(T[:3, 3] - goal_m[:3, 3])) if T is not None else float("nan")
        ang = _rot_angle(T[:3, :3], goal_m[:3, :3]) if T is not None else float("nan")
        info = {"problem_id": pid, "solver": meta.get("solver", ""), "method": method, "iteration": int(k),
                "iterations": its, "frame": f, "position_error_m": dp, "orientation_error_rad": ang,
                "success": bool(rec["success"]), "stop_reason": int(rec["stop_reason"])}
        if T is None:
            continue  # a non-finite iterate has no pose to show
        _write_frame(w, int(round(f * dt * 1e9)), model_m, q_m, goal_m, info, names)
        f += 1
        summary.frames_per_problem[pid] = summary.frames_per_problem.get(pid, 0) + 1
    return f


def _capper(method: str, mapping: dict):
    """``k -> `` the settings ``mapping`` of ``method`` with ``max_iterations = k`` (None below the method's
    minimum cap), each built once."""
    from pipeline.solvers import SettingsError, make_settings

    capped: dict[int, object] = {}

    def capped_settings(k: int):
        if k not in capped:
            try:
                capped[k] = make_settings(method, {**mapping, "max_iterations": k})
            except SettingsError:
                capped[k] = None  # below the method's minimum cap
        return capped[k]

    return capped_settings


def _finish(w, summary, problems: int, frames: int) -> None:
    """Close the replay file with its ``replay_check`` record; the summary gets the frame count and topics."""
    summary.frames = frames
    summary.topics = dict(w.topics)
    w._w.add_metadata("replay_check", {
        "problems": str(problems), "frames": str(frames), "tolerance": repr(TOL),
        "mismatches": "; ".join(summary.mismatches) or "none: every re-run matches the archived q_solution"})
    w.close()


def _in_metres(q, model) -> np.ndarray:
    """Joint values (n,) of ``model`` (revolute rad, prismatic in its length unit) with the prismatic ones in m."""
    from pipeline.robots import LENGTH_UNITS

    q = np.array(q, dtype=float)
    q[np.asarray(model.chain.prismatic, dtype=bool)] *= LENGTH_UNITS[model.length_unit]
    return q


def replay(archive: str | Path, out: str | Path, *, problem: int | None = None, failed: bool = False,
           data: str | Path = "data", robot: str | Path | None = None, frames: str = "auto",
           max_frames: int = 200, dt: float = 0.05, problems: str | Path | None = None) -> ReplaySummary:
    """Re-run archived solves and write them as a Foxglove-viewable MCAP (see the module docstring).

    Parameters
    ----------
    archive : path of a result archive
    out : the replay file to write (``<out>.partial`` until finished)
    problem : replay this problem id; else ``failed`` (every failed solve) or, neither, every solve
    data : data folder (the robot file is ``<data>/robots/<robot>.yaml``) unless ``robot`` names it
    frames : ``auto``, ``iterations`` or ``solutions`` (one frame per problem)
    max_frames : at most this many iterate frames per problem (evenly spaced iterations)
    dt : seconds between frames (log times)
    problems : the archive's problem set, if it is not where its metadata says

    Raises
    ------
    ReplayError, ArchiveError, RobotFileError
    """
    from pipeline.io.archive import read_archive
    from pipeline.robots import LENGTH_UNITS
    from pipeline.runner import problem_seed
    from pipeline.solvers import get, prepare, solve

    _check_frame_args(frames, max_frames, dt)
    arch = read_archive(archive, problems=problems)
    meta = arch.metadata
    method, settings = settings_from_archive(meta, str(arch.path))
    model, robot_path = _replay_robot(arch, robot, data)
    recs = _select(arch, problem, failed)
    chained = len(recs) > 1 and all(int(r.get("chain", -1)) >= 0 for r in recs)
    mode = frames if frames != "auto" else ("solutions" if chained else "iterations")
    mapping = {k: v for k, v in json.loads(meta["settings"]).items() if k != "method"}
    # frames of the iterates: a method with an iteration cap, one start (no restarts), not a global search
    iterate = (mode == "iterations" and "max_iterations" in settings.as_dict() and get(method).kind != "global"
               and not settings.restarts)
    prep = prepare(method, model, settings)
    seed0 = int(meta["seed"]) if str(meta.get("seed", "")).lstrip("-").isdigit() else 0
    f_model = LENGTH_UNITS[model.length_unit]
    model_m = model.in_unit("m")
    names = [nm or f"joint_{i + 1}" for i, nm in enumerate(model.joint_names or [""] * model.n)]
    unit = meta.get("length_unit") or settings.length_unit
    to_model = LENGTH_UNITS[unit] / f_model
    capped_settings = _capper(method, mapping)
    rmeta = _replay_metadata(arch, model, robot_path, method, mode, max_frames, dt)
    w = None
    summary = ReplaySummary(Path(out), [int(r["problem_id"]) for r in recs], 0, {}, mode)
    try:
        w = _Writer(Path(out), rmeta)
        f = 0
        last_q = None
        for rec in recs:
            pid = int(rec["problem_id"])
            T_goal, goal_m = _goal_poses(rec, to_model, LENGTH_UNITS[unit])
            q0 = np.asarray(rec["q_start"], dtype=float)
            q_arch = np.asarray(rec["q_solution"], dtype=float)
            seed = problem_seed(seed0, pid, 0)
            res = solve(method, prep, T_goal, q0, settings, seed=seed)
            mismatch = _mismatch(pid, res.q, q_arch)
            if mismatch:
                summary.mismatches.append(mismatch)
            its = int(rec["iterations"])

            def capped_iterate(k: int):
                sk = capped_settings(k)
                return None if sk is None else solve(method, prep, T_goal, q0, sk, seed=seed).q

            qs = _frame_points(mode, iterate, its, q0, q_arch, last_q, max_frames, capped_iterate)
            qs_m = [_in_metres(q, model) for _, q in qs]
            f = _write_problem_frames(w, qs, qs_m, model_m, goal_m, names, rec, meta, method, f, dt, summary)
            last_q = q_arch
        _finish(w, summary, len(recs), f)
    except BaseException:
        if w is not None:
            w.abort()
        raise
    return summary
