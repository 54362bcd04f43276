"""IK solvers: one settings type, one result type, one ``solve`` call for every method."""

from pipeline.solvers.base import (
    STOP_REASONS,
    IKResult,
    PreparedRobot,
    SettingsError,
    SolverSettings,
    solve,
    verify,
)

__all__ = ["STOP_REASONS", "IKResult", "PreparedRobot", "SettingsError", "SolverSettings", "solve", "verify"]
