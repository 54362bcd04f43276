"""Archive format 5: protobuf batches, traces stored under a trace policy, analytic solutions stored,
the problem file joined and checked, counts checked on read, every damaged copy refused, readable
with mcap and protobuf alone, and reading never imports a solver."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pipeline.io.archive import (FORMAT_VERSION, SOLUTIONS_TOPIC, SOLVE_TOPIC, TRACE_TOPIC, ArchiveError,
                                 ArchiveWriter, TraceNotStored, TracePolicy, batch_columns, digest, read_archive)
from pipeline.problems import random_joint_pairs
from pipeline.solvers import make_settings, prepare, solve_batch

META = {"format_version": FORMAT_VERSION, "study": "s", "robot": "kuka_lwr", "solver": "dls", "settings": "{}",
        "settings_hash": "h", "seed": "1", "package_version": "0", "git_commit": "c"}
SNIPPET = Path(__file__).with_name("archive_reader_snippet.py")


def _batch(robot, n=25, method="dls", criterion="pos_orient", **kw):
    s = make_settings(method, {"criterion": criterion, **kw} if criterion else kw)
    prep = prepare(method, robot, s)
    ps = random_joint_pairs(robot, n, np.random.default_rng(11))
    res = solve_batch(method, prep, ps.goal_transforms(), ps.q_start, s)
    return ps, res


def _write(path, robot, n=25, meta=None, policy=None, ids=None, **kw):
    ps, res = _batch(robot, n, **kw)
    cols, traces = batch_columns(ps.problem_id, np.zeros(n), ps.chain, robot.name, "dls", "m", ps.q_start,
                                 ps.goal_position, ps.goal_quat, res, method=kw.get("method", "dls"))
    with ArchiveWriter(path, {**META, "robot": robot.name, "problems": str(n), **(meta or {})}, policy=policy,
                       problem_ids=ps.problem_id if ids is None else ids) as w:
        w.write_columns(cols, traces)
    return ps, res


def test_records_traces_and_digests_round_trip(tmp_path, lwr):
    p = tmp_path / "a.mcap"
    ps, res = _write(p, lwr)
    a = read_archive(p)
    assert a.metadata["format_version"] == "5" and len(a.solves) == len(ps)
    for i, rec in enumerate(a.solves):
        assert rec["problem_id"] == ps.problem_id[i] and rec["success"] == bool(res.success[i])
        assert rec["q_solution"] == res.q[i].tolist() and rec["iterations"] == res.iterations[i]
        assert rec["goal"]["orientation"]["w"] == ps.goal_quat[i][0]
        assert rec["initial_error"] == res.trace(i)[0, 0] and rec["final_error"] == res.trace(i)[-1, 0]
    traces = {t["problem_id"]: t for t in a.traces()}
    idx = a.trace_index()
    for i in range(len(ps)):
        t, want = traces[int(ps.problem_id[i])], res.trace(i)
        assert t["error"] == want[:, 0].tolist() and t["position_error"] == want[:, 7].tolist()
        np.testing.assert_allclose(t["error_vector"], want[:, 1:7], rtol=1e-6, atol=1e-30)  # float32 on disk
        assert idx[(int(ps.problem_id[i]), 0)][:2] == (len(want), digest(want[:, :8]))
    assert a.trace_summary["stored"] == a.trace_summary["traces"] == str(len(ps))


def test_the_sample_policy_stores_an_even_sample_and_failures_within_the_budget(tmp_path, lwr):
    p = tmp_path / "a.mcap"
    policy = TracePolicy(sample=5, failed_rows=60)
    ps, res = _write(p, lwr, n=40, policy=policy, max_iterations=30)
    a = read_archive(p)
    sample = policy.sample_ids(ps.problem_id)
    assert len(sample) == 5 and min(sample) == ps.problem_id.min() and max(sample) == ps.problem_id.max()
    stored = {k[0] for k in a.stored_traces()}
    failed = [int(p) for p, ok in zip(ps.problem_id, res.success) if not ok]
    rows = {int(p): len(res.trace(i)) for i, p in enumerate(ps.problem_id)}
    budget, want_failed = 60, set()
    for pid in failed:  # in solve order, while they fit
        if rows[pid] <= budget:
            want_failed.add(pid)
            budget -= rows[pid]
    assert failed and stored == sample | want_failed
    assert a.trace_summary["stored"] == str(len(stored)) and a.trace_summary["traces"] == "40"
    assert json.loads(a.metadata["trace_policy"]) == {"mode": "sample", "sample": 5, "failed_rows": 60}
    missing = next(int(p) for p in ps.problem_id if int(p) not in stored)
    with pytest.raises(TraceNotStored) as exc:
        list(a.traces([missing]))
    msg = str(exc.value)
    assert msg.startswith(f"{p}: problem {missing}") and "not stored" in msg and "reproduce" in msg and "\n" not in msg


def test_analytic_solutions_are_stored_and_read_back(tmp_path, ur5):
    p = tmp_path / "a.mcap"
    ps, res = _write(p, ur5, n=12, method="analytic_ur", criterion=None)
    a = read_archive(p)
    for i, rec in enumerate(a.solves):
        k = int(res.n_solutions[i])
        assert rec["_n_solutions"] == k
        assert a.solutions(rec["problem_id"]) == res.solutions[i, :k].tolist()
    assert "_n_solutions" not in a.frame().columns


def _snippet(path) -> dict:
    proc = subprocess.run([sys.executable, "-I", str(SNIPPET), str(path)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_every_channel_reads_with_mcap_and_protobuf_alone_and_agrees_with_the_reader(tmp_path, ur5):
    """The docs' snippet (docs/archives.md) (no `import pipeline`) decodes every message with the schemas in the file,
    finds no NaN or Infinity, and gets the same records, stored traces and solutions as `pipeline`."""
    pytest.importorskip("google.protobuf", reason="protobuf (test extra) not installed")
    p = tmp_path / "a.mcap"
    ps, res = _write(p, ur5, n=30, method="analytic_ur", criterion=None)
    q = tmp_path / "b.mcap"
    _write(q, ur5, n=30, policy=TracePolicy(sample=4, failed_rows=0), criterion="position")
    for path in (p, q):
        got = _snippet(path)
        a = read_archive(path)
        assert got["pipeline_imported"] is False
        assert got["metadata"]["run"] == a.metadata
        solves = got["messages"][SOLVE_TOPIC]
        j = solves[0]["joints"][0]
        assert [x for m in solves for x in m["problem_id"]] == [r["problem_id"] for r in a.solves]
        assert [x for m in solves for x in m["iterations"]] == [r["iterations"] for r in a.solves]
        assert np.array_equal(np.concatenate([m["q_solution"] for m in solves]).reshape(-1, j),
                              np.array([r["q_solution"] for r in a.solves]))
        flags = [x for m in solves for x in m["flags"]]
        assert [bool(f & 1) for f in flags] == [r["success"] for r in a.solves]
        for m in got["messages"].values():
            for fields in m:
                for v in fields.values():
                    if isinstance(v, list) and v and isinstance(v[0], float):
                        assert np.isfinite(v).all()
        tr = got["messages"][TRACE_TOPIC]
        stored = [(pid, r) for m in tr for pid, r, s in zip(m["problem_id"], m.get("repetition", [0] * len(m["problem_id"])),
                                                               m["stored"]) if s]
        assert sorted(stored) == sorted(a.stored_traces())
        err = [x for m in tr for x in m.get("error", [])]
        assert err == [x for t in a.traces() for x in t["error"]]
    sol = _snippet(p)["messages"][SOLUTIONS_TOPIC]
    a = read_archive(p)
    rows = np.concatenate([m["solutions"] for m in sol]).reshape(-1, 6)
    assert np.array_equal(rows, np.concatenate([np.asarray(a.solutions(r["problem_id"])).reshape(-1, 6)
                                                for r in a.solves if a.solutions(r["problem_id"])]))


def test_reading_imports_no_solver(tmp_path, lwr):
    """read_archive, traces, solutions and inspect's views never import the solvers or numba."""
    p = tmp_path / "a.mcap"
    _write(p, lwr, n=8)
    code = ("import sys; from pipeline.io.archive import read_archive; from pipeline.report.inspect import describe; "
            f"a = read_archive({str(p)!r}); list(a.traces()); a.solutions(a.solves[0]['problem_id']); "
            "describe(a); describe(a, problem=a.solves[1]['problem_id']); describe(a, failed=True); "
            "print(sorted(m for m in sys.modules if m.startswith(('pipeline.solvers', 'numba', 'pipeline.runner'))))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"


def test_log_times_are_the_cumulative_solve_time(tmp_path, lwr):
    from mcap.reader import make_reader

    p = tmp_path / "a.mcap"
    _, res = _write(p, lwr, n=2500)
    with open(p, "rb") as fh:
        times = [m.log_time for _, _, m in make_reader(fh).iter_messages(topics=[SOLVE_TOPIC])]
    cum = np.cumsum(res.solve_time_s)
    assert len(times) == 3 and times == sorted(times)
    assert abs(times[-1] - cum[-1] * 1e9) < 10 and abs(times[0] - cum[999] * 1e9) < 10


def test_same_content_same_bytes(tmp_path, lwr):
    ps, res = _batch(lwr, 10)
    cols, traces = batch_columns(ps.problem_id, np.zeros(10), ps.chain, "kuka_lwr", "dls", "m", ps.q_start,
                                 ps.goal_position, ps.goal_quat, res)
    for name in ("a", "b"):
        with ArchiveWriter(tmp_path / f"{name}.mcap", META, policy=TracePolicy(sample=3), problem_ids=ps.problem_id) as w:
            w.write_columns(cols, traces)
    assert (tmp_path / "a.mcap").read_bytes() == (tmp_path / "b.mcap").read_bytes()


def test_interrupted_writer_leaves_nothing(tmp_path, lwr):
    ps, res = _batch(lwr, 3)
    cols, traces = batch_columns(ps.problem_id, np.zeros(3), ps.chain, "kuka_lwr", "dls", "m", ps.q_start,
                                 ps.goal_position, ps.goal_quat, res)
    with pytest.raises(RuntimeError):
        with ArchiveWriter(tmp_path / "a.mcap", META) as w:
            w.write_columns(cols, traces)
            raise RuntimeError("killed")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("cut", [0.5, 0.9])
def test_truncated_archive(tmp_path, lwr, cut):
    p = tmp_path / "a.mcap"
    _write(p, lwr, n=50)
    data = p.read_bytes()
    p.write_bytes(data[: int(len(data) * cut)])
    with pytest.raises(ArchiveError, match="truncated|corrupt|CRC|footer|complete"):
        read_archive(p)


def test_not_mcap_and_missing(tmp_path):
    p = tmp_path / "x.mcap"
    p.write_text("not an archive")
    with pytest.raises(ArchiveError, match="bad magic"):
        read_archive(p)
    with pytest.raises(ArchiveError, match="no such archive"):
        read_archive(tmp_path / "none.mcap")


def test_fewer_records_than_the_metadata_promises_is_an_error(tmp_path, lwr):
    p = tmp_path / "a.mcap"
    _write(p, lwr, n=10, meta={"problems": "12"})
    with pytest.raises(ArchiveError, match=r"a\.mcap: 10 solve records, metadata field 'problems' promises 12"):
        read_archive(p)


def test_a_column_of_the_wrong_length_is_an_error(tmp_path, lwr):
    ps, res = _batch(lwr, 5)
    cols, _ = batch_columns(ps.problem_id, np.zeros(5), ps.chain, "kuka_lwr", "dls", "m", ps.q_start,
                            ps.goal_position, ps.goal_quat, res)
    cols["iterations"] = cols["iterations"][:4]
    p = tmp_path / "a.mcap"
    with ArchiveWriter(p, META) as w:
        w._emit(cols, 5, None)
    with pytest.raises(ArchiveError, match=r"message \d+ on /ik/solve: field 'iterations' holds 4 values for 5 solves"):
        read_archive(p)


@pytest.mark.parametrize("version", ["2", "3", "4", "9"])
def test_other_format_versions_are_refused_in_one_line(tmp_path, lwr, version):
    p = tmp_path / "a.mcap"
    _write(p, lwr, n=3, meta={"format_version": version, "package_version": "0.0.7", "git_commit": "abcdef1234567890"})
    with pytest.raises(ArchiveError) as exc:
        read_archive(p)
    msg = str(exc.value)
    assert f"format_version' is '{version}' (written by ik-pipeline 0.0.7, commit abcdef123456)" in msg
    assert "reads format 5 only" in msg and "\n" not in msg


def _corpus(good: bytes, step: int):
    """Damaged copies: truncations at several offsets and single-byte flips every ``step`` bytes."""
    n = len(good)
    for cut in sorted({8, 9, 40, n // 3, n // 2, n - 40, n - 9, n - 1}):
        yield f"cut{cut}", good[:cut]
    for i in range(0, n, step):
        b = bytearray(good)
        b[i] ^= 0x5A
        yield f"flip{i}", bytes(b)


def test_every_damaged_copy_is_refused_in_one_line_or_reads_the_same(tmp_path, ur5):
    """Truncations and byte flips anywhere: an ArchiveError naming the file, or the very same records."""
    p = tmp_path / "good.mcap"
    _write(p, ur5, n=30, method="analytic_ur", criterion=None)
    good = read_archive(p)
    view = lambda a: (a.metadata, a.solves, list(a.traces()), [a.solutions(r["problem_id"]) for r in a.solves])  # noqa: E731
    want = view(good)
    data = p.read_bytes()
    refused = 0
    for name, blob in _corpus(data, max(1, len(data) // 400)):
        q = tmp_path / f"{name}.mcap"
        q.write_bytes(blob)
        try:
            got = view(read_archive(q))
        except ArchiveError as exc:
            msg = str(exc)
            assert msg.startswith(f"{q}: ") and "\n" not in msg, msg
            refused += 1
            continue
        finally:
            q.unlink()
        assert repr(got) == repr(want), name  # read without complaint: must be the same archive
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


def test_non_finite_starts_and_goals_are_flagged_not_written(tmp_path, lwr):
    """Inline goals (no problem file) with a NaN start and an infinite goal: none in the file, NaN read back."""
    ps, res = _batch(lwr, 4)
    q0, gp = ps.q_start.copy(), ps.goal_position.copy()
    q0[1, 2], gp[2, 0] = np.nan, np.inf
    cols, traces = batch_columns(ps.problem_id, np.zeros(4), ps.chain, "kuka_lwr", "dls", "m", q0, gp, ps.goal_quat, res)
    p = tmp_path / "a.mcap"
    with ArchiveWriter(p, {**META, "problems": "4"}) as w:
        w.write_columns(cols, traces)
    for m in _snippet(p)["messages"].values():
        for fields in m:
            for v in fields.values():
                if isinstance(v, list) and v and isinstance(v[0], float):
                    assert np.isfinite(v).all()
    recs = read_archive(p).solves
    assert np.isnan(recs[1]["q_start"]).all() and recs[0]["q_start"] == ps.q_start[0].tolist()
    assert np.isnan(recs[2]["goal"]["position"]["x"]) and recs[3]["goal"]["position"]["x"] == ps.goal_position[3, 0]


def test_inspect_refuses_a_damaged_archive_with_one_line(tmp_path, lwr):
    p = tmp_path / "a.mcap"
    _write(p, lwr, n=10)
    b = bytearray(p.read_bytes())
    b[len(b) // 2] ^= 0xFF
    p.write_bytes(bytes(b))
    proc = subprocess.run([sys.executable, "-m", "pipeline", "inspect", str(p)], capture_output=True, text=True)
    assert proc.returncode != 0 and "Traceback" not in proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and str(p) in lines[0], proc.stderr


def test_trace_policy_settings_and_samples():
    assert TracePolicy.from_setting(None) == TracePolicy()
    assert TracePolicy.from_setting("all").sample_ids([3, 1, 2]) == {1, 2, 3}
    assert TracePolicy.from_setting("none").sample_ids([3, 1, 2]) == set()
    p = TracePolicy.from_setting({"sample": 3})
    assert p.failed_rows == TracePolicy().failed_rows and p.sample_ids(range(100)) == {0, 50, 99}
    assert TracePolicy.from_json(p.as_json()) == p
    for bad in ("some", {"sample": -1}, {"sample": 1.5}, {"rows": 3}, {"sample": True}, [1]):
        with pytest.raises(ValueError, match="trace_policy"):
            TracePolicy.from_setting(bad)
