"""What a solve record means, written once for the solvers and the archive format alike.

This module sits in the file-format layer (:mod:`pipeline.io`), below the solvers: the solvers
produce what it defines and the archives store it, and a reader needs nothing above it.

- :class:`StopReason`: why a solve stopped, one integer code for every method (archived; never
  renumber). ``STOP_REASONS`` maps each code to its one-line text.
- :data:`TRACE_COLUMNS`: the columns of a per-iteration trace row, in order. Every method's trace
  is an array of shape (iterations + 1, :data:`TRACE_COLS`); row 0 is the start.
"""

from __future__ import annotations

from enum import IntEnum


class StopReason(IntEnum):
    """Why a solve stopped; one enum for every method (values are archived, never renumber)."""

    SUCCESS = 1
    STALLED = 2          # the method's own stop test fired (step, pose change or optimiser tolerance) above tolerance
    DIVERGING = 3        # the error grew on consecutive iterations
    ITERATION_CAP = 4
    NON_FINITE = 5
    FK_CHECK_FAILED = 6  # the method claimed success; an independent FK contradicts it
    NO_SOLUTION = 7      # analytic: no real solution (goal out of reach) or none passes the FK check
    OUT_OF_LIMITS = 8    # the pose was reached, outside the joint limits (only with require_limits)

    @property
    def text(self) -> str:
        """The code's one-line text (:data:`STOP_REASONS`)."""
        return _STOP_TEXT[self]


_STOP_TEXT = {
    StopReason.SUCCESS: "success",
    StopReason.STALLED: "stalled (the method's own stop test fired above the tolerance)",
    StopReason.DIVERGING: "error grew on consecutive iterations",
    StopReason.ITERATION_CAP: "iteration cap",
    StopReason.NON_FINITE: "non-finite value (numerical failure)",
    StopReason.FK_CHECK_FAILED: "claimed success contradicted by forward kinematics",
    StopReason.NO_SOLUTION: "no solution (analytic: goal out of reach)",
    StopReason.OUT_OF_LIMITS: "pose reached outside the joint limits (require_limits)",
}
STOP_REASONS = {int(r): r.text for r in StopReason}

# per iterate: the method's own scalar error (its stop-test measure), the error 6-vector e = (v, omega)
# (v in length_unit, omega in rad), and the position error |dp| [length_unit]
TRACE_COLUMNS = ("error", "v_x", "v_y", "v_z", "omega_x", "omega_y", "omega_z", "position_error")
TRACE_COLS = len(TRACE_COLUMNS)

SAMPLES_FILE = "solves.csv.gz"
"""The per-sample file of a study (every solve, one CSV row; ``pipeline.studies.generic.SAMPLE_COLUMNS``),
written by ``aggregate_tables`` into the study's tables folder and linked from the report."""
