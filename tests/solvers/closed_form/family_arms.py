"""Random 6R arms of every closed-form geometry family, random goals, and a dense numerical search.

The generator works on the joint lines themselves (a unit direction and a point per joint at the zero
pose, world frame), not on a DH table: the family's constraints are imposed on the lines (axes through
one point, parallel directions) and everything else is random, then the lines are written as a robot
in the general (URDF-style) form with a random base and tool. Every random function takes an explicit
``numpy.random.Generator``.

Families (:data:`FAMILIES`: name -> the ``analytic`` family the lines must get, None = the general
elimination):

``sph_general``          axes 4-6 meet; axes 1-3 in general position
``sph_shoulder_general`` axes 1-3 meet; axes 4-6 in general position (the same, read from the tool)
``sph_case``             axes 4-6 meet; axes 1-2 or 2-3 meet or are parallel (one chosen at random)
``three_parallel``       axes 2-4 parallel, axes 5 and 6 meet (the UR family)
``three_parallel_offset`` axes 2-4 parallel, axes 5 and 6 skew
``three_parallel_offset_tool`` axes 3-5 parallel, axes 1 and 2 skew (the same, read from the tool)
``two_parallel``         axes 2 and 3 parallel, nothing else
``two_meeting``          axes 5 and 6 meet, nothing else
``general``              no constraint

Used by ``tests/solvers/closed_form/test_families.py`` (a few arms each) and ``benchmarks/bench_families_eaik.py`` (200).
"""

from __future__ import annotations

import math

import numpy as np

from pipeline.kinematics import Chain, fk_htm
from pipeline.robots import RobotModel

FAMILIES = {
    "sph_general": "spherical_wrist_3r",
    "sph_shoulder_general": "spherical_wrist_3r",
    "sph_case": "spherical_wrist",
    "three_parallel": "three_parallel",
    "three_parallel_offset": "three_parallel_offset",
    "three_parallel_offset_tool": "three_parallel_offset",
    "two_parallel": None,
    "two_meeting": None,
    "general": None,
}
SAME = 1e-6  # two joint vectors closer than this (mod 2π, every joint) are one solution [rad]


def unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _rotation(rng: np.random.Generator) -> np.ndarray:
    Q, R = np.linalg.qr(rng.normal(size=(3, 3)))
    Q = Q * np.sign(np.diag(R))
    return Q if np.linalg.det(Q) > 0 else -Q


def _transform(rng: np.random.Generator, scale: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = _rotation(rng)
    T[:3, 3] = rng.normal(scale=scale, size=3)
    return T


def random_lines(kind: str, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(h (6, 3), p (6, 3), tool point (3,)) of a random arm of family ``kind`` [m]: each joint point a
    random step (0.1-0.4 m) from the last, then the family's constraints imposed."""
    h = np.array([unit(rng) for _ in range(6)])
    p = np.cumsum(rng.normal(size=(6, 3)) * rng.uniform(0.1, 0.4, (6, 1)) / math.sqrt(3), axis=0)

    def through(idx, x):  # the axes idx pass through x (their points slid along their lines)
        x = x.copy()
        for i in idx:
            p[i] = x + rng.uniform(-0.2, 0.2) * h[i]

    def parallel(idx):
        for i in idx[1:]:
            h[i] = h[idx[0]] * rng.choice([-1.0, 1.0])

    if kind in ("sph_general", "sph_case"):
        through((3, 4, 5), p[3])
        if kind == "sph_case":
            case = int(rng.integers(4))
            if case == 0:
                through((0, 1), p[1])
            elif case == 1:
                through((1, 2), p[2])
            else:
                parallel((0, 1) if case == 2 else (1, 2))
    elif kind == "sph_shoulder_general":
        through((0, 1, 2), p[1])
    elif kind in ("three_parallel", "three_parallel_offset"):
        parallel((1, 2, 3))
        if kind == "three_parallel":
            through((4, 5), p[5])
    elif kind == "three_parallel_offset_tool":
        parallel((2, 3, 4))
    elif kind == "two_parallel":
        parallel((1, 2))
    elif kind == "two_meeting":
        through((4, 5), p[5])
    elif kind != "general":
        raise ValueError(f"family_arms: unknown family {kind!r}")
    tool = p[5] + rng.normal(size=3) * rng.uniform(0.05, 0.2) / math.sqrt(3)
    return h, p, tool


def arm(kind: str, rng: np.random.Generator) -> RobotModel:
    """A random 6R robot of family ``kind`` in the general form, random base and tool frame, no limits."""
    return arm_from_lines(*random_lines(kind, rng), rng, kind)


def arm_from_lines(h: np.ndarray, p: np.ndarray, tool: np.ndarray, rng: np.random.Generator,
                   kind: str = "lines") -> RobotModel:
    """The robot whose joint lines at q = 0 are (h (n, 3), p (n, 3)) in the world frame [m], tool point
    ``tool`` (3,), written in the general form behind a random base, with a random tool rotation."""
    base = _transform(rng, 0.3)
    Bi = np.linalg.inv(base)
    hb, pb, tb = h @ Bi[:3, :3].T, p @ Bi[:3, :3].T + Bi[:3, 3], Bi[:3, :3] @ tool + Bi[:3, 3]
    n = len(h)
    origins = np.tile(np.eye(4), (n, 1, 1))
    prev = np.zeros(3)
    for i in range(n):  # every joint frame keeps the base's orientation: its origin on the line
        origins[i][:3, 3] = pb[i] - prev
        prev = pb[i]
    T_tool = np.eye(4)
    T_tool[:3, :3] = _rotation(rng)
    T_tool[:3, 3] = tb - pb[-1]
    z = np.zeros(n)
    chain = Chain(z, z, z, z, np.zeros(n, bool), "general", base, T_tool, origins, hb)
    return RobotModel(f"random {kind}", "tests/solvers/closed_form/family_arms.py", "m", chain,
                      np.tile([-np.inf, np.inf], (n, 1)))


def goals(model: RobotModel, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """n random joint vectors (uniform in (−π, π]) and their poses (n, 4, 4)."""
    Q = rng.uniform(-math.pi, math.pi, (n, model.n))
    return Q, np.array([fk_htm(model.chain, q) for q in Q])


def wrapped(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def gap(S, q) -> float:
    """Largest joint difference (mod 2π) from q to the nearest row of S [rad] (inf when S is empty)."""
    S = np.asarray(S, float).reshape(-1, len(q))
    return float(np.abs(wrapped(S - q)).max(axis=1).min()) if len(S) else math.inf


def distinct(S) -> list:
    out = []
    for s in np.asarray(S, float):
        if all(np.abs(wrapped(s - t)).max() > SAME for t in out):
            out.append(s)
    return out


# ---- a dense numerical search ---------------------------------------------------------------------
def _poe_lines(model: RobotModel):
    from pipeline.kinematics.geometry import joint_lines

    L = joint_lines(model.chain)
    return L.h, L.p, L.M


def _fk_batch(h, p, M, Q):
    """Poses (S, 4, 4) of joint vectors Q (S, 6) by the product of exponentials of the lines."""
    S = Q.shape[0]
    T = np.tile(np.eye(4), (S, 1, 1))
    for i in range(h.shape[0]):
        k = h[i]
        K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        c, s = np.cos(Q[:, i])[:, None, None], np.sin(Q[:, i])[:, None, None]
        R = np.eye(3) + s * K + (1 - c) * (K @ K)
        E = np.tile(np.eye(4), (S, 1, 1))
        E[:, :3, :3] = R
        E[:, :3, 3] = p[i] - R @ p[i]
        T = T @ E
    return T @ M


def _residual(T, Tg):
    """(S, 9): position error [m] and the differences of the first two rotation columns (zero only at
    the goal's rotation, unlike a rotation vector's sine, which vanishes at a half turn too)."""
    dp = Tg[:3, 3] - T[:, :3, 3]
    return np.concatenate([dp, Tg[:3, 0] - T[:, :3, 0], Tg[:3, 1] - T[:, :3, 1]], axis=1)


def dense_search(model: RobotModel, T_goal: np.ndarray, rng: np.random.Generator, starts: int = 400,
                 iters: int = 60, tol: float = 1e-10) -> list:
    """Distinct solutions found by damped Newton (Levenberg-Marquardt, numerical Jacobian of the
    twist-free residual) from ``starts`` random joint vectors: a lower bound on the solution count."""
    h, p, M = _poe_lines(model)
    Q = rng.uniform(-math.pi, math.pi, (starts, 6))
    lam = np.full(starts, 1e-2)
    eps = 1e-7
    for _ in range(iters):
        r = _residual(_fk_batch(h, p, M, Q), T_goal)
        J = np.empty((starts, 9, 6))
        for j in range(6):
            Qe = Q.copy()
            Qe[:, j] += eps
            J[:, :, j] = (_residual(_fk_batch(h, p, M, Qe), T_goal) - r) / eps
        JT = np.transpose(J, (0, 2, 1))
        A = JT @ J + lam[:, None, None] * np.eye(6)
        step = -np.linalg.solve(A, (JT @ r[:, :, None]))[:, :, 0]
        Qn = Q + step
        rn = _residual(_fk_batch(h, p, M, Qn), T_goal)
        better = (rn ** 2).sum(1) < (r ** 2).sum(1)
        Q = np.where(better[:, None], Qn, Q)
        lam = np.where(better, lam * 0.3, lam * 10.0).clip(1e-12, 1e6)
    r = _residual(_fk_batch(h, p, M, Q), T_goal)
    ok = np.abs(r).max(axis=1) < tol
    return distinct(wrapped(Q[ok]))
