"""The fast path: lean kernels, the compiled FK check, bound solvers and the batch API.

Every fast piece is compared with the reference it replaces: the allocation-free kernels with
the numpy kinematics (the Jacobian loop against
000's loop written in numpy), the dual-quaternion FK check with the numpy
HTM check, batch results with one-at-a-time results (bit for bit), and batch results on one thread
with two threads. No timing is asserted here (see benchmarks/bench_fast.py).
"""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import Chain, fk_htm, geometric_jacobian
from pipeline.kinematics.fkcheck import check_model, pose_check
from pipeline.problems import random_joint_pairs, warm_start
from pipeline.solvers import bind, make_settings, prepare, solve, solve_batch
from pipeline.solvers.iterative import lean as _lean
from pipeline.solvers.core import pose_errors
from pipeline.solvers.iterative.jacobian import packed
from tests.conftest import random_chain, random_transform

TOL = 1e-12


def _general(rng: np.random.Generator, n: int) -> Chain:
    axes = rng.normal(size=(n, 3))
    origins = np.stack([random_transform(rng) for _ in range(n)])
    z = np.zeros(n)
    return Chain(z, z, z, z, rng.random(n) < 0.3, "general", random_transform(rng), random_transform(rng, 0.2),
                 origins=origins, axes=axes)


def _chain(seed: int, n: int, form: str) -> Chain:
    rng = np.random.default_rng(seed)
    return _general(rng, n) if form == "general" else random_chain(rng, n, form)


def _lean_args(c: Chain) -> tuple:
    if c.general:
        args = (c.origins[:, :3, :].ravel().copy(), c.axes.ravel().copy())
    else:
        args = (np.array(c.a, dtype=float), np.array(c.alpha, dtype=float))
    return _lean.lean_chain((*args, np.array(c.d, dtype=float), np.array(c.theta_offset, dtype=float),
                             np.array(c.prismatic, dtype=np.bool_), c.form_code, np.array(c.base, dtype=float),
                             np.array(c.tool, dtype=float)))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 8), form=st.sampled_from(["standard", "modified", "general"]))
def test_lean_fk_and_jacobian_match_numpy(seed, n, form):
    c = _chain(seed, n, form)
    q = np.random.default_rng(seed + 1).uniform(-np.pi, np.pi, n)
    axes, origins, T, C, J = np.empty((n, 3)), np.empty((n, 3)), np.eye(4), np.empty((3, 4)), np.empty((6, n))
    _lean.fk(*_lean_args(c), q, axes, origins, T, C)
    _lean._jacobian(np.array(c.prismatic, dtype=np.bool_), axes, origins, T, J)
    np.testing.assert_allclose(T, fk_htm(c, q), atol=100 * TOL)
    np.testing.assert_allclose(J, geometric_jacobian(c, q), atol=100 * TOL)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 8), form=st.sampled_from(["standard", "modified", "general"]))
def test_dual_quaternion_check_matches_the_numpy_check(seed, n, form):
    """The compiled check (dual quaternions) and the numpy one (matrices): same |dp|, angle and |t|."""
    c = _chain(seed, n, form)
    rng = np.random.default_rng(seed + 2)
    q = rng.uniform(-np.pi, np.pi, n)
    Tg = fk_htm(c, q + rng.normal(scale=0.3, size=n))
    got = pose_check(*check_model(c), q, Tg, np.empty(8))
    want = pose_errors(SimpleNamespace(chain=c), Tg, q)
    scale = 1.0 + np.abs(Tg[:3, 3]).max()
    np.testing.assert_allclose(got, want, atol=1e-12 * scale)


def test_check_of_non_finite_angles_is_nan(lwr):
    got = pose_check(*check_model(lwr.chain), np.full(7, np.nan), np.eye(4), np.empty(8))
    assert all(np.isnan(got))


def _numpy_step(method: str, J: np.ndarray, e: np.ndarray, s) -> np.ndarray:
    """The update of 000 §3 (eqs. 48-61) in numpy."""
    if method == "jacobian_transpose":
        g = J.T @ e
        jg = J @ g
        den = jg @ jg
        return (e @ jg / den if den > 0 else 0.0) * g
    if method in ("pseudoinverse", "dls"):
        lam = s.damping if method == "dls" else 0.0
        try:
            return J.T @ np.linalg.solve(J @ J.T + lam * lam * np.eye(6), e)
        except np.linalg.LinAlgError:
            return np.linalg.pinv(J) @ e
    U, S, Vt = np.linalg.svd(J, full_matrices=False)  # SDLS (Buss & Kim 2004), maxabs norm, one block
    rho = np.linalg.norm(J, axis=0)
    out = np.zeros(J.shape[1])
    for i in range(len(S)):
        if S[i] <= max(J.shape) * S[0] * np.finfo(float).eps:
            continue
        M = np.abs(Vt[i]) @ rho / S[i]
        gamma = s.gamma_max * min(1.0, np.linalg.norm(U[:, i]) / M)
        phi = (U[:, i] @ e / S[i]) * Vt[i]
        m = np.abs(phi).max()
        out += phi * (gamma / m) if m > gamma else phi
    m = np.abs(out).max()
    return out * (s.gamma_max / m) if m > s.gamma_max else out


def _numpy_loop(method: str, s, chain: Chain, Tg: np.ndarray, q0: np.ndarray):
    """000's loop (pipeline.solvers.iterative.jacobian, pos_orient criterion) on the numpy kinematics:
    (stop code, iterations, q, trace)."""
    from pipeline.kinematics.errors import orientation_error_angle, orientation_error_axis_angle, \
        orientation_error_quat_vec

    def error(T):
        o = (orientation_error_axis_angle(Tg, T) if s.orientation_error == "axis_angle"
             else s.orientation_gain * orientation_error_quat_vec(Tg, T))
        e = np.concatenate([Tg[:3, 3] - T[:3, 3], o])
        dp = np.linalg.norm(e[:3])
        return e, np.linalg.norm(e), dp, orientation_error_angle(Tg, T)

    q = q0.copy()
    T = fk_htm(chain, q)
    e, err, dp, ang = error(T)
    trace = [[err, *e, dp]]
    code, it, grew = 0, 0, 0
    if not np.isfinite(err):
        code = 5
    elif dp <= s.tol_pos and ang <= s.tol_rot:
        code = 1
    while code == 0:
        it += 1
        q = q + _numpy_step(method, geometric_jacobian(chain, q), e, s)
        Tprev, prev = T, err
        T = fk_htm(chain, q)
        e, err, dp, ang = error(T)
        trace.append([err, *e, dp])
        stalled = (np.linalg.norm(T[:3, 3] - Tprev[:3, 3]) < s.stall_pos
                   and orientation_error_angle(T, Tprev) < s.stall_rot)
        grew = grew + 1 if err > prev else 0
        code = (5 if not np.isfinite(err) else 1 if dp <= s.tol_pos and ang <= s.tol_rot else 2 if stalled
                else 3 if grew >= s.grow_limit else 4 if it >= s.max_iterations else 0)
    return code, it, q, np.array(trace)


@pytest.mark.parametrize("method", ["jacobian_transpose", "pseudoinverse", "dls", "sdls"])
def test_lean_loop_matches_the_numpy_loop_on_converging_problems(lwr, method):
    """Same stop code, iteration count and angles (to rounding) as 000's loop written with the numpy
    kinematics (:func:`_numpy_loop`), from warm starts: the compiled loop has no reference twin."""
    s = make_settings(method, {"max_iterations": 200})
    prep = prepare(method, lwr, s)
    sc = s.converted()
    ip, fp = packed(method, sc)
    chain = _lean.lean_chain(prep.args)
    ps = warm_start(lwr, 100, np.random.default_rng(3), spread=0.2)
    T = ps.goal_transforms()
    same = 0
    for i in range(len(ps)):
        Tg = prep.working_goal(T[i])
        q, trace, times = np.empty(7), np.zeros((201, 8)), np.zeros(3, np.int64)
        c1, i1 = _lean.solve(*chain, Tg, ps.q_start[i].copy(), ip, fp, q, trace, times)
        c2, i2, q2, t2 = _numpy_loop(method, sc, prep.model.chain, Tg, ps.q_start[i].copy())
        if method == "jacobian_transpose":  # its zigzag amplifies rounding: compare the first iterates
            k = min(i1, i2, 10) + 1
            same += np.allclose(trace[:k], t2[:k], rtol=1e-9, atol=1e-12)
        else:
            same += c1 == c2 and i1 == i2 and np.allclose(q, q2, atol=1e-9) and np.allclose(
                trace[:i1 + 1], t2, rtol=1e-6, atol=1e-12)
    assert same >= 98  # the rest: a tolerance met at one iteration by one evaluation order and not the other


@pytest.mark.parametrize("method", ["jacobian_transpose", "pseudoinverse", "dls", "sdls"])
def test_batch_equals_one_at_a_time_bit_for_bit(lwr, method):
    s = make_settings(method)
    prep = prepare(method, lwr, s)
    ps = random_joint_pairs(lwr, 60, np.random.default_rng(4))
    T = ps.goal_transforms()
    b = solve_batch(method, prep, T, ps.q_start, s, threads=2)
    assert len(b) == 60 and b.trace_offsets[-1] == len(b.trace_rows) == int((b.iterations + 1).sum())
    for i in range(len(ps)):
        r = solve(method, prep, T[i], ps.q_start[i], s)
        one = b.result(i)
        assert (r.stop_reason, r.iterations, r.success, r.within_limits) == (
            one.stop_reason, one.iterations, one.success, one.within_limits)
        assert np.array_equal(r.q, one.q) and np.array_equal(r.trace, one.trace)
        assert r.position_error == one.position_error


def test_batch_results_do_not_depend_on_the_thread_count(lwr):
    s = make_settings("dls")
    prep = prepare("dls", lwr, s)
    ps = random_joint_pairs(lwr, 300, np.random.default_rng(5))
    T = ps.goal_transforms()
    a = solve_batch("dls", prep, T, ps.q_start, s, threads=1)
    b = solve_batch("dls", prep, T, ps.q_start, s, threads=2)
    for f in ("q", "stop_reason", "iterations", "success", "position_error", "trace_rows", "trace_offsets"):
        assert np.array_equal(getattr(a, f), getattr(b, f), equal_nan=True), f


def test_batch_without_traces_keeps_the_outcomes(lwr):
    s = make_settings("dls")
    prep = prepare("dls", lwr, s)
    ps = random_joint_pairs(lwr, 40, np.random.default_rng(6))
    T = ps.goal_transforms()
    a = solve_batch("dls", prep, T, ps.q_start, s)
    b = solve_batch("dls", prep, T, ps.q_start, s, traces=False)
    assert b.trace_rows is None and b.trace(0).shape == (1, 8)
    assert np.array_equal(a.q, b.q) and np.array_equal(a.stop_reason, b.stop_reason)


@pytest.mark.parametrize("method,extra", [("levenberg_marquardt", {}), ("bfgs", {}), ("dls", {"require_limits": True}),
                                          ("dls", {"restarts": 2})])
def test_batch_of_a_method_without_a_batch_kernel_is_one_solve_per_problem(lwr, method, extra):
    s = make_settings(method, extra)
    prep = prepare(method, lwr, s)
    ps = warm_start(lwr, 12, np.random.default_rng(7), spread=0.3)
    T = ps.goal_transforms()
    b = solve_batch(method, prep, T, ps.q_start, s, seeds=np.arange(12) + 100)
    for i in range(12):
        r = solve(method, prep, T[i], ps.q_start[i], s, seed=100 + i)
        assert r.stop_reason == b.stop_reason[i] and np.allclose(r.q, b.q[i]), i


def test_batch_rejects_bad_shapes_in_one_line(lwr):
    from pipeline.solvers import SettingsError

    with pytest.raises(SettingsError, match=r"goals: expected shape \(N, 4, 4\)"):
        solve_batch("dls", lwr, np.eye(4), np.zeros((1, 7)))
    with pytest.raises(SettingsError, match=r"starts: expected shape \(2, 7\)"):
        solve_batch("dls", lwr, np.stack([np.eye(4)] * 2), np.zeros((2, 6)))


def test_binding_is_cached_per_settings_object(lwr):
    s, t = make_settings("dls"), make_settings("dls", {"damping": 0.2})
    prep = prepare("dls", lwr, s)
    assert bind("dls", prep, s) is bind("dls", prep, s)
    assert bind("dls", prep, t) is not bind("dls", prep, s)
    assert bind("dls", lwr, s) is not bind("dls", lwr, s)  # a bare model is prepared again each time


def test_a_replaced_run_without_bind_is_what_solve_calls(lwr):
    """``bind`` is only a faster ``run``: a solver registered without it runs ``run``."""
    from pipeline.solvers import Raw, get
    from pipeline.solvers.core import registry

    calls = []

    def run(prep, T_goal, q_start, settings, seed):
        calls.append(seed)
        return Raw(q=q_start.copy(), code=4, iterations=1, solve_ns=1)

    registry._REGISTRY["probe"] = replace(get("dls"), name="probe", run=run, bind=None, batch=None)
    try:
        solve("probe", lwr, np.eye(4), np.zeros(7), seed=3)
        solve_batch("probe", lwr, np.stack([np.eye(4)] * 2), np.zeros((2, 7)), seeds=[5, 6])
    finally:
        del registry._REGISTRY["probe"]
    assert calls == [3, 5, 6]
