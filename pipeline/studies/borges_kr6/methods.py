"""The three IK methods of 002_56eb235931bf5f5d.txt as calls returning :class:`pipeline.solvers.IKResult`.

Each call runs a compiled kernel (:mod:`.kernels`), then checks the returned angles with an
independent forward kinematics (numpy ``fk_htm``): ``success`` is True only when the kernel's stop
test claimed success *and* that FK puts the flange within ``success_tolerance_mm`` of the goal.
The goal is a position only (eq. 3): ``orientation_error`` is NaN.

Method settings are the mappings under ``study_settings.methods`` of data/studies/borges_kr6.yaml
(see workflow/schemas/studies/borges_kr6.schema.yaml for every key).
"""

from __future__ import annotations

import math

import numpy as np

from pipeline.kinematics import fk_htm
from pipeline.robots import RobotModel
from pipeline.solvers import IKResult
from pipeline.studies.borges_kr6 import kernels as K

METHODS = ("ji", "lm", "pso")
JI_ROWS = {"position_only": K.JI_ROWS_POSITION, "hold_orientation": K.JI_ROWS_HOLD}
LM_RESIDUALS = {"scalar": K.LM_SCALAR, "vector": K.LM_VECTOR}


class MethodError(ValueError):
    """A robot or method setting the kernels cannot take (one line)."""


class Prepared:
    """A robot unpacked once into the arrays the kernels take (standard DH only)."""

    def __init__(self, model: RobotModel):
        c = model.chain
        if c.convention != "standard" or bool(np.any(c.prismatic)):
            raise MethodError(f"{model.path}: the borges_kr6 kernels take revolute standard-DH chains only")
        self.model = model
        self.args = tuple(np.ascontiguousarray(x, dtype=float) for x in (c.a, c.alpha, c.d, c.theta_offset, c.base, c.tool))
        self.limits = np.ascontiguousarray(model.limits, dtype=float)


def _result(prep: Prepared, p_goal, q, code: int, iters: int, trace, times, tol_success: float,
            timing: dict | None = None) -> IKResult:
    p = fk_htm(prep.model.chain, q)[:3, 3]
    dp = float(np.linalg.norm(np.asarray(p_goal, float) - p))
    claimed = code == K.SUCCESS
    ok = math.isfinite(dp) and dp <= tol_success * (1 + 1e-9)
    if claimed and not ok:
        code = 6  # claimed success contradicted by forward kinematics
    if not np.all(np.isfinite(q)):
        code = K.NON_FINITE
    t = times[0] * 1e-9
    if timing is not None:
        timing["cpu_time_s"] = times[1] * 1e-9
    return IKResult(q=q, success=claimed and ok, stop_reason=int(code), iterations=int(iters),
                    trace=trace[: iters + 1].copy(), solve_time_s=t, ik_time_s=t, position_error=dp,
                    orientation_error=float("nan"), claimed_success=claimed)


def _buffers(n: int, max_iter: int):
    return np.empty(n), np.zeros((max_iter + 1, K.TRACE_COLS)), np.zeros(2, np.int64)


def solve_ji(prep: Prepared, p_goal, q_start, cfg: dict, common: dict, *, reach_mm: float | None = None,
             gain: float | None = None, max_iterations: int | None = None, timing: dict | None = None) -> IKResult:
    """Inverse Jacobian (eqs. 5-6).

    Parameters
    ----------
    p_goal : ndarray, shape (3,) [mm]
    q_start : ndarray, shape (6,) [rad]
    cfg : dict
        ``methods.ji`` settings: alpha, delta_rad, orientation_rows, max_iterations.
    common : dict
        ``success_tolerance_mm``, ``error_change_stop_mm``.
    reach_mm : float, optional
        Table 2 mode: stop as soon as e < reach_mm (instead of the error-change stop).
    gain : float, optional
        Overrides ``cfg["alpha"]`` (the alpha sweep).
    timing : dict, optional
        Receives ``cpu_time_s`` (thread CPU time of the solve) when given (same for every method).
    """
    n = prep.model.n
    mi = int(max_iterations or cfg["max_iterations"])
    q, trace, times = _buffers(n, mi)
    rule = K.STOP_REACH if reach_mm is not None else K.STOP_CHANGE
    code, it = K.ji_solve(*prep.args, np.asarray(p_goal, float), np.asarray(q_start, float),
                          float(cfg["alpha"] if gain is None else gain), float(cfg["delta_rad"]),
                          JI_ROWS[cfg["orientation_rows"]], rule, float(reach_mm or 0.0),
                          float(common["error_change_stop_mm"]), float(common["success_tolerance_mm"]), mi,
                          q, trace, times)
    tol = reach_mm if reach_mm is not None else common["success_tolerance_mm"]
    return _result(prep, p_goal, q, code, it, trace, times, float(tol), timing)


def solve_lm(prep: Prepared, p_goal, q_start, cfg: dict, common: dict, timing: dict | None = None) -> IKResult:
    """Levenberg-Marquardt (eqs. 7-8, MRPT defaults); ``cfg`` = ``methods.lm`` settings."""
    n = prep.model.n
    mi = int(cfg["max_iterations"])
    q, trace, times = _buffers(n, mi)
    code, it = K.lm_solve(*prep.args, np.asarray(p_goal, float), np.asarray(q_start, float),
                          LM_RESIDUALS[cfg["residual"]], float(cfg["increment_rad"]), mi, float(cfg["tau"]),
                          float(cfg["e1"]), float(cfg["e2"]), float(cfg["min_shrink"]),
                          float(common["error_change_stop_mm"]), float(common["success_tolerance_mm"]),
                          q, trace, times)
    return _result(prep, p_goal, q, code, it, trace, times, float(common["success_tolerance_mm"]), timing)


def solve_pso(prep: Prepared, p_goal, bounds, cfg: dict, common: dict, seed: int, timing: dict | None = None) -> IKResult:
    """Particle swarm (eqs. 9-11, pso-cpp defaults).

    Parameters
    ----------
    bounds : ndarray, shape (6, 2) [rad]
        Search box (the joint limits, or a window around the previous path solution).
    seed : int
        Seed of this run's stream (derive it with :func:`run_seed`).
    """
    n = prep.model.n
    mi = int(cfg["max_iterations"])
    q, trace, times = _buffers(n, mi)
    b = np.asarray(bounds, float)
    if np.any(b[:, 0] >= b[:, 1]):
        raise MethodError("PSO bounds: every lower bound must be below its upper bound (as pso-cpp requires)")
    code, it = K.pso_solve(*prep.args, np.asarray(p_goal, float), np.ascontiguousarray(b[:, 0]),
                           np.ascontiguousarray(b[:, 1]), int(cfg["particles"]), float(cfg["inertia"]),
                           float(cfg["c1"]), float(cfg["c2"]), float(cfg["max_velocity"]), float(cfg["feps"]),
                           float(cfg["xeps"]), mi, int(seed), float(common["success_tolerance_mm"]),
                           q, trace, times)
    return _result(prep, p_goal, q, code, it, trace, times, float(common["success_tolerance_mm"]), timing)


def method_config(settings: dict, method: str) -> tuple[str, dict]:
    """(kind, settings) of a method name: ``ji``, ``lm``, ``pso`` or a key of ``methods.pso_variants``
    (a PSO whose settings are ``methods.pso`` overridden by the variant's entries).

    Raises
    ------
    MethodError
        Unknown method name.
    """
    mcfg = settings["methods"]
    if method in METHODS:
        return method, mcfg[method]
    variants = mcfg.get("pso_variants", {}) or {}
    if method in variants:
        over = {k: v for k, v in variants[method].items() if k != "problem_sets"}
        return "pso", {**mcfg["pso"], **over}
    raise MethodError(f"unknown method {method!r} (have: {', '.join(all_methods(settings))})")


def all_methods(settings: dict) -> tuple[str, ...]:
    """The three methods of the document, then the PSO sensitivity variants of the settings."""
    return METHODS + tuple((settings["methods"].get("pso_variants") or {}).keys())


def variant_sets(settings: dict, method: str) -> tuple[str, ...]:
    """Problem sets a method runs on among points and paths (a variant's ``problem_sets``, else both)."""
    over = (settings["methods"].get("pso_variants") or {}).get(method, {})
    return tuple(over.get("problem_sets", ("points", "paths")))


def run_seed(rng: np.random.Generator) -> int:
    """A 31-bit seed for one PSO run's compiled generator, drawn from an explicit numpy Generator."""
    return int(rng.integers(0, 2**31 - 1))


def window_bounds(limits: np.ndarray, q_prev: np.ndarray, half_width: float) -> np.ndarray:
    """Path-mode PSO search box: ``q_prev +- half_width`` intersected with the joint limits, (n, 2) [rad]."""
    lo = np.maximum(limits[:, 0], q_prev - half_width)
    hi = np.minimum(limits[:, 1], q_prev + half_width)
    return np.stack([lo, hi], axis=1)


def warm_up(prep: Prepared, cfg: dict, common: dict) -> None:
    """Compile (or load from the on-disk cache) every kernel before the first timed solve."""
    q0 = np.zeros(prep.model.n)
    p = fk_htm(prep.model.chain, q0 + 0.1)[:3, 3]
    solve_ji(prep, p, q0, cfg["ji"], common)
    solve_ji(prep, p, q0, cfg["ji"], common, reach_mm=0.01)
    solve_lm(prep, p, q0, cfg["lm"], common)
    small = dict(cfg["pso"], max_iterations=3)
    solve_pso(prep, p, prep.limits, small, common, 1)
