"""MCAP archives: round trip, atomic writes, corrupt and truncated files, inspection."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.cli import main
from pipeline.io.archive import FORMAT_VERSION, ArchiveError, ArchiveWriter, read_archive, solve_record
from pipeline.solvers import IKResult

META = {"format_version": FORMAT_VERSION, "study": "s", "robot": "r", "solver": "dls", "settings": "{}",
        "settings_hash": "h", "seed": "1", "package_version": "0", "git_commit": "c"}


def _result(i):
    trace = np.arange(3 * 8, dtype=float).reshape(3, 8) + i
    return IKResult(q=np.array([0.1, 0.2 + i]), success=i % 2 == 0, stop_reason=1 if i % 2 == 0 else 3,
                    iterations=2, trace=trace, solve_time_s=1e-4, ik_time_s=1e-5, position_error=0.0,
                    orientation_error=0.0, claimed_success=i % 2 == 0)


def _write(path, n=4):
    with ArchiveWriter(path, META) as w:
        for i in range(n):
            w.write(*solve_record(i, "r", "dls", "m", [0.0, 1.0], [1, 2, 3], [1, 0, 0, 0], _result(i)))


def test_round_trip(tmp_path):
    p = tmp_path / "a.mcap"
    _write(p)
    a = read_archive(p)
    assert a.metadata == META
    df = a.frame()
    assert df["problem_id"].tolist() == [0, 1, 2, 3]
    assert df["success"].tolist() == [True, False, True, False]
    assert df["q_solution"][1] == [0.1, 1.2]
    assert df["goal"][0]["orientation"] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
    tr = next(a.traces([2]))
    assert tr["error"] == [2.0, 10.0, 18.0] and len(tr["error_vector"][0]) == 6


def test_same_content_same_bytes(tmp_path):
    _write(tmp_path / "a.mcap")
    _write(tmp_path / "b.mcap")
    assert (tmp_path / "a.mcap").read_bytes() == (tmp_path / "b.mcap").read_bytes()


def test_interrupted_writer_leaves_nothing(tmp_path):
    p = tmp_path / "a.mcap"
    with pytest.raises(RuntimeError):
        with ArchiveWriter(p, META) as w:
            w.write(*solve_record(0, "r", "dls", "m", [0.0], [0, 0, 0], [1, 0, 0, 0], _result(0)))
            raise RuntimeError("killed")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("cut", [0.5, 0.9])
def test_truncated_archive(tmp_path, cut):
    p = tmp_path / "a.mcap"
    _write(p, 50)
    data = p.read_bytes()
    p.write_bytes(data[: int(len(data) * cut)])
    with pytest.raises(ArchiveError, match="truncated|corrupt"):
        read_archive(p)


def test_not_mcap_and_missing(tmp_path):
    p = tmp_path / "x.mcap"
    p.write_text("not an archive")
    with pytest.raises(ArchiveError, match="bad magic"):
        read_archive(p)
    with pytest.raises(ArchiveError, match="no such archive"):
        read_archive(tmp_path / "none.mcap")


def test_inspect_cli(tmp_path, capsys):
    p = tmp_path / "a.mcap"
    _write(p)
    assert main(["inspect", str(p), "--failed", "--csv", str(tmp_path / "o.csv")]) == 0
    out = capsys.readouterr().out
    assert "successes: 2 (50.00 %)" in out and "p95 [ms]" in out and "failed solves (2)" in out
    assert (tmp_path / "o.csv").read_text().count("\n") == 5
    assert main(["inspect", str(p), "--problem", "1"]) == 0
    out = capsys.readouterr().out
    assert "problem 1 (repetition 0)" in out and "trace (3 rows" in out
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(p.read_bytes()[:200])
    assert main(["inspect", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1
