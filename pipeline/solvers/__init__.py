"""IK solvers: one registry, one settings base, one result type, one ``solve`` call for every method.

    from pipeline.solvers import solve, names
    res = solve("dls", robot, T_goal, q_start, {"damping": 0.05})

Layout (bottom to top; ``tests/test_layers.py`` checks the order and that no method folder imports another)
------
``kernels/``      compiled building blocks: FK and Jacobian, the integer codes every kernel takes
                  (``kin``), pose errors (``pose``), the one iteration loop every iterative method
                  supplies a step to (``loop.iterate``), per-family kernel copies (``specialise``)
``core/``         settings, the prepared robot, the result types, the one result rule (``finish``), the
                  driver (``Bound``: one problem or N, restarts, result, timing), the registry
                  (``solve``, ``solve_batch``, ``bind``, ``prepare``), the one timing definition, and the
                  arm as the all-solution methods take it (``models``)
``iterative/``    Jacobian transpose, pseudoinverse, DLS, SDLS (000, ``jacobian`` with its fused loop
                  ``lean``); inverse Jacobian, Levenberg-Marquardt, PSO (002: ``fd_jacobian``, ``lm``,
                  ``pso``); J+ descent, BFGS, L-BFGS-B, Nelder-Mead (004: ``optimizers``); Zero-Position,
                  Newton-Raphson, geometric (001)
``closed_form/``  ``subproblems`` (the building blocks: SP1-SP4, position and wrist stages); one file per
                  family holding its scalar stages and its 8-goal lane pass side by side (``family_sph``,
                  ``family_3p``, ``family_search``; ``lanes``: the lanes' shared scratch layout); the
                  closed forms found from the joint axes (``analytic``: settings, registration, binding;
                  ``analytic_kernels``: the compiled per-goal and batch kernels); the documents'
                  transcriptions (``analytic_ur`` 004, ``analytic_puma`` 001, ``analytic_4dof`` 003);
                  every solution of any other 6R arm (``general6r``, ``general6r_model``, ``eigen``)
``peers/``        peer libraries as registered solvers (``libraries``: Robotics Toolbox, TRAC-IK,
                  Pinocchio, ur_analytic_ik; ``geo``: EAIK, IK-Geo; ``python_ik``: pybullet, ikpy; ``qp_ik``:
                  pink, mink, placo)

Importing this package registers every method, in the order ``python -m pipeline solvers`` lists
them (kernels compile lazily, on first use).
"""

from pipeline.solvers.core import (
    STOP_REASONS,
    BatchResult,
    IKResult,
    NotApplicableError,
    Prepared,
    Raw,
    Settings,
    SettingsError,
    StopReason,
    finish,
    verify,
    within_limits,
)
from pipeline.solvers.core.registry import (Bound, Solver, bind, catalogue, get, make_settings, names, prepare, register, solve,
                                       solve_batch, warm_up)
# registration order = the order of `python -m pipeline solvers`
from pipeline.solvers.iterative import jacobian  # noqa: F401,E402
from pipeline.solvers.iterative import fd_jacobian, lm, pso, optimizers  # noqa: F401,E402
from pipeline.solvers.closed_form import analytic_ur  # noqa: F401,E402
from pipeline.solvers.iterative import zero_position, newton_raphson, geometric  # noqa: F401,E402
from pipeline.solvers.closed_form import analytic_puma, analytic_4dof, analytic  # noqa: F401,E402
from pipeline.solvers.peers import libraries, geo, python_ik, qp_ik  # noqa: F401,E402
from pipeline.solvers.closed_form import general6r  # noqa: F401,E402

__all__ = ["STOP_REASONS", "BatchResult", "Bound", "IKResult", "NotApplicableError", "Prepared", "Raw", "Settings", "SettingsError",
           "Solver", "StopReason", "bind", "catalogue", "finish", "get", "make_settings", "names", "prepare", "register",
           "solve", "solve_batch", "verify", "warm_up", "within_limits"]
