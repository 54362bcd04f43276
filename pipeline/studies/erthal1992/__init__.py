"""Erthal (1992), 001_7601717b50b5e768.txt: robot catalogue with DH <-> zero-position conversion,
Zero-Position IK with its 10 weight strategies, Newton-Raphson with Whitney step control, the
analytic PUMA solution, the iterative geometric method for planar arms, path tasks (RES layout)
and Tests 1-6 of Chapter 6.

The IK methods are registered solvers (``python -m pipeline solvers``): ``zero_position``,
``newton_raphson``, ``geometric_iterative`` and ``analytic_puma`` (:mod:`pipeline.solvers`); the
zero-position description is :mod:`pipeline.kinematics.zero_position`. This package holds only
settings translation, problem orchestration, tables and figures.

Modules: :mod:`.problems` (generators of the study's problem sets: the tests' goals and the path
tasks, solved by the generic solve rule), :mod:`.model` (Appendix 1 conversions, report layout),
:mod:`.tasks` (task files, interpolation, RES files), :mod:`.runs` (catalogue archive, RES rows
written from a path's solve archive), :mod:`.report` (tables, figures), :mod:`.drawing`
(wireframes, workspaces), :mod:`.cli` (``python -m pipeline`` verbs).
"""

from __future__ import annotations


def build_tables(study, archives, published_dir):
    from pipeline.studies.erthal1992.report import build_tables as _bt

    return _bt(study, archives, published_dir)


def build_figures(study, archives, out_dir):
    from pipeline.studies.erthal1992.report import build_figures as _bf

    return _bf(study, archives, out_dir)
