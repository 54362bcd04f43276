"""Zero-position (PZ) description of a serial chain (001_7601717b50b5e768.txt §3.1, Appendix 1 Case 3).

A robot at a reference configuration ``q0`` (its "zero position") is described by the direction
``u_i`` of every joint axis, the body vectors ``b_i`` between consecutive points of those axes
(origin-based form, A1.4-A1.5: ``b_0`` = first axis point from the world origin, ``b_i`` = next
axis point minus this one, ``b_n`` = effector minus the last axis point) and the effector's
approach ``u_a`` (z) and orientation ``u_t`` (y), all in the world frame (base transform applied).
Forward kinematics is then a product of rotations about the zero-position axes (eqs 3.5-3.17,
the product of exponentials): :func:`pz_fk`.

:func:`pz_from_dh` (alias :func:`pz_from_chain`) derives the description from any chain (standard
or modified DH, or the general origin/axis form; prismatic joints, base and tool) through
:func:`pipeline.kinematics.jacobian.joint_axes`. The
Zero-Position IK method (:mod:`pipeline.solvers.iterative.zero_position`) uses the same quantities at the
current configuration, which :func:`pipeline.solvers.kernels.kin.forward` returns directly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.kinematics.chain import Chain
from pipeline.kinematics.htm import fk_htm
from pipeline.kinematics.jacobian import joint_axes


@dataclass(frozen=True)
class PZModel:
    """Zero-position vectors (origin-based form, as SCARA.PAR; A1.4).

    types : tuple of 'r' | 'p'
    b : ndarray, shape (n + 1, 3)   b[0] = first axis point (world frame), b[i] = differences of axis points, b[n] to the effector
    u : ndarray, shape (n, 3)       joint axes at the zero position
    u_a, u_t : ndarray, shape (3,)  effector approach (z) / orientation (y) at the zero position
    q0 : ndarray, shape (n,)        zero position [rad | length]
    """

    types: tuple
    b: np.ndarray
    u: np.ndarray
    u_a: np.ndarray
    u_t: np.ndarray
    q0: np.ndarray


def pz_from_dh(chain: Chain, q0) -> PZModel:
    """Appendix 1 Case 3: a chain at ``q0`` -> its zero-position description.

    Any convention: for a DH chain the axis points are the DH origins the joint acts at; for a
    general-form chain each joint's frame after its fixed origin (before its own motion).

    Parameters
    ----------
    chain : Chain
    q0 : array_like, shape (n,) [rad | length]
        The zero position.

    Returns
    -------
    PZModel
    """
    q0 = np.asarray(q0, dtype=float)
    u, o, p = joint_axes(chain, q0)
    O = np.vstack([o, p])
    b = np.vstack([O[:1], np.diff(O, axis=0)])
    T_tool = fk_htm(chain, q0)
    types = tuple("p" if x else "r" for x in chain.prismatic)
    return PZModel(types, b, u, T_tool[:3, 2].copy(), T_tool[:3, 1].copy(), q0)


pz_from_chain = pz_from_dh  # the name says what it takes since chains are not only DH


def axis_angle_matrix(theta: float, u: np.ndarray) -> np.ndarray:
    """R(theta, u) of eq. 3.12 (rotation by ``theta`` about the unit vector ``u``).

    Parameters
    ----------
    theta : float
        Rotation angle [rad].
    u : ndarray, shape (3,) [1]
        Unit rotation axis.

    Returns
    -------
    R : ndarray, shape (3, 3)
    """
    ux, uy, uz = u
    c, s = np.cos(theta), np.sin(theta)
    v = 1 - c
    return np.array([[(ux * ux - 1) * v + 1, ux * uy * v - uz * s, ux * uz * v + uy * s],
                     [ux * uy * v + uz * s, (uy * uy - 1) * v + 1, uy * uz * v - ux * s],
                     [ux * uz * v - uy * s, uy * uz * v + ux * s, (uz * uz - 1) * v + 1]])


def pz_fk(pz: PZModel, q) -> np.ndarray:
    """Zero-position forward kinematics (eqs 3.5-3.17; prismatic joints keep their body vector).

    Parameters
    ----------
    pz : PZModel
    q : array_like, shape (n,) [rad | length]
        Joint values.

    Returns
    -------
    T : ndarray, shape (4, 4)
        Effector pose in the world frame [length].
    """
    q = np.asarray(q, float)
    R = np.eye(3)
    P = pz.b[0].copy()
    for k, t in enumerate(pz.types):
        uk = R @ pz.u[k]                                         # 3.5
        if t == "p":
            P = P + (q[k] - pz.q0[k]) * uk                       # 3.14 (+ body vector below)
        else:
            R = R @ axis_angle_matrix(q[k] - pz.q0[k], pz.u[k])  # 3.11
        P = P + R @ pz.b[k + 1]                                  # 3.6, 3.15
    z0, y0 = pz.u_a, pz.u_t
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2] = R @ np.cross(y0, z0), R @ y0, R @ z0  # 3.7-3.8, 3.17
    T[:3, 3] = P
    return T


def pz_axes(pz: PZModel, q) -> tuple[np.ndarray, np.ndarray]:
    """Joint axes and axis points at ``q`` from the zero-position description (world frame).

    Parameters
    ----------
    pz : PZModel
    q : array_like, shape (n,) [rad | length]
        Joint values.

    Returns
    -------
    axes : ndarray, shape (n, 3)
        Unit joint axes [1].
    points : ndarray, shape (n, 3)
        A point of each axis [length].
    """
    q = np.asarray(q, float)
    n = len(pz.types)
    R = np.eye(3)
    P = pz.b[0].copy()
    axes, points = np.empty((n, 3)), np.empty((n, 3))
    for k, t in enumerate(pz.types):
        axes[k] = R @ pz.u[k]
        points[k] = P
        if t == "p":
            P = P + (q[k] - pz.q0[k]) * axes[k]
        else:
            R = R @ axis_angle_matrix(q[k] - pz.q0[k], pz.u[k])
        P = P + R @ pz.b[k + 1]
    return axes, points
