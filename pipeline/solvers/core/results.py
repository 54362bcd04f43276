"""What a kernel returns (``Raw``, ``BatchRaw``) and what a caller gets (``IKResult``, ``BatchResult``)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from pipeline.io.layout import TRACE_COLS
from pipeline.solvers.kernels.kin import TRACE_DP


# ---- raw kernel output and the one result type ------------------------------------------------
@dataclass(slots=True)
class Raw:
    """What a method's kernel call returns (before the FK check).

    Attributes
    ----------
    q : ndarray, shape (n,)                 final joint values [rad | working unit]
    code : int                              the method's own stop code (a :class:`StopReason` value)
    iterations : int
    solve_ns : int                          the method's computation on the monotonic clock [ns]
    trace : ndarray, shape (k, 8), optional per iterate: scalar error, e (6), |dp|
    ik_ns : int                             time of the IK block (step) alone [ns], 0 if not measured
    solutions : ndarray, shape (m, n), optional
        Analytic methods: every solution found (``q`` is the one chosen).
    info : dict                             method-specific counters (JSON scalars), archived as is
    """

    q: np.ndarray
    code: int
    iterations: int
    solve_ns: int
    trace: np.ndarray | None = None
    ik_ns: int = 0
    solutions: np.ndarray | None = None
    info: dict = field(default_factory=dict)


@dataclass(slots=True)
class IKResult:
    """Outcome of one IK solve.

    Attributes
    ----------
    q : ndarray, shape (n,) [rad | length_unit]  final joint values (the chosen solution)
    success : bool                              FK-verified success
    stop_reason : int                           a :class:`StopReason` value
    iterations : int
    trace : ndarray, shape (iterations + 1, 8)  per iterate: scalar error, e (6), |dp| [length_unit]
    solve_time_s : float [s]                    the method's own computation (see module docstring)
    ik_time_s : float [s]                       the IK-block (step) time alone where measured, else 0
    position_error : float [length_unit]        |p_goal - p| by independent FK
    orientation_error : float [rad]             rotation angle goal vs reached (NaN for position-only goals)
    claimed_success : bool                      the method's own stop test said success
    within_limits : bool                        ``q`` lies within the joint limits (revolute joints wrapped by 2 pi first)
    call_time_s : float [s]                     the whole ``solve()`` call
    length_unit : str
    solutions : ndarray, shape (m, n) or None   analytic methods: all solutions
    info : dict                                 method-specific counters
    compiled : bool                             this call compiled kernels or loaded them from numba's
                                                cache (the first call of a method in a process): it was
                                                run again once they were ready, and its times are those
                                                of that run
    compile_time_s : float [s]                  the time that compiling or loading took (0 otherwise)
    """

    q: np.ndarray
    success: bool
    stop_reason: int
    iterations: int
    trace: np.ndarray
    solve_time_s: float
    ik_time_s: float
    position_error: float
    orientation_error: float
    claimed_success: bool = False
    within_limits: bool = True
    call_time_s: float = float("nan")
    length_unit: str = "m"
    solutions: np.ndarray | None = None
    info: dict = field(default_factory=dict)
    compiled: bool = False
    compile_time_s: float = 0.0


@dataclass
class BatchRaw:
    """What a method's batch kernel returns for N problems (before the FK check).

    Attributes
    ----------
    q : ndarray, shape (N, n)               final joint values [rad | working unit]
    code, iterations : ndarray, shape (N,)  the method's stop codes and iteration counts
    solve_ns, ik_ns : ndarray, shape (N,)   per-problem times [ns] (as in :class:`Raw`)
    cpu_ns : ndarray, shape (N,), optional  per-problem CPU time of the solving thread [ns], where the
                                            kernel reads it (``_kin.thread_cpu_ns``) around the same work
    trace_rows : ndarray, shape (M, 8), optional       every problem's trace rows, concatenated
    trace_offsets : ndarray, shape (N + 1,), optional  problem i's rows are ``offsets[i]:offsets[i+1]``
    solutions : ndarray, shape (N, m, n), optional     analytic methods: every solution ...
    n_solutions : ndarray, shape (N,), optional        ... of which the first n_solutions[i] hold
    info : list of dict, optional           per-problem counters
    """

    q: np.ndarray
    code: np.ndarray
    iterations: np.ndarray
    solve_ns: np.ndarray
    ik_ns: np.ndarray
    cpu_ns: np.ndarray | None = None
    trace_rows: np.ndarray | None = None
    trace_offsets: np.ndarray | None = None
    solutions: np.ndarray | None = None
    n_solutions: np.ndarray | None = None
    info: list | None = None


class InfoRows(Sequence):
    """Per-problem ``info`` dicts of a batch, built on access from the batch's arrays.

    A list of 100 000 dicts costs more than the batch solve; this sequence holds the arrays and
    ``rows[i]`` builds problem i's dict (the same keys and values as the single call's ``Raw.info``).
    """

    __slots__ = ("_n", "_make")

    def __init__(self, n: int, make):
        self._n, self._make = n, make

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self._make(k) for k in range(*i.indices(self._n))]
        k = int(i)
        if k < 0:
            k += self._n
        if not 0 <= k < self._n:
            raise IndexError(i)
        return self._make(k)


@dataclass
class BatchResult:
    """Outcome of N solves as arrays (:func:`pipeline.solvers.solve_batch`); fields as in :class:`IKResult`.

    Attributes
    ----------
    q : ndarray, shape (N, n) [rad | robot file's length unit]
    success, claimed_success, within_limits : ndarray of bool, shape (N,)
    stop_reason, iterations : ndarray of int, shape (N,)
    solve_time_s, ik_time_s : ndarray, shape (N,) [s]   per problem, measured inside the kernel
    position_error : ndarray, shape (N,) [length_unit]  by the independent FK check
    orientation_error : ndarray, shape (N,) [rad]       NaN for position-only criteria
    call_time_s : float [s]                             the whole batch call
    length_unit : str
    trace_rows, trace_offsets : see :class:`BatchRaw` (None when traces were not kept)
    solutions, n_solutions, info : see :class:`BatchRaw`
    call_times_s : ndarray, shape (N,), optional [s]  per-problem call times when the problems were
                                                      solved one call at a time (else None)
    cpu_times_s : ndarray, shape (N,), optional [s]   per-problem CPU time: of the solving thread where the
                                                      kernel reads it (BatchRaw.cpu_ns), else of the
                                                      process (all threads) when the caller measured it
                                                      (the runner does)
    compiled : bool, compile_time_s : float [s]       the call compiled or loaded kernels (then it was run
                                                      again once they were ready, and its times are that
                                                      run's) and the time that took
    """

    q: np.ndarray
    success: np.ndarray
    stop_reason: np.ndarray
    iterations: np.ndarray
    solve_time_s: np.ndarray
    ik_time_s: np.ndarray
    position_error: np.ndarray
    orientation_error: np.ndarray
    claimed_success: np.ndarray
    within_limits: np.ndarray
    call_time_s: float
    length_unit: str
    trace_rows: np.ndarray | None = None
    trace_offsets: np.ndarray | None = None
    solutions: np.ndarray | None = None
    n_solutions: np.ndarray | None = None
    info: list | None = None
    call_times_s: np.ndarray | None = None
    cpu_times_s: np.ndarray | None = None
    compiled: bool = False
    compile_time_s: float = 0.0

    def __len__(self) -> int:
        return int(self.q.shape[0])

    def trace(self, i: int) -> np.ndarray:
        """Problem ``i``'s trace (iterations + 1, 8); one row of NaN but |dp| when none was kept."""
        if self.trace_rows is None:
            t = np.full((1, TRACE_COLS), np.nan)
            t[0, TRACE_DP] = self.position_error[i]
            return t
        return self.trace_rows[self.trace_offsets[i]:self.trace_offsets[i + 1]]

    def result(self, i: int) -> IKResult:
        """Problem ``i`` as an :class:`IKResult` (``call_time_s``: its own call, or the batch's time / N)."""
        sols = None
        if self.solutions is not None:
            sols = self.solutions[i, : int(self.n_solutions[i])]
        return IKResult(q=self.q[i], success=bool(self.success[i]), stop_reason=int(self.stop_reason[i]),
                        iterations=int(self.iterations[i]), trace=self.trace(i),
                        solve_time_s=float(self.solve_time_s[i]), ik_time_s=float(self.ik_time_s[i]),
                        position_error=float(self.position_error[i]),
                        orientation_error=float(self.orientation_error[i]),
                        claimed_success=bool(self.claimed_success[i]), within_limits=bool(self.within_limits[i]),
                        call_time_s=(float(self.call_times_s[i]) if self.call_times_s is not None
                                     else self.call_time_s / max(1, len(self))), length_unit=self.length_unit,
                        solutions=sols, info=dict(self.info[i]) if self.info is not None else {})


