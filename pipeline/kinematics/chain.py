"""The numeric description of a serial chain that every kinematics function takes."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

STANDARD = "standard"
MODIFIED = "modified"
GENERAL = "general"
CONVENTIONS = (STANDARD, MODIFIED, GENERAL)


def _frozen(x: np.ndarray) -> np.ndarray:
    x = np.array(x, dtype=float)
    x.setflags(write=False)
    return x


@dataclass(frozen=True)
class Chain:
    """A serial chain of joints (immutable arrays): DH links or, as URDF writes it, origins and axes.

    Parameters
    ----------
    a, alpha, d, theta_offset : ndarray, shape (n,) [length | rad | length | rad]
        DH parameters per link (see the conventions in :mod:`pipeline.kinematics`); zeros for the
        general form.
    prismatic : ndarray of bool, shape (n,)
        True where the joint is prismatic (its variable adds to ``d``, or moves along the axis).
    convention : {"standard", "modified", "general"}
    base, tool : ndarray, shape (4, 4)
        ``T_world_base0`` and ``T_flange_tool``; identity when absent.
    origins : ndarray, shape (n, 4, 4) [length], general form only
        Fixed transform from the previous joint's frame (the base for joint 1) to joint i's frame
        at zero joint value (URDF ``<origin xyz rpy>``).
    axes : ndarray, shape (n, 3), general form only
        Unit joint axis in joint i's frame (URDF ``<axis>``). Joint i's motion is ``Rot(axis, q_i)``
        (revolute) or ``Trans(axis q_i)`` (prismatic), after its origin:
        ``T_i = origins[i] @ motion_i(q_i)``.
    """

    a: np.ndarray
    alpha: np.ndarray
    d: np.ndarray
    theta_offset: np.ndarray
    prismatic: np.ndarray
    convention: str = STANDARD
    base: np.ndarray = field(default_factory=lambda: np.eye(4))
    tool: np.ndarray = field(default_factory=lambda: np.eye(4))
    origins: np.ndarray | None = None
    axes: np.ndarray | None = None

    def __post_init__(self) -> None:
        for name in ("a", "alpha", "d", "theta_offset", "base", "tool"):
            object.__setattr__(self, name, _frozen(getattr(self, name)))
        if self.convention == GENERAL:
            if self.origins is None or self.axes is None:
                raise ValueError("Chain: the general form needs origins (n, 4, 4) and axes (n, 3)")
            ax = np.array(self.axes, dtype=float)
            norm = np.linalg.norm(ax, axis=-1, keepdims=True) if ax.ndim == 2 else None
            if norm is None or not np.all(norm > 0):
                raise ValueError("Chain: every joint axis must be a non-zero 3-vector")
            object.__setattr__(self, "axes", _frozen(ax / norm))
            object.__setattr__(self, "origins", _frozen(self.origins))
        elif self.origins is not None or self.axes is not None:
            raise ValueError("Chain: origins and axes belong to the general form only")
        p = np.array(self.prismatic, dtype=bool)
        p.setflags(write=False)
        object.__setattr__(self, "prismatic", p)
        n = self.a.shape[0]
        if any(getattr(self, k).shape != (n,) for k in ("alpha", "d", "theta_offset", "prismatic")):
            raise ValueError("Chain: a, alpha, d, theta_offset and prismatic must all have shape (n,)")
        if self.convention == GENERAL and (self.origins.shape != (n, 4, 4) or self.axes.shape != (n, 3)):
            raise ValueError("Chain: origins must have shape (n, 4, 4) and axes (n, 3)")
        if self.base.shape != (4, 4) or self.tool.shape != (4, 4):
            raise ValueError("Chain: base and tool must be 4x4")
        if self.convention not in CONVENTIONS:
            raise ValueError(f"Chain: convention must be one of {CONVENTIONS}, got {self.convention!r}")

    @property
    def n(self) -> int:
        """Number of joints."""
        return int(self.a.shape[0])

    @property
    def modified(self) -> bool:
        return self.convention == MODIFIED

    @property
    def general(self) -> bool:
        return self.convention == GENERAL

    @property
    def form_code(self) -> int:
        """0 standard DH, 1 modified DH, 2 general (the compiled kinematics' switch)."""
        return CONVENTIONS.index(self.convention)

    def as_general(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The same chain in the general form, exactly (for URDF export and peer libraries).

        Standard DH ``Rz(q + theta0) Tz(d) Tx(a) Rx(alpha)`` is ``Rz(q) P_i`` with the fixed
        ``P_i = Rz(theta0) Tz(d) Tx(a) Rx(alpha)`` (a prismatic ``Tz(q)`` commutes the same way), so
        joint i's origin is ``P_{i-1}`` (identity for joint 1) and ``P_n`` moves into the tool.
        Modified DH ``Rx(alpha) Tx(a) Rz(theta0) Tz(d)`` is joint i's origin, motion after it.

        Returns
        -------
        origins : ndarray, shape (n, 4, 4) [length]
        axes : ndarray, shape (n, 3)          all ``(0, 0, 1)`` for a DH chain
        tool : ndarray, shape (4, 4)          the tool transform after the last joint's frame
        """
        if self.general:
            return self.origins.copy(), self.axes.copy(), self.tool.copy()
        fixed = dh_transform(self.a, self.alpha, self.d, self.theta_offset, self.convention)  # (n, 4, 4)
        axes = np.tile([0.0, 0.0, 1.0], (self.n, 1))
        if self.modified:
            return fixed, axes, self.tool.copy()
        origins = np.concatenate([np.eye(4)[None], fixed[:-1]], axis=0)
        return origins, axes, fixed[-1] @ self.tool

    def joint_dh(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per-link ``theta`` and ``d`` for joint values ``q``.

        Parameters
        ----------
        q : ndarray, shape (..., n) [rad | length]

        Returns
        -------
        theta, d : ndarray, shape (..., n) [rad], [length]
        """
        q = np.asarray(q, dtype=float)
        if q.shape[-1] != self.n:
            raise ValueError(f"expected {self.n} joint values, got shape {q.shape}")
        if self.general:
            raise ValueError("joint_dh: a general-form chain has no DH parameters")
        theta = np.where(self.prismatic, self.theta_offset, q + self.theta_offset)
        d = np.where(self.prismatic, q + self.d, self.d)
        return theta, d

    def scaled(self, factor: float) -> "Chain":
        """A copy with every length multiplied by ``factor`` (unit change)."""
        base = self.base.copy()
        tool = self.tool.copy()
        base[:3, 3] *= factor
        tool[:3, 3] *= factor
        origins = None
        if self.general:
            origins = self.origins.copy()
            origins[:, :3, 3] *= factor
        return Chain(self.a * factor, self.alpha, self.d * factor, self.theta_offset, self.prismatic,
                     self.convention, base, tool, origins, None if self.axes is None else self.axes.copy())


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
