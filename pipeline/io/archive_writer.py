"""Writing archives: the ``run`` metadata, the atomic MCAP file and the solve, trace and solution
batches (:class:`ArchiveWriter`, fed by :func:`batch_columns`). The format: :mod:`pipeline.io.archive`."""

from __future__ import annotations

import json
import os
from pathlib import Path
from zlib import crc32 as _crc32

import numpy as np

from pipeline.io.archive_format import (BATCH, F_CLAIMED, F_NO_GOAL, F_NO_Q, F_NO_START, F_START_FROM_FILE,
                                        F_SUCCESS, F_WITHIN, FORMAT_VERSION, LABELS, MESSAGES, REQUIRED_META,
                                        SOLUTION_FIELDS, SOLUTIONS_TOPIC, SOLVE_FIELDS, SOLVE_TOPIC, TRACE_FIELDS,
                                        TRACE_TOPIC, ABSENT_FLAGS, TracePolicy, descriptor, encode_fields)
from pipeline.io.layout import TRACE_COLS


def run_metadata(*, study: str, robot: str, solver: str, settings: dict, seed="-", **fields) -> dict[str, str]:
    """The ``run`` metadata record of an archive, built in one place for every writer.

    Format version, package version, git commit and the environment
    (:func:`pipeline.provenance.environment`) are filled in here.

    Parameters
    ----------
    study, robot, solver : str
        What the archive holds.
    settings : dict
        JSON-able settings, stored as sorted JSON with its SHA-256 prefix as ``settings_hash`` unless
        ``fields`` gives one.
    seed : int or str, optional
        The problem set's seed (``"-"``: none).
    **fields
        Any other fields (problem file, robot file, scale, ...), stored as strings; None values are left out.

    Returns
    -------
    dict[str, str]
    """
    import hashlib

    import pipeline
    from pipeline.provenance import environment, git_commit

    blob = json.dumps(settings, sort_keys=True)
    meta = {"format_version": FORMAT_VERSION, "study": study, "robot": robot, "solver": solver, "settings": blob,
            "settings_hash": hashlib.sha256(blob.encode()).hexdigest()[:16], "seed": str(seed),
            "package_version": pipeline.__version__, "git_commit": git_commit(),
            "environment": json.dumps(environment(), sort_keys=True)}
    meta.update({k: str(v) for k, v in fields.items() if v is not None})
    return meta


class AtomicMcap:
    """An MCAP file written atomically; the base of every MCAP writer here.

    Data go to ``<path>.partial`` (zstd chunks, data CRCs), which is renamed to ``path`` only when
    :meth:`close` has written the summary; :meth:`abort` (or an exception inside ``with``) removes it.

    Parameters
    ----------
    path : str or Path
        The final file name (its folder is created).
    library : str
        The MCAP header's ``library`` field.
    """

    def __init__(self, path: str | Path, library: str):
        from mcap.writer import CompressionType, Writer

        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.partial = self.path.with_name(self.path.name + ".partial")
        self._fh = open(self.partial, "wb")
        self._w = Writer(self._fh, compression=CompressionType.ZSTD, enable_data_crcs=True)
        self._w.start(profile="", library=library)

    def close(self) -> None:
        """Write the summary and rename ``<path>.partial`` to ``path``."""
        self._w.finish()
        self._fh.close()
        os.replace(self.partial, self.path)

    def abort(self) -> None:
        """Close and remove ``<path>.partial``: no file is left behind."""
        self._fh.close()
        self.partial.unlink(missing_ok=True)

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


class ArchiveWriter(AtomicMcap):
    """Context manager writing one archive atomically.

    Solves are given as columns (:meth:`write_columns`, from :func:`batch_columns`) and written as
    messages of :data:`BATCH`; :meth:`write_message` appends JSON records on an extra channel.

    Parameters
    ----------
    path : str or Path
        Final file name; data go to ``<path>.partial`` until :meth:`close`.
    metadata : dict[str, str]
        The ``run`` record (must hold :data:`REQUIRED_META`; :func:`run_metadata` builds it).
    policy : TracePolicy, optional
        Which traces to store in full (default: all).
    problem_ids : array_like of int, shape (m,), optional
        Every problem id the job solves: the population :meth:`TracePolicy.sample_ids` samples
        (default: the ids written, which the writer sees only batch by batch, so give it).
    """

    def __init__(self, path: str | Path, metadata: dict[str, str], policy: TracePolicy | None = None,
                 problem_ids=None):
        missing = [k for k in REQUIRED_META if k not in metadata]
        if missing:
            raise ValueError(f"archive metadata lacks {missing}")
        self.policy = policy or TracePolicy(mode="all")
        self.meta = {k: str(v) for k, v in metadata.items()}
        self.meta["trace_policy"] = self.policy.as_json()
        self._sample = None if problem_ids is None else self.policy.sample_ids(problem_ids)
        self._budget = self.policy.failed_rows
        self._count = {"traces": 0, "stored": 0, "rows": 0, "rows_stored": 0, "failed_stored": 0}
        super().__init__(path, f"ik-pipeline {metadata['package_version']}")
        self._w.add_metadata("run", self.meta)
        self._ch = {}
        for topic, (message, _, _) in MESSAGES.items():
            sid = self._w.register_schema(message, "protobuf", descriptor(topic))
            self._ch[topic] = self._w.register_channel(topic, "protobuf", sid)
        self._seq = 0
        self._clock = 0  # cumulative solve time of the job so far [ns]: the log time
        self._extra: dict[str, int] = {}
        self.inline_goals = "problem_path" not in metadata

    def add_channel(self, topic: str, schema: dict) -> None:
        """Register an extra JSON channel (e.g. measurements that are not IK solves).

        Parameters
        ----------
        topic : str
            The channel's topic.
        schema : dict
            Its JSON schema (``title``, if any, names the schema).
        """
        sid = self._w.register_schema(schema.get("title", topic), "jsonschema", json.dumps(schema).encode())
        self._extra[topic] = self._w.register_channel(topic, "json", sid)

    def _add(self, channel: int, data: bytes) -> None:
        t = self._clock
        self._w.add_message(channel, log_time=t, publish_time=t, sequence=self._seq, data=data)
        self._seq += 1

    def write_message(self, topic: str, record: dict) -> None:
        """Append one JSON record on a channel registered with :meth:`add_channel` (NaN -> null).

        Parameters
        ----------
        topic : str
            A topic given to :meth:`add_channel`.
        record : dict
            JSON-able values (numpy arrays as lists).
        """
        self._add(self._extra[topic], _dumps(record))

    def write_columns(self, cols: dict, traces: dict | None = None) -> None:
        """Append a batch of solves given as columns, in messages of :data:`BATCH`.

        Parameters
        ----------
        cols : dict
            The columns of N solves, as :func:`batch_columns` builds them.
        traces : dict or None
            ``problem_id``, ``repetition`` and ``rows``, (T,) int arrays, one per solve with a trace, and
            ``full``, (sum of rows, 8) float64 array, per row the
            :data:`~pipeline.io.layout.TRACE_COLUMNS`; None: no traces.
        """
        n = len(cols["problem_id"])
        starts = None
        aligned = False
        if traces is not None:
            starts = np.concatenate([[0], np.cumsum(traces["rows"], dtype=np.int64)])
            aligned = (np.array_equal(traces["problem_id"], cols["problem_id"])
                       and np.array_equal(traces["repetition"], cols["repetition"]))
            if not aligned:  # e.g. repetitions: one trace per problem, for repetition 0
                where = {(int(p), int(r)): k for k, (p, r) in enumerate(zip(traces["problem_id"].tolist(),
                                                                            traces["repetition"].tolist()))}
        for lo in range(0, n, BATCH):
            hi = min(n, lo + BATCH)
            part = {k: (v[lo:hi] if isinstance(v, (list, np.ndarray)) else v) for k, v in cols.items()}
            tr = None
            if aligned:  # one trace per solve, in the same order: slices
                tr = {"problem_id": traces["problem_id"][lo:hi], "repetition": traces["repetition"][lo:hi],
                      "rows": traces["rows"][lo:hi], "full": traces["full"][starts[lo]:starts[hi]],
                      "success": np.asarray(part["success"], dtype=bool)}
            elif traces is not None:
                keys = list(zip(np.asarray(part["problem_id"]).tolist(), np.asarray(part["repetition"]).tolist()))
                have = [(i, where[key]) for i, key in enumerate(keys) if key in where]
                if have:
                    pos = np.array([i for i, _ in have], dtype=np.int64)
                    ks = np.array([k for _, k in have], dtype=np.int64)
                    lens = np.asarray(traces["rows"], dtype=np.int64)[ks]
                    first = np.repeat(starts[ks] - (np.cumsum(lens) - lens), lens)
                    tr = {"problem_id": traces["problem_id"][ks], "repetition": traces["repetition"][ks],
                          "rows": traces["rows"][ks], "full": traces["full"][first + np.arange(int(lens.sum()))],
                          "success": np.asarray(part["success"], dtype=bool)[pos]}
            self._emit(part, hi - lo, tr)

    def _keep(self, tr: dict) -> np.ndarray:
        """Which traces of a batch the policy stores (updates the failed-rows budget, in order)."""
        n = len(tr["problem_id"])
        if self.policy.mode != "sample":
            return np.full(n, self.policy.mode == "all")
        sample = self._sample if self._sample is not None else set()
        pid, rep = tr["problem_id"].tolist(), tr["repetition"].tolist()
        rows, ok = np.asarray(tr["rows"]).tolist(), tr["success"].tolist()
        keep = np.zeros(n, bool)
        for k in range(n):
            if rep[k] == 0 and pid[k] in sample:
                keep[k] = True
            elif not ok[k] and rows[k] <= self._budget:
                keep[k] = True
                self._budget -= rows[k]
                self._count["failed_stored"] += 1
        return keep

    def _emit(self, cols: dict, count: int, traces: dict | None) -> None:
        t = np.asarray(cols["solve_time_s"], dtype=float)
        self._clock += int(round(float(np.nansum(t)) * 1e9))
        self._add(self._ch[SOLVE_TOPIC], encode_fields(SOLVE_FIELDS, _solve_message(cols, count, self.inline_goals,
                                                                              self.meta)))
        if cols.get("solutions") is not None:
            self._add(self._ch[SOLUTIONS_TOPIC], encode_fields(SOLUTION_FIELDS, _solution_message(cols, count)))
        if traces is not None and len(traces["problem_id"]):
            keep = self._keep(traces)
            rows = np.asarray(traces["rows"], dtype=np.int64)
            c = self._count
            c["traces"] += len(rows)
            c["stored"] += int(keep.sum())
            c["rows"] += int(rows.sum())
            c["rows_stored"] += int(rows[keep].sum())
            self._add(self._ch[TRACE_TOPIC], encode_fields(TRACE_FIELDS, _trace_message(traces, keep)))

    job_timing: dict | None = None  # set by the job before closing: written as the ``job_timing`` record

    def close(self) -> None:
        """Write the ``traces`` (and ``job_timing``) records, then finish the file (:meth:`AtomicMcap.close`)."""
        c = self._count
        self._w.add_metadata("traces", {"policy": self.policy.describe(), **{k: str(v) for k, v in c.items()}})
        if self.job_timing:
            self._w.add_metadata("job_timing", {k: str(v) for k, v in self.job_timing.items()})
        super().close()


def _dumps(obj) -> bytes:
    """Strict JSON (NaN and infinities as null; numpy arrays as lists)."""
    import orjson

    return orjson.dumps(obj, option=orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS)


def _ns(x) -> np.ndarray:
    """Seconds -> integer nanoseconds (non-finite or negative -> 0)."""
    x = np.nan_to_num(np.asarray(x, dtype=float) * 1e9, nan=0.0, posinf=0.0, neginf=0.0)
    return np.rint(np.maximum(x, 0.0)).astype("<u8")



def _solve_message(cols: dict, count: int, inline_goals: bool, meta: dict | None = None) -> dict:
    """The fields of one ``SolveBatch`` from the columns of ``count`` solves."""
    import orjson

    b = lambda k: np.asarray(cols[k], dtype=bool)  # noqa: E731
    flags = b("success") * F_SUCCESS | b("claimed_success") * F_CLAIMED | b("within_limits") * F_WITHIN
    out = {}
    for k, bit in ABSENT_FLAGS.items():
        v = np.asarray(cols[k], dtype=float)
        bad = ~np.isfinite(v)
        flags = flags | bad * bit
        out[k] = np.where(bad, 0.0, v)
    q = np.asarray(cols["q_solution"], dtype=float).reshape(count, -1)
    n = q.shape[1]
    qbad = ~np.isfinite(q).all(axis=1)
    flags = flags | qbad * F_NO_Q
    q = np.where(np.isfinite(q), q, 0.0)
    q0 = np.asarray(cols["q_start"], dtype=float).reshape(count, n)
    from_file = np.zeros(count, bool) if inline_goals else np.asarray(cols.get("start_from_file", np.zeros(count, bool)), bool)
    flags = flags | from_file * F_START_FROM_FILE
    keep = q0[~from_file]
    bad0 = ~np.isfinite(keep).all(axis=1)
    if bad0.any():  # a start with a non-finite value: flagged, written 0, read back NaN
        flags[np.flatnonzero(~from_file)[bad0]] |= F_NO_START
        keep = np.where(np.isfinite(keep), keep, 0.0)
    out.update(problem_id=cols["problem_id"], repetition=cols["repetition"], chain=cols["chain"],
               stop_reason=cols["stop_reason"], iterations=cols["iterations"], solve_time_ns=_ns(cols["solve_time_s"]),
               ik_time_ns=_ns(cols["ik_time_s"]), call_time_ns=_ns(cols["call_time_s"]), q_solution=q, q_start=keep,
               joints=np.array([n], dtype="<u4"))
    if inline_goals:
        g = np.column_stack([np.asarray(cols["goal_position"], dtype=float).reshape(count, 3),
                             np.asarray(cols["goal_orientation"], dtype=float).reshape(count, 4)])
        badg = ~np.isfinite(g).all(axis=1)
        flags = flags | badg * F_NO_GOAL
        g = np.where(np.isfinite(g), g, 0.0)
        out["goal_position"], out["goal_orientation"] = g[:, :3], g[:, 3:]
    if cols.get("n_solutions") is not None:
        out["n_solutions"] = np.asarray(cols["n_solutions"], dtype="<i4")
    if cols.get("cpu_time_s") is not None:
        out["cpu_time_ns"] = _ns(cols["cpu_time_s"])
    out["flags"] = flags.astype("<u4")
    out["info_json"] = orjson.dumps(list(cols["info"]), option=orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS)
    labels = {k: [cols[k]] * count if isinstance(cols[k], str) else [str(v) for v in cols[k]]
              for k in LABELS if k in cols and cols[k] is not None}
    if any(set(v) != {(meta or {}).get(k, "")} for k, v in labels.items()):
        out["labels_json"] = orjson.dumps(labels)
    return out


def _solution_message(cols: dict, count: int) -> dict:
    """The fields of one ``SolutionBatch``: every returned solution of ``count`` solves."""
    S = np.asarray(cols["solutions"], dtype=float)
    ns = np.asarray(cols["n_solutions"], dtype=np.int64)
    n = S.shape[-1]
    S = S.reshape(count, -1, n)
    rows = S[np.arange(S.shape[1])[None, :] < ns[:, None]]  # (sum ns, n), solve by solve
    bad = ~np.isfinite(rows)
    out = {"problem_id": cols["problem_id"], "repetition": cols["repetition"], "count": ns.astype("<u4"),
           "joints": np.array([n], dtype="<u4"), "solutions": np.where(bad, 0.0, rows)}
    if bad.any():
        out["absent"] = (bad * (1 << np.arange(n, dtype=np.uint64))).sum(axis=1).astype("<u8")
    return out


def _trace_message(tr: dict, keep: np.ndarray) -> dict:
    """The fields of one ``TraceBatch``: every trace's row count and digest, the kept traces' rows."""
    rows = np.asarray(tr["rows"], dtype=np.int64)
    full = np.ascontiguousarray(np.asarray(tr["full"], dtype=float).reshape(-1, TRACE_COLS), dtype="<f8")
    off = np.concatenate([[0], np.cumsum(rows)])
    b = (off * TRACE_COLS * 8).tolist()
    buf = memoryview(full).cast("B")  # CRC-32 of each trace's rows, straight from the buffer (= digest())
    out = {"problem_id": tr["problem_id"], "repetition": tr["repetition"], "rows": rows.astype("<u4"),
           "digest": np.array([_crc32(buf[b[k]:b[k + 1]]) for k in range(len(rows))], dtype="<u4"),
           "stored": keep.astype("<u4")}
    if keep.any():
        sel = full[np.repeat(keep, rows)]
        bad = ~np.isfinite(sel)
        clean = np.where(bad, 0.0, sel)
        out.update(error=clean[:, 0], position_error=clean[:, 7], error_vector=clean[:, 1:7].astype("<f4"))
        if bad.any():
            out["absent"] = (bad * (1 << np.arange(TRACE_COLS))).sum(axis=1).astype("<u4")
    return out


def batch_columns(problem_id, repetition, chain, robot: str, solver: str, length_unit: str, q_start,
                  goal_position, goal_quat_wxyz, res, *, method: str = "", start_from_file=None) -> tuple[dict, dict | None]:
    """Columns and traces of N solves from a batch result (for :meth:`ArchiveWriter.write_columns`).

    Parameters
    ----------
    problem_id, repetition, chain : array_like of int, shape (N,)
        Per solve: its problem id, repetition and chain number.
    robot, solver, length_unit : str
        The metadata's (stored per solve only where they differ from it).
    q_start : ndarray, shape (N, n) [rad | length]
        The starts.
    goal_position : ndarray, shape (N, 3) [length]
        Goal positions, in ``length_unit``.
    goal_quat_wxyz : ndarray, shape (N, 4) [1]
        Goal orientations, unit quaternions w-first (stored x, y, z, w).
    res : pipeline.solvers.BatchResult
        The batch result (read by its fields only: this module does not import the solvers).
    method : str, optional
        The method name, as the metadata's.
    start_from_file : array_like of bool, shape (N,), optional
        The start is the problem file's (not stored when the archive names its problem file).

    Returns
    -------
    cols : dict
        Column name -> (N, ...) array (or one string for the labels).
    traces : dict or None
        ``problem_id``, ``repetition``, ``rows`` (N,) and ``full`` (sum of rows, 8) float64, or None
        when ``res`` holds no traces.
    """
    n = len(res)
    problem_id = np.asarray(problem_id, dtype=np.int64)
    cols = {
        "problem_id": problem_id, "repetition": np.asarray(repetition, dtype=np.int64),
        "robot": robot, "solver": solver, "method": method, "length_unit": length_unit,
        "chain": np.asarray(chain, dtype=np.int64), "success": res.success, "claimed_success": res.claimed_success,
        "stop_reason": res.stop_reason, "iterations": res.iterations, "solve_time_s": res.solve_time_s,
        "ik_time_s": res.ik_time_s,
        "call_time_s": res.call_times_s if res.call_times_s is not None else np.full(n, res.call_time_s / max(1, n)),
        "cpu_time_s": getattr(res, "cpu_times_s", None),
        "within_limits": res.within_limits, "initial_error": np.full(n, np.nan), "final_error": np.full(n, np.nan),
        "position_error": res.position_error, "orientation_error": res.orientation_error,
        "q_start": np.ascontiguousarray(q_start, dtype=float), "q_solution": np.ascontiguousarray(res.q, dtype=float),
        "goal_position": np.ascontiguousarray(goal_position, dtype=float),
        "goal_orientation": np.ascontiguousarray(np.asarray(goal_quat_wxyz, dtype=float)[:, [1, 2, 3, 0]]),
        "info": list(res.info) if res.info is not None else [{}] * n,
        "start_from_file": np.zeros(n, bool) if start_from_file is None else np.asarray(start_from_file, bool),
    }
    if res.solutions is not None:
        cols["solutions"], cols["n_solutions"] = res.solutions, res.n_solutions  # (N, m, n), counts (N,)
    traces = None
    if res.trace_rows is not None:
        off = res.trace_offsets
        cols["initial_error"] = res.trace_rows[off[:-1], 0]
        cols["final_error"] = res.trace_rows[off[1:] - 1, 0]
        traces = {"problem_id": problem_id.astype(np.int32), "repetition": cols["repetition"].astype(np.int32),
                  "rows": np.diff(off).astype(np.uint32), "full": res.trace_rows[:, :TRACE_COLS]}
    return cols, traces
