"""Nepomuceno (2024), 004_957b32c2b06ea31d.txt: IK at every interpolated point of two UR5 motions.

Modules
-------
_jit        compiled kernels: UR FK, geometric Jacobian, the document's costs, J⁺ descent loop,
            the 8-solution closed-form UR IK
methods     one call per trajectory point for each method (J⁺ descent, SciPy BFGS / L-BFGS-B /
            Nelder-Mead, closed form), every result FK-checked
trajectory  the designed motions (data/nepomuceno2024/motions.yaml) and their interpolation
runner      one (motion, method) job -> one MCAP archive
tables      Tabelas 5.1-5.2, continuity, extra runs, published orderings
figures     Figuras 5.1-5.2, TCP path in 3-D, joint jumps
cli         study verbs solve_motion_nepomuceno2024, plan_motion_nepomuceno2024
"""

from __future__ import annotations


def build_tables(study, archives, published_dir):
    from pipeline.studies.nepomuceno2024.tables import build_tables as _bt

    return _bt(study, archives, published_dir)


def build_figures(study, archives, out_dir):
    from pipeline.studies.nepomuceno2024.figures import build_figures as _bf

    return _bf(study, archives, out_dir)
