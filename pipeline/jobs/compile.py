"""``compile``: compile (or load) the numba kernels of the project's own methods ahead of their first call.

Each method is bound to every shipped robot it applies to (or to the robots named) and called once on a
reachable goal, so that the kernels that call needs are compiled into the cache
(:mod:`pipeline._numba_cache`) or loaded from it; ``batch`` also runs one :func:`solve_batch` of
``BATCH_GOALS`` goals per arm, which compiles the batch kernels (the closed forms' 8-goal lanes). The
peers' methods are not numba code and are skipped. Progress goes to stderr, one line per method.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from pipeline.errors import UsageError

BATCH_GOALS = 16  # two blocks of 8-goal lanes


def _goal(model):
    """A reachable goal (the FK of joint values a third into each joint's range) and a start."""
    import numpy as np

    from pipeline.kinematics import fk_htm

    lim = np.asarray(model.limits, dtype=float)
    lo = np.where(np.isfinite(lim[:, 0]), lim[:, 0], -np.pi)
    hi = np.where(np.isfinite(lim[:, 1]), lim[:, 1], np.pi)
    q = lo + (hi - lo) * np.linspace(0.3, 0.4, model.n)
    return fk_htm(model.chain, q), lo + (hi - lo) * 0.5


def _goal_of(prep):
    """:func:`_goal` of a prepared robot with the goal in the robot file's unit (as a job passes it)."""
    T, q0 = _goal(prep.model)
    T = T.copy()
    T[:3, 3] /= prep.goal_scale
    return T, q0


def compile_methods(methods: list[str] | None = None, robots: list[str] | None = None, *, batch: bool = False,
                    progress=sys.stderr) -> str:
    """Call every method of ``methods`` (default: every registered method of ours) once on each robot of
    ``robots`` (default: every shipped robot) it applies to; returns the summary to print."""
    import numpy as np

    from pipeline.robots import RobotFileError, load_robot, shipped_robots
    from pipeline.solvers import NotApplicableError, SettingsError, bind, get, names, solve_batch

    wanted = list(methods) if methods else [n for n in names() if not get(n).peer]
    for n in wanted:
        if get(n).peer:  # a one-line error for an unknown name first
            raise UsageError(f"{n}: a peer library's method, not numba code; nothing to compile")
    models = []
    for r in robots or shipped_robots():
        try:
            models.append(load_robot(r))
        except RobotFileError as exc:
            raise UsageError(str(exc)) from None
    t_all = time.perf_counter()
    for k, name in enumerate(wanted, 1):
        t0 = time.perf_counter()
        used = []
        for model in models:
            try:
                ik = bind(name, model)
            except (NotApplicableError, SettingsError):
                continue
            T, q0 = _goal(model)
            ik.solve(T, q0)
            if batch and get(name).batch is not None:
                goals = np.repeat(T[None], BATCH_GOALS, axis=0)
                solve_batch(name, model, goals, np.repeat(q0[None], BATCH_GOALS, axis=0), threads=1, traces=False)
            used.append(model.name)
        dt = time.perf_counter() - t0
        line = f"[{k}/{len(wanted)}] {name}: {len(used)} arm(s), {dt:.1f} s"
        print(line, file=progress, flush=True)
    return (f"compiled or loaded the kernels of {len(wanted)} method(s) in {time.perf_counter() - t_all:.1f} s "
            f"(cache: {os.environ.get('NUMBA_CACHE_DIR', 'numba default')})")


def _warm_helpers(prep, settings) -> bool:
    """The kernels a job may call beside its solver's: the independent check of another solution than the
    method's first (``require_limits``; its choice, ``nearest_of``, is warmed up by the solver's own call),
    the joint travel from a warm start (the race and the answer tables, on writable copies) and, for a DH
    chain, the FK timing kernels of mariano2019. Each has one signature, so one call each builds or loads
    it for every robot. Returns whether the FK timing kernels were reached."""
    import numpy as np

    from pipeline.solvers.kernels import kin as _kin
    from pipeline.solvers.core import LIMIT_TOL, check, nearest_rep
    from pipeline.solvers.core.driver import converted

    T, q0 = _goal_of(prep)
    check(prep, prep.working_goal(T), q0, converted(prep, settings))
    lim, prism = np.ascontiguousarray(prep.limits, dtype=float), np.ascontiguousarray(prep.prismatic, dtype=np.bool_)
    nearest_rep(q0, q0, lim.copy(), prism.copy(), LIMIT_TOL, np.empty(prep.n))  # as the answer tables call it
    c = prep.model.chain
    if all(hasattr(c, f) for f in ("a", "alpha", "d", "theta_offset", "prismatic", "modified")):
        Q, out = np.zeros((2, prep.n)), np.empty((2, 3))
        args = (np.asarray(c.a, dtype=float), np.asarray(c.alpha, dtype=float), np.asarray(c.d, dtype=float),
                np.asarray(c.theta_offset, dtype=float), np.asarray(c.prismatic), c.modified, Q, out)
        _kin.fk_htm_batch(*args)
        _kin.fk_dq_batch(*args)
        return True
    return False


def compile_studies(study_paths: list, data="data", *, progress=sys.stderr) -> str:
    """Build or load, once, the kernels every solve job of these studies will call: each (robot, solver
    label) pair of the studies' jobs is warmed up with the label's own settings, as a solve job warms
    up (:func:`pipeline.solvers.warm_up`), and a method with a batch kernel also solves
    ``BATCH_GOALS`` goals in one batch (the path a solve job takes). The workflow runs this as its
    first rule, so that no solve job compiles and no two jobs compile the same kernel."""
    import numpy as np

    from pipeline.robots import load_robot
    from pipeline.settings import load_study
    from pipeline.solvers import NotApplicableError, get, prepare, solve_batch, warm_up

    t_all, done, helpers = time.perf_counter(), 0, False
    studies = [load_study(Path(p)) for p in study_paths]
    for k, st in enumerate(studies, 1):
        t0, pairs = time.perf_counter(), {}
        for _pset, robot, label in st.jobs():
            pairs.setdefault((robot, label), None)
        models, used = {}, 0
        for robot, label in pairs:
            entry = st.solvers[label]
            spec = get(entry.method)
            if spec.peer:
                continue
            model = models.get(robot) or models.setdefault(robot, load_robot(Path(data) / "robots" / f"{robot}.yaml"))
            try:
                prep = prepare(entry.method, model, entry.settings)
            except NotApplicableError:
                continue
            warm_up(entry.method, prep, entry.settings)
            if not helpers:
                helpers = _warm_helpers(prep, entry.settings)
            if spec.batch is not None:
                T, q0 = _goal_of(prep)
                goals = np.repeat(T[None], BATCH_GOALS, axis=0)
                solve_batch(entry.method, prep, goals, np.repeat(q0[None], BATCH_GOALS, axis=0), entry.settings,
                            seeds=np.arange(BATCH_GOALS, dtype=np.int64), threads=1)
            used += 1
        done += used
        print(f"[{k}/{len(studies)}] {st.id}: {used} (robot, solver) pair(s), {time.perf_counter() - t0:.1f} s",
              file=progress, flush=True)
    return (f"compiled or loaded the kernels of {done} (robot, solver) pair(s) of {len(studies)} study(ies) in "
            f"{time.perf_counter() - t_all:.1f} s (cache: {os.environ.get('NUMBA_CACHE_DIR', 'numba default')})")
