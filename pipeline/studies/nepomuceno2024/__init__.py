"""Nepomuceno (2024), 004_957b32c2b06ea31d.txt: IK at every interpolated point of two UR5 motions.

Modules
-------
trajectory  the designed motions (data/nepomuceno2024/motions.yaml) and their interpolation
problems    the problem-set generator: one motion = one chain of path points (warm starts), solved
            by the generic solve rule with the registered solvers jpinv_descent, bfgs, lbfgsb,
            nelder_mead, analytic_ur (pipeline/solvers/iterative/optimizers.py, analytic_ur.py)
tables      Tabelas 5.1-5.2, continuity, extra runs, published orderings
figures     Figuras 5.1-5.2, TCP path in 3-D, joint jumps
cli         study verb plan_motion_nepomuceno2024 (inspection)
"""

from __future__ import annotations


def build_tables(study, archives, published_dir):
    from pipeline.studies.nepomuceno2024.tables import build_tables as _bt

    return _bt(study, archives, published_dir)


def build_figures(study, archives, out_dir):
    from pipeline.studies.nepomuceno2024.figures import build_figures as _bf

    return _bf(study, archives, out_dir)
