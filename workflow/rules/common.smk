# Config validation before any job runs, and the input functions the other rule files use.
#
# The validation (config schema, every study's settings, every robot file they name, which solver applies
# to which robot) needs the solver registry, so it runs in a process of its own
# (workflow/scripts/check_inputs.py) and hands back plain data: the validated config and, per study, its
# settings document, solver settings and solve jobs. Nothing here imports the library.
import ast
import json
import os
import subprocess
import sys


def _check_inputs():
    """The plan of workflow/scripts/check_inputs.py; an input error stops the run with its one line."""
    files = ["workflow/config/config.yaml", *workflow.overwrite_configfiles]
    proc = subprocess.run(
        [
            sys.executable,
            os.path.join(workflow.basedir, "workflow/scripts/check_inputs.py"),
            *files,
        ],
        input=repr(config),
        capture_output=True,
        text=True,
    )
    if proc.returncode == 2:  # its last line (anything printed before it is a library's warning)
        sys.exit(f"error: {proc.stderr.strip().splitlines()[-1]}")
    if proc.returncode:
        sys.exit(f"error: workflow/scripts/check_inputs.py failed:\n{proc.stderr}")
    return ast.literal_eval(proc.stdout)


_PLAN = _check_inputs()
CONFIG = _PLAN["config"]  # the validated run config, defaults filled
STUDIES = _PLAN["studies"]  # study id -> {doc, solvers, jobs, count, repetitions, caps}

RESULTS = CONFIG["results_dir"]
DATA = CONFIG["data_dir"]
SCALE = CONFIG["scale"]
# one thread per job: the solvers are sequential, and 2 jobs fill the 2 cores
ENV = "OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 NUMBA_NUM_THREADS=1"

# Memory [MB] and wall time [min] each kind of job asks a cluster for (`resources:` of every rule),
# from the Snakemake benchmark files of a full build (results/<study>/benchmarks/*.tsv, 2 shared
# cores): largest max RSS 366 MB (an arm_benchmark job of one robot, every solver), solve jobs
# <= 224 MB and <= 60 s, the per-robot benchmark jobs <= 70 s; with about 2x headroom on memory and
# 10x on time (a cluster node may be slower, and runtime is a hard limit there).
RES = {
    # problem sets, tables, RES rows, the report
    "light": {"mem_mb": 512, "runtime": 10},
    # one solver on one problem set; reruns; measurements
    "solve": {"mem_mb": 768, "runtime": 30},
    # every solver of one robot (job_per_robot studies)
    "solve_robot": {"mem_mb": 1024, "runtime": 60},
    # matplotlib over a study's archives
    "figures": {"mem_mb": 1024, "runtime": 20},
}


# cheap rules run in the Snakemake process's own machine, never submitted to a cluster
localrules:
    place_archive,
    aggregate_tables,
    render_report,
    manifest,
    study,


def _alternatives(ids):
    return "|".join(ids) or "__none__"


def _generic(sid):
    return bool(STUDIES[sid]["doc"].get("problem_sets"))


def _per_robot(sid):
    return _generic(sid) and bool(STUDIES[sid]["doc"].get("job_per_robot"))


# studies whose solve jobs run one per (problem set, robot, solver), and those (`job_per_robot`) whose
# solve jobs run one per robot
SOLO_STUDIES = _alternatives(
    sid for sid in STUDIES if _generic(sid) and not _per_robot(sid)
)
PER_ROBOT_STUDIES = [sid for sid in STUDIES if _per_robot(sid)]


# ids never hold a double underscore, so "<robot>__<solver>" splits one way only
wildcard_constraints:
    study="[a-z0-9_]+",
    pset="[a-z0-9]+(?:_[a-z0-9]+)*",
    robot="[a-z0-9]+(?:_[a-z0-9]+)*",
    solver="[a-z0-9]+(?:_[a-z0-9]+)*",


# --- what a study's settings say -------------------------------------------------------------------


def study_doc(sid):
    return STUDIES[sid]["doc"]


def study_settings(sid):
    """The study-specific block (`study_settings`), empty when absent."""
    return study_doc(sid).get("study_settings", {})


def set_robots(sid, pset):
    return list(
        study_doc(sid)["problem_sets"][pset].get("robots") or study_doc(sid)["robots"]
    )


def kept_jobs(sid):
    """The study's solve jobs at this run's scale: (problem set, robot, label), refused pairs and the
    problem sets listed in `study_settings/full_only_problem_sets` (at scale=quick) left out.
    """
    full_only = set(study_settings(sid).get("full_only_problem_sets", []))
    return [
        job
        for job in STUDIES[sid]["jobs"]
        if SCALE == "full" or job[0] not in full_only
    ]


def robot_solvers(sid, pset, robot):
    """Solver labels that run on `robot` in problem set `pset`."""
    return [s for p, r, s in STUDIES[sid]["jobs"] if p == pset and r == robot]


def robot_sets(sid, robot):
    """Problem sets of `robot` (the sets of its one job under `job_per_robot`)."""
    return [p for p in study_doc(sid)["problem_sets"] if robot in set_robots(sid, p)]


def robot_labels(sid, robot):
    """Solver labels of `robot`'s one job under `job_per_robot` (the same on each of its problem sets,
    checked with the config)."""
    return robot_solvers(sid, robot_sets(sid, robot)[0], robot)


def robot_problem_files(wildcards):
    """The problem files of one `job_per_robot` job, in the order of its `--problem-set` list."""
    sid, robot = wildcards.study, wildcards.robot
    return [f"{RESULTS}/{sid}/problems/{p}/{robot}.csv.gz" for p in robot_sets(sid, robot)]


def robot_job_archives(wildcards, output):
    """Where one `job_per_robot` job writes its archives: inside its own folder, one per (problem set,
    label), in the order `solve_problems --out` takes them."""
    sid, robot = wildcards.study, wildcards.robot
    return [
        f"{output[0]}/{p}/{robot}__{lab}.mcap"
        for p in robot_sets(sid, robot)
        for lab in robot_labels(sid, robot)
    ]


def _expand_archive(sid, entry):
    """The files of one `archives` entry of a study's settings (see workflow/schemas/study.schema.yaml)."""
    if isinstance(entry, str):
        entry = {"path": entry}
    path = entry["path"]
    if "robots" in entry:
        return [path.format(robot=r) for r in entry["robots"]]
    default = list(study_doc(sid).get("solvers", {}))
    jobs = [
        (p, r, s)
        for p, r, s in kept_jobs(sid)
        if p in entry.get("problem_sets", [p])
        and (entry.get("reading") != "default" or s in default)
    ]
    return list(
        dict.fromkeys(path.format(pset=p, robot=r, solver=s) for p, r, s in jobs)
    )


# --- input functions ---------------------------------------------------------------------------------


def data_dir(wildcards):
    """The data folder, for the verbs that read more of it than their inputs name (a function: the
    folder is no file of the job's own)."""
    return DATA


def study_file(wildcards):
    return f"{DATA}/studies/{wildcards.study}.yaml"


def solve_archives(sid):
    """One archive per solve job of the study at this run's scale."""
    return [f"{RESULTS}/{sid}/runs/{p}/{r}__{s}.mcap" for p, r, s in kept_jobs(sid)]


def archives(sid):
    """Every archive a study's tables and figures are computed from: one per solve job, then those its
    settings list under `archives` (made by the study's own rules, workflow/rules/studies/).
    """
    extra = [
        f
        for entry in study_doc(sid).get("archives", [])
        for f in _expand_archive(sid, entry)
    ]
    return solve_archives(sid) + [f"{RESULTS}/{sid}/{f}" for f in extra]


def study_archives(wildcards):
    return archives(wildcards.study)


def problem_set_files(wildcards):
    """Data files a problem set's generator reads (`files:` of the set), as rule inputs."""
    spec = study_doc(wildcards.study)["problem_sets"][wildcards.pset]
    return [f"{DATA}/{f}" for f in spec.get("files", [])]


def study_targets(sid):
    """A study's tables and figures, and the stamp of its prose check (rule check_prose)."""
    return [
        f"{RESULTS}/{sid}/tables",
        f"{RESULTS}/{sid}/figures",
        f"{RESULTS}/{sid}/.prose_checked",
    ]


def study_inputs(wildcards):
    """One study's tables and figures, and every archive they read (`snakemake results/<id>/.built`)."""
    return study_targets(wildcards.study) + archives(wildcards.study)


def all_targets():
    """The report, every study's tables and figures, and every archive. Intermediates are listed as
    targets on purpose: since Snakemake 7.7 a deleted intermediate file is not rebuilt while its
    consumers are present, and deleting an archive, a tables or a figures folder must rebuild it and
    exactly what depends on it."""
    return (
        [f"{RESULTS}/report.html"]
        + [t for sid in STUDIES for t in study_targets(sid)]
        + [a for sid in STUDIES for a in archives(sid)]
    )


def race_archives(wildcards):
    """An arm's solve archives (every problem set and label): the race's finalists come from them."""
    return [
        f"{RESULTS}/{wildcards.study}/runs/{p}/{r}__{s}.mcap"
        for p, r, s in kept_jobs(wildcards.study)
        if r == wildcards.robot
    ]


# --- erthal1992 (workflow/rules/studies/erthal1992.smk) ----------------------------------------------


def erthal_catalogue_block():
    """The settings the catalogue job reads (a change re-runs it)."""
    keys = (
        "zero_positions",
        "joint_point_inputs",
        "jog",
        "roundtrip_seed",
        "roundtrip_samples",
        "workspace",
    )
    return {k: study_settings("erthal1992").get(k) for k in keys}


def erthal_path_archive(wildcards):
    """The solve archive a path task's RES rows are written from (the path's `solver`)."""
    solver = study_settings("erthal1992")["paths"][wildcards.pset]["solver"]
    return (
        f"{RESULTS}/erthal1992/runs/{wildcards.pset}/{wildcards.robot}__{solver}.mcap"
    )


# --- mariano2019 (workflow/rules/studies/mariano2019.smk) --------------------------------------------


def mariano_arm():
    return study_settings("mariano2019").get("arm", "mariano_4dof")


def mariano_block(block):
    """A settings block of mariano2019 at this run's scale ({full, quick} pairs resolved)."""
    return {
        k: (v[SCALE] if isinstance(v, dict) and set(v) == {"full", "quick"} else v)
        for k, v in study_settings("mariano2019")[block].items()
    }
