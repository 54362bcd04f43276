"""The analytic solvers' fused public call (``Solver.bind_call``: analytic_ur, analytic_puma).

The fused call (kernel, independent FK check, limit record and result in one compiled call) must
return what the generic path (``bind`` + ``finish``) returns, bit for bit and with the same types,
timings aside: on random, singular, unreachable and non-finite poses, every success criterion, in m
and mm, with base/tool/offset variants. ``require_limits`` keeps the generic path. No timing
assertions (speed is measured by benchmarks/bench_fast.py only).
"""

from __future__ import annotations

import math
from dataclasses import fields, replace

import numpy as np
import pytest

from pipeline.solvers import Bound, SettingsError, bind, get, make_settings, prepare, solve
from pipeline.solvers.core import IKResult, check
from tests.solvers.closed_form.test_analytic_fast import CASES, _problems

TIMINGS = ("solve_time_s", "ik_time_s", "call_time_s", "cpu_time_s", "compiled", "compile_time_s")  # compiled: a first call
CRITERIA = ({}, {"criterion": "position"}, {"criterion": "dq_norm", "tol_dq": 1 + 1e-9},
            {"criterion": "dq_norm_body"}, {"tol_pos": 1e-15, "tol_rot": 1e-15})


def _generic(meth: str, prep, s) -> Bound:
    """The binding without the fused call: ``bind`` + ``finish``, the path the fused call replaces."""
    return Bound(replace(get(meth), bind_call=None), prep, s)


def _same(a, b) -> bool:
    """Equal values of equal types; arrays equal in shape, dtype, values (NaN = NaN) and sign bits."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return (type(a) is type(b) and a.shape == b.shape and a.dtype == b.dtype
                and np.array_equal(a, b, equal_nan=True) and np.array_equal(np.signbit(a), np.signbit(b)))
    if isinstance(a, dict):
        return type(b) is dict and list(a) == list(b) and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return type(a) is type(b) and a == b


def _inputs(model, n: int):
    G, S = _problems(model, n=n, seed=23)
    G, S = list(G), list(S)
    G += [np.full((4, 4), np.nan), G[0].copy(), np.asfortranarray(G[1]), G[2].tolist()]
    S += [np.zeros(6), np.full(6, np.nan), S[1].tolist(), S[2].astype(np.float32)]
    return G, S


@pytest.mark.parametrize("extra", CRITERIA, ids=lambda d: "-".join(f"{k}" for k in d) or "default")
@pytest.mark.parametrize("name", sorted(CASES))
def test_fused_call_equals_the_generic_path_bit_for_bit(name, extra):
    meth, model, sd = CASES[name]
    s = make_settings(meth, {**sd, **extra})
    prep = prepare(meth, model, s)
    fast, ref = bind(meth, prep, s), _generic(meth, prep, s)
    assert fast.fused is not None and ref.fused is None
    G, S = _inputs(model, 120)
    codes = set()
    for T, q0 in zip(G, S):
        a, b = solve(meth, prep, T, q0, s), ref.solve(T, q0)
        assert type(a) is IKResult
        for f in fields(IKResult):
            if f.name not in TIMINGS:
                assert _same(getattr(a, f.name), getattr(b, f.name)), (name, f.name)
        assert type(a.solve_time_s) is float and type(a.ik_time_s) is float and type(a.call_time_s) is float
        assert a.call_time_s >= a.solve_time_s > 0.0
        assert (a.ik_time_s == 0.0) == (meth == "analytic_ur")
        codes.add(a.stop_reason)
    assert {1, 5, 7} <= codes  # success, non-finite and no-solution outcomes all exercised
    assert fast.call is fast.fused  # once a call compiled nothing, the fused call is called straight


@pytest.mark.parametrize("name", ["ur5", "ur_variant", "puma560_mm"])
def test_fused_success_is_the_dual_quaternion_check(name):
    """position_error and success come from the independent compiled dual-quaternion FK
    (:func:`pipeline.solvers.core.finish`), never from the closed form's own kinematics."""
    meth, model, sd = CASES[name]
    s = make_settings(meth, sd)
    prep = prepare(meth, model, s)
    sc = s.converted()
    G, S = _problems(model, n=64, seed=5)
    for T, q0 in zip(G, S):
        r = solve(meth, prep, T, q0, s)
        ok, dp, ang = check(prep, prep.working_goal(T), r.q, sc)
        assert _same(r.position_error, dp) and _same(r.orientation_error, ang)
        assert r.success == (ok and r.claimed_success)


def test_require_limits_and_a_bare_model_keep_the_same_results():
    meth, model, sd = CASES["ur5"]
    s = make_settings(meth, {"require_limits": True})
    prep = prepare(meth, model, s)
    assert bind(meth, prep, s).fused is None  # the generic path chooses within the limits
    plain = make_settings(meth)
    G, S = _problems(model, n=24, seed=9)
    for T, q0 in zip(G, S):
        a, b = solve(meth, model, T, q0, {}), solve(meth, prepare(meth, model, plain), T, q0, plain)
        assert all(_same(getattr(a, f.name), getattr(b, f.name)) for f in fields(IKResult) if f.name not in TIMINGS)


@pytest.mark.parametrize("meth, robot", [("analytic_ur", "ur5"), ("analytic_puma", "puma560")])
def test_fused_call_rejects_a_bad_start_in_one_line(meth, robot):
    _, model, _ = CASES[robot]
    s = make_settings(meth)
    prep = prepare(meth, model, s)
    with pytest.raises(SettingsError, match=r"^q_start: expected shape \(6,\), got \(7,\)$"):
        solve(meth, prep, np.eye(4), np.zeros(7), s)


def test_fused_call_needs_bind():
    """A solver registered without ``bind`` runs ``run`` + ``finish`` even if it has a fused call."""
    from pipeline.solvers.core import registry

    meth, model, _ = CASES["ur5"]
    calls = []

    def run(prep, T_goal, q_start, settings, seed):
        calls.append(seed)
        return get(meth).run(prep, T_goal, q_start, settings, seed)

    registry._REGISTRY["probe_ur"] = replace(get(meth), name="probe_ur", run=run, bind=None)
    try:
        s = make_settings("probe_ur")
        prep = prepare("probe_ur", model, s)
        assert bind("probe_ur", prep, s).fused is None
        solve("probe_ur", prep, np.eye(4), np.zeros(6), s, seed=4)
    finally:
        del registry._REGISTRY["probe_ur"]
    assert calls == [4]
