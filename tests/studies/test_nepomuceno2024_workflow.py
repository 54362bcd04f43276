"""nepomuceno2024 end to end on a tiny scale through the generic verbs: the motion generator,
solve_problems archives, determinism, tables, figures, CLI errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pipeline.cli import main
from pipeline.io.archive import read_archive
from pipeline.io.problems import read_problems
from pipeline.settings import load_study
from pipeline.studies.nepomuceno2024 import build_figures, build_tables
from pipeline.studies.nepomuceno2024.problems import set_motion

ROOT = Path(__file__).resolve().parents[2]
STUDY_FILE = ROOT / "data/studies/nepomuceno2024.yaml"
ROBOT = ROOT / "data/robots/ur5_nepomuceno.yaml"
METHODS = ["pinv", "lbfgsb", "nelder_mead", "analytic"]
TIMING = {"solve_time_s", "ik_time_s", "call_time_s", "cpu_time_s"}


def _make(out: Path, motion: str) -> Path:
    p = out / f"{motion}.csv"
    assert main(["make_problems", "--study", str(STUDY_FILE), "--problem-set", motion, "--robot", str(ROBOT),
                 "--scale", "quick", "--data", str(ROOT / "data"), "--out", str(p)]) == 0
    return p


def _solve(problems: Path, motion: str, solver: str, out: Path) -> Path:
    assert main(["solve_problems", "--study", str(STUDY_FILE), "--problem-set", motion, "--robot", str(ROBOT),
                 "--solver", solver, "--problems", str(problems), "--scale", "quick", "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Quick-scale home motion, each method twice into separate archives."""
    study = load_study(STUDY_FILE)
    out = tmp_path_factory.mktemp("nep")
    problems = _make(out, "home")
    paths = {}
    for method in METHODS:
        for k in (1, 2):
            paths[(method, k)] = _solve(problems, "home", method, out / f"run{k}" / f"ur5_nepomuceno__{method}.mcap")
    return study, problems, paths


def test_the_motion_is_one_chain_of_path_points(runs):
    study, problems, _ = runs
    ps, _ = read_problems(problems)
    mp = set_motion(study, "home", "quick")
    assert len(ps) == len(mp) and np.all(ps.chain == 0) and np.all(np.isnan(ps.q_goal))
    np.testing.assert_allclose(ps.goal_transforms(), mp.T, atol=1e-15)
    assert np.array_equal(ps.q_start[0], mp.q_start)


@pytest.mark.parametrize("method", METHODS)
def test_same_trajectories_give_identical_archives_timings_aside(runs, method):
    _, _, paths = runs
    a, b = read_archive(paths[(method, 1)]), read_archive(paths[(method, 2)])
    assert len(a.solves) == len(b.solves) > 0
    for ra, rb in zip(a.solves, b.solves):
        assert {k: v for k, v in ra.items() if k not in TIMING} == {k: v for k, v in rb.items() if k not in TIMING}
    assert [t["error"] for t in a.traces()] == [t["error"] for t in b.traces()]
    assert {k: v for k, v in a.metadata.items() if k != "problem_file"} == \
        {k: v for k, v in b.metadata.items() if k != "problem_file"}
    reps = int(a.metadata["repetitions"])
    df = a.frame()
    assert reps == 2 and set(df["repetition"]) == {0, 1}
    q = {r: np.array(g.sort_values("problem_id")["q_solution"].tolist()) for r, g in df.groupby("repetition")}
    assert np.array_equal(q[0], q[1])  # every repetition gives the same solutions


def test_every_point_warm_starts_from_the_previous_solution(runs):
    _, _, paths = runs
    for method in METHODS:
        df = read_archive(paths[(method, 1)]).frame()
        g = df[df["repetition"] == 0].sort_values("problem_id")
        q0, q1 = np.array(g["q_start"].tolist()), np.array(g["q_solution"].tolist())
        assert np.array_equal(q0[1:], q1[:-1])
        assert np.isfinite(g["position_error"]).all() and np.isfinite(g["orientation_error"]).all()
        if method in ("pinv", "analytic"):
            assert g["success"].all()
        assert {"nfev", "njev", "doc_error", "message"} <= set(g["info"].iloc[0])


def test_tables_and_figures_build_from_the_archives(runs, tmp_path):
    study, _, paths = runs
    archives = [read_archive(paths[(m, 1)]) for m in METHODS]
    tables = build_tables(study, archives, ROOT / "data/published")
    names = {t.name for t in tables}
    assert {"table5_1_motion_time", "table5_2_error_iterations", "continuity", "orderings"} <= names
    t52 = next(t for t in tables if t.name == "table5_2_error_iterations").frame
    assert any("(published)" in c for c in t52.columns) and any("(ours)" in c for c in t52.columns)
    assert t52["mean error (published)"].notna().sum() == 3  # descent, L-BFGS-B, Nelder-Mead rows
    t51 = next(t for t in tables if t.name == "table5_1_motion_time").frame
    assert (t51["Teste 1 (home): points"] == len(archives[0].frame()) // 2).all()
    figs = build_figures(study, archives, tmp_path)
    for f in figs:
        assert (tmp_path / f.files[0]).stat().st_size > 1000


def test_cli_unknown_solver_is_one_line_error(runs, tmp_path, capsys):
    _, problems, _ = runs
    rc = main(["solve_problems", "--study", str(STUDY_FILE), "--problem-set", "home", "--robot", str(ROBOT),
               "--solver", "newton", "--problems", str(problems), "--scale", "quick", "--out", str(tmp_path / "x.mcap")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and err.startswith("error:") and "newton" in err and "\n" not in err
    assert not (tmp_path / "x.mcap").exists()


def test_cli_unknown_motion_is_one_line_error(tmp_path, capsys):
    rc = main(["plan_motion_nepomuceno2024", "--study", str(STUDY_FILE), "--motion", "dance", "--scale", "quick",
               "--out", str(tmp_path / "x.csv")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "dance" in err and "\n" not in err


def test_cli_plan_motion_writes_points(tmp_path):
    out = tmp_path / "home.csv"
    assert main(["plan_motion_nepomuceno2024", "--study", str(STUDY_FILE), "--motion", "home", "--scale", "quick",
                 "--data", str(ROOT / "data"), "--out", str(out)]) == 0
    lines = out.read_text().splitlines()
    assert lines[0].startswith("point,segment,x_m") and len(lines) > 2
    assert lines[-1].split(",")[1] == "return_home"
