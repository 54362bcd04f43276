"""Quaternions and unit dual quaternions (w-first, Hamilton product).

A dual quaternion is an array ``(..., 8)``: real part ``[..., :4]``, dual part ``[..., 4:]``.
"""

from __future__ import annotations

import numpy as np

from pipeline.kinematics.chain import Chain


def _hamilton_tensor() -> np.ndarray:
    """H[i, j, k]: coefficient of basis k in (basis i)(basis j), basis (1, i, j, k)."""
    H = np.zeros((4, 4, 4))
    table = {  # e_a e_b = sign * e_c
        (0, 0): (1, 0), (0, 1): (1, 1), (0, 2): (1, 2), (0, 3): (1, 3),
        (1, 0): (1, 1), (1, 1): (-1, 0), (1, 2): (1, 3), (1, 3): (-1, 2),
        (2, 0): (1, 2), (2, 1): (-1, 3), (2, 2): (-1, 0), (2, 3): (1, 1),
        (3, 0): (1, 3), (3, 1): (1, 2), (3, 2): (-1, 1), (3, 3): (-1, 0),
    }
    for (a, b), (sign, c) in table.items():
        H[a, b, c] = sign
    return H


_H = _hamilton_tensor()
# dual-quaternion product as one bilinear map on 8-vectors: (pr qr, pr qd + pd qr)
_D = np.zeros((8, 8, 8))
_D[:4, :4, :4] = _H
_D[:4, 4:, 4:] = _H
_D[4:, :4, 4:] = _H


def q_mul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p q`` (eq. 18 of 000_7e3cb7ad5ee98ff0.txt).

    Parameters
    ----------
    p, q : ndarray, shape (..., 4) [1]
        Quaternions, w-first; leading axes broadcast.

    Returns
    -------
    ndarray, shape (..., 4)
    """
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    return np.einsum("...i,ijk,...j->...k", p, _H, q)


def q_conj(q: np.ndarray) -> np.ndarray:
    """Quaternion conjugate ``(w, -v)``.

    Parameters
    ----------
    q : ndarray, shape (..., 4) [1]
        Quaternions, w-first.

    Returns
    -------
    ndarray, shape (..., 4)
    """
    return np.asarray(q, dtype=float) * np.array([1.0, -1.0, -1.0, -1.0])


def dq_mul(P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Dual-quaternion product (eq. 28 of 000): ``(p_r q_r, p_r q_d + p_d q_r)``.

    Parameters
    ----------
    P, Q : ndarray, shape (..., 8) [1 | length]
        Dual quaternions ``(w, x, y, z, w_d, x_d, y_d, z_d)``: real part dimensionless, dual part
        in the chain's length unit; leading axes broadcast.

    Returns
    -------
    ndarray, shape (..., 8)
    """
    P = np.asarray(P, dtype=float)
    Q = np.asarray(Q, dtype=float)
    return np.einsum("...i,ijk,...j->...k", P, _D, Q)


def dq_conj(Q: np.ndarray) -> np.ndarray:
    """Quaternion conjugate of both parts (eq. 29 of 000); for a unit DQ this is its inverse.

    Parameters
    ----------
    Q : ndarray, shape (..., 8) [1 | length]
        Dual quaternions.

    Returns
    -------
    ndarray, shape (..., 8)
    """
    Q = np.asarray(Q, dtype=float)
    return np.concatenate([q_conj(Q[..., :4]), q_conj(Q[..., 4:])], axis=-1)


def quat_from_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternion of a rotation matrix, w >= 0 (Shepperd's branch choice).

    Parameters
    ----------
    R : ndarray, shape (..., 3, 3) or (..., 4, 4) [1]
        Rotation matrices, or homogeneous transforms whose rotation block is used.

    Returns
    -------
    q : ndarray, shape (..., 4)
        w-first.
    """
    R = np.asarray(R, dtype=float)[..., :3, :3]
    tr = R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2]
    cand = np.stack(
        [
            np.stack([1 + tr, R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1),
            np.stack([R[..., 2, 1] - R[..., 1, 2], 1 + 2 * R[..., 0, 0] - tr, R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0]], -1),
            np.stack([R[..., 0, 2] - R[..., 2, 0], R[..., 0, 1] + R[..., 1, 0], 1 + 2 * R[..., 1, 1] - tr, R[..., 1, 2] + R[..., 2, 1]], -1),
            np.stack([R[..., 1, 0] - R[..., 0, 1], R[..., 0, 2] + R[..., 2, 0], R[..., 1, 2] + R[..., 2, 1], 1 + 2 * R[..., 2, 2] - tr], -1),
        ],
        axis=-2,
    )
    pivot = np.argmax(np.stack([tr, R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]], -1), axis=-1)
    q = np.take_along_axis(cand, pivot[..., None, None], axis=-2)[..., 0, :]
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., :1] < 0, -q, q)


def matrix_from_quat(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion.

    Parameters
    ----------
    q : ndarray, shape (..., 4) [1]
        Unit quaternions, w-first.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
    """
    w, x, y, z = np.moveaxis(np.asarray(q, dtype=float), -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=-2,
    )


def dq_from_transform(T: np.ndarray) -> np.ndarray:
    """Unit DQ of a homogeneous transform, ``q_d = 1/2 (0, t) q_r``.

    Parameters
    ----------
    T : ndarray, shape (..., 4, 4) [length]
        Homogeneous transforms; the translation in any length unit, kept in the dual part.

    Returns
    -------
    Q : ndarray, shape (..., 8)
    """
    T = np.asarray(T, dtype=float)
    qr = quat_from_matrix(T)
    t = np.concatenate([np.zeros(T.shape[:-2] + (1,)), T[..., :3, 3]], axis=-1)
    return np.concatenate([qr, 0.5 * q_mul(t, qr)], axis=-1)


def dq_to_transform(Q: np.ndarray) -> np.ndarray:
    """Homogeneous transform of a unit DQ (eqs. 37-38 of 000: ``t = 2 q_d q_r*``).

    Parameters
    ----------
    Q : ndarray, shape (..., 8) [1 | length]
        Unit dual quaternions.

    Returns
    -------
    T : ndarray, shape (..., 4, 4)
    """
    Q = np.asarray(Q, dtype=float)
    T = np.zeros(Q.shape[:-1] + (4, 4))
    T[..., :3, :3] = matrix_from_quat(Q[..., :4])
    T[..., :3, 3] = 2.0 * q_mul(Q[..., 4:], q_conj(Q[..., :4]))[..., 1:]
    T[..., 3, 3] = 1.0
    return T


def _dq_rot(axis: int, angle: np.ndarray) -> np.ndarray:
    angle = np.asarray(angle, dtype=float)
    out = np.zeros(angle.shape + (8,))
    out[..., 0] = np.cos(angle / 2)
    out[..., 1 + axis] = np.sin(angle / 2)
    return out


def _dq_trans(axis: int, dist: np.ndarray) -> np.ndarray:
    dist = np.asarray(dist, dtype=float)
    out = np.zeros(dist.shape + (8,))
    out[..., 0] = 1.0
    out[..., 5 + axis] = dist / 2
    return out


def dq_from_dh(a, alpha, d, theta, convention: str = "standard") -> np.ndarray:
    """Unit DQ of one DH link.

    For the standard convention this is eq. 62 (= eq. 35) of 000_7e3cb7ad5ee98ff0.txt
    (Radavelli et al. 2014), written out term by term. The modified convention is the product
    of the elementary DQs ``Rx(alpha) Tx(a) Rz(theta) Tz(d)``.

    Parameters
    ----------
    a, d : array_like, shape (...) [length]
        Link length and offset; the four parameters broadcast against each other.
    alpha, theta : array_like, shape (...) [rad]
        Link twist and joint angle.
    convention : {"standard", "modified"}

    Returns
    -------
    Q : ndarray, shape (..., 8)

    Raises
    ------
    ValueError
        For another convention.
    """
    a, alpha, d, theta = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (a, alpha, d, theta)))
    if convention == "standard":
        ca, sa = np.cos(alpha / 2), np.sin(alpha / 2)
        ct, st = np.cos(theta / 2), np.sin(theta / 2)
        return np.stack(
            [
                ca * ct,
                sa * ct,
                sa * st,
                ca * st,
                -a / 2 * sa * ct - d / 2 * ca * st,
                a / 2 * ca * ct - d / 2 * sa * st,
                a / 2 * ca * st + d / 2 * sa * ct,
                -a / 2 * sa * st + d / 2 * ca * ct,
            ],
            axis=-1,
        )
    if convention == "modified":
        Q = dq_mul(_dq_rot(0, alpha), _dq_trans(0, a))
        Q = dq_mul(Q, _dq_rot(2, theta))
        return dq_mul(Q, _dq_trans(2, d))
    raise ValueError(f"unknown DH convention {convention!r}")


def dq_axis_motion(axes: np.ndarray, prismatic: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Unit DQs of the general form's joint motions: ``Rot(axis, q)`` or ``Trans(axis q)``.

    Parameters
    ----------
    axes : ndarray, shape (n, 3) [1]
        Unit joint axes.
    prismatic : ndarray of bool, shape (n,)
        Which joints are prismatic.
    q : ndarray, shape (..., n) [rad | length]
        Joint values.

    Returns
    -------
    M : ndarray, shape (..., n, 8)
    """
    q = np.asarray(q, dtype=float)
    k = np.asarray(axes, dtype=float)
    rev = ~np.asarray(prismatic, dtype=bool)
    half = 0.5 * q[..., None]
    M = np.zeros(q.shape + (8,))
    M[..., 0] = np.where(rev, np.cos(0.5 * q), 1.0)
    M[..., 1:4] = np.where(rev[:, None], np.sin(half) * k, 0.0)
    M[..., 5:8] = np.where(rev[:, None], 0.0, half * k)
    return M


def _general_links_dq(chain: Chain, q: np.ndarray) -> np.ndarray:
    """Per-joint DQs ``origin_i motion_i(q_i)`` of a general-form chain; shape (..., n, 8)."""
    q = np.asarray(q, dtype=float)
    if q.shape[-1] != chain.n:
        raise ValueError(f"expected {chain.n} joint values, got shape {q.shape}")
    return dq_mul(dq_from_transform(chain.origins), dq_axis_motion(chain.axes, chain.prismatic, q))


def fk_dq(chain: Chain, q: np.ndarray) -> np.ndarray:
    """End-effector pose as a unit DQ (eq. 63 of 000: ``Q_0 Q_1 ... Q_n``, then the tool).

    DH chains use the DH link DQ (:func:`dq_from_dh`); a general-form chain the product of its
    fixed origin's DQ and the joint motion's (:func:`dq_axis_motion`).

    Parameters
    ----------
    chain : Chain
    q : ndarray, shape (..., n) [rad | length]

    Returns
    -------
    Q : ndarray, shape (..., 8)
    """
    if chain.general:
        links = _general_links_dq(chain, q)
        batch = links.shape[:-2]
    else:
        theta, d = chain.joint_dh(q)
        links = dq_from_dh(chain.a, chain.alpha, d, theta, chain.convention)
        batch = theta.shape[:-1]
    identity = np.array([1.0, 0, 0, 0, 0, 0, 0, 0])
    base = dq_from_transform(chain.base) if np.any(chain.base != np.eye(4)) else identity
    Q = np.broadcast_to(base, batch + (8,))
    for i in range(chain.n):
        Q = dq_mul(Q, links[..., i, :])
    if np.any(chain.tool != np.eye(4)):
        Q = dq_mul(Q, dq_from_transform(chain.tool))
    return Q
