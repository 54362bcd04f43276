"""Pose errors between a goal pose and a current pose."""

from __future__ import annotations

import numpy as np

from pipeline.kinematics.dualquat import dq_conj, dq_from_transform, dq_mul, q_conj, q_mul, quat_from_matrix


def position_error(T_goal: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Position error ``p_goal - p``.

    Parameters
    ----------
    T_goal, T : ndarray, shape (..., 4, 4) [length]
        Goal and current poses.

    Returns
    -------
    ndarray, shape (..., 3) [length]
    """
    return np.asarray(T_goal)[..., :3, 3] - np.asarray(T)[..., :3, 3]


def orientation_error_quat_vec(T_goal: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Vector part of ``q_goal q*`` with the sign chosen so that w >= 0 (eq. 64 of 000).

    Equals ``sin(angle/2) * axis`` of the rotation that takes the current orientation to the goal,
    expressed in the base frame.

    Parameters
    ----------
    T_goal, T : ndarray, shape (..., 4, 4) [length]
        Goal and current poses (only the rotation blocks are read).

    Returns
    -------
    ndarray, shape (..., 3) [1]
    """
    qrel = q_mul(quat_from_matrix(T_goal), q_conj(quat_from_matrix(T)))
    qrel = np.where(qrel[..., :1] < 0, -qrel, qrel)
    return qrel[..., 1:]


def orientation_error_axis_angle(T_goal: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Rotation vector ``angle * axis`` of ``R_goal R^T`` (base frame), angle in [0, pi].

    Parameters
    ----------
    T_goal, T : ndarray, shape (..., 4, 4) [length]
        Goal and current poses (only the rotation blocks are read).

    Returns
    -------
    ndarray, shape (..., 3) [rad]
    """
    qrel = q_mul(quat_from_matrix(T_goal), q_conj(quat_from_matrix(T)))
    qrel = np.where(qrel[..., :1] < 0, -qrel, qrel)
    s = np.linalg.norm(qrel[..., 1:], axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, qrel[..., :1])
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(s > 1e-300, angle / np.where(s > 1e-300, s, 1.0), 2.0)
    return qrel[..., 1:] * scale


def orientation_error_angle(T_goal: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Angle of the rotation between the two orientations, in [0, pi].

    Parameters
    ----------
    T_goal, T : ndarray, shape (..., 4, 4) [length]
        Goal and current poses (only the rotation blocks are read).

    Returns
    -------
    ndarray, shape (...) [rad]
    """
    return np.linalg.norm(orientation_error_axis_angle(T_goal, T), axis=-1)


def relative_dq_norm(T_goal: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Euclidean norm of the 8 coefficients of ``Q_goal Q*`` (the "dq_norm" reading of ‖erro‖).

    000_7e3cb7ad5ee98ff0.txt never gives its error norm (notes §10.2); this is the reading
    under which ‖erro‖ = 1 at the goal. For a unit DQ it equals ``sqrt(1 + |t|^2 / 4)``, with t
    the translation of ``T_goal T^-1``.

    Parameters
    ----------
    T_goal, T : ndarray, shape (..., 4, 4) [length]
        Goal and current poses.

    Returns
    -------
    ndarray, shape (...) [1]
    """
    Q = dq_mul(dq_from_transform(T_goal), dq_conj(dq_from_transform(T)))
    return np.linalg.norm(Q, axis=-1)
