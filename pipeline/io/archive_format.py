"""The archive format (version 5): channels, protobuf schemas written by hand, solve flags, the trace
digest, the trace policy and the errors of reading.

Shared by :mod:`pipeline.io.archive_writer` and the readers (:mod:`pipeline.io.archive`,
:mod:`pipeline.io.archive_bounds`, :mod:`pipeline.io.archive_checks`); the format itself is described in
:mod:`pipeline.io.archive`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from zlib import crc32 as _crc32

import numpy as np

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
ABSENT_FLAGS = {"initial_error": F_NO_INITIAL, "final_error": F_NO_FINAL, "position_error": F_NO_POSITION,
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
    """The FileDescriptorSet of the message on ``topic`` (:data:`MESSAGES`).

    Parameters
    ----------
    topic : str
        One of :data:`SOLVE_TOPIC`, :data:`TRACE_TOPIC`, :data:`SOLUTIONS_TOPIC`.

    Returns
    -------
    bytes
        A serialized ``google.protobuf.FileDescriptorSet`` holding the one message.
    """
    message, fields, file = MESSAGES[topic]
    return _descriptor(message, fields, file)


def encode_fields(fields, values: dict) -> bytes:
    """One protobuf message of packed repeated scalars and singular strings.

    Parameters
    ----------
    fields : tuple of (int, str, str or None, int)
        The message's fields (field number, name, numpy dtype, protobuf type), e.g. :data:`SOLVE_FIELDS`.
    values : dict
        Field name -> value: an array_like of any shape (written flattened in C order, cast to the
        field's dtype) or, for a string field, ``bytes`` or ``str``. A missing, None or empty value is
        not written.

    Returns
    -------
    bytes
        The message, fields in the order of ``fields``.
    """
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


def decode_fields(fields, data: bytes) -> dict:
    """Inverse of :func:`encode_fields`.

    Parameters
    ----------
    fields : tuple of (int, str, str or None, int)
        The message's fields, as for :func:`encode_fields`.
    data : bytes
        One message.

    Returns
    -------
    dict
        Field name -> (k,) array of the field's dtype (read-only views of ``data``; empty when the field
        is absent), or ``bytes`` for a string field.

    Raises
    ------
    ValueError
        On anything :func:`encode_fields` did not write (unknown field, other wire type, truncation).
    """
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
    """CRC-32 of an array's float64 values in C order.

    How ``reproduce`` compares a re-run trace with the archived one. A check of a deterministic re-run,
    not a defence against forgery: 32 bits miss a difference with probability 2**-32 and cost 4 bytes per
    solve.

    Parameters
    ----------
    a : array_like, shape (...) [1]
        The values, any shape (a trace: (rows, 8), the columns of
        :data:`pipeline.io.layout.TRACE_COLUMNS`, each in its own unit); converted to C-ordered float64
        when they are not already.

    Returns
    -------
    int
        The unsigned CRC-32 of the values' bytes.
    """
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
        """The policy a study's ``trace_policy`` setting names.

        Parameters
        ----------
        value : {"all", "none"}, dict or None
            ``"all"``, ``"none"``, or a mapping ``{sample: int, failed_rows: int}`` (missing keys: defaults);
            None: the default policy.
        where : str
            Where the setting was read, for the error message.

        Returns
        -------
        TracePolicy

        Raises
        ------
        ValueError
            One line naming ``where`` when the value is none of these.
        """
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
        """The policy as sorted strict JSON (the ``trace_policy`` field of the ``run`` record)."""
        return json.dumps({"mode": self.mode, "sample": self.sample, "failed_rows": self.failed_rows}, sort_keys=True)

    @classmethod
    def from_json(cls, text: str) -> "TracePolicy":
        """Inverse of :meth:`as_json`.

        Parameters
        ----------
        text : str
            A JSON object with keys ``mode``, ``sample`` and ``failed_rows``.

        Returns
        -------
        TracePolicy
        """
        d = json.loads(text)
        return cls(mode=d["mode"], sample=int(d["sample"]), failed_rows=int(d["failed_rows"]))

    def describe(self) -> str:
        """One line saying which traces the policy stores (the ``policy`` field of the ``traces`` record)."""
        if self.mode != "sample":
            return {"all": "every trace stored", "none": "no trace stored (digests only)"}[self.mode]
        return (f"the traces of {self.sample} problems evenly spaced over the set, and of failed solves up to "
                f"{self.failed_rows} rows per archive; digests of all")

    def sample_ids(self, problem_ids) -> set[int]:
        """The sample: ``sample`` ids evenly spaced over the sorted ``problem_ids`` (all when fewer).

        Parameters
        ----------
        problem_ids : array_like of int, shape (n,)
            Every problem id of the job (repeats allowed).

        Returns
        -------
        set of int
            The sampled ids (every id in ``all`` mode, none in ``none`` mode).
        """
        ids = np.unique(np.asarray(problem_ids, dtype=np.int64))
        if self.mode == "none" or (self.mode == "sample" and self.sample == 0):
            return set()
        if self.mode == "all" or len(ids) <= self.sample:
            return set(ids.tolist())
        pick = np.unique(np.round(np.linspace(0, len(ids) - 1, self.sample)).astype(np.int64))
        return set(ids[pick].tolist())


LABELS = ("robot", "solver", "method", "length_unit")  # per-solve string columns (``labels_json``)
