"""Problem-set files: CSV with full-precision floats and a one-line header comment.

Same seed and settings give a byte-identical file (floats written with 17 significant digits,
no timestamps). A name ending in ``.gz`` is the same text gzip-compressed (no name or time in the
gzip header, so still byte-identical): the workflow writes ``<robot>.csv.gz``, about half the
size, since the archives read their goals from it.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from pipeline.problems import ProblemSet

MAGIC = "# ik-pipeline problem set v2"


class ProblemFileError(ValueError):
    """A problem-set file is unreadable or malformed (one line naming file and field)."""


def _columns(n: int) -> list[str]:
    return (["problem_id", "chain"] + [f"q_start_{i + 1}" for i in range(n)] + [f"q_goal_{i + 1}" for i in range(n)]
            + ["goal_x", "goal_y", "goal_z", "goal_qw", "goal_qx", "goal_qy", "goal_qz"])


def write_problems(path: str | Path, ps: ProblemSet, meta: dict[str, str]) -> None:
    """Write atomically (temporary file, then rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    n = ps.q_start.shape[1]
    buf = io.StringIO()
    head = {"robot": ps.robot, "length_unit": ps.length_unit, **meta}
    buf.write(MAGIC + " " + " ".join(f"{k}={v}" for k, v in head.items()) + "\n")
    buf.write(",".join(_columns(n)) + "\n")
    data = np.column_stack([ps.q_start, ps.q_goal, ps.goal_position, ps.goal_quat])
    for pid, ch, row in zip(ps.problem_id, ps.chain, data):
        buf.write(f"{int(pid)},{int(ch)}," + ",".join(format(x, ".17g") for x in row) + "\n")
    tmp = path.with_name(path.name + ".partial")
    data = buf.getvalue().encode()
    if path.name.endswith(".gz"):
        import gzip

        data = gzip.compress(data, compresslevel=6, mtime=0)
    tmp.write_bytes(data)
    os.replace(tmp, path)


def read_problems(path: str | Path) -> tuple[ProblemSet, dict[str, str]]:
    """Read a problem-set file; returns the set and its header fields."""
    import gzip
    import zlib

    from pipeline.errors import not_regular

    path = Path(path)
    if not_regular(path):
        raise ProblemFileError(f"{path}: {not_regular(path)}")
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ProblemFileError(f"{path}: cannot read problem set ({exc.strerror or exc})") from None
    if path.name.endswith(".gz"):
        try:
            data = gzip.decompress(data)
        except (OSError, EOFError, zlib.error) as exc:  # gzip.BadGzipFile is an OSError
            raise ProblemFileError(f"{path}: damaged gzip file ({str(exc) or type(exc).__name__})") from None
    try:
        lines = data.decode().splitlines()
    except (UnicodeDecodeError, ValueError) as exc:
        raise ProblemFileError(f"{path}: not a readable problem set ({type(exc).__name__}: {exc})") from None
    if not lines or not lines[0].startswith(MAGIC):
        raise ProblemFileError(f"{path}: line 1: not an ik-pipeline problem set (missing '{MAGIC}')")
    meta = dict(kv.split("=", 1) for kv in lines[0][len(MAGIC):].split() if "=" in kv)
    for key in ("robot", "length_unit"):
        if key not in meta:
            raise ProblemFileError(f"{path}: line 1: header field '{key}' missing")
    cols = lines[1].split(",") if len(lines) > 1 else []
    n = (len(cols) - 9) // 2
    if n < 1 or cols != _columns(n):
        raise ProblemFileError(f"{path}: line 2: unexpected columns")
    try:
        data = np.array([[float(x) for x in ln.split(",")] for ln in lines[2:]], dtype=float).reshape(-1, len(cols))
    except ValueError as exc:
        raise ProblemFileError(f"{path}: malformed row ({exc})") from None
    qgoal = slice(2 + n, 2 + 2 * n)
    finite = np.isfinite(data)
    finite[:, qgoal] = True  # goal angles may be unknown (NaN): Cartesian path points
    if data.shape[0] == 0 or not np.all(finite):
        raise ProblemFileError(f"{path}: no rows, or a non-finite value")
    ps = ProblemSet(data[:, 0].astype(int), data[:, 2:2 + n], data[:, qgoal], data[:, 2 + 2 * n:5 + 2 * n],
                    data[:, 5 + 2 * n:], meta["robot"], meta["length_unit"], data[:, 1].astype(int))
    return ps, meta
