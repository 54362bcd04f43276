"""Iterative IK methods: each module registers its methods with :mod:`pipeline.solvers.core.registry`.
Imports ``core`` and ``kernels`` only, never ``closed_form`` or ``peers``."""
