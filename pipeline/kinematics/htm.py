"""Forward kinematics by 4x4 homogeneous transformation matrices."""

from __future__ import annotations

import math

import numpy as np

from pipeline.kinematics.chain import Chain, dh_transform  # noqa: F401  (re-exported)


def rot_x(angle: np.ndarray) -> np.ndarray:
    """Homogeneous rotation about x.

    Parameters
    ----------
    angle : ndarray, shape (...) [rad]
        Rotation angles.

    Returns
    -------
    T : ndarray, shape (..., 4, 4)
    """
    c, s = np.cos(angle), np.sin(angle)
    T = np.zeros(np.shape(angle) + (4, 4))
    T[..., 0, 0] = 1.0
    T[..., 1, 1], T[..., 1, 2], T[..., 2, 1], T[..., 2, 2] = c, -s, s, c
    T[..., 3, 3] = 1.0
    return T


def mul4(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``A @ B`` of stacks of 4x4 matrices by element-wise arithmetic.

    No BLAS: the same bits on every machine, whatever BLAS kernel it picks. Each entry is
    ``((a0 b0 + a1 b1) + a2 b2) + a3 b3``, products and sums rounded one by one.

    Parameters
    ----------
    A, B : ndarray, shape (..., 4, 4) [length]
        Homogeneous transforms; leading axes broadcast.

    Returns
    -------
    ndarray, shape (..., 4, 4)
    """
    shape = np.broadcast_shapes(A.shape, B.shape)
    out = np.empty(shape)
    for i in range(4):
        a = [A[..., i, k] for k in range(4)]
        for j in range(4):
            out[..., i, j] = ((a[0] * B[..., 0, j] + a[1] * B[..., 1, j]) + a[2] * B[..., 2, j]) + a[3] * B[..., 3, j]
    return out


def transform_points(T: np.ndarray, P: np.ndarray) -> np.ndarray:
    """Points moved by a homogeneous transform, element-wise (no BLAS).

    Parameters
    ----------
    T : ndarray, shape (4, 4) [length]
        The transform.
    P : ndarray, shape (m, 3) [length]
        The points, in the transform's length unit.

    Returns
    -------
    ndarray, shape (m, 3) [length]
    """
    P = np.asarray(P, dtype=float)
    return np.stack([((T[i, 0] * P[:, 0] + T[i, 1] * P[:, 1]) + T[i, 2] * P[:, 2]) + T[i, 3] for i in range(3)], axis=1)


def axis_motion(axes: np.ndarray, prismatic: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Joint motions of the general form: ``Rot(axis, q)`` (Rodrigues) or ``Trans(axis q)``.

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
    M : ndarray, shape (..., n, 4, 4)
    """
    q = np.asarray(q, dtype=float)
    th = np.where(prismatic, 0.0, q)[..., None, None]
    k = np.asarray(axes, dtype=float)
    K = np.zeros(k.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -k[..., 2], k[..., 1], -k[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = k[..., 2], -k[..., 1], k[..., 0]
    M = np.zeros(q.shape + (4, 4))
    M[..., :3, :3] = np.eye(3) + np.sin(th) * K + (1.0 - np.cos(th)) * (K @ K)
    M[..., :3, 3] = np.where(prismatic[:, None], k * q[..., None], 0.0)
    M[..., 3, 3] = 1.0
    return M


def link_transforms(chain: Chain, q: np.ndarray) -> np.ndarray:
    """Every joint's link transform ``T_i(q_i)``, any convention.

    Parameters
    ----------
    chain : Chain
    q : ndarray, shape (..., n) [rad | length]
        Joint values.

    Returns
    -------
    ndarray, shape (..., n, 4, 4)

    Raises
    ------
    ValueError
        If a general-form chain gets the wrong number of joint values.
    """
    q = np.asarray(q, dtype=float)
    if chain.general:
        if q.shape[-1] != chain.n:
            raise ValueError(f"expected {chain.n} joint values, got shape {q.shape}")
        return chain.origins @ axis_motion(chain.axes, chain.prismatic, q)
    theta, d = chain.joint_dh(q)
    return dh_transform(chain.a, chain.alpha, d, theta, chain.convention)


def _exact_link(chain: Chain, q: np.ndarray, i: int) -> np.ndarray:
    """Joint ``i``'s link transform for joint vectors ``q`` (..., n), shape (..., 4, 4), by element-wise
    arithmetic only (``cos``/``sin`` and :func:`mul4`; no BLAS)."""
    if not chain.general:
        theta, d = chain.joint_dh(q)
        return dh_transform(chain.a[i], chain.alpha[i], d[..., i], theta[..., i], chain.convention)
    k = chain.axes[i]
    K = np.zeros((4, 4))
    K[0, 1], K[0, 2], K[1, 2] = -k[2], k[1], -k[0]
    K[1, 0], K[2, 0], K[2, 1] = k[2], -k[1], k[0]
    M = np.zeros(q.shape[:-1] + (4, 4))
    if chain.prismatic[i]:
        M[..., :3, :3] = np.eye(3)
        M[..., :3, 3] = k * q[..., i, None]
    else:
        th = q[..., i, None, None]
        M[..., :3, :3] = np.eye(3) + np.sin(th) * K[:3, :3] + (1.0 - np.cos(th)) * mul4(K, K)[:3, :3]
    M[..., 3, 3] = 1.0
    return mul4(chain.origins[i], M)


def fk_frames(chain: Chain, q: np.ndarray, exact: bool = False) -> np.ndarray:
    """Frames of every link, base included, tool excluded.

    Parameters
    ----------
    chain : Chain
    q : ndarray, shape (..., n) [rad | length]
    exact : bool
        Chain the products by :func:`mul4` instead of ``@``: the same bits whatever BLAS kernel the
        machine picks (what figures drawn from archives use, so that they rebuild byte-identical).

    Returns
    -------
    frames : ndarray, shape (..., n + 1, 4, 4)
        ``frames[..., 0]`` is the base, ``frames[..., i]`` is ``base @ T_1 @ ... @ T_i``.
    """
    q = np.asarray(q, dtype=float)
    out = np.empty(q.shape[:-1] + (chain.n + 1, 4, 4))
    out[..., 0, :, :] = chain.base
    if exact:
        for i in range(chain.n):
            out[..., i + 1, :, :] = mul4(out[..., i, :, :], _exact_link(chain, q, i))
        return out
    links = link_transforms(chain, q)
    for i in range(chain.n):
        out[..., i + 1, :, :] = out[..., i, :, :] @ links[..., i, :, :]
    return out


def fk_htm(chain: Chain, q: np.ndarray, exact: bool = False) -> np.ndarray:
    """End-effector pose ``T_base_ee`` by homogeneous matrices.

    Parameters
    ----------
    chain : Chain
    q : ndarray, shape (..., n) [rad | length]
    exact : bool
        No BLAS (see :func:`fk_frames`): the same bits on every machine; what problem-set goals
        (:func:`pipeline.problems.fk_poses`) and figures drawn from archives use.

    Returns
    -------
    T : ndarray, shape (..., 4, 4) [length for the translation]
    """
    q = np.asarray(q, dtype=float)
    if exact:  # one joint at a time: memory O(m) whatever n
        if q.shape[-1] != chain.n:
            raise ValueError(f"expected {chain.n} joint values, got shape {q.shape}")
        T = np.broadcast_to(chain.base, q.shape[:-1] + (4, 4))
        for i in range(chain.n):
            T = mul4(T, _exact_link(chain, q, i))
        return mul4(T, chain.tool)
    if q.ndim == 1 and not chain.general:
        return _fk_one(chain, q)
    return fk_frames(chain, q)[..., -1, :, :] @ chain.tool


def _fk_one(chain: Chain, q: np.ndarray) -> np.ndarray:
    """:func:`fk_htm` of one joint vector of a DH chain, link by link: the same arithmetic as
    :func:`dh_transform` and the same products, so bit-identical, without the batch machinery
    (about 2x faster for one pose: the FK check of every solve)."""
    if q.shape[0] != chain.n:
        raise ValueError(f"expected {chain.n} joint values, got shape {q.shape}")
    a, al, d0, off, pr = chain.a.tolist(), chain.alpha.tolist(), chain.d.tolist(), chain.theta_offset.tolist(), \
        chain.prismatic.tolist()
    T = chain.base
    for i, qi in enumerate(q.tolist()):
        th, d = (off[i], d0[i] + qi) if pr[i] else (off[i] + qi, d0[i])
        ct, st, ca, sa = math.cos(th), math.sin(th), math.cos(al[i]), math.sin(al[i])
        if chain.modified:
            L = np.array([[ct, -st, 0.0, a[i]], [st * ca, ct * ca, -sa, -sa * d], [st * sa, ct * sa, ca, ca * d],
                          [0.0, 0.0, 0.0, 1.0]])
        else:
            L = np.array([[ct, -st * ca, st * sa, a[i] * ct], [st, ct * ca, -ct * sa, a[i] * st], [0.0, sa, ca, d],
                          [0.0, 0.0, 0.0, 1.0]])
        T = T @ L
    return T @ chain.tool
