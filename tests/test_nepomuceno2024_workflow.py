"""nepomuceno2024 end to end on a tiny scale: archives, determinism, tables, figures, CLI errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pipeline.cli import main
from pipeline.io.archive import read_archive
from pipeline.settings import load_study
from pipeline.studies.nepomuceno2024 import build_figures, build_tables
from pipeline.studies.nepomuceno2024.runner import POINT_TOPIC, REP_TOPIC, solve_motion

ROOT = Path(__file__).resolve().parent.parent
STUDY_FILE = ROOT / "data/studies/nepomuceno2024.yaml"
ROBOT = ROOT / "data/robots/ur5_nepomuceno.yaml"
MOTIONS = ROOT / "data/nepomuceno2024/motions.yaml"
METHODS = ["pinv", "lbfgsb", "nelder_mead", "analytic"]
TIMING = {"solve_time_s", "ik_time_s"}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Quick-scale home motion, each method twice into separate archives."""
    study = load_study(STUDY_FILE)
    out = tmp_path_factory.mktemp("nep")
    paths = {}
    for method in METHODS:
        for k in (1, 2):
            p = out / f"run{k}" / f"home__{method}.mcap"
            solve_motion(study, ROBOT, MOTIONS, "home", method, "quick", p, log=open("/dev/null", "w"))
            paths[(method, k)] = p
    return study, paths


@pytest.mark.parametrize("method", METHODS)
def test_same_trajectories_give_identical_archives_timings_aside(runs, method):
    _, paths = runs
    a, b = read_archive(paths[(method, 1)]), read_archive(paths[(method, 2)])
    assert len(a.solves) == len(b.solves) > 0
    for ra, rb in zip(a.solves, b.solves):
        assert {k: v for k, v in ra.items() if k not in TIMING} == {k: v for k, v in rb.items() if k not in TIMING}
    assert list(a.messages(POINT_TOPIC)) == list(b.messages(POINT_TOPIC))
    assert [t["error"] for t in a.traces()] == [t["error"] for t in b.traces()]
    assert a.metadata == b.metadata
    reps = list(a.messages(REP_TOPIC))
    assert len(reps) == int(a.metadata["repetitions"]) and all(r["same_as_repetition_0"] for r in reps)


def test_every_solve_is_fk_checked_and_succeeds_on_home(runs):
    _, paths = runs
    for method in METHODS:
        a = read_archive(paths[(method, 1)])
        df = a.frame()
        assert np.isfinite(df["position_error"]).all() and np.isfinite(df["orientation_error"]).all()
        for r in a.messages(REP_TOPIC):
            assert len(r["position_error"]) == len(df)
        if method in ("pinv", "analytic"):
            assert df["success"].all()


def test_tables_and_figures_build_from_the_archives(runs, tmp_path):
    study, paths = runs
    archives = [read_archive(paths[(m, 1)]) for m in METHODS]
    tables = build_tables(study, archives, ROOT / "data/published")
    names = {t.name for t in tables}
    assert {"table5_1_motion_time", "table5_2_error_iterations", "continuity", "orderings"} <= names
    t52 = next(t for t in tables if t.name == "table5_2_error_iterations").frame
    assert any("(published)" in c for c in t52.columns) and any("(ours)" in c for c in t52.columns)
    assert t52["mean error (published)"].notna().sum() == 3  # descent, L-BFGS-B, Nelder-Mead rows
    figs = build_figures(study, archives, tmp_path)
    for f in figs:
        assert (tmp_path / f.files[0]).stat().st_size > 1000


def test_cli_unknown_method_is_one_line_error(tmp_path, capsys):
    rc = main(["solve_motion_nepomuceno2024", "--study", str(STUDY_FILE), "--robot", str(ROBOT), "--motions",
               str(MOTIONS), "--motion", "home", "--method", "newton", "--scale", "quick",
               "--out", str(tmp_path / "x.mcap")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and err.startswith("error:") and "newton" in err and "\n" not in err
    assert not (tmp_path / "x.mcap").exists()


def test_cli_unknown_motion_is_one_line_error(tmp_path, capsys):
    rc = main(["plan_motion_nepomuceno2024", "--study", str(STUDY_FILE), "--robot", str(ROBOT), "--motions",
               str(MOTIONS), "--motion", "dance", "--scale", "quick", "--out", str(tmp_path / "x.csv")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "dance" in err and "\n" not in err


def test_cli_plan_motion_writes_points(tmp_path):
    out = tmp_path / "home.csv"
    assert main(["plan_motion_nepomuceno2024", "--study", str(STUDY_FILE), "--robot", str(ROBOT), "--motions",
                 str(MOTIONS), "--motion", "home", "--scale", "quick", "--out", str(out)]) == 0
    lines = out.read_text().splitlines()
    assert lines[0].startswith("point,segment,x_m") and len(lines) > 2
    assert lines[-1].split(",")[1] == "return_home"
