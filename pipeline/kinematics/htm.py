"""Forward kinematics by 4x4 homogeneous transformation matrices."""

from __future__ import annotations

import numpy as np

from pipeline.kinematics.chain import Chain


def rot_x(angle: np.ndarray) -> np.ndarray:
    """Homogeneous rotation about x. ``angle`` (...,) [rad] -> (..., 4, 4)."""
    c, s = np.cos(angle), np.sin(angle)
    T = np.zeros(np.shape(angle) + (4, 4))
    T[..., 0, 0] = 1.0
    T[..., 1, 1], T[..., 1, 2], T[..., 2, 1], T[..., 2, 2] = c, -s, s, c
    T[..., 3, 3] = 1.0
    return T


def dh_transform(a, alpha, d, theta, convention: str = "standard") -> np.ndarray:
    """One DH link transform.

    Parameters
    ----------
    a, alpha, d, theta : array_like, broadcastable shapes (...) [length, rad, length, rad]
    convention : {"standard", "modified"}
        standard ``Rz(theta) Tz(d) Tx(a) Rx(alpha)``; modified ``Rx(alpha) Tx(a) Rz(theta) Tz(d)``.

    Returns
    -------
    T : ndarray, shape (..., 4, 4)
    """
    a, alpha, d, theta = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (a, alpha, d, theta)))
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    T = np.zeros(a.shape + (4, 4))
    if convention == "standard":
        T[..., 0, :] = np.stack([ct, -st * ca, st * sa, a * ct], -1)
        T[..., 1, :] = np.stack([st, ct * ca, -ct * sa, a * st], -1)
        T[..., 2, :] = np.stack([np.zeros_like(ct), sa, ca, d], -1)
    elif convention == "modified":
        T[..., 0, :] = np.stack([ct, -st, np.zeros_like(ct), a], -1)
        T[..., 1, :] = np.stack([st * ca, ct * ca, -sa, -sa * d], -1)
        T[..., 2, :] = np.stack([st * sa, ct * sa, ca, ca * d], -1)
    else:
        raise ValueError(f"unknown DH convention {convention!r}")
    T[..., 3, 3] = 1.0
    return T


def fk_frames(chain: Chain, q: np.ndarray) -> np.ndarray:
    """Frames of every link, base included, tool excluded.

    Parameters
    ----------
    chain : Chain
    q : ndarray, shape (..., n) [rad | length]

    Returns
    -------
    frames : ndarray, shape (..., n + 1, 4, 4)
        ``frames[..., 0]`` is the base, ``frames[..., i]`` is ``base @ T_1 @ ... @ T_i``.
    """
    theta, d = chain.joint_dh(q)
    links = dh_transform(chain.a, chain.alpha, d, theta, chain.convention)
    out = np.empty(theta.shape[:-1] + (chain.n + 1, 4, 4))
    out[..., 0, :, :] = chain.base
    for i in range(chain.n):
        out[..., i + 1, :, :] = out[..., i, :, :] @ links[..., i, :, :]
    return out


def fk_htm(chain: Chain, q: np.ndarray) -> np.ndarray:
    """End-effector pose ``T_base_ee`` by homogeneous matrices.

    Parameters
    ----------
    chain : Chain
    q : ndarray, shape (..., n) [rad | length]

    Returns
    -------
    T : ndarray, shape (..., 4, 4) [length for the translation]
    """
    return fk_frames(chain, q)[..., -1, :, :] @ chain.tool
