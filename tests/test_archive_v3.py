"""Archive format 3: batched solve columns (strict JSON), protobuf traces, counts checked on read."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pipeline.io.archive import (FORMAT_VERSION, SOLVE_TOPIC, TRACE_TOPIC, ArchiveError, ArchiveWriter, batch_columns,
                                 decode_trace_batch, encode_trace_batch, read_archive, trace_descriptor)
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
    assert a.metadata["format_version"] == "3" and len(a.solves) == len(ps)
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


def test_every_solve_message_is_strict_json(tmp_path, lwr):
    """Position-only checks leave the orientation error NaN: it is written null and read back NaN."""
    from mcap.reader import make_reader

    p = tmp_path / "a.mcap"
    _write(p, lwr, criterion="position")
    with open(p, "rb") as fh:
        for _, channel, msg in make_reader(fh).iter_messages(topics=[SOLVE_TOPIC]):
            batch = json.loads(msg.data, parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))
            assert batch["orientation_error"][0] is None
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
    msg = cls.FromString(encode_trace_batch(*cols))
    assert list(msg.problem_id) == [7, -1, 9] and list(msg.rows) == [3, 1, 4]
    np.testing.assert_array_equal(msg.error, cols[3])
    np.testing.assert_allclose(msg.error_vector, cols[5].ravel(), rtol=1e-6)
    assert pb.__version__  # the library that decoded it


@pytest.mark.parametrize("cut", [1, 5, 17])
def test_damaged_trace_batches_are_one_line_errors(cut):
    data = encode_trace_batch(np.array([1]), np.array([0]), np.array([2], np.uint32), np.ones(2), np.ones(2),
                              np.ones((2, 6)))
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
    with pytest.raises(ArchiveError, match=r"message \d+ on /ik/solve: column 'iterations' 4 values, count is 5"):
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
    with pytest.raises(ArchiveError, match=r"format_version' is '9', this version reads 2 and 3"):
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
