"""IK solvers: one registry, one settings base, one result type, one ``solve`` call for every method.

    from pipeline.solvers import solve, names
    res = solve("dls", robot, T_goal, q_start, {"damping": 0.05})

Layout
------
``base``      StopReason, Settings (+ ``setting`` fields), Prepared robot, Raw kernel output,
              IKResult, the one result rule (``finish``: independent FK check, limits, stop reason)
``registry``  name -> Solver (settings type, applicability, kernel call); ``solve``, ``solve_batch``,
              ``bind``, ``prepare``
``driver``    the one way to run a solve (``Bound``: a solver bound to a robot and settings, per-job
              work done once; one problem or N, restarts, result, timing)
``timing``    the one timing definition (solve_time_s, ik_time_s, call_time_s)
``_kin``      the compiled kinematics layer (numba) every iterative method uses, and the one table
              of integer codes the kernels take (stop codes, success-test codes, trace columns)
``jacobian``  Jacobian transpose, pseudoinverse, DLS, SDLS (000)
``fd_jacobian``, ``lm``, ``pso``            inverse Jacobian (finite differences), Levenberg-Marquardt, PSO (002)
``optimizers`` J+ gradient descent, BFGS, L-BFGS-B, Nelder-Mead (004); ``analytic_ur`` UR closed form (004)
``zero_position``, ``newton_raphson``, ``geometric``, ``analytic_puma``   (001)
``analytic_4dof``  the closed form of the 4-DOF arm (003)
``analytic``  closed forms by subproblem decomposition found from the joint axes; ``general_6r`` every
              solution of any other 6R arm by algebraic elimination (Raghavan-Roth, Manocha-Canny)

Importing this package registers every method (kernels compile lazily, on first use).
"""

from pipeline.solvers.base import (
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
from pipeline.solvers.registry import (Bound, Solver, bind, catalogue, get, make_settings, names, prepare, register, solve,
                                       solve_batch, warm_up)
from pipeline.solvers import jacobian  # noqa: F401  (registers the four Jacobian methods)
from pipeline.solvers import _methods  # noqa: F401  (registers the methods of the other studies)
from pipeline.solvers import peers_geo  # noqa: F401  (registers the EAIK and IK-Geo peers)
from pipeline.solvers import general6r  # noqa: F401  (registers general_6r)

__all__ = ["STOP_REASONS", "BatchResult", "Bound", "IKResult", "NotApplicableError", "Prepared", "Raw", "Settings", "SettingsError",
           "Solver", "StopReason", "bind", "catalogue", "finish", "get", "make_settings", "names", "prepare", "register",
           "solve", "solve_batch", "verify", "warm_up", "within_limits"]
