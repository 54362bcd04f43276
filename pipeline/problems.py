"""Seeded IK problem sets (pure: every random function takes a ``numpy.random.Generator``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.kinematics import fk_htm, matrix_from_quat, quat_from_matrix
from pipeline.robots import RobotModel


@dataclass(frozen=True)
class ProblemSet:
    """A set of IK problems for one robot.

    Attributes
    ----------
    problem_id : ndarray of int, shape (m,)
    q_start, q_goal : ndarray, shape (m, n) [rad | length]
    goal_position : ndarray, shape (m, 3) [length_unit]
    goal_quat : ndarray, shape (m, 4)   w-first
    robot, length_unit : str
    """

    problem_id: np.ndarray
    q_start: np.ndarray
    q_goal: np.ndarray
    goal_position: np.ndarray
    goal_quat: np.ndarray
    robot: str
    length_unit: str

    def __len__(self) -> int:
        return int(self.problem_id.shape[0])

    def goal_transforms(self) -> np.ndarray:
        """Goal poses ``T_base_ee``, shape (m, 4, 4)."""
        T = np.zeros((len(self), 4, 4))
        T[:, :3, :3] = matrix_from_quat(self.goal_quat)
        T[:, :3, 3] = self.goal_position
        T[:, 3, 3] = 1.0
        return T

    def head(self, m: int) -> "ProblemSet":
        return ProblemSet(self.problem_id[:m], self.q_start[:m], self.q_goal[:m], self.goal_position[:m],
                          self.goal_quat[:m], self.robot, self.length_unit)


def random_joint_pairs(model: RobotModel, count: int, rng: np.random.Generator,
                       low: float = 0.0, high: float = 2 * np.pi) -> ProblemSet:
    """Start and goal joint vectors drawn uniformly in ``[low, high)``; goal pose = FK(goal).

    This is the protocol of 000_7e3cb7ad5ee98ff0.txt §3.2 (``unifrnd(0, 2*pi)`` per joint).
    Start angles are drawn first (all problems), then goal angles, so that a larger ``count``
    with the same seed does not extend a smaller set: sets of different sizes are independent.

    Parameters
    ----------
    model : RobotModel
    count : int
    rng : numpy.random.Generator
    low, high : float [rad]

    Returns
    -------
    ProblemSet
    """
    if count < 1:
        raise ValueError(f"problem count must be >= 1, got {count}")
    n = model.n
    q_start = rng.uniform(low, high, size=(count, n))
    q_goal = rng.uniform(low, high, size=(count, n))
    T = fk_htm(model.chain, q_goal)
    return ProblemSet(np.arange(count), q_start, q_goal, T[:, :3, 3].copy(), quat_from_matrix(T),
                      model.name, model.length_unit)
