"""``benchmark_arm``: the arm benchmark on one robot file alone, without re-running the catalogue arms.

It writes a data folder beside the results (``<results>/data``) holding a copy of
``studies/arm_benchmark.yaml`` whose robot list is that one robot, the robot file (and the URDF
files a URDF-form robot file names), and a link to the published tables; then runs Snakemake on it
with ``studies=[arm_benchmark]``. Everything else (problem sets, solvers, the recommendation rule)
is the catalogue's protocol, so the arm's answer reads like the catalogue arms' answers.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

from pipeline.errors import UsageError
from pipeline.io.layout import SAMPLES_FILE
from pipeline.names import check_name, check_path

STUDY = "arm_benchmark"


def prepare_arm_data(robot, data: Path, out: Path) -> str:
    """Write ``out`` (a data folder) for benchmarking the robot file ``robot`` alone; returns its name."""
    from pipeline.jobs.build import answer_study_text
    from pipeline.robots import RobotFileError, load_robot

    robot = Path(robot)
    try:
        model = load_robot(robot)
    except RobotFileError as exc:
        raise UsageError(str(exc)) from None
    check_name(model.name, f"{robot}: field 'name'")
    text = answer_study_text(data, lambda src: f"# written by `python -m pipeline benchmark_arm {robot.name}`: {src} with "
                                               f"robots: [{model.name}]\n", robots=[model.name])
    (out / "studies").mkdir(parents=True, exist_ok=True)
    (out / "robots").mkdir(parents=True, exist_ok=True)
    (out / "studies" / f"{STUDY}.yaml").write_text(text, encoding="utf-8")
    copy = out / "robots" / f"{model.name}.yaml"
    if not (copy.exists() and copy.samefile(robot)):  # re-running on the copy a first run wrote
        shutil.copyfile(robot, copy)
    urdf_dir = robot.resolve().parent / "urdf"
    if urdf_dir.is_dir():  # URDF-form robot files name their URDF relative to the robots folder
        shutil.copytree(urdf_dir, out / "robots" / "urdf", dirs_exist_ok=True)
    published = out / "published"
    if not published.exists():
        published.symlink_to((data / "published").resolve(), target_is_directory=True)
    return model.name


def benchmark_arm(robot, *, scale: str = "full", cores: int = 2, results=None, data="data",
                  dry_run: bool = False) -> str:
    """Benchmark the robot file ``robot`` alone (see the module docstring); returns the report's path."""
    robot = Path(robot)
    if not robot.is_file():
        raise UsageError(f"{robot}: no such robot file")
    if cores < 1:
        raise UsageError(f"--cores {cores}: at least 1")
    root = Path(__file__).resolve().parents[2]  # the checkout: Snakefile, workflow/
    if not (root / "Snakefile").is_file():
        raise UsageError(f"{root}: no Snakefile here (benchmark_arm runs the workflow of a source checkout)")
    if results is None:
        check_name(robot.stem, f"{robot}: the file name")
    results = Path(results or f"results/arm_{robot.stem}").resolve()
    data = Path(data).resolve()
    # both folders reach the rules' shell commands through Snakemake's config: no shell text in them
    check_path(results, "--results (resolved)")
    check_path(data, "--data (resolved)")
    data_out = results / "data"
    name = prepare_arm_data(robot, data, data_out)
    cmd = [sys.executable, "-m", "snakemake", "--cores", str(cores), "--config", f"studies=[{STUDY}]", f"scale={scale}",
           f"data_dir={data_out}", f"results_dir={results}"]
    if dry_run:
        return f"would run in {root}: " + " ".join(cmd)
    print(f"running in {root}: " + " ".join(cmd), file=sys.stderr, flush=True)
    proc = subprocess.run(cmd, cwd=root)
    if proc.returncode != 0:
        raise UsageError(f"snakemake failed (exit {proc.returncode}); its log is above, the jobs' logs in {results}/"
                         f"{STUDY}/logs")
    return f"benchmarked {name} alone: {results / 'report.html'} (per-solve data: {results / STUDY / 'tables' / SAMPLES_FILE})"
