"""Run configuration and study settings: loading, JSON-schema validation, hashing.

Every validation error is one line naming the file and the field path. Every YAML file goes
through :func:`pipeline.yamlio.load_yaml` (bounded size, nesting and alias expansion; no tags,
duplicate keys or YAML 1.1 surprises). Beyond the schemas, a study may hold no infinite or NaN
number and no integer above :data:`MAX_INT` (seeds aside), at most :data:`MAX_SOLVES` solves per
job (problems x repetitions), and its built-in problem sets' parameters are checked by
:func:`pipeline.problems.check_spec` (finite, ``low <= high``, within sane maxima).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

import math

import jsonschema

from pipeline.names import PATH_RULE
from pipeline.provenance import file_sha256, git_commit  # noqa: F401  (re-exported)
from pipeline.robots import load_robot
from pipeline.solvers import Settings
from pipeline.yamlio import YAMLInputError, load_yaml

ROOT = Path(__file__).resolve().parent.parent
SCHEMAS = ROOT / "workflow" / "schemas"
DEFAULT_CONFIG = "workflow/config/config.yaml"
MAX_EXACT_INT = 2**53  # any integer of a study or config (seeds aside): beyond it a float no longer holds it
MAX_INT = 10_000_000  # an integer solver setting without a maximum of its own in the registry (grow limits,
#                       stored corrections, searches...): the registry's cap on iteration counts; above it a
#                       job runs for days or asks for more than 1 GiB (1e12 made numpy ask for tens of TiB)
MAX_SOLVES = 1_000_000  # problems x repetitions of one solve job: 100x the largest document's 10 000 problems


class ConfigError(ValueError):
    """Invalid configuration or study settings (one line: file, field, problem)."""


def _schema(name: str) -> dict:
    return load_yaml(SCHEMAS / name, "schema")


def read_yaml(path, error: type[Exception] = ConfigError, what: str = ""):
    """Parse a YAML file, turning an unreadable file or bad YAML into one line that names the file.

    Parameters
    ----------
    path : str or Path
        The file.
    error : exception class
        Raised with the one-line message (each file kind has its own).
    what : str
        Noun for the message, e.g. ``"task file"``: "cannot read task file (...)".
    """
    try:
        return load_yaml(path, what or "file")
    except YAMLInputError as exc:
        raise error(str(exc)) from None


def check_numbers(doc, path: str, exempt: tuple = ("seed",)) -> None:
    """Refuse (one line naming the field) a non-finite number, an integer beyond :data:`MAX_EXACT_INT` or a
    string holding a NUL character anywhere in a parsed document; keys in ``exempt`` may hold any integer
    (the schema bounds them)."""
    todo = [((), doc)]
    seen = set()
    while todo:
        where, x = todo.pop()
        if isinstance(x, (dict, list)):
            if id(x) in seen and where:  # an alias: already checked where it was defined
                continue
            seen.add(id(x))
            items = x.items() if isinstance(x, dict) else enumerate(x)
            todo.extend(((*where, k), v) for k, v in items)
            continue
        field = "/".join(str(p) for p in where) or "(top level)"
        if isinstance(x, str) and "\x00" in x:  # no file name, id or text of this project holds one
            raise ConfigError(f"{path}: field '{field}': contains a NUL character")
        if isinstance(x, float) and not math.isfinite(x):
            raise ConfigError(f"{path}: field '{field}': must be finite, got {x!r}")
        if isinstance(x, int) and not isinstance(x, bool) and abs(x) > MAX_EXACT_INT \
                and not (where and where[-1] in exempt):
            raise ConfigError(f"{path}: field '{field}': {str(x)[:30]} is beyond the sane maximum 2**53 (the "
                              f"largest integer a float holds exactly)")


def _raise_first_error(doc, schema: dict, path: str) -> None:
    """Raise ConfigError naming the field path of the first schema violation (if any)."""
    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(doc), key=lambda e: list(e.absolute_path))
    if errors:
        err = errors[0]
        where = "/".join(str(p) for p in err.absolute_path) or "(top level)"
        message = err.message
        if err.validator == "pattern" and where in ("data_dir", "results_dir"):  # the rules' shell commands get it
            message = f"{err.instance!r}: not allowed in a path the workflow passes to Snakemake (use {PATH_RULE})"
        raise ConfigError(f"{path}: field '{where}': {message}")


def validate_against(doc, schema: dict, path: str) -> None:
    """Validate with defaults filled in; raise ConfigError naming the field path."""
    _raise_first_error(doc, schema, path)
    _fill_defaults(doc, schema)


def _fill_defaults(doc, schema: dict) -> None:
    if not isinstance(doc, dict):
        return
    for key, sub in schema.get("properties", {}).items():
        if key not in doc and "default" in sub:
            doc[key] = sub["default"]
        if key in doc:
            _fill_defaults(doc[key], sub)


def validate_config(config: dict, path: str = DEFAULT_CONFIG) -> dict:
    """Validate the Snakemake config in place (defaults filled)."""
    check_numbers(config, path)
    validate_against(config, _schema("config.schema.yaml"), path)
    return config


def validate_config_part(doc, path: str) -> dict:
    """Validate one source of the run config (a config file, or one ``--set``/``--config`` value):
    every key it holds must be valid; keys it leaves out come from the others."""
    if doc is None:
        doc = {}
    if not isinstance(doc, dict):
        raise ConfigError(f"{path}: field '(top level)': expected a mapping of config keys, got {type(doc).__name__}")
    check_numbers(doc, path)
    schema = dict(_schema("config.schema.yaml"))
    schema.pop("required", None)
    _raise_first_error(doc, schema, path)
    return doc


def load_config_file(path: str | Path) -> dict:
    """Read and validate one run-config file (errors name it); returns its mapping."""
    return validate_config_part(read_yaml(path, ConfigError, "config file"), str(path))


def check_config_files(paths, config: dict, overrides: str = "--config") -> dict:
    """Validate every config file the run reads (each error names its file), then the merged config.

    For the Snakefile: ``paths`` are the workflow's config file and every ``--configfile``; the
    merged ``config`` differs from them only by ``--config KEY=VALUE`` values, so an error left
    after the files passed is reported against ``overrides``.
    """
    for p in paths:
        load_config_file(p)
    label = f"{overrides} (on top of {', '.join(str(p) for p in paths) or 'no config file'})"
    return validate_config(config, label)


@dataclass(frozen=True)
class SolverEntry:
    """One solver label of a study: a registered method with its validated settings."""

    label: str
    method: str
    settings: Settings
    reading: str = "default"

    def as_dict(self) -> dict:
        """``{"method": ..., **settings}`` (what the archive and the rule parameters record)."""
        return {**self.settings.as_dict(), "method": self.method}  # the registered name, never a setting


@dataclass(frozen=True)
class Study:
    """A validated study: its settings document, solver labels and problem sets."""

    id: str
    path: Path
    doc: dict
    solvers: dict[str, SolverEntry]
    readings: dict[str, str] = None  # solver label -> reading label (see `readings` in the schema)
    refused: dict = None  # (problem set, robot, label) -> why the solver does not apply (skip_inapplicable)

    def default_solvers(self) -> list[str]:
        """Solver labels of the default reading (the study's main tables)."""
        return list(self.doc.get("solvers", {}))

    @property
    def problem_sets(self) -> dict[str, dict]:
        return self.doc.get("problem_sets", {}) or {}

    @property
    def generic(self) -> bool:
        """True when the study has problem sets solved by the generic solve rule."""
        return bool(self.problem_sets)

    @property
    def settings(self) -> dict:
        """The study-specific settings block (``study_settings``), empty when absent."""
        return self.doc.get("study_settings", {})

    def count(self, pset: str, scale: str) -> int:
        return int(self.problem_sets[pset]["count"][scale])

    def solver_cap(self, pset: str, label: str, scale: str) -> int | None:
        """At most this many problems (the first N of the file) for solver ``label`` (``solver_counts``),
        None when the label solves every problem of the set."""
        cap = (self.problem_sets[pset].get("solver_counts") or {}).get(label)
        return int(cap[scale]) if cap else None

    @property
    def skip_inapplicable(self) -> bool:
        return bool(self.doc.get("skip_inapplicable", False))

    @property
    def job_per_robot(self) -> bool:
        return bool(self.doc.get("job_per_robot", False))

    def repetitions(self, pset: str, scale: str) -> int:
        rep = self.problem_sets[pset].get("repetitions")
        return int(rep[scale]) if rep else 1

    def timing_runs(self, pset: str, scale: str) -> int:
        """Runs of every solve whose fastest gives its times (``pipeline.runner``; 1 = one run)."""
        runs = self.problem_sets[pset].get("timing_runs")
        return int(runs[scale]) if runs else 1

    def set_robots(self, pset: str) -> list[str]:
        return list(self.problem_sets[pset].get("robots") or self.doc["robots"])

    def set_solvers(self, pset: str) -> list[str]:
        return list(self.problem_sets[pset].get("solvers") or self.solvers)

    def jobs(self) -> list[tuple[str, str, str]]:
        """Every (problem set, robot, solver label) solve job of the study (refused pairs left out)."""
        refused = self.refused or {}
        return [(ps, r, s) for ps in self.problem_sets for r in self.set_robots(ps) for s in self.set_solvers(ps)
                if (ps, r, s) not in refused]

    def robot_solvers(self, pset: str, robot: str) -> list[str]:
        """Solver labels that run on ``robot`` in set ``pset`` (one job under ``job_per_robot``)."""
        return [s for p, r, s in self.jobs() if p == pset and r == robot]

    def problem_hash(self, pset: str, scale: str) -> dict:
        return {"problem_set": pset, "spec": self.problem_sets[pset], "scale": scale, "count": self.count(pset, scale)}

    def solver_hash(self, pset: str, solver: str, scale: str) -> str:
        """Hash of everything that determines one solve job's archive (timings aside)."""
        blob = {**self.problem_hash(pset, scale), "repetitions": self.repetitions(pset, scale),
                "solver": self.solvers[solver].as_dict()}
        if self.timing_runs(pset, scale) > 1:
            blob["timing_runs"] = self.timing_runs(pset, scale)
        if self.solver_cap(pset, solver, scale) is not None:
            blob["solver_count"] = self.solver_cap(pset, solver, scale)
        return hashlib.sha256(json.dumps(blob, sort_keys=True).encode()).hexdigest()[:16]


def _solver_entry(label: str, mapping, where: str, reading: str) -> SolverEntry:
    from pipeline.solvers import make_settings, names

    if not isinstance(mapping, dict):
        raise ConfigError(f"{where}: expected a mapping of settings, got {type(mapping).__name__}")
    d = dict(mapping)
    method = d.pop("method", None)
    if method is None:
        raise ConfigError(f"{where}: field 'method': missing (a registered solver: {', '.join(names())})")
    if method not in names():
        raise ConfigError(f"{where}: field 'method': {method!r} is not a registered solver ({', '.join(names())})")
    settings = make_settings(method, d, where)
    from dataclasses import fields

    for f in fields(settings):
        v = getattr(settings, f.name)
        if isinstance(v, int) and not isinstance(v, bool) and f.metadata.get("maximum") is None \
                and f.name != "seed" and abs(v) > MAX_INT:
            raise ConfigError(f"{where}: field '{f.name}': {v} is beyond the sane maximum {MAX_INT} (see MAX_INT in "
                              f"pipeline/settings.py)")
    return SolverEntry(label, method, settings, reading)


def load_study(path: str | Path) -> Study:
    """Read and validate ``data/studies/<id>.yaml`` (schema, then every solver's settings)."""
    path = Path(path)
    doc = read_yaml(path, ConfigError, "study settings")
    if doc is None:
        raise ConfigError(f"{path}: field '(top level)': expected a mapping of study settings, got an empty file")
    check_numbers(doc, str(path))
    validate_against(doc, _schema("study.schema.yaml"), str(path))
    if doc["study"] != path.stem:
        raise ConfigError(f"{path}: field 'study': {doc['study']!r} must equal the file name {path.stem!r}")
    own = SCHEMAS / "studies" / f"{doc['study']}.schema.yaml"
    if own.is_file():
        validate_against(doc.get("study_settings", {}), load_yaml(own, "schema"), f"{path}: study_settings")
    if bool(doc.get("problem_sets")) != bool(doc.get("solvers")):
        raise ConfigError(f"{path}: field 'problem_sets'/'solvers': a study with solve jobs needs both (or neither)")
    default = doc.get("readings", {}).get("default", "default")
    solvers = {name: _solver_entry(name, s, f"{path}: solvers/{name}", default)
               for name, s in (doc.get("solvers") or {}).items()}
    for variant, overrides in doc.get("readings", {}).get("variants", {}).items():
        overrides = dict(overrides)
        only = overrides.pop("only", None)  # the solvers the reading concerns (default: every solver)
        if only is not None:
            unknown = [o for o in only if o not in doc["solvers"]]
            if unknown:
                raise ConfigError(f"{path}: field 'readings/variants/{variant}/only': unknown solver(s) {unknown} "
                                  f"(have {sorted(doc['solvers'])})")
        for name, base in doc["solvers"].items():
            if only is not None and name not in only:
                continue
            label = f"{name}_{variant}"
            if label in solvers:
                raise ConfigError(f"{path}: field 'readings/variants/{variant}': label {label!r} clashes with a solver")
            solvers[label] = _solver_entry(label, {**base, **overrides}, f"{path}: readings/variants/{variant}", variant)
    from pipeline.problems import ProblemSpecError, check_spec

    for pset, spec in (doc.get("problem_sets") or {}).items():
        where = f"{path}: problem_sets/{pset}"
        if (spec["kind"] == "generator") != ("generator" in spec):
            raise ConfigError(f"{where}: field 'generator': required exactly when kind is 'generator'")
        try:
            check_spec(spec)
        except ProblemSpecError as exc:
            raise ConfigError(f"{where}: {exc}") from None
        for scale in ("full", "quick"):
            reps = (spec.get("repetitions") or {}).get(scale, 1)
            runs = (spec.get("timing_runs") or {}).get(scale, 1)
            if spec["count"][scale] * reps * runs > MAX_SOLVES:
                runs_text = f" x {runs} timing runs" if runs > 1 else ""
                raise ConfigError(f"{where}: field 'count/{scale}': {spec['count'][scale]} problems x {reps} "
                                  f"repetitions{runs_text} is beyond the sane maximum of {MAX_SOLVES} solves per job")
        for label in spec.get("solvers") or []:
            if label not in solvers:
                raise ConfigError(f"{where}: field 'solvers': {label!r} is not a solver label ({', '.join(solvers)})")
        for label in spec.get("solver_counts") or {}:
            if label not in solvers:
                raise ConfigError(f"{where}: field 'solver_counts': {label!r} is not a solver label ({', '.join(solvers)})")
    return Study(doc["study"], path, doc, solvers, {k: v.reading for k, v in solvers.items()})


def refusals(study: Study, models: dict) -> dict:
    """(problem set, robot, solver label) -> why the solver does not apply, for every job that does not fit."""
    from pipeline.solvers import NotApplicableError, Prepared, prepare

    out, preps = {}, {}
    for pset, robot, label in study.jobs():
        entry = study.solvers[label]
        unit = entry.settings.length_unit  # one Prepared per robot and unit: applicability is memoised
        prep = preps.get((robot, unit)) or preps.setdefault((robot, unit), Prepared(models[robot], unit))
        try:
            prepare(entry.method, prep, entry.settings)
        except NotApplicableError as exc:
            out[(pset, robot, label)] = str(exc).split(" does not apply: ", 1)[-1]
    return out


def _check_applicable(study: Study, models: dict) -> Study:
    """Every (problem set, robot, solver) job must fit: a solver that does not apply is one line,
    unless the study skips such jobs (``skip_inapplicable``): then they are recorded in ``refused``."""
    from dataclasses import replace

    for pset, robot, label in study.jobs():
        study.solvers[label].settings.check_robot(models[robot].n,
                                                  f"{study.path}: solvers/{label} on robot '{robot}'")
    refused = refusals(study, models)
    if refused and not study.skip_inapplicable:
        (pset, robot, label), why = next(iter(refused.items()))
        raise ConfigError(f"{study.path}: problem_sets/{pset}: solver '{label}' on robot '{robot}': "
                          f"{models[robot].path}: solver '{study.solvers[label].method}' does not apply: {why}")
    return replace(study, refused=refused)


def check_inputs(config: dict, root: Path = Path("."), config_path: str = DEFAULT_CONFIG) -> list[Study]:
    """Validate config, every study's settings and every robot file they name, before any job runs.

    ``config_path`` names the config in messages (the file the user gave)."""
    validate_config(config, str(config_path))
    data = root / config["data_dir"]
    studies = []
    for sid in config["studies"]:
        spath = data / "studies" / f"{sid}.yaml"
        if not spath.is_file():
            raise ConfigError(f"{config_path}: field 'studies': no settings file {spath} for study '{sid}'")
        st = load_study(spath)
        robots = set(st.doc["robots"]) | {r for ps in st.problem_sets for r in st.set_robots(ps)}
        for robot in sorted(robots):
            if not (data / "robots" / f"{robot}.yaml").is_file():
                raise ConfigError(f"{spath}: field 'robots': no robot file {data / 'robots' / f'{robot}.yaml'} for "
                                  f"robot '{robot}'")
        models = {robot: load_robot(data / "robots" / f"{robot}.yaml") for robot in sorted(robots)}
        studies.append(_check_applicable(st, models))
    return studies


