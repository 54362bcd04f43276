"""An arm's joint lines turned back into a chain, and joints held at fixed values folded into it.

The joint lines (:func:`pipeline.kinematics.geometry.joint_lines`: a direction ``h_i`` and a point
``p_i`` per joint at the zero pose, the tool pose ``M``) describe the arm completely in the
product-of-exponentials form ``T(q) = E_1(q_1) ... E_n(q_n) M``. :func:`lines_chain` writes them as a
general-form :class:`~pipeline.kinematics.chain.Chain` (base the identity, joint i's frame the world
frame moved to ``p_i``), so that everything that takes a chain takes a folded or snapped arm too;
:func:`hold` removes joints held at given values (the lines after a held joint, and ``M``, moved by its
motion), which is exact: the shorter chain's pose at ``q_kept`` equals the arm's pose at ``q_kept``
with the held joints at their values.
"""

from __future__ import annotations

import numpy as np

from pipeline.kinematics.chain import GENERAL, Chain
from pipeline.kinematics.geometry import Lines, axis_rotation


def lines_chain(lines: Lines) -> Chain:
    """The general-form chain whose joint lines at q = 0 are ``lines``.

    Joint i's origin is the translation from ``p_{i-1}`` to ``p_i`` (from the world origin for the
    first), its axis ``h_i`` in the world frame, the tool ``Trans(-p_n) M``: ``Trans(p_1) Rot(h_1, q_1)
    Trans(p_2 - p_1) ... = E_1(q_1) E_2(q_2) ... Trans(p_n)`` by induction, so the pose is
    ``E_1 ... E_n M``.

    Parameters
    ----------
    lines : Lines
        ``h`` (n, 3) [1], ``p`` (n, 3) [length], ``M`` (4, 4) [length], ``prismatic`` (n,).

    Returns
    -------
    Chain
        General form, base the identity, joint offsets zero (the lines' own joint values).
    """
    n = lines.n
    origins = np.tile(np.eye(4), (n, 1, 1))
    prev = np.zeros(3)
    for i in range(n):
        origins[i, :3, 3] = lines.p[i] - prev
        prev = lines.p[i]
    tool = np.array(lines.M, dtype=float)
    tool[:3, 3] -= prev
    z = np.zeros(n)
    return Chain(z, z, z, z, np.asarray(lines.prismatic, bool), GENERAL, np.eye(4), tool, origins,
                 np.array(lines.h, dtype=float))


def hold(lines: Lines, held: dict) -> tuple[Lines, np.ndarray]:
    """The arm with the joints ``held`` (0-based index -> value [rad | length]) fixed at their values.

    Parameters
    ----------
    lines : Lines
        The whole arm's joint lines (n joints).
    held : dict of int to float
        Joint index (0-based) -> its value; a revolute joint's in rad, a prismatic one's in the
        lines' length unit.

    Returns
    -------
    lines : Lines
        The n - len(held) joints that move, in order, with the motion of each held joint applied to
        the lines after it and to ``M``.
    keep : ndarray of int, shape (n - len(held),)
        The moving joints' indices (0-based) in the whole arm.
    """
    h, p, M = lines.h.copy(), lines.p.copy(), np.array(lines.M, dtype=float)
    for k in sorted(held):
        E = np.eye(4)
        if lines.prismatic[k]:
            E[:3, 3] = held[k] * h[k]
        else:
            R = axis_rotation(h[k], held[k])
            E[:3, :3], E[:3, 3] = R, p[k] - R @ p[k]
        h[k + 1:] = h[k + 1:] @ E[:3, :3].T
        p[k + 1:] = p[k + 1:] @ E[:3, :3].T + E[:3, 3]
        M = E @ M
    keep = np.array([i for i in range(lines.n) if i not in held], dtype=np.int64)
    return Lines(h[keep], p[keep], M, lines.prismatic[keep].copy(), lines.reach), keep
