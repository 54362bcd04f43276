"""Problem sets: determinism, goal = FK(goal angles), file round trip."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.cli import main
from pipeline.io.problems import ProblemFileError, read_problems, write_problems
from pipeline.kinematics import fk_htm
from pipeline.problems import random_joint_pairs
from tests.conftest import DATA

STUDY = str(DATA / "studies" / "cerbaro2019.yaml")
ROBOT = str(DATA / "robots" / "kuka_lwr.yaml")


def test_same_seed_same_file(tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    for out in (a, b):
        assert main(["make_problems", "--study", STUDY, "--problem-set", "random", "--robot", ROBOT, "--scale", "quick", "--out", str(out)]) == 0
    assert a.read_bytes() == b.read_bytes()


def test_different_seed_differs(lwr):
    p1 = random_joint_pairs(lwr, 5, np.random.default_rng(1))
    p2 = random_joint_pairs(lwr, 5, np.random.default_rng(2))
    assert not np.allclose(p1.q_start, p2.q_start)


def test_goal_is_fk_of_goal_angles_and_in_range(lwr):
    ps = random_joint_pairs(lwr, 50, np.random.default_rng(7))
    assert ps.q_start.min() >= 0 and ps.q_start.max() < 2 * np.pi
    np.testing.assert_allclose(ps.goal_transforms(), fk_htm(lwr.chain, ps.q_goal), atol=1e-12)


def test_file_round_trip_is_exact(tmp_path, lwr):
    ps = random_joint_pairs(lwr, 20, np.random.default_rng(3))
    write_problems(tmp_path / "p.csv", ps, {"seed": 3})
    back, meta = read_problems(tmp_path / "p.csv")
    assert meta["seed"] == "3" and back.robot == "kuka_lwr"
    for field in ("q_start", "q_goal", "goal_position", "goal_quat"):
        assert np.array_equal(getattr(back, field), getattr(ps, field))


def test_bad_problem_file(tmp_path):
    p = tmp_path / "p.csv"
    p.write_text("hello\n")
    with pytest.raises(ProblemFileError, match="line 1: not an ik-pipeline problem set"):
        read_problems(p)
