"""Closed-form IK: subproblems, per-family closed forms found from the joint axes, the documents'
transcriptions and the general 6R elimination. Imports ``core`` and ``kernels`` only, never
``iterative`` or ``peers``."""
