"""Problem-set files: CSV with full-precision floats and a one-line header comment.

Same seed and settings give a byte-identical file (floats written with 17 significant digits,
no timestamps). A name ending in ``.gz`` is the same text gzip-compressed (no name or time in the
gzip header, so still byte-identical): the workflow writes ``<robot>.csv.gz``, about half the
size, since the archives read their goals from it.

Reading is bounded (:data:`MAX_PROBLEM_FILE_BYTES`, :data:`MAX_PROBLEM_TEXT_BYTES`,
:data:`MAX_PROBLEMS`, :data:`MAX_LINE_CHARS`, :data:`pipeline.robots.MAX_JOINTS`): the file's size
is checked before it is read, a gzip stream is decompressed with a bounded output and refused one
byte past the cap, the rows are counted before any is split. Every read of a problem file goes
through :func:`problem_file_text` (also the hash an archive records, :func:`problem_file_sha256`).
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from pipeline.problems import ProblemSet
from pipeline.robots import MAX_JOINTS

MAGIC = "# ik-pipeline problem set v2"

# ---- caps: a problem file is refused in one line past any of them, before the memory is spent ------
# The largest problem file of a full build is a 10 000-problem set of a 7-joint arm (cerbaro2019's
# random set): 1.9 MiB gzip-compressed, 4.0 MiB of text, ~410 characters a row. Reading a file costs
# about 4 bytes of memory per byte of text (bytes, str, lines, one float64 table), so the text cap
# keeps a read under ~300 MiB, while leaving a 16x margin over the largest real file.
MAX_PROBLEM_FILE_BYTES = 64 << 20  # the file on disk (compressed or not) [bytes]
MAX_PROBLEM_TEXT_BYTES = 64 << 20  # its text (a .gz file decompressed with a bounded output) [bytes]
MAX_PROBLEMS = 100_000             # data rows (and a header's ``count``): 10x the largest set (10 000)
MAX_LINE_CHARS = 16_384            # one line: a 64-joint row (137 columns x 25 characters) is ~3.5 kB


class ProblemFileError(ValueError):
    """A problem-set file is unreadable or malformed (one line naming file and field)."""


def _columns(n: int) -> list[str]:
    return (["problem_id", "chain"] + [f"q_start_{i + 1}" for i in range(n)] + [f"q_goal_{i + 1}" for i in range(n)]
            + ["goal_x", "goal_y", "goal_z", "goal_qw", "goal_qx", "goal_qy", "goal_qz"])


def write_problems(path: str | Path, ps: ProblemSet, meta: dict[str, str]) -> None:
    """Write a problem set atomically (temporary file, then rename).

    Parameters
    ----------
    path : str or Path
        The file (``.csv``; its folder is created).
    ps : ProblemSet
        m problems of n joints: ``q_start``, ``q_goal`` (m, n) [rad or length unit], ``goal_position``
        (m, 3) [``ps.length_unit``], ``goal_quat`` (m, 4) w-first; values written with 17 significant digits.
    meta : dict[str, str]
        Header fields written after ``robot`` and ``length_unit`` (seed, count, ...).
    """
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


def _size(n: int) -> str:
    """A byte count for a message: ``64 MiB`` (whole MiB) or ``1234 bytes``."""
    return f"{n >> 20} MiB" if n >= 1 << 20 and not n % (1 << 20) else f"{n} bytes"


def _gunzip(path: Path, data: bytes, cap: int) -> bytes:
    """:func:`gzip.decompress` with a bound: every member decompressed with at most ``cap`` bytes of output
    in all (one byte past it and the file is refused, before more memory is spent). Errors as
    ``gzip.decompress`` words them (the same lines as before the bound)."""
    import struct
    import zlib

    out, total, pos = [], 0, 0
    eof = "Compressed file ended before the end-of-stream marker was reached"
    while pos < len(data):
        if data[pos:pos + 2] != b"\037\213":
            raise ProblemFileError(f"{path}: damaged gzip file (Not a gzipped file ({data[pos:pos + 2]!r}))")
        if len(data) < pos + 10:
            raise ProblemFileError(f"{path}: damaged gzip file ({eof})")
        method, flag = data[pos + 2], data[pos + 3]
        if method != 8:
            raise ProblemFileError(f"{path}: damaged gzip file (Unknown compression method)")
        pos += 10
        if flag & 4:  # FEXTRA
            if len(data) < pos + 2:
                raise ProblemFileError(f"{path}: damaged gzip file ({eof})")
            pos += 2 + struct.unpack_from("<H", data, pos)[0]
        for bit in (8, 16):  # FNAME, FCOMMENT: zero-terminated
            if flag & bit:
                end = data.find(b"\0", pos)
                pos = len(data) if end < 0 else end + 1
        if flag & 2:  # FHCRC
            pos += 2
        if pos > len(data):
            raise ProblemFileError(f"{path}: damaged gzip file ({eof})")
        do = zlib.decompressobj(wbits=-zlib.MAX_WBITS)
        try:
            part = do.decompress(data[pos:], cap - total + 1)  # at most one byte past the cap
        except zlib.error as exc:
            raise ProblemFileError(f"{path}: damaged gzip file ({exc})") from None
        total += len(part)
        if total > cap:
            raise ProblemFileError(f"{path}: decompresses past {_size(cap)} (the problem-file cap, "
                                   f"MAX_PROBLEM_TEXT_BYTES); not read")
        if not do.eof or len(do.unused_data) < 8:
            raise ProblemFileError(f"{path}: damaged gzip file ({eof})")
        crc, length = struct.unpack("<II", do.unused_data[:8])
        if crc != zlib.crc32(part):
            raise ProblemFileError(f"{path}: damaged gzip file (CRC check failed)")
        if length != (len(part) & 0xFFFFFFFF):
            raise ProblemFileError(f"{path}: damaged gzip file (Incorrect length of data produced)")
        out.append(part)
        rest = do.unused_data[8:]
        pos = len(data) - len(rest)
        while pos < len(data) and data[pos] == 0:  # zero padding between members, as gzip allows
            pos += 1
    return b"".join(out)


def problem_file_text(path: str | Path) -> bytes:
    """The text of a problem-set file (decompressed for a ``.gz`` name), read within the caps.

    The file on disk may hold at most :data:`MAX_PROBLEM_FILE_BYTES`, its text at most
    :data:`MAX_PROBLEM_TEXT_BYTES`; a gzip stream is decompressed with a bounded output and refused
    one byte past the cap (a few kB that inflate to gigabytes never reach memory).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    bytes

    Raises
    ------
    ProblemFileError
        One line naming the file: not a regular file, unreadable, past a cap, or a damaged gzip stream.
    """
    from pipeline.errors import not_regular

    path = Path(path)
    if not_regular(path):
        raise ProblemFileError(f"{path}: {not_regular(path)}")
    try:
        with open(path, "rb") as fh:
            big = os.fstat(fh.fileno()).st_size > MAX_PROBLEM_FILE_BYTES
            data = b"" if big else fh.read(MAX_PROBLEM_FILE_BYTES + 1)  # one byte past the cap at most
    except OSError as exc:
        raise ProblemFileError(f"{path}: cannot read problem set ({exc.strerror or exc})") from None
    if big or len(data) > MAX_PROBLEM_FILE_BYTES:
        raise ProblemFileError(f"{path}: larger than {_size(MAX_PROBLEM_FILE_BYTES)} on disk (the problem-file cap, "
                               f"MAX_PROBLEM_FILE_BYTES); not read")
    if path.name.endswith(".gz"):
        return _gunzip(path, data, MAX_PROBLEM_TEXT_BYTES)
    if len(data) > MAX_PROBLEM_TEXT_BYTES:
        raise ProblemFileError(f"{path}: larger than {_size(MAX_PROBLEM_TEXT_BYTES)} (the problem-file cap, "
                               f"MAX_PROBLEM_TEXT_BYTES); not read")
    return data


def problem_file_sha256(path: str | Path) -> str:
    """SHA-256 of a problem set's text (decompressed for ``.gz``), read within the caps.

    The hash :func:`pipeline.provenance.file_sha256` gives a problem file, without its unbounded gzip read.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    str
        Hexadecimal digest.
    """
    import hashlib

    return hashlib.sha256(problem_file_text(path)).hexdigest()


def read_problems(path: str | Path) -> tuple[ProblemSet, dict[str, str]]:
    """Read a problem-set file (:func:`load_problems` without the hash).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    ps : ProblemSet
    meta : dict[str, str]
        The header fields.
    """
    ps, meta, _ = load_problems(path)
    return ps, meta


def _header(path: Path, lines: list[str]) -> dict[str, str]:
    """The header fields of line 1, checked (a declared ``count`` against the rows); trailing blank lines
    are dropped from ``lines``."""
    if not lines or not lines[0].startswith(MAGIC):
        raise ProblemFileError(f"{path}: line 1: not an ik-pipeline problem set (missing '{MAGIC}')")
    if len(lines[0]) > MAX_LINE_CHARS:
        raise ProblemFileError(f"{path}: line 1: longer than {MAX_LINE_CHARS} characters (MAX_LINE_CHARS)")
    meta = dict(kv.split("=", 1) for kv in lines[0][len(MAGIC):].split() if "=" in kv)
    for key in ("robot", "length_unit"):
        if key not in meta:
            raise ProblemFileError(f"{path}: line 1: header field '{key}' missing")
    while len(lines) > 2 and not lines[-1].strip():  # trailing blank lines
        lines.pop()
    if "count" in meta:
        c = meta["count"]
        if not c.isdigit() or len(c) > 12 or int(c) > MAX_PROBLEMS:
            raise ProblemFileError(f"{path}: line 1: header field 'count': {c[:40]!r} is not a problem count "
                                   f"up to {MAX_PROBLEMS} (MAX_PROBLEMS)")
        if int(c) != len(lines) - 2:
            raise ProblemFileError(f"{path}: line 1: header field 'count' is {c}, the file holds "
                                   f"{max(0, len(lines) - 2)} rows")
    return meta


def _table(path: Path, lines: list[str]) -> tuple[np.ndarray, list[str], int]:
    """The data rows as a (m, 2n + 9) float array, with the column names and the joint count n."""
    if len(lines) > 1 and len(lines[1]) > MAX_LINE_CHARS:
        raise ProblemFileError(f"{path}: line 2: longer than {MAX_LINE_CHARS} characters (MAX_LINE_CHARS)")
    cols = lines[1].split(",") if len(lines) > 1 else []
    n = (len(cols) - 9) // 2
    if n < 1 or n > MAX_JOINTS or cols != _columns(n):
        raise ProblemFileError(f"{path}: line 2: unexpected columns")
    m = len(lines) - 2
    if m == 0:
        raise ProblemFileError(f"{path}: no rows, or a non-finite value")
    table = np.empty((m, len(cols)), dtype=float)  # rows x columns, both bounded above
    for i, ln in enumerate(lines[2:]):
        if len(ln) > MAX_LINE_CHARS:
            raise ProblemFileError(f"{path}: line {i + 3}: longer than {MAX_LINE_CHARS} characters (MAX_LINE_CHARS)")
        fields = ln.split(",")
        if len(fields) != len(cols):
            raise ProblemFileError(f"{path}: malformed row (line {i + 3}: {len(fields)} fields, the header names "
                                   f"{len(cols)})")
        try:
            table[i] = [float(x) for x in fields]
        except ValueError as exc:
            raise ProblemFileError(f"{path}: malformed row ({exc}; line {i + 3})") from None
    return table, cols, n


def _check_table(path: Path, table: np.ndarray, cols: list[str], n: int) -> np.ndarray:
    """Finite values (goal angles may be NaN), int32 problem ids and chains, unique problem ids; returns
    the ids, (m,) int64."""
    qgoal = slice(2 + n, 2 + 2 * n)
    finite = np.isfinite(table)
    finite[:, qgoal] = True  # goal angles may be unknown (NaN): Cartesian path points
    if not np.all(finite):
        i, j = np.argwhere(~finite)[0]
        raise ProblemFileError(f"{path}: no rows, or a non-finite value (line {i + 3}, column '{cols[j]}': "
                               f"{float(table[i, j])})")
    for j, name in ((0, "problem_id"), (1, "chain")):
        v = table[:, j]
        bad = (v != np.round(v)) | (v < -2**31) | (v >= 2**31)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ProblemFileError(f"{path}: line {i + 3}: column '{name}': {float(v[i])!r} is not an int32 integer")
    ids = table[:, 0].astype(np.int64)
    uniq, first, counts = np.unique(ids, return_index=True, return_counts=True)
    if len(uniq) != len(ids):
        k = int(np.flatnonzero(counts > 1)[0])
        dup = int(uniq[k])
        lines_of = (np.flatnonzero(ids == dup)[:2] + 3).tolist()
        raise ProblemFileError(f"{path}: column 'problem_id': problem {dup} appears more than once "
                               f"(lines {lines_of[0]} and {lines_of[1]})")
    return ids


def load_problems(path: str | Path) -> tuple[ProblemSet, dict[str, str], str]:
    """Read and check a problem-set file.

    Bounded (:func:`problem_file_text` and the caps of this module) and checked line by line: the
    header, a declared ``count`` (an integer within :data:`MAX_PROBLEMS`, equal to the rows), the
    column names, the number of fields on every row, integral problem ids and chains (int32, the
    archives' type), unique problem ids, finite values (goal angles may be NaN: Cartesian path points).

    Parameters
    ----------
    path : str or Path
        A ``.csv`` or ``.csv.gz`` problem set (:func:`write_problems`).

    Returns
    -------
    ps : ProblemSet
        m problems of n joints: ``q_start``, ``q_goal`` (m, n) [rad or length unit], ``goal_position``
        (m, 3) [``length_unit``], ``goal_quat`` (m, 4) w-first.
    meta : dict[str, str]
        The header fields (``robot``, ``length_unit``, and what the writer added).
    sha256 : str
        The SHA-256 of the file's text (decompressed for ``.gz``), hexadecimal.

    Raises
    ------
    ProblemFileError
        One line naming the file and the line or field.
    """
    import hashlib

    path = Path(path)
    data = problem_file_text(path)
    sha = hashlib.sha256(data).hexdigest()
    rows = data.rstrip(b"\r\n").count(b"\n") - 1  # data rows (lines end in \n), counted before any is split
    if rows > MAX_PROBLEMS:
        raise ProblemFileError(f"{path}: {rows} rows, past the {MAX_PROBLEMS} problems a set may hold "
                               f"(MAX_PROBLEMS); not read")
    try:
        lines = [ln[:-1] if ln.endswith("\r") else ln for ln in data.decode().split("\n")]
    except (UnicodeDecodeError, ValueError) as exc:
        raise ProblemFileError(f"{path}: not a readable problem set ({type(exc).__name__}: {exc})") from None
    del data
    meta = _header(path, lines)
    table, cols, n = _table(path, lines)
    lines = None
    ids = _check_table(path, table, cols, n)
    ps = ProblemSet(ids.astype(int), table[:, 2:2 + n], table[:, 2 + n:2 + 2 * n], table[:, 2 + 2 * n:5 + 2 * n],
                    table[:, 5 + 2 * n:], meta["robot"], meta["length_unit"], table[:, 1].astype(int))
    return ps, meta, sha
