"""The arm of the general 6R elimination on its joint lines (metres): the model built once per robot and
split (``build_model``), its forward kinematics, and the compiled pieces the elimination shares with the
Newton polish (motions about a line, the 14 line coordinates, Gauss elimination, the polish itself).
Poses (4, 4), joint lines as unit axes H (6, 3) and points P (6, 3) [m], angles [rad]."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from pipeline.solvers.core import Prepared, inv_rigid
from pipeline.solvers.core.models import poe
from pipeline.solvers.kernels.kin import rodrigues

SHIFT = (0.5 * math.sqrt(2.0), -0.5 * math.sqrt(3.0), 0.25 * math.sqrt(5.0))  # [rad] fixed offsets of joints 3-5
_GRID = (0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0)  # [rad] where the coefficient sets are evaluated

# ---- pure kinematics on joint lines (metres) ---------------------------------------------------------
def _motion(h: np.ndarray, p: np.ndarray, t: float) -> np.ndarray:
    """(4, 4) rotation by ``t`` [rad] about the line through ``p`` along the unit ``h``."""
    T = np.eye(4)
    R, u = np.empty((3, 3)), np.empty(3)
    _motion_into(np.asarray(h, dtype=float), np.asarray(p, dtype=float), float(t), R, u)
    T[:3, :3], T[:3, 3] = R, u
    return T


def _fourteen(p: np.ndarray, l: np.ndarray) -> np.ndarray:
    """The 14 quantities of Raghavan and Roth of a point ``p`` (3,) and a direction ``l`` (3,)."""
    out = np.empty(14)
    fourteen_into(np.ascontiguousarray(p, dtype=float), np.ascontiguousarray(l, dtype=float), out)
    return out


# the nine products of two joints' (sin, cos, 1), "_nine's order": (sa sb, sa cb, ca sb, ca cb, sa, ca, sb, cb, 1),
# each as its (index in a's triple, index in b's)
_ORDER = [(0, 0), (0, 1), (1, 0), (1, 1), (0, 2), (1, 2), (2, 0), (2, 1), (2, 2)]


def _grid_nine(a: float, b: float) -> np.ndarray:
    """The nine products in the Kronecker order of ``(s, c, 1)_a ⊗ (s, c, 1)_b``."""
    u, v = (math.sin(a), math.cos(a), 1.0), (math.sin(b), math.cos(b), 1.0)
    return np.array([u[i] * v[j] for i in range(3) for j in range(3)])


KRON_OF = np.array([3 * i + j for i, j in _ORDER], np.int64)  # _nine's term t sits at Kronecker index KRON_OF[t]


# How the closure is split: (the three joints of the left side, the joint whose axis carries the point
# and direction, the two joints of the right side). Split 0: E3 E4 E5 (c, h6) = E2⁻¹ E1⁻¹ G (c, h6);
# split 1: E2 E3 E4 (c, h5) = E1⁻¹ G E6⁻¹ (c, h5), G = T M⁻¹ (0-based joint indices below).
SPLITS = (((2, 3, 4), 5, (0, 1)), ((1, 2, 3), 4, (0, 5)))


@dataclass(frozen=True)
class ArmModel:
    H: np.ndarray        # (6, 3) unit axes of the arm
    P: np.ndarray        # (6, 3) a point on each
    T0: np.ndarray       # (4, 4) the tool at q = 0
    reversed: bool       # the elimination runs on the chain read from the tool back (below)
    split: int           # which of SPLITS
    eH: np.ndarray       # (6, 3), (6, 3), (4, 4): the chain the elimination runs on (the arm's own, or
    eP: np.ndarray       # reversed: joint k is the arm's joint 7 - k with angle −θ, its lines moved by
    eT0: np.ndarray      # T0⁻¹, home T0⁻¹; the goal T⁻¹)
    left: tuple          # (Ps, Pc, P1), each (14, 9): coefficients of (s, c, 1) of the left's first joint
    right_inv: np.ndarray  # (9, 9) inverse of the right side's design on the grid
    right_L: np.ndarray  # (9, 4, 4) the right side's motion before G on the grid
    right_c: np.ndarray  # (9, 3), (9, 3): the point and direction G acts on, on the grid
    right_h: np.ndarray
    roles: np.ndarray    # (6,) int: the right pair, the left triple, the joint whose axis carries the point
    C: np.ndarray        # (9, 9) _nine's terms times (1 + x4²)(1 + x5²) as monomials x4^i x5^j (index 3i + j)


def build_model(prep: Prepared, reversed_: bool = False, split: int = 0) -> ArmModel:
    g = poe(prep)
    c = np.ascontiguousarray
    H0, P0, M0 = c(g.H, dtype=float), c(g.pts, dtype=float), c(g.T0, dtype=float)
    H, P, T0 = H0, P0, M0
    if reversed_:  # T⁻¹ = T0⁻¹ E_6(−θ6) ⋯ E_1(−θ1) = E'_1(−θ6) ⋯ E'_6(−θ1) T0⁻¹, E'_k about T0⁻¹ (line 7 − k)
        R0, p0 = M0[:3, :3], M0[:3, 3]
        H = c(np.array([R0.T @ H0[5 - k] for k in range(6)]))
        P = c(np.array([R0.T @ (P0[5 - k] - p0) for k in range(6)]))
        T0 = c(inv_rigid(M0))
    tri, pt, (ja, jb) = SPLITS[split]
    o, cp, hp = P[tri[0]], P[pt], H[pt]
    rows, vals = [], []
    for f3 in _GRID:
        for f4 in _GRID:
            for f5 in _GRID:
                T = (_motion(H[tri[0]], P[tri[0]], f3 + SHIFT[0]) @ _motion(H[tri[1]], P[tri[1]], f4 + SHIFT[1])
                     @ _motion(H[tri[2]], P[tri[2]], f5 + SHIFT[2]))
                rows.append(np.kron((math.sin(f3), math.cos(f3), 1.0), _grid_nine(f4, f5)))
                vals.append(_fourteen(T[:3, :3] @ cp + T[:3, 3] - o, T[:3, :3] @ hp))
    coef = np.linalg.solve(np.array(rows), np.array(vals))  # (27, 14), exact: a Kronecker product of 3 × 3 grids
    left = tuple(c(coef[9 * k:9 * k + 9][KRON_OF].T) for k in range(3))
    design, Ls, cs, hs = [], [], [], []
    for f1 in _GRID:
        for f2 in _GRID:
            design.append(_grid_nine(f1, f2))
            if split == 0:  # (E1 E2)⁻¹ G (c, h)
                Ls.append(np.linalg.inv(_motion(H[ja], P[ja], f1) @ _motion(H[jb], P[jb], f2)))
                cs.append(cp)
                hs.append(hp)
            else:  # E1⁻¹ G E6⁻¹ (c, h)
                Ls.append(np.linalg.inv(_motion(H[ja], P[ja], f1)))
                B = np.linalg.inv(_motion(H[jb], P[jb], f2))
                cs.append(B[:3, :3] @ cp + B[:3, 3])
                hs.append(B[:3, :3] @ hp)
    s_, c_, o_ = np.array([0.0, 2.0, 0.0]), np.array([1.0, 0.0, -1.0]), np.array([1.0, 0.0, 1.0])
    half = {0: s_, 1: c_, 2: o_}
    C = np.array([np.outer(half[a], half[b]).ravel() for a, b in _ORDER])
    roles = np.array([ja, jb, *tri, pt], np.int64)
    return ArmModel(H0, P0, M0, reversed_, split, H, P, T0, left, c(np.linalg.inv(np.array(design))), c(np.array(Ls)),
                  c(np.array(cs)), c(np.array(hs)), roles, c(C))


def fk_model(m: ArmModel, q: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    for i in range(6):
        T = T @ _motion(m.H[i], m.P[i], q[i])
    return T @ m.T0


@numba.njit(cache=True, error_model="numpy", inline="always")
def _motion_into(h, p, t, R, u):
    """Rotation ``R`` (3, 3) and translation ``u`` (3,) of the motion by ``t`` [rad] about the line
    through ``p`` along the unit ``h`` (:func:`pipeline.solvers.kernels.kin.rodrigues`), written into R and u."""
    r9 = rodrigues(h[0], h[1], h[2], t)
    for r in range(3):
        R[r, 0], R[r, 1], R[r, 2] = r9[3 * r], r9[3 * r + 1], r9[3 * r + 2]
    for r in range(3):
        u[r] = p[r] - (R[r, 0] * p[0] + R[r, 1] * p[1] + R[r, 2] * p[2])


@numba.njit(cache=True, error_model="numpy", inline="always")
def times_motion(A, h, p, t, R, u, B):
    """``A`` (4, 4) times the motion E(t) about the line (h, p), in place (R, u, B scratch)."""
    _motion_into(h, p, t, R, u)
    for r in range(3):
        for c in range(3):
            B[r, c] = A[r, 0] * R[0, c] + A[r, 1] * R[1, c] + A[r, 2] * R[2, c]
        B[r, 3] = A[r, 0] * u[0] + A[r, 1] * u[1] + A[r, 2] * u[2] + A[r, 3]
    for r in range(3):
        for c in range(4):
            A[r, c] = B[r, c]


@numba.njit(cache=True, error_model="numpy")
def chain_into(H, P, q, k, A):
    """``A`` (4, 4) = E_1(q_1) ⋯ E_k(q_k)."""
    R, u, B = np.empty((3, 3)), np.empty(3), np.empty((4, 4))
    for r in range(4):
        for c in range(4):
            A[r, c] = 1.0 if r == c else 0.0
    for i in range(k):
        times_motion(A, H[i], P[i], q[i], R, u, B)


@numba.njit(cache=True, error_model="numpy")
def gauss_solve(A, B):
    """Solve ``A X = B`` (A (k, k), B (k, m); both overwritten, X in B) by Gaussian elimination with
    partial pivoting; returns (X, ok), ok False at a zero pivot (no LAPACK call, no exception)."""
    k, m = A.shape[0], B.shape[1]
    for c in range(k):
        piv = c
        for r in range(c + 1, k):
            if abs(A[r, c]) > abs(A[piv, c]):
                piv = r
        if not A[piv, c] != 0.0:  # zero (or NaN)
            return B, False
        if piv != c:
            for j in range(c, k):
                A[c, j], A[piv, j] = A[piv, j], A[c, j]
            for j in range(m):
                B[c, j], B[piv, j] = B[piv, j], B[c, j]
        for r in range(c + 1, k):
            f = A[r, c] / A[c, c]
            if f != 0.0:
                for j in range(c + 1, k):
                    A[r, j] -= f * A[c, j]
                for j in range(m):
                    B[r, j] -= f * B[c, j]
    for c in range(k - 1, -1, -1):
        for j in range(m):
            acc = B[c, j]
            for i in range(c + 1, k):
                acc -= A[c, i] * B[i, j]
            B[c, j] = acc / A[c, c]
    return B, True


@numba.njit(cache=True, error_model="numpy")
def newton_polish(H, P, T0, Tg, q, steps):
    """``steps`` Newton steps of the joint values ``q`` (6,) towards the goal ``Tg`` (4, 4) (spatial
    twist error, geometric Jacobian, least squares); returns the polished ``q``."""
    q = q.copy()
    W = np.empty(36 + 6 + 16 + 16 + 9 + 3 + 16 + 3 + 3 + 9)  # one allocation, then views
    J, e = W[0:36].reshape((6, 6)), W[36:42]
    A, T = W[42:58].reshape((4, 4)), W[58:74].reshape((4, 4))
    R, u, B, h, pt = W[74:83].reshape((3, 3)), W[83:86], W[86:102].reshape((4, 4)), W[102:105], W[105:108]
    d = W[108:117].reshape((3, 3))
    for _ in range(steps):
        for r in range(4):
            for c in range(4):
                A[r, c] = 1.0 if r == c else 0.0
        for i in range(6):  # joint i's line moved by E_1 ⋯ E_i-1: (h, -h × p) of the spatial Jacobian
            for r in range(3):
                h[r] = A[r, 0] * H[i, 0] + A[r, 1] * H[i, 1] + A[r, 2] * H[i, 2]
                pt[r] = A[r, 0] * P[i, 0] + A[r, 1] * P[i, 1] + A[r, 2] * P[i, 2] + A[r, 3]
            J[0, i], J[1, i], J[2, i] = h[0], h[1], h[2]
            J[3, i] = -(h[1] * pt[2] - h[2] * pt[1])
            J[4, i] = -(h[2] * pt[0] - h[0] * pt[2])
            J[5, i] = -(h[0] * pt[1] - h[1] * pt[0])
            times_motion(A, H[i], P[i], q[i], R, u, B)
        for r in range(3):
            for c in range(4):
                T[r, c] = A[r, 0] * T0[0, c] + A[r, 1] * T0[1, c] + A[r, 2] * T0[2, c] + (A[r, 3] if c == 3 else 0.0)
        # d = Rg Rᵀ
        for r in range(3):
            for c in range(3):
                d[r, c] = Tg[r, 0] * T[c, 0] + Tg[r, 1] * T[c, 1] + Tg[r, 2] * T[c, 2]
        w0, w1, w2 = 0.5 * (d[2, 1] - d[1, 2]), 0.5 * (d[0, 2] - d[2, 0]), 0.5 * (d[1, 0] - d[0, 1])
        e[0], e[1], e[2] = w0, w1, w2
        # spatial linear error: goal position minus reached, less ω × reached position
        e[3] = Tg[0, 3] - T[0, 3] - (w1 * T[2, 3] - w2 * T[1, 3])
        e[4] = Tg[1, 3] - T[1, 3] - (w2 * T[0, 3] - w0 * T[2, 3])
        e[5] = Tg[2, 3] - T[2, 3] - (w0 * T[1, 3] - w1 * T[0, 3])
        if max(abs(e[0]), abs(e[1]), abs(e[2]), abs(e[3]), abs(e[4]), abs(e[5])) < 1e-15:
            break
        dq, ok = gauss_solve(J, e.reshape((6, 1)))
        if not ok:  # a singular Jacobian: the root is left as it is
            break
        step = 0.0
        for i in range(6):
            q[i] += dq[i, 0]
            step = max(step, abs(dq[i, 0]))
        if step <= 1e-12:  # converged (quadratically): a further step would move q by rounding only
            break
    return q


@numba.njit(cache=True, error_model="numpy")
def fourteen_into(p, l, out):
    pp = p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
    lp = l[0] * p[0] + l[1] * p[1] + l[2] * p[2]
    cx, cy, cz = l[1] * p[2] - l[2] * p[1], l[2] * p[0] - l[0] * p[2], l[0] * p[1] - l[1] * p[0]
    for r in range(3):
        out[r] = l[r]
        out[3 + r] = p[r]
        out[11 + r] = pp * l[r] - 2.0 * lp * p[r]
    out[6], out[7], out[8], out[9], out[10] = pp, lp, cx, cy, cz
