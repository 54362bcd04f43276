"""Borges et al., 002_56eb235931bf5f5d.txt: JI vs LM vs PSO on the KUKA KR 6 R700 sixx.

Modules: :mod:`.kernels` (compiled methods), :mod:`.methods` (IKResult-returning calls),
:mod:`.problems` (alpha sweep, points, paths), :mod:`.run` (problem set -> MCAP archive),
:mod:`.report` (Tables 2-3, path table, Figures 5-10), :mod:`.cli` (verb ``solve_borges_kr6``).
Heavy imports stay inside the functions so that ``python -m pipeline`` starts fast.
"""

from __future__ import annotations


def build_tables(study, archives, published_dir):
    from pipeline.studies.borges_kr6.report import build_tables as _bt

    return _bt(study, archives, published_dir)


def build_figures(study, archives, out_dir):
    from pipeline.studies.borges_kr6.report import build_figures as _bf

    return _bf(study, archives, out_dir)
