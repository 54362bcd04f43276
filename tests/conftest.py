"""Shared fixtures and hypothesis strategies."""

from __future__ import annotations

import os
from pathlib import Path

os.environ.setdefault("PIPELINE_COMPILE_NOTICE", "0")  # no compile line in the outputs the tests compare

import numpy as np
import pytest
from hypothesis import strategies as st

from pipeline.kinematics import Chain

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "data"


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    from pipeline.kinematics import matrix_from_quat

    return matrix_from_quat(q)


def random_transform(rng: np.random.Generator, scale: float = 1.0) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = random_rotation(rng)
    T[:3, 3] = rng.normal(scale=scale, size=3)
    return T


def random_chain(rng: np.random.Generator, n: int, convention: str, prismatic_share: float = 0.3,
                 with_base_tool: bool = True) -> Chain:
    return Chain(rng.normal(size=n), rng.uniform(-np.pi, np.pi, n), rng.normal(size=n),
                 rng.uniform(-np.pi, np.pi, n), rng.random(n) < prismatic_share, convention,
                 random_transform(rng) if with_base_tool else np.eye(4),
                 random_transform(rng, 0.2) if with_base_tool else np.eye(4))


@st.composite
def chains(draw, max_dof: int = 8):
    """A random DH chain (standard or modified, revolute and prismatic joints, base and tool)."""
    seed = draw(st.integers(0, 2**32 - 1))
    n = draw(st.integers(1, max_dof))
    conv = draw(st.sampled_from(["standard", "modified"]))
    return random_chain(np.random.default_rng(seed), n, conv)


@pytest.fixture(scope="session")
def lwr():
    from pipeline.robots import load_robot

    return load_robot(DATA / "robots" / "kuka_lwr.yaml")


@pytest.fixture(scope="session")
def ur5():
    from pipeline.robots import load_robot

    return load_robot(DATA / "robots" / "ur5.yaml")


def rodrigues(axis, angle) -> np.ndarray:
    """Rotation (3, 3) about ``axis`` by ``angle`` [rad], written out (not from pipeline.kinematics)."""
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def homogeneous(R=None, t=None) -> np.ndarray:
    """4 x 4 transform from a rotation (3, 3) and a translation (3,) (identity parts when omitted)."""
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    if t is not None:
        T[:3, 3] = t
    return T


@pytest.fixture(scope="session")
def quick_build(tmp_path_factory):
    """One quick-scale Snakemake build of the whole workflow, shared by the workflow and browser tests
    (tests/workflow/test_workflow.py's ``built``, tests/report/test_browser.py)."""
    from tests.workflow.test_workflow import _snakemake

    results = tmp_path_factory.mktemp("results")
    _snakemake(results)
    return results


def run_pipeline(*args, env=None, cwd=None):
    """``python -m pipeline ARGS`` from the project folder (``env``: variables added to this one's)."""
    import os
    import subprocess
    import sys

    return subprocess.run([sys.executable, "-m", "pipeline", *args], capture_output=True, text=True,
                          env={**os.environ, **(env or {})}, cwd=cwd or ROOT)


def mutated(good: dict, path, value):
    """A deep copy of the robot document ``good`` with the field at ``path`` (keys and indices) set to
    ``value``, or removed where ``value`` is ``KeyError``."""
    import yaml

    doc = yaml.safe_load(yaml.safe_dump(good))
    node = doc
    for k in path[:-1]:
        node = node[k]
    if value is KeyError:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return doc
