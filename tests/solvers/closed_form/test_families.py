"""``analytic`` on random arms of every geometry family (tests/family_arms.py): the family found from
the lines, the generating joint vector among the solutions, every solution FK-exact, and the solution
count equal to a dense numerical search's on a few goals. Plus the quartic of
:mod:`pipeline.solvers.closed_form.family_gen3r` against numpy's roots.

The full check (200 arms a family, counts on 50) is ``benchmarks/bench_families_eaik.py``; here a
seeded sample small enough for CI.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.kinematics import fk_htm, geometry
from pipeline.solvers import solve
from tests.solvers.closed_form import family_arms as fa

POS_TOL_M = 1e-8  # every returned solution reproduces the goal to this [m] ...
ROT_TOL = 1e-8    # ... and this (Frobenius distance of the rotations)
MATCH_TOL = 1e-7  # the generating joint vector is among the solutions (mod 2π) [rad]
ARMS, GOALS = 6, 8         # per family: the round trips
COUNT_ARMS = 2             # per family: goals compared with the dense search (one a arm)
KINDS = list(fa.FAMILIES)


def _seed(kind: str, k: int) -> int:
    return 1000 * KINDS.index(kind) + k


@pytest.mark.parametrize("kind", KINDS)
def test_family_found_from_the_lines(kind):
    for k in range(20):
        m = fa.arm(kind, np.random.default_rng(_seed(kind, k)))
        d = geometry.classify(m.chain)
        assert d.family == fa.FAMILIES[kind], (k, d.reason)


def _check(m, r, T):
    assert r.success, r.info
    for s in r.solutions:
        Ts = fk_htm(m.chain, s)
        assert np.linalg.norm(Ts[:3, 3] - T[:3, 3]) <= POS_TOL_M
        assert np.linalg.norm(Ts[:3, :3] - T[:3, :3]) <= ROT_TOL
    assert len(fa.distinct(r.solutions)) == len(r.solutions), "duplicate solutions"


@pytest.mark.parametrize("kind", KINDS)
def test_generating_solution_is_returned(kind):
    for k in range(ARMS):
        rng = np.random.default_rng(_seed(kind, k))
        m = fa.arm(kind, rng)
        Q, Ts = fa.goals(m, rng, GOALS)
        for q, T in zip(Q, Ts):
            r = solve("analytic", m, T, rng.uniform(-math.pi, math.pi, 6), {})
            _check(m, r, T)
            assert fa.gap(r.solutions, q) < MATCH_TOL, (k, q, r.info)


@pytest.mark.parametrize("kind", KINDS)
def test_count_equals_dense_search(kind):
    for k in range(COUNT_ARMS):
        rng = np.random.default_rng(_seed(kind, 100 + k))
        m = fa.arm(kind, rng)
        _, Ts = fa.goals(m, rng, 1)
        r = solve("analytic", m, Ts[0], np.zeros(6), {})
        found = fa.dense_search(m, Ts[0], rng, starts=250, iters=50)
        assert r.info["n_solutions"] == len(found), (k, r.info, len(found))
        for s in found:
            assert fa.gap(r.solutions, s) < 1e-6


def test_quartic_roots_match_numpy():
    from pipeline.solvers.closed_form.family_gen3r import quartic_roots

    rng = np.random.default_rng(3)
    out = np.empty(4, np.complex128)
    for _ in range(200):
        c = rng.normal(size=5)
        quartic_roots(c[0], c[1], c[2], c[3], c[4], out)
        ref = np.roots(c)
        for z in ref:
            assert np.abs(out - z).min() < 1e-8 * (1 + abs(z))


def test_trig2_roots_every_real_root_and_a_continuum():
    from pipeline.solvers.closed_form.family_gen3r import trig2_roots

    rng = np.random.default_rng(4)
    X = np.empty(4, np.complex128)
    x = np.linspace(-math.pi, math.pi, 200001)
    for _ in range(200):
        k = rng.normal(size=5)
        f = k[0] + k[1] * np.cos(x) + k[2] * np.sin(x) + k[3] * np.cos(2 * x) + k[4] * np.sin(2 * x)
        changes = int(np.count_nonzero(np.sign(f[1:]) != np.sign(f[:-1])))
        n = trig2_roots(k, 0.0, X)
        assert n == changes
        for r in np.angle(X[:n]):
            assert abs(k[0] + k[1] * math.cos(r) + k[2] * math.sin(r) + k[3] * math.cos(2 * r)
                       + k[4] * math.sin(2 * r)) < 1e-12 * np.abs(k).sum()
    assert trig2_roots(np.zeros(5), 0.7, X) == 1 and abs(np.angle(X[0]) - 0.7) < 1e-15


def test_four_parallel_axes_refused_with_the_reason():
    """Four consecutive parallel axes leave the arm 5 independent motions: no goal has a finite solution set,
    and the refusal says so in its one line."""
    from pipeline.solvers import NotApplicableError

    rng = np.random.default_rng(9)
    h, p, tool = fa.random_lines("general", rng)
    h[1:4] = h[0]
    model = fa.arm_from_lines(h, p, tool, rng)
    with pytest.raises(NotApplicableError, match="axes 1 to 4 are parallel: the arm has at most 5 independent"):
        solve("analytic", model, np.eye(4), np.zeros(6), {})


@pytest.mark.parametrize("kind", ["sph_general"])  # one family: each compiles its own batch kernel (CI time)
def test_batch_equals_single_calls(kind):
    from pipeline.solvers import solve_batch

    rng = np.random.default_rng(_seed(kind, 7))
    m = fa.arm(kind, rng)
    _, Ts = fa.goals(m, rng, 12)
    starts = rng.uniform(-math.pi, math.pi, (12, 6))
    b = solve_batch("analytic", m, Ts, starts, {}, threads=1)
    for i in range(12):
        r = solve("analytic", m, Ts[i], starts[i], {})
        assert b.success[i] and r.success
        assert np.array_equal(b.q[i], r.q)
        assert b.n_solutions[i] == len(r.solutions)
        assert np.array_equal(b.solutions[i][: b.n_solutions[i]], r.solutions)


def test_seven_joint_arm_whose_six_fit_a_quartic_family():
    """A 7R arm that is a spherical wrist on a general positioner with joint 1 held: the sweep solves it,
    each solution FK-exact."""
    rng = np.random.default_rng(21)
    h6, p6, tool = fa.random_lines("sph_general", rng)
    # joint 0 in front: a new first axis, the six after it as generated
    h = np.vstack([fa.unit(rng), h6])
    p = np.vstack([p6[0] - rng.normal(size=3) * 0.2, p6])
    model = fa.arm_from_lines(h, p, tool, rng)
    d = geometry.classify(model.chain)
    assert d.family == "spherical_wrist_3r" and d.free_joint is not None, d.reason
    Q = rng.uniform(-math.pi, math.pi, (6, 7))
    for q in Q:
        T = fk_htm(model.chain, q)
        r = solve("analytic", model, T, q + rng.normal(size=7) * 0.1, {})
        _check(model, r, T)
