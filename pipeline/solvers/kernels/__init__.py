"""Compiled building blocks every method folder may use: forward kinematics and the Jacobian, the
integer codes the kernels take (stop, success test, trace columns), the clock (``kin``); pose errors
(``pose``); the one loop of the iterative methods and their shared trace rows (``loop``);
per-family kernel copies (``specialise``). Imports nothing else from ``pipeline.solvers``."""
