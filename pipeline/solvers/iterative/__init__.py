"""Iterative IK methods: each module registers its methods with :mod:`pipeline.solvers.core.registry`.
Every compiled search runs in the one loop :func:`pipeline.solvers.kernels.loop.iterate` (clock, start,
first FK and trace row, stop rule, cap, non-finite test), to which each method supplies its ``start``,
``step`` and ``record`` (Jacobian family: ``lean``; ``fd_jacobian``, ``lm``, ``pso``, the J+ descent of
``optimizers``, ``zero_position``, ``newton_raphson``, ``geometric``); the SciPy optimisers of ``optimizers``
run in SciPy's loops.
Imports ``core`` and ``kernels`` only, never ``closed_form`` or ``peers``."""
