"""Pure kinematics: DH chains, homogeneous matrices, unit dual quaternions, Jacobians, pose errors.

Conventions (written down once; every module of the project follows them)
--------------------------------------------------------------------------
Units
    Angles are radians. Lengths are in the robot file's own ``length_unit`` (a study keeps
    the document's unit, e.g. cm for the KUKA LWR of 000_7e3cb7ad5ee98ff0.txt Table 2);
    nothing here converts lengths silently. ``RobotModel.scaled`` makes a copy in another unit.
Quaternions
    Hamilton product, scalar first: ``q = (w, x, y, z)``. The only place where the order changes
    is ``pipeline.io`` (Foxglove-style schemas name fields x, y, z, w).
Dual quaternions
    ``Q = q_r + eps q_d`` stored as an array ``(..., 8)`` = ``(w, x, y, z, w_d, x_d, y_d, z_d)``;
    a rigid transform (R, t) is ``q_r = quat(R)``, ``q_d = 1/2 (0, t) q_r`` and ``t = 2 q_d q_r*``
    (eqs. 37-38 of 000_7e3cb7ad5ee98ff0.txt). Products are left to right, base to tip.
Denavit-Hartenberg
    ``standard``: ``T_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``; joint i turns about z of frame i-1.
    ``modified`` (Craig): ``T_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``; a robot file's
    row i then holds ``a_{i-1}, alpha_{i-1}``; joint i turns about z of frame i.
    Revolute joint: ``theta_i = q_i + theta_offset_i``; prismatic joint: ``d_i = q_i + d_i(file)``.
Poses
    ``T_base_ee = base @ T_1 @ ... @ T_n @ tool``, shape ``(..., 4, 4)``.
Twists and errors
    Six-vectors are ordered (linear, angular) = (v, omega); the geometric Jacobian is ``(6, n)``,
    linear rows first, expressed in the base frame.
Batches
    Leading axes are batch axes: joint vectors are ``(..., n)``, poses ``(..., 4, 4)``.
"""

from pipeline.kinematics.chain import Chain
from pipeline.kinematics.dualquat import (
    dq_conj,
    dq_from_dh,
    dq_from_transform,
    dq_mul,
    dq_to_transform,
    fk_dq,
    q_conj,
    q_mul,
    quat_from_matrix,
    matrix_from_quat,
)
from pipeline.kinematics.htm import dh_transform, fk_htm, fk_frames
from pipeline.kinematics.jacobian import geometric_jacobian
from pipeline.kinematics.errors import (
    orientation_error_angle,
    orientation_error_axis_angle,
    orientation_error_quat_vec,
    position_error,
    relative_dq_norm,
)

__all__ = [
    "Chain",
    "dh_transform",
    "dq_conj",
    "dq_from_dh",
    "dq_from_transform",
    "dq_mul",
    "dq_to_transform",
    "fk_dq",
    "fk_frames",
    "fk_htm",
    "geometric_jacobian",
    "matrix_from_quat",
    "orientation_error_angle",
    "orientation_error_axis_angle",
    "orientation_error_quat_vec",
    "position_error",
    "q_conj",
    "q_mul",
    "quat_from_matrix",
    "relative_dq_norm",
]
