"""The batch's closed form in vector lanes (``pipeline.solvers.closed_form.lanes``): 8 goals at once give the single
call's candidates bit for bit, on arms of every family and position case it takes (written here as
joint lines, with random geometry), on unreachable and non-finite goals, and at the wrist singularity
where a subproblem takes a default (the goal is then left to the single call)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import fk_htm
from pipeline.robots import load_robot
from pipeline.solvers import make_settings, solve, solve_batch
from pipeline.solvers.closed_form import family_3p, family_sph, lanes
from pipeline.solvers.closed_form.analytic import packed
from pipeline.solvers.closed_form.analytic_kernels import candidates8, unpack
from pipeline.solvers.core.registry import bind
from tests.conftest import homogeneous, rodrigues
from pipeline.solvers.closed_form import subproblems as sp

ROBOTS = Path(__file__).resolve().parents[3] / "data" / "robots"
NOLIM = np.column_stack([np.full(6, -np.inf), np.full(6, np.inf)])
CLIP = 1e-9


def _unit(rng) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _arm(kind: str, rng) -> tuple:
    """Joint lines (H (6, 3), P (6, 3)) and a tool pose (RM, pM) of a random arm of family ``kind``: "3p"
    (axes 2-4 parallel, 5-6 meet) or "sph1" .. "sph4" (axes 4-6 meet; position case 1: axes 1-2 meet,
    2: axes 2-3 meet, 3: 1 ∥ 2, 4: 2 ∥ 3)."""
    H = np.array([_unit(rng) for _ in range(6)])
    P = rng.normal(size=(6, 3)) * 0.4
    if kind == "3p":
        for i in (2, 3):
            H[i] = H[1] * rng.choice([-1.0, 1.0])
        c = rng.normal(size=3) * 0.4
        P[4], P[5] = c + 0.3 * rng.normal() * H[4], c + 0.3 * rng.normal() * H[5]
    else:
        c = rng.normal(size=3) * 0.4
        for i in (3, 4, 5):
            P[i] = c + 0.2 * rng.normal() * H[i]
        case = int(kind[-1])
        if case in (1, 2):
            o = rng.normal(size=3) * 0.3
            a, b = (0, 1) if case == 1 else (1, 2)
            P[a], P[b] = o + 0.2 * rng.normal() * H[a], o + 0.2 * rng.normal() * H[b]
        else:
            a, b = (0, 1) if case == 3 else (1, 2)
            H[b] = H[a] * rng.choice([-1.0, 1.0])
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    RM = q * np.sign(np.linalg.det(q))
    return H, P, RM, rng.normal(size=3) * 0.3


def _fk(H, P, RM, pM, q) -> np.ndarray:
    """T(q) = E_1(q_1) .. E_6(q_6) M, E_i the rotation by q_i about line i."""
    T = np.eye(4)
    for h, p, t in zip(H, P, q):
        R = rodrigues(h, t)
        T = T @ homogeneous(R, p - R @ p)
    return T @ homogeneous(RM, pM)


def _single(kind, H, P, RM, pM, Tg, pref, Q) -> int:
    pg = (Tg[0, 3], Tg[1, 3], Tg[2, 3])
    if kind == "3p":
        return family_3p.solve_3p(H, P, RM, pM, Tg, pg, CLIP, pref, Q)
    return family_sph.solve_sph(int(kind[-1]), H, P, RM, pM, Tg, pg, CLIP, pref, Q, NOLIM)


def _compare(kind, H, P, RM, pM, goals, prefs) -> tuple[int, int]:
    """Lanes against the single call on every block of 8 goals: (goals compared, goals left to the single
    call). Asserts the same candidates bit for bit."""
    fam = sp.FAM_3P if kind == "3p" else sp.FAM_SPH
    case = 0 if kind == "3p" else int(kind[-1])
    L = np.empty(lanes.SIZE)
    Z = np.empty(6 * sp.MAX_SOL, np.complex128)
    Q = np.empty((sp.MAX_SOL, 6), np.complex128)
    compared = free_n = 0
    for i0 in range(0, len(goals) - 7, 8):
        candidates8(fam, case, H, P, RM, pM, CLIP, goals, i0, L)
        for lane in range(8):
            k, free = lanes.take(L, lane, Z)
            if free:
                free_n += 1
                continue
            n = _single(kind, H, P, RM, pM, goals[i0 + lane], prefs[i0 + lane], Q)
            assert k == n, (kind, i0 + lane, k, n)
            assert np.array_equal(Z[:6 * k].view(np.float64), Q[:n].ravel().view(np.float64), equal_nan=True)
            compared += 1
    return compared, free_n


@pytest.mark.parametrize("kind", ["3p", "sph1", "sph2", "sph3", "sph4"])
@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_lanes_give_the_single_calls_candidates(kind, seed):
    rng = np.random.default_rng(seed)
    H, P, RM, pM = _arm(kind, rng)
    qs = rng.uniform(-math.pi, math.pi, (24, 6))
    goals = np.array([_fk(H, P, RM, pM, q) for q in qs])
    goals[5, :3, 3] += 50.0  # unreachable
    goals[11, 0, 0] = np.nan  # not finite
    goals[17, :3, 3] = np.inf
    prefs = rng.uniform(-math.pi, math.pi, (24, 6))
    compared, _ = _compare(kind, H, P, RM, pM, goals, prefs)
    assert compared >= 16
    # the arm is of the family: the single call reaches a reachable goal (its candidates by FK)
    Q = np.empty((sp.MAX_SOL, 6), np.complex128)
    n = _single(kind, H, P, RM, pM, goals[0], prefs[0], Q)
    err = min(np.abs(_fk(H, P, RM, pM, np.angle(Q[r])) - goals[0]).max() for r in range(min(n, 8)))
    assert n >= 1 and err < 1e-9


@pytest.mark.parametrize("name", ["ur5", "puma560", "abb_irb140"])
def test_a_free_angle_is_left_to_the_single_call(name):
    """θ5 = 0 puts axes 4 and 6 (or 6 on 5's plane) in line: a subproblem takes the start's angle as its
    default. The lanes flag such goals; the batch then equals the single call there too."""
    m = load_robot(ROBOTS / f"{name}.yaml")
    rng = np.random.default_rng(3)
    lim = np.clip(np.array(m.limits, dtype=float), -math.pi, math.pi)
    qs = rng.uniform(lim[:, 0], lim[:, 1], (32, 6))
    qs[::2, 4] = 0.0
    goals = np.array([fk_htm(m.chain, q) for q in qs])
    starts = rng.uniform(lim[:, 0], lim[:, 1], (32, 6))
    b = solve_batch("analytic", m, goals, starts, {}, threads=1)
    for i in range(32):
        r = solve("analytic", m, goals[i], starts[i], {})
        assert np.array_equal(b.q[i], r.q) and b.success[i] == r.success
        k = int(b.n_solutions[i])
        assert np.array_equal(b.solutions[i, :k], r.solutions)
    # the lanes did flag the singular goals of a spherical wrist (θ4 free), and only goals
    bd = bind("analytic", m, make_settings("analytic", {}))
    k = packed(bd.prep, bd.sc)
    H, P, RM, pM, par, _ = unpack(k.ints, k.G)
    G = goals.copy()
    G[:, :3, 3] *= bd.prep.goal_scale
    L, Z = np.empty(lanes.SIZE), np.empty(6 * sp.MAX_SOL, np.complex128)
    free = []
    for i0 in range(0, 32, 8):
        candidates8(int(k.ints[1]), int(k.ints[2]), H, P, RM, pM, par[0], G, i0, L)
        free += [lanes.take(L, lane, Z)[1] for lane in range(8)]
    if name != "ur5":  # the UR5's θ6 is the free one there: its default e^{i0} needs no start
        assert any(free[::2])
    assert not any(free[1::2])


def test_applies_only_to_a_6r_closed_form_read_from_the_base():
    assert lanes.applies(6, sp.FAM_SPH, 0) and lanes.applies(6, sp.FAM_3P, 0)
    assert not lanes.applies(6, sp.FAM_SEARCH, 0)
    assert not lanes.applies(6, sp.FAM_SPH, 1)
    assert not lanes.applies(7, sp.FAM_SPH, 0)
