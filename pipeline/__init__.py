"""Reproducible re-runs of published inverse-kinematics comparisons.

Layers (imports only go downward):

``pipeline.kinematics``  pure numpy maths, no I/O
``pipeline.solvers``     one result type and one call shape for every IK method
``pipeline.robots``      robot-file loading and validation
``pipeline.problems``    seeded problem sets
``pipeline.io``          archives (the only place that imports mcap) and tabular files
``pipeline.studies``     per-study aggregation into the documents' tables
``pipeline.report``      figures and the HTML report (the only place that imports matplotlib/jinja2)
``pipeline.cli``         ``python -m pipeline <verb>``; parses, loads, calls, writes
"""

__version__ = "0.1.0"

from pipeline._numba_cache import use_source_keyed_cache as _use_source_keyed_cache

_use_source_keyed_cache()
