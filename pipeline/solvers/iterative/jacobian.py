"""Jacobian transpose, pseudoinverse, DLS and SDLS (000_7e3cb7ad5ee98ff0.txt §3, eqs. 47-61).

One compiled loop serves the four methods (:func:`pipeline.solvers.iterative.lean.solve`, allocation-free;
its batch form runs on every core);
each is registered under its own name with the settings it uses. The stop rules are the document's:
success (code 1), pose change below the stall threshold (2), error grew ``grow_limit`` times in a
row (3), iteration cap (4), non-finite value (5).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

import pipeline.solvers.kernels.pose as _jit
import pipeline.solvers.iterative.lean as _lean
from pipeline.solvers.kernels.kin import SEARCH_LIMITS, TRACE_COLS
from pipeline.solvers.core import (CRITERION_CODE, BatchRaw, IKResult, Prepared, Raw, Settings, SettingsError,
                                   check_pack, fused_inputs, search_limits_setting, setting)
from pipeline.solvers.core import fixed
from pipeline.solvers.core.driver import run_of
from pipeline.solvers.core.timing import clock_ns
from pipeline.solvers.core.registry import Solver, register

SOURCE = "000_7e3cb7ad5ee98ff0.txt (Cerbaro 2019) §3"


@dataclass(frozen=True)
class JacobianSettings(Settings):
    """Settings of the Jacobian-transpose loop (and the base of the other three)."""

    max_iterations: int = setting(500, "stop code 4 after this many iterations", minimum=1, maximum=10_000_000)
    grow_limit: int = setting(5, "stop code 3 after the error grew this many iterations in a row", minimum=1)
    orientation_error: str = setting("quat_vec", "angular half of the error 6-vector: orientation_gain * "
                                     "vec(q_goal q*) or the rotation vector", choices=("quat_vec", "axis_angle"))
    orientation_gain: float = setting(1.0, "gain on vec(q_goal q*) (quat_vec only)", minimum=0.0)
    stall_dq: float = setting(1 + 1e-12, "stall (code 2) when the DQ norm of the pose change is below this "
                              "(dq_norm criteria)", minimum=1.0)
    stall_pos: float = setting(1e-9, "stall when the position moves less than this ... (pos_orient)", unit="m",
                               minimum=0.0, length=True)
    stall_rot: float = setting(1e-9, "... and the orientation less than this (pos_orient)", unit="rad", minimum=0.0)
    disable_stall: bool = setting(False, "turn stop code 2 off (the Table 16 rerun of 000)")
    disable_grow: bool = setting(False, "turn stop code 3 off (the Table 16 rerun of 000)")
    time_ik_block: bool = setting(False, "read the clock around every update step to record ik_time_s (two clock "
                                  "reads per iteration, about 40 ns of a ~550 ns iteration); off (default): "
                                  "ik_time_s = 0. cerbaro2019 turns it on for its IK-block times (Figure 21)")
    search_limits: str = search_limits_setting()
    fixed_joints: tuple = fixed.fixed_joints_setting()


@dataclass(frozen=True)
class NewtonSettings(JacobianSettings):
    """Pseudoinverse, DLS and SDLS: the rotation vector by default (a full Newton step on orientation;
    000's vec(q_goal q*) halves it, so they converge linearly: 9 iterations instead of 3 at the median
    of 500 warm starts, and 97.8 % instead of 99.6 % for the pseudoinverse on the UR5)."""

    orientation_error: str = setting("axis_angle", "angular half of the error 6-vector: the rotation vector, or "
                                     "orientation_gain * vec(q_goal q*) (000's choice)", choices=("quat_vec", "axis_angle"))


@dataclass(frozen=True)
class DLSSettings(NewtonSettings):
    damping: float = setting(0.01, "damping lambda of J^T (J J^T + lambda^2 I)^-1 (in the units of J: "
                             "length_unit and rad; 000 uses 0.1)", minimum=0.0)


@dataclass(frozen=True)
class SDLSSettings(NewtonSettings):
    gamma_max: float = setting(3 * math.pi / 2, "maximum joint step", unit="rad", above=0.0)
    sdls_norm: str = setting("maxabs", "norm of the SDLS clamps (Buss's code: maxabs; 000 §3 text: one)",
                             choices=("maxabs", "one", "two"))
    sdls_blocks: int = setting(1, "end-effector blocks: 1 = the 6-vector as one, 2 = position and orientation",
                               choices=(1, 2))


def packed(method: str, s: JacobianSettings, limits: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The kernel's integer and float parameter vectors (settings already in the working unit).

    Parameters
    ----------
    method : str
        One of :data:`pipeline.solvers.kernels.pose.METHODS`.
    s : JacobianSettings
        Settings in the working unit.
    limits : ndarray, shape (n, 2) [rad | working length unit], optional
        The joint limits (+-inf where none); needed when ``s.search_limits`` is not ``off``, and then
        appended to the float vector.

    Returns
    -------
    ip : ndarray, shape (N_IP,) of int64
    fp : ndarray, shape (N_FP,) or (N_FP + 2 n,)
    """
    ip = np.zeros(_jit.N_IP, np.int64)
    lim = SEARCH_LIMITS.index(getattr(s, "search_limits", "off"))
    ip[_jit.I_LIMITS] = lim
    fp = np.zeros(_jit.N_FP if lim == 0 else _jit.N_FP + 2 * len(limits))
    if lim:
        fp[_jit.N_FP:] = np.concatenate([limits[:, 0], limits[:, 1]])
    ip[_jit.I_METHOD] = _jit.METHODS[method]
    ip[_jit.I_MAX_ITER] = s.max_iterations
    ip[_jit.I_CRITERION] = CRITERION_CODE[s.criterion]  # position: pos_orient's tests, tol_rot = inf
    ip[_jit.I_ORIENT] = _jit.ORIENT_ERRORS[s.orientation_error]
    ip[_jit.I_GROW_LIMIT] = s.grow_limit
    ip[_jit.I_SDLS_NORM] = _jit.NORMS[getattr(s, "sdls_norm", "maxabs")]
    ip[_jit.I_SDLS_BLOCKS] = getattr(s, "sdls_blocks", 1)
    ip[_jit.I_NO_STALL] = int(s.disable_stall)
    ip[_jit.I_NO_GROW] = int(s.disable_grow)
    ip[_jit.I_TIME_IK] = int(s.time_ik_block)
    fp[_jit.F_LAMBDA] = getattr(s, "damping", 0.0)
    fp[_jit.F_GAMMA_MAX] = getattr(s, "gamma_max", 0.0)
    fp[_jit.F_TOL_DQ] = s.tol_dq
    fp[_jit.F_STALL_DQ] = s.stall_dq
    fp[_jit.F_TOL_POS] = s.tol_pos
    fp[_jit.F_TOL_ROT] = math.inf if s.criterion == "position" else s.tol_rot
    fp[_jit.F_STALL_POS] = s.stall_pos
    fp[_jit.F_STALL_ROT] = math.inf if s.criterion == "position" else s.stall_rot
    fp[_jit.F_ORIENT_GAIN] = s.orientation_gain
    return ip, fp


def _bind(method: str):
    def bind(prep: Prepared, s: JacobianSettings):
        if s.fixed_joints:  # the held joints folded into the links: the loop never moves them
            return fixed.bind_held(prep, s, bind)
        ip, fp = packed(method, s, prep.limits)
        chain = prep.memo("lean_chain", lambda: _lean.lean_chain(prep.args))
        rows = s.max_iterations + 1
        kernel = _lean.solve

        def run1(T_goal: np.ndarray, q_start: np.ndarray, seed: int) -> Raw:
            q = np.empty_like(q_start)
            trace = np.empty((rows, TRACE_COLS))
            times = np.zeros(2, np.int64)  # two slots: no thread-CPU clock (a system call each read, ~0.45 us)
            code, iters = kernel(*chain, T_goal, q_start, ip, fp, q, trace, times)
            return Raw(q=q, code=code, iterations=iters, solve_ns=int(times[0]), trace=trace[: iters + 1].copy(),
                       ik_ns=int(times[1]))

        return run1

    return bind


def _bind_call(method: str):
    def bind_call(prep: Prepared, s: JacobianSettings):
        """The public single call fused (``Solver.bind_call``): the loop, the independent FK check and the
        limit record in one compiled call (:func:`pipeline.solvers.iterative.lean.solve_checked`), the result
        built positionally; None with ``fixed_joints`` (the generic path runs the folded arm). Same values as
        ``bind`` + :func:`~pipeline.solvers.core.finish`, ``require_limits`` included, timings aside; with
        ``restarts`` the driver restarts from its result when it failed."""
        if s.fixed_joints:
            return None
        req = int(bool(s.require_limits))
        ip, fp = packed(method, s, prep.limits)
        # the per-bind inputs in two own arrays (writable, C-contiguous: the kernel's one signature)
        K, F = _lean.pack_checked(prep.memo("lean_chain", lambda: _lean.lean_chain(prep.args)), ip, fp,
                                  check_pack(prep, s), req)
        kernel, inputs = _lean.checked_call(), fused_inputs(prep)
        n, rows, unit, pos_only = prep.n, s.max_iterations + 1, prep.unit, s.criterion == "position"
        scaled = prep.goal_scale != 1.0
        empty, nan = np.empty, math.nan

        def make(on_failure):
            """The call; with ``on_failure`` (the driver's restarts, ``on_failure(res, T_goal, q_start, seed,
            t0)``) one that hands a failed search's result on itself, a Python frame less than a wrapper."""

            def call(T_goal: np.ndarray, q_start: np.ndarray, seed: int, t0: int) -> IKResult:
                q, trace = empty(n), empty((rows, TRACE_COLS))
                # the goal in the working unit (a copy, the shapes checked) when the robot file's unit is not
                Tg, q0 = inputs(T_goal, q_start) if scaled else (T_goal, q_start)
                try:  # the caller's arrays as they are when C-contiguous float64 (the kernel writes into neither)
                    code, it, claimed, success, dp, ang, inside, ns, ik_ns = kernel(K, F, Tg, q0, q, trace)
                except TypeError:  # anything else: converted as every solver's inputs are (a wrong shape: SettingsError)
                    Tg, q0 = (Tg, q0) if scaled else inputs(T_goal, q_start)
                    code, it, claimed, success, dp, ang, inside, ns, ik_ns = kernel(
                        K, F, np.array(Tg, order="C"), np.array(q0, order="C"), q, trace)
                if code < 0:  # a shape the kernel refused
                    inputs(T_goal, q_start)
                    raise SettingsError(f"T_goal / q_start: expected shapes (4, 4) and ({n},)")
                res = IKResult(q, success, code, it, trace[:it + 1].copy(), ns * 1e-9, ik_ns * 1e-9, dp,
                               nan if pos_only else ang, claimed, inside, nan, unit, None, {})
                res.call_time_s = (clock_ns() - t0) * 1e-9
                if success or on_failure is None:
                    return res
                return on_failure(res, T_goal, q_start, seed, t0)  # the caller's goal and start, as given

            call.on_failure = make
            return call

        return make(None)

    return bind_call


TRACE_BUDGET = 64 * 2**20  # [bytes] per chunk of a batch's trace buffer (N x (max_iterations + 1) x 8 floats)


def _batch(method: str):
    def batch(prep: Prepared, s: JacobianSettings, goals: np.ndarray, starts: np.ndarray, seeds, keep_traces: bool):
        if s.fixed_joints:  # one call per problem (:func:`_bind`)
            return None
        ip, fp = packed(method, s, prep.limits)
        chain = prep.memo("lean_chain", lambda: _lean.lean_chain(prep.args))
        N, n = starts.shape
        rows = s.max_iterations + 1 if keep_traces else 1
        chunk = max(1, min(N, TRACE_BUDGET // (rows * TRACE_COLS * 8)))
        Q = np.empty((N, n))
        codes = np.zeros(N, np.int64)
        iters = np.zeros(N, np.int64)
        times = np.zeros((N, 3), np.int64)
        parts, counts = [], []
        for lo in range(0, N, chunk):
            hi = min(N, lo + chunk)
            # written once here, outside the timed solves: a first write inside them faults in a 2 MiB huge
            # page (numpy madvises large arrays) every 65 problems, ~170 µs on one solve's CPU time (issue 45)
            buf = np.full((hi - lo, rows, TRACE_COLS), np.nan)
            _lean.solve_batch(*chain, goals[lo:hi], starts[lo:hi], ip, fp, Q[lo:hi], codes[lo:hi], iters[lo:hi],
                              times[lo:hi], buf)
            if keep_traces:
                k = iters[lo:hi] + 1
                parts.append(buf[np.arange(hi - lo).repeat(k), _ragged_index(k)])
                counts.append(k)
        rows_out = offsets = None
        if keep_traces:
            rows_out = np.concatenate(parts) if parts else np.empty((0, TRACE_COLS))
            offsets = np.concatenate([[0], np.cumsum(np.concatenate(counts))]).astype(np.int64)
        return BatchRaw(q=Q, code=codes, iterations=iters, solve_ns=times[:, 0], ik_ns=times[:, 1],
                        cpu_ns=times[:, 2],
                        trace_rows=rows_out, trace_offsets=offsets)

    return batch


def _ragged_index(k: np.ndarray) -> np.ndarray:
    """0..k[0]-1, 0..k[1]-1, ... concatenated."""
    total = int(k.sum())
    starts = np.repeat(np.cumsum(k) - k, k)
    return np.arange(total) - starts


for _name, _title, _cls in (
    ("jacobian_transpose", "Jacobian transpose with the adaptive step of eq. 48", JacobianSettings),
    ("pseudoinverse", "Jacobian pseudoinverse J^T (J J^T)^-1 e (eq. 49; SVD pseudoinverse when singular)", NewtonSettings),
    ("dls", "damped least squares J^T (J J^T + lambda^2 I)^-1 e (eq. 50)", DLSSettings),
    ("sdls", "selectively damped least squares (Buss & Kim 2004; eqs. 56-61)", SDLSSettings),
):
    _b = _bind(_name)
    register(Solver(_name, _title, "local", _cls, run_of(_b), source=SOURCE, bind=_b, batch=_batch(_name),
                    bind_call=_bind_call(_name)))
