"""What every IK method shares: settings, the prepared robot, the result types, the one result rule
(``finish``), the driver, the registry and the one timing definition.

Modules, bottom to top: ``settings`` -> ``prepared`` -> ``results`` -> ``rule`` (``finish``) -> ``driver`` ->
``registry``; ``timing`` and ``models`` (the arm as the all-solution methods and the peers take it)
stand beside them. This package imports nothing from the method folders (``iterative``,
``closed_form``, ``peers``); ``tests/test_layers.py`` checks it.
"""

from pipeline.io.layout import STOP_REASONS, TRACE_COLS, StopReason
from pipeline.solvers.kernels.kin import CRITERIA, CRITERION_CODE, LIMIT_TOL
from pipeline.solvers.core.settings import (MAX_LIBRARY_TIMEOUT_S, MAX_SETTING_FLOAT, MAX_TIME_BUDGET_S, MAX_WORK,
                                            POSITION_CRITERIA, NotApplicableError, Settings, SettingsError,
                                            check_data_path, search_limits_setting, setting)
from pipeline.solvers.core.prepared import Prepared, inv_rigid
from pipeline.solvers.core.results import BatchRaw, BatchResult, IKResult, InfoRows, Raw
from pipeline.solvers.core.rule import (check, check_fields, check_pack, finish, finish_args, finish_batch,
                                          finish_packed, finish_packed_limits, fused_inputs, meets, nearest_of, nearest_rep,
                                          pose_errors, unpack_check, verify, within_limits, wrap_into_limits)

__all__ = ["CRITERIA", "CRITERION_CODE", "LIMIT_TOL", "MAX_LIBRARY_TIMEOUT_S", "MAX_SETTING_FLOAT", "MAX_TIME_BUDGET_S",
           "MAX_WORK", "POSITION_CRITERIA", "STOP_REASONS", "TRACE_COLS", "BatchRaw", "BatchResult", "IKResult",
           "InfoRows", "NotApplicableError", "Prepared", "Raw", "Settings", "SettingsError", "StopReason", "check",
           "check_data_path", "check_fields", "check_pack", "finish", "finish_args", "finish_batch", "finish_packed",
           "finish_packed_limits", "fused_inputs", "inv_rigid", "meets", "nearest_of", "nearest_rep", "pose_errors", "search_limits_setting", "setting", "unpack_check",
           "verify", "within_limits", "wrap_into_limits"]
