"""Result archives: one MCAP file per solve job, zstd-compressed chunks.

Channels (format version 3)
---------------------------
``/ik/solve``  one message per batch of up to :data:`BATCH` problems, strict JSON (no NaN or
               Infinity: a missing number is ``null``), schema ``ik_pipeline.SolveBatch``: columns
               of equal length ``count`` (problem_id, success, stop_reason, times, errors, ...),
               ``q_start``/``q_solution`` as ``count`` rows of joint values, the goal as
               ``goal_position`` (x, y, z) and ``goal_orientation`` (x, y, z, w) rows, ``info``
               (method-specific counters) and, for analytic methods, ``solutions``.
``/ik/trace``  one message per batch, protobuf ``ik_pipeline.TraceBatch`` (schema written into
               the file as a FileDescriptorSet): per problem its id, repetition and number of
               trace rows; per row the scalar stop-test error and |dp| (float64) and the error
               6-vector (v, omega) (float32).
Metadata record ``run``: study, robot, solver, settings (JSON), settings hash, seed, scale,
package version, git commit, problem file and its SHA-256, problem count, environment.

A reader turns the batches back into one record per solve (:attr:`Archive.solves`), the same
dicts as version 2 (one JSON message per solve and per trace), which it still reads.

Log times: a batch's log time is the cumulative ``solve_time_s`` of the job up to its last solve
[ns], so a timeline shows where the solving time went. Nothing else in the file depends on the
clock: the same settings and seed give the same file except for the timing fields.
An archive is written to ``<name>.partial`` and renamed only after the MCAP summary is written:
an interrupted job never leaves a file that looks complete.

Quaternions are w-first everywhere in the library; here, and only here, the goal orientation is
written x, y, z, w (Foxglove ``Pose`` style).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np

FORMAT_VERSION = "3"
READABLE_VERSIONS = ("2", "3")
BATCH = 1000  # solves per /ik/solve and /ik/trace message
SOLVE_TOPIC = "/ik/solve"
TRACE_TOPIC = "/ik/trace"
REQUIRED_META = ("format_version", "study", "robot", "solver", "settings", "settings_hash", "seed",
                 "package_version", "git_commit")

_NUMS = {"type": "array", "items": {"type": ["number", "null"]}}
_ROWS = {"type": "array", "items": _NUMS}
_INTS = {"type": "array", "items": {"type": "integer"}}
_BOOLS = {"type": "array", "items": {"type": "boolean"}}
_STRS = {"type": "array", "items": {"type": "string"}}
# column -> (JSON schema, kind): kind f = float, i = int, b = bool, s = string, r = rows of floats, o = objects
SOLVE_COLUMNS = {
    "problem_id": (_INTS, "i"), "repetition": (_INTS, "i"), "chain": (_INTS, "i"),
    "robot": (_STRS, "s"), "solver": (_STRS, "s"), "method": (_STRS, "s"),
    "success": ({**_BOOLS, "description": "FK-verified success"}, "b"),
    "claimed_success": ({**_BOOLS, "description": "the method's own stop test said success"}, "b"),
    "stop_reason": ({**_INTS, "description": "pipeline.solvers.StopReason: 1 success, 2 stalled, 3 error grew, "
                     "4 cap, 5 non-finite, 6 FK contradicts, 7 no solution, 8 outside the joint limits"}, "i"),
    "iterations": (_INTS, "i"),
    "solve_time_s": ({**_NUMS, "description": "the method's own computation, monotonic clock [s]"}, "f"),
    "ik_time_s": ({**_NUMS, "description": "IK-block (step) time [s], 0 where not measured"}, "f"),
    "call_time_s": ({**_NUMS, "description": "the whole solve() call [s]; in a batch, the batch call / its size"}, "f"),
    "within_limits": ({**_BOOLS, "description": "q_solution within the joint limits (revolute wrapped by 2 pi)"}, "b"),
    "initial_error": (_NUMS, "f"), "final_error": (_NUMS, "f"),
    "position_error": ({**_NUMS, "description": "|p_goal - p| by independent FK [length_unit]"}, "f"),
    "orientation_error": ({**_NUMS, "description": "rotation angle goal vs reached [rad]; null = not checked"}, "f"),
    "length_unit": (_STRS, "s"),
    "q_start": ({**_ROWS, "description": "start joint values [rad | length_unit]"}, "r"),
    "q_solution": ({**_ROWS, "description": "returned joint values [rad | length_unit]"}, "r"),
    "goal_position": ({**_ROWS, "description": "x, y, z [length_unit]"}, "r"),
    "goal_orientation": ({**_ROWS, "description": "unit quaternion x, y, z, w"}, "r"),
    "info": ({"type": "array", "items": {"type": "object"}, "description": "method-specific counters"}, "o"),
    "solutions": ({"type": "array", "items": {"type": ["array", "null"]},
                   "description": "analytic methods: every solution (null for other methods)"}, "o"),
}
SOLVE_SCHEMA = {
    "title": "ik_pipeline.SolveBatch",
    "description": "a batch of IK solves as columns of equal length `count` (format_version 3)",
    "type": "object",
    "required": ["count"] + [k for k in SOLVE_COLUMNS if k != "solutions"],
    "properties": {"count": {"type": "integer"}, **{k: v for k, (v, _) in SOLVE_COLUMNS.items()}},
}

# ---- /ik/trace: protobuf, written by hand (fixed-width packed fields: numpy bytes) ----------
# (field number, name, numpy dtype, protobuf type: 15 sfixed32, 7 fixed32, 1 double, 2 float)
TRACE_FIELDS = ((1, "problem_id", "<i4", 15), (2, "repetition", "<i4", 15), (3, "rows", "<u4", 7),
                (4, "error", "<f8", 1), (5, "position_error", "<f8", 1), (6, "error_vector", "<f4", 2))
TRACE_MESSAGE = "ik_pipeline.TraceBatch"


def _varint(n: int) -> bytes:
    out = bytearray()
    while True:
        b = n & 0x7F
        n >>= 7
        if n:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


def _ld(field: int, payload: bytes) -> bytes:
    """A length-delimited protobuf field (wire type 2)."""
    return _varint(field << 3 | 2) + _varint(len(payload)) + payload


def _vf(field: int, value: int) -> bytes:
    """A varint protobuf field (wire type 0)."""
    return _varint(field << 3) + _varint(value)


def trace_descriptor() -> bytes:
    """The FileDescriptorSet of ``ik_pipeline.TraceBatch`` (proto3: repeated scalars are packed)."""
    fields = b"".join(_ld(2, _ld(1, name.encode()) + _vf(3, num) + _vf(4, 3) + _vf(5, ptype)
                             + _ld(10, "".join(w.title() if i else w for i, w in enumerate(name.split("_"))).encode()))
                      for num, name, _, ptype in TRACE_FIELDS)
    message = _ld(1, b"TraceBatch") + fields
    file = _ld(1, b"ik_pipeline/trace_batch.proto") + _ld(2, b"ik_pipeline") + _ld(4, message) + _ld(12, b"proto3")
    return _ld(1, file)


def encode_trace_batch(problem_id, repetition, rows, error, position_error, error_vector) -> bytes:
    """One ``TraceBatch`` message: per problem (id, repetition, row count), per row the errors."""
    cols = (problem_id, repetition, rows, error, position_error, error_vector)
    return b"".join(_ld(num, np.ascontiguousarray(c, dtype=dt).tobytes())
                    for (num, _, dt, _), c in zip(TRACE_FIELDS, cols) if len(c))


def _read_varint(buf: bytes, pos: int) -> tuple[int, int]:
    n = shift = 0
    while True:
        if pos >= len(buf) or shift > 63:
            raise ValueError("truncated varint")
        b = buf[pos]
        pos += 1
        n |= (b & 0x7F) << shift
        shift += 7
        if not b & 0x80:
            return n, pos


def decode_trace_batch(data: bytes) -> dict[str, np.ndarray]:
    """Inverse of :func:`encode_trace_batch`; raises ValueError on anything it did not write."""
    by_num = {num: (name, dt) for num, name, dt, _ in TRACE_FIELDS}
    out = {name: np.zeros(0, dtype=dt) for _, name, dt, _ in TRACE_FIELDS}
    pos = 0
    while pos < len(data):
        key, pos = _read_varint(data, pos)
        num, wt = key >> 3, key & 7
        if num not in by_num or wt != 2:
            raise ValueError(f"unexpected field {num} (wire type {wt})")
        size, pos = _read_varint(data, pos)
        if pos + size > len(data):
            raise ValueError(f"field {num} runs past the message")
        name, dt = by_num[num]
        if size % np.dtype(dt).itemsize:
            raise ValueError(f"field {name}: {size} bytes is not a whole number of values")
        out[name] = np.frombuffer(data, dtype=dt, count=size // np.dtype(dt).itemsize, offset=pos)
        pos += size
    n, m = len(out["problem_id"]), int(out["rows"].sum())
    if len(out["repetition"]) != n or len(out["rows"]) != n:
        raise ValueError("problem_id, repetition and rows differ in length")
    if len(out["error"]) != m or len(out["position_error"]) != m or len(out["error_vector"]) != 6 * m:
        raise ValueError(f"row columns do not hold the {m} rows the problems promise")
    out["error_vector"] = out["error_vector"].reshape(m, 6)
    return out


class ArchiveError(ValueError):
    """An archive is missing, corrupt, truncated or not ours (one-line message naming the file)."""


def _goal(position: np.ndarray, quat_wxyz: np.ndarray) -> dict:
    w, x, y, z = (float(v) for v in quat_wxyz)
    px, py, pz = (float(v) for v in position)
    return {"position": {"x": px, "y": py, "z": pz}, "orientation": {"x": x, "y": y, "z": z, "w": w}}


def goal_from_record(goal: dict) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of the goal encoding: (position (3,), quaternion w-first (4,))."""
    p, o = goal["position"], goal["orientation"]
    return np.array([p["x"], p["y"], p["z"]]), np.array([o["w"], o["x"], o["y"], o["z"]])


class ArchiveWriter:
    """Context manager writing one archive atomically.

    Solves are buffered and written as batches of :data:`BATCH` (:meth:`write` for one record at a
    time, :meth:`write_columns` for a whole batch of columns at once, the fast path of solve jobs).

    Parameters
    ----------
    path : str or Path
        Final file name; data go to ``<path>.partial`` until :meth:`close`.
    metadata : dict[str, str]
        The ``run`` record (must hold :data:`REQUIRED_META`).
    """

    def __init__(self, path: str | Path, metadata: dict[str, str]):
        from mcap.writer import CompressionType, Writer

        missing = [k for k in REQUIRED_META if k not in metadata]
        if missing:
            raise ValueError(f"archive metadata lacks {missing}")
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.partial = self.path.with_name(self.path.name + ".partial")
        self._fh = open(self.partial, "wb")
        _use_fast_zstd()
        self._w = Writer(self._fh, compression=CompressionType.ZSTD, enable_data_crcs=True)
        self._w.start(profile="", library=f"ik-pipeline {metadata['package_version']}")
        self._w.add_metadata("run", {k: str(v) for k, v in metadata.items()})
        sid = self._w.register_schema(SOLVE_SCHEMA["title"], "jsonschema", json.dumps(SOLVE_SCHEMA).encode())
        tid = self._w.register_schema(TRACE_MESSAGE, "protobuf", trace_descriptor())
        self._solve = self._w.register_channel(SOLVE_TOPIC, "json", sid)
        self._trace = self._w.register_channel(TRACE_TOPIC, "protobuf", tid)
        self._seq = 0
        self._clock = 0  # cumulative solve time of the job so far [ns]: the log time
        self._pending: list[tuple[dict, dict | None]] = []
        self._extra: dict[str, int] = {}

    def add_channel(self, topic: str, schema: dict) -> None:
        """Register an extra JSON channel (e.g. measurements that are not IK solves)."""
        sid = self._w.register_schema(schema.get("title", topic), "jsonschema", json.dumps(schema).encode())
        self._extra[topic] = self._w.register_channel(topic, "json", sid)

    def _add(self, channel: int, data: bytes) -> None:
        t = self._clock
        self._w.add_message(channel, log_time=t, publish_time=t, sequence=self._seq, data=data)
        self._seq += 1

    def write_message(self, topic: str, record: dict) -> None:
        """Append one JSON record on a channel registered with :meth:`add_channel` (NaN -> null)."""
        self._flush()
        self._add(self._extra[topic], _dumps(record))

    def write(self, solve: dict, trace: dict | None) -> None:
        """Append one problem's solve record and its trace (dicts of :func:`solve_record`; no trace if None)."""
        self._pending.append((solve, trace))
        if len(self._pending) >= BATCH:
            self._flush()

    def write_columns(self, cols: dict, traces: dict | None = None) -> None:
        """Append a batch of solves given as columns (:func:`batch_columns`), in messages of :data:`BATCH`.

        ``traces``: ``problem_id``, ``repetition``, ``rows`` (per problem with a trace) and ``error``,
        ``position_error``, ``error_vector`` (per row), or None.
        """
        self._flush()
        n = len(cols["problem_id"])
        aligned = False
        if traces is not None:
            starts = np.concatenate([[0], np.cumsum(traces["rows"], dtype=np.int64)])
            aligned = (np.array_equal(traces["problem_id"], cols["problem_id"])
                       and np.array_equal(traces["repetition"], cols["repetition"]))
            if not aligned:
                where = {(int(p), int(r)): k for k, (p, r) in enumerate(zip(traces["problem_id"], traces["repetition"]))}
        for lo in range(0, n, BATCH):
            hi = min(n, lo + BATCH)
            part = {k: v[lo:hi] for k, v in cols.items()}
            tr = None
            if aligned:  # one trace per solve, in the same order: slices
                a, b = starts[lo], starts[hi]
                tr = {"problem_id": traces["problem_id"][lo:hi], "repetition": traces["repetition"][lo:hi],
                      "rows": traces["rows"][lo:hi], "error": traces["error"][a:b],
                      "position_error": traces["position_error"][a:b], "error_vector": traces["error_vector"][a:b]}
            elif traces is not None:
                ks = [where[key] for key in zip(part["problem_id"].tolist(), part["repetition"].tolist()) if key in where]
                if ks:
                    rows = np.concatenate([np.arange(starts[k], starts[k + 1]) for k in ks])
                    tr = {"problem_id": traces["problem_id"][ks], "repetition": traces["repetition"][ks],
                          "rows": traces["rows"][ks], "error": traces["error"][rows],
                          "position_error": traces["position_error"][rows], "error_vector": traces["error_vector"][rows]}
            self._emit(part, hi - lo, tr)

    def _emit(self, cols: dict, count: int, traces: dict | None) -> None:
        t = np.asarray(cols["solve_time_s"], dtype=float)
        self._clock += int(round(float(np.nansum(t)) * 1e9))
        cols = {k: np.ascontiguousarray(v) if isinstance(v, np.ndarray) else v for k, v in cols.items()}
        self._add(self._solve, _dumps({"count": count, **cols}))
        if traces is not None and len(traces["problem_id"]):
            self._add(self._trace, encode_trace_batch(traces["problem_id"], traces["repetition"], traces["rows"],
                                                      traces["error"], traces["position_error"],
                                                      traces["error_vector"]))

    def _flush(self) -> None:
        if not self._pending:
            return
        recs = [s for s, _ in self._pending]
        trs = [t for _, t in self._pending if t is not None]
        self._pending = []
        self._emit(_columns(recs), len(recs), _trace_columns(trs) if trs else None)

    def close(self) -> None:
        self._flush()
        self._w.finish()
        self._fh.close()
        os.replace(self.partial, self.path)

    def abort(self) -> None:
        self._fh.close()
        self.partial.unlink(missing_ok=True)

    def __enter__(self) -> "ArchiveWriter":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


class _Zstd1:
    """``zstandard`` as the mcap writer calls it (``compress(data)``), at level 1 instead of 3: on
    the solve batches it is 2-3x faster and no larger (measured on a 10 000-solve DLS archive)."""

    def __init__(self):
        import zstandard

        self._c = zstandard.ZstdCompressor(level=1)

    def compress(self, data: bytes) -> bytes:
        return self._c.compress(data)


def _use_fast_zstd() -> None:
    import mcap.writer

    if not isinstance(mcap.writer.zstandard, _Zstd1):
        mcap.writer.zstandard = _Zstd1()


def _dumps(obj) -> bytes:
    """Strict JSON (NaN and infinities as null; numpy arrays as lists)."""
    import orjson

    return orjson.dumps(obj, option=orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS)


def _columns(recs: list[dict]) -> dict:
    """Per-solve records (:func:`solve_record`) -> the columns of one ``SolveBatch``."""
    cols = {}
    for k, (_, kind) in SOLVE_COLUMNS.items():
        if k == "goal_position":
            cols[k] = [[r["goal"]["position"][a] for a in "xyz"] for r in recs]
        elif k == "goal_orientation":
            cols[k] = [[r["goal"]["orientation"][a] for a in "xyzw"] for r in recs]
        elif k == "solutions":
            if any("solutions" in r for r in recs):
                cols[k] = [r.get("solutions") for r in recs]
        elif k == "info":
            cols[k] = [r.get("info", {}) for r in recs]
        else:
            cols[k] = [r.get(k) for r in recs]
    return cols


def _trace_columns(trs: list[dict]) -> dict:
    rows = np.array([len(t["error"]) for t in trs], dtype=np.uint32)
    return {"problem_id": np.array([t["problem_id"] for t in trs], dtype=np.int32),
            "repetition": np.array([t.get("repetition", 0) for t in trs], dtype=np.int32), "rows": rows,
            "error": np.concatenate([np.asarray(t["error"], dtype=float) for t in trs]),
            "position_error": np.concatenate([np.asarray(t["position_error"], dtype=float) for t in trs]),
            "error_vector": np.concatenate([np.asarray(t["error_vector"], dtype=float).reshape(-1, 6) for t in trs])}


def batch_columns(problem_id, repetition, chain, robot: str, solver: str, length_unit: str, q_start,
                  goal_position, goal_quat_wxyz, res, *, method: str = "") -> tuple[dict, dict | None]:
    """Columns and traces of N solves from a :class:`pipeline.solvers.BatchResult` (for :meth:`ArchiveWriter.write_columns`).

    ``goal_position`` (N, 3) must be in ``length_unit``; ``goal_quat_wxyz`` (N, 4).
    """
    n = len(res)
    problem_id = np.asarray(problem_id, dtype=np.int64)
    cols = {
        "problem_id": problem_id, "repetition": np.asarray(repetition, dtype=np.int64),
        "chain": np.asarray(chain, dtype=np.int64), "robot": [robot] * n, "solver": [solver] * n,
        "method": [method] * n, "success": res.success, "claimed_success": res.claimed_success,
        "stop_reason": res.stop_reason, "iterations": res.iterations, "solve_time_s": res.solve_time_s,
        "ik_time_s": res.ik_time_s,
        "call_time_s": res.call_times_s if res.call_times_s is not None else np.full(n, res.call_time_s / max(1, n)),
        "within_limits": res.within_limits, "initial_error": np.full(n, np.nan), "final_error": np.full(n, np.nan),
        "position_error": res.position_error, "orientation_error": res.orientation_error,
        "length_unit": [length_unit] * n, "q_start": np.ascontiguousarray(q_start, dtype=float),
        "q_solution": np.ascontiguousarray(res.q, dtype=float),
        "goal_position": np.ascontiguousarray(goal_position, dtype=float),
        "goal_orientation": np.ascontiguousarray(np.asarray(goal_quat_wxyz, dtype=float)[:, [1, 2, 3, 0]]),
        "info": list(res.info) if res.info is not None else [{}] * n,
    }
    if res.solutions is not None:
        cols["solutions"] = [res.solutions[i, : int(res.n_solutions[i])].tolist() for i in range(n)]
    traces = None
    if res.trace_rows is not None:
        off = res.trace_offsets
        cols["initial_error"] = res.trace_rows[off[:-1], 0]
        cols["final_error"] = res.trace_rows[off[1:] - 1, 0]
        traces = {"problem_id": problem_id.astype(np.int32), "repetition": cols["repetition"].astype(np.int32),
                  "rows": np.diff(off).astype(np.uint32), "error": res.trace_rows[:, 0],
                  "position_error": res.trace_rows[:, 7], "error_vector": res.trace_rows[:, 1:7]}
    return cols, traces


def solve_record(problem_id: int, robot: str, solver: str, length_unit: str, q_start, goal_position, goal_quat,
                 result, *, method: str = "", repetition: int = 0, chain: int = -1) -> tuple[dict, dict]:
    """Encode one :class:`pipeline.solvers.IKResult` as (solve message, trace message).

    ``goal_position`` must be in ``length_unit`` (the result's unit).
    """
    tr = result.trace
    solve = {
        "problem_id": int(problem_id), "repetition": int(repetition), "chain": int(chain), "robot": robot,
        "solver": solver, "method": method,
        "success": bool(result.success), "claimed_success": bool(result.claimed_success),
        "stop_reason": int(result.stop_reason), "iterations": int(result.iterations),
        "solve_time_s": float(result.solve_time_s), "ik_time_s": float(result.ik_time_s),
        "call_time_s": float(getattr(result, "call_time_s", float("nan"))),
        "within_limits": bool(getattr(result, "within_limits", True)),
        "initial_error": float(tr[0, 0]), "final_error": float(tr[-1, 0]),
        "position_error": float(result.position_error), "orientation_error": float(result.orientation_error),
        "length_unit": length_unit,
        "q_start": [float(v) for v in q_start], "q_solution": [float(v) for v in result.q],
        "goal": _goal(goal_position, goal_quat),
        "info": {k: (v if isinstance(v, (bool, int, str)) or v is None else float(v))
                 for k, v in (getattr(result, "info", None) or {}).items()},
    }
    sols = getattr(result, "solutions", None)
    if sols is not None:
        solve["solutions"] = np.asarray(sols, dtype=float).tolist()
    trace = {"problem_id": int(problem_id), "repetition": int(repetition), "error": tr[:, 0].tolist(),
             "error_vector": tr[:, 1:7].tolist(), "position_error": tr[:, 7].tolist()}
    return solve, trace


@dataclass
class Archive:
    """An archive read back: metadata and the per-problem solve records (traces on demand)."""

    path: Path
    metadata: dict[str, str]
    solves: list[dict]

    def frame(self):
        """Solve records as a pandas DataFrame (vectors kept as lists)."""
        import pandas as pd

        return pd.DataFrame(self.solves)

    def messages(self, topic: str) -> Iterator[dict]:
        """Yield the decoded JSON records of a JSON channel (e.g. a study's measurement channel)."""
        for _, _, msg in _iter_messages(self.path, [topic]):
            yield _loads(msg.data, self.path, topic, msg.sequence)

    def traces(self, problem_ids=None) -> Iterator[dict]:
        """Yield trace records ``{problem_id, repetition, error, error_vector, position_error}`` (lists),
        optionally only for ``problem_ids``."""
        wanted = None if problem_ids is None else {int(p) for p in np.atleast_1d(problem_ids)}
        v3 = self.metadata.get("format_version") == "3"
        for _, _, msg in _iter_messages(self.path, [TRACE_TOPIC]):
            if not v3:
                rec = _loads(msg.data, self.path, TRACE_TOPIC, msg.sequence)
                if wanted is None or rec["problem_id"] in wanted:
                    yield rec
                continue
            try:
                b = decode_trace_batch(msg.data)
            except ValueError as exc:
                raise ArchiveError(f"{self.path}: message {msg.sequence} on {TRACE_TOPIC}: {exc}") from None
            starts = np.concatenate([[0], np.cumsum(b["rows"], dtype=np.int64)])
            for k, pid in enumerate(b["problem_id"].tolist()):
                if wanted is None or pid in wanted:
                    lo, hi = starts[k], starts[k + 1]
                    yield {"problem_id": pid, "repetition": int(b["repetition"][k]),
                           "error": b["error"][lo:hi].tolist(),
                           "error_vector": b["error_vector"][lo:hi].astype(float).tolist(),
                           "position_error": b["position_error"][lo:hi].tolist()}


def _loads(data: bytes, path, topic: str, seq: int):
    import orjson

    try:
        return orjson.loads(data)
    except ValueError as exc:
        raise ArchiveError(f"{path}: message {seq} on {topic} is not JSON ({exc})") from None


def _iter_messages(path: Path, topics):
    from mcap.reader import make_reader

    try:
        with open(path, "rb") as fh:
            reader = make_reader(fh, validate_crcs=True)  # chunk CRCs checked on every read
            for schema, channel, msg in reader.iter_messages(topics=topics):
                yield schema, channel, msg
    except ArchiveError:
        raise
    except Exception as exc:  # mcap raises many types for corrupt data
        raise ArchiveError(f"{path}: corrupt archive ({type(exc).__name__}: {exc})") from None


_FLOAT_COLS = [k for k, (_, kind) in SOLVE_COLUMNS.items() if kind == "f"]


def _expand(batch, path: Path, seq: int) -> list[dict]:
    """One ``SolveBatch`` message -> per-solve records (the version-2 record layout)."""
    where = f"{path}: message {seq} on {SOLVE_TOPIC}"
    if not isinstance(batch, dict) or not isinstance(batch.get("count"), int) or batch["count"] < 0:
        raise ArchiveError(f"{where}: not a SolveBatch (no 'count')")
    n = batch["count"]
    for k in SOLVE_SCHEMA["required"][1:] + (["solutions"] if "solutions" in batch else []):
        v = batch.get(k)
        if not isinstance(v, list) or len(v) != n:
            got = "missing" if v is None else f"{len(v) if isinstance(v, list) else type(v).__name__} values"
            raise ArchiveError(f"{where}: column '{k}' {got}, count is {n}")
    nan = math.nan
    for k in _FLOAT_COLS:
        col = batch[k]
        if None in col:
            batch[k] = [nan if v is None else v for v in col]
    for k in ("q_start", "q_solution"):
        batch[k] = [[nan if v is None else v for v in row] if None in row else row for row in batch[k]]
    gp, go = batch["goal_position"], batch["goal_orientation"]
    sols = batch.get("solutions")
    keys = [k for k in SOLVE_COLUMNS if k not in ("goal_position", "goal_orientation", "solutions")]
    cols = [batch[k] for k in keys]
    out = []
    for i in range(n):
        rec = {k: c[i] for k, c in zip(keys, cols)}
        p, o = gp[i], go[i]
        rec["goal"] = {"position": {"x": p[0], "y": p[1], "z": p[2]},
                       "orientation": {"x": o[0], "y": o[1], "z": o[2], "w": o[3]}}
        if sols is not None and sols[i] is not None:
            rec["solutions"] = sols[i]
        out.append(rec)
    return out


_MAGIC = b"\x89MCAP0\r\n"


def check_file_crcs(path: Path) -> bool:
    """Check the whole file against the CRCs the writer stored: the data section's (DataEnd record:
    every byte from the start to the summary, metadata included) and the summary's (Footer).

    The mcap reader checks each chunk's CRC; these two cover the rest, so a changed byte anywhere
    (an edited metadata value, a flipped bit in a record header) is caught.

    Returns
    -------
    bool
        The file carries a data-section CRC (format 3 always does; format 2 did not).

    Raises
    ------
    ArchiveError
    """
    import struct
    import zlib

    data = path.read_bytes()
    if len(data) < 2 * len(_MAGIC) + 29 or data[:8] != _MAGIC or data[-8:] != _MAGIC:
        raise ArchiveError(f"{path}: not a complete MCAP file (magic bytes missing at the start or end)")
    foot = len(data) - 8 - 29
    op, length, summary_start, offset_start, summary_crc = struct.unpack_from("<BQQQI", data, foot)
    if op != 0x02 or length != 20 or not (0 < summary_start <= foot) or offset_start > foot:
        raise ArchiveError(f"{path}: damaged footer (no summary section where the footer points)")
    if summary_crc:
        crc = zlib.crc32(data[foot:foot + 25], zlib.crc32(data[summary_start:foot]))
        if crc != summary_crc:
            raise ArchiveError(f"{path}: summary section CRC mismatch (the file was changed after it was written)")
    end = summary_start - 13
    if end < 8 or data[end] != 0x0F:
        raise ArchiveError(f"{path}: damaged file (no DataEnd record before the summary)")
    (data_crc,) = struct.unpack_from("<I", data, end + 9)
    if data_crc and zlib.crc32(data[:end]) != data_crc:
        raise ArchiveError(f"{path}: data section CRC mismatch (the file was changed after it was written)")
    return data_crc != 0


def read_archive(path: str | Path) -> Archive:
    """Read and check one archive (format 3, or 2 written before).

    Checks: the MCAP magic, the data-section and summary CRCs (:func:`check_file_crcs`), chunk
    CRCs, a summary section (the writer finished), the ``run``
    metadata and its required fields, every ``/ik/solve`` message against its schema (columns of
    ``count`` values), and the number of solve records against the metadata's problem count
    (``problems`` x ``repetitions``), so that a damaged file never reads as fewer solves.

    Raises
    ------
    ArchiveError
        One line naming the file and what is wrong.
    """
    from mcap.reader import make_reader

    path = Path(path)
    if not path.is_file():
        raise ArchiveError(f"{path}: no such archive")
    try:
        with open(path, "rb") as fh:
            if fh.read(8) != _MAGIC:
                raise ArchiveError(f"{path}: not an MCAP file (bad magic)")
        has_data_crc = check_file_crcs(path)
        with open(path, "rb") as fh:
            fh.seek(0)
            reader = make_reader(fh, validate_crcs=True)  # chunk CRCs checked on every read
            summary = reader.get_summary()
            if summary is None:
                raise ArchiveError(f"{path}: truncated archive (no summary section; the job did not finish)")
            meta = None
            for rec in reader.iter_metadata():
                if rec.name == "run":
                    meta = dict(rec.metadata)
    except ArchiveError:
        raise
    except Exception as exc:
        raise ArchiveError(f"{path}: corrupt or truncated archive ({type(exc).__name__}: {exc})") from None
    if meta is None:
        raise ArchiveError(f"{path}: not an ik-pipeline archive (no 'run' metadata record)")
    for key in REQUIRED_META:
        if key not in meta:
            raise ArchiveError(f"{path}: metadata field '{key}' missing")
    if meta["format_version"] not in READABLE_VERSIONS:
        raise ArchiveError(f"{path}: metadata field 'format_version' is {meta['format_version']!r}, this version "
                           f"reads {' and '.join(READABLE_VERSIONS)}")
    if meta["format_version"] == "3" and not has_data_crc:
        raise ArchiveError(f"{path}: no data-section CRC (every format-3 archive has one): not written by this package")
    solves: list[dict] = []
    for _, _, msg in _iter_messages(path, [SOLVE_TOPIC]):
        data = _loads(msg.data, path, SOLVE_TOPIC, msg.sequence)
        if meta["format_version"] == "2":
            solves.append(data)
        else:
            solves.extend(_expand(data, path, msg.sequence))
    probs, reps = str(meta.get("problems", "")), str(meta.get("repetitions", "1") or "1")
    if probs.isdigit() and reps.isdigit() and len(solves) != int(probs) * int(reps):
        raise ArchiveError(f"{path}: {len(solves)} solve records, metadata field 'problems' promises "
                           f"{int(probs) * int(reps)}")
    return Archive(path, meta, solves)
