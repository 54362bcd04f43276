"""Borges et al., 002_56eb235931bf5f5d.txt: JI vs LM vs PSO on the KUKA KR 6 R700 sixx.

The study is settings plus tables and figures: its three methods are the registered solvers
``inverse_jacobian_fd``, ``levenberg_marquardt`` and ``pso`` (:mod:`pipeline.solvers`), its problem
sets (alpha sweep, single points, paths) are drawn by the generators of :mod:`.problems` and solved by
the generic solve rule (data/studies/borges_kr6.yaml). :mod:`.report` builds Tables 2-3, the path
table, the PSO readings, the shape checks and Figures 5-10 from the archives.
Heavy imports stay inside the functions so that ``python -m pipeline`` starts fast.
"""

from __future__ import annotations


def build_tables(study, archives, published_dir):
    from pipeline.studies.borges_kr6.report import build_tables as _bt

    return _bt(study, archives, published_dir)


def build_figures(study, archives, out_dir):
    from pipeline.studies.borges_kr6.report import build_figures as _bf

    return _bf(study, archives, out_dir)
