"""What every IK method shares: stop reasons, settings, the prepared robot, the result, the FK check.

Call shape (see :mod:`pipeline.solvers.registry`)::

    solve(name, robot, T_goal, q_start, settings=None, *, seed=0) -> IKResult

A registered method supplies only its kernel call, ``run(prep, T_goal, q_start, settings, seed) ->
Raw``; :func:`finish` turns that raw output into an :class:`IKResult`: it re-checks the returned
angles with forward kinematics that share no code with the solvers' (compiled dual-quaternion FK,
:mod:`pipeline.kinematics.fkcheck`; never the kernel's own FK), sets ``success``
only when the method claimed success *and* that check passes, marks a contradicted claim as
:attr:`StopReason.FK_CHECK_FAILED`, and records whether the solution lies within the robot file's
joint limits.

Units. Settings are written in SI (m, rad) whatever the robot file's unit. ``length_unit`` names the
unit the method computes in (default m); the robot and the goal are converted to it once per job
(:class:`Prepared`) and every length-valued setting once per job (:meth:`Settings.converted`). A
study that needs a document's own unit (cerbaro2019's cm reading, borges_kr6's mm) sets
``length_unit`` and still writes its tolerances in metres. Results (``position_error``, traces) are
in ``length_unit``, which the result and the archive record.

Timing (one definition for every method, :mod:`pipeline.solvers.timing`): ``solve_time_s`` is the
method's own computation, from its first to its last operation on this problem, on the monotonic
clock; ``call_time_s`` is the whole Python call of :func:`pipeline.solvers.solve`, input conversion
and the FK check included.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import math
from dataclasses import MISSING, asdict, dataclass, field, fields, replace

import numpy as np

import numba

from pipeline.kinematics import fk_htm
from pipeline.kinematics.fkcheck import CHECK8_SCRATCH, check_model, check_one, pose_check, pose_check8
from pipeline.kinematics.fkcheck import meets as meets_compiled
from pipeline.io.layout import STOP_REASONS, TRACE_COLS, StopReason  # noqa: F401  (re-exported)
from pipeline.robots import LENGTH_UNITS, RobotModel
from pipeline.solvers._kin import CRITERIA, CRITERION_CODE  # noqa: F401  (re-exported: the one success-test code)
from pipeline.solvers._kin import FK_CHECK_FAILED, LIMIT_TOL, NON_FINITE, OUT_OF_LIMITS, SUCCESS, TRACE_DP
from pipeline.solvers._kin import borrowed, grid


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
PROJECT_ROOT = Path(__file__).resolve().parents[2]  # file-valued settings are paths from here ...
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
            length: bool = False, file: bool = False):
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
    """
    meta = {"doc": doc, "unit": unit, "choices": tuple(choices) if choices is not None else None,
            "minimum": minimum, "above": above, "maximum": maximum, "length": length, "file": file}
    return field(default=default, metadata=meta)


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
        :class:`SettingsError`. ``check_inputs`` calls it for every (robot, solver) job of a study."""

    def as_dict(self) -> dict:
        return asdict(self)

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
            rows.append({"name": f.name, "type": f.type, "default": f.default if f.default is not MISSING else None,
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
            props[f.name] = p
        return {"type": "object", "additionalProperties": False, "properties": props}


def _coerce(f, v, where: str):
    """Type check of one field value (ints accepted where floats are expected)."""
    want = _PY_TYPES.get(f.type)
    if want is None:
        return v
    if want is float and isinstance(v, int) and not isinstance(v, bool):
        return float(v)
    if want in (int, float) and isinstance(v, bool) or not isinstance(v, want):
        raise SettingsError(f"{where}: field '{f.name}': expected {f.type}, got {v!r}")
    return v


# ---- the robot, prepared once per job ---------------------------------------------------------
_MISSING = object()


class Prepared:
    """A robot converted to a working length unit and unpacked into the kernels' arrays.

    Attributes
    ----------
    source : RobotModel             the model as given (goals are passed in its unit)
    model : RobotModel              the model in ``unit``
    unit : str                      working length unit
    goal_scale : float              factor from ``source``'s unit to ``unit``
    args : tuple                    ``a, alpha, d, offs, prism, form, base, tool`` for :mod:`._kin`
                                    (``form`` = 0 standard / 1 modified DH / 2 general; for the
                                    general form ``a`` holds the origins' rows 0-2 (12 n,) and
                                    ``alpha`` the unit axes (3 n,), see ``_kin.link_transform``)
    limits : ndarray, shape (n, 2)  joint limits [rad | unit]; +-inf where the file gives none
    """

    def __init__(self, model: RobotModel, unit: str | None = None):
        if isinstance(model, Prepared):
            model = model.source
        unit = unit or "m"
        self.source = model
        self.unit = unit
        self.model = model.in_unit(unit) if unit != model.length_unit else model
        self.goal_scale = LENGTH_UNITS[model.length_unit] / LENGTH_UNITS[unit]
        c = self.model.chain
        # writable C-contiguous copies: the model's arrays are read-only, and numba compiles kernels
        # taking read-only arrays into code measured 2-3.5x slower (inverse Jacobian on the KR6)
        own = lambda x, dt=float: np.array(x, dtype=dt, order="C", copy=True)  # noqa: E731
        if c.general:
            a, alpha = own(c.origins[:, :3, :].ravel()), own(c.axes.ravel())
        else:
            a, alpha = own(c.a), own(c.alpha)
        self.args = (a, alpha, own(c.d), own(c.theta_offset), own(c.prismatic, np.bool_),
                     int(c.form_code), own(c.base), own(c.tool))
        self.limits = own(self.model.limits)
        self.prismatic = np.asarray(c.prismatic, dtype=bool)
        self._cache: dict = {}  # see memo()
        self._bound: dict = {}  # (solver name, id(settings)) -> driver.Bound (see registry.bind)
        self._finish_args = None  # finish()'s packed check model (see _finish_args)

    @property
    def n(self) -> int:
        return self.model.n

    @property
    def check(self) -> tuple:
        """The independent FK check's model of the working-unit chain (:func:`pipeline.kinematics.fkcheck.check_model`)."""
        return self.memo("fkcheck", lambda: check_model(self.model.chain))

    def memo(self, key, make):
        """Data derived once per job and robot (packed settings, an analytic solver's geometry...):
        ``make()`` on the first call with ``key`` (hashable), the stored value afterwards."""
        value = self._cache.get(key, _MISSING)
        if value is _MISSING:
            value = self._cache[key] = make()
        return value

    def working_goal(self, T_goal: np.ndarray) -> np.ndarray:
        """``T_goal`` (4, 4) in the source model's unit -> the working unit, C-contiguous float64
        (the caller's array itself when it already is that and no unit change is needed: kernels
        never write into the goal)."""
        if self.goal_scale != 1.0:
            T = np.array(T_goal, dtype=float, order="C")
            T[:3, 3] *= self.goal_scale
            return T
        return np.ascontiguousarray(T_goal, dtype=float)

    def bare_goal(self, T_goal: np.ndarray) -> np.ndarray:
        """Goal of the bare DH chain: ``base^-1 T_goal tool^-1`` (for analytic solvers)."""
        c = self.model.chain
        return _inv_rigid(c.base) @ T_goal @ _inv_rigid(c.tool)

    def search_box(self, default_half_width: float = math.pi) -> np.ndarray:
        """Finite joint box (n, 2): the limits, with ``[-w, w]`` for unbounded revolute joints.

        Raises
        ------
        NotApplicableError
            An unbounded prismatic joint (no finite box to search).
        """
        box = self.limits.copy()
        for i in range(self.n):
            if not np.all(np.isfinite(box[i])):
                if self.prismatic[i]:
                    raise NotApplicableError(f"{self.source.path or self.source.name}: joint {i + 1}: a prismatic "
                                             "joint without limits gives no finite search box")
                box[i] = (-default_half_width, default_half_width)
        return box


def _inv_rigid(T: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = T[:3, :3].T
    out[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return out


# ---- raw kernel output and the one result type ------------------------------------------------
@dataclass(slots=True)
class Raw:
    """What a method's kernel call returns (before the FK check).

    Attributes
    ----------
    q : ndarray, shape (n,)                 final joint values [rad | working unit]
    code : int                              the method's own stop code (a :class:`StopReason` value)
    iterations : int
    solve_ns : int                          the method's computation on the monotonic clock [ns]
    trace : ndarray, shape (k, 8), optional per iterate: scalar error, e (6), |dp|
    ik_ns : int                             time of the IK block (step) alone [ns], 0 if not measured
    solutions : ndarray, shape (m, n), optional
        Analytic methods: every solution found (``q`` is the one chosen).
    info : dict                             method-specific counters (JSON scalars), archived as is
    """

    q: np.ndarray
    code: int
    iterations: int
    solve_ns: int
    trace: np.ndarray | None = None
    ik_ns: int = 0
    solutions: np.ndarray | None = None
    info: dict = field(default_factory=dict)


@dataclass(slots=True)
class IKResult:
    """Outcome of one IK solve.

    Attributes
    ----------
    q : ndarray, shape (n,) [rad | length_unit]  final joint values (the chosen solution)
    success : bool                              FK-verified success
    stop_reason : int                           a :class:`StopReason` value
    iterations : int
    trace : ndarray, shape (iterations + 1, 8)  per iterate: scalar error, e (6), |dp| [length_unit]
    solve_time_s : float [s]                    the method's own computation (see module docstring)
    ik_time_s : float [s]                       the IK-block (step) time alone where measured, else 0
    position_error : float [length_unit]        |p_goal - p| by independent FK
    orientation_error : float [rad]             rotation angle goal vs reached (NaN for position-only goals)
    claimed_success : bool                      the method's own stop test said success
    within_limits : bool                        ``q`` lies within the joint limits (revolute joints wrapped by 2 pi first)
    call_time_s : float [s]                     the whole ``solve()`` call
    length_unit : str
    solutions : ndarray, shape (m, n) or None   analytic methods: all solutions
    info : dict                                 method-specific counters
    compiled : bool                             this call compiled kernels or loaded them from numba's
                                                cache (the first call of a method in a process): it was
                                                run again once they were ready, and its times are those
                                                of that run
    compile_time_s : float [s]                  the time that compiling or loading took (0 otherwise)
    """

    q: np.ndarray
    success: bool
    stop_reason: int
    iterations: int
    trace: np.ndarray
    solve_time_s: float
    ik_time_s: float
    position_error: float
    orientation_error: float
    claimed_success: bool = False
    within_limits: bool = True
    call_time_s: float = float("nan")
    length_unit: str = "m"
    solutions: np.ndarray | None = None
    info: dict = field(default_factory=dict)
    compiled: bool = False
    compile_time_s: float = 0.0


@dataclass
class BatchRaw:
    """What a method's batch kernel returns for N problems (before the FK check).

    Attributes
    ----------
    q : ndarray, shape (N, n)               final joint values [rad | working unit]
    code, iterations : ndarray, shape (N,)  the method's stop codes and iteration counts
    solve_ns, ik_ns : ndarray, shape (N,)   per-problem times [ns] (as in :class:`Raw`)
    cpu_ns : ndarray, shape (N,), optional  per-problem CPU time of the solving thread [ns], where the
                                            kernel reads it (``_kin.thread_cpu_ns``) around the same work
    trace_rows : ndarray, shape (M, 8), optional       every problem's trace rows, concatenated
    trace_offsets : ndarray, shape (N + 1,), optional  problem i's rows are ``offsets[i]:offsets[i+1]``
    solutions : ndarray, shape (N, m, n), optional     analytic methods: every solution ...
    n_solutions : ndarray, shape (N,), optional        ... of which the first n_solutions[i] hold
    info : list of dict, optional           per-problem counters
    """

    q: np.ndarray
    code: np.ndarray
    iterations: np.ndarray
    solve_ns: np.ndarray
    ik_ns: np.ndarray
    cpu_ns: np.ndarray | None = None
    trace_rows: np.ndarray | None = None
    trace_offsets: np.ndarray | None = None
    solutions: np.ndarray | None = None
    n_solutions: np.ndarray | None = None
    info: list | None = None


class InfoRows(Sequence):
    """Per-problem ``info`` dicts of a batch, built on access from the batch's arrays.

    A list of 100 000 dicts costs more than the batch solve; this sequence holds the arrays and
    ``rows[i]`` builds problem i's dict (the same keys and values as the single call's ``Raw.info``).
    """

    __slots__ = ("_n", "_make")

    def __init__(self, n: int, make):
        self._n, self._make = n, make

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self._make(k) for k in range(*i.indices(self._n))]
        k = int(i)
        if k < 0:
            k += self._n
        if not 0 <= k < self._n:
            raise IndexError(i)
        return self._make(k)


@dataclass
class BatchResult:
    """Outcome of N solves as arrays (:func:`pipeline.solvers.solve_batch`); fields as in :class:`IKResult`.

    Attributes
    ----------
    q : ndarray, shape (N, n) [rad | robot file's length unit]
    success, claimed_success, within_limits : ndarray of bool, shape (N,)
    stop_reason, iterations : ndarray of int, shape (N,)
    solve_time_s, ik_time_s : ndarray, shape (N,) [s]   per problem, measured inside the kernel
    position_error : ndarray, shape (N,) [length_unit]  by the independent FK check
    orientation_error : ndarray, shape (N,) [rad]       NaN for position-only criteria
    call_time_s : float [s]                             the whole batch call
    length_unit : str
    trace_rows, trace_offsets : see :class:`BatchRaw` (None when traces were not kept)
    solutions, n_solutions, info : see :class:`BatchRaw`
    call_times_s : ndarray, shape (N,), optional [s]  per-problem call times when the problems were
                                                      solved one call at a time (else None)
    cpu_times_s : ndarray, shape (N,), optional [s]   per-problem CPU time: of the solving thread where the
                                                      kernel reads it (BatchRaw.cpu_ns), else of the
                                                      process (all threads) when the caller measured it
                                                      (the runner does)
    compiled : bool, compile_time_s : float [s]       the call compiled or loaded kernels (then it was run
                                                      again once they were ready, and its times are that
                                                      run's) and the time that took
    """

    q: np.ndarray
    success: np.ndarray
    stop_reason: np.ndarray
    iterations: np.ndarray
    solve_time_s: np.ndarray
    ik_time_s: np.ndarray
    position_error: np.ndarray
    orientation_error: np.ndarray
    claimed_success: np.ndarray
    within_limits: np.ndarray
    call_time_s: float
    length_unit: str
    trace_rows: np.ndarray | None = None
    trace_offsets: np.ndarray | None = None
    solutions: np.ndarray | None = None
    n_solutions: np.ndarray | None = None
    info: list | None = None
    call_times_s: np.ndarray | None = None
    cpu_times_s: np.ndarray | None = None
    compiled: bool = False
    compile_time_s: float = 0.0

    def __len__(self) -> int:
        return int(self.q.shape[0])

    def trace(self, i: int) -> np.ndarray:
        """Problem ``i``'s trace (iterations + 1, 8); one row of NaN but |dp| when none was kept."""
        if self.trace_rows is None:
            t = np.full((1, TRACE_COLS), np.nan)
            t[0, TRACE_DP] = self.position_error[i]
            return t
        return self.trace_rows[self.trace_offsets[i]:self.trace_offsets[i + 1]]

    def result(self, i: int) -> IKResult:
        """Problem ``i`` as an :class:`IKResult` (``call_time_s``: its own call, or the batch's time / N)."""
        sols = None
        if self.solutions is not None:
            sols = self.solutions[i, : int(self.n_solutions[i])]
        return IKResult(q=self.q[i], success=bool(self.success[i]), stop_reason=int(self.stop_reason[i]),
                        iterations=int(self.iterations[i]), trace=self.trace(i),
                        solve_time_s=float(self.solve_time_s[i]), ik_time_s=float(self.ik_time_s[i]),
                        position_error=float(self.position_error[i]),
                        orientation_error=float(self.orientation_error[i]),
                        claimed_success=bool(self.claimed_success[i]), within_limits=bool(self.within_limits[i]),
                        call_time_s=(float(self.call_times_s[i]) if self.call_times_s is not None
                                     else self.call_time_s / max(1, len(self))), length_unit=self.length_unit,
                        solutions=sols, info=dict(self.info[i]) if self.info is not None else {})


def finish_batch(prep: Prepared, goals: np.ndarray, raw: BatchRaw, settings: Settings) -> BatchResult:
    """:func:`finish` for N problems at once: the same compiled rule per problem (:func:`_result`), on
    every core (not for ``require_limits``; the registry solves those one at a time).

    ``goals`` (N, 4, 4) and ``settings`` in the working unit; ``call_time_s`` is left at 0.
    """
    q = np.ascontiguousarray(raw.q, dtype=float)
    N = q.shape[0]
    code = np.asarray(raw.code, dtype=np.int64).copy()
    claimed, success, inside = np.zeros(N, np.bool_), np.zeros(N, np.bool_), np.zeros(N, np.bool_)
    dp, ang = np.empty(N), np.empty(N)
    F, prism = finish_args(prep)
    _finish_many(F, prism, q, np.ascontiguousarray(goals, dtype=float), CRITERION_CODE[settings.criterion],
                 settings.tol_pos, settings.tol_rot, settings.tol_dq, bool(settings.require_limits), code, claimed,
                 success, dp, ang, inside)
    if settings.criterion == "position":
        ang = np.full(N, np.nan)
    return BatchResult(q=q, success=success, stop_reason=code,
                       iterations=np.asarray(raw.iterations, dtype=np.int64), solve_time_s=raw.solve_ns * 1e-9,
                       ik_time_s=raw.ik_ns * 1e-9, position_error=dp, orientation_error=ang,
                       claimed_success=claimed, within_limits=inside, call_time_s=0.0, length_unit=prep.unit,
                       trace_rows=raw.trace_rows, trace_offsets=raw.trace_offsets, solutions=raw.solutions,
                       n_solutions=raw.n_solutions, info=raw.info,
                       cpu_times_s=None if raw.cpu_ns is None else raw.cpu_ns * 1e-9)


def pose_errors(model: RobotModel, T_goal: np.ndarray, q: np.ndarray) -> tuple[float, float, float]:
    """Independent FK of ``q``: (|dp| [unit], rotation angle [rad], |t| of ``T_goal T^-1`` [unit])."""
    T = fk_htm(model.chain, q)
    Rg, R = T_goal[:3, :3], T[:3, :3]
    dpv = T_goal[:3, 3] - T[:3, 3]
    dp = float(math.sqrt(dpv @ dpv))
    Rrel = Rg @ R.T
    c = (np.trace(Rrel) - 1.0) / 2.0
    s = 0.5 * math.sqrt((Rrel[2, 1] - Rrel[1, 2]) ** 2 + (Rrel[0, 2] - Rrel[2, 0]) ** 2 + (Rrel[1, 0] - Rrel[0, 1]) ** 2)
    ang = float(math.atan2(s, c)) if math.isfinite(c) and math.isfinite(s) else math.nan
    tv = T_goal[:3, 3] - Rrel @ T[:3, 3]
    return dp, ang, float(math.sqrt(tv @ tv))


def meets(settings: Settings, dp: float, ang: float, t: float) -> bool:
    """The success test of ``settings.criterion`` on FK errors (tolerances in the working unit)."""
    if not math.isfinite(dp) or (settings.criterion != "position" and not math.isfinite(ang)):
        return False
    crit = settings.criterion
    if crit == "dq_norm":
        return math.sqrt(1 + t * t / 4) <= settings.tol_dq * (1 + 1e-12)
    if crit == "dq_norm_body":
        return math.sqrt(1 + dp * dp / 4) <= settings.tol_dq * (1 + 1e-12)
    if crit == "position":
        return dp <= settings.tol_pos * (1 + 1e-9)
    return dp <= settings.tol_pos * (1 + 1e-9) and ang <= settings.tol_rot * (1 + 1e-9)


def verify(model: RobotModel, T_goal: np.ndarray, q: np.ndarray, settings: Settings) -> tuple[bool, float, float]:
    """Independent FK check of a solution: (meets the success criterion, |dp| [length], angle [rad]).

    Uses the numpy reference FK (not a compiled kernel). The DQ norm of ``Q_goal Q*`` is taken in
    its closed form ``sqrt(1 + |t|^2 / 4)``, t the translation of ``T_goal T^-1`` (tested against the
    explicit dual-quaternion product in tests/test_kinematics.py). ``settings`` must already be in
    the model's unit (:meth:`Settings.converted`).
    """
    dp, ang, t = pose_errors(model, T_goal, q)
    return meets(settings, dp, ang, t), dp, ang


def check(prep: Prepared, T_goal: np.ndarray, q: np.ndarray, settings: Settings) -> tuple[bool, float, float]:
    """:func:`verify` by the compiled dual-quaternion FK (:mod:`pipeline.kinematics.fkcheck`): the
    check every solve gets. ``T_goal`` and ``settings`` in the working unit; returns (ok, |dp|, angle)."""
    ok, dp, ang, _ = check_one(*prep.check, np.asarray(q, dtype=float), T_goal, CRITERION_CODE[settings.criterion],
                               settings.tol_pos, settings.tol_rot, settings.tol_dq, np.empty(8))
    return bool(ok), dp, ang


@numba.njit(cache=True)
def _within(q, limits, prismatic, tol):
    for i in range(q.shape[0]):
        x, lo, hi = q[i], limits[i, 0], limits[i, 1]
        if not math.isfinite(x):
            return False
        if not prismatic[i] and math.isfinite(lo):
            x = lo + np.mod(x - lo, 2 * math.pi)
            if abs(x - 2 * math.pi - lo) <= tol:
                x = lo
        if x < lo - tol or x > hi + tol:
            return False
    return True


def within_limits(q: np.ndarray, limits: np.ndarray, prismatic: np.ndarray, tol: float = LIMIT_TOL) -> bool:
    """True when every joint lies within its limits (up to ``tol``, by default the one tolerance
    :data:`pipeline.solvers._kin.LIMIT_TOL`); a revolute joint may first be wrapped by 2 pi.

    A wrapped value just below ``lo + 2 pi`` (within ``tol``) counts as ``lo``. Compiled (called
    once per solve).
    """
    return bool(_within(np.asarray(q, dtype=float), np.asarray(limits, dtype=float), np.asarray(prismatic, dtype=np.bool_),
                        float(tol)))


def wrap_into_limits(q: np.ndarray, limits: np.ndarray, prismatic: np.ndarray) -> np.ndarray:
    """``q`` with each revolute joint moved by a multiple of 2 pi into its limits where that fits.

    Joints that do not fit either way (and prismatic or unbounded joints) keep their value, so
    the pose is unchanged up to rounding of ``q +- 2 k pi``.
    """
    q = np.array(q, dtype=float)
    lo, hi = limits[:, 0], limits[:, 1]
    for i in range(q.shape[0]):
        if prismatic[i] or not math.isfinite(lo[i]) or not math.isfinite(q[i]) or lo[i] <= q[i] <= hi[i]:
            continue
        w = lo[i] + math.fmod(q[i] - lo[i], 2 * math.pi) % (2 * math.pi)
        if w <= hi[i]:
            q[i] = w
    return q


@numba.njit(cache=True)
def nearest_rep(x, ref, limits, prismatic, tol, out):
    """``x`` (n,) moved joint by joint by whole turns to the value within the limits (up to ``tol``)
    nearest ``ref`` (n,), into ``out``; returns the joint travel from ``ref`` (Euclidean norm of the
    moves), inf when a joint fits no turn or a value is not finite. Prismatic joints keep their value;
    an unbounded revolute joint takes the turn nearest ``ref``."""
    two_pi = 2.0 * math.pi
    acc = 0.0
    for j in range(x.shape[0]):
        if prismatic[j]:
            c = x[j] - ref[j]
        else:
            w = x[j] - ref[j]
            w = w - two_pi * math.floor((w + math.pi) / two_pi)
            c = math.inf
            for k in (0, -1, 1, -2, 2):
                y = w + two_pi * k
                if limits[j, 0] - tol <= ref[j] + y <= limits[j, 1] + tol and abs(y) < abs(c):
                    c = y
        out[j] = ref[j] + c
        acc += c * c
    return math.sqrt(acc) if math.isfinite(acc) else math.inf


@numba.njit(cache=True)
def nearest_of(q, S, ref, limits, prismatic, tol, out, d):
    """:func:`nearest_rep` of ``q`` (n,) and of every row of ``S`` (m, n): ``d`` (m + 1,) their travels
    (``q`` first); the representative of the least travel into ``out``. Returns its index (0: ``q``,
    1 + i: row i of ``S``), -1 when none fits the limits."""
    best = -1
    bd = math.inf
    for i in range(S.shape[0] + 1):
        d[i] = nearest_rep(q if i == 0 else S[i - 1], ref, limits, prismatic, tol, out)
        if d[i] < bd:
            bd = d[i]
            best = i
    if best >= 0:
        nearest_rep(q if best == 0 else S[best - 1], ref, limits, prismatic, tol, out)
    return best


def _within_limit_choice(prep: Prepared, T_goal: np.ndarray, raw: Raw, settings: Settings,
                         q_start: np.ndarray | None) -> np.ndarray:
    """The returned angles under ``require_limits``: wrapped into the limits; for an analytic method, the
    solution that moves the joints least from the start (each one, the method's first choice among them,
    moved by whole turns to its value within the limits nearest the start, :func:`nearest_of`). The first
    choice is judged beside the method's other solutions: a joint whose limits are narrower than a turn
    may put the solution nearest by wrapped angles on the far side of the joint's range (a UR3 elbow at
    +3.13 rad for a seed at -2.88), where a neighbouring solution lies within 0.5 rad. Another solution
    than the first is taken only if it passes the independent FK check (the first is checked by
    :func:`finish` as every result is); if it does not, the next nearest that does."""
    if raw.solutions is None or len(raw.solutions) == 0 or q_start is None:
        return wrap_into_limits(raw.q, prep.limits, prep.prismatic)
    S = np.ascontiguousarray(raw.solutions, dtype=float).reshape(len(raw.solutions), -1)
    ref = np.ascontiguousarray(q_start, dtype=float)
    lim, prism = prep.memo("limit_arrays", lambda: (np.ascontiguousarray(prep.limits, dtype=float),
                                                    np.ascontiguousarray(prep.prismatic, dtype=np.bool_)))
    out, d = np.empty(ref.shape[0]), np.empty(len(S) + 1)
    best = nearest_of(np.ascontiguousarray(raw.q, dtype=float), S, ref, lim, prism, LIMIT_TOL, out, d)
    if best == 0 or (best > 0 and check(prep, T_goal, out, settings)[0]):
        return out
    for i in np.argsort(d, kind="stable"):  # (rare) the nearest other solution failed the check
        if i == best or not np.isfinite(d[i]):
            continue
        nearest_rep(np.asarray(raw.q if i == 0 else S[i - 1], dtype=float), ref, lim, prism, LIMIT_TOL, out)
        if i == 0 or check(prep, T_goal, out, settings)[0]:
            return out
    return wrap_into_limits(raw.q, prep.limits, prep.prismatic)


def finish(prep: Prepared, T_goal: np.ndarray, raw: Raw, settings: Settings, call_ns: int = 0,
           q_start: np.ndarray | None = None) -> IKResult:
    """Turn a kernel's raw output into the result: FK check, stop reason, limits, timings.

    Parameters
    ----------
    prep : Prepared
    T_goal : ndarray, shape (4, 4)   goal in the working unit
    raw : Raw
    settings : Settings              converted to the working unit
    call_ns : int                    the whole call's duration so far [ns] (set again by the registry)
    q_start : ndarray, shape (n,), optional   the start (for an analytic method's choice under
                                              ``require_limits``)

    Notes
    -----
    The stop reason, ``success``, the errors and the limit record come from one compiled rule,
    :func:`_result`, which :func:`finish_batch` and the analytic closed forms' fused public calls
    (``Solver.bind_call``, through :func:`finish_packed`) run too.
    """
    if settings.require_limits:
        q = _within_limit_choice(prep, T_goal, raw, settings, q_start)
    else:
        q = raw.q
        if type(q) is not np.ndarray or q.dtype != np.float64:
            q = np.asarray(q, dtype=float)
    F, prism = finish_args(prep)
    code, claimed, success, dp, ang, inside = _finish_one(F, prism, q, T_goal, CRITERION_CODE[settings.criterion],
                                                          settings.tol_pos, settings.tol_rot, settings.tol_dq,
                                                          int(raw.code), settings.require_limits)
    trace = raw.trace
    if trace is None:
        trace = np.full((1, TRACE_COLS), np.nan)
        trace[0, TRACE_DP] = dp
    elif len(trace) != raw.iterations + 1:
        trace = np.asarray(trace)[: raw.iterations + 1]
    # positional: a keyword call of the 15-field dataclass costs ~0.5 us more (Python 3.11), on every solve
    return IKResult(q, success, code, int(raw.iterations), trace,
                    raw.solve_ns * 1e-9, raw.ik_ns * 1e-9, dp, math.nan if settings.criterion == "position" else ang,
                    claimed, inside, call_ns * 1e-9, prep.unit, raw.solutions, raw.info)


def finish_args(prep: Prepared) -> tuple[np.ndarray, np.ndarray]:
    """``(F, prism)`` of :func:`_result` for ``prep`` (built once, kept on the prepared robot)."""
    fa = prep._finish_args
    if fa is None:
        fa = prep._finish_args = _finish_args(prep)
    return fa


def _finish_args(prep: Prepared) -> tuple[np.ndarray, np.ndarray]:
    """The check's model and the limits packed into one float array (fewer arguments = a cheaper
    compiled call): K (n+1, 8), axis (n, 3), offset (n,), limits (n, 2), then 8 floats of scratch."""
    K, axis, offset, prism = prep.check
    F = np.concatenate([K.ravel(), axis.ravel(), offset, prep.limits.ravel(), np.zeros(8)])
    return F, np.ascontiguousarray(prism)


@numba.njit(cache=True, inline="always")
def final_code(code, ok, dp, q, inside, require_limits):
    """The one result rule: the stop reason and success from the method's own stop ``code`` and the
    independent FK check (``ok``, ``dp``) of ``q``. A claimed success the check contradicts is
    FK_CHECK_FAILED; a NaN error from a non-finite joint value is NON_FINITE; under
    ``require_limits`` a success outside the limits is OUT_OF_LIMITS. Returns (code, claimed, success)."""
    claimed = code == SUCCESS
    if claimed and not ok:
        code = FK_CHECK_FAILED
    if dp != dp:  # a NaN error: a non-finite joint value (or goal)
        for j in range(q.shape[0]):
            if not math.isfinite(q[j]):
                code = NON_FINITE
                break
    if code == SUCCESS and require_limits and not inside:
        code = OUT_OF_LIMITS
    return code, claimed, claimed and ok and code == SUCCESS


@numba.njit(cache=True, inline="always")
def _unpack(F, n):
    """(K (n+1, 8), axis (n, 3), offset (n,), limits (n, 2), scratch (8,)) views of :func:`_finish_args`'s array."""
    o1 = 8 * (n + 1)
    o2 = o1 + 3 * n
    o3 = o2 + n
    o4 = o3 + 2 * n
    return grid(F, n + 1, 8), grid(F[o1:], n, 3), F[o2:o3], grid(F[o3:], n, 2), F[o4:o4 + 8]


@numba.njit(cache=True, inline="always")
def _result(F, prism, q, Tg, crit, tol_pos, tol_rot, tol_dq, code, require_limits, buf):
    """Everything of a result but its packing, for one solution (every path's finish): the FK check, the
    joint-limit record and :func:`final_code`. Returns (code, claimed, success, |dp|, angle, within)."""
    K, axis, offset, _, _ = _unpack(F, q.shape[0])
    dp, ang, t = pose_check(K, axis, offset, prism, q, Tg, buf)
    return _verdict(F, prism, q, crit, tol_pos, tol_rot, tol_dq, code, require_limits, dp, ang, t)


@numba.njit(cache=True, inline="always")
def _verdict(F, prism, q, crit, tol_pos, tol_rot, tol_dq, code, require_limits, dp, ang, t):
    """:func:`_result` from the check's errors (|dp|, angle, |t|) of ``q``."""
    limits = _unpack(F, q.shape[0])[3]
    ok = meets_compiled(crit, tol_pos, tol_rot, tol_dq, dp, ang, t)
    inside = _within(q, limits, prism, LIMIT_TOL)
    code, claimed, success = final_code(code, ok, dp, q, inside, require_limits)
    return code, claimed, success, dp, ang, inside


@numba.njit(cache=True)
def _finish_one(F, prism, q, Tg, crit, tol_pos, tol_rot, tol_dq, code, require_limits):
    """:func:`_result` of one solution in one compiled call (``F``: :func:`_finish_args`, its scratch used)."""
    return _result(F, prism, q, Tg, crit, tol_pos, tol_rot, tol_dq, code, require_limits, _unpack(F, q.shape[0])[4])


@numba.njit(cache=True, parallel=True)
def _finish_many(F, prism, Q, goals, crit, tol_pos, tol_rot, tol_dq, require_limits, code, claimed, success, dp, ang,
                 inside):
    """:func:`_result` for every row of ``Q`` (N, n) against ``goals`` (N, 4, 4); ``code`` (N,) in and out.

    The check runs 8 rows at a time (:func:`~pipeline.kinematics.fkcheck.pose_check8`, vector lanes), the
    rows past the last 8 one at a time: the same floats either way."""
    Fb, pb, Qb, gb = borrowed(F), borrowed(prism), borrowed(Q), borrowed(goals)  # no atomic counting per row
    N, n, chunk = Q.shape[0], Q.shape[1], 32
    K, axis, offset, _, _ = _unpack(Fb, n)
    for c_ in numba.prange((N + chunk - 1) // chunk):  # work items of 32 rows, one scratch each
        W = np.empty(CHECK8_SCRATCH + 8 * n)
        E = np.empty((3, 8))
        Wb, Eb = borrowed(W), borrowed(E)
        hi = min(N, (c_ + 1) * chunk)
        for k8 in range(c_ * chunk, hi, 8):
            full = k8 + 8 <= hi
            if full:
                pose_check8(K, axis, offset, pb, Qb, gb, k8, Wb, Eb)
            for k in range(k8, min(hi, k8 + 8)):
                if full:
                    e0, e1, e2 = Eb[0, k - k8], Eb[1, k - k8], Eb[2, k - k8]
                else:
                    e0, e1, e2 = pose_check(K, axis, offset, pb, Qb[k], gb[k], Wb)
                c, cl, su, d, a, w = _verdict(Fb, pb, Qb[k], crit, tol_pos, tol_rot, tol_dq, code[k], require_limits,
                                              e0, e1, e2)
                code[k], claimed[k], success[k], dp[k], ang[k], inside[k] = c, cl, su, d, a, w
        # the work item's scratch read after its last borrowed use (numba frees a local after its last use)
        E[0, 0] = W[0]


# ---- the check packed for a fused call (an analytic solver's kernel, choice and check in one call) ----
C_CRIT, C_TOLP, C_TOLR, C_TOLDQ, C_F = 0, 1, 2, 3, 4  # criterion code, tolerances, then F (:func:`_finish_args`)


def fused_inputs(prep: Prepared, scaled: bool = True):
    """The input half of a fused closed-form call (``Solver.bind_call``): ``inputs(T_goal, q_start) ->
    (goal (4, 4), start (n,))``, both contiguous float64, the shapes checked (one-line SettingsError)
    as :meth:`pipeline.solvers.driver.Bound.solve` does; the goal in the working unit, or left in the
    robot file's unit when not ``scaled`` (a kernel that scales it itself)."""
    scale, working_goal, contiguous, shape = prep.goal_scale, prep.working_goal, np.ascontiguousarray, (prep.n,)
    if not scaled:
        scale = 1.0

    def inputs(T_goal, q_start):
        Tg = contiguous(T_goal, dtype=float) if scale == 1.0 else working_goal(T_goal)
        if Tg.shape != (4, 4):
            raise SettingsError(f"T_goal: expected shape (4, 4), got {Tg.shape}")
        q0 = contiguous(q_start, dtype=float)  # the kernels never write into the start
        if q0.shape != shape:
            raise SettingsError(f"q_start: expected shape {shape}, got {q0.shape}")
        return Tg, q0

    return inputs


def check_pack(prep: Prepared, settings: Settings) -> np.ndarray:
    """The success test, the FK check's model and the limits in one float array, for :func:`finish_packed`.

    ``[criterion code, tol_pos, tol_rot, tol_dq, F (see :func:`_finish_args`), prismatic flags as 1.0/0.0]``
    (``settings`` in the working unit). A kernel that runs the check inside its own compiled call
    takes this appended to its own packed parameters, so the check adds no argument to the call
    (numba's dispatch costs ~40 ns per array argument).
    """
    F, prism = finish_args(prep)
    head = [float(CRITERION_CODE[settings.criterion]), float(settings.tol_pos), float(settings.tol_rot),
            float(settings.tol_dq)]
    return np.concatenate([head, F, prism.astype(float)])


@numba.njit(cache=True, inline="always")
def check_fields(C, n):
    """The parts of one :func:`check_pack` array of an n-joint arm: (F (:func:`_finish_args`), prismatic
    flags (n,), criterion code, tol_pos, tol_rot, tol_dq)."""
    nf = 14 * n + 16  # len(F): K 8 (n + 1), axis 3 n, offset n, limits 2 n, scratch 8
    return C[C_F:C_F + nf], C[C_F + nf:C_F + nf + n], int(C[C_CRIT]), C[C_TOLP], C[C_TOLR], C[C_TOLDQ]


@numba.njit(cache=True, inline="always")
def finish_packed(C, q, Tg, code):
    """:func:`_result` (without ``require_limits``) from one :func:`check_pack` array, for a fused
    compiled call: (code, claimed, success, |dp|, angle, within)."""
    n = q.shape[0]
    F, prism, crit, tol_pos, tol_rot, tol_dq = check_fields(C, n)
    return _result(F, prism, q, Tg, crit, tol_pos, tol_rot, tol_dq, code, False, _unpack(F, n)[4])
