"""Geometric Jacobian of a serial chain (DH or general form)."""

from __future__ import annotations

import numpy as np

from pipeline.kinematics.chain import Chain
from pipeline.kinematics.htm import dh_transform, fk_frames


def joint_axes(chain: Chain, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Joint axes, joint origins and the end-effector position, all in the base frame.

    Parameters
    ----------
    chain : Chain
    q : ndarray, shape (..., n) [rad | length]

    Returns
    -------
    z : ndarray, shape (..., n, 3)      unit axis of each joint
    o : ndarray, shape (..., n, 3)      a point on each axis [length]: the frame the joint acts in
                                        (DH: origin of frame i-1, or after Rx Tx for modified;
                                        general: after joint i's fixed origin), before its motion
    p : ndarray, shape (..., 3)         tool position [length]
    """
    frames = fk_frames(chain, q)
    if chain.general:
        # joint i acts after its fixed origin; its axis is given in that frame
        axes_frames = frames[..., :-1, :, :] @ chain.origins
        p = (frames[..., -1, :, :] @ chain.tool)[..., :3, 3]
        z = (axes_frames[..., :3, :3] @ chain.axes[:, :, None])[..., 0]
        return z, axes_frames[..., :3, 3], p
    if chain.modified:
        # joint i acts after Rx(alpha_{i-1}) Tx(a_{i-1}) of its own row
        pre = dh_transform(chain.a, chain.alpha, 0.0, 0.0, "modified")
        axes_frames = frames[..., :-1, :, :] @ pre
    else:
        axes_frames = frames[..., :-1, :, :]
    p = (frames[..., -1, :, :] @ chain.tool)[..., :3, 3]
    return axes_frames[..., :3, 2], axes_frames[..., :3, 3], p


def geometric_jacobian(chain: Chain, q: np.ndarray) -> np.ndarray:
    """Geometric Jacobian in the base frame (eq. 43 of 000 for the linear rows).

    Revolute column ``[z_i x (p - o_i); z_i]``, prismatic column ``[z_i; 0]``.

    Parameters
    ----------
    chain : Chain
    q : ndarray, shape (..., n) [rad | length]

    Returns
    -------
    J : ndarray, shape (..., 6, n)  rows (v, omega): [length/rad | 1] and [1 | 0]
    """
    z, o, p = joint_axes(chain, q)
    lin = np.where(chain.prismatic[:, None], z, np.cross(z, p[..., None, :] - o))
    ang = np.where(chain.prismatic[:, None], 0.0, z)
    return np.concatenate([np.swapaxes(lin, -1, -2), np.swapaxes(ang, -1, -2)], axis=-2)
