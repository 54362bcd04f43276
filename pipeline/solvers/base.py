"""One result type and one call shape for every IK method.

``solve(model, T_goal, q_start, settings) -> IKResult``. The compiled loop in
:mod:`pipeline.solvers._jit` does the iterations; this module validates settings, times nothing
itself (the kernel times each solve with a monotonic clock), and verifies every claimed success by
an independent forward kinematics (numpy, homogeneous matrices) before the flag is set.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from pipeline.kinematics import fk_htm
from pipeline.robots import RobotModel
from pipeline.solvers import _jit

STOP_REASONS = {
    _jit.SUCCESS: "success",
    _jit.STALLED: "stalled (pose change below the stall threshold)",
    _jit.DIVERGING: "error grew on consecutive iterations",
    _jit.ITERATION_CAP: "iteration cap",
    _jit.NON_FINITE: "non-finite value (numerical failure)",
    _jit.FK_CHECK_FAILED: "claimed success contradicted by forward kinematics",
}


class SettingsError(ValueError):
    """A solver setting is missing, unknown or out of range (message names the field)."""


@dataclass(frozen=True)
class SolverSettings:
    """Settings of the Jacobian IK loop (constants from 000_7e3cb7ad5ee98ff0.txt §4.1 by default).

    Attributes
    ----------
    method : {"jacobian_transpose", "pseudoinverse", "dls", "sdls"}
    max_iterations : int
        Stop code 4 after this many iterations (500 in 000).
    criterion : {"dq_norm", "dq_norm_body", "pos_orient"}
        ``dq_norm``: success when the 8-coefficient norm of ``Q_goal Q*`` is at most ``tol_dq``
        (1 + 1e-6), stall when the norm of ``Q_k Q_{k-1}*`` is below ``stall_dq`` (1 + 1e-12).
        ``dq_norm_body``: the same with ``Q* Q_goal``, whose translation is ``R^T (p_goal - p)``:
        the norm then sees the position error only.
        ``pos_orient``: success when |dp| <= ``tol_pos`` [length] and angle <= ``tol_rot`` [rad];
        stall when the pose moves less than ``stall_pos`` and ``stall_rot``.
    orientation_error : {"quat_vec", "axis_angle"}
        Angular half of the 6-vector: ``orientation_gain * vec(q_goal q*)`` or the rotation vector.
    grow_limit : int
        Stop code 3 after the error grew this many iterations in a row (5 in 000).
    damping : float
        DLS lambda (0.1 in 000).
    gamma_max : float [rad]
        SDLS maximum joint step (3 pi / 2 in 000).
    sdls_norm : {"maxabs", "one", "two"}
        Norm used by the SDLS clamps.
    sdls_blocks : {1, 2}
        SDLS end-effector blocks: 1 = the 6-vector as one block, 2 = position and orientation.
    disable_stall, disable_grow : bool
        Turn stop codes 2 and 3 off (the Table 16 rerun of 000).
    """

    method: str = "dls"
    max_iterations: int = 500
    criterion: str = "dq_norm"
    orientation_error: str = "quat_vec"
    orientation_gain: float = 1.0
    grow_limit: int = 5
    damping: float = 0.1
    gamma_max: float = 3 * math.pi / 2
    sdls_norm: str = "maxabs"
    sdls_blocks: int = 1
    tol_dq: float = 1 + 1e-6
    stall_dq: float = 1 + 1e-12
    tol_pos: float = 1e-3
    tol_rot: float = 1e-3
    stall_pos: float = 1e-9
    stall_rot: float = 1e-9
    disable_stall: bool = False
    disable_grow: bool = False
    length_unit: str | None = None  # None = the robot file's own unit

    @classmethod
    def from_dict(cls, d: dict, where: str = "solver settings") -> "SolverSettings":
        """Build from a mapping, naming the bad field in a one-line ``SettingsError``."""
        known = {f: v for f, v in cls.__dataclass_fields__.items()}
        for k in d:
            if k not in known:
                raise SettingsError(f"{where}: field '{k}': unknown setting (allowed: {', '.join(known)})")
        out = cls(**d)
        out.validate(where)
        return out

    def validate(self, where: str = "solver settings") -> None:
        choices = {"method": _jit.METHODS, "criterion": _jit.CRITERIA, "orientation_error": _jit.ORIENT_ERRORS,
                   "sdls_norm": _jit.NORMS, "sdls_blocks": {1: 1, 2: 2}}
        for k, allowed in choices.items():
            if getattr(self, k) not in allowed:
                raise SettingsError(f"{where}: field '{k}': {getattr(self, k)!r} is not one of {list(allowed)}")
        for k in ("max_iterations", "grow_limit"):
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise SettingsError(f"{where}: field '{k}': expected a positive integer, got {v!r}")
        for k in ("orientation_gain", "damping", "gamma_max", "tol_dq", "stall_dq", "tol_pos", "tol_rot", "stall_pos", "stall_rot"):
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise SettingsError(f"{where}: field '{k}': expected a finite number >= 0, got {v!r}")
        if self.tol_dq < 1 or self.stall_dq < 1:
            raise SettingsError(f"{where}: field 'tol_dq'/'stall_dq': a DQ-norm threshold is 1 + epsilon (>= 1)")
        if self.length_unit not in (None, "m", "cm", "mm"):
            raise SettingsError(f"{where}: field 'length_unit': {self.length_unit!r} is not one of m, cm, mm")

    def as_dict(self) -> dict:
        return asdict(self)

    def packed(self) -> tuple[np.ndarray, np.ndarray]:
        ip = np.zeros(_jit.N_IP, np.int64)
        fp = np.zeros(_jit.N_FP)
        ip[_jit.I_METHOD] = _jit.METHODS[self.method]
        ip[_jit.I_MAX_ITER] = self.max_iterations
        ip[_jit.I_CRITERION] = _jit.CRITERIA[self.criterion]
        ip[_jit.I_ORIENT] = _jit.ORIENT_ERRORS[self.orientation_error]
        ip[_jit.I_GROW_LIMIT] = self.grow_limit
        ip[_jit.I_SDLS_NORM] = _jit.NORMS[self.sdls_norm]
        ip[_jit.I_SDLS_BLOCKS] = self.sdls_blocks
        ip[_jit.I_NO_STALL] = int(self.disable_stall)
        ip[_jit.I_NO_GROW] = int(self.disable_grow)
        fp[_jit.F_LAMBDA] = self.damping
        fp[_jit.F_GAMMA_MAX] = self.gamma_max
        fp[_jit.F_TOL_DQ] = self.tol_dq
        fp[_jit.F_STALL_DQ] = self.stall_dq
        fp[_jit.F_TOL_POS] = self.tol_pos
        fp[_jit.F_TOL_ROT] = self.tol_rot
        fp[_jit.F_STALL_POS] = self.stall_pos
        fp[_jit.F_STALL_ROT] = self.stall_rot
        fp[_jit.F_ORIENT_GAIN] = self.orientation_gain
        return ip, fp


@dataclass(frozen=True)
class IKResult:
    """Outcome of one IK solve.

    Attributes
    ----------
    q : ndarray, shape (n,) [rad | length]      final joint values
    success : bool                              FK-verified success
    stop_reason : int                           1 success, 2 stall, 3 error grew, 4 cap, 5 non-finite, 6 FK contradicts
    iterations : int
    trace : ndarray, shape (iterations + 1, 8)  per iteration: scalar error, e (6), |dp| [length]
    solve_time_s : float [s]                    whole solve, one monotonic-clock interval
    ik_time_s : float [s]                       sum of the IK-block (step) times
    position_error : float [length]             |p_goal - p| by independent FK
    orientation_error : float [rad]             rotation angle between goal and reached orientation
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
    claimed_success: bool = field(default=False)


class PreparedRobot:
    """A robot's chain unpacked into the arrays the kernel takes (done once per job)."""

    def __init__(self, model: RobotModel, unit: str | None = None):
        self.model = model.in_unit(unit) if unit and unit != model.length_unit else model
        c = self.model.chain
        self.args = (np.ascontiguousarray(c.a), np.ascontiguousarray(c.alpha), np.ascontiguousarray(c.d),
                     np.ascontiguousarray(c.theta_offset), np.ascontiguousarray(c.prismatic),
                     bool(c.modified), np.ascontiguousarray(c.base), np.ascontiguousarray(c.tool))


def verify(model: RobotModel, T_goal: np.ndarray, q: np.ndarray, settings: SolverSettings) -> tuple[bool, float, float]:
    """Independent FK check of a solution: (meets the success criterion, |dp| [length], angle [rad]).

    Uses the numpy reference FK (not the compiled kernel). The DQ norm of ``Q_goal Q*`` is taken in
    its closed form ``sqrt(1 + |t|^2 / 4)``, t the translation of ``T_goal T^-1`` (tested against the
    explicit dual-quaternion product in tests/test_kinematics.py).
    """
    T = fk_htm(model.chain, q)
    Rg, R = T_goal[:3, :3], T[:3, :3]
    dpv = T_goal[:3, 3] - T[:3, 3]
    dp = float(math.sqrt(dpv @ dpv))
    Rrel = Rg @ R.T
    c = (np.trace(Rrel) - 1.0) / 2.0
    s = 0.5 * math.sqrt((Rrel[2, 1] - Rrel[1, 2]) ** 2 + (Rrel[0, 2] - Rrel[2, 0]) ** 2 + (Rrel[1, 0] - Rrel[0, 1]) ** 2)
    ang = float(math.atan2(s, c)) if math.isfinite(c) and math.isfinite(s) else math.nan
    if not (math.isfinite(dp) and math.isfinite(ang)):
        return False, dp, ang
    if settings.criterion == "dq_norm":
        t = T_goal[:3, 3] - Rrel @ T[:3, 3]
        ok = math.sqrt(1 + (t @ t) / 4) <= settings.tol_dq * (1 + 1e-12)
    elif settings.criterion == "dq_norm_body":
        ok = math.sqrt(1 + dp * dp / 4) <= settings.tol_dq * (1 + 1e-12)
    else:
        ok = dp <= settings.tol_pos * (1 + 1e-9) and ang <= settings.tol_rot * (1 + 1e-9)
    return ok, dp, ang


def solve(robot: RobotModel | PreparedRobot, T_goal: np.ndarray, q_start: np.ndarray,
          settings: SolverSettings, _kernel=None) -> IKResult:
    """Solve one IK problem.

    Parameters
    ----------
    robot : RobotModel or PreparedRobot
        Lengths are taken in ``settings.length_unit`` (the robot's own when None); ``T_goal`` must
        be in that same unit.
    T_goal : ndarray, shape (4, 4)
    q_start : ndarray, shape (n,) [rad | length]
    settings : SolverSettings

    Returns
    -------
    IKResult
        ``success`` is True only when an independent FK of the returned angles meets the
        criterion; a kernel claim that FK contradicts becomes stop reason 6.
    """
    prep = robot if isinstance(robot, PreparedRobot) else PreparedRobot(robot, settings.length_unit)
    ip, fp = settings.packed()
    q0 = np.ascontiguousarray(q_start, dtype=float)
    Tg = np.ascontiguousarray(T_goal, dtype=float)
    q = np.empty_like(q0)
    trace = np.zeros((settings.max_iterations + 1, _jit.TRACE_COLS))
    times = np.zeros(3, np.int64)
    kernel = _kernel or _jit.solve_one
    code, iters = kernel(*prep.args, Tg, q0, ip, fp, q, trace, times)
    code, iters = int(code), int(iters)
    ok, dp, ang = verify(prep.model, Tg, q, settings)
    claimed = code == _jit.SUCCESS
    if claimed and not ok:
        code = _jit.FK_CHECK_FAILED
    if not np.all(np.isfinite(q)):
        code = _jit.NON_FINITE
    return IKResult(q=q, success=claimed and ok, stop_reason=code, iterations=iters,
                    trace=trace[: iters + 1].copy(), solve_time_s=times[0] * 1e-9, ik_time_s=times[1] * 1e-9,
                    position_error=dp, orientation_error=ang, claimed_success=claimed)
