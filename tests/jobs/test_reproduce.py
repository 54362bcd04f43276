"""`python -m pipeline reproduce`: re-runs from an archive's metadata, bit-identical here, findings elsewhere."""

from __future__ import annotations

import shutil

import pytest

from tests.conftest import run_pipeline


@pytest.fixture(scope="module")
def archives(tmp_path_factory):
    d = tmp_path_factory.mktemp("rep")
    study = "data/studies/cerbaro2019.yaml"
    assert run_pipeline("make_problems", "--study", study, "--problem-set", "random", "--robot", "data/robots/kuka_lwr.yaml",
                     "--scale", "quick", "--out", str(d / "p.csv.gz")).returncode == 0
    outs = [str(d / f"{s}.mcap") for s in ("dls", "sdls")]
    p = run_pipeline("solve_problems", "--study", study, "--problem-set", "random", "--robot", "data/robots/kuka_lwr.yaml",
                  "--solver", "dls", "sdls", "--problems", str(d / "p.csv.gz"), "--scale", "quick", "--limit", "12",
                  "--out", *outs)
    assert p.returncode == 0, p.stderr
    return d


def test_every_solve_re_runs_bit_identical_on_the_machine_that_wrote_it(archives):
    p = run_pipeline("reproduce", str(archives))
    assert p.returncode == 0, p.stderr
    assert "2 deterministic archive(s): 2 bit-identical on every re-run solve, 0 with differences" in p.stdout
    rows = [ln.split() for ln in p.stdout.splitlines() if ln.startswith(("dls.mcap", "sdls.mcap"))]
    assert [r[3:5] for r in rows] == [["12", "12"], ["12", "12"]]
    assert "written on:" in p.stdout and "re-run on:" in p.stdout


def test_another_blas_kernel_is_a_finding_not_an_error(archives):
    p = run_pipeline("reproduce", str(archives / "sdls.mcap"), "--problem", "3", env={"OPENBLAS_CORETYPE": "Prescott"})
    assert p.returncode == 0, p.stderr
    assert "OPENBLAS_CORETYPE=Prescott" in p.stdout.split("re-run on:")[1]
    assert "deterministic archive(s)" in p.stdout


def test_a_missing_robot_file_or_problem_is_one_line(archives, tmp_path):
    alone = tmp_path / "a.mcap"
    shutil.copy(archives / "dls.mcap", alone)
    shutil.copy(archives / "p.csv.gz", tmp_path / "p.csv.gz")
    p = run_pipeline("reproduce", str(alone), "--robot", str(tmp_path / "none.yaml"))
    lines = [ln for ln in p.stderr.splitlines() if ln.strip() and not ln.startswith("[")]
    assert p.returncode == 2 and len(lines) == 1 and "robot_file" in lines[0] and "--robot" in lines[0], p.stderr
    p = run_pipeline("reproduce", str(archives / "dls.mcap"), "--problem", "99999")
    lines = [ln for ln in p.stderr.splitlines() if ln.strip() and not ln.startswith("[")]
    assert p.returncode == 2 and lines == [f"error: {archives / 'dls.mcap'}: problem 99999 is not in the archive"]
