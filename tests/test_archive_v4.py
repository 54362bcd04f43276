"""Archive format 4: protobuf solve batches, traces and analytic solutions derived from digests,
the problem file joined and checked, counts checked on read, every damaged copy refused."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pipeline.io.archive import (FORMAT_VERSION, SOLVE_TOPIC, TRACE_TOPIC, ArchiveError, ArchiveWriter, batch_columns,
                                 decode_trace_batch, encode_trace_batch, read_archive, solve_descriptor, trace_descriptor)
from pipeline.problems import random_joint_pairs
from pipeline.solvers import make_settings, prepare, solve_batch

META = {"format_version": FORMAT_VERSION, "study": "s", "robot": "kuka_lwr", "solver": "dls", "settings": "{}",
        "settings_hash": "h", "seed": "1", "package_version": "0", "git_commit": "c"}


def _batch(lwr, n=25, method="dls", criterion="pos_orient"):
    s = make_settings(method, {"criterion": criterion})
    prep = prepare(method, lwr, s)
    ps = random_joint_pairs(lwr, n, np.random.default_rng(11))
    res = solve_batch(method, prep, ps.goal_transforms(), ps.q_start, s)
    return ps, res


def _write(path, lwr, n=25, meta=None, **kw):
    ps, res = _batch(lwr, n, **kw)
    cols, traces = batch_columns(ps.problem_id, np.zeros(n), ps.chain, "kuka_lwr", "dls", "m", ps.q_start,
                                 ps.goal_position, ps.goal_quat, res, method="dls")
    with ArchiveWriter(path, {**META, "problems": str(n), **(meta or {})}) as w:
        w.write_columns(cols, traces)
    return ps, res


def test_columns_round_trip_to_the_version_2_records(tmp_path, lwr):
    p = tmp_path / "a.mcap"
    ps, res = _write(p, lwr)
    a = read_archive(p)
    assert a.metadata["format_version"] == "4" and len(a.solves) == len(ps)
    for i, rec in enumerate(a.solves):
        assert rec["problem_id"] == ps.problem_id[i] and rec["success"] == bool(res.success[i])
        assert rec["q_solution"] == res.q[i].tolist() and rec["iterations"] == res.iterations[i]
        assert rec["goal"]["orientation"]["w"] == ps.goal_quat[i][0]
        assert rec["initial_error"] == res.trace(i)[0, 0] and rec["final_error"] == res.trace(i)[-1, 0]
    traces = {t["problem_id"]: t for t in a.traces()}
    for i in range(len(ps)):
        t, want = traces[int(ps.problem_id[i])], res.trace(i)
        assert t["error"] == want[:, 0].tolist() and t["position_error"] == want[:, 7].tolist()
        np.testing.assert_allclose(t["error_vector"], want[:, 1:7], rtol=1e-6, atol=1e-30)  # float32 on disk


def _protobuf_class(schema):
    from google.protobuf import descriptor_pb2, message_factory

    fds = descriptor_pb2.FileDescriptorSet.FromString(schema.data)
    return message_factory.GetMessages(list(fds.file))[schema.name]


def test_every_message_decodes_with_its_protobuf_schema_and_holds_no_nan(tmp_path, lwr):
    """Position-only checks leave the orientation error absent: flagged (written 0), read back NaN."""
    pytest.importorskip("google.protobuf", reason="protobuf (test extra) not installed")
    from mcap.reader import make_reader

    p = tmp_path / "a.mcap"
    _write(p, lwr, criterion="position")
    seen = set()
    with open(p, "rb") as fh:
        for schema, channel, msg in make_reader(fh).iter_messages():
            assert channel.message_encoding == "protobuf" and schema.encoding == "protobuf"
            m = _protobuf_class(schema).FromString(msg.data)
            for field, value in m.ListFields():
                if field.type in (field.TYPE_DOUBLE, field.TYPE_FLOAT):
                    assert np.isfinite(np.asarray(value, dtype=float)).all(), field.name
            seen.add(channel.topic)
    assert seen == {SOLVE_TOPIC, TRACE_TOPIC}
    assert all(np.isnan(r["orientation_error"]) for r in read_archive(p).solves)


def test_log_times_are_the_cumulative_solve_time(tmp_path, lwr):
    from mcap.reader import make_reader

    p = tmp_path / "a.mcap"
    _, res = _write(p, lwr, n=2500)
    with open(p, "rb") as fh:
        times = [m.log_time for _, _, m in make_reader(fh).iter_messages(topics=[SOLVE_TOPIC])]
    cum = np.cumsum(res.solve_time_s)
    assert len(times) == 3 and times == sorted(times)
    assert abs(times[-1] - cum[-1] * 1e9) < 10 and abs(times[0] - cum[999] * 1e9) < 10


def test_trace_schema_is_a_valid_protobuf_descriptor():
    pb = pytest.importorskip("google.protobuf", reason="protobuf (test extra) not installed")
    from google.protobuf import descriptor_pb2, message_factory

    fds = descriptor_pb2.FileDescriptorSet.FromString(trace_descriptor())
    cls = message_factory.GetMessages(list(fds.file))["ik_pipeline.TraceBatch"]
    rng = np.random.default_rng(1)
    rows = np.array([3, 1, 4], dtype=np.uint32)
    m = int(rows.sum())
    cols = (np.array([7, -1, 9]), np.array([0, 2, 1]), rows, rng.normal(size=m), rng.normal(size=m),
            rng.normal(size=(m, 6)))
    msg = cls.FromString(encode_trace_batch(*cols, digest=np.array([1, 2, 3]), stored=np.ones(3)))
    assert list(msg.problem_id) == [7, -1, 9] and list(msg.rows) == [3, 1, 4] and list(msg.digest) == [1, 2, 3]
    np.testing.assert_array_equal(msg.error, cols[3])
    np.testing.assert_allclose(msg.error_vector, cols[5].ravel(), rtol=1e-6)
    assert pb.__version__  # the library that decoded it


@pytest.mark.parametrize("cut", [1, 5, 17])
def test_damaged_trace_batches_are_one_line_errors(cut):
    data = encode_trace_batch(np.array([1]), np.array([0]), np.array([2], np.uint32), np.ones(2), np.ones(2),
                              np.ones((2, 6)), digest=np.zeros(1), stored=np.ones(1))
    with pytest.raises(ValueError):
        decode_trace_batch(data[:-cut])


def test_fewer_records_than_the_metadata_promises_is_an_error(tmp_path, lwr):
    p = tmp_path / "a.mcap"
    _write(p, lwr, n=10, meta={"problems": "12"})
    with pytest.raises(ArchiveError, match=r"a\.mcap: 10 solve records, metadata field 'problems' promises 12"):
        read_archive(p)


def test_a_column_of_the_wrong_length_is_an_error(tmp_path, lwr):
    ps, res = _batch(lwr, 5)
    cols, traces = batch_columns(ps.problem_id, np.zeros(5), ps.chain, "kuka_lwr", "dls", "m", ps.q_start,
                                 ps.goal_position, ps.goal_quat, res)
    cols["iterations"] = cols["iterations"][:4]
    p = tmp_path / "a.mcap"
    with ArchiveWriter(p, META) as w:
        w._emit(cols, 5, None)
    with pytest.raises(ArchiveError, match=r"message \d+ on /ik/solve: field 'iterations' holds 4 values for 5 solves"):
        read_archive(p)


def test_version_2_archives_still_read(tmp_path):
    """One JSON message per solve and per trace, as archives written before format 3."""
    from mcap.writer import CompressionType, Writer

    p = tmp_path / "v2.mcap"
    rec = {"problem_id": 4, "success": True, "stop_reason": 1, "iterations": 2, "solve_time_s": 1e-5,
           "q_solution": [0.1, 0.2], "goal": {"position": {"x": 0, "y": 0, "z": 1},
                                             "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}}
    tr = {"problem_id": 4, "repetition": 0, "error": [1.0, 0.5, 0.1], "error_vector": [[0.0] * 6] * 3,
          "position_error": [1.0, 0.5, 0.1]}
    with open(p, "wb") as fh:
        w = Writer(fh, compression=CompressionType.ZSTD)
        w.start(profile="", library="old")
        w.add_metadata("run", {**META, "format_version": "2", "problems": "1"})
        sid = w.register_schema("ik_pipeline.Solve", "jsonschema", b"{}")
        s_ch = w.register_channel(SOLVE_TOPIC, "json", sid)
        t_ch = w.register_channel(TRACE_TOPIC, "json", sid)
        w.add_message(s_ch, log_time=0, publish_time=0, sequence=0, data=json.dumps(rec).encode())
        w.add_message(t_ch, log_time=0, publish_time=0, sequence=0, data=json.dumps(tr).encode())
        w.finish()
    a = read_archive(p)
    assert a.solves == [rec] and next(a.traces([4]))["error"] == [1.0, 0.5, 0.1]


def test_unknown_format_version_is_refused_in_one_line(tmp_path, lwr):
    p = tmp_path / "a.mcap"
    _write(p, lwr, n=3, meta={"format_version": "9"})
    with pytest.raises(ArchiveError, match=r"format_version' is '9', this version reads 2, 3 and 4"):
        read_archive(p)


def _corpus(good: bytes, step: int):
    """Damaged copies: truncations at several offsets and single-byte flips every ``step`` bytes."""
    n = len(good)
    for cut in sorted({8, 9, 40, n // 3, n // 2, n - 40, n - 9, n - 1}):
        yield f"cut{cut}", good[:cut]
    for i in range(0, n, step):
        b = bytearray(good)
        b[i] ^= 0x5A
        yield f"flip{i}", bytes(b)


def test_every_damaged_copy_is_refused_in_one_line_or_reads_the_same(tmp_path, lwr):
    """Truncations and byte flips anywhere: an ArchiveError naming the file, or the very same records."""
    p = tmp_path / "good.mcap"
    _write(p, lwr, n=30)
    good = read_archive(p)
    want = (good.metadata, good.solves, list(good.traces()))
    data = p.read_bytes()
    refused = harmless = 0
    for name, blob in _corpus(data, max(1, len(data) // 400)):
        q = tmp_path / f"{name}.mcap"
        q.write_bytes(blob)
        try:
            a = read_archive(q)
            got = (a.metadata, a.solves, list(a.traces()))
        except ArchiveError as exc:
            msg = str(exc)
            assert msg.startswith(f"{q}: ") and "\n" not in msg, msg
            refused += 1
            continue
        assert repr(got) == repr(want), name  # read without complaint: must be the same archive
        harmless += 1
    assert refused > 300


def test_an_edited_metadata_value_is_caught(tmp_path, lwr):
    """Changing a metadata value in place (same length, no CRC update) breaks the data-section CRC."""
    p = tmp_path / "a.mcap"
    _write(p, lwr, n=10, meta={"seed": "12345"})
    data = p.read_bytes()
    assert data.count(b"12345") == 1
    p.write_bytes(data.replace(b"12345", b"99999"))
    with pytest.raises(ArchiveError, match="data section CRC mismatch"):
        read_archive(p)


def test_inspect_and_aggregation_refuse_a_damaged_archive_with_one_line(tmp_path, lwr):
    import subprocess
    import sys

    p = tmp_path / "a.mcap"
    _write(p, lwr, n=10)
    b = bytearray(p.read_bytes())
    b[len(b) // 2] ^= 0xFF
    p.write_bytes(bytes(b))
    proc = subprocess.run([sys.executable, "-m", "pipeline", "inspect", str(p)], capture_output=True, text=True)
    assert proc.returncode != 0 and "Traceback" not in proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and str(p) in lines[0], proc.stderr


# ---- derived traces and solutions: the problem file and the robot file, checked on every read ----------

def _derived_archive(tmp_path, method="dls", robot="kuka_lwr", n=40, settings=None, seed=5):
    """An archive as a solve job writes it: goals in a problem file beside it, traces as digests."""
    import os

    from pipeline.io.problems import read_problems, write_problems
    from pipeline.problems import random_joint_pairs
    from pipeline.robots import load_robot
    from pipeline.runner import solve_set_batches
    from pipeline.settings import file_sha256
    from pipeline.solvers import make_settings

    from tests.conftest import DATA

    rf = DATA / "robots" / f"{robot}.yaml"
    model = load_robot(rf)
    pf = tmp_path / "problems" / "set" / f"{robot}.csv"
    write_problems(pf, random_joint_pairs(model, n, np.random.default_rng(seed)), {"seed": str(seed)})
    ps, _ = read_problems(pf)
    s = make_settings(method, settings or {})
    out = tmp_path / "runs" / "set" / f"{robot}__{method}.mcap"
    out.parent.mkdir(parents=True, exist_ok=True)
    meta = {**META, "robot": robot, "solver": method, "method": method, "problems": str(n), "seed": str(seed),
            "settings": json.dumps({"method": method, **s.as_dict()}) if hasattr(s, "as_dict") else json.dumps(
                {"method": method, **(settings or {})}),
            "problem_sha256": file_sha256(pf)[:16], "problem_path": os.path.relpath(pf, out.parent),
            "robot_file": str(rf), "robot_sha256": file_sha256(rf)[:16], "length_unit": s.length_unit}
    results = []
    with ArchiveWriter(out, meta, derive=True) as w:
        for rows, rep, q0, res in solve_set_batches(method, s, model, ps, set_seed=seed):
            cols, traces = batch_columns(ps.problem_id[rows], rep, ps.chain[rows], robot, method, s.length_unit, q0,
                                         ps.goal_position[rows], ps.goal_quat[rows], res, method=method,
                                         start_from_file=np.all(q0 == ps.q_start[rows], axis=1))
            w.write_columns(cols, traces)
            results.append(res)
    return out, pf, ps, results[0]


def test_derived_traces_are_the_solver_traces_bit_for_bit(tmp_path):
    p, _, ps, res = _derived_archive(tmp_path)
    a = read_archive(p)
    from pipeline.robots import LENGTH_UNITS

    scale = LENGTH_UNITS[ps.length_unit] / LENGTH_UNITS[a.metadata["length_unit"]]  # goals in the solver's unit
    for i, rec in enumerate(a.solves):  # goals and starts come from the problem file
        assert rec["q_start"] == ps.q_start[i].tolist() and rec["goal"]["position"]["x"] == ps.goal_position[i, 0] * scale
        assert rec["q_solution"] == res.q[i].tolist() and rec["solve_time_s"] == pytest.approx(res.solve_time_s[i], abs=1e-9)
    traces = {t["problem_id"]: t for t in a.traces()}
    assert len(traces) == len(ps)
    for i in range(len(ps)):
        want = res.trace(i)
        t = traces[int(ps.problem_id[i])]
        assert t["error"] == want[:, 0].tolist() and t["error_vector"] == want[:, 1:7].tolist()  # float64, exact


def test_solve_messages_cost_little_without_goals_starts_and_traces(tmp_path):
    """The compact encoding: no goal or start repeated from the problem file, no trace rows."""
    from mcap.reader import make_reader

    p, *_ = _derived_archive(tmp_path, n=1000)
    with open(p, "rb") as fh:
        sizes = {t: 0 for t in (SOLVE_TOPIC, TRACE_TOPIC)}
        for _, ch, msg in make_reader(fh).iter_messages():
            sizes[ch.topic] += len(msg.data)
    # raw (uncompressed) bytes per solve: 7 joint values, 4 errors, 3 times, 6 ints, info
    assert sizes[SOLVE_TOPIC] / 1000 < 220 and sizes[TRACE_TOPIC] / 1000 <= 24, sizes


def test_analytic_solutions_are_derived_and_checked(tmp_path):
    p, _, ps, res = _derived_archive(tmp_path, method="analytic_ur", robot="ur5", n=12)
    a = read_archive(p)
    for i, rec in enumerate(a.solves):
        assert "solutions" not in rec and rec["_n_solutions"] == int(res.n_solutions[i])
        assert a.solutions(rec["problem_id"]) == res.solutions[i, : int(res.n_solutions[i])].tolist()


def test_a_changed_or_missing_problem_file_is_one_line(tmp_path):
    p, pf, _, _ = _derived_archive(tmp_path, n=5)
    text = pf.read_text()
    pf.write_text(text.replace(",0.", ",1.", 1))
    with pytest.raises(ArchiveError, match=r"metadata field 'problem_sha256'.*problem file changed"):
        read_archive(p)
    pf.unlink()
    with pytest.raises(ArchiveError, match=r"metadata field 'problem_path': problem file .* not found"):
        read_archive(p)


def test_a_re_run_that_differs_from_the_digest_is_an_error_not_a_silent_trace(tmp_path, monkeypatch):
    """Written by 'another version': the archived digests do not match what this code computes."""
    import pipeline.io.archive as A

    real = A._crc32
    monkeypatch.setattr(A, "_crc32", lambda b: (real(b) + 1) & 0xFFFFFFFF)
    p, *_ = _derived_archive(tmp_path, n=5)
    monkeypatch.setattr(A, "_crc32", real)
    a = read_archive(p)  # the records read; only the derived traces are refused
    with pytest.raises(ArchiveError, match=r"problem \d+: the re-run trace differs from the archived digest .* commit"):
        list(a.traces())


def test_a_robot_file_changed_since_writing_is_refused_on_derivation(tmp_path):
    p, *_ = _derived_archive(tmp_path, n=5)
    a = read_archive(p)
    other = tmp_path / "kuka_lwr.yaml"
    from tests.conftest import DATA

    other.write_text((DATA / "robots" / "kuka_lwr.yaml").read_text() + "\n# edited\n")
    a.metadata = {**a.metadata, "robot_file": str(other)}
    with pytest.raises(ArchiveError, match="robot_sha256.*changed since the archive was written"):
        list(a.traces())


def test_every_damaged_copy_of_a_derived_archive_is_refused_or_reads_the_same(tmp_path):
    p, pf, _, _ = _derived_archive(tmp_path, n=30)
    good = read_archive(p)
    want = (good.metadata, good.solves, list(good.traces()))
    data = p.read_bytes()
    refused = 0
    for name, blob in _corpus(data, max(1, len(data) // 200)):
        q = p.with_name(f"{name}.mcap")
        q.write_bytes(blob)
        try:
            a = read_archive(q)
            got = (a.metadata, a.solves, list(a.traces()))
        except ArchiveError as exc:
            assert str(exc).startswith(f"{q}: ") and "\n" not in str(exc), str(exc)
            refused += 1
            continue
        finally:
            q.unlink()
        assert repr(got) == repr(want), name
    assert refused > 150


def test_non_finite_starts_and_goals_are_flagged_not_written(tmp_path, lwr):
    """An archive with inline goals (no problem file) given a NaN start and an infinite goal: no NaN
    or Infinity in the file, NaN read back."""
    from mcap.reader import make_reader

    ps, res = _batch(lwr, 4)
    q0, gp = ps.q_start.copy(), ps.goal_position.copy()
    q0[1, 2], gp[2, 0] = np.nan, np.inf
    cols, traces = batch_columns(ps.problem_id, np.zeros(4), ps.chain, "kuka_lwr", "dls", "m", q0, gp, ps.goal_quat, res)
    p = tmp_path / "a.mcap"
    with ArchiveWriter(p, {**META, "problems": "4"}) as w:
        w.write_columns(cols, traces)
    with open(p, "rb") as fh:
        for schema, _, msg in make_reader(fh).iter_messages():
            m = _protobuf_class(schema).FromString(msg.data)
            for field, value in m.ListFields():
                if field.type in (field.TYPE_DOUBLE, field.TYPE_FLOAT):
                    assert np.isfinite(np.asarray(value, dtype=float)).all(), field.name
    recs = read_archive(p).solves
    assert np.isnan(recs[1]["q_start"]).all() and recs[0]["q_start"] == ps.q_start[0].tolist()
    assert np.isnan(recs[2]["goal"]["position"]["x"]) and recs[3]["goal"]["position"]["x"] == ps.goal_position[3, 0]


def test_an_archive_copied_out_of_its_tree_reads_with_problems_and_robot_given(tmp_path):
    """Alone, one line saying what to give; with --problems and --robot, inspect shows everything."""
    import shutil
    import subprocess
    import sys

    from tests.conftest import DATA, ROOT

    p, pf, _, _ = _derived_archive(tmp_path / "tree", method="analytic_ur", robot="ur5", n=6)
    alone = tmp_path / "elsewhere" / "a.mcap"
    alone.parent.mkdir()
    shutil.copy(p, alone)
    run = lambda *a: subprocess.run([sys.executable, "-m", "pipeline", "inspect", str(alone), *a],  # noqa: E731
                                    capture_output=True, text=True, cwd=tmp_path)
    bad = run("--problem", "2")
    assert bad.returncode != 0 and "Traceback" not in bad.stderr
    lines = [ln for ln in bad.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and str(alone) in lines[0] and "--problems FILE" in lines[0], bad.stderr
    robot = DATA / "robots" / "ur5.yaml"
    ok = run("--problem", "2", "--problems", str(pf), "--robot", str(robot))
    assert ok.returncode == 0, ok.stderr
    assert "analytic solutions:" in ok.stdout and "re-derived from the archive" in ok.stdout
    assert ROOT.is_dir()
