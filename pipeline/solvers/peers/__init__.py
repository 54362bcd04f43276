"""Peer IK libraries registered as solvers (baselines, never a substitute for our own methods).
Imports ``core`` and ``kernels`` only; a peer library itself is imported on the first ``prepare``."""
