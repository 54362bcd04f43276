"""Joints held at given values (the ``fixed_joints`` setting): the arm folded into a shorter one, a solver
run on that, its joint vectors written back for the whole arm.

A held joint is folded into the link transforms next to it (:func:`pipeline.kinematics.folding.hold`):
the shorter arm's pose at the moving joints' values is exactly the whole arm's with the held joints at
their values, so a 7R arm with one joint held is a 6R arm and gets every 6R path of a closed form (the
general elimination included), and an iterative method simply never moves the held joints. The solve
starts from ``q_start`` with the held joints at their values; ``q`` and every row of ``solutions`` carry
the held values; the result rule (:func:`pipeline.solvers.core.finish`) checks ``q`` by the whole
arm's forward kinematics, as for every solver.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from pipeline.kinematics.folding import hold, lines_chain
from pipeline.kinematics.geometry import joint_lines
from pipeline.robots import RobotModel
from pipeline.solvers.core.prepared import Prepared
from pipeline.solvers.core.results import Raw
from pipeline.solvers.core.settings import check_joint_numbers, setting

FIELD = "fixed_joints"


def fixed_joints_setting():
    """The ``fixed_joints`` field of a solver's settings (a joint map: ``{joint number (1-based): value}``)."""
    return setting((), "joints held at the given values while the others are solved, {joint number: value} with "
                   "joints numbered from 1 as in the robot file (e.g. {3: 0.0}); values in rad (a prismatic joint's "
                   "in the robot file's length unit); the held joints are folded into the neighbouring links, "
                   "so a 7R arm with one joint held is solved as a 6R arm; {} = none", joints=True, quiet=True)


def held(s) -> tuple:
    """``s``'s held joints as sorted ``(joint number, value)`` pairs (empty for settings without the field)."""
    return getattr(s, FIELD, ())


def folded(prep: Prepared, pairs: tuple) -> tuple[Prepared, np.ndarray]:
    """The arm of ``prep`` with the joints ``pairs`` (:func:`held`) held: the shorter arm prepared in the
    same working unit, and the moving joints' indices (0-based), once per job.

    Raises
    ------
    SettingsError
        A joint number beyond the arm, or every joint held (one line naming the field).
    """
    check_joint_numbers(pairs, prep.n, f"solver settings: field '{FIELD}'")
    return prep.memo((FIELD, pairs), lambda: _fold(prep, pairs))


def _fold(prep: Prepared, pairs: tuple) -> tuple[Prepared, np.ndarray]:
    values = {k - 1: v * (prep.goal_scale if prep.prismatic[k - 1] else 1.0) for k, v in pairs}
    lines, keep = hold(joint_lines(prep.model.chain), values)
    src = prep.model
    names = tuple(src.joint_names[i] for i in keep) if src.joint_names else ()
    label = ", ".join(str(k) for k, _ in pairs)
    model = RobotModel(f"{src.name} (joint{'s' if len(pairs) > 1 else ''} {label} held)", src.source, prep.unit,
                       lines_chain(lines), np.array(src.limits[keep]), src.path, src.notes, names)
    return Prepared(model, prep.unit), keep


def bind_held(prep: Prepared, s, bind):
    """``run1(T_goal, q_start, seed) -> Raw`` for the whole arm of ``bind(prep', s')``, the method's own
    ``bind`` on the folded arm ``prep'`` (:func:`folded`) with ``s'`` = ``s`` without held joints.

    Parameters
    ----------
    prep : Prepared
        The whole arm (n joints).
    s : Settings
        The method's settings in the working unit, with a non-empty ``fixed_joints``.
    bind : callable
        The method's ``bind(prep, settings) -> run1``.
    """
    small, keep = folded(prep, held(s))
    inner = bind(small, replace(s, **{FIELD: ()}))
    full = np.zeros(prep.n)
    for k, v in held(s):
        full[k - 1] = v * (prep.goal_scale if prep.prismatic[k - 1] else 1.0)

    def run1(T_goal: np.ndarray, q_start: np.ndarray, seed: int) -> Raw:
        raw = inner(T_goal, np.ascontiguousarray(q_start[keep]), seed)
        q = full.copy()
        q[keep] = raw.q
        sols = raw.solutions
        if sols is not None:
            whole = np.tile(full, (len(sols), 1))
            whole[:, keep] = sols
            sols = whole
        return replace(raw, q=q, solutions=sols)

    return run1
