# Config validation (schema + every study settings file + every robot file) before any job runs,
# and the helpers the other rule files use.
import json
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


wildcard_constraints:
    study="[a-z0-9_]+",
    robot="[a-z0-9_]+",
    solver="[a-z0-9_]+",


def study_file(wildcards):
    return f"{DATA}/studies/{wildcards.study}.yaml"


# Archives each study's tables and figures are computed from. Generic studies get one archive
# per (robot, solver); a study with its own rules (workflow/rules/studies/<id>.smk) sets its list.
STUDY_ARCHIVES = {
    sid: [
        f"{RESULTS}/{sid}/runs/{robot}__{solver}.mcap"
        for robot in st.doc["robots"]
        for solver in st.solvers
    ]
    for sid, st in STUDIES.items()
    if st.generic
}
GENERIC_STUDIES = "|".join(sid for sid, st in STUDIES.items() if st.generic) or "__none__"


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
