"""`python -m pipeline replay`: a Foxglove-viewable MCAP re-run from an archive (issue 15, item 4)."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from pipeline.cli import main
from pipeline.io.archive import FORMAT_VERSION, ArchiveWriter, batch_columns, read_archive
from pipeline.kinematics import fk_htm, quat_from_matrix
from pipeline.problems import random_joint_pairs
from pipeline.robots import LENGTH_UNITS
from pipeline.runner import solve_set_batches
from pipeline.solvers import make_settings
from tests.conftest import DATA

TOPICS = {"/tf": "foxglove.FrameTransform", "/arm": "foxglove.SceneUpdate", "/goal": "foxglove.PoseInFrame",
          "/reached": "foxglove.PoseInFrame", "/joint_states": "foxglove.JointStates",
          "/replay/frame": "ik_pipeline.ReplayFrame"}


def _archive(path, lwr, ps, method="dls", settings=None, seed=1):
    """Solve ``ps`` as a solve job does (chains followed, goals in the settings' unit) into an archive."""
    s = make_settings(method, settings or {})
    unit = s.length_unit
    to_unit = LENGTH_UNITS[ps.length_unit] / LENGTH_UNITS[unit]
    meta = {"format_version": FORMAT_VERSION, "study": "t", "robot": lwr.name, "solver": f"{method}_label",
            "method": method, "settings": json.dumps({"method": method, **s.as_dict()}, sort_keys=True),
            "settings_hash": "h", "seed": str(seed), "package_version": "0", "git_commit": "c",
            "problems": str(len(ps)), "repetitions": "1", "length_unit": unit}
    with ArchiveWriter(path, meta) as w:
        for rows, rep, q0, res in solve_set_batches(method, s, lwr, ps, set_seed=seed):
            cols, traces = batch_columns(ps.problem_id[rows], rep, ps.chain[rows], lwr.name, f"{method}_label", unit,
                                         q0, ps.goal_position[rows] * to_unit, ps.goal_quat[rows], res, method=method)
            w.write_columns(cols, traces)
    return read_archive(path)


def _path_problems(lwr, m=6):
    """A chained path: goals along a straight joint-space segment, each solve starting from the last solution."""
    ps = random_joint_pairs(lwr, 2, np.random.default_rng(3))
    qa, qb = ps.q_goal[0], ps.q_goal[1]
    q_path = qa + (qb - qa) * np.linspace(0, 1, m)[:, None]
    T = fk_htm(lwr.chain, q_path)
    return replace(ps.take(np.zeros(m, dtype=int)), problem_id=np.arange(m), q_goal=q_path,
                   goal_position=T[:, :3, 3], goal_quat=quat_from_matrix(T), chain=np.zeros(m, dtype=int),
                   q_start=np.repeat(ps.q_start[:1], m, axis=0))


def _read(path):
    from mcap.reader import make_reader

    with open(path, "rb") as fh:
        r = make_reader(fh, validate_crcs=True)
        summary = r.get_summary()
        chans = {c.topic: (summary.schemas[c.schema_id], c) for c in summary.channels.values()}
        msgs = [(ch.topic, m) for _, ch, m in r.iter_messages(log_time_order=False)]
        meta = {m.name: dict(m.metadata) for m in r.iter_metadata()}
    return chans, msgs, meta


def _decoder(schema):
    pytest.importorskip("google.protobuf", reason="protobuf (test extra) not installed")
    from google.protobuf import descriptor_pb2, message_factory

    fds = descriptor_pb2.FileDescriptorSet.FromString(schema.data)
    return message_factory.GetMessages(list(fds.file))[schema.name]


def _tool_m(lwr, q):
    """FK of ``q`` (robot file units) in metres."""
    m = lwr.in_unit("m")
    q = np.array(q, dtype=float)
    q[lwr.chain.prismatic] *= LENGTH_UNITS[lwr.length_unit]
    return fk_htm(m.chain, q)


def _assert_pose(tr, rot, T):
    np.testing.assert_allclose([tr.x, tr.y, tr.z], T[:3, 3], rtol=0, atol=1e-9)
    w, x, y, z = quat_from_matrix(T)
    np.testing.assert_allclose([rot.x, rot.y, rot.z, rot.w], [x, y, z, w], rtol=0, atol=1e-9)


def test_replay_of_one_problem_shows_each_iterate_and_ends_at_the_archived_solution(tmp_path, lwr):
    src, out = tmp_path / "a.mcap", tmp_path / "replay.mcap"
    arch = _archive(src, lwr, random_joint_pairs(lwr, 4, np.random.default_rng(11)))
    rec = arch.solves[1]
    assert rec["success"] and rec["iterations"] > 3
    assert main(["replay", str(src), "--problem", str(rec["problem_id"]), "-o", str(out)]) == 0
    chans, msgs, meta = _read(out)
    assert {t: s.name for t, (s, _) in chans.items()} == TOPICS
    for t, (s, c) in chans.items():
        enc = "json" if t == "/replay/frame" else "protobuf"
        assert c.message_encoding == enc and s.encoding == ("jsonschema" if enc == "json" else "protobuf")
    assert meta["replay"]["method"] == "dls" and meta["replay"]["length_unit"] == "m"
    assert meta["replay_check"]["mismatches"].startswith("none")
    # one frame per iteration 0..iterations, 0.05 s apart; each frame's |dp| is the archived trace's
    frames = [json.loads(m.data) for t, m in msgs if t == "/replay/frame"]
    its = rec["iterations"]
    assert [f["iteration"] for f in frames] == list(range(its + 1))
    assert [m.log_time for t, m in msgs if t == "/replay/frame"] == [k * 50_000_000 for k in range(its + 1)]
    trace = next(arch.traces([rec["problem_id"]]))
    np.testing.assert_allclose([f["position_error_m"] for f in frames], trace["position_error"], rtol=1e-7, atol=1e-12)
    # the last frame's tool transform (protobuf, decoded with the file's own schema) = FK of the archived q_solution
    T = _tool_m(lwr, rec["q_solution"])
    FT = _decoder(chans["/tf"][0])
    tools = [FT.FromString(m.data) for t, m in msgs if t == "/tf" and FT.FromString(m.data).child_frame_id == "tool"]
    assert len(tools) == its + 1 and tools[-1].parent_frame_id == "world"
    _assert_pose(tools[-1].translation, tools[-1].rotation, T)
    assert tools[-1].timestamp.seconds * 10**9 + tools[-1].timestamp.nanos == its * 50_000_000
    links = {FT.FromString(m.data).child_frame_id for t, m in msgs if t == "/tf"}
    assert links == {"base", "tool"} | {f"link_{i}" for i in range(1, lwr.n + 1)}
    PF = _decoder(chans["/reached"][0])
    reached = [PF.FromString(m.data) for t, m in msgs if t == "/reached"][-1]
    _assert_pose(reached.pose.position, reached.pose.orientation, T)
    goal = [PF.FromString(m.data) for t, m in msgs if t == "/goal"][-1]
    g = rec["goal"]["position"]
    np.testing.assert_allclose([goal.pose.position.x, goal.pose.position.y, goal.pose.position.z],
                               [g["x"], g["y"], g["z"]], rtol=0, atol=1e-12)  # archive unit m here
    JS = _decoder(chans["/joint_states"][0])
    js = [JS.FromString(m.data) for t, m in msgs if t == "/joint_states"]
    np.testing.assert_allclose([j.position for j in js[0].joints], rec["q_start"], rtol=0, atol=0)
    np.testing.assert_allclose([j.position for j in js[-1].joints], rec["q_solution"], rtol=0, atol=0)
    SU = _decoder(chans["/arm"][0])
    scene = SU.FromString([m.data for t, m in msgs if t == "/arm"][-1])
    line = scene.entities[0].lines[0]
    assert scene.entities[0].frame_id == "world" and len(line.points) == lwr.n + 2
    np.testing.assert_allclose([line.points[-1].x, line.points[-1].y, line.points[-1].z], T[:3, 3], atol=1e-9)


def test_replay_is_deterministic_and_caps_the_frames(tmp_path, lwr):
    src = tmp_path / "a.mcap"
    arch = _archive(src, lwr, random_joint_pairs(lwr, 3, np.random.default_rng(11)))
    pid = arch.solves[2]["problem_id"]
    for name in ("r1.mcap", "r2.mcap"):
        assert main(["replay", str(src), "--problem", str(pid), "--max-frames", "4",
                     "--out", str(tmp_path / name)]) == 0
    assert (tmp_path / "r1.mcap").read_bytes() == (tmp_path / "r2.mcap").read_bytes()
    _, msgs, _ = _read(tmp_path / "r1.mcap")
    frames = [json.loads(m.data) for t, m in msgs if t == "/replay/frame"]
    its = arch.solves[2]["iterations"]
    assert len(frames) == 4 and frames[0]["iteration"] == 0 and frames[-1]["iteration"] == its


def test_replay_of_a_chained_path_follows_the_path(tmp_path, lwr):
    src, out = tmp_path / "path.mcap", tmp_path / "replay.mcap"
    arch = _archive(src, lwr, _path_problems(lwr, 6))
    assert all(r["chain"] == 0 for r in arch.solves)
    assert main(["replay", str(src), "--all", "-o", str(out)]) == 0
    chans, msgs, meta = _read(out)
    assert meta["replay"]["frames"] == "solutions" and set(chans) == set(TOPICS)
    frames = [json.loads(m.data) for t, m in msgs if t == "/replay/frame"]
    # the start of the path, then one frame per problem: its solution (the next one's start)
    assert [f["problem_id"] for f in frames] == [0] + list(range(6))
    assert [f["frame"] for f in frames] == list(range(7))
    for f, rec in zip(frames[1:], arch.solves):
        np.testing.assert_allclose(f["q"], rec["q_solution"], rtol=0, atol=1e-12)  # revolute joints: rad
    FT = _decoder(chans["/tf"][0])
    tools = [FT.FromString(m.data) for t, m in msgs if t == "/tf" and FT.FromString(m.data).child_frame_id == "tool"]
    assert len(tools) == 7
    for tool, rec in zip(tools[1:], arch.solves):
        _assert_pose(tool.translation, tool.rotation, _tool_m(lwr, rec["q_solution"]))
    # per-iteration frames of every problem on request
    assert main(["replay", str(src), "--all", "--frames", "iterations", "-o", str(tmp_path / "it.mcap")]) == 0
    _, msgs, _ = _read(tmp_path / "it.mcap")
    frames = [json.loads(m.data) for t, m in msgs if t == "/replay/frame"]
    assert len(frames) == sum(r["iterations"] + 1 for r in arch.solves)


def test_replay_errors_are_one_line(tmp_path, lwr, capsys):
    src = tmp_path / "a.mcap"
    _archive(src, lwr, random_joint_pairs(lwr, 2, np.random.default_rng(1)))
    assert main(["replay", str(src), "--problem", "99", "-o", str(tmp_path / "r.mcap")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "a.mcap" in err and "problem 99" in err
    assert main(["replay", str(src), "--problem", "0", "--data", str(tmp_path), "-o", str(tmp_path / "r.mcap")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "kuka_lwr" in err and "--data" in err
    assert not list(tmp_path.glob("r.mcap*"))
    with pytest.raises(SystemExit):
        main(["replay", str(src), "-o", str(tmp_path / "r.mcap")])  # one of --problem, --failed, --all
    assert (DATA / "robots" / "kuka_lwr.yaml").is_file()
