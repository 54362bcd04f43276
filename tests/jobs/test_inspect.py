"""`python -m pipeline inspect`: units, per-solver summary, one problem, raw JSON, CSV, speed (issue 15, item 5)."""

from __future__ import annotations

import csv
import json
import re

import numpy as np
import pytest

from pipeline.cli import main
from pipeline.io.archive import FORMAT_VERSION, ArchiveWriter, batch_columns, read_archive
from pipeline.report.inspect import describe
from pipeline.solvers import IKResult

META = {"format_version": FORMAT_VERSION, "study": "s", "robot": "r", "solver": "dls", "settings": "{}",
        "settings_hash": "h", "seed": "1", "package_version": "0", "git_commit": "c", "length_unit": "cm"}


def _result(i, rows=3, info=None):
    trace = np.arange(rows * 8, dtype=float).reshape(rows, 8) + i
    return IKResult(q=np.array([0.1, 0.2 + i, 0.3]), success=i % 2 == 0, stop_reason=1 if i % 2 == 0 else 3,
                    iterations=rows - 1, trace=trace, solve_time_s=1e-4 * (i + 1), ik_time_s=1e-5,
                    position_error=0.5 * i,
                    orientation_error=float("nan") if i == 1 else 0.01 * i, claimed_success=i % 2 == 0,
                    info=info or {})


def _write(path, n=4, solvers=("dls",), rows=3, strategies=None):
    from pipeline.solvers.core.driver import stack as _stack

    with ArchiveWriter(path, {**META, "problems": str(n * len(solvers))}) as w:
        for s_i, solver in enumerate(solvers):
            res = _stack([_result(i + s_i, rows, {"strategy": strategies[i % len(strategies)]} if strategies
                                  else {"steps": i}) for i in range(n)], "cm", traces=True)
            cols, tr = batch_columns(np.arange(n), np.zeros(n), np.full(n, -1), "r", solver, "cm",
                                     np.tile([0.0, 1.0, -1.0], (n, 1)), np.tile([1.5, 2.5, 3.5], (n, 1)),
                                     np.tile([1.0, 0, 0, 0], (n, 1)), res, method=solver.split("_")[0])
            w.write_columns(cols, tr)
    return read_archive(path)


def _headers(line: str) -> list[str]:
    return re.split(r"\s{2,}", line.strip())


def _section(out: str, title: str) -> list[str]:
    lines = out.splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith(title))
    return lines[k + 1:]


def test_summary_columns_all_carry_units(tmp_path, capsys):
    p = tmp_path / "a.mcap"
    _write(p)
    assert main(["inspect", str(p), "--failed"]) == 0
    out = capsys.readouterr().out
    assert "FK-verified successes: 2 (50.00 %)" in out
    per = _section(out, "per solver (1)")
    for h in _headers(per[0])[2:]:
        assert re.search(r"\[(count|%|ms)\]$", h), h
    assert _headers(per[1])[:4] == ["dls", "dls", "4", "2"]
    stops = _section(out, "stop reasons")
    assert _headers(stops[0]) == ["stop", "reason", "dls [count]"]
    assert _headers(stops[1]) == ["1", "success", "2"] and stops[2].split()[0] == "3"
    failed = _section(out, "failed solves (2)")
    assert all("[" in h for h in _headers(failed[0])[4:]) and "position_error [cm]" in failed[0]
    assert [ln.split()[0] for ln in failed[1:3]] == ["1", "3"]


def test_several_solvers_and_strategies_are_summarised_per_solver(tmp_path, capsys):
    p = tmp_path / "a.mcap"
    _write(p, solvers=("dls", "sdls_b"))
    assert main(["inspect", str(p)]) == 0
    out = capsys.readouterr().out
    per = _section(out, "per solver (2)")
    assert [_headers(r)[:3] for r in per[1:3]] == [["dls", "dls", "4"], ["sdls_b", "sdls", "4"]]
    assert "dls [count]" in out and "sdls_b [count]" in out
    q = tmp_path / "b.mcap"
    _write(q, n=6, strategies=[3, 5])
    out = describe(read_archive(q))
    per = _section(out, "per solver (2)")
    assert _headers(per[0])[:3] == ["solver", "method", "strategy"]
    assert [_headers(r)[:4] for r in per[1:3]] == [["dls", "dls", "3", "3"], ["dls", "dls", "5", "3"]]


def test_problem_view_is_a_short_summary(tmp_path, capsys):
    p = tmp_path / "a.mcap"
    _write(p, rows=30)
    assert main(["inspect", str(p), "--problem", "1"]) == 0
    out = capsys.readouterr().out
    assert "solver: dls (method dls)" in out
    assert "stop reason 3: error grew on consecutive iterations" in out and "result: failure" in out
    assert "iterations: 29 [count]" in out and "solve time: 0.2 ms" in out
    assert "position error: 0.5 cm" in out and "orientation error: - rad" in out  # null: not checked
    assert "q_start:    0.000000 1.000000 -1.000000" in out and "q_solution: 0.100000 1.200000 0.300000" in out
    trace = _section(out, "  trace (30 rows")
    assert _headers(trace[0]) == ["iteration", "error [method's own measure]", "|dp| [cm]", "|e_omega| [rad]"]
    assert [r.split()[0] for r in trace[1:12]] == ["0", "1", "2", "3", "4", "...", "25", "26", "27", "28", "29"]
    assert len(out.splitlines()) < 40


def test_json_prints_the_raw_record_as_strict_json(tmp_path, capsys):
    p = tmp_path / "a.mcap"
    arch = _write(p)
    assert main(["inspect", str(p), "--problem", "1", "--json"]) == 0
    out = capsys.readouterr().out
    rec = json.loads(out, parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))
    want = arch.solves[1]
    assert rec["orientation_error"] is None and np.isnan(want["orientation_error"])
    assert rec == {k: None if isinstance(v, float) and np.isnan(v) else v for k, v in want.items()}
    assert main(["inspect", str(p), "--json"]) == 2
    assert "--problem" in capsys.readouterr().err


def test_a_missing_problem_is_an_error(tmp_path, capsys):
    p = tmp_path / "a.mcap"
    _write(p)
    assert main(["inspect", str(p), "--problem", "77"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and str(p) in captured.err and "problem 77" in captured.err
    assert main(["inspect", str(p), "--problem", "77", "--json"]) == 2


def test_csv_has_a_column_per_joint_and_goal_value_with_units(tmp_path, capsys):
    p, out = tmp_path / "a.mcap", tmp_path / "o.csv"
    arch = _write(p)
    assert main(["inspect", str(p), "--csv", str(out)]) == 0
    assert f"wrote {out}: 4 rows" in capsys.readouterr().out
    rows = list(csv.DictReader(out.open()))
    assert len(rows) == 4
    cols = list(rows[0])
    for c in ["q_start_1", "q_start_2", "q_start_3", "q_solution_1", "q_solution_3", "goal_x_cm", "goal_y_cm",
              "goal_z_cm", "goal_qx", "goal_qy", "goal_qz", "goal_qw", "solve_time_s", "call_time_s",
              "position_error_cm", "orientation_error_rad", "info_steps"]:
        assert c in cols, c
    assert not any(c in cols for c in ("q_start", "q_solution", "goal", "info"))
    for r, rec in zip(rows, arch.solves):
        assert float(r["q_solution_2"]) == rec["q_solution"][1] and float(r["goal_z_cm"]) == 3.5
        assert float(r["goal_qw"]) == 1.0 and float(r["solve_time_s"]) == rec["solve_time_s"]
    assert rows[1]["orientation_error_rad"] == ""  # not checked (null in the archive)


def _big_archive(path, n):
    rng = np.random.default_rng(0)
    cols = {"problem_id": np.arange(n), "repetition": np.zeros(n, int), "chain": np.full(n, -1),
            "robot": ["r"] * n, "solver": ["a" if i % 3 else "b" for i in range(n)], "method": ["dls"] * n,
            "success": rng.random(n) < 0.9, "claimed_success": np.ones(n, bool),
            "stop_reason": rng.integers(1, 5, n), "iterations": rng.integers(1, 500, n),
            "solve_time_s": rng.random(n) * 1e-3, "ik_time_s": np.zeros(n), "call_time_s": rng.random(n) * 1e-3,
            "within_limits": np.ones(n, bool), "initial_error": rng.random(n), "final_error": rng.random(n),
            "position_error": rng.random(n), "orientation_error": rng.random(n), "length_unit": ["m"] * n,
            "q_start": rng.normal(size=(n, 7)), "q_solution": rng.normal(size=(n, 7)),
            "goal_position": rng.normal(size=(n, 3)), "goal_orientation": np.tile([0.0, 0, 0, 1], (n, 1)),
            "info": [{"steps": int(i)} for i in range(n)]}
    with ArchiveWriter(path, {**META, "problems": str(n), "length_unit": "m"}) as w:
        w.write_columns(cols)


def test_ten_thousand_solves_summarise(tmp_path):
    """A large archive summarises per solver (no test asserts a wall time: a loaded machine moves it)."""
    p = tmp_path / "big.mcap"
    _big_archive(p, 10_000)
    out = describe(read_archive(p), failed=True)
    assert "per solver (2)" in out
