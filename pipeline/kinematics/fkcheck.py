"""The independent success check, compiled: forward kinematics by unit dual quaternions.

Every solver's claimed success is re-checked by forward kinematics that share no code with the
solvers' own (:mod:`pipeline.solvers._kin` multiplies homogeneous matrices). This module writes a
chain as a product of unit dual quaternions (DQ, w-first, :mod:`pipeline.kinematics.dualquat`)::

    K_0 M_0(q_0) K_1 M_1(q_1) ... M_{n-1}(q_{n-1}) K_n

with constant DQs ``K`` (base, the fixed parts of each link, tool; built once per robot by
:func:`check_model` with the numpy reference) and joint motions ``M_i``: a rotation about, or a
translation along, the unit axis ``k_i`` by ``q_i + offset_i``. For standard DH a revolute link
is ``Rz(theta) | Tz(d) Tx(a) Rx(alpha)``, a prismatic one ``Rz(theta) | Tz(d) | Tx(a) Rx(alpha)``;
modified DH puts ``Rx(alpha) Tx(a)`` first; the general (URDF) form is ``origin | motion``.

:func:`pose_check` (compiled, one pose, no allocation) returns what the success test needs:
``|dp|`` [length], the rotation angle between goal and reached orientation [rad], and ``|t|``,
the translation of ``T_goal T^-1`` (for the dual-quaternion norm criteria). ``tests/test_fkcheck.py``
compares it with the numpy HTM forward kinematics on random chains of every form.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from pipeline.kinematics.chain import Chain
from pipeline.kinematics.dualquat import dq_from_transform, dq_mul
from pipeline.kinematics.htm import dh_transform


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


@numba.njit(cache=True, error_model="numpy")
def fk_dq(K, axis, offset, prism, q, out):
    """Tool pose of joint values ``q`` (n,) as a unit DQ into ``out`` (8,)."""
    r0, r1, r2, r3 = K[0, 0], K[0, 1], K[0, 2], K[0, 3]
    d0, d1, d2, d3 = K[0, 4], K[0, 5], K[0, 6], K[0, 7]
    n = q.shape[0]
    for i in range(n):
        x = q[i] + offset[i]
        k0, k1, k2 = axis[i, 0], axis[i, 1], axis[i, 2]
        if prism[i]:  # M = (1, 0 | 0, x k / 2): real part unchanged, dual += r (0, x k / 2)
            h = 0.5 * x
            e0, e1, e2, e3 = _qmul(r0, r1, r2, r3, 0.0, h * k0, h * k1, h * k2)
            d0, d1, d2, d3 = d0 + e0, d1 + e1, d2 + e2, d3 + e3
        else:  # M = (cos x/2, sin x/2 k | 0)
            c, s = math.cos(0.5 * x), math.sin(0.5 * x)
            m1, m2, m3 = s * k0, s * k1, s * k2
            r0, r1, r2, r3 = _qmul(r0, r1, r2, r3, c, m1, m2, m3)
            d0, d1, d2, d3 = _qmul(d0, d1, d2, d3, c, m1, m2, m3)
        # times the constant K[i + 1]: (r kr, r kd + d kr)
        j = i + 1
        kr0, kr1, kr2, kr3 = K[j, 0], K[j, 1], K[j, 2], K[j, 3]
        kd0, kd1, kd2, kd3 = K[j, 4], K[j, 5], K[j, 6], K[j, 7]
        e0, e1, e2, e3 = _qmul(r0, r1, r2, r3, kd0, kd1, kd2, kd3)
        f0, f1, f2, f3 = _qmul(d0, d1, d2, d3, kr0, kr1, kr2, kr3)
        d0, d1, d2, d3 = e0 + f0, e1 + f1, e2 + f2, e3 + f3
        r0, r1, r2, r3 = _qmul(r0, r1, r2, r3, kr0, kr1, kr2, kr3)
    out[0], out[1], out[2], out[3] = r0, r1, r2, r3
    out[4], out[5], out[6], out[7] = d0, d1, d2, d3


@numba.njit(cache=True, error_model="numpy")
def _quat_of(T):
    """Unit quaternion (w-first) of the rotation part of ``T`` (Shepperd's method)."""
    m00, m11, m22 = T[0, 0], T[1, 1], T[2, 2]
    tr = m00 + m11 + m22
    if tr > 0.0:
        s = 2.0 * math.sqrt(1.0 + tr)
        return 0.25 * s, (T[2, 1] - T[1, 2]) / s, (T[0, 2] - T[2, 0]) / s, (T[1, 0] - T[0, 1]) / s
    if m00 > m11 and m00 > m22:
        s = 2.0 * math.sqrt(max(1.0 + m00 - m11 - m22, 1e-300))
        return (T[2, 1] - T[1, 2]) / s, 0.25 * s, (T[0, 1] + T[1, 0]) / s, (T[0, 2] + T[2, 0]) / s
    if m11 > m22:
        s = 2.0 * math.sqrt(max(1.0 + m11 - m00 - m22, 1e-300))
        return (T[0, 2] - T[2, 0]) / s, (T[0, 1] + T[1, 0]) / s, 0.25 * s, (T[1, 2] + T[2, 1]) / s
    s = 2.0 * math.sqrt(max(1.0 + m22 - m00 - m11, 1e-300))
    return (T[1, 0] - T[0, 1]) / s, (T[0, 2] + T[2, 0]) / s, (T[1, 2] + T[2, 1]) / s, 0.25 * s


@numba.njit(cache=True, error_model="numpy")
def pose_check(K, axis, offset, prism, q, Tg, buf):
    """Errors of joint values ``q`` (n,) against the goal ``Tg`` (4, 4); ``buf`` (8,) is scratch.

    Returns
    -------
    dp : float      |p_goal - p| [length]
    angle : float   rotation angle of ``R_goal R^T`` in [0, pi] [rad]
    t : float       |translation of T_goal T^-1| [length]
    (NaN everywhere when ``q`` holds a non-finite value.)
    """
    for i in range(q.shape[0]):
        if not math.isfinite(q[i]):
            return math.nan, math.nan, math.nan
    fk_dq(K, axis, offset, prism, q, buf)
    r0, r1, r2, r3 = buf[0], buf[1], buf[2], buf[3]
    nr = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2 + r3 * r3)
    # p = 2 d r*  (vector part), with r normalised against rounding
    w, x, y, z = _qmul(buf[4], buf[5], buf[6], buf[7], r0, -r1, -r2, -r3)
    px, py, pz = 2.0 * x / (nr * nr), 2.0 * y / (nr * nr), 2.0 * z / (nr * nr)
    r0, r1, r2, r3 = r0 / nr, r1 / nr, r2 / nr, r3 / nr
    dx, dy, dz = Tg[0, 3] - px, Tg[1, 3] - py, Tg[2, 3] - pz
    dp = math.sqrt(dx * dx + dy * dy + dz * dz)
    g0, g1, g2, g3 = _quat_of(Tg)
    # relative rotation g r*: angle = 2 atan2(|vec|, |w|)
    e0, e1, e2, e3 = _qmul(g0, g1, g2, g3, r0, -r1, -r2, -r3)
    angle = 2.0 * math.atan2(math.sqrt(e1 * e1 + e2 * e2 + e3 * e3), abs(e0))
    # t = p_goal - R_rel p, R_rel p = e (0, p) e*
    a0, a1, a2, a3 = _qmul(e0, e1, e2, e3, 0.0, px, py, pz)
    _, b1, b2, b3 = _qmul(a0, a1, a2, a3, e0, -e1, -e2, -e3)
    ne = e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3
    tx, ty, tz = Tg[0, 3] - b1 / ne, Tg[1, 3] - b2 / ne, Tg[2, 3] - b3 / ne
    return dp, angle, math.sqrt(tx * tx + ty * ty + tz * tz)


@numba.njit(cache=True, error_model="numpy")
def meets(crit, tol_pos, tol_rot, tol_dq, dp, ang, t):
    """The success test (criterion codes of :data:`pipeline.solvers.base.CRITERION_CODE`)."""
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
    """(meets the criterion, |dp|, angle, |t|) of one solution."""
    dp, ang, t = pose_check(K, axis, offset, prism, q, Tg, buf)
    return meets(crit, tol_pos, tol_rot, tol_dq, dp, ang, t), dp, ang, t


@numba.njit(cache=True, error_model="numpy", parallel=True)
def check_many(K, axis, offset, prism, Q, goals, crit, tol_pos, tol_rot, tol_dq, ok, out):
    """:func:`check_one` for every row: ``Q`` (N, n), ``goals`` (N, 4, 4) -> ``ok`` (N,), ``out`` (N, 3)."""
    for k in numba.prange(Q.shape[0]):
        buf = np.empty(8)
        r, dp, ang, t = check_one(K, axis, offset, prism, Q[k], goals[k], crit, tol_pos, tol_rot, tol_dq, buf)
        ok[k] = r
        out[k, 0], out[k, 1], out[k, 2] = dp, ang, t
