"""The robot prepared once per job: working unit, the kernels' arrays, per-job memo."""

from __future__ import annotations

import math

import numpy as np

from pipeline.kinematics.fkcheck import check_model
from pipeline.robots import LENGTH_UNITS, RobotModel
from pipeline.solvers.core.settings import NotApplicableError


_MISSING = object()


class Prepared:
    """A robot converted to a working length unit and unpacked into the kernels' arrays.

    Attributes
    ----------
    source : RobotModel             the model as given (goals are passed in its unit)
    model : RobotModel              the model in ``unit``
    unit : str                      working length unit
    goal_scale : float              factor from ``source``'s unit to ``unit``
    args : tuple                    ``a, alpha, d, offs, prism, form, base, tool`` for :mod:`._kin`
                                    (``form`` = 0 standard / 1 modified DH / 2 general; for the
                                    general form ``a`` holds the origins' rows 0-2 (12 n,) and
                                    ``alpha`` the unit axes (3 n,), see ``_kin.link_transform``)
    limits : ndarray, shape (n, 2)  joint limits [rad | unit]; +-inf where the file gives none
    """

    def __init__(self, model: RobotModel, unit: str | None = None):
        if isinstance(model, Prepared):
            model = model.source
        unit = unit or "m"
        self.source = model
        self.unit = unit
        self.model = model.in_unit(unit) if unit != model.length_unit else model
        self.goal_scale = LENGTH_UNITS[model.length_unit] / LENGTH_UNITS[unit]
        c = self.model.chain
        # writable C-contiguous copies: the model's arrays are read-only, and numba compiles kernels
        # taking read-only arrays into code measured 2-3.5x slower (inverse Jacobian on the KR6)
        own = lambda x, dt=float: np.array(x, dtype=dt, order="C", copy=True)  # noqa: E731
        if c.general:
            a, alpha = own(c.origins[:, :3, :].ravel()), own(c.axes.ravel())
        else:
            a, alpha = own(c.a), own(c.alpha)
        self.args = (a, alpha, own(c.d), own(c.theta_offset), own(c.prismatic, np.bool_),
                     int(c.form_code), own(c.base), own(c.tool))
        self.limits = own(self.model.limits)
        self.prismatic = np.asarray(c.prismatic, dtype=bool)
        self._cache: dict = {}  # see memo()
        self._bound: dict = {}  # (solver name, id(settings)) -> driver.Bound (see registry.bind)
        self._last: dict = {}  # solver name -> the Bound solve() called last for it (see registry.solve)
        self._finish_args = None  # finish()'s packed check model (see _finish_args)

    @property
    def n(self) -> int:
        return self.model.n

    @property
    def check(self) -> tuple:
        """The independent FK check's model of the working-unit chain (:func:`pipeline.kinematics.fkcheck.check_model`)."""
        return self.memo("fkcheck", lambda: check_model(self.model.chain))

    def memo(self, key, make):
        """Data derived once per job and robot (packed settings, an analytic solver's geometry...):
        ``make()`` on the first call with ``key`` (hashable), the stored value afterwards."""
        value = self._cache.get(key, _MISSING)
        if value is _MISSING:
            value = self._cache[key] = make()
        return value

    def working_goal(self, T_goal: np.ndarray) -> np.ndarray:
        """``T_goal`` (4, 4) in the source model's unit -> the working unit, C-contiguous float64
        (the caller's array itself when it already is that and no unit change is needed: kernels
        never write into the goal)."""
        if self.goal_scale != 1.0:
            T = np.array(T_goal, dtype=float, order="C")
            T[:3, 3] *= self.goal_scale
            return T
        return np.ascontiguousarray(T_goal, dtype=float)

    def bare_goal(self, T_goal: np.ndarray) -> np.ndarray:
        """Goal of the bare DH chain: ``base^-1 T_goal tool^-1`` (for analytic solvers)."""
        c = self.model.chain
        return inv_rigid(c.base) @ T_goal @ inv_rigid(c.tool)

    def search_box(self, default_half_width: float = math.pi) -> np.ndarray:
        """Finite joint box (n, 2): the limits, with ``[-w, w]`` for unbounded revolute joints.

        Raises
        ------
        NotApplicableError
            An unbounded prismatic joint (no finite box to search).
        """
        box = self.limits.copy()
        for i in range(self.n):
            if not np.all(np.isfinite(box[i])):
                if self.prismatic[i]:
                    raise NotApplicableError(f"{self.source.path or self.source.name}: joint {i + 1}: a prismatic "
                                             "joint without limits gives no finite search box")
                box[i] = (-default_half_width, default_half_width)
        return box


def inv_rigid(T: np.ndarray) -> np.ndarray:
    """The inverse of a rigid transform.

    Parameters
    ----------
    T : ndarray, shape (4, 4) [length]
        Rotation and translation.

    Returns
    -------
    ndarray, shape (4, 4) [length]
    """
    out = np.eye(4)
    out[:3, :3] = T[:3, :3].T
    out[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return out


