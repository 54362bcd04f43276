"""Result archives: one MCAP file per solve job, zstd-compressed chunks (format version 5).

An archive stands on its own: everything a table, a figure, ``inspect`` or the report shows is read
from its bytes, the problem-set file it names and nothing else. Reading never imports or runs a
solver (this module imports nothing above :mod:`pipeline.robots`), so an archive reads the same on
any machine, whatever its CPU or BLAS. Re-running the solves of an archive is a separate act,
``python -m pipeline reproduce`` (:mod:`pipeline.jobs.reproduce`), whose differences are findings,
never read errors.

Channels (all protobuf, schemas written into the file as FileDescriptorSets, so any MCAP reader
with ``protobuf`` decodes them without this package; the README shows how)
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
across the three channels (:class:`_Structure`): a solve is one (labels, problem id, repetition) of
the file, traces and solutions belong to the solves of their batch, once each, and solution counts
are the solves' ``n_solutions``. A file past a cap or with a broken structure is one
:class:`ArchiveError` line naming it and the cap or field.

Quaternions are w-first everywhere in the library; in records, and only there, the goal
orientation is x, y, z, w (Foxglove ``Pose`` style).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator
from zlib import crc32 as _crc32

import numpy as np

from pipeline.io.layout import TRACE_COLS

FORMAT_VERSION = "5"
BATCH = 1000  # solves per /ik/solve, /ik/trace and /ik/solutions message
SOLVE_TOPIC = "/ik/solve"
TRACE_TOPIC = "/ik/trace"
SOLUTIONS_TOPIC = "/ik/solutions"
REQUIRED_META = ("format_version", "study", "robot", "solver", "settings", "settings_hash", "seed",
                 "package_version", "git_commit")

# ---- protobuf, written by hand (packed fixed-width fields: numpy bytes; string fields) ---------
# (field number, name, numpy dtype, protobuf type: 15 sfixed32, 7 fixed32, 6 fixed64, 1 double, 2 float,
# 9 string). Every repeated field is packed (proto3); a string field is singular.
TRACE_FIELDS = (
    (1, "problem_id", "<i4", 15), (2, "repetition", "<i4", 15),
    (3, "rows", "<u4", 7),       # per trace: its row count
    (4, "error", "<f8", 1),      # per stored row: the method's own (stop-test) error
    (5, "position_error", "<f8", 1),  # per stored row: |dp| [length_unit]
    (6, "error_vector", "<f4", 2),    # per stored row: e = (v, omega), 6 values
    (7, "digest", "<u4", 7),     # per trace: CRC-32 of its float64 rows (:func:`digest`), stored or not
    (8, "stored", "<u4", 7),     # per trace: 1 = its rows are in this message
    (9, "absent", "<u4", 7))     # per stored row: bit k = column k of TRACE_COLUMNS absent (written 0)
TRACE_MESSAGE = "ik_pipeline.TraceBatch"

SOLUTION_FIELDS = (
    (1, "problem_id", "<i4", 15), (2, "repetition", "<i4", 15),
    (3, "count", "<u4", 7),      # per solve: number of solutions
    (4, "joints", "<u4", 7),     # one value: joints per row
    (5, "solutions", "<f8", 1),  # rows of joint values, count rows per solve
    (6, "absent", "<u8", 6))     # per row (only when a value was non-finite): bit k = joint k absent
SOLUTION_MESSAGE = "ik_pipeline.SolutionBatch"

# flags of a solve (SolveBatch.flags)
F_SUCCESS, F_CLAIMED, F_WITHIN, F_START_FROM_FILE = 1, 2, 4, 8
F_NO_INITIAL, F_NO_FINAL, F_NO_POSITION, F_NO_ORIENTATION, F_NO_Q = 16, 32, 64, 128, 256
F_NO_START, F_NO_GOAL = 1024, 2048  # (512 was format 4's "solutions stored here")
_ABSENT = {"initial_error": F_NO_INITIAL, "final_error": F_NO_FINAL, "position_error": F_NO_POSITION,
           "orientation_error": F_NO_ORIENTATION}
SOLVE_FIELDS = (
    (1, "problem_id", "<i4", 15), (2, "repetition", "<i4", 15), (3, "chain", "<i4", 15),
    (4, "stop_reason", "<i4", 15), (5, "iterations", "<i4", 15),
    (6, "flags", "<u4", 7),            # F_* bits above
    (7, "solve_time_ns", "<u8", 6), (8, "ik_time_ns", "<u8", 6), (9, "call_time_ns", "<u8", 6),
    (10, "initial_error", "<f8", 1), (11, "final_error", "<f8", 1),
    (12, "position_error", "<f8", 1), (13, "orientation_error", "<f8", 1),
    (14, "q_solution", "<f8", 1),      # count x joints
    (15, "q_start", "<f8", 1),         # joints values of each solve whose start is not the problem file's
    (16, "goal_position", "<f8", 1),   # count x 3, only in archives without a problem file
    (17, "goal_orientation", "<f8", 1),  # count x 4 (x, y, z, w), idem
    (18, "n_solutions", "<i4", 15),    # analytic methods: number of solutions (on /ik/solutions)
    (21, "joints", "<u4", 7),          # one value: joints per row
    (22, "info_json", None, 9),        # strict JSON array of the solves' info objects
    (23, "labels_json", None, 9),      # only when a solve's robot/solver/method/length_unit is not the
                                       # metadata's: strict JSON object of per-solve string columns
    (24, "cpu_time_ns", "<u8", 6))     # per solve, when measured: CPU time of the call (pipeline.runner);
                                       # absent in archives written before it
SOLVE_MESSAGE = "ik_pipeline.SolveBatch"
MESSAGES = {SOLVE_TOPIC: (SOLVE_MESSAGE, SOLVE_FIELDS, "ik_pipeline/solve_batch.proto"),
            TRACE_TOPIC: (TRACE_MESSAGE, TRACE_FIELDS, "ik_pipeline/trace_batch.proto"),
            SOLUTIONS_TOPIC: (SOLUTION_MESSAGE, SOLUTION_FIELDS, "ik_pipeline/solution_batch.proto")}


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


def _descriptor(message: str, fields, file: str) -> bytes:
    """The FileDescriptorSet of one proto3 message of packed repeated scalars (and singular strings)."""
    body = b"".join(_ld(2, _ld(1, name.encode()) + _vf(3, num) + _vf(4, 1 if ptype == 9 else 3) + _vf(5, ptype)
                          + _ld(10, "".join(w.title() if i else w for i, w in enumerate(name.split("_"))).encode()))
                    for num, name, _, ptype in fields)
    pkg, short = message.split(".")
    msg = _ld(1, short.encode()) + body
    return _ld(1, _ld(1, file.encode()) + _ld(2, pkg.encode()) + _ld(4, msg) + _ld(12, b"proto3"))


def descriptor(topic: str) -> bytes:
    """The FileDescriptorSet of the message on ``topic`` (:data:`MESSAGES`)."""
    message, fields, file = MESSAGES[topic]
    return _descriptor(message, fields, file)


def _encode(fields, values: dict) -> bytes:
    out = []
    for num, name, dt, ptype in fields:
        v = values.get(name)
        if v is None:
            continue
        if ptype == 9:
            out.append(_ld(num, v if isinstance(v, bytes) else str(v).encode()))
        elif len(v):
            out.append(_ld(num, np.ascontiguousarray(v, dtype=dt).tobytes()))
    return b"".join(out)


def _decode(fields, data: bytes) -> dict:
    """Inverse of :func:`_encode`; raises ValueError on anything it did not write."""
    by_num = {f[0]: f for f in fields}
    out = {name: (b"" if ptype == 9 else np.zeros(0, dtype=dt)) for _, name, dt, ptype in fields}
    pos = 0
    while pos < len(data):
        key, pos = _read_varint(data, pos)
        num, wt = key >> 3, key & 7
        if num not in by_num or wt != 2:
            raise ValueError(f"unexpected field {num} (wire type {wt})")
        size, pos = _read_varint(data, pos)
        if pos + size > len(data):
            raise ValueError(f"field {num} runs past the message")
        _, name, dt, ptype = by_num[num]
        if ptype == 9:
            out[name] = bytes(data[pos:pos + size])
        else:
            if size % np.dtype(dt).itemsize:
                raise ValueError(f"field {name}: {size} bytes is not a whole number of values")
            out[name] = np.frombuffer(data, dtype=dt, count=size // np.dtype(dt).itemsize, offset=pos)
        pos += size
    return out


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




_F8 = np.dtype("<f8")


def digest(a) -> int:
    """CRC-32 of an array's float64 values in C order: how ``reproduce`` compares a re-run trace with
    the archived one. A check of a deterministic re-run, not a defence against forgery: 32 bits miss
    a difference with probability 2**-32 and cost 4 bytes per solve."""
    if not (type(a) is np.ndarray and a.dtype == _F8 and a.flags.c_contiguous):
        a = np.ascontiguousarray(a, dtype=_F8)
    return _crc32(a)  # the array's buffer, no copy


class ArchiveError(ValueError):
    """An archive is missing, corrupt, truncated or not ours (one-line message naming the file)."""


class TraceNotStored(ArchiveError):
    """The archive holds the digest of a trace but not its rows (its trace policy left them out)."""


@dataclass(frozen=True)
class TracePolicy:
    """Which per-iteration traces an archive stores in full (every trace's digest is always stored).

    Attributes
    ----------
    mode : {"sample", "all", "none"}
    sample : int
        ``sample`` mode: problems of a deterministic sample, evenly spaced over the set's problem
        ids (:meth:`sample_ids`); their repetition-0 traces are stored.
    failed_rows : int
        ``sample`` mode: the traces of failed solves are stored too, in solve order, while their
        rows fit this per-archive budget [rows] (a trace that does not fit is skipped).
    """

    mode: str = "sample"
    sample: int = 200
    failed_rows: int = 20_000

    MODES = ("sample", "all", "none")

    @classmethod
    def from_setting(cls, value, where: str = "trace_policy") -> "TracePolicy":
        """``"all"``, ``"none"``, or a mapping ``{sample: int, failed_rows: int}`` (missing keys: defaults)."""
        if value is None:
            return cls()
        if isinstance(value, str):
            if value not in ("all", "none"):
                raise ValueError(f"{where}: {value!r} is not all, none or a mapping of sample and failed_rows")
            return cls(mode=value)
        if not isinstance(value, dict) or set(value) - {"sample", "failed_rows"}:
            raise ValueError(f"{where}: expected all, none or a mapping with keys sample and failed_rows")
        kw = {}
        for k, v in value.items():
            if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= 10_000_000:
                raise ValueError(f"{where}/{k}: {v!r} is not an integer from 0 to 10000000")
            kw[k] = v
        return cls(**kw)

    def as_json(self) -> str:
        return json.dumps({"mode": self.mode, "sample": self.sample, "failed_rows": self.failed_rows}, sort_keys=True)

    @classmethod
    def from_json(cls, text: str) -> "TracePolicy":
        d = json.loads(text)
        return cls(mode=d["mode"], sample=int(d["sample"]), failed_rows=int(d["failed_rows"]))

    def describe(self) -> str:
        if self.mode != "sample":
            return {"all": "every trace stored", "none": "no trace stored (digests only)"}[self.mode]
        return (f"the traces of {self.sample} problems evenly spaced over the set, and of failed solves up to "
                f"{self.failed_rows} rows per archive; digests of all")

    def sample_ids(self, problem_ids) -> set[int]:
        """The sample: ``sample`` ids evenly spaced over the sorted ``problem_ids`` (all when fewer)."""
        ids = np.unique(np.asarray(problem_ids, dtype=np.int64))
        if self.mode == "none" or (self.mode == "sample" and self.sample == 0):
            return set()
        if self.mode == "all" or len(ids) <= self.sample:
            return set(ids.tolist())
        pick = np.unique(np.round(np.linspace(0, len(ids) - 1, self.sample)).astype(np.int64))
        return set(ids[pick].tolist())


def run_metadata(*, study: str, robot: str, solver: str, settings: dict, seed="-", **fields) -> dict[str, str]:
    """The ``run`` metadata record of an archive, built in one place for every writer.

    ``settings`` (a JSON-able dict) is stored as sorted JSON with its SHA-256 prefix as
    ``settings_hash`` unless ``fields`` gives one; ``fields`` adds any other string fields (problem
    file, robot file, scale, ...). Format version, package version, git commit and the environment
    (:func:`pipeline.provenance.environment`) are filled in here.
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
    """An MCAP file written atomically: data go to ``<path>.partial`` (zstd chunks, data CRCs), which
    is renamed to ``path`` only when :meth:`close` has written the summary; :meth:`abort` (or an
    exception inside ``with``) removes it. The base of every MCAP writer here."""

    def __init__(self, path: str | Path, library: str):
        from mcap.writer import CompressionType, Writer

        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.partial = self.path.with_name(self.path.name + ".partial")
        self._fh = open(self.partial, "wb")
        self._w = Writer(self._fh, compression=CompressionType.ZSTD, enable_data_crcs=True)
        self._w.start(profile="", library=library)

    def close(self) -> None:
        self._w.finish()
        self._fh.close()
        os.replace(self.partial, self.path)

    def abort(self) -> None:
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
    problem_ids : array of int, optional
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
        """Register an extra JSON channel (e.g. measurements that are not IK solves)."""
        sid = self._w.register_schema(schema.get("title", topic), "jsonschema", json.dumps(schema).encode())
        self._extra[topic] = self._w.register_channel(topic, "json", sid)

    def _add(self, channel: int, data: bytes) -> None:
        t = self._clock
        self._w.add_message(channel, log_time=t, publish_time=t, sequence=self._seq, data=data)
        self._seq += 1

    def write_message(self, topic: str, record: dict) -> None:
        """Append one JSON record on a channel registered with :meth:`add_channel` (NaN -> null)."""
        self._add(self._extra[topic], _dumps(record))

    def write_columns(self, cols: dict, traces: dict | None = None) -> None:
        """Append a batch of solves given as columns (:func:`batch_columns`), in messages of :data:`BATCH`.

        ``traces``: ``problem_id``, ``repetition``, ``rows`` (per solve with a trace) and ``full``
        (per row the :data:`~pipeline.io.layout.TRACE_COLUMNS`, float64, shape (m, 8)), or None.
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
        self._add(self._ch[SOLVE_TOPIC], _encode(SOLVE_FIELDS, _solve_message(cols, count, self.inline_goals,
                                                                              self.meta)))
        if cols.get("solutions") is not None:
            self._add(self._ch[SOLUTIONS_TOPIC], _encode(SOLUTION_FIELDS, _solution_message(cols, count)))
        if traces is not None and len(traces["problem_id"]):
            keep = self._keep(traces)
            rows = np.asarray(traces["rows"], dtype=np.int64)
            c = self._count
            c["traces"] += len(rows)
            c["stored"] += int(keep.sum())
            c["rows"] += int(rows.sum())
            c["rows_stored"] += int(rows[keep].sum())
            self._add(self._ch[TRACE_TOPIC], _encode(TRACE_FIELDS, _trace_message(traces, keep)))

    job_timing: dict | None = None  # set by the job before closing: written as the ``job_timing`` record

    def close(self) -> None:
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


_LABELS = ("robot", "solver", "method", "length_unit")


def _solve_message(cols: dict, count: int, inline_goals: bool, meta: dict | None = None) -> dict:
    """The fields of one ``SolveBatch`` from the columns of ``count`` solves."""
    import orjson

    b = lambda k: np.asarray(cols[k], dtype=bool)  # noqa: E731
    flags = b("success") * F_SUCCESS | b("claimed_success") * F_CLAIMED | b("within_limits") * F_WITHIN
    out = {}
    for k, bit in _ABSENT.items():
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
              for k in _LABELS if k in cols and cols[k] is not None}
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
    full = np.ascontiguousarray(np.asarray(tr["full"], dtype=float).reshape(-1, TRACE_COLS), dtype=_F8)
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

    ``res`` is a :class:`pipeline.solvers.BatchResult` (read by its fields only: this module does not
    import the solvers). ``goal_position`` (N, 3) must be in ``length_unit``; ``goal_quat_wxyz`` (N, 4).
    ``start_from_file`` (N,) bool: the start is the problem file's (not stored when the archive
    names its problem file). ``robot``, ``solver`` and ``method`` are the metadata's (stored per
    solve only where they differ from it).
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


def goal_from_record(goal: dict) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of the goal encoding of a record: (position (3,), quaternion w-first (4,))."""
    p, o = goal["position"], goal["orientation"]
    return np.array([p["x"], p["y"], p["z"]]), np.array([o["w"], o["x"], o["y"], o["z"]])


def decode(topic: str, data: bytes) -> dict[str, np.ndarray]:
    """One protobuf message of ``topic`` as its fields (numpy arrays; string fields as bytes)."""
    return _decode(MESSAGES[topic][1], data)


@dataclass
class Archive:
    """An archive read back: metadata and one record per solve; traces and solutions read on demand.

    Attributes
    ----------
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
        """Solve records as a pandas DataFrame (vectors kept as lists; private ``_`` keys left out)."""
        import pandas as pd

        df = pd.DataFrame(self.solves)
        return df.drop(columns=[c for c in df.columns if str(c).startswith("_")])

    def messages(self, topic: str) -> Iterator[dict]:
        """Yield the decoded JSON records of a JSON channel (e.g. a study's measurement channel)."""
        for _, _, msg in _iter_messages(self.path, [topic]):
            yield _loads(msg.data, self.path, topic, msg.sequence)

    def _batches(self, topic: str, decode) -> Iterator[dict]:
        """The messages of ``topic`` decoded by ``decode``; a damaged one is a one-line ArchiveError."""
        for _, _, msg in _iter_messages(self.path, [topic]):
            try:
                yield decode(msg.data)
            except ValueError as exc:
                raise ArchiveError(f"{self.path}: message {msg.sequence} on {topic}: {exc}") from None

    def trace_index(self) -> dict:
        """``(problem_id, repetition) -> (rows, digest, stored rows as a (rows, 8) float64 array or None)``."""
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
        """The ``(problem_id, repetition)`` keys whose trace rows this archive holds."""
        return {k for k, v in self.trace_index().items() if v[2] is not None}

    def records(self) -> dict:
        """``(problem_id, repetition) -> solve record``."""
        if self._by_key is None:
            self._by_key = {(r["problem_id"], r.get("repetition", 0)): r for r in self.solves}
        return self._by_key

    def traces(self, problem_ids=None) -> Iterator[dict]:
        """Yield stored trace records ``{problem_id, repetition, error, error_vector, position_error}`` (lists).

        Without ``problem_ids``: every stored trace. With them: the traces of those problems, and a
        :class:`TraceNotStored` error for one whose trace the archive does not hold (never a re-run).
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
        """The one-line answer for a trace this archive does not hold."""
        s = self.trace_summary
        held = f"it holds {s.get('stored', '?')} of {s.get('traces', '?')} traces: {s.get('policy', 'unknown policy')}"
        return TraceNotStored(f"{self.path}: problem {problem_id} (repetition {repetition}): trace not stored ({held}); "
                              f"`python -m pipeline reproduce {self.path} --problem {problem_id}` re-runs it")

    def solutions(self, problem_id: int, repetition: int = 0) -> list | None:
        """Every solution an analytic method returned for one solve (rows of joint values); None for other methods."""
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


def _trace_batch(data: bytes) -> dict[str, np.ndarray]:
    """One ``TraceBatch`` decoded and checked; ``error_vector`` shaped (m, 6)."""
    out = _decode(TRACE_FIELDS, data)
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
    b = _decode(SOLUTION_FIELDS, data)
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


# ---- bounded reading ---------------------------------------------------------------------------------
# Every read of an archive is bounded before memory is spent: the file's size, each chunk's declared and
# actual uncompressed size, the sum over its chunks, and the solve records it may expand to. The caps
# are set from the largest archive of a full build (every study at full scale, 1 314 archives): 5.2 MiB
# on disk (cerbaro2019's Jacobian-transpose runs), 6.2 MiB uncompressed in all, 4.4 MiB in its largest
# chunk (a 1 000-solve /ik/trace batch of every_method's Nelder-Mead), 10 000 solve records (the
# 10 000-problem studies; 2 000 problems x 5 repetitions is the same). A file past a cap is refused in
# one line naming it and the cap (ArchiveError), never read further.
MAX_ARCHIVE_BYTES = 256 << 20       # the file on disk: ~50x the largest; it is held in memory while read
MAX_CHUNK_BYTES = 64 << 20          # one chunk decompressed (declared and actual): ~14x the largest
MAX_UNCOMPRESSED_BYTES = 1 << 30    # all chunks of a file decompressed: ~160x; bounds the time a read takes
MAX_SOLVES = 100_000                # solve records (and metadata 'problems' x 'repetitions'): 10x the
                                    # largest; a record costs ~3 kB of memory read back, so ~300 MB at most
_CHUNK, _MESSAGE, _DATA_END = 0x06, 0x05, 0x0F


def _mib(n: int) -> str:
    return f"{n >> 20} MiB" if n >= 1 << 20 and not n % (1 << 20) else f"{n} bytes"


def _file_bytes(path: Path) -> bytes:
    """The bytes of an archive, refused past :data:`MAX_ARCHIVE_BYTES` (checked before they are read)."""
    try:
        with open(path, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            data = b"" if size > MAX_ARCHIVE_BYTES else fh.read(MAX_ARCHIVE_BYTES + 1)  # one byte past the cap at most
    except OSError as exc:
        raise ArchiveError(f"{path}: cannot read archive ({exc.strerror or exc})") from None
    if size > MAX_ARCHIVE_BYTES or len(data) > MAX_ARCHIVE_BYTES:
        raise ArchiveError(f"{path}: {max(size, len(data))} bytes, past the {_mib(MAX_ARCHIVE_BYTES)} archive cap "
                           f"(MAX_ARCHIVE_BYTES); not read")
    return data


def _summary_reader(data: bytes):
    """An mcap reader over the bytes in memory (a record declaring more bytes than the file holds reads
    what there is: nothing is allocated for a declared length)."""
    import io

    from mcap.reader import SeekingReader

    return SeekingReader(io.BytesIO(data), validate_crcs=True, record_size_limit=MAX_CHUNK_BYTES)


def _unzstd(payload, size: int, where: str) -> bytes:
    """Decompress one chunk's zstd data to at most ``size`` bytes (its declared size, already within
    :data:`MAX_CHUNK_BYTES`) plus one: the output buffer is never sized from the data (a frame may declare
    any content size) and the window is bounded too."""
    import zstandard

    out = bytearray()
    try:
        dec = zstandard.ZstdDecompressor(max_window_size=MAX_CHUNK_BYTES)
        with dec.stream_reader(payload, read_across_frames=True) as r:
            while len(out) <= size:
                part = r.read(size + 1 - len(out))
                if not part:
                    break
                out += part
    except zstandard.ZstdError as exc:
        raise ArchiveError(f"{where}: damaged zstd data ({exc})") from None
    if len(out) > size:
        raise ArchiveError(f"{where}: decompresses past the {size} bytes its header declares (uncompressed_size)")
    return bytes(out)


@dataclass(frozen=True)
class _Msg:
    topic: str
    sequence: int
    log_time: int
    data: bytes


def _messages(path: Path, topics=None, data: bytes | None = None, summary=None) -> Iterator[_Msg]:
    """The messages of ``topics`` (all when None) in file order (the writer's order; its log times never
    decrease), each chunk read with the caps of this module and its CRC checked.

    mcap's own reader is used for the summary and metadata only: it sizes a chunk's output buffer from
    the chunk's declared uncompressed size, or the zstd frame's, before it decompresses."""
    import struct
    from zlib import crc32

    if data is None:
        data = _file_bytes(path)
    try:
        if summary is None:
            summary = _summary_reader(data).get_summary()
    except ArchiveError:
        raise
    except Exception as exc:  # noqa: BLE001  (mcap raises many types for corrupt data)
        raise ArchiveError(f"{path}: corrupt archive ({type(exc).__name__}: {exc})") from None
    if summary is None:
        raise ArchiveError(f"{path}: truncated archive (no summary section; the job did not finish)")
    channels = {cid: ch.topic for cid, ch in summary.channels.items()}
    want = {cid for cid, t in channels.items() if topics is None or t in topics}
    total = 0
    for ci in sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset):
        o = ci.chunk_start_offset
        where = f"{path}: chunk at byte {o}"
        if not 8 <= o <= len(data) - 9 - 40 or data[o] != _CHUNK:
            raise ArchiveError(f"{where}: the summary's chunk index points at no chunk record")
        (length,) = struct.unpack_from("<Q", data, o + 1)
        end = o + 9 + length
        if length < 40 or end > len(data):
            raise ArchiveError(f"{where}: record length {length} runs past the file")
        _, _, size, crc, clen = struct.unpack_from("<QQQII", data, o + 9)
        if size > MAX_CHUNK_BYTES:
            raise ArchiveError(f"{where}: declares {size} bytes uncompressed, past the {_mib(MAX_CHUNK_BYTES)} "
                               f"chunk cap (MAX_CHUNK_BYTES); not read")
        total += size
        if total > MAX_UNCOMPRESSED_BYTES:
            raise ArchiveError(f"{path}: chunks declare more than {_mib(MAX_UNCOMPRESSED_BYTES)} uncompressed, "
                               f"past the archive cap (MAX_UNCOMPRESSED_BYTES); not read")
        p = o + 9 + 32
        if p + clen + 8 > end:
            raise ArchiveError(f"{where}: record fields run past its length")
        compression = bytes(data[p:p + clen])
        p += clen
        (dlen,) = struct.unpack_from("<Q", data, p)
        p += 8
        if p + dlen > end:
            raise ArchiveError(f"{where}: compressed data runs past the record")
        payload = memoryview(data)[p:p + dlen]
        if compression == b"zstd":
            raw = _unzstd(payload, size, where)
        elif compression == b"":
            raw = bytes(payload)
        else:
            raise ArchiveError(f"{where}: compression {compression[:20]!r} (this package writes zstd)")
        if len(raw) != size:
            raise ArchiveError(f"{where}: decompresses to {len(raw)} bytes, its header declares {size}")
        if crc and crc32(raw) != crc:
            raise ArchiveError(f"{where}: CRC mismatch (the chunk's data changed after it was written)")
        pos = 0
        while pos < len(raw):
            if pos + 9 > len(raw):
                raise ArchiveError(f"{where}: a record header runs past the chunk")
            op, n = raw[pos], struct.unpack_from("<Q", raw, pos + 1)[0]
            body = pos + 9
            if body + n > len(raw):
                raise ArchiveError(f"{where}: a record of {n} bytes runs past the chunk")
            if op == _MESSAGE:
                if n < 22:
                    raise ArchiveError(f"{where}: a message record of {n} bytes")
                cid, seq, t, _ = struct.unpack_from("<HIQQ", raw, body)
                if cid not in channels:
                    raise ArchiveError(f"{where}: message {seq} on channel {cid}, which the summary does not name")
                if cid in want:
                    yield _Msg(channels[cid], seq, t, raw[body + 22:body + n])
            pos = body + n


def _iter_messages(path: Path, topics):
    """``(None, None, message)`` of ``topics``, as :func:`_messages` reads them (message: ``.sequence``, ``.data``)."""
    for m in _messages(path, topics):
        yield None, None, m


def _expand(data: bytes, meta: dict, path: Path, seq: int, problems, room: int = MAX_SOLVES,
            want: int | None = None, keys: list | None = None) -> list[dict]:
    """One ``SolveBatch`` message -> per-solve records; ``room``: how many more records the archive may
    hold (refused before a record is built past it); ``want``: the count the metadata promises, if any;
    ``keys``: a list given to be filled with the records' problem ids, repetitions, label tuples and
    numbers of solutions (None without ``n_solutions``), for :class:`_Structure`."""
    import orjson

    where = f"{path}: message {seq} on {SOLVE_TOPIC}"
    try:
        b = _decode(SOLVE_FIELDS, data)
    except ValueError as exc:
        raise ArchiveError(f"{where}: not a SolveBatch ({exc})") from None
    n = len(b["problem_id"])
    if n > BATCH:
        raise ArchiveError(f"{where}: field 'problem_id' holds {n} solves, a message holds at most {BATCH}")
    if n > room:
        raise ArchiveError(f"{where}: more solve records than metadata field 'problems' promises ({want})" if want
                           is not None else f"{where}: more than {MAX_SOLVES} solve records (MAX_SOLVES); not read")
    for k in ("repetition", "chain", "stop_reason", "iterations", "flags", "solve_time_ns", "ik_time_ns",
              "call_time_ns", *_ABSENT):
        if len(b[k]) != n:
            raise ArchiveError(f"{where}: field '{k}' holds {len(b[k])} values for {n} solves")
    if len(b["joints"]) != 1 or b["joints"][0] < 1 or len(b["q_solution"]) != n * int(b["joints"][0]):
        raise ArchiveError(f"{where}: field 'q_solution' does not hold {n} rows of 'joints' values")
    j = int(b["joints"][0])
    flags = b["flags"].astype(np.int64)
    from_file = (flags & F_START_FROM_FILE) != 0
    q0 = b["q_start"]
    if len(q0) != int((~from_file).sum()) * j:
        raise ArchiveError(f"{where}: field 'q_start' holds {len(q0)} values, the flags promise {int((~from_file).sum()) * j}")
    try:
        info = orjson.loads(b["info_json"]) if b["info_json"] else [{}] * n
    except ValueError as exc:
        raise ArchiveError(f"{where}: field 'info_json' is not JSON ({exc})") from None
    if not isinstance(info, list) or len(info) != n or not all(isinstance(x, dict) for x in info):
        raise ArchiveError(f"{where}: field 'info_json' is not a list of {n} objects")
    q = b["q_solution"].reshape(n, j).astype(float)
    q[(flags & F_NO_Q) != 0] = np.nan
    errs = {}
    for k, bit in _ABSENT.items():
        errs[k] = np.where((flags & bit) != 0, np.nan, b[k]).tolist()
    pid = b["problem_id"].tolist()
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
    ns = b["n_solutions"]
    if len(ns) not in (0, n):
        raise ArchiveError(f"{where}: field 'n_solutions' does not hold one value per solve")
    fixed = {k: meta.get(k, "") for k in _LABELS}
    labels = None
    if b["labels_json"]:
        try:
            labels = orjson.loads(b["labels_json"])
        except ValueError as exc:
            raise ArchiveError(f"{where}: field 'labels_json' is not JSON ({exc})") from None
        if not isinstance(labels, dict) or any(k not in _LABELS or not isinstance(v, list) or len(v) != n
                                               or not all(isinstance(x, str) for x in v) for k, v in labels.items()):
            raise ArchiveError(f"{where}: field 'labels_json' is not an object of {n}-value label columns (strings)")
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
        fixed_key = tuple(fixed[k] for k in _LABELS)
        if labels:
            cols = [labels.get(k) or [fixed[k]] * n for k in _LABELS]
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


_PROBLEM_CACHE: dict = {}


# What a file named by an archive's metadata may be: the archive is read from anywhere, so its
# metadata must not make a verb read any other file (``/proc/self/environ``, ``~/.ssh/id_rsa``): a
# problem set is a ``.csv``/``.csv.gz`` file named relative to the archive (as the writer records it),
# a robot file a ``.yaml`` file in a ``robots`` folder (``data/robots/<name>.yaml``).
NAMED_FILES = {"problem_path": (None, (".csv", ".csv.gz")), "robot_path": ("robots", (".yaml", ".yml")),
               "robot_file": ("robots", (".yaml", ".yml"))}


def named_file(path: Path, meta: dict, field: str) -> Path | None:
    """The file the metadata ``field`` of archive ``path`` names (relative to the archive's folder, or as
    written for ``robot_file``), resolved; None when the field is empty. Raises :class:`ArchiveError` when
    it names anything but what :data:`NAMED_FILES` allows (a problem set: a ``.csv``/``.csv.gz`` path
    relative to the archive; a robot file: a ``.yaml`` file in a ``robots`` folder): such a file is never
    opened."""
    value = meta.get(field)
    if not value or value == "-":
        return None
    folder, suffixes = NAMED_FILES[field]
    text = str(value)
    rel = Path(text)
    if "\0" in text or len(text) > 4096 or (rel.is_absolute() and field != "robot_file"):
        raise ArchiveError(f"{path}: metadata field '{field}': {text[:120]!r} is not a path relative to the archive; "
                           f"not read (give the file with --{'problems' if field == 'problem_path' else 'robot'})")
    target = (rel if field == "robot_file" else Path(path).parent / rel).resolve()
    if not target.name.endswith(suffixes) or (folder and folder not in target.parent.parts):
        where = f" in a '{folder}' folder" if folder else ""
        raise ArchiveError(f"{path}: metadata field '{field}': {text[:120]!r} is not a {' or '.join(suffixes)} file"
                           f"{where}; not read (give the file with --{'problems' if field == 'problem_path' else 'robot'})")
    return target


def _problems_of(path: Path, meta: dict, given: str | Path | None = None):
    """The problem file an archive names (or ``given``): (problem id -> row, ProblemSet, goal length
    scale), or None for an archive that stores its goals.

    Raises ArchiveError when it is named but missing, changed (SHA-256) or not the archive's robot's.
    """
    rel = meta.get("problem_path")
    if not rel:
        return None
    from pipeline.io.problems import load_problems
    from pipeline.robots import LENGTH_UNITS

    pf = Path(given).resolve() if given else named_file(path, meta, "problem_path")
    if not pf.is_file():
        where = f"--problems {given}: no such file" if given else f"problem file {rel} not found next to the archive"
        raise ArchiveError(f"{path}: metadata field 'problem_path': {where} (the archive stores no goals of its own: "
                           f"keep it in its results tree, or give its problem set {meta.get('problem_file', '')} "
                           f"with --problems FILE)")
    st = pf.stat()
    key = (str(pf), st.st_mtime_ns, st.st_size)
    hit = _PROBLEM_CACHE.get(key)
    if hit is None:
        try:  # within the problem-file caps (pipeline.io.problems): a gzip bomb is refused, never inflated
            ps, _, sha = load_problems(pf)
        except ValueError as exc:  # ProblemFileError: one line naming the problem file
            raise ArchiveError(f"{str(exc).splitlines()[0]} (the problem set of archive {path})") from None
        except (OSError, EOFError) as exc:
            raise ArchiveError(f"{pf}: unreadable problem file ({type(exc).__name__}: {exc}) (the problem set of "
                               f"archive {path})") from None
        hit = _PROBLEM_CACHE[key] = (sha, ps, {int(p): i for i, p in enumerate(ps.problem_id.tolist())})
    sha, ps, rows = hit
    want = meta.get("problem_sha256", "")
    if not want or not sha.startswith(want):
        raise ArchiveError(f"{pf}: SHA-256 {sha[:16]}, but archive {path} recorded {want!r} (metadata field "
                           f"'problem_sha256'): the problem file changed after the archive was written")
    unit = meta.get("length_unit") or ps.length_unit
    if unit not in LENGTH_UNITS:
        raise ArchiveError(f"{path}: metadata field 'length_unit': unknown unit {unit!r}")
    return rows, ps, LENGTH_UNITS[ps.length_unit] / LENGTH_UNITS[unit]


def problems_of(arch: "Archive", given: str | Path | None = None):
    """The problem set an archive names, checked: ``(problem id -> row, ProblemSet, goal length scale)`` or None."""
    return _problems_of(arch.path, arch.metadata, given)


_MAGIC = b"\x89MCAP0\r\n"


def check_file_crcs(path: Path, data: bytes | None = None) -> bool:
    """Check the whole file against the CRCs the writer stored: the data section's (DataEnd record:
    every byte from the start to the summary, metadata included) and the summary's (Footer).

    Each chunk's own CRC is checked when it is read (:func:`_messages`); these two cover the rest, so a
    changed byte anywhere (an edited metadata value, a flipped bit in a record header) is caught.
    ``data``: the file's bytes when the caller holds them (else read within :data:`MAX_ARCHIVE_BYTES`).

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

    data = _file_bytes(path) if data is None else data
    if len(data) < 2 * len(_MAGIC) + 29 or data[:8] != _MAGIC or data[-8:] != _MAGIC:
        raise ArchiveError(f"{path}: not a complete MCAP file (magic bytes missing at the start or end)")
    foot = len(data) - 8 - 29
    op, length, summary_start, offset_start, summary_crc = struct.unpack_from("<BQQQI", data, foot)
    if op != 0x02 or length != 20 or not (0 < summary_start <= foot) or offset_start > foot:
        raise ArchiveError(f"{path}: damaged footer (no summary section where the footer points)")
    view = memoryview(data)
    if summary_crc:
        crc = zlib.crc32(view[foot:foot + 25], zlib.crc32(view[summary_start:foot]))
        if crc != summary_crc:
            raise ArchiveError(f"{path}: summary section CRC mismatch (the file was changed after it was written)")
    end = summary_start - 13
    if end < 8 or data[end] != _DATA_END:
        raise ArchiveError(f"{path}: damaged file (no DataEnd record before the summary)")
    (data_crc,) = struct.unpack_from("<I", data, end + 9)
    if data_crc and zlib.crc32(view[:end]) != data_crc:
        raise ArchiveError(f"{path}: data section CRC mismatch (the file was changed after it was written)")
    return data_crc != 0


def archive_metadata(path: str | Path) -> dict[str, str]:
    """The ``run`` metadata record of an MCAP file, unchecked ({} when there is none or the file
    cannot be read): for naming what a file is after :func:`read_archive` refused it.

    Read within :data:`MAX_ARCHIVE_BYTES`, by a linear pass over the file's records that never
    decompresses a chunk (a truncated file's metadata is still found)."""
    import io

    from mcap.records import Metadata
    from mcap.stream_reader import StreamReader

    try:
        data = _file_bytes(Path(path))
        for r in StreamReader(io.BytesIO(data), emit_chunks=True, record_size_limit=MAX_ARCHIVE_BYTES).records:
            if isinstance(r, Metadata) and r.name == "run":
                return dict(r.metadata)
    except Exception:  # noqa: BLE001  (any damage: nothing to name)
        pass
    return {}


def _json_object(meta: dict, key: str, path: Path) -> None:
    import orjson

    if key in meta:
        try:
            ok = isinstance(orjson.loads(meta[key]), dict)
        except ValueError:
            ok = False
        if not ok:
            raise ArchiveError(f"{path}: metadata field '{key}' is not a JSON object")


def _check_metadata(path: Path, meta: dict, traces: dict, timing: dict) -> int | None:
    """The types of the metadata fields a reader relies on; returns the solve records the ``run``
    record promises (``problems`` x ``repetitions``), or None for an archive without a count
    (a measurement archive: ``problems`` is ``-`` or absent).

    Raises
    ------
    ArchiveError
        One line naming the file and the field.
    """
    for key in ("settings", "environment"):
        _json_object(meta, key, path)
    if "trace_policy" in meta:
        try:
            TracePolicy.from_json(meta["trace_policy"])
        except (ValueError, TypeError, KeyError):
            raise ArchiveError(f"{path}: metadata field 'trace_policy' is not a trace policy (JSON object of "
                               f"mode, sample and failed_rows)") from None
    seed = str(meta.get("seed", "-"))
    if seed != "-" and not (seed.lstrip("-").isdigit() and len(seed) <= 20):
        raise ArchiveError(f"{path}: metadata field 'seed' is {seed[:40]!r}, not an integer or '-'")
    sha = meta.get("problem_sha256", "")
    if meta.get("problem_path") and not (0 < len(sha) <= 64 and all(c in "0123456789abcdef" for c in sha)):
        raise ArchiveError(f"{path}: metadata field 'problem_sha256' is {sha[:40]!r}, not a hexadecimal SHA-256 prefix")
    for k, v in traces.items():
        if k != "policy" and not (v.isdigit() and len(v) <= 15):
            raise ArchiveError(f"{path}: metadata record 'traces': field '{k}' is {v[:40]!r}, not a count")
    for k, v in timing.items():
        try:
            float(v)
        except ValueError:
            raise ArchiveError(f"{path}: metadata record 'job_timing': field '{k}' is {v[:40]!r}, "
                               "not a number") from None
    probs, reps = str(meta.get("problems", "-")), str(meta.get("repetitions", "1") or "1")
    if probs != "-" and not probs.isdigit():
        raise ArchiveError(f"{path}: metadata field 'problems' is {probs[:40]!r}, not a count (or '-')")
    if not reps.isdigit() or int(reps) < 1:
        raise ArchiveError(f"{path}: metadata field 'repetitions' is {reps[:40]!r}, not a positive count")
    if probs == "-":
        return None
    want = int(probs) * int(reps)
    if want > MAX_SOLVES:
        raise ArchiveError(f"{path}: metadata fields 'problems' x 'repetitions' promise {want} solve records, past "
                           f"the {MAX_SOLVES} an archive may hold (MAX_SOLVES); not read")
    return want


class _Structure:
    """The cross-channel checks of :func:`read_archive`, fed message by message in file order.

    The writer emits per batch one ``/ik/solve`` message, then (analytic methods) one
    ``/ik/solutions`` message for the same solves and (with traces) one ``/ik/trace`` message for
    some of them. So: a solve is one (labels, problem id, repetition) of the archive, at most once
    (the labels -- robot, solver, method, length unit -- are the metadata's unless ``labels_json``
    gives a solve its own); a solutions message lists exactly the solves of the solve message before
    it, in its order, with the counts its ``n_solutions`` field gives, and a solve message with
    ``n_solutions`` has one; a trace message lists each of its traces once, each a solve of the solve
    message before it; no solve has two traces or two solution lists.
    """

    def __init__(self, path: Path):
        self.path = path
        self.solved: dict = {}   # labels -> {(problem id, repetition)} of every solve so far
        self.traced: dict = {}   # idem, with a trace
        self.listed: dict = {}   # idem, with solutions
        self.batch: dict | None = None  # (problem id, repetition) -> labels, of the last solve message
        self.batch_ids = None
        self.pending_solutions = False

    def _fail(self, msg, text: str):
        raise ArchiveError(f"{self.path}: message {msg.sequence} on {msg.topic}: {text}")

    def _end_batch(self, msg=None) -> None:
        if self.pending_solutions:
            where = f"message {msg.sequence} on {msg.topic}" if msg is not None else "the end of the file"
            raise ArchiveError(f"{self.path}: the {SOLVE_TOPIC} message before {where} has field 'n_solutions' but "
                               f"no {SOLUTIONS_TOPIC} message: counts differ across channels")

    def _add(self, msg, seen: dict, pairs: list, labels: list, what: str) -> None:
        """Record ``pairs`` (with their ``labels``) in ``seen``; a pair met twice is one line."""
        if len(set(labels)) == 1:  # every solve of the message has the same labels: set operations
            have = seen.setdefault(labels[0], set())
            new = set(pairs)
            if len(new) == len(pairs) and have.isdisjoint(new):
                have |= new
                return
        for pair, lab in zip(pairs, labels):
            have = seen.setdefault(lab, set())
            if pair in have:
                self._fail(msg, f"field 'problem_id': problem {pair[0]} (repetition {pair[1]}) has {what} twice")
            have.add(pair)

    def solves(self, msg, pid: list, rep: list, labels: list, n_solutions: list | None) -> None:
        self._end_batch(msg)
        pairs = list(zip(pid, rep))
        self._add(msg, self.solved, pairs, labels, "a solve record")
        self.batch = dict(zip(pairs, labels))
        self.batch_ids = (pid, rep, n_solutions)
        self.pending_solutions = n_solutions is not None

    def _of_batch(self, msg, pid: list, rep: list, what: str) -> tuple[list, list]:
        if self.batch is None:
            self._fail(msg, f"{what} before any {SOLVE_TOPIC} message")
        pairs = list(zip(pid, rep))
        labels = [self.batch.get(pair) for pair in pairs]
        if None in labels:
            p, r = pairs[labels.index(None)]
            self._fail(msg, f"field 'problem_id': problem {p} (repetition {r}) has {what} but no solve record in the "
                            f"{SOLVE_TOPIC} message before it")
        return pairs, labels

    def traces(self, msg, b: dict) -> None:
        n = len(b["problem_id"])
        if n > BATCH:
            self._fail(msg, f"field 'problem_id' holds {n} traces, a message holds at most {BATCH}")
        pairs, labels = self._of_batch(msg, b["problem_id"].tolist(), b["repetition"].tolist(), "a trace")
        self._add(msg, self.traced, pairs, labels, "a trace")

    def solutions(self, msg, b: dict) -> None:
        pid, rep, cnt = b["problem_id"].tolist(), b["repetition"].tolist(), b["count"].tolist()
        if not self.pending_solutions:
            self._fail(msg, f"solutions for a {SOLVE_TOPIC} message without field 'n_solutions' (or a second "
                            f"solutions message for it)")
        want_pid, want_rep, want_n = self.batch_ids
        if pid != want_pid or rep != want_rep:
            self._fail(msg, f"field 'problem_id': {len(pid)} solves, not the {len(want_pid)} solves of the "
                            f"{SOLVE_TOPIC} message before it: counts differ across channels")
        if cnt != want_n:
            k = next(i for i, (c, w) in enumerate(zip(cnt, want_n)) if c != w)
            self._fail(msg, f"field 'count': problem {pid[k]} has {cnt[k]} solutions, its solve record's "
                            f"'n_solutions' says {want_n[k]}: counts differ across channels")
        pairs, labels = self._of_batch(msg, pid, rep, "solutions")
        self._add(msg, self.listed, pairs, labels, "solutions")
        self.pending_solutions = False

    def finish(self) -> None:
        self._end_batch()


def read_archive(path: str | Path, problems: str | Path | None = None) -> Archive:
    """Read and check one archive (format 5).

    ``problems``: the archive's problem set when it is not where the metadata's ``problem_path``
    says (an archive copied out of its results tree); its SHA-256 is checked all the same.

    Checks: the caps of this module (file size, each chunk's declared and actual uncompressed size,
    all chunks together, solve records), the MCAP magic, the data-section and summary CRCs
    (:func:`check_file_crcs`), chunk CRCs, a summary section (the writer finished), the ``run``
    metadata, its required fields and the types of the fields readers use (:func:`_check_metadata`),
    the format version, every message of the three channels against its schema, and the structure
    across them (:class:`_Structure`): each solve (labels, problem id, repetition) once, every problem
    id in the problem set, traces and solutions only of the solves of their batch, at most one each,
    solution counts equal to the solves' ``n_solutions``; then the number of solve records against the
    metadata's problem count (``problems`` x ``repetitions``), so that a damaged file never reads as
    fewer solves. Stored trace rows and solutions are read (and their own fields checked) on demand.

    Raises
    ------
    ArchiveError
        One line naming the file and what is wrong.
    """
    path = Path(path)
    if not path.is_file():
        raise ArchiveError(f"{path}: no such archive")
    data = _file_bytes(path)
    if data[:8] != _MAGIC:
        raise ArchiveError(f"{path}: not an MCAP file (bad magic)")
    has_data_crc = check_file_crcs(path, data)
    try:
        reader = _summary_reader(data)
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
    want = _check_metadata(path, meta, traces, timing)
    room = MAX_SOLVES if want is None else want
    solves: list[dict] = []
    problem_set = _problems_of(path, meta, problems)
    st = _Structure(path)
    for msg in _messages(path, (SOLVE_TOPIC, TRACE_TOPIC, SOLUTIONS_TOPIC), data, summary):
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
