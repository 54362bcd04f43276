"""Imports every method module so that importing :mod:`pipeline.solvers` registers them all.

Each helper/maintainer adds one import line per module (keep the order: it is the order of
``python -m pipeline solvers``).
"""

import importlib

for _mod in ("fd_jacobian", "lm", "pso", "optimizers", "analytic_ur", "zero_position", "newton_raphson",
             "geometric", "analytic_puma", "analytic_4dof", "analytic", "peers"):
    try:
        importlib.import_module(f"pipeline.solvers.{_mod}")
    except ModuleNotFoundError as exc:  # a module not written yet
        if exc.name != f"pipeline.solvers.{_mod}":
            raise
