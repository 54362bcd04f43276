"""The application layer: what a verb does, between the library (robots, problems, solvers,
archives, studies' tables and figures) and the command line (``pipeline/cli.py`` only parses
arguments and calls one function here).

``solve``      make_problems and the solve job: a problem set through one registered solver into one archive
``build``      tables, figures and new study files from archives and settings
``reproduce``  re-run an archive's solves and compare them with it (findings, never read errors)
``race``       time one arm's finalists against each other in one process, interleaved (the answer's speed)
``replay``     re-run archived problems into a Foxglove-viewable MCAP
``verify``     recompute every table from its archives and check the results tree

Layers (``tests/test_layers.py`` walks the import graph and fails on an upward import or a cycle):
provenance, yamlio, errors, kinematics -> robots, urdf, problems -> io -> solvers, settings, runner
-> studies, report -> jobs -> cli.
"""
