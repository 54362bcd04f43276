# Config validation (schema + every study settings file + every robot file) before any job runs,
# and the helpers the other rule files use.
import json
import os
import sys

from pipeline.settings import ConfigError, check_inputs
from pipeline.robots import RobotFileError
from pipeline.solvers import SettingsError

try:
    STUDIES = {s.id: s for s in check_inputs(config)}
except (ConfigError, RobotFileError, SettingsError) as exc:
    sys.exit(f"error: {exc}")

RESULTS = config["results_dir"]
DATA = config["data_dir"]
SCALE = config["scale"]
# one thread per job: the solvers are sequential, and 2 jobs fill the 2 cores
ENV = "OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 NUMBA_NUM_THREADS=1"

# Memory [MB] and wall time [min] each kind of job asks a cluster for (`resources:` of every rule),
# from the Snakemake benchmark files of a full build (results/<study>/benchmarks/*.tsv, 2 shared
# cores): largest max RSS 366 MB (an arm_benchmark job of one robot, every solver), solve jobs
# <= 224 MB and <= 60 s, the per-robot benchmark jobs <= 70 s; with about 2x headroom on memory and
# 10x on time (a cluster node may be slower, and runtime is a hard limit there).
RES = {
    "light": {"mem_mb": 512, "runtime": 10},  # problem sets, tables, RES rows, the report
    "solve": {"mem_mb": 768, "runtime": 30},  # one solver on one problem set; reruns; measurements
    "solve_robot": {"mem_mb": 1024, "runtime": 60},  # every solver of one robot (job_per_robot studies)
    "figures": {"mem_mb": 1024, "runtime": 20},  # matplotlib over a study's archives
}


# cheap rules run in the Snakemake process's own machine, never submitted to a cluster
localrules:
    aggregate_tables,
    render_report,
    manifest,


# ids never hold a double underscore, so "<robot>__<solver>" splits one way only
wildcard_constraints:
    study="[a-z0-9_]+",
    pset="[a-z0-9]+(?:_[a-z0-9]+)*",
    robot="[a-z0-9]+(?:_[a-z0-9]+)*",
    solver="[a-z0-9]+(?:_[a-z0-9]+)*",


def study_file(wildcards):
    return f"{DATA}/studies/{wildcards.study}.yaml"


# Archives each study's tables and figures are computed from: one per (problem set, robot, solver
# label) solve job; a study with rules of its own (workflow/rules/studies/<id>.smk) may append more.
STUDY_ARCHIVES = {
    sid: [f"{RESULTS}/{sid}/runs/{pset}/{robot}__{solver}.mcap" for pset, robot, solver in st.jobs()]
    for sid, st in STUDIES.items()
}
GENERIC_STUDIES = "|".join(sid for sid, st in STUDIES.items() if st.generic) or "__none__"
# studies whose solve jobs run one per (problem set, robot) (`job_per_robot`), and the others
PER_ROBOT_STUDIES = [sid for sid, st in STUDIES.items() if st.generic and st.job_per_robot]
SOLO_STUDIES = "|".join(sid for sid, st in STUDIES.items() if st.generic and not st.job_per_robot) or "__none__"


def problem_set_files(wildcards):
    """Data files a problem set's generator reads (`files:` of the set), as rule inputs."""
    spec = STUDIES[wildcards.study].problem_sets[wildcards.pset]
    return [f"{DATA}/{f}" for f in spec.get("files", [])]


def study_archives(wildcards):
    return STUDY_ARCHIVES[wildcards.study]


def study_targets(sid):
    return [f"{RESULTS}/{sid}/tables", f"{RESULTS}/{sid}/figures"]


def all_targets():
    """The report, every study's tables and figures, and every archive. Intermediates are listed as
    targets on purpose: since Snakemake 7.7 a deleted intermediate file is not rebuilt while its
    consumers are present, and deleting an archive, a tables or a figures folder must rebuild it and
    exactly what depends on it."""
    return ([f"{RESULTS}/report.html"] + [t for sid in STUDIES for t in study_targets(sid)]
            + [a for sid in STUDIES for a in STUDY_ARCHIVES.get(sid, [])])
