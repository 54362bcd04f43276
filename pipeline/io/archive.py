"""Result archives: one MCAP file per solve job, JSON-schema channels, zstd-compressed chunks.

Channels
--------
``/ik/solve``  one message per problem (schema ``ik_pipeline.Solve``)
``/ik/trace``  one message per problem: the per-iteration error trace (``ik_pipeline.Trace``)
Metadata record ``run``: study, robot, solver, settings (JSON), settings hash, seed, scale,
package version, git commit, problem file and its SHA-256.

Quaternions are w-first everywhere in the library; here, and only here, the goal orientation is
written with fields named x, y, z, w (Foxglove ``Pose`` style).

Determinism: message log times are the problem index (ns), not the wall clock, and no creation
time is stored, so the same settings and seed give the same file except for the timing fields.
An archive is written to ``<name>.partial`` and renamed only after the MCAP summary is written:
an interrupted job never leaves a file that looks complete.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np

FORMAT_VERSION = "2"
SOLVE_TOPIC = "/ik/solve"
TRACE_TOPIC = "/ik/trace"
REQUIRED_META = ("format_version", "study", "robot", "solver", "settings", "settings_hash", "seed",
                 "package_version", "git_commit")

_VEC3 = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}}
_QUAT = {"type": "object", "properties": {k: {"type": "number"} for k in "xyzw"}}
_NUMS = {"type": "array", "items": {"type": "number"}}
SOLVE_SCHEMA = {
    "title": "ik_pipeline.Solve",
    "type": "object",
    "properties": {
        "problem_id": {"type": "integer"},
        "robot": {"type": "string"},
        "solver": {"type": "string"},
        "success": {"type": "boolean", "description": "FK-verified success"},
        "claimed_success": {"type": "boolean", "description": "the method's own stop test said success"},
        "repetition": {"type": "integer", "description": "0-based repetition of the problem (timing studies)"},
        "chain": {"type": "integer", "description": "-1 = independent; else warm-started from the previous problem of the chain"},
        "method": {"type": "string", "description": "registered solver name"},
        "stop_reason": {"type": "integer", "description": "pipeline.solvers.StopReason: 1 success, 2 stalled, 3 error grew, 4 cap, 5 non-finite, 6 FK contradicts, 7 no solution"},
        "call_time_s": {"type": "number", "description": "the whole solve() call [s]"},
        "within_limits": {"type": "boolean", "description": "q_solution within the robot file's joint limits (revolute wrapped by 2 pi)"},
        "info": {"type": "object", "description": "method-specific counters"},
        "solutions": {"type": "array", "items": _NUMS, "description": "analytic solvers: every solution"},
        "iterations": {"type": "integer"},
        "solve_time_s": {"type": "number", "description": "the method's own computation, monotonic clock [s] (pipeline/solvers/timing.py)"},
        "ik_time_s": {"type": "number", "description": "sum of IK-block (step) times [s], 0 where not measured"},
        "initial_error": {"type": "number"},
        "final_error": {"type": "number"},
        "position_error": {"type": "number", "description": "|p_goal - p| by independent FK [length_unit]"},
        "orientation_error": {"type": "number", "description": "rotation angle goal vs reached [rad]"},
        "length_unit": {"type": "string"},
        "q_start": _NUMS,
        "q_solution": _NUMS,
        "goal": {"type": "object", "properties": {"position": _VEC3, "orientation": _QUAT}},
    },
}
TRACE_SCHEMA = {
    "title": "ik_pipeline.Trace",
    "type": "object",
    "properties": {
        "problem_id": {"type": "integer"},
        "error": {**_NUMS, "description": "scalar stop-test error per iteration (0 = start)"},
        "error_vector": {"type": "array", "items": _NUMS, "description": "6-vector (v, omega) per iteration"},
        "position_error": {**_NUMS, "description": "|dp| per iteration [length_unit]"},
    },
}


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
        self._w = Writer(self._fh, compression=CompressionType.ZSTD)
        self._w.start(profile="", library=f"ik-pipeline {metadata['package_version']}")
        self._w.add_metadata("run", {k: str(v) for k, v in metadata.items()})
        sid = self._w.register_schema("ik_pipeline.Solve", "jsonschema", json.dumps(SOLVE_SCHEMA).encode())
        tid = self._w.register_schema("ik_pipeline.Trace", "jsonschema", json.dumps(TRACE_SCHEMA).encode())
        self._solve = self._w.register_channel(SOLVE_TOPIC, "json", sid)
        self._trace = self._w.register_channel(TRACE_TOPIC, "json", tid)
        self._seq = 0
        self._extra: dict[str, int] = {}

    def add_channel(self, topic: str, schema: dict) -> None:
        """Register an extra JSON channel (e.g. measurements that are not IK solves)."""
        sid = self._w.register_schema(schema.get("title", topic), "jsonschema", json.dumps(schema).encode())
        self._extra[topic] = self._w.register_channel(topic, "json", sid)

    def write_message(self, topic: str, record: dict) -> None:
        """Append one JSON record on a channel registered with :meth:`add_channel`."""
        t = self._seq
        self._w.add_message(self._extra[topic], log_time=t, publish_time=t, sequence=t,
                            data=json.dumps(record, separators=(",", ":")).encode())
        self._seq += 1

    def write(self, solve: dict, trace: dict | None) -> None:
        """Append one problem's solve record and its trace (plain JSON-able dicts; no trace if None)."""
        t = self._seq
        self._w.add_message(self._solve, log_time=t, publish_time=t, sequence=t,
                            data=json.dumps(solve, separators=(",", ":")).encode())
        if trace is not None:
            self._w.add_message(self._trace, log_time=t, publish_time=t, sequence=t,
                                data=json.dumps(trace, separators=(",", ":")).encode())
        self._seq += 1

    def close(self) -> None:
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
        """Yield the decoded JSON records of any channel."""
        for _, _, msg in _iter_messages(self.path, [topic]):
            yield json.loads(msg.data)

    def traces(self, problem_ids=None) -> Iterator[dict]:
        """Yield trace messages (optionally only for ``problem_ids``)."""
        wanted = None if problem_ids is None else {int(p) for p in problem_ids}
        for _, _, msg in _iter_messages(self.path, [TRACE_TOPIC]):
            rec = json.loads(msg.data)
            if wanted is None or rec["problem_id"] in wanted:
                yield rec


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


def read_archive(path: str | Path) -> Archive:
    """Read and check one archive.

    Raises
    ------
    ArchiveError
        Missing file, not MCAP, truncated (no summary: the writer never finished), no ``run``
        metadata or a field missing from it, or a record that cannot be decoded.
    """
    from mcap.reader import make_reader

    path = Path(path)
    if not path.is_file():
        raise ArchiveError(f"{path}: no such archive")
    try:
        with open(path, "rb") as fh:
            if fh.read(8) != b"\x89MCAP0\r\n":
                raise ArchiveError(f"{path}: not an MCAP file (bad magic)")
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
    if meta["format_version"] != FORMAT_VERSION:
        raise ArchiveError(f"{path}: metadata field 'format_version' is {meta['format_version']!r}, expected {FORMAT_VERSION!r}")
    solves = []
    for _, _, msg in _iter_messages(path, [SOLVE_TOPIC]):
        try:
            solves.append(json.loads(msg.data))
        except ValueError as exc:
            raise ArchiveError(f"{path}: message {msg.sequence} on {SOLVE_TOPIC} is not JSON ({exc})") from None
    return Archive(path, meta, solves)
