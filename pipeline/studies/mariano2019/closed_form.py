"""Closed-form FK (eqs. 23-28) and IK (eqs. 29-32) of the 4-DOF arm of 003_8b306f4736fa5051.txt.

Generic over the scalar type (float or :class:`~.counting.Counted`). The arm is the DH chain
``(theta1, d1, d, +90 deg), (theta2, 0, a2, 0), (theta3, 0, a3, 0), (theta4, 0, a4, 0)`` (notes §2.2);
:func:`arm_params` reads ``d1, d, a2, a3, a4`` from a robot model and checks that shape.
The pitch is ``phi = -(theta2 + theta3 + theta4)`` (eq. 26); ``omega = theta1`` (eq. 27) and
``gamma = 90 deg`` (eq. 28); the orientation is ``Rz(omega) Ry(phi) Rx(gamma)`` for every q.

These printed formulas are the object of the operation counts (Tables II-III), not a solver: the
study's IK problems are solved by the registered ``analytic_4dof`` (:mod:`pipeline.solvers.closed_form.analytic_4dof`).
"""

from __future__ import annotations

import math

import numpy as np

from pipeline.studies.mariano2019 import counting as K

BETA_TOL = 1e-12  # |beta| up to 1 + this is rounding of a stretched/folded arm: clipped, not unreachable
ARM_KEYS = ("d1", "d", "a2", "a3", "a4")


class UnreachableError(ValueError):
    """The goal is outside the workspace (|beta| > 1 in eq. 31)."""


def arm_params(model) -> dict:
    """``{d1, d, a2, a3, a4}`` of a robot with the 4-DOF arm's DH structure.

    Raises
    ------
    ValueError
        When the chain is not 4 standard-DH revolute links with alpha = (pi/2, 0, 0, 0),
        d2 = d3 = d4 = 0 and no offsets.
    """
    c = model.chain
    ok = (c.n == 4 and c.convention == "standard" and not c.prismatic.any()
          and np.allclose(c.alpha, [np.pi / 2, 0, 0, 0], atol=1e-12) and np.allclose(c.d[1:], 0)
          and np.allclose(c.theta_offset, 0))
    if not ok:
        raise ValueError(f"{model.name}: not the 4-DOF arm of 003 (DH table of notes §2.2)")
    return {"d1": float(c.d[0]), "d": float(c.a[0]), "a2": float(c.a[1]), "a3": float(c.a[2]),
            "a4": float(c.a[3])}


def fk_printed(p: dict, q) -> tuple:
    """Eqs. 23-28 exactly as printed (each term written out): returns (x, y, z, phi, omega, gamma)."""
    t1, t2, t3, t4 = q
    t23 = t2 + t3
    t234 = t23 + t4
    C1, S1, C2, S2 = K.cos(t1), K.sin(t1), K.cos(t2), K.sin(t2)
    C23, S23, C234, S234 = K.cos(t23), K.sin(t23), K.cos(t234), K.sin(t234)
    x = p["a4"] * C234 * C1 + p["a3"] * C1 * C23 + p["a2"] * C1 * C2 + p["d"] * C1
    y = p["a4"] * C234 * S1 + p["a3"] * S1 * C23 + p["a2"] * S1 * C2 + p["d"] * S1
    z = p["a4"] * S234 + p["a3"] * S23 + p["a2"] * S2 + p["d1"]
    return x, y, z, -t234, t1, math.pi / 2


def fk_factored(p: dict, q) -> tuple:
    """Eqs. 23-28 with the common factor taken out: ``rho = a4 C234 + a3 C23 + a2 C2 + d``,
    ``x = rho C1``, ``y = rho S1``. Returns (x, y, z, phi, omega, gamma)."""
    t1, t2, t3, t4 = q
    t23 = t2 + t3
    t234 = t23 + t4
    C2, S2, C23, S23, C234, S234 = K.cos(t2), K.sin(t2), K.cos(t23), K.sin(t23), K.cos(t234), K.sin(t234)
    rho = p["a4"] * C234 + p["a3"] * C23 + p["a2"] * C2 + p["d"]
    z = p["a4"] * S234 + p["a3"] * S23 + p["a2"] * S2 + p["d1"]
    return rho * K.cos(t1), rho * K.sin(t1), z, -t234, t1, math.pi / 2


def pose_matrix(x, y, z, phi, omega, gamma) -> np.ndarray:
    """4x4 ``T_base_ee`` of (position, ``Rz(omega) Ry(phi) Rx(gamma)``) (eq. 3 of 003), floats."""
    x, y, z, phi, omega, gamma = (K.value(v) for v in (x, y, z, phi, omega, gamma))
    cw, sw, cp, sp, cg, sg = (math.cos(omega), math.sin(omega), math.cos(phi), math.sin(phi),
                              math.cos(gamma), math.sin(gamma))
    return np.array([[cw * cp, cw * sp * sg - sw * cg, cw * sp * cg + sw * sg, x],
                     [sw * cp, sw * sp * sg + cw * cg, sw * sp * cg - cw * sg, y],
                     [-sp, cp * sg, cp * cg, z],
                     [0.0, 0.0, 0.0, 1.0]])


def ik(p: dict, x, y, z, phi, elbow: int = 1) -> list:
    """Eqs. 29-32 (theta of eq. 31 read as the pitch phi): joint angles for (x, y, z, phi).

    Parameters
    ----------
    p : dict
        Arm lengths from :func:`arm_params` [length].
    x, y, z : scalar [length]; phi : scalar [rad]
    elbow : {+1, -1}
        Sign of the square root in eq. 30 (the two elbow branches).

    Returns
    -------
    [theta1, theta2, theta3, theta4] [rad]; theta1 = atan2(y, x) is the front solution.

    Raises
    ------
    UnreachableError
        When |beta| > 1 + BETA_TOL (the wrist point is out of reach of links 2-3).
    """
    t1 = K.atan2(y, x)                                        # (29)
    r = K.sqrt(x * x + y * y)
    cp, sp = K.cos(phi), K.sin(phi)
    u = z - p["d1"] + p["a4"] * sp                            # wrist height, (31)
    w = r - p["a4"] * cp - p["d"]                             # wrist radius, (31)
    beta = (u * u + w * w - p["a2"] * p["a2"] - p["a3"] * p["a3"]) / (2.0 * (p["a2"] * p["a3"]))
    if abs(beta) > 1.0 + BETA_TOL:
        raise UnreachableError(f"unreachable: |beta| = {abs(K.value(beta)):.6g} > 1 (eq. 31)")
    if abs(beta) > 1.0:
        beta = 1.0 if beta > 0 else -1.0
    s3 = K.sqrt(1.0 - beta * beta)
    if elbow < 0:
        s3 = -s3
    t3 = K.atan2(s3, beta)                                    # (30)
    t2 = K.atan2(u, w) - K.atan2(p["a3"] * s3, p["a2"] + p["a3"] * beta)   # second (31)
    t4 = -phi - t2 - t3                                       # (32)
    return [t1, t2, t3, t4]


def ik_from_htm(p: dict, T, elbow: int = 1) -> list:
    """IK of a pose given as an HTM (4x4 list): position = last column, pitch by eq. 4."""
    r11, r21, r31 = T[0][0], T[1][0], T[2][0]
    phi = K.atan2(-r31, K.sqrt(r11 * r11 + r21 * r21))
    return ik(p, T[0][3], T[1][3], T[2][3], phi, elbow)


def ik_from_dq(p: dict, Q, elbow: int = 1) -> list:
    """IK of a pose given as a unit DQ: position by eq. 18, r11, r21, r31 by eq. 19, pitch by eq. 4."""
    from pipeline.studies.mariano2019.algebra import dq_translation

    q1, q2, q3, q4 = Q[:4]
    x, y, z = dq_translation(Q)
    r11 = 1.0 - 2.0 * (q3 * q3) - 2.0 * (q4 * q4)
    r21 = 2.0 * (q2 * q3 + q1 * q4)
    r31 = 2.0 * (q2 * q4 - q1 * q3)
    phi = K.atan2(-r31, K.sqrt(r11 * r11 + r21 * r21))
    return ik(p, x, y, z, phi, elbow)
