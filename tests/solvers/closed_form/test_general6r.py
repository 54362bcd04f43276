"""The general 6R elimination (``general_6r``, and ``analytic`` on arms no subproblem family fits).

Random 6R arms (random DH lengths and twists: no intersecting or parallel axes) in every file form
and unit: the configuration that made a goal is among the solutions, every solution reaches the goal
by the numpy forward kinematics, and on fixed arms the solution set equals that of a dense Newton
search from many starts. Refusals name the geometry in one line.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import fk_htm
from pipeline.solvers import NotApplicableError, SettingsError, StopReason, solve, solve_batch
from pipeline.solvers.closed_form import eigen, general6r, general6r_model
from pipeline.solvers.core import Prepared
from pipeline.solvers.core.models import metric as _metric
from pipeline.solvers.core.registry import get
from tests.conftest import random_transform
from tests.solvers.closed_form.test_analytic_geometry import _lengths, _twists, as_general, dh_model, robot, wrapped


def general_arm(seed: int, conv: str = "standard", unit: str = "m", form: str = "dh"):
    rng = np.random.default_rng(seed)
    f = 1000.0 if unit == "mm" else 1.0
    m = dh_model(conv, _lengths(rng, 6) * f, _twists(rng, 6), _lengths(rng, 6) * f, rng.uniform(-np.pi, np.pi, 6),
                 random_transform(rng, 0.5 * f), random_transform(rng, 0.1 * f), unit=unit)
    return as_general(m) if form == "general" else m


def reaches(m, q, T, tol=1e-9) -> bool:
    R = fk_htm(m.chain, q)
    scale = 1000.0 if m.length_unit == "mm" else 1.0
    return bool(np.abs(R[:3, 3] - T[:3, 3]).max() <= tol * scale and np.abs(R[:3, :3] - T[:3, :3]).max() <= tol)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), conv=st.sampled_from(["standard", "modified"]),
       unit=st.sampled_from(["m", "mm"]), form=st.sampled_from(["dh", "general"]),
       method=st.sampled_from(["general_6r", "analytic"]))
def test_generating_configuration_is_among_the_solutions(seed, conv, unit, form, method):
    m = general_arm(seed, conv, unit, form)
    rng = np.random.default_rng(seed + 1)
    q = rng.uniform(-np.pi, np.pi, 6)
    T = fk_htm(m.chain, q)
    r = solve(method, m, T, rng.uniform(-np.pi, np.pi, 6), {})
    assert r.success, (r.stop_reason, r.info)
    assert len(r.solutions) % 2 == 0 and 2 <= len(r.solutions) <= 16  # real roots come in pairs here
    assert np.abs(wrapped(r.solutions - q)).max(axis=1).min() < 1e-5
    assert all(reaches(m, s, T) for s in r.solutions)


def _dense(m6, T, starts) -> list[np.ndarray]:
    """Distinct solutions Newton reaches from ``starts`` (the same polish as the solver, 40 steps)."""
    found = []
    for s0 in starts:
        x = general6r_model.newton_polish(m6.H, m6.P, m6.T0, T, s0, 40)
        if np.all(np.isfinite(x)) and np.abs(general6r_model.fk_model(m6, x) - T).max() < 1e-10:
            x = wrapped(x)
            if all(np.abs(wrapped(x - y)).max() > 1e-6 for y in found):
                found.append(x)
    return found


@pytest.mark.parametrize("seed", [3, 8])
def test_solution_set_equals_a_dense_newton_search(seed):
    m = general_arm(seed)
    prep = Prepared(m)
    m6 = general6r.model(prep)
    rng = np.random.default_rng(seed)
    for _ in range(3):
        T = _metric(prep).goal(fk_htm(m.chain, rng.uniform(-np.pi, np.pi, 6)))
        ours = general6r.candidates(m6, T, general6r.General6RSettings())
        ours = [x for x in ours if np.abs(general6r_model.fk_model(m6, x) - T).max() < 1e-9]
        dense = _dense(m6, T, rng.uniform(-np.pi, np.pi, (600, 6)))
        assert len(dense) >= 2
        for y in dense:  # every solution the search finds, the elimination finds
            assert min(np.abs(wrapped(y - x)).max() for x in ours) < 1e-6
        assert len(ours) <= 16


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), spread=st.integers(0, 12))
def test_qr_split_gives_the_left_null_space_and_the_least_squares_solve(seed, spread):
    """Rows of sizes spread over up to 12 orders of magnitude (the 14 quantities' units differ): the
    null space (undone of its power-of-two row scaling) is orthonormal and annihilates the scaled
    matrix, and ``Qp`` solves least squares (Qp Q = I)."""
    rng = np.random.default_rng(seed)
    Q = rng.standard_normal((14, 8)) * 10.0 ** rng.uniform(-spread / 2, spread / 2, (14, 1))
    Qp, Nl = np.empty((8, 14)), np.empty((6, 14))
    assert eigen.qr_split(Q, Qp, Nl)
    d = 2.0 ** -np.floor(np.log2(np.abs(Q).max(axis=1)))  # the row scaling _qr_split applies
    U = Nl / d
    assert np.abs(U @ U.T - np.eye(6)).max() < 1e-12
    assert np.abs(U @ (d[:, None] * Q)).max() < 1e-12
    assert np.abs(Qp @ Q - np.eye(8)).max() < 1e-8 * np.linalg.cond(d[:, None] * Q)


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 24), spread=st.integers(0, 6))
def test_own_eigenvalues_equal_lapacks(seed, n, spread):
    """Balancing, Hessenberg reduction and the Francis QR: every eigenvalue numpy (LAPACK) finds, to a
    relative 1e-9 of the largest, on matrices whose rows differ by up to 6 orders of magnitude."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n)) * 10.0 ** rng.uniform(-spread / 2, spread / 2, (n, 1))
    wr, wi = np.empty(n), np.empty(n)
    assert eigen.eig_hess(A.copy(), wr, wi)
    ours, ref = wr + 1j * wi, np.linalg.eigvals(A)
    scale = 1.0 + np.abs(ref).max()
    assert np.abs(ref[:, None] - ours[None, :]).min(axis=1).max() < 1e-9 * scale
    assert np.abs(ours[:, None] - ref[None, :]).min(axis=1).max() < 1e-9 * scale


def test_own_eigenvalues_of_a_companion_with_known_roots_and_a_refused_infinity():
    roots = np.array([-3.0, -1.5, 0.25, 0.5, 2.0, 7.0])
    c = np.poly(roots)  # monic, highest power first
    A = np.zeros((6, 6))
    A[0] = -c[1:]
    A[1:, :-1] = np.eye(5)
    wr, wi = np.empty(6), np.empty(6)
    assert eigen.eig_hess(A.copy(), wr, wi)
    assert np.allclose(np.sort(wr), roots, atol=1e-10) and np.all(wi == 0.0)
    A[2, 3] = np.inf
    assert not eigen.eig_hess(A, wr, wi)


def test_qr_split_refuses_a_rank_deficient_matrix():
    Q = np.random.default_rng(1).standard_normal((14, 8))
    Q[:, 7] = Q[:, 0] - 2.0 * Q[:, 3]
    assert not eigen.qr_split(Q, np.empty((8, 14)), np.empty((6, 14)))


def _pencil_of(m6, T):
    return general6r._pencil(m6.eP[m6.roles[2]], m6.eT0, *m6.left, m6.right_inv, m6.right_L, m6.right_c,
                             m6.right_h, m6.C, general6r_model.KRON_OF, np.ascontiguousarray(T), general6r._MOBIUS)


@pytest.mark.parametrize("seed", [3, 8, 21])
def test_deflation_removes_exactly_the_eight_eigenvalues_at_plus_minus_i(seed):
    """The companion's 24 eigenvalues are the deflated 16 and ±i four times each."""
    m = general_arm(seed, "modified" if seed % 2 else "standard")
    prep = Prepared(m)
    m6 = general6r.model(prep)
    rng = np.random.default_rng(seed)
    for _ in range(5):
        T = _metric(prep).goal(fk_htm(m.chain, rng.uniform(-np.pi, np.pi, 6)))
        if m6.reversed:
            T = np.linalg.inv(T)
        ok, comp, abcd, pen, Qp, P1m = _pencil_of(m6, T)
        assert ok
        full = np.linalg.eigvals(comp)
        B = np.empty((16, 16))
        assert eigen.deflate(pen, comp.copy(), B)
        rest = np.linalg.eigvals(B)
        assert np.sum(np.abs(np.abs(full.imag) - 1.0) + np.abs(full.real) < 1e-6) >= 8
        assert np.sum(np.abs(np.abs(rest.imag) - 1.0) + np.abs(rest.real) < 1e-6) == 0
        for lam in rest:  # each remaining eigenvalue is one of the companion's
            assert np.abs(full - lam).min() < 1e-6 * (1.0 + abs(lam))
        real = lambda w: np.sort(w.real[np.abs(w.imag) <= 1e-6 * (1.0 + np.abs(w))])  # noqa: E731
        assert np.allclose(real(full), real(rest), rtol=1e-7, atol=1e-9)


def test_deflation_declines_a_pencil_without_the_block_at_i():
    """A pencil with no null space at i (a random one) is not deflated: the whole companion is solved."""
    rng = np.random.default_rng(4)
    pen = rng.standard_normal((3, 12, 12))
    comp = np.zeros((24, 24))
    comp[:12, 12:] = np.eye(12)
    comp[12:] = -np.linalg.solve(pen[2], np.hstack((pen[0], pen[1])))
    assert not eigen.deflate(pen, comp, np.empty((16, 16)))


def test_public_call_of_a_general_arm_equals_the_general_6r_solver():
    """``analytic``'s fused call (one compiled call: roots, FK checks, choice, the independent check)
    gives what ``general_6r`` gives through its Python result path: the same solutions, the same q."""
    for seed, conv, unit, form in [(5, "standard", "m", "dh"), (6, "modified", "mm", "general")]:
        m = general_arm(seed, conv, unit, form)
        prep = Prepared(m)
        rng = np.random.default_rng(seed)
        for _ in range(10):
            T, q0 = fk_htm(m.chain, rng.uniform(-np.pi, np.pi, 6)), rng.uniform(-np.pi, np.pi, 6)
            a = solve("analytic", prep, T, q0, {})
            b = solve("general_6r", prep, T, q0, {"tol_pos": 1e-9 * (1000.0 if unit == "mm" else 1.0),
                                                  "tol_rot": 1e-9})
            assert a.success and b.success and a.info["family"] == "general 6R (algebraic elimination)"
            assert len(a.solutions) == len(b.solutions) == a.info["n_solutions"]
            assert np.abs(a.solutions - b.solutions).max() < 1e-9 and np.abs(a.q - b.q).max() < 1e-9
            assert a.position_error <= 1e-9 * (1000.0 if unit == "mm" else 1.0)


def test_batch_equals_one_by_one_on_a_general_arm():
    m = general_arm(21, "modified", "mm")
    rng = np.random.default_rng(5)
    Q = rng.uniform(-np.pi, np.pi, (12, 6))
    goals = np.array([fk_htm(m.chain, q) for q in Q])
    starts = rng.uniform(-np.pi, np.pi, (12, 6))
    b = solve_batch("analytic", m, goals, starts, {})  # the general elimination's batch kernel, every core
    lean = solve_batch("analytic", m, goals, starts, {}, threads=1, traces=False)
    for i in range(12):
        r = solve("analytic", m, goals[i], starts[i], {})
        assert r.success == b.success[i] and np.array_equal(r.q, b.q[i])
        assert np.array_equal(r.solutions, b.solutions[i, :b.n_solutions[i]])
        assert r.trace.shape == (2, 8) and np.isfinite(r.trace).all()
        assert np.array_equal(r.trace, b.trace_rows[b.trace_offsets[i]:b.trace_offsets[i + 1]])
        assert r.info == b.info[i]
        assert np.array_equal(lean.q[i], b.q[i]) and lean.info[i] == b.info[i]


def test_solutions_nearest_first_and_capped():
    m = general_arm(4)
    rng = np.random.default_rng(9)
    q = rng.uniform(-np.pi, np.pi, 6)
    T, q0 = fk_htm(m.chain, q), rng.uniform(-np.pi, np.pi, 6)
    r = solve("general_6r", m, T, q0, {})
    d = (wrapped(r.solutions - q0) ** 2).sum(axis=1)
    assert np.all(np.diff(d) >= 0)
    assert np.abs(wrapped(r.q - r.solutions[0])).max() < 1e-12
    one = solve("general_6r", m, T, q0, {"max_solutions": 1})
    assert len(one.solutions) == 1 and np.allclose(one.solutions[0], r.solutions[0])


@pytest.mark.parametrize("bad", ["far", "nan", "inf"])
def test_unreachable_or_non_finite_goal_is_no_solution(bad):
    m = general_arm(6)
    T = fk_htm(m.chain, np.zeros(6))
    if bad == "far":
        T[:3, 3] *= 50.0
    else:
        T[0, 3] = np.nan if bad == "nan" else np.inf
    q0 = np.full(6, 0.3)
    for method in ("general_6r", "analytic"):
        r = solve(method, m, T, q0, {})
        assert not r.success and r.stop_reason == StopReason.NO_SOLUTION
        assert np.array_equal(r.q, q0)
        assert np.isfinite(r.position_error) or bad != "far"


@pytest.mark.parametrize("require_limits", [False, True])
def test_a_start_with_nan_is_no_solution_with_the_start_returned(require_limits):
    """As the subproblem families: no distance to a NaN start, so no solution is chosen; ``q`` is the
    start, which the finish reports as non-finite."""
    m = general_arm(6)
    T = fk_htm(m.chain, np.full(6, 0.4))
    q0 = np.array([np.nan, 0.1, 0.2, 0.3, 0.4, 0.5])
    for method in ("general_6r", "analytic"):
        r = solve(method, m, T, q0, {"require_limits": require_limits})
        assert not r.success and r.stop_reason == StopReason.NON_FINITE and len(r.solutions) == 0
        assert np.array_equal(r.q, q0, equal_nan=True)


def collinear_arm():
    """Axes 2 and 3 on one line (parallel and meeting): the arm's joints are not independent."""
    rng = np.random.default_rng(17)
    a, alpha = _lengths(rng, 6), _twists(rng, 6)
    a[1], alpha[1] = 0.0, 0.0
    return dh_model("standard", a, alpha, _lengths(rng, 6), np.zeros(6))


@pytest.mark.parametrize("name, words", [("franka_panda", "6R arms, the robot has 7 joints"),
                                         ("stanford", "revolute joints only, joint(s) 3"),
                                         ("collinear", "the general 6R elimination degenerates")])
def test_refusals_name_the_geometry(name, words):
    m = collinear_arm() if name == "collinear" else robot(name)
    why = get("general_6r").refusal(Prepared(m))
    assert why and words in why and "\n" not in why
    with pytest.raises(NotApplicableError):
        solve("general_6r", m, fk_htm(m.chain, np.full(m.n, 0.2)), np.zeros(m.n), {})


def test_special_arms_keep_their_subproblem_family():
    """Arms a family fits are still solved by subproblems, not by the elimination."""
    for name in ("ur5", "puma560", "ufactory_xarm6"):
        m = robot(name)
        r = solve("analytic", m, fk_htm(m.chain, np.full(6, 0.4)), np.zeros(6), {})
        assert r.success and "general" not in r.info["family"]


@pytest.mark.parametrize("field, value", [("polish_steps", -1), ("real_tol", 0.0), ("max_solutions", 17)])
def test_bad_setting_is_one_line(field, value):
    with pytest.raises(SettingsError) as exc:
        solve("general_6r", general_arm(1), np.eye(4), np.zeros(6), {field: value})
    assert field in str(exc.value) and "\n" not in str(exc.value).strip()


def test_shifted_angles_are_not_special():
    """A configuration at θ = π on joints 3-5 (where an unshifted half-angle tangent is infinite)."""
    m = general_arm(12)
    q = np.array([0.3, -0.7, math.pi, math.pi, -math.pi, 1.1])
    r = solve("general_6r", m, fk_htm(m.chain, q), np.zeros(6), {})
    assert r.success and np.abs(wrapped(r.solutions - q)).max(axis=1).min() < 1e-6


@pytest.mark.parametrize("alpha, reversed_", [([0.0, 0.9, 0.5, 1.1, 0.7, 0.4], True),   # axes 1 ∥ 2
                                              ([0.6, 0.9, 0.5, 1.1, 0.0, 0.4], False)])  # axes 5 ∥ 6
def test_chain_read_from_the_tool_back_where_the_base_end_degenerates(alpha, reversed_):
    """Axes 1 and 2 parallel make the elimination degenerate on the arm's own chain, not on the chain
    read from the tool back (and the other way round for axes 5 and 6)."""
    rng = np.random.default_rng(2)
    m = dh_model("standard", rng.uniform(0.1, 0.5, 6), alpha, rng.uniform(0.1, 0.5, 6), np.zeros(6))
    assert general6r.model(Prepared(m)).reversed == reversed_
    for q in rng.uniform(-np.pi, np.pi, (8, 6)):
        T = fk_htm(m.chain, q)
        r = solve("analytic", m, T, np.zeros(6), {})
        assert r.success and np.abs(wrapped(r.solutions - q)).max(axis=1).min() < 1e-6
        assert all(reaches(m, x, T) for x in r.solutions)


def test_robot_verb_says_the_elimination_solves_a_general_arm(tmp_path, capsys):
    from pipeline.cli import main

    rng = np.random.default_rng(31)
    joints = "\n".join(f"  - {{type: revolute, a: {rng.uniform(0.05, 0.4):.4f}, alpha: {rng.uniform(0.4, 2.7):.4f}, "
                       f"d: {rng.uniform(0.05, 0.3):.4f}, theta_offset: 0}}" for _ in range(6))
    f = tmp_path / "arm.yaml"
    f.write_text(f"name: arm\nsource: test\nlength_unit: m\nconvention: standard\njoints:\n{joints}\n")
    main(["robot", str(f)])
    out = capsys.readouterr().out
    assert "none: no closed-form family fits" in out
    assert "general 6R: `analytic` solves it by algebraic elimination" in out


def test_require_limits_returns_a_solution_within_them():
    rng = np.random.default_rng(14)
    lim = [(-2.0, 2.5)] * 6
    m = dh_model("modified", _lengths(rng, 6), _twists(rng, 6), _lengths(rng, 6), rng.uniform(-np.pi, np.pi, 6),
                 limits=lim)
    done = 0
    for q in rng.uniform(-2.0, 2.5, (10, 6)):
        r = solve("analytic", m, fk_htm(m.chain, q), np.zeros(6), {"require_limits": True})
        assert r.success and r.within_limits
        assert np.all(r.q >= -2.0 - 1e-9) and np.all(r.q <= 2.5 + 1e-9)
        done += 1
    assert done == 10


def both_methods(name: str, n: int, seed: int):
    """(the elimination's model, [(analytic's solutions, general_6r's at 1e-9)] on ``n`` goals)."""
    m = robot(name)
    prep = Prepared(m)
    rng = np.random.default_rng(seed)
    lim = np.where(np.isfinite(m.limits), m.limits, np.array([-np.pi, np.pi]))
    out = []
    for q in rng.uniform(lim[:, 0], lim[:, 1], (n, 6)):
        T = fk_htm(m.chain, q)
        out.append((solve("analytic", prep, T, q, {}).solutions,
                    solve("general_6r", prep, T, q, {"tol_pos": 1e-9, "tol_rot": 1e-9}).solutions))
    return general6r.model(prep), out


def contains(big, small) -> bool:
    return all(np.abs(wrapped(big - x)).max(axis=1).min() < 1e-6 for x in small)


def test_offset_wrist_arm_same_solutions_as_the_subproblem_search():
    """The xArm6 (offset wrist) is solved both by ``analytic``'s one-dimensional search and, on the chain
    read from the tool back, by the elimination: two independent methods, the same solution sets (the
    search may miss a pair of solutions closer than its grid, never the other way round)."""
    m6, pairs = both_methods("ufactory_xarm6", 60, 3)
    assert m6.reversed and m6.split == 0
    assert all(contains(g, a) for a, g in pairs)
    assert sum(len(a) == len(g) for a, g in pairs) >= 59


@pytest.mark.parametrize("name", ["ur5", "kinova_gen3_lite"])
def test_special_arms_by_the_split_loop_agree_with_the_subproblems(name):
    """Three parallel axes and an offset wrist: the elimination (split 1) and the subproblem solution
    give the same solution sets (the elimination may miss a root where the pencil is close to
    singular: at most 1 goal in 40 here)."""
    m6, pairs = both_methods(name, 40, 4)
    assert m6.split == 1
    assert all(contains(a, g) for a, g in pairs)
    assert sum(len(a) == len(g) for a, g in pairs) >= 39


@pytest.mark.parametrize("name", ["puma560", "staubli_tx2_60"])
def test_a_spherical_wrist_degenerates_the_elimination_and_general_6r_says_so(name):
    """A spherical wrist makes the 12 x 12 pencil singular for every x3 (each x3 root is shared by four
    solutions), whichever way the loop is split: ``general_6r`` refuses the arm in one line naming
    the geometry, and ``analytic`` solves it by its subproblems."""
    m = robot(name)
    prep = Prepared(m)
    why = general6r.degenerate(prep)
    assert why and "degenerates for this geometry" in why
    with pytest.raises(NotApplicableError, match="degenerates for this geometry"):
        solve("general_6r", prep, fk_htm(m.chain, np.full(6, 0.3)), np.zeros(6), {})
    r = solve("analytic", prep, fk_htm(m.chain, np.full(6, 0.3)), np.zeros(6), {})
    assert r.success and len(r.solutions) == 8


def test_the_returned_solution_is_listed_first_whatever_the_cap():
    rng = np.random.default_rng(14)
    m = dh_model("modified", _lengths(rng, 6), _twists(rng, 6), _lengths(rng, 6), rng.uniform(-np.pi, np.pi, 6),
                 limits=[(-2.0, 2.5)] * 6)
    for q in rng.uniform(-2.0, 2.5, (6, 6)):
        T = fk_htm(m.chain, q)
        for cap in (1, 2, 16):
            r = solve("general_6r", m, T, np.zeros(6), {"require_limits": True, "max_solutions": cap})
            assert r.success and len(r.solutions) <= cap
            assert np.abs(wrapped(r.solutions[0] - r.q)).max() < 1e-12
