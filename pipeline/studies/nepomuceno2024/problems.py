"""Problem sets of nepomuceno2024: one designed motion = one chain of Cartesian path points.

``motion_points`` is the generator of the study's ``problem_sets`` (``kind: generator``): every
interpolated point of one motion of ``data/nepomuceno2024/motions.yaml`` is one IK problem, in
order, all in chain 0, so the generic solve loop (:mod:`pipeline.runner`) warm-starts every point
from the previous point's solution and the first from the motion's ``start_joints`` (the
document's scheme, notes §5.6). Goal angles are unknown (NaN): the goals are Cartesian poses.

The interpolation density is the problem set's ``count``: points per metre of TCP travel
(300 full, 20 quick); ``params.min_points`` maps that density to the points added to every segment
(80 at 300, 4 at 20), since a generator is not told the scale. Segment ``N = int(count · |Δp| +
min_points)`` as :func:`.trajectory.segment_count`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pipeline.problems import ProblemSet, ProblemSpecError, fk_poses, from_poses
from pipeline.robots import RobotModel
from pipeline.studies.nepomuceno2024.trajectory import MotionPoints, build_motion, load_motions


def interpolation(count: int, params: dict) -> dict:
    """``{points_per_metre, min_points}`` of a problem set from its ``count`` and ``params``."""
    table = {int(k): int(v) for k, v in (params.get("min_points") or {}).items()}
    if int(count) not in table:
        raise ProblemSpecError(f"field 'params/min_points': no entry for the density count = {count} "
                               f"(have: {', '.join(map(str, table)) or 'none'})")
    return {"points_per_metre": float(count), "min_points": table[int(count)]}


def motion(model: RobotModel, count: int, params: dict, data_dir: Path) -> MotionPoints:
    """The interpolated points of ``params.motion`` for ``model`` (poses in the robot file's unit)."""
    for key in ("motion", "motions_file"):
        if key not in params:
            raise ProblemSpecError(f"field 'params/{key}': missing")
    doc = load_motions(Path(data_dir) / params["motions_file"])
    if params["motion"] not in doc["motions"]:
        raise ProblemSpecError(f"field 'params/motion': {params['motion']!r} is not a motion of "
                               f"{params['motions_file']} (have: {', '.join(doc['motions'])})")
    if model.n != 6 or model.length_unit != "m":
        raise ProblemSpecError(f"field 'robots': the designed motions are for a 6-joint arm in m, not {model.name}")
    return build_motion(doc, params["motion"], lambda q: fk_poses(model.chain, np.atleast_2d(q))[0], **interpolation(count, params))


def motion_points(model: RobotModel, count: int, rng: np.random.Generator, params: dict,
                  data_dir: Path) -> ProblemSet:
    """Generator: the points of one motion as one chain (``q_start`` = the motion's start joints)."""
    mp = motion(model, count, params, data_dir)
    q_start = np.tile(mp.q_start, (len(mp), 1))
    return from_poses(model, q_start, mp.T, chain=np.zeros(len(mp), dtype=int))


def set_motion(study, pset: str, scale: str, data_dir: Path | None = None) -> MotionPoints:
    """The motion behind problem set ``pset`` of ``study`` at ``scale`` (segment names for tables)."""
    from pipeline.robots import load_robot
    from pipeline.settings import ROOT

    data_dir = Path(data_dir) if data_dir is not None else ROOT / "data"
    spec = study.problem_sets[pset]
    model = load_robot(data_dir / "robots" / f"{study.set_robots(pset)[0]}.yaml")
    return motion(model, study.count(pset, scale), spec.get("params") or {}, data_dir)
