"""Hostile archives and problem files: bounded reading, structural checks, forgeries verify and reproduce see.

A corpus written here (:data:`PROBLEM_CASES`, :data:`ARCHIVE_CASES`, :data:`FORGERIES`): decompression bombs
(a 5 GiB gzip problem set of 5 MB, a zstd chunk inflating to 5 GiB, a chunk declaring 2^40 bytes),
damaged gzip and zstd data, malformed CSV, chunks whose sizes or CRC lie, truncated files, duplicated
problem ids and channel counts that disagree with every CRC rebuilt, metadata of the wrong type, and
forgeries a reader cannot see (a flipped success flag, a solution moved by one ulp) that ``verify``
finds by recomputing the FK check and ``reproduce`` by comparing every stored field.

Every hostile archive starts from a real one (``make_problems`` + ``solve_problems`` in-process) whose
messages are decoded, edited and written again as an MCAP file by :func:`_mcap` with the ``mcap``
library's records, every CRC recomputed (a forger's rebuild). Each case: one line naming the file and
the expected fragment, no traceback, under 10 s; the bombs run as ``python -m pipeline`` processes with
1 GiB of address space and their peak RSS is asserted under 1 GiB.
"""

from __future__ import annotations

import gzip
import io
import json
import sys
import shutil
import struct
import time
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
import zstandard

from pipeline.cli import main
from pipeline.io import archive as A
from pipeline.io import archive_bounds
from pipeline.io import problems as P
from pipeline.io.archive import ArchiveError, read_archive
from pipeline.io.problems import ProblemFileError, read_problems
from tests.conftest import DATA, ROOT

STUDY, SID = str(DATA / "studies" / "cerbaro2019.yaml"), "cerbaro2019"
ROBOT = DATA / "robots" / "kuka_lwr.yaml"
N = 12  # solves of the base archive
MAGIC = b"\x89MCAP0\r\n"


# ---- the base: a real results tree (problem set and archive), and its parts -------------------------
@pytest.fixture(scope="module")
def base(tmp_path_factory):
    """results/<study>/problems/random/kuka_lwr.csv.gz and results/<study>/runs/random/kuka_lwr__dls.mcap."""
    res = tmp_path_factory.mktemp("results")
    pset = res / SID / "problems" / "random" / "kuka_lwr.csv.gz"
    arch = res / SID / "runs" / "random" / "kuka_lwr__dls.mcap"
    assert main(["make_problems", "--study", STUDY, "--problem-set", "random", "--robot", str(ROBOT), "--scale",
                 "quick", "--out", str(pset)]) == 0
    assert main(["solve_problems", "--study", STUDY, "--problem-set", "random", "--robot", str(ROBOT), "--solver",
                 "dls", "--problems", str(pset), "--scale", "quick", "--limit", str(N), "--out", str(arch)]) == 0
    (res / SID / "tables").mkdir()
    (res / SID / "tables" / "provenance.json").write_text(json.dumps([{"archive": f"{SID}/runs/random/{arch.name}",
                                                                        "study": SID}]))
    return res, pset, arch


@dataclass
class Parts:
    """An archive as the ``mcap`` library reads it: schemas, channels, messages, metadata records."""

    schemas: dict
    channels: dict
    msgs: list  # [topic, sequence, log_time, data]
    meta: list = field(default_factory=list)  # [name, dict]

    def copy(self) -> "Parts":
        return Parts(dict(self.schemas), dict(self.channels), [list(m) for m in self.msgs],
                     [[n, dict(d)] for n, d in self.meta])

    def fields(self, topic: str, k: int = 0) -> tuple[int, dict]:
        """The k-th message of ``topic``: (its index in msgs, its fields as writable arrays)."""
        i = [j for j, m in enumerate(self.msgs) if m[0] == topic][k]
        f = A.decode(topic, self.msgs[i][3])
        return i, {name: (v if isinstance(v, bytes) else np.array(v)) for name, v in f.items()}

    def put(self, i: int, topic: str, f: dict) -> None:
        self.msgs[i][3] = A.encode_fields(A.MESSAGES[topic][1], f)

    def edit(self, topic: str, fn, k: int = 0) -> "Parts":
        i, f = self.fields(topic, k)
        fn(f)
        self.put(i, topic, f)
        return self

    def run(self) -> dict:
        return next(d for n, d in self.meta if n == "run")


def _parts(path: Path) -> Parts:
    from mcap.reader import make_reader

    with open(path, "rb") as fh:
        r = make_reader(fh)
        s = r.get_summary()
        msgs = [[ch.topic, m.sequence, m.log_time, m.data] for _, ch, m in r.iter_messages(log_time_order=False)]
        return Parts(dict(s.schemas), dict(s.channels), msgs, [[m.name, dict(m.metadata)] for m in r.iter_metadata()])


def _records(parts: Parts, msgs=None) -> bytes:
    from mcap.data_stream import RecordBuilder
    from mcap.records import Message

    ids = {ch.topic: cid for cid, ch in parts.channels.items()}
    b = RecordBuilder()
    for topic, seq, t, data in parts.msgs if msgs is None else msgs:
        Message(channel_id=ids.get(topic, 999), log_time=t, data=data, publish_time=t, sequence=seq).write(b)
    return b.end()


def _mcap(parts: Parts, chunks=None) -> bytes:
    """An MCAP file of ``parts``, every CRC computed: ``chunks`` (default: every message in one zstd chunk)
    are dicts of ``records`` (the uncompressed bytes) and optionally ``payload`` (the stored data),
    ``compression``, ``size`` (declared uncompressed size), ``crc`` (declared CRC), ``offset`` (the offset
    the summary's chunk index gives)."""
    from mcap.data_stream import RecordBuilder
    from mcap.records import (Channel, Chunk, ChunkIndex, DataEnd, Footer, Header, Metadata, MetadataIndex,
                              Schema)

    chunks = [{"records": _records(parts)}] if chunks is None else chunks
    b = RecordBuilder()
    Header(profile="", library="hostile").write(b)
    for s in parts.schemas.values():
        Schema(id=s.id, name=s.name, encoding=s.encoding, data=s.data).write(b)
    for c in parts.channels.values():
        Channel(id=c.id, topic=c.topic, message_encoding=c.message_encoding, metadata={}, schema_id=c.schema_id).write(b)
    data = bytearray(MAGIC) + b.end()
    index, mindex = [], []
    for c in chunks:
        raw = c["records"]
        payload = c.get("payload")
        if payload is None:
            payload = zstandard.ZstdCompressor(level=3).compress(raw)
        size = c.get("size", len(raw))
        Chunk(compression=c.get("compression", "zstd"), data=payload, message_start_time=0, message_end_time=0,
              uncompressed_crc=c.get("crc", zlib.crc32(raw)), uncompressed_size=size).write(b)
        rec = b.end()
        index.append(ChunkIndex(message_start_time=0, message_end_time=0, chunk_start_offset=c.get("offset", len(data)),
                                chunk_length=len(rec), message_index_offsets={}, message_index_length=0,
                                compression=c.get("compression", "zstd"), compressed_size=len(payload),
                                uncompressed_size=size))
        data += rec
    for name, d in parts.meta:
        Metadata(name=name, metadata=d).write(b)
        rec = b.end()
        mindex.append(MetadataIndex(offset=len(data), length=len(rec), name=name))
        data += rec
    DataEnd(data_section_crc=zlib.crc32(data)).write(b)
    data += b.end()
    start = len(data)
    for s in parts.schemas.values():
        Schema(id=s.id, name=s.name, encoding=s.encoding, data=s.data).write(b)
    for c in parts.channels.values():
        Channel(id=c.id, topic=c.topic, message_encoding=c.message_encoding, metadata={}, schema_id=c.schema_id).write(b)
    for r in index + mindex:
        r.write(b)
    summary = b.end()
    crc = zlib.crc32(struct.pack("<BQQQ", 0x02, 20, start, 0), zlib.crc32(summary))
    Footer(summary_start=start, summary_offset_start=0, summary_crc=crc).write(b)
    return bytes(data + summary + b.end() + MAGIC)


@pytest.fixture(scope="module")
def parts(base):
    return _parts(base[2])


def _put(base, name: str, blob: bytes) -> Path:
    """``blob`` as an archive next to the base one (its problem file found by the same relative path)."""
    p = base[2].with_name(name)
    p.write_bytes(blob)
    return p


# ---- one line, the file named, no traceback, under 10 s -------------------------------------------
def _refused(fn, path: Path, fragment: str, kind=(ArchiveError, ProblemFileError)) -> str:
    t0 = time.monotonic()
    with pytest.raises(kind) as exc:
        fn(path)
    dt = time.monotonic() - t0
    msg = str(exc.value)
    assert "\n" not in msg and "Traceback" not in msg, msg
    assert str(path) in msg, msg
    assert fragment in msg, f"{fragment!r} not in {msg!r}"
    assert dt < 10, dt
    return msg


def _cli(argv: list[str], capsys) -> tuple[int, str, str]:
    t0 = time.monotonic()
    try:
        rc = main(argv)
    except SystemExit as exc:  # verify exits 1 on a difference
        rc = exc.code
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    assert time.monotonic() - t0 < 10
    return rc, out, err


# ---- problem files -----------------------------------------------------------------------------------
def _text(base) -> str:
    return gzip.decompress(base[1].read_bytes()).decode()


def _gz_zeros(total: int, block: int = 64 << 20) -> bytes:
    """A gzip file of ``total`` zero bytes (a multiple of ``block``), built in well under a second: deflate's
    output for a zero block after a full flush repeats byte for byte, so it is compressed once."""
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    zero = bytes(block)
    piece = c.compress(zero) + c.flush(zlib.Z_FULL_FLUSH)
    crc = 0
    for _ in range(total // block):
        crc = zlib.crc32(zero, crc)
    return (b"\x1f\x8b\x08\x00\x00\x00\x00\x00\x00\xff" + piece * (total // block) + c.flush(zlib.Z_FINISH)
            + struct.pack("<II", crc, total & 0xFFFFFFFF))


def _csv(base, edit) -> bytes:
    lines = _text(base).split("\n")
    return "\n".join(edit(lines)).encode()


def _row(lines, k, j, value):
    f = lines[k].split(",")
    f[j] = value
    lines[k] = ",".join(f)
    return lines


CAP = P.MAX_PROBLEM_TEXT_BYTES
PROBLEM_CASES = {  # name -> (file name, bytes from base, expected fragment)
    "gzip_bomb_cap_plus_1MiB": ("p.csv.gz", lambda b: gzip.compress(bytes(CAP + (1 << 20)), 9),
                                "decompresses past 64 MiB (the problem-file cap"),
    "gzip_bomb_two_members": ("p.csv.gz", lambda b: gzip.compress(bytes(CAP // 2 + 1), 9) * 2,
                              "decompresses past 64 MiB"),
    "gzip_truncated": ("p.csv.gz", lambda b: b[1].read_bytes()[:-20],
                       "damaged gzip file (Compressed file ended before the end-of-stream marker was reached)"),
    "gzip_crc": ("p.csv.gz", lambda b: b[1].read_bytes()[:-8] + b"\0\0\0\0" + b[1].read_bytes()[-4:],
                 "damaged gzip file (CRC check failed)"),
    "gzip_length": ("p.csv.gz", lambda b: b[1].read_bytes()[:-4] + b"\1\0\0\0",
                    "damaged gzip file (Incorrect length of data produced)"),
    "gzip_trailing_garbage": ("p.csv.gz", lambda b: b[1].read_bytes() + b"junk", "Not a gzipped file (b'ju')"),
    "not_gzip_with_gz_name": ("p.csv.gz", lambda b: _text(b).encode(), "damaged gzip file (Not a gzipped file (b'# '))"),
    "gzip_bad_method": ("p.csv.gz", lambda b: b[1].read_bytes()[:2] + b"\x07" + b[1].read_bytes()[3:],
                        "Unknown compression method"),
    "gzip_header_only": ("p.csv.gz", lambda b: b[1].read_bytes()[:6], "Compressed file ended"),
    "count_huge": ("p.csv", lambda b: _csv(b, lambda ls: [ls[0].replace("count=", "count=1000000000000 x="), *ls[1:]]),
                   "header field 'count': '1000000000000' is not a problem count up to 100000"),
    "count_mismatch": ("p.csv", lambda b: _csv(b, lambda ls: [ls[0].replace("count=", "count=5 x="), *ls[1:]]),
                       "header field 'count' is 5, the file holds"),
    "rows_past_cap": ("p.csv", lambda b: (_text(b).split("\n", 2)[0].replace("count=", "x=") + "\n"
                                          + _text(b).split("\n", 2)[1] + "\n" + "0\n" * (P.MAX_PROBLEMS + 1)).encode(),
                      f"{P.MAX_PROBLEMS + 1} rows, past the {P.MAX_PROBLEMS} problems"),
    "long_line": ("p.csv", lambda b: _csv(b, lambda ls: _row(ls, 2, 3, "1" * (1 << 20))),
                  "line 3: longer than 16384 characters"),
    "nan_goal": ("p.csv", lambda b: _csv(b, lambda ls: _row(ls, 3, -7, "nan")), "non-finite value (line 4, column 'goal_x'"),
    "inf_goal": ("p.csv", lambda b: _csv(b, lambda ls: _row(ls, 2, -1, "-inf")), "column 'goal_qz': -inf"),
    "nan_start": ("p.csv", lambda b: _csv(b, lambda ls: _row(ls, 2, 2, "nan")), "column 'q_start_1': nan"),
    "missing_column": ("p.csv", lambda b: _csv(b, lambda ls: [ls[0], ls[1].rsplit(",", 1)[0], *ls[2:]]),
                       "line 2: unexpected columns"),
    "extra_column": ("p.csv", lambda b: _csv(b, lambda ls: [ls[0], ls[1] + ",extra", *ls[2:]]), "line 2: unexpected columns"),
    "row_extra_field": ("p.csv", lambda b: _csv(b, lambda ls: [*ls[:3], ls[3] + ",1", *ls[4:]]),
                        "malformed row (line 4: 24 fields, the header names 23)"),
    "row_missing_field": ("p.csv", lambda b: _csv(b, lambda ls: [*ls[:4], ls[4].rsplit(",", 1)[0], *ls[5:]]),
                          "malformed row (line 5: 22 fields"),
    "row_not_a_number": ("p.csv", lambda b: _csv(b, lambda ls: _row(ls, 2, 5, "0x1p3")), "malformed row (could not convert"),
    "duplicated_problem_id": ("p.csv", lambda b: _csv(b, lambda ls: _row(ls, 4, 0, "0")),
                              "problem 0 appears more than once (lines 3 and 5)"),
    "fractional_problem_id": ("p.csv", lambda b: _csv(b, lambda ls: _row(ls, 2, 0, "0.5")),
                              "column 'problem_id': 0.5 is not an int32 integer"),
    "huge_chain": ("p.csv", lambda b: _csv(b, lambda ls: _row(ls, 2, 1, "1e300")), "column 'chain': 1e+300 is not an int32"),
    "not_utf8": ("p.csv", lambda b: b"# ik-pipeline problem set v2 \xff\xfe\n", "not a readable problem set (UnicodeDecodeError"),
    "empty": ("p.csv", lambda b: b"", "line 1: not an ik-pipeline problem set"),
    "header_only": ("p.csv", lambda b: _csv(b, lambda ls: ls[:2]), "header field 'count' is 200, the file holds 0 rows"),
    "header_only_no_count": ("p.csv", lambda b: _csv(b, lambda ls: [ls[0].replace("count=", "x="), ls[1]]), "no rows"),
    "header_field_missing": ("p.csv", lambda b: _csv(b, lambda ls: [ls[0].replace("robot=", "r="), *ls[1:]]),
                             "header field 'robot' missing"),
}


@pytest.mark.parametrize("case", sorted(PROBLEM_CASES))
def test_hostile_problem_files_are_refused_in_one_line(base, tmp_path, case):
    name, make, fragment = PROBLEM_CASES[case]
    p = tmp_path / name
    p.write_bytes(make(base))
    _refused(read_problems, p, fragment)


def test_a_problem_file_past_its_size_cap_is_not_read(tmp_path):
    p = tmp_path / "p.csv"
    with open(p, "wb") as fh:  # sparse: 65 MiB that take no disk
        fh.truncate(P.MAX_PROBLEM_FILE_BYTES + (1 << 20))
    _refused(read_problems, p, "larger than 64 MiB on disk (the problem-file cap")


def test_the_real_problem_file_reads_and_hashes_as_before(base):
    from pipeline.provenance import file_sha256

    ps, meta, sha = P.load_problems(base[1])
    assert len(ps) == int(meta["count"]) and sha == file_sha256(base[1]) == P.problem_file_sha256(base[1])


# ---- archives: bounded chunks, lying headers, structure ------------------------------------------
def _zstd_zeros(total: int, block: int = 1 << 20) -> bytes:
    """One zstd frame of ``total`` zero bytes, streamed (5 GiB compress in about a second to ~160 kB)."""
    c = zstandard.ZstdCompressor(level=1).compressobj()
    zero = bytes(block)
    return b"".join(c.compress(zero) for _ in range(total // block)) + c.flush()


def _frame_declaring(size: int, real: int = 1 << 16) -> bytes:
    """A zstd frame whose header declares ``size`` bytes of content (single segment, 8-byte content size)
    and whose one RLE block holds ``real`` zero bytes."""
    return (struct.pack("<I", 0xFD2FB528) + bytes([0xE0]) + struct.pack("<Q", size)
            + struct.pack("<I", 1 | 1 << 1 | real << 3)[:3] + b"\0")


def _chunk(parts, **kw) -> list:
    return [{"records": _records(parts), **kw}]


def _meta(**fields):
    def edit(p):
        p.run().update({k: v for k, v in fields.items() if v is not None})
        for k, v in fields.items():
            if v is None:
                del p.run()[k]
        return _mcap(p)
    return edit


def _named_meta(name, **fields):
    def edit(p):
        next(d for n, d in p.meta if n == name).update(fields)
        return _mcap(p)
    return edit


def _dup_in_message(p):
    return _mcap(p.edit(A.SOLVE_TOPIC, lambda f: f["problem_id"].__setitem__(1, f["problem_id"][0])))


def _dup_across_messages(p):
    """The base's 12 solves as two messages of 6, the second's first problem id the first's."""
    i, f = p.fields(A.SOLVE_TOPIC)
    j = f["joints"][0]
    halves = []
    for lo, hi in ((0, 6), (6, 12)):
        g = dict(f)
        for k, v in f.items():
            if isinstance(v, np.ndarray) and k not in ("joints",) and len(v):
                per = len(v) // N
                g[k] = v[lo * per:hi * per]
        g["info_json"] = json.dumps(json.loads(f["info_json"])[lo:hi]).encode()
        g["q_start"] = f["q_start"][lo * j:hi * j] if len(f["q_start"]) else f["q_start"]
        halves.append(g)
    halves[1]["problem_id"] = halves[1]["problem_id"].copy()
    halves[1]["problem_id"][0] = halves[0]["problem_id"][0]
    p.msgs = [[A.SOLVE_TOPIC, 0, 0, A.encode_fields(A.SOLVE_FIELDS, halves[0])],  # traces left out
              [A.SOLVE_TOPIC, 1, 0, A.encode_fields(A.SOLVE_FIELDS, halves[1])]]
    return _mcap(p)


def _trace_of_unknown_solve(p):
    return _mcap(p.edit(A.TRACE_TOPIC, lambda f: f["problem_id"].__setitem__(0, 99_999)))


def _trace_twice(p):
    return _mcap(p.edit(A.TRACE_TOPIC, lambda f: f["problem_id"].__setitem__(1, f["problem_id"][0])))


def _with_solutions(p, count_edit=None, drop=False, no_n=False, pid_edit=None):
    """The DLS base made analytic-like: ``n_solutions`` on the solve message (1 each) and a solutions message
    holding each solve's q_solution, then damaged one way."""
    i, f = p.fields(A.SOLVE_TOPIC)
    n, j = len(f["problem_id"]), int(f["joints"][0])
    if not no_n:
        f["n_solutions"] = np.ones(n, dtype="<i4")
        p.put(i, A.SOLVE_TOPIC, f)
    sol = {"problem_id": f["problem_id"].copy(), "repetition": f["repetition"].copy(),
           "count": np.ones(n, dtype="<u4"), "joints": np.array([j], dtype="<u4"), "solutions": f["q_solution"]}
    if count_edit:
        sol["count"][0] = 2
        sol["solutions"] = np.concatenate([f["q_solution"][:j], f["q_solution"]])
    if pid_edit:
        for k in ("problem_id", "repetition", "count"):
            sol[k] = sol[k][:-1]
        sol["solutions"] = sol["solutions"][:-j]
    if not drop:
        p.msgs.insert(i + 1, [A.SOLUTIONS_TOPIC, 99, 0, A.encode_fields(A.SOLUTION_FIELDS, sol)])
    if A.SOLUTIONS_TOPIC not in {c.topic for c in p.channels.values()}:
        raise AssertionError("the base archive registers every channel")
    return _mcap(p)


def _extra_solves(p):
    i, f = p.fields(A.SOLVE_TOPIC)
    p.msgs.append([A.SOLVE_TOPIC, 500, 0, p.msgs[i][3]])
    return _mcap(p)


def _one_solve_less(p):
    def cut(f):
        j = int(f["joints"][0])
        for k, v in list(f.items()):
            if isinstance(v, np.ndarray) and k != "joints" and len(v) == N:
                f[k] = v[:-1]
        f["q_solution"] = f["q_solution"][:-j]
        if len(f["q_start"]):
            f["q_start"] = f["q_start"][:-j]
        f["info_json"] = json.dumps(json.loads(f["info_json"])[:-1]).encode()
    p.edit(A.SOLVE_TOPIC, cut)
    p.msgs = [m for m in p.msgs if m[0] != A.TRACE_TOPIC]
    return _mcap(p)


def _batch_past_1000(p):
    def grow(f):
        j = int(f["joints"][0])
        reps = 84  # 12 x 84 = 1008 solves in one message
        for k, v in list(f.items()):
            if isinstance(v, np.ndarray) and k != "joints" and len(v):
                f[k] = np.tile(v, reps)
        f["problem_id"] = np.arange(N * reps, dtype="<i4")
        f["info_json"] = json.dumps(json.loads(f["info_json"]) * reps).encode()
        del j
    p.run()["problems"] = str(N * 84)
    return _mcap(p.edit(A.SOLVE_TOPIC, grow))


def _unknown_problem(p):
    return _mcap(p.edit(A.SOLVE_TOPIC, lambda f: f["problem_id"].__setitem__(3, 777_777)))


def _labels_not_strings(p):
    return _mcap(p.edit(A.SOLVE_TOPIC, lambda f: f.__setitem__("labels_json", json.dumps({"solver": [1] * N}).encode())))


def _unknown_channel(p):
    recs = _records(p) + _records(p, [["/nowhere", 7, 0, b"x"]])
    return _mcap(p, [{"records": recs}])


def _record_past_chunk(p):
    recs = bytearray(_records(p))
    recs[1:9] = struct.pack("<Q", len(recs) + 100)
    return _mcap(p, [{"records": bytes(recs)}])


def _no_run_metadata(p):
    p.meta = [m for m in p.meta if m[0] != "run"]
    return _mcap(p)


GiB = 1 << 30
ARCHIVE_CASES = {  # name -> (bytes from parts, expected fragment)
    # metadata naming a file that is no problem set: never opened (an archive is read from anywhere)
    **{f"problem_path_{k}": (_meta(problem_path=v), why)
       for k, v, why in [("etc_passwd", "/etc/passwd", "is not a path relative to the archive; not read"),
                         ("proc_environ", "../../../../../../../../proc/self/environ",
                          "is not a .csv or .csv.gz file; not read"),
                         ("ssh_key", "/root/.ssh/id_rsa", "is not a path relative to the archive; not read"),
                         ("csv_absolute", "/tmp/x.csv", "is not a path relative to the archive; not read"),
                         ("yaml_in_problems", "../../problems/random/kuka_lwr.yaml",
                          "is not a .csv or .csv.gz file; not read")]},
    "chunk_declares_2_40": (lambda p: _mcap(p, _chunk(p, size=1 << 40)),
                            "declares 1099511627776 bytes uncompressed, past the 64 MiB chunk cap (MAX_CHUNK_BYTES)"),
    "chunk_frame_declares_2_40": (lambda p: _mcap(p, _chunk(p, payload=_frame_declaring(1 << 40), size=1 << 16)),
                                  "damaged zstd data"),
    "chunk_inflates_past_its_header": (lambda p: _mcap(p, _chunk(p, payload=_zstd_zeros(8 << 20), size=1 << 20)),
                                       "decompresses past the 1048576 bytes its header declares"),
    "chunk_smaller_than_its_header": (lambda p: _mcap(p, _chunk(p, size=len(_records(p)) + 1)),
                                      f"decompresses to {{n}} bytes, its header declares {{n1}}"),
    "chunk_one_byte_past_its_header": (lambda p: _mcap(p, _chunk(p, size=len(_records(p)) - 1)),
                                       "bytes its header declares (uncompressed_size)"),
    "chunk_crc_mismatch": (lambda p: _mcap(p, _chunk(p, crc=12345)), "CRC mismatch (the chunk's data changed"),
    "chunk_zstd_garbage": (lambda p: _mcap(p, _chunk(p, payload=b"\x28\xb5\x2f\xfd" + b"\xff" * 40)), "damaged zstd data"),
    "chunk_zstd_truncated": (lambda p: _mcap(p, _chunk(p, payload=zstandard.ZstdCompressor().compress(_records(p))[:200])),
                             "decompresses to"),
    "chunk_lz4": (lambda p: _mcap(p, _chunk(p, compression="lz4")), "compression b'lz4' (this package writes zstd)"),
    "chunk_index_points_nowhere": (lambda p: _mcap(p, _chunk(p, offset=9)), "the summary's chunk index points at no chunk"),
    "record_past_chunk": (_record_past_chunk, "runs past the chunk"),
    "message_on_unknown_channel": (_unknown_channel, "on channel 999, which the summary does not name"),
    "truncated_half": (lambda p: _mcap(p)[:len(_mcap(p)) // 2], "not a complete MCAP file"),
    "truncated_last_byte": (lambda p: _mcap(p)[:-1], "not a complete MCAP file"),
    "summary_crc": (lambda p: (lambda b: b[:-20] + bytes([b[-20] ^ 1]) + b[-19:])(_mcap(p)), "summary section CRC mismatch"),
    "duplicated_id_in_a_message": (_dup_in_message, "has a solve record twice"),
    "duplicated_id_across_messages": (_dup_across_messages, "has a solve record twice"),
    "trace_of_no_solve": (_trace_of_unknown_solve, "problem 99999 (repetition 0) has a trace but no solve record"),
    "trace_twice": (_trace_twice, "has a trace twice"),
    "n_solutions_without_solutions": (lambda p: _with_solutions(p, drop=True),
                                      "has field 'n_solutions' but no /ik/solutions message"),
    "solution_count_differs": (lambda p: _with_solutions(p, count_edit=True),
                               "has 2 solutions, its solve record's 'n_solutions' says 1"),
    "solutions_of_fewer_solves": (lambda p: _with_solutions(p, pid_edit=True), "counts differ across channels"),
    "solutions_without_n_solutions": (lambda p: _with_solutions(p, no_n=True),
                                      "solutions for a /ik/solve message without field 'n_solutions'"),
    "more_solves_than_promised": (_extra_solves, "more solve records than metadata field 'problems' promises (12)"),
    "fewer_solves_than_promised": (_one_solve_less, "11 solve records, metadata field 'problems' promises 12"),
    "message_past_1000_solves": (_batch_past_1000, "holds 1008 solves, a message holds at most 1000"),
    "problem_not_in_problem_set": (_unknown_problem, "problem 777777 is not in the problem file"),
    "labels_not_strings": (_labels_not_strings, "field 'labels_json' is not an object"),
    "format_version_6": (_meta(format_version="6"), "metadata field 'format_version' is '6'"),
    "format_version_missing": (_meta(format_version=None), "metadata field 'format_version' missing"),
    "problems_not_a_count": (_meta(problems="twelve"), "metadata field 'problems' is 'twelve', not a count"),
    "problems_past_cap": (_meta(problems=str(10**12)), "promise 1000000000000 solve records, past the 100000"),
    "repetitions_zero": (_meta(repetitions="0"), "metadata field 'repetitions' is '0', not a positive count"),
    "settings_not_json": (_meta(settings="{not json"), "metadata field 'settings' is not a JSON object"),
    "settings_a_list": (_meta(settings="[1, 2]"), "metadata field 'settings' is not a JSON object"),
    "trace_policy_garbage": (_meta(trace_policy='{"mode": 3}'), "metadata field 'trace_policy' is not a trace policy"),
    "seed_not_integer": (_meta(seed="1.5e3"), "metadata field 'seed' is '1.5e3', not an integer"),
    "problem_sha256_not_hex": (_meta(problem_sha256="../../etc"), "metadata field 'problem_sha256' is '../../etc'"),
    "traces_count_not_a_count": (_named_meta("traces", stored="many"), "metadata record 'traces': field 'stored'"),
    "job_timing_not_a_number": (_named_meta("job_timing", cpu_s="fast"), "metadata record 'job_timing': field 'cpu_s'"),
    "no_run_metadata": (_no_run_metadata, "no 'run' metadata record"),
}


def test_the_rebuilt_base_reads_as_the_original(base, parts, tmp_path):
    """The corpus's writer (:func:`_mcap`) is faithful: the base rebuilt reads as the base itself."""
    a, b = read_archive(base[2]), read_archive(_put(base, "rebuilt.mcap", _mcap(parts.copy())))
    assert a.metadata == b.metadata and repr(a.solves) == repr(b.solves) and repr(a.trace_index()) == repr(b.trace_index())
    assert len(a.solves) == N and a.stored_traces()


@pytest.mark.parametrize("case", sorted(ARCHIVE_CASES))
def test_hostile_archives_are_refused_in_one_line(base, parts, case):
    make, fragment = ARCHIVE_CASES[case]
    p = _put(base, f"{case}.mcap", make(parts.copy()))
    if "{n}" in fragment:
        n = len(_records(parts))
        fragment = fragment.format(n=n, n1=n + 1)
    _refused(read_archive, p, fragment, ArchiveError)


def test_an_archive_past_its_size_cap_is_not_read(tmp_path):
    p = tmp_path / "huge.mcap"
    with open(p, "wb") as fh:  # sparse
        fh.write(MAGIC)
        fh.truncate(A.MAX_ARCHIVE_BYTES + 1)
    _refused(read_archive, p, "bytes, past the 256 MiB archive cap (MAX_ARCHIVE_BYTES); not read")
    assert A.archive_metadata(p) == {}


def test_chunks_past_the_uncompressed_total_are_not_read(base, parts, monkeypatch):
    """The total over an archive's chunks (cap lowered here to 1 MiB; 1 GiB in use) is checked before the
    chunk that passes it is decompressed."""
    monkeypatch.setattr(archive_bounds, "MAX_UNCOMPRESSED_BYTES", 1 << 20)
    pad = b"\xff" + struct.pack("<Q", (600 << 10) - 9) + bytes((600 << 10) - 9)  # an unknown record, skipped
    p = _put(base, "total.mcap", _mcap(parts.copy(), [{"records": _records(parts) + pad}, {"records": pad}]))
    _refused(read_archive, p, "chunks declare more than 1 MiB uncompressed, past the archive cap")


# ---- forgeries with every CRC rebuilt: what verify and reproduce see ------------------------------
def _flags(p, i, xor):
    return p.edit(A.SOLVE_TOPIC, lambda f: f["flags"].__setitem__(i, f["flags"][i] ^ xor))


def _success_index(parts) -> int:
    _, f = parts.fields(A.SOLVE_TOPIC)
    return int(np.flatnonzero(f["flags"] & A.F_SUCCESS)[0])


def _ulp(p, i, j):
    def move(f):
        k = i * int(f["joints"][0]) + j
        f["q_solution"][k] = np.nextafter(f["q_solution"][k], np.inf)
    return p.edit(A.SOLVE_TOPIC, move)


def _robot():
    return ROBOT


def test_verify_recomputes_every_stored_verdict_of_the_real_archive(base):
    from pipeline.jobs.verify import record_problems

    assert record_problems(read_archive(base[2]), _robot()) == []


FORGERIES = {  # name -> (forge(parts, success index), verify's fragment, reproduce's field)
    "success_flag_flipped": (lambda p, i: _flags(p, i, A.F_SUCCESS), "whose flags contradict their stop reason", "success"),
    "success_and_stop_reason_forged": (
        lambda p, i: p.edit(A.SOLVE_TOPIC, lambda f: (f["flags"].__setitem__(i, f["flags"][i] ^ A.F_SUCCESS),
                                                      f["stop_reason"].__setitem__(i, 2))),
        "disagree with the FK check of their stored joints", "stop_reason"),
    "within_limits_flipped": (lambda p, i: _flags(p, i, A.F_WITHIN), "field 'within_limits'", "within_limits"),
    "position_error_one_ulp": (
        lambda p, i: p.edit(A.SOLVE_TOPIC, lambda f: f["position_error"].__setitem__(i, np.nextafter(f["position_error"][i], 1))),
        "field 'position_error'", "position_error"),
    "final_error_edited": (
        lambda p, i: p.edit(A.SOLVE_TOPIC, lambda f: f["final_error"].__setitem__(i, f["final_error"][i] * 0.5)),
        "whose errors differ from their stored traces", "final_error"),
    "iterations_edited": (lambda p, i: p.edit(A.SOLVE_TOPIC, lambda f: f["iterations"].__setitem__(i, f["iterations"][i] + 1)),
                          None, "iterations"),
}


@pytest.mark.parametrize("case", sorted(FORGERIES))
def test_forgeries_with_rebuilt_crcs_are_found_by_verify_and_reproduce(base, parts, case, capsys):
    from pipeline.jobs.verify import record_problems

    forge, fragment, name = FORGERIES[case]
    i = _success_index(parts)
    p = _put(base, f"{case}.mcap", _mcap(forge(parts.copy(), i)))
    a = read_archive(p)  # reads: a consistent forgery is no read error
    lines = record_problems(a, _robot())
    if fragment is None:  # iterations are not derived from anything stored: only a re-run sees them
        assert lines == []
    else:
        assert lines and all(ln.startswith(f"{p}: ") for ln in lines) and any(fragment in ln for ln in lines), lines
    rc, out, err = _cli(["reproduce", str(p), "--data", str(DATA)], capsys)
    assert rc == 0, err
    row = next(ln for ln in out.splitlines() if ln.startswith(p.name))
    assert f"{name}:1" in row and "0 bit-identical on every re-run solve, 1 with differences" in out, out


def test_a_solution_moved_by_one_ulp_is_found_without_a_re_run(base, parts, capsys):
    """verify's FK check sees a one-ulp move of a joint where it changes the check's floats (the first
    joint of the first success that it does, here), and most one-ulp moves do; reproduce sees them all."""
    from pipeline.jobs.verify import fk_problems

    i = _success_index(parts)
    for j in range(7):
        p = _put(base, f"ulp_{j}.mcap", _mcap(_ulp(parts.copy(), i, j)))
        lines = fk_problems(read_archive(p), _robot())
        if lines:
            break
    assert lines and ("field 'position_error'" in lines[0] or "field 'orientation_error'" in lines[0]), lines
    rc, out, _ = _cli(["reproduce", str(p), "--data", str(DATA)], capsys)
    assert rc == 0 and "q_solution:1" in out
    every = parts.copy()
    for k in range(N):
        _ulp(every, k, 0)
    p = _put(base, "ulp_every.mcap", _mcap(every))
    (line,) = fk_problems(read_archive(p), _robot())
    assert int(line.split(": ")[1].split()[0]) >= 9, line  # 9 or more of the 12 moves seen


def _tree(base, tmp_path, blob: bytes | None = None, pset: bytes | None = None) -> Path:
    """A copy of the base results tree, its archive replaced by ``blob`` and/or its problem set by ``pset``,
    and its manifest rebuilt (a forger's last step)."""
    from pipeline.io.manifest import write_manifest

    res = tmp_path / "results"
    rel = base[2].relative_to(base[0])
    shutil.copytree(base[0], res, ignore=lambda d, names: [n for n in names if n.endswith(".mcap") and n != rel.name])
    if blob is not None:
        (res / rel).write_bytes(blob)
    if pset is not None:
        (res / base[1].relative_to(base[0])).write_bytes(pset)
    write_manifest(res)
    return res


@pytest.mark.parametrize("case,fragment", [
    ("duplicated_id", "has a solve record twice"),
    ("success_flag_flipped", "whose flags contradict their stop reason"),
    ("moved_one_ulp", "disagree with the FK check of their stored joints"),
])
def test_the_verify_verb_fails_on_forgeries_with_a_rebuilt_manifest(base, parts, tmp_path, capsys, case, fragment):
    i = _success_index(parts)
    forged = {"duplicated_id": lambda p: _dup_in_message(p),
              "success_flag_flipped": lambda p: _mcap(_flags(p, i, A.F_SUCCESS)),
              "moved_one_ulp": lambda p: _mcap(_ulp_every(p))}[case](parts.copy())
    res = _tree(base, tmp_path, blob=forged)
    rc, out, _ = _cli(["verify", str(res), "--data", str(DATA)], capsys)
    line = next(ln for ln in out.splitlines() if ln.startswith(f"{SID}: "))
    assert rc == 1 and fragment in line and str(res / base[2].relative_to(base[0])) in line, out
    assert any(ln.startswith("manifest: ok") for ln in out.splitlines()), out  # the manifest was rebuilt to match


def _ulp_every(p):
    for k in range(N):
        _ulp(p, k, 0)
    return p


# ---- CLI verbs in-process -----------------------------------------------------------------------
@pytest.mark.parametrize("case", ["chunk_declares_2_40", "duplicated_id_in_a_message", "format_version_6",
                                  "truncated_half", "chunk_crc_mismatch"])
def test_inspect_and_reproduce_verbs_give_the_one_line(base, parts, capsys, case):
    make, fragment = ARCHIVE_CASES[case]
    p = _put(base, f"cli_{case}.mcap", make(parts.copy()))
    for verb in (["inspect", str(p)], ["reproduce", str(p), "--data", str(DATA)]):
        rc, out, err = _cli(verb, capsys)
        lines = err.strip().splitlines()
        assert rc == 2 and len(lines) == 1 and lines[0].startswith(f"error: {p}: ") and fragment in lines[0], err


@pytest.mark.parametrize("case", ["gzip_bomb_cap_plus_1MiB", "not_gzip_with_gz_name", "duplicated_problem_id",
                                  "nan_goal"])
def test_problem_file_verbs_give_the_one_line(base, tmp_path, capsys, case):
    name, make, fragment = PROBLEM_CASES[case]
    bad = tmp_path / ("bad" + name[1:])
    bad.write_bytes(make(base))
    argvs = [["solve_problems", "--study", STUDY, "--problem-set", "random", "--robot", str(ROBOT), "--solver", "dls",
              "--problems", str(bad), "--scale", "quick", "--out", str(tmp_path / "x.mcap")],
             ["inspect", str(base[2]), "--problems", str(bad)],
             ["reproduce", str(base[2]), "--problems", str(bad), "--data", str(DATA)]]
    for argv in argvs:
        rc, out, err = _cli(argv, capsys)
        lines = err.strip().splitlines()
        assert rc == 2 and len(lines) == 1 and lines[0].startswith(f"error: {bad}: ") and fragment in lines[0], err
    assert not (tmp_path / "x.mcap").exists()


# ---- true bombs, in a process of 1 GiB address space: one line, peak RSS under 1 GiB -------------------
@pytest.fixture(scope="module")
def bombs(base, tmp_path_factory):
    d = tmp_path_factory.mktemp("bombs")
    gz = d / "bomb.csv.gz"
    gz.write_bytes(_gz_zeros(5 * GiB))  # 5 GiB of zeros, ~5 MB on disk
    assert gz.stat().st_size < 8 << 20
    parts = _parts(base[2])
    z5 = _zstd_zeros(5 * GiB)
    inflate = _put(base, "bomb_inflates.mcap", _mcap(parts, _chunk(parts, payload=z5, size=A.MAX_CHUNK_BYTES)))
    declare = _put(base, "bomb_declares.mcap", _mcap(parts, _chunk(parts, size=1 << 40)))
    frame = _put(base, "bomb_frame.mcap", _mcap(parts, _chunk(parts, payload=_frame_declaring(1 << 40), size=1 << 16)))
    return gz, inflate, declare, frame


def test_bombs_stay_within_a_gibibyte_and_one_line(base, bombs, tmp_path):
    from tests.test_malformed_inputs import _run_limited

    gz, inflate, declare, frame = bombs
    runs = [
        (["solve_problems", "--study", STUDY, "--problem-set", "random", "--robot", str(ROBOT), "--solver", "dls",
          "--problems", str(gz), "--scale", "quick", "--out", str(tmp_path / "x.mcap")], gz, "decompresses past 64 MiB"),
        (["inspect", str(base[2]), "--problems", str(gz)], gz, "decompresses past 64 MiB"),
        (["reproduce", str(base[2]), "--problems", str(gz), "--data", str(DATA)], gz, "decompresses past 64 MiB"),
        (["inspect", str(inflate)], inflate, "decompresses past the 67108864 bytes its header declares"),
        (["inspect", str(declare)], declare, "past the 64 MiB chunk cap"),
        (["inspect", str(frame)], frame, "damaged zstd data"),
    ]
    for argv, named, fragment in runs:
        proc, rss_mib = _run_limited(argv, tmp_path)
        lines = proc.stderr.strip().splitlines()
        assert proc.returncode == 2 and "Traceback" not in proc.stderr and len(lines) == 1, (argv, proc.stderr)
        assert lines[0].startswith(f"error: {named}: ") and fragment in lines[0], lines[0]
        assert rss_mib < 1024, (argv, rss_mib)


def test_verify_names_a_bombed_problem_set_within_a_gibibyte(base, bombs, tmp_path):
    from tests.test_malformed_inputs import _run_limited

    res = _tree(base, tmp_path, pset=bombs[0].read_bytes())
    proc, rss_mib = _run_limited(["verify", str(res), "--data", str(DATA)], tmp_path)
    line = next(ln for ln in proc.stdout.splitlines() if ln.startswith(f"{SID}: "))
    pset = res / base[1].relative_to(base[0])
    assert proc.returncode == 1 and "Traceback" not in proc.stderr + proc.stdout, proc.stderr
    assert f"{pset}: decompresses past 64 MiB (the problem-file cap" in line and "problem set of archive" in line, line
    assert rss_mib < 1024, rss_mib


def test_the_corpus_is_large_enough():
    assert len(PROBLEM_CASES) + len(ARCHIVE_CASES) + len(FORGERIES) + 4 >= 40


_OPENED: list | None = None


def _opened() -> list:
    """Paths under /etc or /proc/self/environ this process opened since the list was last cleared (one audit
    hook for the whole session: hooks cannot be removed, so it is installed once and only records)."""
    global _OPENED
    if _OPENED is None:
        _OPENED = []

        def hook(event, args):
            if event == "open" and isinstance(args[0], str) and args[0].startswith(("/etc/", "/proc/self/environ")):
                _OPENED.append(args[0])

        sys.addaudithook(hook)
    return _OPENED


@pytest.mark.parametrize("field,value", [("robot_file", "/etc/passwd"), ("robot_path", "../../../../../etc/passwd"),
                                         ("robot_file", "/proc/self/environ"), ("robot", "../../../etc/x")])
def test_reproduce_and_verify_never_open_a_file_the_metadata_names_outside_robots(base, parts, field, value, capsys):
    """A forged ``robot_file``/``robot_path``/``robot`` field: reproduce refuses the archive, or finds the
    robot file in the data folder by the archive's robot name, and never opens the named file."""
    p = _put(base, f"forged_{field}.mcap", _meta(**{field: value})(parts.copy()))
    opened = _opened()
    opened.clear()
    rc, out, err = _cli(["reproduce", str(p), "--sample", "2", "--data", str(DATA)], capsys)
    assert not [f for f in opened if "passwd" in f or "environ" in f], opened
    assert "Traceback" not in err
    if rc != 0:
        assert len(err.strip().splitlines()) == 1 and field.split("_")[0] in err, err
