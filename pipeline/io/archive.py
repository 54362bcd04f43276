"""Result archives: one MCAP file per solve job, zstd-compressed chunks (format version 5).

An archive stands on its own: everything a table, a figure, ``inspect`` or the report shows is read
from its bytes, the problem-set file it names and nothing else. Reading never imports or runs a
solver (this module imports nothing above :mod:`pipeline.robots`), so an archive reads the same on
any machine, whatever its CPU or BLAS. Re-running the solves of an archive is a separate act,
``python -m pipeline reproduce`` (:mod:`pipeline.jobs.reproduce`), whose differences are findings,
never read errors.

Channels (all protobuf, schemas written into the file as FileDescriptorSets, so any MCAP reader
with ``protobuf`` decodes them without this package; docs/archives.md "Reading an archive without this package" shows how)
------------------------------------------------------------------------------------------------
``/ik/solve``      ``ik_pipeline.SolveBatch``, up to :data:`BATCH` solves a message, fields in
                   :data:`SOLVE_FIELDS`: per solve its problem id, repetition, chain, stop reason
                   (:class:`pipeline.io.layout.StopReason`), iterations, a ``flags`` word (success,
                   claimed success, within limits, start taken from the problem file, which numbers
                   are absent), the three times as integer nanoseconds, the four errors (float64),
                   ``q_solution``, and for analytic methods the number of solutions; ``info_json``
                   (method-specific counters) is one strict-JSON array per batch.
``/ik/trace``      ``ik_pipeline.TraceBatch``: per solve with a trace its row count, the CRC-32 of
                   its full-precision float64 rows (what ``reproduce`` compares a re-run with) and
                   whether the rows are stored; stored rows hold the stop-test error and |dp|
                   (float64) and the error 6-vector (v, omega) (float32), columns as
                   :data:`pipeline.io.layout.TRACE_COLUMNS`.
``/ik/solutions``  ``ik_pipeline.SolutionBatch``: every solution an analytic method returned, per
                   solve its count and the rows (float64), all of them stored.

Trace policy (:class:`TracePolicy`; a study's ``trace_policy`` setting): every trace's row count
and digest are stored; its rows are stored for every solve of a deterministic sample of the set
(``sample`` problems, evenly spaced over the set's problem ids, repetition 0) and for failed
solves, in solve order, while their rows fit a per-archive budget (``failed_rows``). ``all``
stores every trace, ``none`` none. The ``run`` metadata names the policy (``trace_policy``); a
second metadata record, ``traces``, written when the archive is closed, counts what was stored.
Asking for a trace an archive does not hold is a one-line :class:`TraceNotStored` error naming
``reproduce``, never a silent re-run.

What is not repeated. Goals and starts are the problem file's (``problem_path``, relative to the
archive, checked against ``problem_sha256`` on every read); only a start that is not the problem
file's (a chained problem warm-started from the previous solution) is stored. An archive written
without a problem file (``problem_path`` absent) stores goals and starts inline.

No NaN or Infinity anywhere: an absent number (an orientation error not checked, a non-finite
result) is flagged in ``flags`` (a trace row's or a solution row's ``absent`` mask) and written as
0; readers give NaN back. Metadata record ``run`` (:func:`run_metadata`): study, robot, robot file
and its SHA-256, solver, method, settings (JSON), settings hash, seed, scale, package version, git
commit, problem file, its path and SHA-256, problem count, trace policy, environment (CPU, BLAS
and its core type, library versions).

Log times: a batch's log time is the cumulative ``solve_time_s`` of the job up to its last solve
[ns], so a timeline shows where the solving time went. Nothing else in the file depends on the
clock: the same settings and seed give the same file except for the timing fields.
An archive is written to ``<name>.partial`` and renamed only after the MCAP summary is written:
an interrupted job never leaves a file that looks complete. Chunks use the mcap writer's zstd level
3 (1.7 % smaller than level 1 on these batches for 2.4 ms more per 10 000 solves).

Only format 5 is read; an archive of an earlier format is refused in one line naming its format
and the package version that wrote it (rebuild it with the workflow).

Reading is bounded and checked before memory is spent (:data:`MAX_ARCHIVE_BYTES`,
:data:`MAX_CHUNK_BYTES`, :data:`MAX_UNCOMPRESSED_BYTES`, :data:`MAX_SOLVES`, each set from the
largest archive of a full build with a margin): the file's size is checked before it is read, each
chunk's declared uncompressed size before it is decompressed, and a chunk is decompressed by a
streaming zstd reader that stops one byte past its declared size (the ``mcap`` reader's own chunk
decompression, which sizes its buffer from the chunk's or the zstd frame's declared size, is not
used; ``mcap`` parses the summary and the metadata only). The reader also checks the structure
across the three channels (:class:`~pipeline.io.archive_checks.ChannelStructure`): a solve is one
(labels, problem id, repetition) of the file, traces and solutions belong to the solves of their batch,
once each, and solution counts are the solves' ``n_solutions``. A file past a cap or with a broken
structure is one :class:`ArchiveError` line naming it and the cap or field.

Quaternions are w-first everywhere in the library; in records, and only there, the goal
orientation is x, y, z, w (Foxglove ``Pose`` style).

Where the code is: this module reads (:func:`read_archive`, :class:`Archive`) and re-exports the names
of the others, so ``from pipeline.io.archive import ...`` reaches all of them:
:mod:`pipeline.io.archive_format` (channels, schemas, flags, :class:`TracePolicy`, errors),
:mod:`pipeline.io.archive_writer` (:class:`ArchiveWriter`, :func:`run_metadata`, :func:`batch_columns`),
:mod:`pipeline.io.archive_bounds` (the caps, bounded chunk reading, file CRCs) and
:mod:`pipeline.io.archive_checks` (named files, metadata types, the cross-channel structure).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

import numpy as np

from pipeline.io.archive_bounds import (MAGIC, MAX_ARCHIVE_BYTES, MAX_CHUNK_BYTES, MAX_SOLVES,  # noqa: F401
                                        MAX_UNCOMPRESSED_BYTES, archive_metadata, check_file_crcs,
                                        chunk_messages, iter_messages, read_bytes, summary_reader)
from pipeline.io.archive_checks import (NAMED_FILES, ChannelStructure, check_metadata, named_file,  # noqa: F401
                                        problem_set_of)
from pipeline.io.archive_format import (ABSENT_FLAGS, BATCH, F_CLAIMED, F_NO_GOAL, F_NO_Q,  # noqa: F401
                                        F_NO_START, F_START_FROM_FILE, F_SUCCESS, F_WITHIN, FORMAT_VERSION, LABELS,
                                        MESSAGES, REQUIRED_META, SOLUTION_FIELDS, SOLUTIONS_TOPIC, SOLVE_FIELDS,
                                        SOLVE_TOPIC, TRACE_FIELDS, TRACE_TOPIC, ArchiveError, TraceNotStored,
                                        TracePolicy, decode_fields, descriptor, digest, encode_fields)
from pipeline.io.archive_format import F_NO_FINAL, F_NO_INITIAL, F_NO_ORIENTATION, F_NO_POSITION  # noqa: F401
from pipeline.io.archive_writer import AtomicMcap, ArchiveWriter, batch_columns, run_metadata  # noqa: F401
from pipeline.io.layout import TRACE_COLS


def goal_from_record(goal: dict) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of the goal encoding of a record.

    Parameters
    ----------
    goal : dict
        A solve record's ``goal``: ``position`` {x, y, z} and ``orientation`` {x, y, z, w}.

    Returns
    -------
    position : ndarray, shape (3,) [length]
        The goal position, in the archive's length unit.
    quat : ndarray, shape (4,) [1]
        The orientation as a unit quaternion, w-first.
    """
    p, o = goal["position"], goal["orientation"]
    return np.array([p["x"], p["y"], p["z"]]), np.array([o["w"], o["x"], o["y"], o["z"]])


def decode(topic: str, data: bytes) -> dict[str, np.ndarray]:
    """One protobuf message of ``topic`` as its fields.

    Parameters
    ----------
    topic : str
        One of the three solve channels (:data:`MESSAGES`).
    data : bytes
        The message.

    Returns
    -------
    dict[str, numpy.ndarray]
        Field name -> (k,) array of the field's dtype; string fields as ``bytes``.

    Raises
    ------
    ValueError
        On a message this package did not write.
    """
    return decode_fields(MESSAGES[topic][1], data)


@dataclass
class Archive:
    """An archive read back: metadata and one record per solve; traces and solutions read on demand.

    Attributes
    ----------
    path : Path
        The file read.
    metadata : dict[str, str]
        The ``run`` record.
    solves : list[dict]
        One record per solve (goal and start from the problem file).
    trace_summary : dict[str, str]
        The ``traces`` record: policy and counts of traces and stored traces.
    job_timing : dict[str, str]
        The ``job_timing`` record ({} in archives written without it): ``cpu_s`` and ``wall_s``, the
        process CPU time and the wall time of the job's solving (archiving excluded), and ``cpu_share``
        = cpu_s / wall_s (below 0.9: the job did not get a core to itself).
    """

    path: Path
    metadata: dict[str, str]
    solves: list[dict]
    trace_summary: dict = field(default_factory=dict)
    job_timing: dict = field(default_factory=dict)
    _trace_index: dict | None = None
    _solutions: dict | None = None
    _by_key: dict | None = None

    def frame(self):
        """Solve records as a pandas DataFrame (vectors kept as lists; private ``_`` keys left out).

        Returns
        -------
        pandas.DataFrame
            One row per solve.
        """
        import pandas as pd

        df = pd.DataFrame(self.solves)
        return df.drop(columns=[c for c in df.columns if str(c).startswith("_")])

    def messages(self, topic: str) -> Iterator[dict]:
        """Yield the decoded JSON records of a JSON channel (e.g. a study's measurement channel).

        Parameters
        ----------
        topic : str
            The channel's topic.

        Yields
        ------
        dict or list
            One decoded record per message, in file order.
        """
        for _, _, msg in iter_messages(self.path, [topic]):
            yield _loads(msg.data, self.path, topic, msg.sequence)

    def _batches(self, topic: str, decode) -> Iterator[dict]:
        """The messages of ``topic`` decoded by ``decode``; a damaged one is a one-line ArchiveError."""
        for _, _, msg in iter_messages(self.path, [topic]):
            try:
                yield decode(msg.data)
            except ValueError as exc:
                raise ArchiveError(f"{self.path}: message {msg.sequence} on {topic}: {exc}") from None

    def trace_index(self) -> dict:
        """Every trace the archive knows of, stored or not (built once, then cached).

        Returns
        -------
        dict
            ``(problem_id, repetition) -> (rows, digest, full)``: row count, CRC-32 (:func:`digest`) and the
            stored rows as a (rows, 8) float64 array of :data:`~pipeline.io.layout.TRACE_COLUMNS` (NaN
            where absent), or None when the rows are not stored.
        """
        if self._trace_index is not None:
            return self._trace_index
        idx = {}
        for bt in self._batches(TRACE_TOPIC, _trace_batch):
            lo = 0
            for k, pid in enumerate(bt["problem_id"].tolist()):
                rows = int(bt["rows"][k])
                full = None
                if bt["stored"][k]:
                    full = np.column_stack([bt["error"][lo:lo + rows], bt["error_vector"][lo:lo + rows].astype(float),
                                            bt["position_error"][lo:lo + rows]])
                    if len(bt["absent"]):
                        mask = (bt["absent"][lo:lo + rows, None] >> np.arange(TRACE_COLS)) & 1
                        full[mask.astype(bool)] = np.nan
                    lo += rows
                idx[(pid, int(bt["repetition"][k]))] = (rows, int(bt["digest"][k]), full)
        self._trace_index = idx
        return idx

    def stored_traces(self) -> set[tuple[int, int]]:
        """The ``(problem_id, repetition)`` keys whose trace rows this archive holds.

        Returns
        -------
        set of (int, int)
        """
        return {k for k, v in self.trace_index().items() if v[2] is not None}

    def records(self) -> dict:
        """The solve records by key.

        Returns
        -------
        dict
            ``(problem_id, repetition) -> solve record`` (the dicts of :attr:`solves`).
        """
        if self._by_key is None:
            self._by_key = {(r["problem_id"], r.get("repetition", 0)): r for r in self.solves}
        return self._by_key

    def traces(self, problem_ids=None) -> Iterator[dict]:
        """Yield stored trace records.

        Parameters
        ----------
        problem_ids : int or array_like of int, shape (k,), optional
            Without them: every stored trace. With them: the traces of those problems, and a
            :class:`TraceNotStored` error for one whose trace the archive does not hold (never a re-run).

        Yields
        ------
        dict
            ``problem_id``, ``repetition``, and as lists over the trace's rows ``error`` (rows,),
            ``error_vector`` (rows, 6; v then omega) and ``position_error`` (rows,) [length unit].

        Raises
        ------
        TraceNotStored
        """
        idx = self.trace_index()
        if problem_ids is None:
            keys = [k for k, v in idx.items() if v[2] is not None]
        else:
            wanted = {int(p) for p in np.atleast_1d(problem_ids)}
            keys = [k for k in idx if k[0] in wanted]
            for k in keys:
                if idx[k][2] is None:
                    raise self.not_stored(k[0], k[1])
        for k in keys:
            full = idx[k][2]
            yield {"problem_id": k[0], "repetition": k[1], "error": full[:, 0].tolist(),
                   "error_vector": full[:, 1:7].tolist(), "position_error": full[:, 7].tolist()}

    def not_stored(self, problem_id: int, repetition: int = 0) -> TraceNotStored:
        """The one-line answer for a trace this archive does not hold.

        Parameters
        ----------
        problem_id, repetition : int
            The solve whose trace was asked for.

        Returns
        -------
        TraceNotStored
            The error to raise: it names the trace policy and the ``reproduce`` command that re-runs the solve.
        """
        s = self.trace_summary
        held = f"it holds {s.get('stored', '?')} of {s.get('traces', '?')} traces: {s.get('policy', 'unknown policy')}"
        return TraceNotStored(f"{self.path}: problem {problem_id} (repetition {repetition}): trace not stored ({held}); "
                              f"`python -m pipeline reproduce {self.path} --problem {problem_id}` re-runs it")

    def solutions(self, problem_id: int, repetition: int = 0) -> list | None:
        """Every solution an analytic method returned for one solve.

        Parameters
        ----------
        problem_id : int
            The solve's problem.
        repetition : int, optional
            Its repetition (default 0).

        Returns
        -------
        list or None
            (m, n) nested list of joint values [rad or length unit], NaN where absent; None for methods
            that do not list solutions.

        Raises
        ------
        ArchiveError
            When the solve is not in the archive.
        """
        key = (int(problem_id), int(repetition))
        if key not in self.records():
            raise ArchiveError(f"{self.path}: problem {problem_id} (repetition {repetition}) is not in the archive")
        if self._solutions is None:
            out = {}
            for b in self._batches(SOLUTIONS_TOPIC, _solution_batch):
                lo = 0
                for p, r, c in zip(b["problem_id"].tolist(), b["repetition"].tolist(), b["count"].tolist()):
                    out[(p, r)] = b["rows"][lo:lo + c].tolist()
                    lo += c
            self._solutions = out
        return self._solutions.get(key)


def problems_of(arch: Archive, given: str | Path | None = None):
    """The problem set an archive names, checked (:func:`~pipeline.io.archive_checks.problem_set_of`).

    Parameters
    ----------
    arch : Archive
    given : str or Path, optional
        The problem file when it is not where the archive's metadata says.

    Returns
    -------
    tuple or None
        ``(problem id -> row, ProblemSet, goal length scale)``, or None for an archive that stores its goals.
    """
    return problem_set_of(arch.path, arch.metadata, given)


def _trace_batch(data: bytes) -> dict[str, np.ndarray]:
    """One ``TraceBatch`` decoded and checked; ``error_vector`` shaped (m, 6)."""
    out = decode_fields(TRACE_FIELDS, data)
    n = len(out["problem_id"])
    for k in ("repetition", "rows", "digest", "stored"):
        if len(out[k]) != n:
            raise ValueError(f"field '{k}' holds {len(out[k])} values for {n} traces")
    if np.any(out["stored"] > 1):
        raise ValueError("field 'stored' holds a value other than 0 and 1")
    m = int(out["rows"][out["stored"] == 1].sum())
    if len(out["error"]) != m or len(out["position_error"]) != m or len(out["error_vector"]) != 6 * m:
        raise ValueError(f"row fields do not hold the {m} rows the stored traces promise")
    if len(out["absent"]) not in (0, m):
        raise ValueError(f"field 'absent' holds {len(out['absent'])} values for {m} rows")
    out["error_vector"] = out["error_vector"].reshape(m, 6)
    return out


def _solution_batch(data: bytes, rows: bool = True) -> dict[str, np.ndarray]:
    """One ``SolutionBatch`` decoded and checked; ``rows`` (sum of counts, joints), NaN where absent
    (not built when ``rows`` is False: the counts checked only)."""
    b = decode_fields(SOLUTION_FIELDS, data)
    n = len(b["problem_id"])
    if len(b["repetition"]) != n or len(b["count"]) != n:
        raise ValueError("fields 'problem_id', 'repetition' and 'count' differ in length")
    if len(b["joints"]) != 1 or b["joints"][0] < 1:
        raise ValueError("field 'joints' is not one positive value")
    j, m = int(b["joints"][0]), int(b["count"].sum())
    if len(b["solutions"]) != m * j or len(b["absent"]) not in (0, m):
        raise ValueError(f"field 'solutions' holds {len(b['solutions'])} values, the counts promise {m * j}")
    if n > BATCH:
        raise ValueError(f"field 'problem_id' holds {n} solves, a message holds at most {BATCH}")
    if not rows:
        return b
    rows = b["solutions"].reshape(m, j).astype(float)
    if len(b["absent"]):
        rows[((b["absent"][:, None] >> np.arange(j, dtype=np.uint64)) & 1).astype(bool)] = np.nan
    b["rows"] = rows
    return b


def _loads(data: bytes, path, topic: str, seq: int):
    import orjson

    try:
        return orjson.loads(data)
    except ValueError as exc:
        raise ArchiveError(f"{path}: message {seq} on {topic} is not JSON ({exc})") from None


def _checked_batch(data: bytes, where: str, room: int, want: int | None) -> tuple[dict, int, int, np.ndarray]:
    """One ``SolveBatch`` decoded, its count within ``BATCH`` and ``room`` and its per-solve fields of one
    length: ``(fields, solves n, joints j, flags (n,) int64)``."""
    try:
        b = decode_fields(SOLVE_FIELDS, data)
    except ValueError as exc:
        raise ArchiveError(f"{where}: not a SolveBatch ({exc})") from None
    n = len(b["problem_id"])
    if n > BATCH:
        raise ArchiveError(f"{where}: field 'problem_id' holds {n} solves, a message holds at most {BATCH}")
    if n > room:
        raise ArchiveError(f"{where}: more solve records than metadata field 'problems' promises ({want})" if want
                           is not None else f"{where}: more than {MAX_SOLVES} solve records (MAX_SOLVES); not read")
    for k in ("repetition", "chain", "stop_reason", "iterations", "flags", "solve_time_ns", "ik_time_ns",
              "call_time_ns", *ABSENT_FLAGS):
        if len(b[k]) != n:
            raise ArchiveError(f"{where}: field '{k}' holds {len(b[k])} values for {n} solves")
    if len(b["joints"]) != 1 or b["joints"][0] < 1 or len(b["q_solution"]) != n * int(b["joints"][0]):
        raise ArchiveError(f"{where}: field 'q_solution' does not hold {n} rows of 'joints' values")
    j = int(b["joints"][0])
    flags = b["flags"].astype(np.int64)
    from_file = (flags & F_START_FROM_FILE) != 0
    if len(b["q_start"]) != int((~from_file).sum()) * j:
        raise ArchiveError(f"{where}: field 'q_start' holds {len(b['q_start'])} values, the flags promise "
                           f"{int((~from_file).sum()) * j}")
    return b, n, j, flags


def _info_of(b: dict, where: str, n: int) -> list[dict]:
    """The batch's ``info_json``: one method-specific object per solve."""
    import orjson

    try:
        info = orjson.loads(b["info_json"]) if b["info_json"] else [{}] * n
    except ValueError as exc:
        raise ArchiveError(f"{where}: field 'info_json' is not JSON ({exc})") from None
    if not isinstance(info, list) or len(info) != n or not all(isinstance(x, dict) for x in info):
        raise ArchiveError(f"{where}: field 'info_json' is not a list of {n} objects")
    return info


def _goals_and_starts(b: dict, problems, pid: list, flags: np.ndarray, n: int, j: int,
                      where: str) -> tuple[list, list, list]:
    """Goal positions (n lists of 3, in the archive's length unit), goal orientations (n lists of 4, x, y,
    z, w) and starts (n lists of j, rad or length unit) of a batch: from the problem file (``problems``,
    as :func:`pipeline.io.archive_checks.problem_set_of` gives it) or, without one, stored inline."""
    from_file = (flags & F_START_FROM_FILE) != 0
    q0 = b["q_start"]
    if problems is None:
        if len(b["goal_position"]) != 3 * n or len(b["goal_orientation"]) != 4 * n:
            raise ArchiveError(f"{where}: no problem file named and no inline goals")
        nog = (flags & F_NO_GOAL) != 0
        gp = np.where(nog[:, None], np.nan, b["goal_position"].reshape(n, 3)).tolist()
        go = np.where(nog[:, None], np.nan, b["goal_orientation"].reshape(n, 4)).tolist()
        starts = iter(q0.reshape(-1, j).tolist())
        q_start = [next(starts) for _ in range(n)]
    else:
        rows, ps, scale = problems
        try:
            r = [rows[p] for p in pid]
        except KeyError as exc:
            raise ArchiveError(f"{where}: problem {exc.args[0]} is not in the problem file") from None
        if ps.q_start.shape[1] != j:
            raise ArchiveError(f"{where}: {j} joints per row, the problem file has {ps.q_start.shape[1]}")
        gp = (ps.goal_position[r] * scale).tolist()
        go = ps.goal_quat[r][:, [1, 2, 3, 0]].tolist()
        file_q0 = ps.q_start[r]
        own = iter(q0.reshape(-1, j))
        q_start = [file_q0[i].tolist() if from_file[i] else next(own).tolist() for i in range(n)]
    for i in np.flatnonzero((flags & F_NO_START) != 0):
        q_start[i] = [math.nan] * j
    return gp, go, q_start


def _labels_of(b: dict, where: str, n: int) -> dict | None:
    """The batch's per-solve label columns (``labels_json``), or None when every solve has the metadata's."""
    import orjson

    if not b["labels_json"]:
        return None
    try:
        labels = orjson.loads(b["labels_json"])
    except ValueError as exc:
        raise ArchiveError(f"{where}: field 'labels_json' is not JSON ({exc})") from None
    if not isinstance(labels, dict) or any(k not in LABELS or not isinstance(v, list) or len(v) != n
                                           or not all(isinstance(x, str) for x in v) for k, v in labels.items()):
        raise ArchiveError(f"{where}: field 'labels_json' is not an object of {n}-value label columns (strings)")
    return labels


def _expand(data: bytes, meta: dict, path: Path, seq: int, problems, room: int = MAX_SOLVES,
            want: int | None = None, keys: list | None = None) -> list[dict]:
    """One ``SolveBatch`` message -> per-solve records; ``room``: how many more records the archive may
    hold (refused before a record is built past it); ``want``: the count the metadata promises, if any;
    ``keys``: a list given to be filled with the records' problem ids, repetitions, label tuples and
    numbers of solutions (None without ``n_solutions``), for :class:`ChannelStructure`."""
    where = f"{path}: message {seq} on {SOLVE_TOPIC}"
    b, n, j, flags = _checked_batch(data, where, room, want)
    info = _info_of(b, where, n)
    q = b["q_solution"].reshape(n, j).astype(float)
    q[(flags & F_NO_Q) != 0] = np.nan
    errs = {}
    for k, bit in ABSENT_FLAGS.items():
        errs[k] = np.where((flags & bit) != 0, np.nan, b[k]).tolist()
    pid = b["problem_id"].tolist()
    gp, go, q_start = _goals_and_starts(b, problems, pid, flags, n, j, where)
    ns = b["n_solutions"]
    if len(ns) not in (0, n):
        raise ArchiveError(f"{where}: field 'n_solutions' does not hold one value per solve")
    fixed = {k: meta.get(k, "") for k in LABELS}
    labels = _labels_of(b, where, n)
    sv = (b["solve_time_ns"] * 1e-9).tolist()
    ik = (b["ik_time_ns"] * 1e-9).tolist()
    ct = (b["call_time_ns"] * 1e-9).tolist()
    if len(b["cpu_time_ns"]) not in (0, n):
        raise ArchiveError(f"{where}: field 'cpu_time_ns' does not hold one value per solve")
    cpu = (b["cpu_time_ns"] * 1e-9).tolist() if len(b["cpu_time_ns"]) else [math.nan] * n
    rep, ch, sr, it = b["repetition"].tolist(), b["chain"].tolist(), b["stop_reason"].tolist(), b["iterations"].tolist()
    fl = flags.tolist()
    ql = q.tolist()
    nsl = ns.tolist() if len(ns) else None
    if keys is not None:
        fixed_key = tuple(fixed[k] for k in LABELS)
        if labels:
            cols = [labels.get(k) or [fixed[k]] * n for k in LABELS]
            keys += [pid, rep, list(zip(*cols)), nsl]
        else:
            keys += [pid, rep, [fixed_key] * n, nsl]
    out = []
    for i in range(n):
        f = fl[i]
        g, o = gp[i], go[i]
        rec = {"problem_id": pid[i], "repetition": rep[i], "chain": ch[i], **fixed,
               **({k: v[i] for k, v in labels.items()} if labels else {}),
               "success": bool(f & F_SUCCESS), "claimed_success": bool(f & F_CLAIMED), "stop_reason": sr[i],
               "iterations": it[i], "solve_time_s": sv[i], "ik_time_s": ik[i], "call_time_s": ct[i],
               "cpu_time_s": cpu[i],
               "within_limits": bool(f & F_WITHIN), "initial_error": errs["initial_error"][i],
               "final_error": errs["final_error"][i], "position_error": errs["position_error"][i],
               "orientation_error": errs["orientation_error"][i], "q_start": q_start[i], "q_solution": ql[i],
               "goal": {"position": {"x": g[0], "y": g[1], "z": g[2]},
                        "orientation": {"x": o[0], "y": o[1], "z": o[2], "w": o[3]}},
               "info": info[i]}
        if nsl is not None:
            rec["_n_solutions"] = nsl[i]  # private key (not in frame()): solutions on /ik/solutions
        out.append(rec)
    return out


def _summary_and_metadata(path: Path, data: bytes) -> tuple:
    """The MCAP summary of an archive's bytes and its ``run``, ``traces`` and ``job_timing`` metadata
    records (``run`` None when absent, the others {})."""
    try:
        reader = summary_reader(data)
        summary = reader.get_summary()
        if summary is None:
            raise ArchiveError(f"{path}: truncated archive (no summary section; the job did not finish)")
        meta, traces, timing = None, {}, {}
        for rec in reader.iter_metadata():
            if rec.name == "run":
                meta = dict(rec.metadata)
            elif rec.name == "traces":
                traces = dict(rec.metadata)
            elif rec.name == "job_timing":
                timing = dict(rec.metadata)
    except ArchiveError:
        raise
    except Exception as exc:  # noqa: BLE001  (mcap raises many types for corrupt data)
        raise ArchiveError(f"{path}: corrupt or truncated archive ({type(exc).__name__}: {exc})") from None
    return summary, meta, traces, timing


def _check_run_record(path: Path, meta: dict | None, has_data_crc: bool) -> None:
    """A ``run`` record of this format with every required field, in a file with a data-section CRC."""
    if meta is None:
        raise ArchiveError(f"{path}: not an ik-pipeline archive (no 'run' metadata record)")
    version = meta.get("format_version")
    if version is not None and version != FORMAT_VERSION:
        raise ArchiveError(f"{path}: metadata field 'format_version' is {version[:40]!r} (written by ik-pipeline "
                           f"{meta.get('package_version', '?')[:40]}, commit {meta.get('git_commit', '?')[:12]}); this "
                           f"version reads format {FORMAT_VERSION} only: rebuild it (snakemake) or read it with that "
                           "version")
    for key in REQUIRED_META:
        if key not in meta:
            raise ArchiveError(f"{path}: metadata field '{key}' missing")
    if not has_data_crc:
        raise ArchiveError(f"{path}: no data-section CRC (every format-{FORMAT_VERSION} archive has one): "
                           f"not written by this package")


def read_archive(path: str | Path, problems: str | Path | None = None) -> Archive:
    """Read and check one archive (format 5).

    Checks: the caps of :mod:`pipeline.io.archive_bounds` (file size, each chunk's declared and actual
    uncompressed size, all chunks together, solve records), the MCAP magic, the data-section and summary
    CRCs (:func:`check_file_crcs`), chunk CRCs, a summary section (the writer finished), the ``run``
    metadata, its required fields and the types of the fields readers use (:func:`check_metadata`), the
    format version, every message of the three channels against its schema, and the structure across
    them (:class:`ChannelStructure`): each solve (labels, problem id, repetition) once, every problem id
    in the problem set, traces and solutions only of the solves of their batch, at most one each,
    solution counts equal to the solves' ``n_solutions``; then the number of solve records against the
    metadata's problem count (``problems`` x ``repetitions``), so that a damaged file never reads as
    fewer solves. Stored trace rows and solutions are read (and their own fields checked) on demand.

    Parameters
    ----------
    path : str or Path
        The archive.
    problems : str or Path, optional
        The archive's problem set when it is not where the metadata's ``problem_path`` says (an archive
        copied out of its results tree); its SHA-256 is checked all the same.

    Returns
    -------
    Archive

    Raises
    ------
    ArchiveError
        One line naming the file and what is wrong.
    """
    path = Path(path)
    if not path.is_file():
        raise ArchiveError(f"{path}: no such archive")
    data = read_bytes(path)
    if data[:8] != MAGIC:
        raise ArchiveError(f"{path}: not an MCAP file (bad magic)")
    has_data_crc = check_file_crcs(path, data)
    summary, meta, traces, timing = _summary_and_metadata(path, data)
    _check_run_record(path, meta, has_data_crc)
    want = check_metadata(path, meta, traces, timing)
    room = MAX_SOLVES if want is None else want
    solves: list[dict] = []
    problem_set = problem_set_of(path, meta, problems)
    st = ChannelStructure(path)
    for msg in chunk_messages(path, (SOLVE_TOPIC, TRACE_TOPIC, SOLUTIONS_TOPIC), data, summary):
        if msg.topic == SOLVE_TOPIC:
            keys: list = []
            recs = _expand(msg.data, meta, path, msg.sequence, problem_set, room - len(solves), want, keys)
            st.solves(msg, *keys)
            solves.extend(recs)
            continue
        try:
            b = _trace_batch(msg.data) if msg.topic == TRACE_TOPIC else _solution_batch(msg.data, rows=False)
        except ValueError as exc:
            raise ArchiveError(f"{path}: message {msg.sequence} on {msg.topic}: {exc}") from None
        (st.traces if msg.topic == TRACE_TOPIC else st.solutions)(msg, b)
    st.finish()
    if want is not None and len(solves) != want:
        raise ArchiveError(f"{path}: {len(solves)} solve records, metadata field 'problems' promises {want}")
    return Archive(path, meta, solves, traces, timing)
