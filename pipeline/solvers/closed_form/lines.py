"""Forward kinematics on joint lines, compiled: the pose of a product of exponentials
``E_1(θ_1) ⋯ E_n(θ_n) M`` (each ``E_i`` the rotation about joint line i: a unit axis and a point on
it), its distance to a goal within the FK check's tolerances, and the document's error row. Shared by
the closed forms (:mod:`pipeline.solvers.closed_form.analytic`) and the general elimination
(:mod:`pipeline.solvers.closed_form.general6r`); poses as 12 floats (the rotation row by row, then the
translation) or R (3, 3) and p (3,), lengths in the caller's unit."""

from __future__ import annotations

import math

import numba

from pipeline.solvers.kernels.pose import half_cross

EYE_ACC = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)


@numba.njit(cache=True, error_model="numpy", inline="always")
def poe_step(acc, line, c, s_):
    """``acc`` (the rotation's 9 entries row by row, then the translation: 12 floats) times one POE
    factor: the rotation by θ (``c``, ``s_`` = cos θ, sin θ) about the joint line ``line`` = (x, y, z,
    px, py, pz), through (px, py, pz) along the unit (x, y, z)."""
    x, y, z, px, py, pz = line
    C = 1.0 - c
    r00, r01, r02 = c + x * x * C, x * y * C - z * s_, x * z * C + y * s_
    r10, r11, r12 = y * x * C + z * s_, c + y * y * C, y * z * C - x * s_
    r20, r21, r22 = z * x * C - y * s_, z * y * C + x * s_, c + z * z * C
    ux = px - (r00 * px + r01 * py + r02 * pz)
    uy = py - (r10 * px + r11 * py + r12 * pz)
    uz = pz - (r20 * px + r21 * py + r22 * pz)
    return times_home(acc, (r00, r01, r02, r10, r11, r12, r20, r21, r22, ux, uy, uz))  # acc · (R | u)


@numba.njit(cache=True, error_model="numpy", inline="always")
def chain_acc(H, P, Z, i0, i1, acc):
    """``acc`` (12 floats, as :func:`poe_step`) times the POE factors ``E_{i0+1} ... E_{i1}`` (0-based
    joints i0 .. i1 − 1) from each joint's e^{iθ} ``Z[i]``."""
    for i in range(i0, i1):
        acc = poe_step(acc, joint_line(H, P, i), Z[i].real, Z[i].imag)
    return acc


@numba.njit(cache=True, error_model="numpy", inline="always")
def joint_line(H, P, i):
    """Joint i's line (its unit axis, then a point on it): 6 floats."""
    return H[i, 0], H[i, 1], H[i, 2], P[i, 0], P[i, 1], P[i, 2]


@numba.njit(cache=True, error_model="numpy", inline="always")
def twelve(R, p):
    """R (3, 3) row by row, then p (3,): 12 floats (a home pose, a goal's or a reached one)."""
    return R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1], R[2, 2], p[0], p[1], p[2]


@numba.njit(cache=True, error_model="numpy", inline="always")
def times_home(acc, m):
    """The pose ``acc · m`` (12 floats each, as :func:`poe_step`; ``m`` the home pose M, or one POE factor)."""
    a00, a01, a02, a10, a11, a12, a20, a21, a22, tx, ty, tz = acc
    m00, m01, m02, m10, m11, m12, m20, m21, m22, q0, q1, q2 = m
    return (a00 * m00 + a01 * m10 + a02 * m20, a00 * m01 + a01 * m11 + a02 * m21, a00 * m02 + a01 * m12 + a02 * m22,
            a10 * m00 + a11 * m10 + a12 * m20, a10 * m01 + a11 * m11 + a12 * m21, a10 * m02 + a11 * m12 + a12 * m22,
            a20 * m00 + a21 * m10 + a22 * m20, a20 * m01 + a21 * m11 + a22 * m21, a20 * m02 + a21 * m12 + a22 * m22,
            a00 * q0 + a01 * q1 + a02 * q2 + tx, a10 * q0 + a11 * q1 + a12 * q2 + ty,
            a20 * q0 + a21 * q1 + a22 * q2 + tz)


@numba.njit(cache=True, error_model="numpy", inline="always")
def acc_pose(acc, RM, pM, R, p):
    """The pose ``acc · M`` into R (3, 3), p (3,)."""
    v = times_home(acc, twelve(RM, pM))
    for r in range(3):
        for k in range(3):
            R[r, k] = v[3 * r + k]
        p[r] = v[9 + r]


@numba.njit(cache=True, error_model="numpy", inline="always")
def within_goal(v, g, tolp2, f_max):
    """The pose ``v`` within the FK check's tolerances of the goal ``g`` (12 floats each, as
    :func:`twelve`), without a square root or an arcsine: |Δp|² against ``tolp2`` (the position
    tolerance squared), and the Frobenius distance ‖R − Rg‖² = 8 sin²(θ/2) (θ the rotation angle
    between them) against ``f_max``, its value at the rotation tolerance (which is below π)."""
    v00, v01, v02, v10, v11, v12, v20, v21, v22, vx, vy, vz = v
    g00, g01, g02, g10, g11, g12, g20, g21, g22, gx, gy, gz = g
    dp2 = (vx - gx) ** 2 + (vy - gy) ** 2 + (vz - gz) ** 2
    f = ((((((((v00 - g00) ** 2 + (v01 - g01) ** 2) + (v02 - g02) ** 2) + (v10 - g10) ** 2) + (v11 - g11) ** 2)
            + (v12 - g12) ** 2) + (v20 - g20) ** 2) + (v21 - g21) ** 2) + (v22 - g22) ** 2
    return (dp2 <= tolp2) & (f <= f_max)


@numba.njit(cache=True, error_model="numpy")
def fk_linesz(H, P, RM, pM, Z, R, p):
    """Pose of the POE chain ``E_1(θ_1) ... E_n(θ_n) M`` into R (3, 3), p (3,) from each joint's
    e^{iθ} (the closed form's own cosines and sines: no trig), no allocation."""
    acc_pose(chain_acc(H, P, Z, 0, H.shape[0], EYE_ACC), RM, pM, R, p)


@numba.njit(cache=True, error_model="numpy")
def fk_lines(H, P, RM, pM, th, R, p, cs, Z):
    """Pose of the POE chain ``E_1(θ_1) ... E_n(θ_n) M`` into R (3, 3), p (3,).

    ``cs`` (n, 3) keeps each joint's last angle with its cosine and sine: a joint whose angle is
    bitwise the last one reuses them. ``Z`` (n,) complex: scratch for each joint's e^{iθ}."""
    n = H.shape[0]
    for i in range(n):
        if th[i] != cs[i, 0]:
            cs[i, 0], cs[i, 1], cs[i, 2] = th[i], math.cos(th[i]), math.sin(th[i])
        Z[i] = complex(cs[i, 1], cs[i, 2])
    fk_linesz(H, P, RM, pM, Z, R, p)


@numba.njit(cache=True, error_model="numpy", inline="always")
def pose_within(R, p, Tg, tolp2, f_max):
    """(R, p) within the FK check's tolerances of the goal ``Tg`` (:func:`within_goal`)."""
    return within_goal(twelve(R, p), twelve(Tg, Tg[:, 3]), tolp2, f_max)


@numba.njit(cache=True, error_model="numpy")
def doc_row(Tg, R, p, out):
    for r in range(3):
        out[1 + r] = Tg[r, 3] - p[r]
    out[4], out[5], out[6] = half_cross(R, Tg)
    out[7] = math.sqrt(out[1] ** 2 + out[2] ** 2 + out[3] ** 2)
    s = 0.0
    for r in range(6):
        s += out[1 + r] ** 2
    out[0] = math.sqrt(s)
