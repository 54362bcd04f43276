"""The analytic solvers' lean single call and batch kernel (analytic_ur, analytic_puma).

Batch == single call on random, unreachable and singular poses (UR5, UR10, a UR variant with base,
tool and offsets, the PUMA 560 in m and mm, a PUMA variant); results independent of the thread
count; every returned solution passes an independent FK check. No timing assertions.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from pipeline.kinematics import fk_htm
from pipeline.robots import load_robot, parse_robot
from pipeline.solvers import make_settings, prepare, solve, solve_batch
from pipeline.solvers.closed_form.analytic_puma import run as puma_run
from pipeline.solvers.closed_form.analytic_ur import run as ur_run
from pipeline.solvers.core import StopReason, pose_errors
from tests.conftest import DATA, random_transform

ROBOTS = DATA / "robots"


def _variant(name: str, rng, unit: str, base_scale: float, tool_scale: float, a6: float = 0.0, al6: float = 0.0):
    c = load_robot(ROBOTS / f"{name}.yaml").chain
    offs = rng.uniform(-1, 1, 6)
    joints = [{"type": "revolute", "a": float(c.a[i]), "alpha": float(c.alpha[i]), "d": float(c.d[i]),
               "theta_offset": float(offs[i])} for i in range(6)]
    if name == "ur5e":
        joints[1]["d"], joints[2]["d"] = 0.03, -0.02  # a shoulder offset split over d2, d3
    if a6:
        joints[5]["a"], joints[5]["alpha"] = a6, al6
    return parse_robot({"name": f"{name}_variant", "source": "test", "length_unit": unit, "convention": "standard",
                        "joints": joints, "base": random_transform(rng, base_scale).tolist(),
                        "tool": random_transform(rng, tool_scale).tolist()})


def _cases():
    rng = np.random.default_rng(17)
    return {
        "ur5": ("analytic_ur", load_robot(ROBOTS / "ur5.yaml"), {}),
        "ur10": ("analytic_ur", load_robot(ROBOTS / "ur10.yaml"), {"wrist_eps": 1e-8}),
        "ur_variant": ("analytic_ur", _variant("ur5e", rng, "m", 0.5, 0.1), {}),
        "ur5_mm": ("analytic_ur", load_robot(ROBOTS / "ur5.yaml"), {"length_unit": "mm", "tol_pos": 1e-6}),
        "puma560": ("analytic_puma", load_robot(ROBOTS / "puma560.yaml"), {}),
        "puma560_mm": ("analytic_puma", load_robot(ROBOTS / "puma560.yaml"),
                       {"length_unit": "mm", "tol_pos": 1e-9, "tol_rot": 1e-8}),
        "puma_variant": ("analytic_puma", _variant("puma560", rng, "mm", 300.0, 50.0, 12.0, 0.3),
                         {"tol_pos": 1e-9, "tol_rot": 1e-8}),
    }


CASES = _cases()


def _problems(model, n: int = 240, seed: int = 3):
    """Goals and starts in the robot file's unit: random, wrist singular (sin theta5 = 0) and nearly so,
    stretched elbow, out of reach, at the base origin, and starts near, far from and at the goal angles."""
    rng = np.random.default_rng(seed)
    offs = np.asarray(model.chain.theta_offset, dtype=float)
    G, S = [], []
    for k in range(n):
        q = rng.uniform(-np.pi, np.pi, 6)
        kind = k % 8
        if kind == 1:
            q[4] = -offs[4]
        elif kind == 2:
            q[4] = -offs[4] + rng.choice([1e-13, 1e-11, 1e-9, np.pi])
        elif kind == 3:
            q[2] = -offs[2]
        T = fk_htm(model.chain, q)
        if kind == 4:
            T[:3, 3] *= 3.0
        elif kind == 5:
            T[:3, 3] = model.chain.base[:3, 3]
        start = {6: rng.uniform(-np.pi, np.pi, 6), 7: q.copy()}.get(kind, q + rng.normal(scale=0.3, size=6))
        G.append(T)
        S.append(start)
    return np.array(G), np.array(S)


def _same_info(a: dict, b: dict) -> bool:
    """Equal dicts (keys in the same order), NaN equal to NaN."""
    return list(a) == list(b) and all(a[k] == b[k] or (isinstance(a[k], float) and isinstance(b[k], float)
                                                       and math.isnan(a[k]) and math.isnan(b[k])) for k in a)


def _same(a, b):
    """Equal arrays, NaN where the other has NaN."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and np.array_equal(a, b, equal_nan=True)


@pytest.fixture(scope="module", params=sorted(CASES))
def case(request):
    meth, model, sd = CASES[request.param]
    s = make_settings(meth, sd)
    prep = prepare(meth, model, s)
    G, S = _problems(model)
    return meth, model, s, prep, G, S


def test_batch_equals_single_call(case):
    meth, model, s, prep, G, S = case
    b = solve_batch(meth, prep, G, S, s)
    assert len(b) == len(G) and b.solutions.shape == (len(G), 8, 6)
    codes = set()
    for i in range(len(G)):
        r = solve(meth, prep, G[i], S[i], s)
        ri = b.result(i)
        codes.add(r.stop_reason)
        assert ri.stop_reason == r.stop_reason and ri.success == r.success
        assert _same(ri.q, r.q)
        assert _same(ri.solutions, r.solutions)
        assert _same(ri.trace, r.trace)
        assert ri.position_error == r.position_error or (math.isnan(ri.position_error) and math.isnan(r.position_error))
        assert _same_info(ri.info, r.info)
        assert ri.iterations == r.iterations and ri.within_limits == r.within_limits
        assert int(b.n_solutions[i]) == len(r.solutions)
        assert np.isnan(b.solutions[i, len(r.solutions):]).all()
    assert {int(StopReason.SUCCESS), int(StopReason.NO_SOLUTION)} == codes  # both outcomes are exercised


def test_batch_without_traces(case):
    meth, model, s, prep, G, S = case
    full = solve_batch(meth, prep, G, S, s)
    lean = solve_batch(meth, prep, G, S, s, traces=False)
    assert lean.trace_rows is None
    assert _same(lean.q, full.q) and _same(lean.solutions, full.solutions)
    assert np.array_equal(lean.stop_reason, full.stop_reason)
    assert all(_same_info(x, y) for x, y in zip(lean.info, full.info))  # UR: doc_error needs no start row


def test_thread_count_does_not_change_results(case):
    meth, model, s, prep, G, S = case
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("one numba thread available")
    one = solve_batch(meth, prep, G, S, s, threads=1)
    two = solve_batch(meth, prep, G, S, s, threads=2)
    for f in ("q", "stop_reason", "solutions", "n_solutions", "position_error", "orientation_error"):
        assert _same(getattr(one, f), getattr(two, f)), f
    if one.trace_rows is not None:
        assert _same(one.trace_rows, two.trace_rows)
    assert all(_same_info(x, y) for x, y in zip(one.info, two.info))


def test_every_returned_solution_passes_fk(case):
    """Every solution the UR returns, and every one the PUMA flags valid, meets the settings' test by
    the numpy reference FK; success implies the chosen angles are among them."""
    meth, model, s, prep, G, S = case
    b = solve_batch(meth, prep, G, S, s)
    sc = s.converted()
    tol_pos = sc.verify_position if meth == "analytic_ur" else sc.tol_pos
    tol_rot = sc.verify_rotation if meth == "analytic_ur" else sc.tol_rot
    Gw = G.copy()
    Gw[:, :3, 3] *= prep.goal_scale
    checked = 0
    for i in range(len(G)):
        info = b.info[i]
        sols = b.solutions[i, : int(b.n_solutions[i])]
        flags = info["valid"] if meth == "analytic_puma" else "1" * len(sols)
        for qs, ok in zip(sols, flags):
            if ok != "1":
                continue
            dp, ang, _ = pose_errors(prep.model, Gw[i], qs)
            assert dp <= 10 * tol_pos and ang <= 10 * tol_rot
            checked += 1
        if b.success[i]:
            d = np.abs((sols - b.q[i] + np.pi) % (2 * np.pi) - np.pi).max(axis=1)
            assert d.min() < 1e-12
    assert checked > len(G)


def test_run_keeps_working_and_matches_the_public_call():
    """``run(prep, T, q0, settings, seed)`` (working-unit goal, converted settings) = the public call's raw result."""
    for name, fn in (("ur5_mm", ur_run), ("puma560_mm", puma_run)):
        meth, model, sd = CASES[name]
        s = make_settings(meth, sd)
        prep = prepare(meth, model, s)
        G, S = _problems(model, n=16)
        for i in range(len(G)):
            Tw = prep.working_goal(G[i])
            raw = fn(prep, Tw, S[i], s.converted(), 0)
            r = solve(meth, prep, G[i], S[i], s)
            assert _same(raw.q, r.q) and _same(raw.solutions, r.solutions) and _same_info(raw.info, r.info)


def test_ur_single_call_info_and_trace():
    meth, model, sd = CASES["ur5"]
    s = make_settings(meth, sd)
    q = np.array([0.3, -1.1, 1.4, -0.6, 0.9, 2.0])
    r = solve(meth, model, fk_htm(model.chain, q), q + 0.05, s)
    assert r.success and r.iterations == 1 and r.trace.shape == (2, 8)
    assert set(r.info) == {"n_solutions", "branch", "nfev", "njev", "doc_error", "message"}
    assert r.info["n_solutions"] == len(r.solutions) == 8 and r.info["doc_error"] == r.trace[1, 0] < 1e-12
    assert np.abs(r.q - q).max() < 1e-9 and r.trace[0, 7] > 0
    far = fk_htm(model.chain, q)
    far[:3, 3] *= 5
    r = solve(meth, model, far, q, s)
    assert r.stop_reason == StopReason.NO_SOLUTION and np.array_equal(r.q, q) and len(r.solutions) == 0
    assert r.info["branch"] == -1 and r.info["message"] == "no valid closed-form solution"
    assert np.array_equal(r.trace[0], r.trace[1])


def test_puma_single_call_info():
    meth, model, sd = CASES["puma560_mm"]
    s = make_settings(meth, sd)
    q = np.array([0.3, -0.7, 0.4, 1.1, 0.8, -2.0])
    r = solve(meth, model, fk_htm(model.chain, q), q, s)
    i = r.info
    assert r.success and i["solutions_found"] == i["solutions_valid"] == i["distinct_branches"] == 8
    assert i["branches"] == "+++ ++- +-+ +-- -++ -+- --+ ---" and i["valid"] == "11111111"
    assert i["degenerate_wrist"] == 0 and 0 <= i["max_position_error"] < 1e-6 and i["chosen"] >= 0
    assert np.array_equal(r.q, r.solutions[i["chosen"]])
    qd = q.copy()
    qd[4] = 0.0  # wrist degeneracy of this arm/elbow pair: theta4 := 0 in both its solutions, flagged d
    r = solve(meth, model, fk_htm(model.chain, qd), qd, s)
    words = r.info["branches"].split()
    deg = [k for k, w in enumerate(words) if w.endswith("d")]
    assert r.success and r.info["degenerate_wrist"] == len(deg) == 2 and r.info["chosen"] in deg
    assert np.all(r.solutions[deg, 3] == 0.0)


@pytest.mark.parametrize("robot", ["abb_irb2400", "puma560", "franka_panda"])
def test_fused_call_takes_any_array_form_and_refuses_wrong_shapes(robot):
    """The fused ``analytic`` call hands C-contiguous float64 arrays to the kernel unchecked; every
    other form (list, int or float32 dtype, Fortran order, read-only, a strided view) gives the same
    result through the converting path, and a wrong shape is one SettingsError line naming it."""
    from pipeline.solvers import SettingsError

    model = load_robot(ROBOTS / f"{robot}.yaml")
    prep = prepare("analytic", model, make_settings("analytic", {}))
    rng = np.random.default_rng(4)
    lim = np.clip(np.asarray(model.limits, dtype=float), -np.pi, np.pi)
    qg = lim[:, 0] + (lim[:, 1] - lim[:, 0]) * rng.random(model.n)
    T = fk_htm(model.chain, qg)
    q0 = np.zeros(model.n)
    ref = solve("analytic", prep, T, q0)
    assert ref.success
    ro = T.copy()
    ro.flags.writeable = False
    forms = [(T.tolist(), q0.tolist()), (np.asfortranarray(T), q0), (ro, q0), (T, np.zeros(2 * model.n)[::2]),
             (T, q0.astype(np.int64)), (T, q0.astype(np.float32))]
    for Tg, qs in forms:
        r = solve("analytic", prep, Tg, qs)
        assert r.success == ref.success and _same(r.q, ref.q) and _same(r.solutions, ref.solutions)
    for Tg, qs, field in ((T[:3], q0, "T_goal"), (T, q0[:-1], "q_start"), (T[..., None], q0, "T_goal"),
                          (T.ravel(), q0, "T_goal")):
        with pytest.raises(SettingsError, match=field):
            solve("analytic", prep, Tg, qs)
