"""``general_6r``: every real solution of a 6R arm by algebraic elimination, whatever its geometry.

The subproblem closed forms (:mod:`pipeline.solvers.closed_form.analytic`) need intersecting or parallel axes.
An arm with neither is the general 6R problem, which has at most 16 solutions (Lee & Liang 1988;
Raghavan & Roth 1993). This solver follows the elimination of Raghavan and Roth in the matrix form
of Manocha and Canny (1994, "Efficient inverse kinematics for general 6R manipulators", IEEE Trans.
Robotics and Automation 10(5)), written here on the joint lines of the arm (product of
exponentials: ``E_i(θ)`` the rotation by θ about joint line i, ``T = E_1 ⋯ E_6 M``), so any robot
file form works:

1. With ``c`` a point on axis 6 and ``h_6`` its direction, ``E_6`` leaves both alone, so
   ``E_3 E_4 E_5 (c, h_6) = E_2⁻¹ E_1⁻¹ (w, g)`` with ``w = T M⁻¹ c`` and ``g = R_T R_Mᵀ h_6``.
   Measured from a point on axis 3, the point ``p`` and direction ``l`` of each side give the 14
   quantities of Raghavan and Roth: ``l``, ``p``, ``p·p``, ``l·p``, ``l × p`` and
   ``(p·p) l − 2 (l·p) p``. On the left they are linear in the nine products
   ``(s4, c4, 1) ⊗ (s5, c5, 1)`` with coefficients linear in ``(s3, c3, 1)``; on the right linear in
   ``(s1, c1, 1) ⊗ (s2, c2, 1)``. Both coefficient sets are found exactly by evaluating the
   quantities on a 3 × 3 (× 3) grid of angles and solving the (Kronecker) system: no symbolic
   expansion. The left set depends on the arm only (once per robot), the right one on the goal.
2. The 8 products of joints 1-2 are eliminated: the 6 rows of the left null space of their 14 × 8
   coefficient matrix give 6 equations in joints 3-5 only (a Householder QR with column pivoting,
   each row first scaled by a power of two to unit size: the 14 quantities have different units,
   and an unscaled null space leaves rounding of the large rows in the small ones).
3. Half-angle tangents ``x_i = tan(θ_i / 2)`` (each joint shifted by a fixed offset first, so that
   no solution sits at θ = π where ``x`` is infinite) turn them into 6 equations in the 9 monomials
   ``x4^i x5^j`` (i, j ≤ 2), quadratic in ``x3``; with the same equations times ``x4`` they are 12 in
   12 monomials, ``(M2 x3² + M1 x3 + M0) m = 0``. A Möbius change of variable (``_MOBIUS``) makes
   its leading matrix well conditioned. Its 24 × 24 companion matrix has 8 eigenvalues at ±i whatever
   the goal (the factor ``(1 + x3²)⁴`` of Raghavan and Roth's degree-24 polynomial); they are
   deflated (:func:`_deflate`) and the real eigenvalues of the remaining 16 × 16 (:func:`_eig_hess`,
   LAPACK ``dgeev`` its fallback) give joint 3; the null vector ``m`` (one step of inverse iteration)
   joints 4 and 5, the 14 equations joints 1 and 2 (least squares on the eliminated products) and the pose joint 6. The
   whole goal is one compiled call (:func:`_all_roots`).
4. Each root is polished by ``polish_steps`` Newton steps on the full pose and kept when the FK check
   (the compiled dual-quaternion check every result gets, with the settings' tolerances) passes;
   duplicates (a double root) are merged. ``q`` is the kept solution nearest ``q_start``, as for
   the other all-solution methods (:func:`pipeline.solvers.peers.geo._result`).

Near a singular configuration two roots merge: the eigenvalue turns slightly complex or the null
space of ``M(x3)`` two-dimensional, the root is then inaccurate or missed, and the Newton polish and
the FK check decide; a goal on the boundary of the workspace may lose its double root (measured:
the 40 most singular of 6 000 random configurations of each of 4 random arms, σ_min/σ_max down to
5e-7, all solved, the configuration itself among the solutions). Arms with
special geometry (a spherical wrist, parallel axes) can make the 12 × 12 pencil singular for every
``x3`` (their solutions are not isolated in this formulation: a spherical wrist's four solutions of
each elbow share one ``x3``). Once per robot three goals of the
arm's own configurations are solved, and when a configuration is not among its goal's roots the
next way of setting up the elimination is tried: the chain read from the tool back
(``T⁻¹ = T0⁻¹ E_6(−θ6) ⋯ E_1(−θ1)``: joint k of that chain is the arm's joint 7 − k, its line moved by
``T0⁻¹``), then the loop split the other way (:data:`SPLITS`: joints 2-4 on the left, the point on
axis 5, joints 1 and 6 on the right with the goal between them), on each chain. With these, every
general 6R arm tried here is solved, and 16 of the catalogue's 22 6R arms (UR arms, offset wrists,
some spherical wrists; ``analytic`` uses its subproblems for them: on 200 goals of each the two gave
the same solution sets on every goal). Where every way degenerates the arm is refused in one line
(measured: the PUMA 560, ABB IRB 120, Stäubli TX2-60 and the UR5e's URDF, each of which the
subproblems solve; an earlier SVD null space "solved" them through rounding noise of an exactly
singular pencil), as is an arm with two joint axes on one line (its joints are not independent).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numba.np.linalg import _LAPACK, ensure_lapack

from pipeline.kinematics.fkcheck import check_one
from pipeline.solvers.kernels.kin import NO_SOLUTION, SUCCESS, TRACE_COLS, now_ns, rodrigues
from pipeline.solvers.closed_form.lines import doc_row, fk_lines
from pipeline.solvers.core import (Prepared, Raw, Settings, inv_rigid, unpack_check, check_fields, check_pack,
                                   finish_packed, setting)
from pipeline.solvers.core.driver import run_of
from pipeline.solvers.core.models import metric, poe, six_revolute, wrap_angles
from pipeline.solvers.core.registry import Solver, register
from pipeline.solvers.closed_form.subproblems import wrap

ensure_lapack()

SOURCE = ("Raghavan & Roth (1993), Inverse kinematics of the general 6R manipulator and related linkages, ASME J. "
          "Mech. Des. 115; Manocha & Canny (1994), Efficient inverse kinematics for general 6R manipulators, IEEE "
          "Trans. Robot. Autom. 10(5) (their matrix formulation, written on the joint lines)")
SHIFT = (0.5 * math.sqrt(2.0), -0.5 * math.sqrt(3.0), 0.25 * math.sqrt(5.0))  # [rad] fixed offsets of joints 3-5
_GRID = (0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0)  # [rad] where the coefficient sets are evaluated
_CHECK_Q = np.random.default_rng(606).uniform(-math.pi, math.pi, (3, 6))  # the arm's own test configurations


@dataclass(frozen=True)
class General6RSettings(Settings):
    max_solutions: int = setting(16, "solutions returned per goal at most, the nearest to the start", minimum=1,
                                 maximum=16)
    polish_steps: int = setting(4, "Newton steps on the full pose for each root of the eigenproblem", minimum=0,
                                maximum=50)
    real_tol: float = setting(1e-6, "an eigenvalue x3 counts as real when |Im x3| <= this times (1 + |x3|)",
                              above=0.0, maximum=1e-1)


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
    _fourteen_into(np.ascontiguousarray(p, dtype=float), np.ascontiguousarray(l, dtype=float), out)
    return out


# the nine products of two joints' (sin, cos, 1), "_nine's order": (sa sb, sa cb, ca sb, ca cb, sa, ca, sb, cb, 1),
# each as its (index in a's triple, index in b's)
_ORDER = [(0, 0), (0, 1), (1, 0), (1, 1), (0, 2), (1, 2), (2, 0), (2, 1), (2, 2)]


def _grid_nine(a: float, b: float) -> np.ndarray:
    """The nine products in the Kronecker order of ``(s, c, 1)_a ⊗ (s, c, 1)_b``."""
    u, v = (math.sin(a), math.cos(a), 1.0), (math.sin(b), math.cos(b), 1.0)
    return np.array([u[i] * v[j] for i in range(3) for j in range(3)])


_KRON_OF = np.array([3 * i + j for i, j in _ORDER], np.int64)  # _nine's term t sits at Kronecker index _KRON_OF[t]


# How the closure is split: (the three joints of the left side, the joint whose axis carries the point
# and direction, the two joints of the right side). Split 0: E3 E4 E5 (c, h6) = E2⁻¹ E1⁻¹ G (c, h6);
# split 1: E2 E3 E4 (c, h5) = E1⁻¹ G E6⁻¹ (c, h5), G = T M⁻¹ (0-based joint indices below).
SPLITS = (((2, 3, 4), 5, (0, 1)), ((1, 2, 3), 4, (0, 5)))


@dataclass(frozen=True)
class _Model:
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


def _model(prep: Prepared, reversed_: bool = False, split: int = 0) -> _Model:
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
    left = tuple(c(coef[9 * k:9 * k + 9][_KRON_OF].T) for k in range(3))
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
    return _Model(H0, P0, M0, reversed_, split, H, P, T0, left, c(np.linalg.inv(np.array(design))), c(np.array(Ls)),
                  c(np.array(cs)), c(np.array(hs)), roles, c(C))


def _fk(m: _Model, q: np.ndarray) -> np.ndarray:
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
def _times_motion(A, h, p, t, R, u, B):
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
def _chain(H, P, q, k, A):
    """``A`` (4, 4) = E_1(q_1) ⋯ E_k(q_k)."""
    R, u, B = np.empty((3, 3)), np.empty(3), np.empty((4, 4))
    for r in range(4):
        for c in range(4):
            A[r, c] = 1.0 if r == c else 0.0
    for i in range(k):
        _times_motion(A, H[i], P[i], q[i], R, u, B)


@numba.njit(cache=True, error_model="numpy")
def _gauss(A, B):
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
def _newton(H, P, T0, Tg, q, steps):
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
            _times_motion(A, H[i], P[i], q[i], R, u, B)
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
        dq, ok = _gauss(J, e.reshape((6, 1)))
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
def _mm(A, B):
    """A @ B by loops (small matrices; no BLAS)."""
    out = np.zeros((A.shape[0], B.shape[1]))
    for r in range(A.shape[0]):
        for k in range(A.shape[1]):
            a = A[r, k]
            for c in range(B.shape[1]):
                out[r, c] += a * B[k, c]
    return out


@numba.njit(cache=True, error_model="numpy")
def _qr_split(Q, Qp, Nl):
    """Householder QR with column pivoting of the products' coefficients ``Q`` (14, 8): ``Q Π = U R``.
    Writes the least-squares solve ``Qp`` (8, 14) = Π R⁻¹ U₁ᵀ and the left null space ``Nl`` (6, 14)
    (the last 6 columns of U, as rows); returns False when Q is rank deficient (|R₇₇| <= 1e-12 |R₀₀|).
    About 1 µs, against 20 µs for LAPACK's SVD of so small a matrix."""
    A = Q.copy()
    sc = np.empty(14)  # each row scaled by a power of two to unit size (exact): the rows' units differ
    for r in range(14):
        big = 0.0
        for c in range(8):
            big = max(big, abs(A[r, c]))
        sc[r] = 2.0 ** -math.floor(math.log2(big)) if big > 0.0 and math.isfinite(big) else 1.0
        for c in range(8):
            A[r, c] *= sc[r]
    V = np.zeros((14, 8))
    tau = np.zeros(8)
    perm = np.arange(8)
    w = np.empty(14)
    for j in range(8):
        best, p = -1.0, j
        for c in range(j, 8):
            nn = 0.0
            for r in range(j, 14):
                nn += A[r, c] * A[r, c]
            if nn > best:
                best, p = nn, c
        if p != j:
            for r in range(14):
                A[r, j], A[r, p] = A[r, p], A[r, j]
            perm[j], perm[p] = perm[p], perm[j]
        nrm = math.sqrt(best)
        if not nrm > 0.0:
            return False
        alpha = -nrm if A[j, j] >= 0.0 else nrm
        vv = 0.0
        for r in range(j, 14):
            V[r, j] = A[r, j]
        V[j, j] -= alpha
        for r in range(j, 14):
            vv += V[r, j] * V[r, j]
        tau[j] = 2.0 / vv
        A[j, j] = alpha
        for r in range(j + 1, 14):
            A[r, j] = 0.0
        for c in range(j + 1, 8):
            d = 0.0
            for r in range(j, 14):
                d += V[r, j] * A[r, c]
            d *= tau[j]
            for r in range(j, 14):
                A[r, c] -= d * V[r, j]
    if not abs(A[7, 7]) > 1e-12 * abs(A[0, 0]):
        return False
    U = np.zeros((14, 14))  # U = H₀ ⋯ H₇, each H = I − τ v vᵀ
    for r in range(14):
        U[r, r] = 1.0
    for j in range(7, -1, -1):
        for c in range(14):
            w[c] = 0.0
        for r in range(j, 14):
            vr = V[r, j]
            for c in range(14):
                w[c] += vr * U[r, c]
        for r in range(j, 14):
            f = tau[j] * V[r, j]
            for c in range(14):
                U[r, c] -= f * w[c]
    for k in range(6):
        for c in range(14):
            Nl[k, c] = U[c, 8 + k] * sc[c]
    Y = np.empty((8, 14))  # R Y = U₁ᵀ by back substitution
    for i in range(7, -1, -1):
        for c in range(14):
            acc = U[c, i]
            for k in range(i + 1, 8):
                acc -= A[i, k] * Y[k, c]
            Y[i, c] = acc / A[i, i]
    for i in range(8):
        for c in range(14):
            Qp[perm[i], c] = Y[i, c] * sc[c]
    return True


_RGEEV = _LAPACK().numba_ez_rgeev(numba.types.float64)  # numba's own LAPACK entry (scipy's dgeev): cacheable


@numba.njit(cache=True, error_model="numpy")
def _eigvals(A, wr, wi):
    """Eigenvalues of the square ``A`` (n, n) into ``wr``, ``wi`` (n,) by LAPACK ``dgeev`` (no vectors);
    A is overwritten (LAPACK reads the C-ordered array as its transpose: the same eigenvalues).
    Returns LAPACK's info (0: done)."""
    n = A.shape[0]
    vl, vr = np.empty(1), np.empty(1)
    return _RGEEV(100, 78, 78, n, A.ctypes, n, wr.ctypes, wi.ctypes, vl.ctypes, 1, vr.ctypes, 1)  # 'd', 'N', 'N'


@numba.njit(cache=True, error_model="numpy")
def _eig_hess(a, wr, wi):
    """Eigenvalues of the square ``a`` (n, n) into ``wr``, ``wi`` (n,), ``a`` overwritten: balanced by
    powers of two, reduced to Hessenberg form by stabilized elementary similarity transformations,
    then the Francis double-shift QR iteration on the active block only (eigenvalues, no vectors;
    the EISPACK algorithms balanc, elmhes and hqr as Press et al., Numerical Recipes, §11.5-11.6,
    give them). Returns False for a non-finite entry or when an eigenvalue does not converge in 30
    iterations (the caller then asks LAPACK). On the deflated 16 × 16 here it takes 13-20 µs against
    LAPACK ``dgeev``'s 27-37 (the same real eigenvalues to 6e-10 on 2 000 goals; Newton polishes them after)."""
    n = a.shape[0]
    for i in range(n):
        for j in range(n):
            if not math.isfinite(a[i, j]):
                return False  # (the balancing would not end on an infinity)
    # balance (powers of two, exact)
    done = False
    while not done:
        done = True
        for i in range(n):
            r = 0.0
            c = 0.0
            for j in range(n):
                if j != i:
                    c += abs(a[j, i])
                    r += abs(a[i, j])
            if c != 0.0 and r != 0.0:
                g = r / 2.0
                f = 1.0
                s = c + r
                while c < g:
                    f *= 2.0
                    c *= 4.0
                g = r * 2.0
                while c > g:
                    f /= 2.0
                    c /= 4.0
                if (c + r) / f < 0.95 * s:
                    done = False
                    g = 1.0 / f
                    for j in range(n):
                        a[i, j] *= g
                    for j in range(n):
                        a[j, i] *= f
    # Hessenberg by stabilized elementary similarity transformations
    for m in range(1, n - 1):
        x = 0.0
        i = m
        for j in range(m, n):
            if abs(a[j, m - 1]) > abs(x):
                x = a[j, m - 1]
                i = j
        if i != m:
            for j in range(m - 1, n):
                a[i, j], a[m, j] = a[m, j], a[i, j]
            for j in range(n):
                a[j, i], a[j, m] = a[j, m], a[j, i]
        if x != 0.0:
            for i in range(m + 1, n):
                y = a[i, m - 1]
                if y != 0.0:
                    y /= x
                    a[i, m - 1] = y
                    for j in range(m, n):
                        a[i, j] -= y * a[m, j]
                    for j in range(n):
                        a[j, m] += y * a[j, i]
    for i in range(2, n):  # below the subdiagonal: zero
        for j in range(i - 1):
            a[i, j] = 0.0
    # shifted QR on the Hessenberg matrix (eigenvalues only)
    anorm = 0.0
    for i in range(n):
        for j in range(max(i - 1, 0), n):
            anorm += abs(a[i, j])
    nn = n - 1
    t = 0.0
    its = 0
    total = 0
    x = y = w = 0.0
    while nn >= 0:
        l = 0
        for ll in range(nn, 0, -1):
            s = abs(a[ll - 1, ll - 1]) + abs(a[ll, ll])
            if s == 0.0:
                s = anorm
            if abs(a[ll, ll - 1]) + s == s:
                a[ll, ll - 1] = 0.0
                l = ll
                break
        x = a[nn, nn]
        if l == nn:
            wr[nn] = x + t
            wi[nn] = 0.0
            nn -= 1
            its = 0
            continue
        y = a[nn - 1, nn - 1]
        w = a[nn, nn - 1] * a[nn - 1, nn]
        if l == nn - 1:
            p = 0.5 * (y - x)
            q = p * p + w
            z = math.sqrt(abs(q))
            x += t
            if q >= 0.0:
                z = p + (z if p >= 0.0 else -z)
                wr[nn - 1] = wr[nn] = x + z
                if z != 0.0:
                    wr[nn] = x - w / z
                wi[nn - 1] = wi[nn] = 0.0
            else:
                wr[nn - 1] = wr[nn] = x + p
                wi[nn - 1] = -z
                wi[nn] = z
            nn -= 2
            its = 0
            continue
        if its == 30 or total > 30 * n:
            return False
        if its == 10 or its == 20:  # exceptional shift
            t += x
            for i in range(nn + 1):
                a[i, i] -= x
            s = abs(a[nn, nn - 1]) + abs(a[nn - 1, nn - 2])
            x = y = 0.75 * s
            w = -0.4375 * s * s
        its += 1
        total += 1
        m = nn - 2
        p = q = r = 0.0
        while m >= l:
            z = a[m, m]
            r = x - z
            s = y - z
            p = (r * s - w) / a[m + 1, m] + a[m, m + 1]
            q = a[m + 1, m + 1] - z - r - s
            r = a[m + 2, m + 1]
            s = abs(p) + abs(q) + abs(r)
            p /= s
            q /= s
            r /= s
            if m == l:
                break
            u = abs(a[m, m - 1]) * (abs(q) + abs(r))
            v = abs(p) * (abs(a[m - 1, m - 1]) + abs(z) + abs(a[m + 1, m + 1]))
            if u + v == v:
                break
            m -= 1
        for i in range(m + 2, nn + 1):
            a[i, i - 2] = 0.0
            if i != m + 2:
                a[i, i - 3] = 0.0
        for k in range(m, nn):
            if k != m:
                p = a[k, k - 1]
                q = a[k + 1, k - 1]
                r = 0.0
                if k != nn - 1:
                    r = a[k + 2, k - 1]
                x = abs(p) + abs(q) + abs(r)
                if x != 0.0:
                    p /= x
                    q /= x
                    r /= x
            s = math.sqrt(p * p + q * q + r * r)
            if p < 0.0:
                s = -s
            if s != 0.0:
                if k == m:
                    if l != m:
                        a[k, k - 1] = -a[k, k - 1]
                else:
                    a[k, k - 1] = -s * x
                p += s
                x = p / s
                y = q / s
                z = r / s
                q /= p
                r /= p
                for j in range(k, nn + 1):
                    p = a[k, j] + q * a[k + 1, j]
                    if k != nn - 1:
                        p += r * a[k + 2, j]
                        a[k + 2, j] -= p * z
                    a[k + 1, j] -= p * y
                    a[k, j] -= p * x
                mmin = nn if nn < k + 3 else k + 3
                for i in range(l, mmin + 1):
                    p = x * a[i, k] + y * a[i, k + 1]
                    if k != nn - 1:
                        p += z * a[i, k + 2]
                        a[i, k + 2] -= p * r
                    a[i, k + 1] -= p * q
                    a[i, k] -= p
    return True


@numba.njit(cache=True, error_model="numpy")
def _deflate(pen, comp, B):
    """The companion ``comp`` (24, 24) with its 8 eigenvalues at ±i removed, into ``B`` (16, 16).

    Whatever the arm, ``(1 + x3²)⁴`` divides the degree-24 determinant (Raghavan & Roth), and the
    change of variable fixes ±i: the pencil ``N(i) = N0 − N2 + i N1`` has a 4-dimensional null space
    (complete-pivoting LU, 8 steps, the rest below 1e-9 of the first pivot), whose vectors ``v`` give
    the companion's invariant subspace ``[Re v; −Im v], [Im v; Re v]`` (24, 8) for ±i, checked to
    1e-9. With P X = [L1; L2] U (row pivoting, |L| <= 1), the similarity ``[[X1, 0], [X2, I]]``
    makes P comp Pᵀ block triangular, its other eigenvalues those of ``A22 − L2 L1⁻¹ A12`` (about 7 µs
    here; the 16 × 16 eigenvalues then take about two thirds of the 24 × 24's time). Returns False where a check fails (the
    caller then solves the whole companion)."""
    Nc = np.empty((12, 12), np.complex128)
    for r in range(12):
        for c in range(12):
            Nc[r, c] = complex(pen[0, r, c] - pen[2, r, c], pen[1, r, c])
    perm = np.arange(12)
    p0 = 0.0
    for s_ in range(8):
        pr, pc, pm = s_, s_, -1.0
        for r in range(s_, 12):
            for c in range(s_, 12):
                a = abs(Nc[r, c].real) + abs(Nc[r, c].imag)
                if a > pm:
                    pm, pr, pc = a, r, c
        if s_ == 0:
            p0 = pm
        if not pm > 0.0:
            return False
        if pr != s_:
            for c in range(12):
                Nc[s_, c], Nc[pr, c] = Nc[pr, c], Nc[s_, c]
        if pc != s_:
            for r in range(12):
                Nc[r, s_], Nc[r, pc] = Nc[r, pc], Nc[r, s_]
            perm[s_], perm[pc] = perm[pc], perm[s_]
        inv = 1.0 / Nc[s_, s_]
        for r in range(s_ + 1, 12):
            f = Nc[r, s_] * inv
            for c in range(s_ + 1, 12):
                Nc[r, c] -= f * Nc[s_, c]
    for r in range(8, 12):
        for c in range(8, 12):
            if not abs(Nc[r, c].real) + abs(Nc[r, c].imag) <= 1e-9 * p0:
                return False
    X = np.empty((24, 8))
    z = np.empty(12, np.complex128)
    for k in range(4):
        for j in range(8, 12):
            z[j] = 1.0 if j == 8 + k else 0.0
        for i in range(7, -1, -1):
            acc = -Nc[i, 8 + k]
            for j in range(i + 1, 8):
                acc -= Nc[i, j] * z[j]
            z[i] = acc / Nc[i, i]
        for j in range(12):
            c = perm[j]
            X[c, 2 * k], X[12 + c, 2 * k] = z[j].real, -z[j].imag
            X[c, 2 * k + 1], X[12 + c, 2 * k + 1] = z[j].imag, z[j].real
    # check: comp x₂ₖ = −x₂ₖ₊₁ and comp x₂ₖ₊₁ = x₂ₖ (the top half holds by the companion's form)
    amax, xmax, res = 0.0, 0.0, 0.0
    for r in range(12, 24):
        for c in range(24):
            amax = max(amax, abs(comp[r, c]))
    for r in range(24):
        for c in range(8):
            xmax = max(xmax, abs(X[r, c]))
    for k in range(4):
        for r in range(12, 24):
            ea, eb = 0.0, 0.0
            for c in range(24):
                ea += comp[r, c] * X[c, 2 * k]
                eb += comp[r, c] * X[c, 2 * k + 1]
            res = max(res, abs(ea + X[r, 2 * k + 1]), abs(eb - X[r, 2 * k]))
    if not res <= 1e-9 * (amax + 1.0) * xmax:
        return False
    # P X = [L1; L2] U by Gaussian elimination with row pivoting; rows[:8] the pivot rows
    rows = np.arange(24)
    for j in range(8):
        p, pm = j, -1.0
        for r in range(j, 24):
            if abs(X[r, j]) > pm:
                pm, p = abs(X[r, j]), r
        if not pm > 0.0:
            return False
        if p != j:
            for c in range(8):
                X[j, c], X[p, c] = X[p, c], X[j, c]
            rows[j], rows[p] = rows[p], rows[j]
        for r in range(j + 1, 24):
            f = X[r, j] / X[j, j]
            X[r, j] = f  # the multiplier: L's entry
            for c in range(j + 1, 8):
                X[r, c] -= f * X[j, c]
    # W = L1⁻¹ A12 (8, 16), then B = A22 − L2 W, in the pivoted order
    W = np.empty((8, 16))
    for i in range(8):
        for c in range(16):
            acc = comp[rows[i], rows[8 + c]]
            for k in range(i):
                acc -= X[i, k] * W[k, c]
            W[i, c] = acc
    for r in range(16):
        for c in range(16):
            acc = comp[rows[8 + r], rows[8 + c]]
            for k in range(8):
                acc -= X[8 + r, k] * W[k, c]
            B[r, c] = acc
    return True


_MOBIUS = (0.0, 0.25 * math.pi, 0.5 * math.pi, 0.75 * math.pi)  # x3 = tan(atan(y) + φ), tried in this order


@numba.njit(cache=True, error_model="numpy")
def _pencil(o, T0, Ps, Pc, P1, Rinv, RL, RC, RH, C, kron_of, T, mobius):
    """The goal's eliminated system: (ok, companion (24, 24), (a, b, c, d) of the change of variable
    ``x3 = (a y + b) / (c y + d)``, N (3, 12, 12) the pencil in ``y`` (N0, N1, N2), Qp (8, 14) the
    pseudo-inverse of the products of the right pair, P1 (14, 9) with the goal's constant folded in).
    ``o`` (3,): the point the quantities are measured from (on the left's first axis); the right side
    on the grid is ``RL[k] · G · (RC[k], RH[k])``, G = T M⁻¹."""
    R0, p0 = T0[:3, :3], T0[:3, 3]
    G = np.empty((3, 4))
    for r in range(3):
        for c_ in range(3):
            G[r, c_] = T[r, 0] * R0[c_, 0] + T[r, 1] * R0[c_, 1] + T[r, 2] * R0[c_, 2]
        G[r, 3] = T[r, 3] - (G[r, 0] * p0[0] + G[r, 1] * p0[1] + G[r, 2] * p0[2])
    Y = np.empty((9, 14))
    w, g, pr, lr = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    for k in range(9):
        for r in range(3):
            w[r] = G[r, 0] * RC[k, 0] + G[r, 1] * RC[k, 1] + G[r, 2] * RC[k, 2] + G[r, 3]
            g[r] = G[r, 0] * RH[k, 0] + G[r, 1] * RH[k, 1] + G[r, 2] * RH[k, 2]
        for r in range(3):
            pr[r] = RL[k, r, 0] * w[0] + RL[k, r, 1] * w[1] + RL[k, r, 2] * w[2] + RL[k, r, 3] - o[r]
            lr[r] = RL[k, r, 0] * g[0] + RL[k, r, 1] * g[1] + RL[k, r, 2] * g[2]
        _fourteen_into(pr, lr, Y[k])
    coef = _mm(Rinv, Y)  # (9, 14), Kronecker order of (s1, c1, 1) ⊗ (s2, c2, 1)
    Q = np.empty((14, 8))
    P1m = P1.copy()
    for t in range(9):
        for r in range(14):
            if t < 8:
                Q[r, t] = coef[kron_of[t], r]
            else:
                P1m[r, 8] -= coef[kron_of[t], r]
    pen = np.zeros((3, 12, 12))
    comp = np.zeros((24, 24))
    Qp = np.zeros((8, 14))
    Nl = np.empty((6, 14))  # the left null space of Q
    if not _qr_split(Q, Qp, Nl):
        return False, comp, (1.0, 0.0, 0.0, 1.0), pen, Qp, P1m
    Ss, Sc, S1 = _mm(Nl, Ps), _mm(Nl, Pc), _mm(Nl, P1m)
    A0, A1, A2 = _mm(S1 + Sc, C), _mm(2.0 * Ss, C), _mm(S1 - Sc, C)  # x3^0, x3^1, x3^2: (6, 9) each
    M = np.zeros((3, 12, 12))
    for k, Ak in enumerate((A0, A1, A2)):
        for i in range(3):
            for j in range(3):
                for r in range(6):
                    M[k, r, 3 * i + j] = Ak[r, 3 * i + j]
                    M[k, 6 + r, 3 * (i + 1) + j] = Ak[r, 3 * i + j]
    # x3 = (a y + b) / (c y + d): (c y + d)² M(x3) = N2 y² + N1 y + N0, N2 = c² M(a / c) well conditioned
    for phi in mobius:
        a, b, c_, d = math.cos(phi), math.sin(phi), -math.sin(phi), math.cos(phi)
        pen[2] = a * a * M[2] + a * c_ * M[1] + c_ * c_ * M[0]
        pen[1] = 2.0 * a * b * M[2] + (a * d + b * c_) * M[1] + 2.0 * c_ * d * M[0]
        pen[0] = b * b * M[2] + b * d * M[1] + d * d * M[0]
        X, ok = _gauss(pen[2].copy(), np.hstack((pen[0], pen[1])))  # N2⁻¹ (N0 | N1): (12, 24)
        big = 0.0
        for r in range(12):
            for c2 in range(24):
                big = max(big, abs(X[r, c2]))
        if ok and big <= 1e10:  # N2 well conditioned enough: the companion's entries stay moderate (NaN fails too)
            for r in range(12):
                comp[r, 12 + r] = 1.0
                for c2 in range(24):
                    comp[12 + r, c2] = -X[r, c2]
            return True, comp, (a, b, c_, d), pen, Qp, P1m
    return False, comp, (1.0, 0.0, 0.0, 1.0), pen, Qp, P1m


@numba.njit(cache=True, error_model="numpy")
def _fourteen_into(p, l, out):
    pp = p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
    lp = l[0] * p[0] + l[1] * p[1] + l[2] * p[2]
    cx, cy, cz = l[1] * p[2] - l[2] * p[1], l[2] * p[0] - l[0] * p[2], l[0] * p[1] - l[1] * p[0]
    for r in range(3):
        out[r] = l[r]
        out[3 + r] = p[r]
        out[11 + r] = pp * l[r] - 2.0 * lp * p[r]
    out[6], out[7], out[8], out[9], out[10] = pp, lp, cx, cy, cz


@numba.njit(cache=True, error_model="numpy")
def _roots(H, P, T0, T, Ps, Pc, P1m, Qp, abcd, pen, ys, shift, steps, roles):
    """Joint values of each real eigenvalue ``y`` of the pencil, polished by ``steps`` Newton steps and
    wrapped to (−π, π], duplicates merged: (k, 6) [rad]. ``roles``: the right pair, the left
    triple and the joint whose axis carries the point (:data:`SPLITS`)."""
    a, b, c_, d = abcd
    out = np.empty((ys.shape[0], 6))
    k = 0
    A, B, Bs, R6, RG, Rs, us = (np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4)), np.empty((3, 3)),
                                np.empty((3, 3)), np.empty((3, 3)), np.empty(3))
    q = np.empty(6)
    v9 = np.empty(9)
    rhs12 = np.empty(12)
    for r in range(12):  # a fixed start vector with no special structure
        rhs12[r] = 1.0 + 0.1 * r * (-1.0) ** r
    Ny, Nw, z0, mono, v = np.empty((12, 12)), np.empty((12, 12)), np.empty((12, 1)), np.empty((4, 3)), np.empty(8)
    for y in ys:
        big = 0.0
        for r in range(12):
            for c2 in range(12):
                x_ = pen[2, r, c2] * (y * y) + pen[1, r, c2] * y + pen[0, r, c2]
                Ny[r, c2] = x_
                big = max(big, abs(x_))
        # the null vector (x4^i x5^j, i <= 3, j <= 2) by one step of inverse iteration, the matrix nudged
        # off exact singularity by a relative 1e-13 on its diagonal
        for r in range(12):
            Ny[r, r] += 1e-13 * big
        for r in range(12):
            z0[r, 0] = rhs12[r]
            for c2 in range(12):
                Nw[r, c2] = Ny[r, c2]
        z, ok = _gauss(Nw, z0)
        if ok:
            for r in range(12):
                mono[r // 3, r % 3] = z[r, 0]
        else:  # a zero pivot (a monomial no equation holds, on special arms): the SVD's null vector
            vt = np.linalg.svd(Ny)[2]
            for r in range(12):
                mono[r // 3, r % 3] = vt[11, r]
        j, i = 0, 0
        for r in range(3):
            if abs(mono[0, r]) > abs(mono[0, j]):
                j = r
        for r in range(4):
            if abs(mono[r, 0]) > abs(mono[i, 0]):
                i = r
        if mono[0, j] == 0.0 or mono[i, 0] == 0.0:
            continue
        den = c_ * y + d
        f3 = 2.0 * math.atan2(a * y + b, den)  # 2 atan(x3), up to a whole turn
        f4, f5 = 2.0 * math.atan(mono[1, j] / mono[0, j]), 2.0 * math.atan(mono[i, 1] / mono[i, 0])
        s4, c4, s5, c5 = math.sin(f4), math.cos(f4), math.sin(f5), math.cos(f5)
        v9[0], v9[1], v9[2], v9[3], v9[4], v9[5], v9[6], v9[7], v9[8] = (s4 * s5, s4 * c5, c4 * s5, c4 * c5, s4, c4,
                                                                           s5, c5, 1.0)
        s3, c3 = math.sin(f3), math.cos(f3)
        v[:] = 0.0
        for r in range(14):
            rhs = 0.0
            for t in range(9):
                rhs += (Ps[r, t] * s3 + Pc[r, t] * c3 + P1m[r, t]) * v9[t]
            for t in range(8):
                v[t] += Qp[t, r] * rhs
        q[roles[0]], q[roles[1]] = math.atan2(v[4], v[5]), math.atan2(v[6], v[7])
        q[roles[2]], q[roles[3]], q[roles[4]] = f3 + shift[0], f4 + shift[1], f5 + shift[2]
        jp = roles[5]
        _chain(H, P, q, jp, A)  # the joints before jp (q[jp] not read)
        for r in range(4):
            for cc in range(4):
                B[r, cc] = 1.0 if r == cc else 0.0
        for i2 in range(jp + 1, 6):  # the joints after it
            _times_motion(B, H[i2], P[i2], q[i2], Rs, us, Bs)
        # R_jp = R_Aᵀ R_G R_Bᵀ, R_G = R_T R_0ᵀ
        for r in range(3):
            for cc in range(3):
                g = T[r, 0] * T0[cc, 0] + T[r, 1] * T0[cc, 1] + T[r, 2] * T0[cc, 2]
                RG[r, cc] = g
        for r in range(3):
            for cc in range(3):
                acc = 0.0
                for k2 in range(3):
                    for k3 in range(3):
                        acc += A[k2, r] * RG[k2, k3] * B[cc, k3]
                R6[r, cc] = acc
        hp = H[jp]
        ux, uy, uz = (1.0, 0.0, 0.0) if abs(hp[0]) < 0.9 else (0.0, 1.0, 0.0)
        u0, u1, u2 = hp[1] * uz - hp[2] * uy, hp[2] * ux - hp[0] * uz, hp[0] * uy - hp[1] * ux
        un = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
        u0, u1, u2 = u0 / un, u1 / un, u2 / un
        Ru = (R6[0, 0] * u0 + R6[0, 1] * u1 + R6[0, 2] * u2, R6[1, 0] * u0 + R6[1, 1] * u1 + R6[1, 2] * u2,
              R6[2, 0] * u0 + R6[2, 1] * u1 + R6[2, 2] * u2)
        cr = (u1 * Ru[2] - u2 * Ru[1], u2 * Ru[0] - u0 * Ru[2], u0 * Ru[1] - u1 * Ru[0])
        q[jp] = math.atan2(hp[0] * cr[0] + hp[1] * cr[1] + hp[2] * cr[2], u0 * Ru[0] + u1 * Ru[1] + u2 * Ru[2])
        qp = _newton(H, P, T0, T, q, steps)
        new = True
        for r in range(6):
            x = qp[r]
            if not math.isfinite(x):
                new = False
            qp[r] = wrap(x)
        for r in range(k):
            far = 0.0
            for t in range(6):
                far = max(far, abs(wrap(qp[t] - out[r, t])))
            if far <= 1e-7:
                new = False
        if new:
            out[k] = qp
            k += 1
    return out[:k].copy()


@numba.njit(cache=True, error_model="numpy")
def _all_roots(T, rev, o, T0, Ps, Pc, P1, Rinv, RL, RC, RH, C, kron_of, mobius, H, P, shift, steps, roles, real_tol):
    """:func:`candidates` in one compiled call: the pencil, the eigenvalues (the companion deflated of
    its ±i block where the checks pass, else whole), the real ones' roots polished; (k, 6) [rad]."""
    for r in range(4):
        for c in range(4):
            if not math.isfinite(T[r, c]):
                return np.empty((0, 6))  # a goal with NaN or infinity has no solution (NO_SOLUTION, as elsewhere)
    Tg = np.zeros((4, 4))
    Tg[3, 3] = 1.0
    for r in range(3):
        for c in range(3):
            Tg[r, c] = T[c, r] if rev else T[r, c]
    for r in range(3):
        Tg[r, 3] = -(T[0, r] * T[0, 3] + T[1, r] * T[1, 3] + T[2, r] * T[2, 3]) if rev else T[r, 3]
    ok, comp, abcd, pen, Qp, P1m = _pencil(o, T0, Ps, Pc, P1, Rinv, RL, RC, RH, C, kron_of, Tg, mobius)
    if not ok:
        return np.empty((0, 6))
    wr, wi = np.empty(24), np.empty(24)
    B = np.empty((16, 16))
    A = B if _deflate(pen, comp, B) else comp
    n = A.shape[0]
    if not _eig_hess(A.copy(), wr[:n], wi[:n]) and _eigvals(A, wr[:n], wi[:n]) != 0:
        return np.empty((0, 6))
    ys = np.empty(n)
    k = 0
    for i in range(n):
        if abs(wi[i]) <= real_tol * (1.0 + math.hypot(wr[i], wi[i])):
            ys[k] = wr[i]
            k += 1
    roots = _roots(H, P, T0, Tg, Ps, Pc, P1m, Qp, abcd, pen, ys[:k], shift, steps, roles)
    if rev:  # back to the arm's joints: θ_k = −(reversed joint 7 − k), wrapped to (−π, π]
        out = np.empty_like(roots)
        for r in range(roots.shape[0]):
            for c in range(6):
                out[r, c] = wrap(-roots[r, 5 - c])
        return out
    return roots


_TURNS = (0.0, -2.0 * math.pi, 2.0 * math.pi, -4.0 * math.pi, 4.0 * math.pi)  # nearest the start first


@numba.njit(cache=True, error_model="numpy")
def general_pose(E, Tg, to_m, L, CK, limits_on, q_start, S, q, trace, start_row):
    """A goal solved whole in one compiled call, as :func:`pipeline.solvers.closed_form.analytic.solve_pose` does for
    the subproblem families.

    Every root (:func:`_all_roots`, ``E`` its arm arguments after the goal) wrapped to (−π, π], in
    order of wrapped distance to ``q_start`` (ties in root order); each kept when the dual-quaternion
    FK check passes under ``CK`` (:func:`~pipeline.solvers.core.check_pack` of the criterion and
    tolerances that decide a root, its limits with it). Without ``limits_on`` the kept roots go to
    ``S`` as they are and ``q`` is the first moved by whole turns to within π of the start; with it
    each kept root's representative within the limits nearest the start (by whole turns, joint by
    joint) goes to ``S``, the nearest of them first and ``q``; a kept root with none is dropped (when
    every kept root is, ``q`` is the nearest kept root's representative near the start, reported as a
    success for the finish to mark out of the limits). At most S's rows, NaN after. A start with a
    non-finite value has no distance to any root: no solution (as the subproblem families). ``trace``: the
    document's error at the start (when ``start_row`` or no solution) and at ``q``, by the joint
    lines ``L`` = (H (6, 3), P (6, 3), RM (3, 3), pM (3,)). ``Tg`` (4, 4) in the working unit,
    ``to_m`` its length factor to metres.

    Returns (solutions in S, roots, kept roots, code SUCCESS or NO_SOLUTION, the index of q's row
    among the listed ones before it was moved first, solve time [ns])."""
    clk = np.empty(2, np.int64)
    t0 = now_ns(clk)
    H, P, RM, pM = L
    Tm = Tg.copy()
    for r in range(3):
        Tm[r, 3] *= to_m
    roots = _all_roots(Tm, *E)
    for j in range(6):
        if not math.isfinite(q_start[j]):  # no distance to a NaN start: no solution, as the other families
            roots = roots[:0]
    k = roots.shape[0]
    F, prism, crit, tolp, tolr, toldq = check_fields(CK, 6)
    K, axis, offset, lim, buf = unpack_check(F, 6)
    dist = np.empty(k)
    for i in range(k):
        d = 0.0
        for j in range(6):
            roots[i, j] = wrap(roots[i, j])
            e = wrap(roots[i, j] - q_start[j])
            d += e * e
        dist[i] = d
    order = np.argsort(dist, kind="mergesort")  # stable: ties in root order
    kept = np.empty((k, 6))
    nk = 0
    for i in order:
        ok = True
        for j in range(6):
            ok &= math.isfinite(roots[i, j])
        if ok and check_one(K, axis, offset, prism, roots[i], Tg, crit, tolp, tolr, toldq, buf)[0]:
            kept[nk] = roots[i]
            nk += 1
    listed = np.empty((nk, 6))
    nl, best, bd = 0, -1, math.inf
    for i in range(nk):
        inside = True
        dd = 0.0
        for j in range(6):
            y = q_start[j] + wrap(kept[i, j] - q_start[j])
            if limits_on:
                found = False
                for t in _TURNS:
                    if lim[j, 0] - 1e-9 <= y + t <= lim[j, 1] + 1e-9:
                        y += t
                        found = True
                        break
                inside &= found
                listed[nl, j] = y
            else:
                listed[nl, j] = kept[i, j]
            dd += (y - q_start[j]) ** 2
        if inside:
            if dd < bd:
                bd, best = dd, nl
            nl += 1
    code = SUCCESS if nk > 0 else NO_SOLUTION
    if nl > 0:
        for j in range(6):
            q[j] = listed[best, j] if limits_on else q_start[j] + wrap(listed[best, j] - q_start[j])
    elif nk > 0:  # under limits_on: FK-valid, none within the limits
        bd2, b2 = math.inf, 0
        for i in range(nk):
            dd = 0.0
            for j in range(6):
                dd += wrap(kept[i, j] - q_start[j]) ** 2
            if dd < bd2:
                bd2, b2 = dd, i
        for j in range(6):
            q[j] = q_start[j] + wrap(kept[b2, j] - q_start[j])
    else:
        for j in range(6):
            q[j] = q_start[j]
    m = min(nl, S.shape[0])
    for a in range(m):  # the chosen row first, then the others in their order
        src = best if a == 0 else (a - 1 if a <= best else a)
        for j in range(6):
            S[a, j] = listed[src, j]
    for a in range(m, S.shape[0]):
        for j in range(6):
            S[a, j] = math.nan
    ns = now_ns(clk) - t0
    R, p, cs, Zf = np.empty((3, 3)), np.empty(3), np.full((6, 3), math.nan), np.empty(6, np.complex128)
    if start_row or nl == 0:
        fk_lines(H, P, RM, pM, q_start, R, p, cs, Zf)
        doc_row(Tg, R, p, trace[0])
    if nl == 0:
        for c in range(trace.shape[1]):
            trace[1, c] = trace[0, c]
    else:
        fk_lines(H, P, RM, pM, q, R, p, cs, Zf)
        doc_row(Tg, R, p, trace[1])
    return m, k, nk, code, best, ns


@numba.njit(cache=True, error_model="numpy")
def general_call(E, L, CK, GC, scale, Tg, q_start, S, q, trace):
    """The whole public single call of a general arm in one compiled call (as
    :func:`pipeline.solvers.closed_form.analytic.call_pose`), without limits: the goal scaled to the working unit
    by ``scale``, :func:`general_pose` (roots decided by ``CK``), then the independent FK check of
    ``q`` (:func:`~pipeline.solvers.core.finish_packed` on ``GC``, the solver's own criterion)."""
    Tw = Tg.copy()
    for r in range(3):
        Tw[r, 3] *= scale
    m, k, nk, code, best, ns = general_pose(E, Tw, 1.0, L, CK, False, q_start, S, q, trace, True)
    code, claimed, success, dp, ang, inside = finish_packed(GC, q, Tw, code)
    return m, k, ns, code, claimed, success, dp, ang, inside, trace[1, 0]


@numba.njit(cache=True, error_model="numpy", nogil=True)
def general_rows(E, to_m, L, CK, goals, starts, S, Qo, traces, doc, out, lo, hi):
    """:func:`general_pose` (without limits) for rows ``lo .. hi - 1`` of ``goals`` (N, 4, 4, working unit)
    and ``starts`` (N, 6), without the GIL (:func:`batch_arrays` runs row ranges on threads); each pose
    writes only its own rows, so the results do not depend on the split: ``S[i]`` (m, 6) its solutions,
    ``Qo[i]`` (6,) ``q``, ``traces[i]`` (2, 8) its trace (``traces`` (0, 2, 8): none kept, the row at the
    start unwritten), ``doc[i]`` the document's error at ``q``, ``out[i]`` (solutions, roots, kept roots,
    code, chosen, solve time [ns]). (Not a ``prange``: numba's parallel loops do not take the arm's
    argument tuple ``E``.)"""
    keep = traces.shape[0] == goals.shape[0]
    scratch = np.empty((2, TRACE_COLS))
    for i in range(lo, hi):
        tr = traces[i] if keep else scratch
        m, k, nk, code, best, ns = general_pose(E, goals[i], to_m, L, CK, False, starts[i], S[i], Qo[i], tr, keep)
        doc[i] = tr[1, 0]
        out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4], out[i, 5] = m, k, nk, code, best, ns


def batch_arrays(prep: Prepared, s: General6RSettings, goals: np.ndarray, starts: np.ndarray, keep_traces: bool):
    """N goals by :func:`general_rows`, in as many row ranges on as many threads as numba's thread count
    (the ``threads`` of :func:`pipeline.solvers.solve_batch`; ranges of 16 rows at least): (S (N,
    max_solutions, 6), q (N, 6), traces (N or 0, 2, 8), doc (N,), out (N, 6) int)."""
    E, to_m, lines, CK = pose_args(prep, s)
    N = goals.shape[0]
    S = np.empty((N, s.max_solutions, 6))
    Q = np.empty((N, 6))
    traces = np.empty((N if keep_traces else 0, 2, TRACE_COLS))
    doc = np.empty(N)
    out = np.zeros((N, 6), np.int64)
    args = (E, to_m, lines, CK, np.ascontiguousarray(goals, dtype=float), np.ascontiguousarray(starts, dtype=float), S,
            Q, traces, doc, out)
    k = max(1, min(numba.get_num_threads(), N // 16))
    cut = [N * j // k for j in range(k + 1)]
    if k == 1:
        general_rows(*args, 0, N)
    else:
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(k) as pool:
            for f in [pool.submit(general_rows, *args, cut[j], cut[j + 1]) for j in range(k)]:
                f.result()
    return S, Q, traces, doc, out


def lines_of(prep: Prepared) -> tuple:
    """The arm's joint lines in the working unit for :func:`general_pose`'s trace: (H, P, RM, pM)."""
    def make():
        from pipeline.kinematics import geometry

        L = geometry.joint_lines(prep.model.chain)
        c = np.ascontiguousarray
        return c(L.h, dtype=float), c(L.p, dtype=float), c(L.M[:3, :3], dtype=float), c(L.M[:3, 3], dtype=float)

    return prep.memo(("general_6r", "lines"), make)


def elimination_args(m: _Model, s: General6RSettings) -> tuple:
    """The arm's arguments of :func:`_all_roots` after the goal (``E`` of :func:`general_pose`)."""
    return (m.reversed, m.eP[m.roles[2]], m.eT0, *m.left, m.right_inv, m.right_L, m.right_c, m.right_h, m.C,
            _KRON_OF, _MOBIUS, m.eH, m.eP, SHIFT, s.polish_steps, m.roles, s.real_tol)


def pose_args(prep: Prepared, s: General6RSettings) -> tuple:
    """(``E``, metres per working unit, the joint lines, the check pack that keeps a root under ``s``'s
    criterion and tolerances): :func:`general_pose`'s arm arguments, built once per job."""
    return elimination_args(model(prep), s), metric(prep).to_m, lines_of(prep), check_pack(prep, s)


def bind_pose(prep: Prepared, s: General6RSettings, limits_on: bool, start_row: bool):
    """``solve1(T_goal, q_start) -> ((solutions, roots, kept roots, code, chosen, ns), S, q, trace)``:
    :func:`general_pose` with its arm arguments (:func:`pose_args`) built once; ``S`` holds
    ``s.max_solutions`` rows."""
    E, to_m, lines, CK = pose_args(prep, s)
    ms, c, empty = s.max_solutions, np.ascontiguousarray, np.empty

    def solve1(T_goal: np.ndarray, q_start: np.ndarray):
        S, q, trace = empty((ms, 6)), empty(6), empty((2, TRACE_COLS))
        out = general_pose(E, c(T_goal, dtype=float), to_m, lines, CK, limits_on, c(q_start, dtype=float), S, q,
                           trace, start_row)
        return out, S, q, trace

    return solve1


def candidates(m: _Model, T: np.ndarray, s: General6RSettings) -> np.ndarray:
    """Every root of the elimination for the goal ``T`` (4, 4) [m], polished: (k, 6) [rad], k <= 16
    (not yet FK-checked; duplicates merged)."""
    return _all_roots(np.ascontiguousarray(T, dtype=float), *elimination_args(m, s))


def _found_all(m: _Model) -> bool:
    """The roots of the poses of three configurations of the arm contain each configuration."""
    s = General6RSettings()
    for q in _CHECK_Q:
        roots = candidates(m, _fk(m, q), s)
        if not any(np.abs(wrap_angles(q - r)).max() < 1e-6 for r in roots):
            return False
    return True


def _choice(prep: Prepared) -> tuple[_Model, str | None]:
    """(the model to solve with, why the elimination does not apply or None), once per robot: the first
    of split 0 on the arm's chain, on the chain read from the tool back, then split 1 on each (:data:`SPLITS`)
    that finds every test configuration. One can degenerate where another does not (axes 1 and 2
    parallel: split 0 from the tool; a spherical wrist or three parallel axes: split 1)."""

    def choose():
        first = _model(prep)
        for m in (first, _model(prep, True), _model(prep, False, 1), _model(prep, True, 1)):
            if _found_all(m):
                return m, None
        return first, ("the general 6R elimination degenerates for this geometry, whichever way the loop is split "
                       "(a configuration of the arm is not among the roots of its own pose, as with two axes on "
                       "one line)")

    return prep.memo(("general_6r", "model"), choose)


def model(prep: Prepared) -> _Model:
    return _choice(prep)[0]


def degenerate(prep: Prepared) -> str | None:
    """Why the elimination does not solve this 6R revolute arm (one line), or None: once per robot, the
    goals of three configurations of the arm are solved and each configuration must be among the
    roots, on the arm's chain or on the chain read from the tool back. Arms with intersecting or
    parallel axes make the pencil singular for every ``x3``."""
    return _choice(prep)[1]


def applies_to(prep: Prepared) -> str | None:
    why = six_revolute(prep, "general_6r")
    if why:
        return why
    why = degenerate(prep)
    return None if why is None else f"{why}; `analytic` solves such arms by subproblems where a family fits"


def bind(prep: Prepared, s: General6RSettings):
    """``run1``: every FK-valid solution, nearest to the start first (under ``require_limits`` those with
    a representative within the limits, the nearest of them first), in one compiled call
    (:func:`general_pose`)."""
    solve1 = bind_pose(prep, s, bool(s.require_limits), False)

    def run1(T_goal: np.ndarray, q_start: np.ndarray, seed: int) -> Raw:
        (m, k, nk, code, best, ns), S, q, _ = solve1(T_goal, q_start)
        return Raw(q=q, code=int(code), iterations=0, solve_ns=int(ns), solutions=S[:m],
                   info={"roots": k, "n_solutions": m, "n_returned": k, "n_least_squares": 0, "n_fk_valid": nk,
                         "chosen": best})

    return run1


run = run_of(bind)


register(Solver("general_6r", "every real solution of any 6R arm by algebraic elimination (Raghavan-Roth, "
                "Manocha-Canny: a 24 x 24 companion deflated to 16 x 16, roots polished by Newton and FK-checked), "
                "nearest to the start", "analytic", General6RSettings, run, applies_to=applies_to, source=SOURCE,
                bind=bind))
