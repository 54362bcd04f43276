"""Problem sets of 002_56eb235931bf5f5d.txt: the alpha sweep (Table 2), single points (Table 3), paths (Figs. 5-7).

The generators :func:`alpha_sweep`, :func:`points` and :func:`paths` have the signature of
``problem_sets.<set>.generator`` (``fn(model, count, rng, params, data_dir) -> ProblemSet``) and are
named in data/studies/borges_kr6.yaml. Goals are positions (identity orientation; the solvers run
with ``criterion: position``), written in the robot file's unit; the document's coordinates are mm.
Every random function takes an explicit ``numpy.random.Generator``. Lengths in mm, angles in rad.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pipeline.problems import ProblemSet, fk_poses, from_poses
from pipeline.robots import LENGTH_UNITS, RobotModel

CURVES = ("lemniscate", "rhodonea", "circle")


def lemniscate(t: np.ndarray) -> np.ndarray:
    """Eq. 12 (lemniscate of Bernoulli in the plane y = -700 mm). ``t`` (k,) [rad] -> (k, 3) [mm]."""
    t = np.asarray(t, float)
    den = np.sin(t) ** 2 + 1
    x = 100 * np.sqrt(2) * np.cos(t) / den
    z = 100 * np.sqrt(2) * np.cos(t) * np.sin(t) / den + 430
    return np.stack([x, np.full_like(t, -700.0), z], axis=-1)


def rhodonea(t: np.ndarray) -> np.ndarray:
    """Eq. 13 (four-petal rose, k = 2). ``t`` (k,) [rad] -> (k, 3) [mm]."""
    t = np.asarray(t, float)
    r = np.cos(2 * t)
    return np.stack([100 * r * np.cos(t), 50 * r * np.cos(t) - 700, 100 * r * np.sin(t) + 430], axis=-1)


def circle(t: np.ndarray, swap_yz: bool = True) -> np.ndarray:
    """Eq. 14. As printed (``swap_yz=False``): x = 100 cos t, y = 100 sin t + 430, z = 50 cos t - 700,
    about 1120-1230 mm from the shoulder, beyond the 762 mm reach. ``swap_yz=True`` (the curve the
    authors evidently ran): y = 50 cos t - 700, z = 100 sin t + 430. ``t`` (k,) -> (k, 3) [mm]."""
    t = np.asarray(t, float)
    y = 100 * np.sin(t) + 430
    z = 50 * np.cos(t) - 700
    if swap_yz:
        y, z = z, y
    return np.stack([100 * np.cos(t), y, z], axis=-1)


def curve_points(name: str, t: np.ndarray, swap_yz: bool = True) -> np.ndarray:
    if name == "lemniscate":
        return lemniscate(t)
    if name == "rhodonea":
        return rhodonea(t)
    if name == "circle":
        return circle(t, swap_yz)
    raise ValueError(f"unknown curve {name!r} (have: {', '.join(CURVES)})")


def path_parameter(t_start: float, t_step: float, count: int) -> np.ndarray:
    """t = t_start, t_start + t_step, ... (``count`` values; 0, 0.1, ..., 6.2 for 63 points), rounded to 1e-12."""
    return np.round(t_start + t_step * np.arange(count), 12)


@dataclass(frozen=True)
class Pair:
    """One alpha-sweep problem: start angles, goal position, the target distance class."""

    distance_class: float      # [mm] 300, 960 or 1160
    q_start: np.ndarray        # (6,) [rad]
    q_goal: np.ndarray         # (6,) [rad] (only used to make the goal reachable)
    p_goal: np.ndarray         # (3,) [mm]
    distance: float            # [mm] actual |p_goal - p(q_start)|


def distance_pairs(model: RobotModel, distances, count: int, tolerance: float, rng: np.random.Generator,
                   batch: int = 20000, max_batches: int = 200) -> list[Pair]:
    """``count`` start/goal pairs per distance, both configurations uniform within the joint limits,
    kept when ``| |p(q_goal) - p(q_start)| - distance | <= tolerance`` (rejection sampling, in draw order).

    Raises
    ------
    ValueError
        When ``max_batches`` batches do not yield enough pairs (a distance beyond twice the reach).
    """
    lim = model.limits
    want = {float(d): [] for d in distances}
    for _ in range(max_batches):
        qs = rng.uniform(lim[:, 0], lim[:, 1], size=(batch, model.n))
        qg = rng.uniform(lim[:, 0], lim[:, 1], size=(batch, model.n))
        ps = fk_poses(model.chain, qs)[:, :3, 3]  # BLAS-free: the same digits on every machine
        pg = fk_poses(model.chain, qg)[:, :3, 3]
        dist = np.linalg.norm(pg - ps, axis=1)
        for dclass, got in want.items():
            for i in np.flatnonzero(np.abs(dist - dclass) <= tolerance):
                if len(got) < count:
                    got.append(Pair(dclass, qs[i], qg[i], pg[i], float(dist[i])))
        if all(len(g) >= count for g in want.values()):
            break
    short = [d for d, g in want.items() if len(g) < count]
    if short:
        raise ValueError(f"alpha sweep: could not draw {count} pairs at distances {short} mm")
    return [p for d in want for p in want[d]]


# ---- problem-set generators (problem_sets.<set>.generator) -------------------------------------
def _mm_to_model(model: RobotModel) -> float:
    return LENGTH_UNITS["mm"] / LENGTH_UNITS[model.length_unit]


def _position_goals(p: np.ndarray) -> np.ndarray:
    """Goal poses (m, 4, 4) with identity orientation at positions ``p`` (m, 3)."""
    T = np.tile(np.eye(4), (p.shape[0], 1, 1))
    T[:, :3, 3] = p
    return T


def alpha_sweep(model: RobotModel, count: int, rng: np.random.Generator, params: dict, data_dir: Path) -> ProblemSet:
    """Table 2: ``count`` start/goal pairs per distance class (:func:`distance_pairs`), grouped by class in the
    order of ``params["distances_mm"]`` (problem ids ``k * count + i`` for class ``k``); ``q_goal`` = the
    drawn goal angles. Params: distances_mm, distance_tolerance_mm [mm]."""
    f = _mm_to_model(model)
    pairs = distance_pairs(model, [d * f for d in params["distances_mm"]], count,
                           float(params["distance_tolerance_mm"]) * f, rng)
    q_start = np.array([p.q_start for p in pairs])
    q_goal = np.array([p.q_goal for p in pairs])
    return from_poses(model, q_start, _position_goals(np.array([p.p_goal for p in pairs])), q_goal=q_goal)


def points(model: RobotModel, count: int, rng: np.random.Generator, params: dict, data_dir: Path) -> ProblemSet:
    """Table 3: each target of ``params["targets_mm"]`` (in its order) ``count`` times (the runs; problem ids
    ``k * count + run``), every run from ``params["start_configuration_deg"]``. Deterministic (``rng`` unused)."""
    q_home = np.radians(np.asarray(params["start_configuration_deg"], float))
    targets = np.asarray(list(params["targets_mm"].values()), float) * _mm_to_model(model)
    p = np.repeat(targets, count, axis=0)
    return from_poses(model, np.tile(q_home, (p.shape[0], 1)), _position_goals(p))


def paths(model: RobotModel, count: int, rng: np.random.Generator, params: dict, data_dir: Path) -> ProblemSet:
    """Figures 5-10: ``count`` points of each curve of ``params["curves"]`` at t = t_start + k t_step; curve ``c`` is
    chain ``c`` (each point warm-started from the previous point's solution), its first point starts from
    ``params["start_configuration_deg"]``. Deterministic (``rng`` unused)."""
    q_home = np.radians(np.asarray(params["start_configuration_deg"], float))
    t = path_parameter(float(params["t_start"]), float(params["t_step"]), count)
    curves = list(params["curves"])
    p = np.concatenate([curve_points(c, t, bool(params["circle_swap_yz"])) for c in curves]) * _mm_to_model(model)
    chain = np.repeat(np.arange(len(curves)), len(t))
    return from_poses(model, np.tile(q_home, (p.shape[0], 1)), _position_goals(p), chain=chain)
