"""The workflow's config validation, in a process of its own: the Snakefile's one call into the library.

    python workflow/scripts/check_inputs.py CONFIG_FILE... < merged config (a Python literal)

Validates every config file the run reads (each error names its file), the merged config, every study's
settings and every robot file they name (:func:`pipeline.settings.check_config_files`, then
:func:`pipeline.settings.check_inputs`: the solver registry, so numba), and prints on stdout, as one
Python literal, what the rules need from them:

    {"config": the validated config (defaults filled),
     "studies": {id: {"doc": the validated settings document,
                      "solvers": {label: {"method": ..., **settings}},
                      "jobs": [(problem set, robot, label), ...]  # refused pairs left out
                      "count": {problem set: problems at the run's scale},
                      "repetitions": {problem set: repetitions at the run's scale},
                      "caps": {problem set: {label: problems it solves, or None for all}}}}}

A literal rather than JSON: study documents hold integer mapping keys, and the rules' parameters must
equal (as ``repr``) what the library computes. An input error is one line on stderr and exit status 2;
anything else is a traceback and status 1. Running here, not in the Snakemake process, keeps the
solvers (numba, SciPy) out of the process that parses the workflow.
"""

from __future__ import annotations

import ast
import os
import sys


def plan(config: dict, config_files: list[str]) -> dict:
    """Validate and describe the run (see the module docstring)."""
    from pipeline.settings import ConfigError, check_config_files, check_inputs

    check_config_files(config_files, config)
    scale = config["scale"]
    studies = {}
    for st in check_inputs(config):
        sets = st.problem_sets
        studies[st.id] = {
            "doc": st.doc,
            "solvers": {label: entry.as_dict() for label, entry in st.solvers.items()},
            "jobs": st.jobs(),
            "count": {p: st.count(p, scale) for p in sets},
            "repetitions": {p: st.repetitions(p, scale) for p in sets},
            "caps": {p: {label: st.solver_cap(p, label, scale) for label in st.set_solvers(p)} for p in sets},
        }
        if st.doc.get("job_per_robot"):
            _same_labels(st.id, studies[st.id]["jobs"], config["data_dir"], ConfigError)
    return {"config": config, "studies": studies}


def _same_labels(sid: str, jobs: list, data: str, error) -> None:
    """A `job_per_robot` study runs the same solvers on every problem set of a robot (one job writes
    them all, under one list of labels)."""
    labels: dict = {}
    for pset, robot, label in jobs:
        labels.setdefault(robot, {}).setdefault(pset, []).append(label)
    for robot, by_set in labels.items():
        if len({tuple(v) for v in by_set.values()}) > 1:
            raise error(f"{data}/studies/{sid}.yaml: job_per_robot: needs the same solvers on every problem set of "
                        f"{robot} (they differ: {', '.join(sorted(by_set))})")


def main(argv: list[str]) -> int:
    sys.path.insert(0, os.getcwd())  # the package the rules' `python -m pipeline` runs: the working folder's
    from pipeline.robots import RobotFileError
    from pipeline.settings import ConfigError
    from pipeline.solvers import SettingsError

    config = ast.literal_eval(sys.stdin.read())
    try:
        out = plan(config, argv)
    except (ConfigError, RobotFileError, SettingsError) as exc:
        print(exc, file=sys.stderr)
        return 2
    print(repr(out))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
