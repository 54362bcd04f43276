"""Settings every IK method shares: the ``setting`` field, the ``Settings`` base, the limits on values."""

from __future__ import annotations

from pathlib import Path

import math
from dataclasses import MISSING, asdict, dataclass, field, fields, replace

from pipeline.robots import LENGTH_UNITS
from pipeline.solvers.kernels.kin import CRITERIA, SEARCH_LIMITS


class SettingsError(ValueError):
    """A solver setting is missing, unknown or out of range (message names the field)."""


# ---- caps on settings: no solve runs unbounded, no setting reads outside the data folder -------------
MAX_TIME_BUDGET_S = 60.0  # ``time_budget`` of all restarts of one call: 3000x TRAC-IK's 20 ms budget; a solve job
#                           of 10 000 goals then still ends (every iterative search is also capped by MAX_WORK)
MAX_LIBRARY_TIMEOUT_S = 1.0  # a peer library's own wall-time budget per solve (TRAC-IK ``timeout``): 200x its 5 ms
#                              default (1e9 s made one solve hang)
MAX_WORK = 10_000_000  # iterations of one call, all searches together: (restarts + 1) x the product of the work
#                        settings (WORK_FIELDS) present; the per-field iteration cap, so restarts cannot multiply it
WORK_FIELDS = ("max_iterations", "ilimit", "slimit", "particles")
MAX_SETTING_FLOAT = 1e9  # |value| of a float setting without a maximum of its own (tolerances, gains, weights,
#                          steps): far beyond any meaningful value in SI units, and far from overflow
PROJECT_ROOT = Path(__file__).resolve().parents[3]  # file-valued settings are paths from here ...
DATA_FOLDER = PROJECT_ROOT / "data"  # ... and must resolve inside this folder (no '..', no absolute path)


def check_data_path(value: str, where: str) -> Path:
    """The file a file-valued setting names: relative to the project root, resolving (symbolic links
    followed) inside :data:`DATA_FOLDER`, an existing regular file; else one line naming the field.

    Raises
    ------
    SettingsError
    """
    rel = Path(value)
    inside = "a path from the project root inside its data folder, e.g. data/robots/<name>.yaml"
    if rel.is_absolute() or ".." in rel.parts or "\\" in value or "\x00" in value:
        raise SettingsError(f"{where}: {value[:80]!r} is not {inside}")
    path = (PROJECT_ROOT / rel).resolve()
    if not path.is_relative_to(DATA_FOLDER.resolve()):
        raise SettingsError(f"{where}: {value[:80]!r} resolves outside the data folder {DATA_FOLDER}")
    if not path.is_file():
        raise SettingsError(f"{where}: {value[:80]!r}: no such regular file in the data folder")
    return path


class NotApplicableError(ValueError):
    """A solver does not apply to a robot (one line: the robot file, the solver, why)."""


POSITION_CRITERIA = ("position", "dq_norm_body")  # success tests that ignore the goal orientation


def setting(default, doc: str, *, unit: str = "", choices=None, minimum=None, above=None, maximum=None,
            length: bool = False, file: bool = False, quiet: bool = False, joints: bool = False):
    """A settings field with its documentation and checks (read by ``from_dict`` and ``json_schema``).

    Parameters
    ----------
    unit : str
        Unit shown in ``python -m pipeline solvers`` (e.g. ``m``, ``rad``).
    choices : sequence, optional
        Allowed values.
    minimum, above, maximum : float, optional
        Inclusive lower bound, exclusive lower bound, inclusive upper bound.
    length : bool
        The value is a length written in metres and converted to ``length_unit`` once per job.
    file : bool
        The value names a file (``''`` = none): a path from the project root that must resolve inside
        its data folder (:func:`check_data_path`).
    quiet : bool
        :meth:`Settings.as_dict` leaves the field out while it holds its default: a setting added after
        archives were written, whose settings records and job hashes then stay as they were.
    joints : bool
        The value maps joint numbers (1-based) to joint values, ``{4: 0.5}``: written as a mapping (keys
        integers or digit strings), kept as a sorted tuple of ``(joint, value)`` pairs (so that settings
        stay hashable), written back as a mapping with string keys (:func:`joint_map`).
    """
    meta = {"doc": doc, "unit": unit, "choices": tuple(choices) if choices is not None else None,
            "minimum": minimum, "above": above, "maximum": maximum, "length": length, "file": file,
            "quiet": quiet, "joints": joints}
    return field(default=default, metadata=meta)


def search_limits_setting():
    """The ``search_limits`` field of the Jacobian-family methods (issue 43): joint limits inside the search."""
    return setting("off", "joint limits inside the search: off (iterates unconstrained, the documents' methods; "
                   "the result is wrapped into the limits afterwards), clamp (every iterate, the start included, "
                   "clamped into the limits), reflect (the start clamped; a joint a step takes past a limit is "
                   "mirrored at it, then clamped: the search leaves the limit instead of stalling on it; "
                   "Levenberg-Marquardt takes a mirrored step even when it does not lower the error)",
                   choices=SEARCH_LIMITS, quiet=True)


_PY_TYPES = {"int": int, "float": float, "bool": bool, "str": str}


@dataclass(frozen=True)
class Settings:
    """Settings every method has: working unit and the success test its FK check applies.

    Subclasses add their own fields with :func:`setting` and may override :meth:`check` for
    cross-field rules. Everything is validated by :meth:`from_dict`; errors are one line naming
    the field.
    """

    length_unit: str = setting("m", "unit the method computes in (robot and goal converted once); "
                               "length settings are still written in m", choices=tuple(LENGTH_UNITS))
    criterion: str = setting("pos_orient", "success test of the FK check: pos_orient (|dp| <= tol_pos and "
                             "angle <= tol_rot), position (|dp| only), dq_norm (8-coefficient norm of "
                             "Q_goal Q* <= tol_dq), dq_norm_body (norm of Q* Q_goal: position only)",
                             choices=CRITERIA)
    tol_pos: float = setting(1e-4, "position tolerance", unit="m", minimum=0.0, length=True)
    tol_rot: float = setting(1e-3, "orientation tolerance (rotation angle)", unit="rad", minimum=0.0)
    tol_dq: float = setting(1 + 1e-6, "dual-quaternion norm tolerance (1 + epsilon; dq_norm criteria only)",
                            minimum=1.0)
    require_limits: bool = setting(False, "a success must also lie within the robot file's joint limits "
                                   "(revolute joints wrapped by 2 pi first, and returned wrapped; an analytic "
                                   "method returns the solution that moves the joints least from the start, "
                                   "each by whole turns to its value within the limits nearest the start)")
    restarts: int = setting(0, "random restarts after a failed search (iterative methods): each restart starts "
                            "uniformly within the joint limits (+-pi for unbounded revolute joints) and the "
                            "first success ends the call; iterations and solve time add up over the searches",
                            minimum=0, maximum=100000)
    time_budget: float = setting(0.0, "wall-time budget of all restarts together, 0 = none (the search under way "
                                 "is finished; a budget makes results depend on the machine's speed)",
                                 unit="s", minimum=0.0, maximum=MAX_TIME_BUDGET_S)

    def __post_init__(self) -> None:
        for f in fields(self):  # a joint map given as a mapping (direct construction): kept as sorted pairs
            if f.metadata.get("joints") and not isinstance(getattr(self, f.name), tuple):
                object.__setattr__(self, f.name, joint_map(getattr(self, f.name), f.name, "solver settings"))

    # ---- construction and validation -------------------------------------------------------
    @classmethod
    def from_dict(cls, d: dict | None, where: str = "solver settings") -> "Settings":
        """Build from a mapping, naming the bad field in a one-line :class:`SettingsError`."""
        d = dict(d or {})
        known = {f.name: f for f in fields(cls)}
        for k in d:
            if k not in known:
                raise SettingsError(f"{where}: field '{k}': unknown setting (allowed: {', '.join(known)})")
        for k, v in d.items():
            d[k] = _coerce(known[k], v, where)
        out = cls(**d)
        out.validate(where)
        return out

    def validate(self, where: str = "solver settings") -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            _coerce(f, v, where)
            m = f.metadata
            if m.get("choices") is not None and v not in m["choices"]:
                raise SettingsError(f"{where}: field '{f.name}': {v!r} is not one of {list(m['choices'])}")
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                if not math.isfinite(v):
                    raise SettingsError(f"{where}: field '{f.name}': must be finite, got {v!r}")
                if m.get("minimum") is not None and v < m["minimum"]:
                    raise SettingsError(f"{where}: field '{f.name}': must be >= {m['minimum']}, got {v!r}")
                if m.get("above") is not None and v <= m["above"]:
                    raise SettingsError(f"{where}: field '{f.name}': must be > {m['above']}, got {v!r}")
                if m.get("maximum") is not None and v > m["maximum"]:
                    raise SettingsError(f"{where}: field '{f.name}': must be <= {m['maximum']}, got {v!r}")
                if isinstance(v, float) and m.get("maximum") is None and abs(v) > MAX_SETTING_FLOAT:
                    raise SettingsError(f"{where}: field '{f.name}': {v!r} is beyond the sane maximum "
                                        f"{MAX_SETTING_FLOAT:g} in absolute value (MAX_SETTING_FLOAT)")
            if m.get("file") and v:
                check_data_path(v, f"{where}: field '{f.name}'")
        work = self.restarts + 1
        for name in WORK_FIELDS:
            work *= getattr(self, name, 1)
        if work > MAX_WORK:
            used = " x ".join(f"{n} {getattr(self, n)}" for n in WORK_FIELDS if hasattr(self, n))
            raise SettingsError(f"{where}: field 'restarts': (restarts {self.restarts} + 1) x {used} is beyond the "
                                f"sane maximum of {MAX_WORK} iterations per call (MAX_WORK)")
        self.check(where)

    def check(self, where: str) -> None:
        """Cross-field rules of a method (override; raise :class:`SettingsError`)."""

    def check_robot(self, n_joints: int, where: str) -> None:
        """Rules that need the robot (a list of one value per joint, say): override; raise
        :class:`SettingsError`. ``check_inputs`` calls it for every (robot, solver) job of a study. Here: a
        joint map's joint numbers exist on the arm and leave at least one joint free."""
        for f in fields(self):
            if f.metadata.get("joints"):
                check_joint_numbers(getattr(self, f.name), n_joints, f"{where}: field '{f.name}'")

    def as_dict(self) -> dict:
        """Every field's value (a joint map as a mapping with string keys), but a ``quiet`` field
        (:func:`setting`) only when it is not its default."""
        out = asdict(self)
        for f in fields(self):
            if f.metadata.get("quiet") and out[f.name] == f.default:
                del out[f.name]
            elif f.metadata.get("joints"):
                out[f.name] = {str(k): v for k, v in getattr(self, f.name)}
        return out

    def converted(self) -> "Settings":
        """A copy whose length-valued fields are in ``length_unit`` instead of metres."""
        f = 1.0 / LENGTH_UNITS[self.length_unit]
        if f == 1.0:
            return self
        return replace(self, **{x.name: getattr(self, x.name) * f for x in fields(self) if x.metadata.get("length")})

    @classmethod
    def describe(cls) -> list[dict]:
        """One row per field: name, type, default, unit, allowed values / range, documentation."""
        rows = []
        for f in fields(cls):
            m = f.metadata
            rng = []
            if m.get("choices") is not None:
                rng.append("one of " + ", ".join(map(str, m["choices"])))
            for key, sym in (("minimum", ">="), ("above", ">"), ("maximum", "<=")):
                if m.get(key) is not None:
                    rng.append(f"{sym} {m[key]}")
            if m.get("joints"):
                rng.append("joint numbers 1..n (1-based) -> joint values")
            rows.append({"name": f.name, "type": "mapping" if m.get("joints") else f.type,
                         "default": ({} if m.get("joints") else f.default) if f.default is not MISSING else None,
                         "unit": m.get("unit", ""), "range": "; ".join(rng), "doc": m.get("doc", "")})
        return rows

    @classmethod
    def json_schema(cls) -> dict:
        """JSON schema of the settings mapping (every field optional; defaults given)."""
        kinds = {"int": "integer", "float": "number", "bool": "boolean", "str": "string"}
        props = {}
        for f in fields(cls):
            m = f.metadata
            p = {"type": kinds.get(f.type, "string"), "default": f.default, "description": m.get("doc", "")}
            if m.get("choices") is not None:
                p["enum"] = list(m["choices"])
            if m.get("minimum") is not None:
                p["minimum"] = m["minimum"]
            if m.get("above") is not None:
                p["exclusiveMinimum"] = m["above"]
            if m.get("maximum") is not None:
                p["maximum"] = m["maximum"]
            if m.get("joints"):
                p = {"type": "object", "default": {}, "description": m.get("doc", ""), "additionalProperties": False,
                     "patternProperties": {"^[1-9][0-9]*$": {"type": "number"}}}
            props[f.name] = p
        return {"type": "object", "additionalProperties": False, "properties": props}


def joint_map(v, name: str, where: str) -> tuple:
    """A joint-map setting (``setting(..., joints=True)``) as sorted ``(joint, value)`` pairs: joint numbers
    1-based integers (or digit strings, as JSON writes keys), each once; values finite numbers
    [rad | the robot file's length unit]. A mapping or a sequence of pairs is accepted.

    Raises
    ------
    SettingsError
        One line naming the field.
    """
    head = f"{where}: field '{name}'"
    if isinstance(v, dict):
        items = list(v.items())
    elif isinstance(v, (tuple, list)) and all(isinstance(x, (tuple, list)) and len(x) == 2 for x in v):
        items = [tuple(x) for x in v]
    else:
        raise SettingsError(f"{head}: expected a mapping of joint numbers (1-based) to values, e.g. {{4: 0.5}}, "
                            f"got {str(v)[:60]!r}")
    out = {}
    for k, x in items:
        if isinstance(k, str) and k.strip().isdigit():
            k = int(k)
        if isinstance(k, bool) or not isinstance(k, int) or k < 1:
            raise SettingsError(f"{head}: joint {str(k)[:20]!r} is not a joint number (1-based: 1 is the first joint)")
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x) \
                or abs(x) > MAX_SETTING_FLOAT:
            raise SettingsError(f"{head}: joint {k}: the value must be a finite number [rad | length], got "
                                f"{str(x)[:30]!r}")
        if k in out:
            raise SettingsError(f"{head}: joint {k} is given twice")
        out[k] = float(x)
    return tuple(sorted(out.items()))


def check_joint_numbers(pairs: tuple, n_joints: int, where: str) -> None:
    """A joint map's (:func:`joint_map`) joints exist on an arm of ``n_joints`` and leave one free, else one line."""
    for k, _ in pairs:
        if k > n_joints:
            raise SettingsError(f"{where}: joint {k} does not exist (the arm has {n_joints} joints, numbered 1 to "
                                f"{n_joints})")
    if pairs and len(pairs) >= n_joints:
        raise SettingsError(f"{where}: every joint is held (at least one must move)")


def _coerce(f, v, where: str):
    """Type check of one field value (ints accepted where floats are expected; a joint map normalised)."""
    if f.metadata.get("joints"):
        return joint_map(v, f.name, where)
    want = _PY_TYPES.get(f.type)
    if want is None:
        return v
    if want is float and isinstance(v, int) and not isinstance(v, bool):
        return float(v)
    if want in (int, float) and isinstance(v, bool) or not isinstance(v, want):
        raise SettingsError(f"{where}: field '{f.name}': expected {f.type}, got {v!r}")
    return v


# ---- the robot, prepared once per job ---------------------------------------------------------
