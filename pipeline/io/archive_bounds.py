"""Bounded reading of an archive's bytes: the size caps, the file and chunk CRCs, chunk by chunk
decompression within the caps, and the ``run`` metadata of a file that could not be read."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

from pipeline.io.archive_format import ArchiveError

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


def read_bytes(path: Path) -> bytes:
    """The bytes of an archive, refused past :data:`MAX_ARCHIVE_BYTES` (checked before they are read).

    Parameters
    ----------
    path : Path

    Returns
    -------
    bytes

    Raises
    ------
    ArchiveError
        The file cannot be read or is past the cap.
    """
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


def summary_reader(data: bytes):
    """An mcap reader over the bytes in memory.

    A record declaring more bytes than the file holds reads what there is: nothing is allocated for a
    declared length.

    Parameters
    ----------
    data : bytes
        A whole MCAP file.

    Returns
    -------
    mcap.reader.SeekingReader
        Records limited to :data:`MAX_CHUNK_BYTES`, CRCs validated.
    """
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
class ChunkMessage:
    """One message read from a chunk: its channel's topic, sequence number, log time [ns] and payload."""
    topic: str
    sequence: int
    log_time: int
    data: bytes


def chunk_messages(path: Path, topics=None, data: bytes | None = None, summary=None) -> Iterator[ChunkMessage]:
    """The messages of ``topics`` in file order, each chunk read within the caps of this module.

    File order is the writer's order (its log times never decrease). Each chunk's CRC is checked. mcap's
    own reader is used for the summary and metadata only: it sizes a chunk's output buffer from the
    chunk's declared uncompressed size, or the zstd frame's, before it decompresses.

    Parameters
    ----------
    path : Path
        The archive (named in errors; read when ``data`` is None).
    topics : collection of str, optional
        The topics to yield (all when None).
    data : bytes, optional
        The file's bytes, when the caller holds them.
    summary : mcap.records.Summary, optional
        The file's summary, when the caller has parsed it.

    Yields
    ------
    ChunkMessage

    Raises
    ------
    ArchiveError
        One line naming the file (and the chunk) at the first cap passed or damage found.
    """
    if data is None:
        data = read_bytes(path)
    try:
        if summary is None:
            summary = summary_reader(data).get_summary()
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
        size, crc, clen, end = _chunk_header(data, o, where)
        total += size
        if total > MAX_UNCOMPRESSED_BYTES:
            raise ArchiveError(f"{path}: chunks declare more than {_mib(MAX_UNCOMPRESSED_BYTES)} uncompressed, "
                               f"past the archive cap (MAX_UNCOMPRESSED_BYTES); not read")
        raw = _chunk_data(data, o, end, size, crc, clen, where)
        yield from _chunk_records(raw, where, channels, want)


def _chunk_header(data: bytes, o: int, where: str) -> tuple[int, int, int, int]:
    """The chunk record at byte ``o``: (declared uncompressed size within :data:`MAX_CHUNK_BYTES`, CRC,
    length of its compression name, end of the record)."""
    import struct

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
    return size, crc, clen, end


def _chunk_data(data: bytes, o: int, end: int, size: int, crc: int, clen: int, where: str) -> bytes:
    """The records of the chunk at byte ``o``, decompressed to its declared ``size`` and checked against its CRC."""
    import struct
    from zlib import crc32

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
    return raw


def _chunk_records(raw: bytes, where: str, channels: dict, want: set) -> Iterator[ChunkMessage]:
    """The messages on the ``want`` channels among a chunk's records, in order."""
    import struct

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
                yield ChunkMessage(channels[cid], seq, t, raw[body + 22:body + n])
        pos = body + n


def iter_messages(path: Path, topics):
    """The messages of ``topics`` as :func:`chunk_messages` reads them, in the shape of mcap's ``iter_messages``.

    Parameters
    ----------
    path : Path
    topics : collection of str

    Yields
    ------
    tuple
        ``(None, None, message)``, message a :class:`ChunkMessage` (``.sequence``, ``.data``).
    """
    for m in chunk_messages(path, topics):
        yield None, None, m


MAGIC = b"\x89MCAP0\r\n"


def check_file_crcs(path: Path, data: bytes | None = None) -> bool:
    """Check the whole file against the CRCs the writer stored.

    The data section's (DataEnd record: every byte from the start to the summary, metadata included) and
    the summary's (Footer). Each chunk's own CRC is checked when it is read (:func:`chunk_messages`);
    these two cover the rest, so a changed byte anywhere (an edited metadata value, a flipped bit in a
    record header) is caught.

    Parameters
    ----------
    path : Path
        The archive.
    data : bytes, optional
        The file's bytes when the caller holds them (else read within :data:`MAX_ARCHIVE_BYTES`).

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

    data = read_bytes(path) if data is None else data
    if len(data) < 2 * len(MAGIC) + 29 or data[:8] != MAGIC or data[-8:] != MAGIC:
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
    """The ``run`` metadata record of an MCAP file, unchecked: for naming what a file is after
    :func:`pipeline.io.archive.read_archive` refused it.

    Read within :data:`MAX_ARCHIVE_BYTES`, by a linear pass over the file's records that never
    decompresses a chunk (a truncated file's metadata is still found).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    dict[str, str]
        The record; {} when there is none or the file cannot be read.
    """
    import io

    from mcap.records import Metadata
    from mcap.stream_reader import StreamReader

    try:
        data = read_bytes(Path(path))
        for r in StreamReader(io.BytesIO(data), emit_chunks=True, record_size_limit=MAX_ARCHIVE_BYTES).records:
            if isinstance(r, Metadata) and r.name == "run":
                return dict(r.metadata)
    except Exception:  # noqa: BLE001  (any damage: nothing to name)
        pass
    return {}
