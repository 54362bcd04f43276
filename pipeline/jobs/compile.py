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
