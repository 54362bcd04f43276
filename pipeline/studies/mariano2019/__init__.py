"""Mariano & Lima (2019), 003_8b306f4736fa5051.txt: HTM vs unit dual quaternions.

Operation counts by instrumentation (:mod:`.counting`, :mod:`.algebra`, :mod:`.closed_form`),
host timing (:mod:`.timing`, over the compiled chain kernels of :mod:`pipeline.solvers.kernels.kin`),
generated C on a simulated ATmega328P (:mod:`.codegen`, :mod:`.avr`); Tables I-VI and Gráficos 1-4 from the archives (:mod:`.report`). The IK round trip is
the problem set ``ik_roundtrip`` solved by the registered ``analytic_4dof`` (generic solve rule).
"""

from __future__ import annotations


def build_tables(study, archives, published_dir):
    from pipeline.studies.mariano2019.report import build_tables as _bt

    return _bt(study, archives, published_dir)


def build_figures(study, archives, out_dir):
    from pipeline.studies.mariano2019.report import build_figures as _bf

    return _bf(study, archives, out_dir)
