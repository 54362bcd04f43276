"""The numeric description of a serial chain that every kinematics function takes."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

STANDARD = "standard"
MODIFIED = "modified"
CONVENTIONS = (STANDARD, MODIFIED)


def _frozen(x: np.ndarray) -> np.ndarray:
    x = np.array(x, dtype=float)
    x.setflags(write=False)
    return x


@dataclass(frozen=True)
class Chain:
    """A serial chain of DH links (immutable arrays).

    Parameters
    ----------
    a, alpha, d, theta_offset : ndarray, shape (n,) [length | rad | length | rad]
        DH parameters per link (see the conventions in :mod:`pipeline.kinematics`).
    prismatic : ndarray of bool, shape (n,)
        True where the joint is prismatic (its variable adds to ``d``).
    convention : {"standard", "modified"}
    base, tool : ndarray, shape (4, 4)
        ``T_world_base0`` and ``T_flange_tool``; identity when absent.
    """

    a: np.ndarray
    alpha: np.ndarray
    d: np.ndarray
    theta_offset: np.ndarray
    prismatic: np.ndarray
    convention: str = STANDARD
    base: np.ndarray = field(default_factory=lambda: np.eye(4))
    tool: np.ndarray = field(default_factory=lambda: np.eye(4))

    def __post_init__(self) -> None:
        for name in ("a", "alpha", "d", "theta_offset", "base", "tool"):
            object.__setattr__(self, name, _frozen(getattr(self, name)))
        p = np.array(self.prismatic, dtype=bool)
        p.setflags(write=False)
        object.__setattr__(self, "prismatic", p)
        n = self.a.shape[0]
        if any(getattr(self, k).shape != (n,) for k in ("alpha", "d", "theta_offset", "prismatic")):
            raise ValueError("Chain: a, alpha, d, theta_offset and prismatic must all have shape (n,)")
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
        theta = np.where(self.prismatic, self.theta_offset, q + self.theta_offset)
        d = np.where(self.prismatic, q + self.d, self.d)
        return theta, d

    def scaled(self, factor: float) -> "Chain":
        """A copy with every length multiplied by ``factor`` (unit change)."""
        base = self.base.copy()
        tool = self.tool.copy()
        base[:3, 3] *= factor
        tool[:3, 3] *= factor
        return Chain(self.a * factor, self.alpha, self.d * factor, self.theta_offset, self.prismatic,
                     self.convention, base, tool)
