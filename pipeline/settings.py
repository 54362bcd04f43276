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
from pipeline.solvers import SolverSettings

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
class Study:
    """A validated study: its settings document and resolved solver settings."""

    id: str
    path: Path
    doc: dict
    solvers: dict[str, SolverSettings]
    readings: dict[str, str] = None  # solver name -> reading label (see `readings` in the schema)

    def default_solvers(self) -> list[str]:
        """Solvers of the default reading (the study's main tables)."""
        return list(self.doc.get("solvers", {}))

    @property
    def generic(self) -> bool:
        """True when the study uses the generic problem/solve rules (random problems + Jacobian solvers)."""
        return "problems" in self.doc

    @property
    def settings(self) -> dict:
        """The study-specific settings block (``study_settings``), empty when absent."""
        return self.doc.get("study_settings", {})

    def count(self, scale: str) -> int:
        return int(self.doc["problems"]["count"][scale])

    def solver_hash(self, solver: str, scale: str) -> str:
        """Hash of everything that determines one solve job's archive (timings aside)."""
        blob = {"problems": self.doc["problems"], "scale": scale, "count": self.count(scale),
                "solver": self.solvers[solver].as_dict()}
        return hashlib.sha256(json.dumps(blob, sort_keys=True).encode()).hexdigest()[:16]


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
    if ("problems" in doc) != ("solvers" in doc):
        raise ConfigError(f"{path}: field 'problems'/'solvers': a generic study needs both (or neither)")
    solvers = {name: SolverSettings.from_dict(s, f"{path}: solvers/{name}") for name, s in doc.get("solvers", {}).items()}
    readings = {name: doc.get("readings", {}).get("default", "default") for name in solvers}
    for variant, overrides in doc.get("readings", {}).get("variants", {}).items():
        for name, base in doc["solvers"].items():
            solvers[f"{name}_{variant}"] = SolverSettings.from_dict({**base, **overrides},
                                                                    f"{path}: readings/variants/{variant}")
            readings[f"{name}_{variant}"] = variant
    return Study(doc["study"], path, doc, solvers, readings)


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
        for robot in st.doc["robots"]:
            load_robot(data / "robots" / f"{robot}.yaml")
        studies.append(st)
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
