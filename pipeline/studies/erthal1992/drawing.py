"""Wireframe robots (Appendix 2 of 001_7601717b50b5e768.txt) and workspace sampling.

Each link i is drawn as two boxes built from its DH parameters (A2.1-A2.4): the first in frame
``W_{i-1}`` spanning ``z in [-C, d_i - C]`` (``z_n = 0`` for the base link), the second in
``V_{i-1} = W_{i-1} M1_i`` (after Rot(theta) and Tr(d)) spanning ``x in [-C, a_i - C]``; half
thickness C on the other axes. The gripper is a box of half widths (C, 2C) and height C at
``W_N`` (Table A2.2). Boxes are trimesh meshes; their edges are drawn with matplotlib.
"""

from __future__ import annotations

import numpy as np

from pipeline.kinematics import Chain, fk_frames, fk_htm
from pipeline.kinematics.htm import mul4, transform_points


def _box(lo, hi, T):
    import trimesh

    lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
    ext = np.maximum(hi - lo, 1e-6)
    center = np.eye(4)
    center[:3, 3] = (lo + hi) / 2
    box = trimesh.creation.box(extents=ext)  # moved below without BLAS: the figure rebuilds byte-identical
    box.vertices = transform_points(mul4(T, center), box.vertices)
    return box


def robot_boxes(chain: Chain, q: np.ndarray, C: float) -> list:
    """trimesh boxes of every link and the gripper at joint values ``q`` (n,)."""
    F = fk_frames(chain, q, exact=True)
    theta, d = chain.joint_dh(q)
    boxes = []
    for i in range(chain.n):
        W = F[i]
        zlo = 0.0 if i == 0 else -C
        boxes.append(_box(np.array([-C, -C, zlo]), np.array([C, C, d[i] - C if abs(d[i]) > C else C]), W))
        M1 = np.eye(4)
        ct, st = np.cos(theta[i]), np.sin(theta[i])
        M1[:2, :2] = [[ct, -st], [st, ct]]
        M1[2, 3] = d[i]
        V = mul4(W, M1)
        if abs(chain.a[i]) > C:
            boxes.append(_box(np.array([-C, -C, -C]), np.array([chain.a[i] - C, C, C]), V))
    WN = mul4(F[-1], chain.tool)
    boxes.append(_box(np.array([-C, -2 * C, 0.0]), np.array([C, 2 * C, C]), WN))
    return boxes


def draw_robot(ax, chain: Chain, q: np.ndarray, C: float, color="C0") -> None:
    """Draw the wireframe on a 3-D matplotlib axis (edges of every box + effector frame glyph)."""
    for b in robot_boxes(chain, q, C):
        real = b.face_adjacency_edges[b.face_adjacency_angles > 1e-6]  # the 12 box edges, no face diagonals
        segs = b.vertices[real]
        for s in segs:
            ax.plot(s[:, 0], s[:, 1], s[:, 2], color=color, lw=0.7)
    T = fk_htm(chain, q, exact=True)
    for k, col in enumerate(("r", "g", "b")):
        p = np.vstack([T[:3, 3], T[:3, 3] + 2 * C * T[:3, k]])
        ax.plot(p[:, 0], p[:, 1], p[:, 2], color=col, lw=1.2)


def set_equal(ax, pts: np.ndarray) -> None:
    c = (pts.max(0) + pts.min(0)) / 2
    r = max(float((pts.max(0) - pts.min(0)).max()) / 2, 1.0)
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(c[2] - r, c[2] + r)


def sample_workspace(chain: Chain, limits: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """Effector positions (n, 3) of joint values uniform within ``limits`` (n_joints, 2)."""
    q = rng.uniform(limits[:, 0], limits[:, 1], (n, chain.n))
    return fk_htm(chain, q, exact=True)[:, :3, 3]


def hull_measure(points: np.ndarray, planar: bool) -> float:
    """Convex-hull volume [length^3] (trimesh) or, for a planar arm, area [length^2] (xy)."""
    if planar:
        from scipy.spatial import ConvexHull

        return float(ConvexHull(points[:, :2]).volume)
    import trimesh

    return float(trimesh.convex.convex_hull(points).volume)


def planar3r_workspaces(lengths, n_grid: int, n_phi: int) -> dict:
    """Primary (every orientation) and secondary (some orientation) workspace of a planar 3R arm
    by a polar grid: p is reachable with orientation phi iff the wrist point p - L3 (cos phi,
    sin phi) lies in the 2R annulus [|L1 - L2|, L1 + L2]. Returns radii and flags and the areas."""
    L1, L2, L3 = lengths
    rmax = L1 + L2 + L3
    r = np.linspace(0, rmax, n_grid)
    phi = np.linspace(-np.pi, np.pi, n_phi, endpoint=False)
    # by symmetry only the radius matters: take p = (r, 0)
    w = np.hypot(r[:, None] - L3 * np.cos(phi)[None], -L3 * np.sin(phi)[None])
    ok = (w >= abs(L1 - L2) - 1e-9) & (w <= L1 + L2 + 1e-9)
    primary, secondary = ok.all(axis=1), ok.any(axis=1)
    dr = r[1] - r[0]
    ring = 2 * np.pi * r * dr
    return {"r": r, "primary": primary, "secondary": secondary,
            "primary_area": float(np.sum(ring[primary])), "secondary_area": float(np.sum(ring[secondary]))}
