"""The independent success check, compiled: forward kinematics by unit dual quaternions.

Every solver's claimed success is re-checked by forward kinematics that share no code with the
solvers' own (:mod:`pipeline.solvers.kernels.kin` multiplies homogeneous matrices). This module writes a
chain as a product of unit dual quaternions (DQ, w-first, :mod:`pipeline.kinematics.dualquat`)::

    K_0 M_0(q_0) K_1 M_1(q_1) ... M_{n-1}(q_{n-1}) K_n

with constant DQs ``K`` (base, the fixed parts of each link, tool; built once per robot by
:func:`check_model` with the numpy reference) and joint motions ``M_i``: a rotation about, or a
translation along, the unit axis ``k_i`` by ``q_i + offset_i``. For standard DH a revolute link
is ``Rz(theta) | Tz(d) Tx(a) Rx(alpha)``, a prismatic one ``Rz(theta) | Tz(d) | Tx(a) Rx(alpha)``;
modified DH puts ``Rx(alpha) Tx(a)`` first; the general (URDF) form is ``origin | motion``.

:func:`pose_check` (compiled, one pose, no allocation) returns what the success test needs:
``|dp|`` [length], the rotation angle between goal and reached orientation [rad], and ``|t|``,
the translation of ``T_goal T^-1`` (for the dual-quaternion norm criteria). :func:`pose_check8` gives
the same floats for 8 poses at once, as the lanes of vector instructions (a batch's finish): both
take their sines, cosines and arctangent from :mod:`pipeline.kinematics.vmath`, whose polynomials
vectorize, and share every formula (:func:`_joint_step`, :func:`_errors_of`). ``tests/solvers/core/test_fast_path.py``
compares the check with the numpy HTM forward kinematics on random chains of every form,
``tests/kinematics/test_vmath.py`` the two checks with each other.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from pipeline.kinematics.chain import Chain
from pipeline.kinematics.dualquat import dq_from_transform
from pipeline.kinematics.htm import dh_transform
from pipeline.kinematics.vmath import atan2, atan2_core, sincos, sincos_core


def check_model(chain: Chain) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The chain as constant DQs and joint motions (see the module docstring).

    Returns
    -------
    K : ndarray, shape (n + 1, 8)    constant DQs between the motions (base and tool folded in)
    axis : ndarray, shape (n, 3)     unit joint axes, each in its motion's own frame
    offset : ndarray, shape (n,)     added to q [rad | length]
    prismatic : ndarray of bool, shape (n,)
    """
    n = chain.n
    I4 = np.eye(4)
    pre = [I4] * n
    post = [I4] * n
    axis = np.zeros((n, 3))
    offset = np.zeros(n)
    pris = np.asarray(chain.prismatic, dtype=bool)
    for i in range(n):
        if chain.general:
            pre[i], axis[i] = np.asarray(chain.origins[i], dtype=float), chain.axes[i]
            continue
        axis[i] = (0.0, 0.0, 1.0)
        a, al, d, th = (float(chain.a[i]), float(chain.alpha[i]), float(chain.d[i]), float(chain.theta_offset[i]))
        if chain.modified:  # Rx(alpha) Tx(a) | Rz(theta) | Tz(d)
            if pris[i]:
                pre[i], offset[i] = dh_transform(a, al, 0.0, th, "modified"), d
            else:
                pre[i], post[i], offset[i] = dh_transform(a, al, 0.0, 0.0, "modified"), dh_transform(0.0, 0.0, d, 0.0), th
        else:  # Rz(theta) | Tz(d) | Tx(a) Rx(alpha)
            if pris[i]:
                pre[i], post[i], offset[i] = dh_transform(0.0, 0.0, 0.0, th), dh_transform(a, al, 0.0, 0.0), d
            else:
                post[i], offset[i] = dh_transform(a, al, d, 0.0), th
    K = np.empty((n + 1, 8))
    K[0] = dq_from_transform(np.asarray(chain.base, dtype=float) @ pre[0])
    for i in range(1, n):
        K[i] = dq_from_transform(post[i - 1] @ pre[i])
    K[n] = dq_from_transform(post[n - 1] @ np.asarray(chain.tool, dtype=float))
    for i in range(n + 1):  # keep the real parts in one hemisphere (the sign of a DQ is free)
        if K[i, 0] < 0:
            K[i] = -K[i]
    return np.ascontiguousarray(K), np.ascontiguousarray(axis), offset, pris


@numba.njit(cache=True, error_model="numpy", inline="always")
def _qmul(a0, a1, a2, a3, b0, b1, b2, b3):
    return (a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
            a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _joint_step(r0, r1, r2, r3, d0, d1, d2, d3, h, s, c, k0, k1, k2, pr, kr0, kr1, kr2, kr3, kd0, kd1, kd2, kd3):
    """The pose (r | d) times joint i's motion and then the constant (kr | kd) = K[i + 1]; ``h`` is half
    the joint value plus offset, ``s`` and ``c`` its sine and cosine (used by a revolute joint).

    One formula for both joint kinds, without a branch (a loop over poses then vectorizes): the motion
    is (cos h, sin h k | 0, 0) for a revolute joint and (1, 0 | 0, h k) for a prismatic one (``pr``
    true), and (r | d)(m | e) = (r m | r e + d m). Both kinds are exact this way: a product by (1, 0) or
    by a zero dual part adds only zeros."""
    c = 1.0 if pr else c
    s = 0.0 if pr else s
    e = h if pr else 0.0
    m1, m2, m3 = s * k0, s * k1, s * k2
    a0, a1, a2, a3 = _qmul(r0, r1, r2, r3, 0.0, e * k0, e * k1, e * k2)
    b0, b1, b2, b3 = _qmul(d0, d1, d2, d3, c, m1, m2, m3)
    d0, d1, d2, d3 = a0 + b0, a1 + b1, a2 + b2, a3 + b3
    r0, r1, r2, r3 = _qmul(r0, r1, r2, r3, c, m1, m2, m3)
    # times the constant: (r kr | r kd + d kr)
    e0, e1, e2, e3 = _qmul(r0, r1, r2, r3, kd0, kd1, kd2, kd3)
    f0, f1, f2, f3 = _qmul(d0, d1, d2, d3, kr0, kr1, kr2, kr3)
    r0, r1, r2, r3 = _qmul(r0, r1, r2, r3, kr0, kr1, kr2, kr3)
    return r0, r1, r2, r3, e0 + f0, e1 + f1, e2 + f2, e3 + f3


@numba.njit(cache=True, error_model="numpy", inline="always")
def _errors_of(r0, r1, r2, r3, d0, d1, d2, d3, g, o, st):
    """(|dp|, cos and sin of the rotation angle, |t|) of the tool pose (r | d) against the goal whose
    first three rows are ``g[o], g[o + st], ..., g[o + 11 st]`` (row-major; ``o`` unsigned; ``st`` 1 for
    a goal's own 16 floats).

    With R the rotation of the (normalised) real part and p = 2 vec(d r*) / |r|², R_rel = R_goal Rᵀ:
    dp = p_goal − p, cos = (tr R_rel − 1) / 2, sin = |vee(R_rel − R_relᵀ)| / 2, t = p_goal − R_rel p
    (the formulas of :func:`pipeline.solvers.core.pose_errors`, the numpy check)."""
    nr2 = r0 * r0 + r1 * r1 + r2 * r2 + r3 * r3
    _, x, y, z = _qmul(d0, d1, d2, d3, r0, -r1, -r2, -r3)
    px, py, pz = 2.0 * x / nr2, 2.0 * y / nr2, 2.0 * z / nr2
    nr = math.sqrt(nr2)
    w, x, y, z = r0 / nr, r1 / nr, r2 / nr, r3 / nr
    R00, R01, R02 = 1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)
    R10, R11, R12 = 2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)
    R20, R21, R22 = 2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)
    G00, G01, G02, gx = g[o], g[o + st], g[o + 2 * st], g[o + 3 * st]
    G10, G11, G12, gy = g[o + 4 * st], g[o + 5 * st], g[o + 6 * st], g[o + 7 * st]
    G20, G21, G22, gz = g[o + 8 * st], g[o + 9 * st], g[o + 10 * st], g[o + 11 * st]
    # R_rel[a, b] = Σ_k G[a, k] R[b, k]
    A00 = G00 * R00 + G01 * R01 + G02 * R02
    A01 = G00 * R10 + G01 * R11 + G02 * R12
    A02 = G00 * R20 + G01 * R21 + G02 * R22
    A10 = G10 * R00 + G11 * R01 + G12 * R02
    A11 = G10 * R10 + G11 * R11 + G12 * R12
    A12 = G10 * R20 + G11 * R21 + G12 * R22
    A20 = G20 * R00 + G21 * R01 + G22 * R02
    A21 = G20 * R10 + G21 * R11 + G22 * R12
    A22 = G20 * R20 + G21 * R21 + G22 * R22
    dx, dy, dz = gx - px, gy - py, gz - pz
    u, v, s_ = A21 - A12, A02 - A20, A10 - A01
    tx = gx - (A00 * px + A01 * py + A02 * pz)
    ty = gy - (A10 * px + A11 * py + A12 * pz)
    tz = gz - (A20 * px + A21 * py + A22 * pz)
    return (math.sqrt(dx * dx + dy * dy + dz * dz), 0.5 * (A00 + A11 + A22 - 1.0),
            0.5 * math.sqrt(u * u + v * v + s_ * s_), math.sqrt(tx * tx + ty * ty + tz * tz))


@numba.njit(cache=True, error_model="numpy")
def pose_check(K, axis, offset, prism, q, Tg, buf):
    """Errors of joint values ``q`` against the goal ``Tg``, one pose, no allocation.

    :func:`pose_check8` gives the same floats, bit for bit, for 8 poses at once.

    Parameters
    ----------
    K : ndarray, shape (n + 1, 8) [1 | length]
        Constant DQs between the motions (base and tool folded in), from :func:`check_model`.
    axis : ndarray, shape (n, 3) [1]
        Unit joint axes, each in its motion's own frame.
    offset : ndarray, shape (n,) [rad | length]
        Added to the joint values.
    prism : ndarray of bool, shape (n,)
        Which joints are prismatic.
    q : ndarray, shape (n,) [rad | length]
        Joint values.
    Tg : ndarray, shape (4, 4) [length]
        Goal pose.
    buf : ndarray, shape (m,) [1]
        Unused (kept for the callers' signature).

    Returns
    -------
    dp : float
        ``|p_goal - p|`` [length].
    angle : float
        Rotation angle of ``R_goal R^T`` [rad], in [0, pi].
    t : float
        ``|translation of T_goal T^-1|`` [length]. All three are NaN when ``q`` holds a non-finite value.
    """
    for i in range(q.shape[0]):
        if not math.isfinite(q[i]):
            return math.nan, math.nan, math.nan
    r0, r1, r2, r3, d0, d1, d2, d3 = K[0, 0], K[0, 1], K[0, 2], K[0, 3], K[0, 4], K[0, 5], K[0, 6], K[0, 7]
    for i in range(q.shape[0]):
        h = 0.5 * (q[i] + offset[i])
        s, c = sincos(h)
        r0, r1, r2, r3, d0, d1, d2, d3 = _joint_step(r0, r1, r2, r3, d0, d1, d2, d3, h, s, c, axis[i, 0], axis[i, 1],
                                                     axis[i, 2], prism[i], K[i + 1, 0], K[i + 1, 1], K[i + 1, 2],
                                                     K[i + 1, 3], K[i + 1, 4], K[i + 1, 5], K[i + 1, 6], K[i + 1, 7])
    dp, c, s, t = _errors_of(r0, r1, r2, r3, d0, d1, d2, d3, Tg.ravel(), np.uint64(0), 1)
    return dp, atan2(s, c), t


CHECK8_SCRATCH = 200  # floats of pose_check8's scratch besides 8 per joint


@numba.njit(cache=True, error_model="numpy")
def pose_check8(K, axis, offset, prism, Q, goals, k0, W, out):
    """:func:`pose_check` of the 8 rows ``k0 .. k0 + 7`` of ``Q``, the same floats bit for bit.

    The poses are the vector lanes. Every value a pass reads or writes lies in the one array ``W`` at a
    constant offset (quantity × 8 + row, indexed unsigned), so the compiler sees that the rows do not
    overlap and runs the pass as vector instructions, 8 rows at once with AVX-512: each row's dual
    quaternion at 0-63, the present joint's values at 64-71, the goals' 12 values at 72-167, the results
    at 168-191, every joint's values from 200. A block with a value :func:`sincos_core` does not take
    (NaN, infinite, beyond 2e5 [rad | length]) is checked again row by row.

    Parameters
    ----------
    K : ndarray, shape (n + 1, 8) [1 | length]
        Constant DQs between the motions (base and tool folded in), from :func:`check_model`.
    axis : ndarray, shape (n, 3) [1]
        Unit joint axes, each in its motion's own frame.
    offset : ndarray, shape (n,) [rad | length]
        Added to the joint values.
    prism : ndarray of bool, shape (n,)
        Which joints are prismatic.
    Q : ndarray, shape (N, n) [rad | length]
        Joint values, one row per pose.
    goals : ndarray, shape (N, 4, 4) [length]
        Goal poses.
    k0 : int
        First of the 8 rows.
    W : ndarray, shape (CHECK8_SCRATCH + 8 n,) [1]
        Scratch (at least :data:`CHECK8_SCRATCH` + 8 n floats).
    out : ndarray, shape (3, 8) [length | rad]
        Written: ``|dp|``, angle and ``|t|`` per row.
    """
    n = Q.shape[1]
    for lane in range(8):
        for c in range(8):
            W[8 * c + lane] = K[0, c]
        for r in range(3):
            for c in range(4):
                W[72 + 8 * (4 * r + c) + lane] = goals[k0 + lane, r, c]
        for i in range(n):
            W[200 + 8 * i + lane] = Q[k0 + lane, i] + offset[i]
    odd = 0
    for i in range(n):
        a0, a1, a2, pr = axis[i, 0], axis[i, 1], axis[i, 2], prism[i]
        kr0, kr1, kr2, kr3 = K[i + 1, 0], K[i + 1, 1], K[i + 1, 2], K[i + 1, 3]
        kd0, kd1, kd2, kd3 = K[i + 1, 4], K[i + 1, 5], K[i + 1, 6], K[i + 1, 7]
        for lane in range(8):  # half this joint's values, at a constant offset
            W[64 + lane] = 0.5 * W[200 + 8 * i + lane]
        for lane in range(8):
            u = np.uint64(lane)  # unsigned: no wrap-around select on the index
            h = W[64 + u]
            s, c, ok = sincos_core(h)
            odd += not ok
            r0, r1, r2, r3, d0, d1, d2, d3 = _joint_step(W[u], W[8 + u], W[16 + u], W[24 + u], W[32 + u], W[40 + u],
                                                         W[48 + u], W[56 + u], h, s, c, a0, a1, a2, pr, kr0, kr1,
                                                         kr2, kr3, kd0, kd1, kd2, kd3)
            W[u], W[8 + u], W[16 + u], W[24 + u] = r0, r1, r2, r3
            W[32 + u], W[40 + u], W[48 + u], W[56 + u] = d0, d1, d2, d3
    for lane in range(8):
        u = np.uint64(lane)
        dp, c, s, t = _errors_of(W[u], W[8 + u], W[16 + u], W[24 + u], W[32 + u], W[40 + u], W[48 + u], W[56 + u],
                                 W, 72 + u, 8)
        a, ok = atan2_core(s, c)
        W[168 + u], W[176 + u], W[184 + u] = dp, a, t
        W[192 + u] = ok
    unusual = 0
    for lane in range(8):
        out[0, lane], out[1, lane], out[2, lane] = W[168 + lane], W[176 + lane], W[184 + lane]
        unusual += W[192 + lane] == 0.0
    if unusual:  # a zero or non-finite pair: libm's atan2
        for lane in range(8):
            dp, c, s, t = _errors_of(W[lane], W[8 + lane], W[16 + lane], W[24 + lane], W[32 + lane],
                                     W[40 + lane], W[48 + lane], W[56 + lane], W, np.uint64(72 + lane), 8)
            if not atan2_core(s, c)[1]:
                out[1, lane] = math.atan2(s, c)
    if odd:  # a value beyond sincos_core (NaN, infinite, huge): the rows again, one at a time
        for lane in range(8):
            out[0, lane], out[1, lane], out[2, lane] = pose_check(K, axis, offset, prism, Q[k0 + lane],
                                                                  goals[k0 + lane], W)


@numba.njit(cache=True, error_model="numpy")
def meets(crit, tol_pos, tol_rot, tol_dq, dp, ang, t):
    """The success test (criterion codes of :data:`pipeline.solvers.core.CRITERION_CODE`)."""
    if not math.isfinite(dp) or (crit != 1 and not math.isfinite(ang)):
        return False
    if crit == 2:
        return math.sqrt(1.0 + t * t / 4.0) <= tol_dq * (1.0 + 1e-12)
    if crit == 3:
        return math.sqrt(1.0 + dp * dp / 4.0) <= tol_dq * (1.0 + 1e-12)
    if crit == 1:
        return dp <= tol_pos * (1.0 + 1e-9)
    return dp <= tol_pos * (1.0 + 1e-9) and ang <= tol_rot * (1.0 + 1e-9)


@numba.njit(cache=True, error_model="numpy")
def check_one(K, axis, offset, prism, q, Tg, crit, tol_pos, tol_rot, tol_dq, buf):
    """(meets the criterion, ``|dp|``, angle, ``|t|``) of one solution.

    Parameters
    ----------
    K : ndarray, shape (n + 1, 8) [1 | length]
        Constant DQs between the motions (base and tool folded in), from :func:`check_model`.
    axis : ndarray, shape (n, 3) [1]
        Unit joint axes, each in its motion's own frame.
    offset : ndarray, shape (n,) [rad | length]
        Added to the joint values.
    prism : ndarray of bool, shape (n,)
        Which joints are prismatic.
    q : ndarray, shape (n,) [rad | length]
        Joint values.
    Tg : ndarray, shape (4, 4) [length]
        Goal pose.
    crit : int
        Criterion code (:data:`pipeline.solvers.core.CRITERION_CODE`).
    tol_pos, tol_rot, tol_dq : float
        Position [length], orientation [rad] and dual-quaternion-norm tolerances.
    buf : ndarray, shape (m,) [1]
        Unused (kept for the callers' signature).
    """
    dp, ang, t = pose_check(K, axis, offset, prism, q, Tg, buf)
    return meets(crit, tol_pos, tol_rot, tol_dq, dp, ang, t), dp, ang, t
