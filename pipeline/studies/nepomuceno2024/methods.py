"""The five IK methods of 004_957b32c2b06ea31d.txt §4.2/Apêndices B-E, one call shape each.

``solve_point(method, prep, T_goal, q_start) -> PointResult`` (an :class:`pipeline.solvers.IKResult`
plus the counters the document reports). Method settings come from the study settings
(``study_settings.methods.<name>``); ``kind`` selects the implementation:

``pinv_descent``  θ ← θ + rate · J⁺ e, e = [Δp; ½ Σ cᵢ × dᵢ] (Apêndice E), compiled loop.
``scipy``         ``scipy.optimize.minimize(cost, q_start, method=..., bounds=..., options=...)``
                  on cost A (‖Δp‖ + ‖ΔR‖_F, BFGS listing) or cost B (‖Δp‖ + 0.1 ‖ΔR‖_F, L-BFGS-B).
``analytic``      the 8-solution closed form, each solution FK-verified, nearest to ``q_start``.

Every result is confirmed by an independent numpy FK (:func:`pipeline.kinematics.fk_htm`):
``success`` = position error ≤ ``success.position`` [m] and orientation error ≤
``success.orientation`` [rad] (pick-and-place tolerances; the document defines none).
Stop codes as :mod:`pipeline.solvers`: 1 success, 2 stopped short of the tolerance, 4 iteration
cap, 5 non-finite, 6 the method claimed convergence but FK says the pose is outside the tolerance.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from pipeline.kinematics import fk_htm, orientation_error_angle, position_error
from pipeline.robots import RobotModel
from pipeline.solvers import IKResult
from pipeline.studies.nepomuceno2024 import _jit

KINDS = ("pinv_descent", "scipy", "analytic")
UR_ALPHA = np.array([math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0])
UR_TOL = 1e-9  # a UR-type DH table must match the closed form's structure to this (typed decimals are exact)


class MethodError(ValueError):
    """A method setting is invalid or the robot does not suit the method (one line)."""


@dataclass
class PointResult:
    """One IK solve at one trajectory point.

    Attributes
    ----------
    ik : IKResult
        ``trace`` rows: [the method's own error measure, e (6), |dp|] per iterate.
    nfev : int                     cost / FK evaluations
    njev : int                     gradient (SciPy) or Jacobian (descent) evaluations
    doc_error : float              the document's per-method error measure at the solution
    message : str                  the method's own stop message
    n_solutions : int              analytic only: FK-verified closed-form solutions (else -1)
    branch : int                   analytic only: chosen branch row 0..7 (else -1)
    """

    ik: IKResult
    nfev: int
    njev: int
    doc_error: float
    message: str = ""
    n_solutions: int = -1
    branch: int = -1
    extra: dict = field(default_factory=dict)


def pack_dh(model: RobotModel) -> np.ndarray:
    """``[a, alpha, d, theta_offset]`` (4 n,) of a revolute standard-DH robot without base/tool."""
    c = model.chain
    if c.modified or c.prismatic.any():
        raise MethodError(f"{model.name}: the study kernels need a revolute standard-DH chain")
    if not (np.allclose(c.base, np.eye(4)) and np.allclose(c.tool, np.eye(4))):
        raise MethodError(f"{model.name}: base/tool transforms are not supported by the study kernels")
    return np.ascontiguousarray(np.concatenate([c.a, c.alpha, c.d, c.theta_offset]), dtype=float)


def pack_dh_table(a, alpha, d, offset=None) -> np.ndarray:
    a = np.asarray(a, float)
    return np.ascontiguousarray(np.concatenate([a, np.asarray(alpha, float), np.asarray(d, float),
                                                np.zeros_like(a) if offset is None else np.asarray(offset, float)]))


def check_ur(model: RobotModel) -> None:
    """Raise MethodError unless the robot has the DH structure the UR closed form assumes."""
    c = model.chain
    ok = (c.n == 6 and np.allclose(c.alpha, UR_ALPHA, atol=UR_TOL) and np.allclose(c.a[[0, 3, 4, 5]], 0, atol=UR_TOL)
          and np.allclose(c.d[[1, 2]], 0, atol=UR_TOL) and np.allclose(c.theta_offset, 0, atol=UR_TOL)
          and abs(c.d[5]) > 0 and abs(c.a[1]) > 0 and abs(c.a[2]) > 0)
    if not ok:
        raise MethodError(f"{model.name}: not a UR-type DH table (alpha = π/2,0,0,π/2,-π/2,0; a1=a4=a5=a6=0; d2=d3=0)")


def analytic_solutions(model: RobotModel, T_goal: np.ndarray, q6_ref: float = 0.0, wrist_eps: float = 1e-10,
                       tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All 8 closed-form IK solutions of a UR-type robot, each checked by FK.

    Parameters
    ----------
    model : RobotModel                  UR-type DH table (see :func:`check_ur`), no base/tool
    T_goal : ndarray, shape (4, 4) [m]
    q6_ref : float [rad]                θ6 used where the wrist is singular (|sin θ5| < wrist_eps)
    tol : float                         FK check: |Δp| [m] and ‖ΔR‖_F both below tol

    Returns
    -------
    Q : ndarray, shape (8, 6) [rad]     branches (shoulder ±) × (wrist ±) × (elbow ±), wrapped to (-π, π];
                                        always finite (unreachable branches are clipped)
    valid : ndarray of bool, shape (8,) the FK check passed
    err : ndarray, shape (8, 2)         (|Δp| [m], ‖ΔR‖_F) of each branch

    Raises
    ------
    MethodError
        The robot is not UR-type.
    """
    check_ur(model)
    Q = np.empty((8, 6))
    valid = np.zeros(8, dtype=np.bool_)
    err = np.empty((8, 2))
    _jit.ur_ik_all(pack_dh(model), np.ascontiguousarray(T_goal, dtype=float), float(q6_ref), float(wrist_eps),
                   float(tol), float(tol), Q, valid, err)
    return Q, valid, err


def goal_vector(T_goal: np.ndarray) -> np.ndarray:
    """The document's ``target_pose`` 12-vector ``[p, R.flatten()]`` (row-major R)."""
    return np.ascontiguousarray(np.concatenate([T_goal[:3, 3], T_goal[:3, :3].ravel()]))


class Prepared:
    """A robot unpacked once per job for the kernels, plus the study's success tolerances."""

    def __init__(self, model: RobotModel, success_position: float, success_orientation: float):
        self.model = model
        self.dh = pack_dh(model)
        self.tol_pos = float(success_position)
        self.tol_rot = float(success_orientation)

    def verify(self, T_goal: np.ndarray, q: np.ndarray) -> tuple[bool, float, float]:
        """Independent numpy FK: (within the success tolerances, |dp| [m], angle [rad])."""
        T = fk_htm(self.model.chain, q)
        dp = float(np.linalg.norm(position_error(T_goal, T)))
        ang = float(orientation_error_angle(T_goal, T))
        ok = math.isfinite(dp) and math.isfinite(ang) and dp <= self.tol_pos and ang <= self.tol_rot
        return ok, dp, ang


def _trace_rows(dh: np.ndarray, goal: np.ndarray, xs, own) -> np.ndarray:
    """Trace (len(xs), 8): [own measure, e (6), |dp|] for each iterate."""
    out = np.empty((len(xs), _jit.TRACE_COLS))
    T = np.empty((4, 4))
    e = np.empty(6)
    for i, x in enumerate(xs):
        _jit.fk(dh, x, T)
        dp = _jit.pose_error(T, goal, e)
        out[i, 0] = own(x, e)
        out[i, 1:7] = e
        out[i, 7] = dp
    return out


def _stop_code(ok: bool, claimed: bool, q: np.ndarray, capped: bool) -> int:
    if not np.all(np.isfinite(q)):
        return 5
    if ok:
        return 1
    if claimed:
        return 6
    return 4 if capped else 2


def cost_params(cost: dict, goal: np.ndarray, dh: np.ndarray) -> np.ndarray:
    """Packed parameters of :func:`_jit.cost`: ``[w_p, w_R, squared, goal (12), dh]``."""
    return np.ascontiguousarray(np.concatenate([[cost["position_weight"], cost["rotation_weight"],
                                                 1.0 if cost.get("squared", False) else 0.0], goal, dh]))


def solve_point(name: str, cfg: dict, costs: dict, prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray,
                jac_dh: np.ndarray | None = None) -> PointResult:
    """Solve one point with method ``cfg`` (a ``study_settings.methods`` entry).

    Parameters
    ----------
    name : str                         method name (for messages)
    cfg : dict                         the method's settings (``kind`` + its constants)
    costs : dict                       ``study_settings.costs`` (weights of costs A and B)
    prep : Prepared
    T_goal : ndarray, shape (4, 4) [m]
    q_start : ndarray, shape (6,) [rad]   warm start (the previous point's solution)
    jac_dh : ndarray, shape (24,), optional
        Packed DH table of the Jacobian model for ``pinv_descent`` (default: the FK model).
    """
    kind = cfg["kind"]
    goal = goal_vector(T_goal)
    q0 = np.ascontiguousarray(q_start, dtype=float)
    dh = prep.dh
    if kind == "pinv_descent":
        cap = int(cfg["max_iterations"])
        q = np.empty_like(q0)
        trace = np.zeros((cap + 1, _jit.TRACE_COLS))
        jdh = dh if jac_dh is None else jac_dh
        t0 = time.perf_counter_ns()
        code, it = _jit.pinv_descent(dh, jdh, goal, q0, float(cfg["rate"]), float(cfg["tolerance"]), cap,
                                     float(cfg["rcond"]), q, trace)
        t1 = time.perf_counter_ns()
        code, it = int(code), int(it)
        ok, dp, ang = prep.verify(T_goal, q)
        claimed = code == _jit.SUCCESS
        stop = _stop_code(ok, claimed, q, code == _jit.ITERATION_CAP)
        ik = IKResult(q=q, success=ok, stop_reason=stop, iterations=it, trace=trace[: it + 1].copy(),
                      solve_time_s=(t1 - t0) * 1e-9, ik_time_s=(t1 - t0) * 1e-9, position_error=dp,
                      orientation_error=ang, claimed_success=claimed)
        msg = {1: "norm(e) < tolerance", 4: "iteration cap", 5: "non-finite"}.get(code, str(code))
        return PointResult(ik, nfev=it + 1, njev=it, doc_error=float(trace[it, 0]), message=msg)
    if kind == "scipy":
        from scipy.optimize import minimize

        cw = costs[cfg["cost"]]
        params = cost_params(cw, goal, dh)
        xs = [q0.copy()]

        def callback(xk):
            xs.append(np.array(xk, dtype=float))

        bounds = [tuple(b) for b in cfg["bounds"]] if cfg.get("bounds") else None
        options = dict(cfg.get("options", {}))
        t0 = time.perf_counter_ns()
        res = minimize(_jit.cost, q0, args=(params,), method=cfg["method"], bounds=bounds, callback=callback,
                       options=options)
        t1 = time.perf_counter_ns()
        q = np.asarray(res.x, dtype=float)
        ok, dp, ang = prep.verify(T_goal, q)
        claimed = bool(res.success)
        nit = int(res.nit)
        maxiter = options.get("maxiter")
        capped = maxiter is not None and nit >= int(maxiter)
        if maxiter is None:  # SciPy default 200 n for BFGS / Nelder-Mead
            capped = "maximum number of iterations" in str(res.message).lower()
        stop = _stop_code(ok, claimed, q, capped)
        trace = _trace_rows(dh, goal, xs, lambda x, e: float(_jit.cost(x, params)))
        ik = IKResult(q=q, success=ok, stop_reason=stop, iterations=nit, trace=trace,
                      solve_time_s=(t1 - t0) * 1e-9, ik_time_s=(t1 - t0) * 1e-9, position_error=dp,
                      orientation_error=ang, claimed_success=claimed)
        return PointResult(ik, nfev=int(res.nfev), njev=int(getattr(res, "njev", 0) or 0), doc_error=float(res.fun),
                           message=str(res.message))
    if kind == "analytic":
        q = np.empty(6)
        Q = np.empty((8, 6))
        valid = np.zeros(8, dtype=np.bool_)
        err = np.empty((8, 2))
        t0 = time.perf_counter_ns()
        nv, best = _jit.ur_ik_nearest(dh, np.ascontiguousarray(T_goal, dtype=float), q0, float(cfg["wrist_eps"]),
                                      float(cfg["verify_position"]), float(cfg["verify_rotation"]), q, Q, valid, err)
        t1 = time.perf_counter_ns()
        nv, best = int(nv), int(best)
        ok, dp, ang = prep.verify(T_goal, q)
        claimed = best >= 0
        stop = _stop_code(ok, claimed, q, False)
        trace = _trace_rows(dh, goal, [q0, q], lambda x, e: float(np.linalg.norm(e)))
        ik = IKResult(q=q, success=ok, stop_reason=stop, iterations=1, trace=trace,
                      solve_time_s=(t1 - t0) * 1e-9, ik_time_s=(t1 - t0) * 1e-9, position_error=dp,
                      orientation_error=ang, claimed_success=claimed)
        return PointResult(ik, nfev=8, njev=0, doc_error=float(trace[-1, 0]),
                           message=f"{nv} FK-verified solutions" if claimed else "no valid closed-form solution",
                           n_solutions=nv, branch=best)
    raise MethodError(f"method {name!r}: field 'kind': {kind!r} is not one of {', '.join(KINDS)}")


def warm_up(prep: Prepared, methods: dict, costs: dict, jac: dict) -> None:
    """Compile (or load cached machine code of) every kernel before any timed solve."""
    T = fk_htm(prep.model.chain, np.array([0.1, -1.0, 1.0, 1.5, 1.5, 0.3]))
    q0 = np.array([0.12, -1.02, 1.01, 1.49, 1.52, 0.31])
    for name, cfg in methods.items():
        solve_point(name, cfg, costs, prep, T, q0, jac.get(name))
