"""Run configuration and study settings: loading, JSON-schema validation, hashing.

Every validation error is one line naming the file and the field path.
"""

from __future__ import annotations

import hashlib
import json
import subprocess
from dataclasses import dataclass
from pathlib import Path

import jsonschema
import yaml

from pipeline.robots import load_robot
from pipeline.solvers import Settings

ROOT = Path(__file__).resolve().parent.parent
SCHEMAS = ROOT / "workflow" / "schemas"


class ConfigError(ValueError):
    """Invalid configuration or study settings (one line: file, field, problem)."""


def _schema(name: str) -> dict:
    return yaml.safe_load((SCHEMAS / name).read_text())


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
        return yaml.safe_load(Path(path).read_text())
    except OSError as exc:
        noun = f" {what}" if what else ""
        raise error(f"{path}: cannot read{noun} ({exc.strerror})") from None
    except yaml.YAMLError as exc:
        raise error(f"{path}: not valid YAML ({getattr(exc, 'problem', exc)})") from None


def validate_against(doc, schema: dict, path: str) -> None:
    """Validate with defaults filled in; raise ConfigError naming the field path."""
    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(doc), key=lambda e: list(e.absolute_path))
    if errors:
        err = errors[0]
        where = "/".join(str(p) for p in err.absolute_path) or "(top level)"
        raise ConfigError(f"{path}: field '{where}': {err.message}")
    _fill_defaults(doc, schema)


def _fill_defaults(doc, schema: dict) -> None:
    if not isinstance(doc, dict):
        return
    for key, sub in schema.get("properties", {}).items():
        if key not in doc and "default" in sub:
            doc[key] = sub["default"]
        if key in doc:
            _fill_defaults(doc[key], sub)


def validate_config(config: dict, path: str = "workflow/config/config.yaml") -> dict:
    """Validate the Snakemake config in place (defaults filled)."""
    validate_against(config, _schema("config.schema.yaml"), path)
    return config


@dataclass(frozen=True)
class SolverEntry:
    """One solver label of a study: a registered method with its validated settings."""

    label: str
    method: str
    settings: Settings
    reading: str = "default"

    def as_dict(self) -> dict:
        """``{"method": ..., **settings}`` (what the archive and the rule parameters record)."""
        return {"method": self.method, **self.settings.as_dict()}


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
    return SolverEntry(label, method, make_settings(method, d, where), reading)


def load_study(path: str | Path) -> Study:
    """Read and validate ``data/studies/<id>.yaml`` (schema, then every solver's settings)."""
    path = Path(path)
    doc = read_yaml(path)
    validate_against(doc, _schema("study.schema.yaml"), str(path))
    if doc["study"] != path.stem:
        raise ConfigError(f"{path}: field 'study': {doc['study']!r} must equal the file name {path.stem!r}")
    own = SCHEMAS / "studies" / f"{doc['study']}.schema.yaml"
    if own.is_file():
        validate_against(doc.get("study_settings", {}), yaml.safe_load(own.read_text()), f"{path}: study_settings")
    if bool(doc.get("problem_sets")) != bool(doc.get("solvers")):
        raise ConfigError(f"{path}: field 'problem_sets'/'solvers': a study with solve jobs needs both (or neither)")
    default = doc.get("readings", {}).get("default", "default")
    solvers = {name: _solver_entry(name, s, f"{path}: solvers/{name}", default)
               for name, s in (doc.get("solvers") or {}).items()}
    for variant, overrides in doc.get("readings", {}).get("variants", {}).items():
        for name, base in doc["solvers"].items():
            label = f"{name}_{variant}"
            if label in solvers:
                raise ConfigError(f"{path}: field 'readings/variants/{variant}': label {label!r} clashes with a solver")
            solvers[label] = _solver_entry(label, {**base, **overrides}, f"{path}: readings/variants/{variant}", variant)
    for pset, spec in (doc.get("problem_sets") or {}).items():
        where = f"{path}: problem_sets/{pset}"
        if (spec["kind"] == "generator") != ("generator" in spec):
            raise ConfigError(f"{where}: field 'generator': required exactly when kind is 'generator'")
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

    refused = refusals(study, models)
    if refused and not study.skip_inapplicable:
        (pset, robot, label), why = next(iter(refused.items()))
        raise ConfigError(f"{study.path}: problem_sets/{pset}: solver '{label}' on robot '{robot}': "
                          f"{models[robot].path}: solver '{study.solvers[label].method}' does not apply: {why}")
    return replace(study, refused=refused)


def check_inputs(config: dict, root: Path = Path(".")) -> list[Study]:
    """Validate config, every study's settings and every robot file they name, before any job runs."""
    validate_config(config)
    data = root / config["data_dir"]
    studies = []
    for sid in config["studies"]:
        spath = data / "studies" / f"{sid}.yaml"
        if not spath.is_file():
            raise ConfigError(f"{spath}: no settings file for study '{sid}' (config field 'studies')")
        st = load_study(spath)
        robots = set(st.doc["robots"]) | {r for ps in st.problem_sets for r in st.set_robots(ps)}
        models = {robot: load_robot(data / "robots" / f"{robot}.yaml") for robot in sorted(robots)}
        studies.append(_check_applicable(st, models))
    return studies


def git_commit(root: Path = ROOT) -> str:
    """The checkout's commit (``+dirty`` when tracked files differ), or ``unknown``."""
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True,
                              timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return (head + ("+dirty" if dirty else "")) if head else "unknown"


def file_sha256(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()
