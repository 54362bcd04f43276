"""What produced a number: library versions, Python, CPU model and BLAS (archives and the report).

Everything here is read, never guessed: a library that is not installed is reported as such, a CPU
or BLAS that cannot be identified as ``unknown``.
"""

from __future__ import annotations

import hashlib
import os
import platform
import subprocess
from functools import lru_cache
from importlib import metadata as _md
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent  # the checkout (for git_commit)

# every library that touches the numbers (solvers, tables, figures, archives, the workflow),
# and the peer libraries the benchmark runs as baselines
LIBRARIES = ("numpy", "numba", "scipy", "pandas", "matplotlib", "mcap", "zstandard", "snakemake", "pyyaml",
             "jsonschema", "jinja2", "yourdfpy", "roboticstoolbox-python", "spatialmath-python", "pytracik", "pin",
             "ur-analytic-ik", "eaik", "ik-geo", "pybullet", "ikpy", "pin-pink", "mink", "mujoco", "daqp", "placo")


def library_versions(names=LIBRARIES) -> dict[str, str]:
    """Installed version of each distribution, or ``"not installed"``."""
    out = {}
    for name in names:
        try:
            out[name] = _md.version(name)
        except _md.PackageNotFoundError:
            out[name] = "not installed"
    return out


def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo``; ``platform.processor()`` elsewhere)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def blas() -> str:
    """The BLAS numpy was built against, with its version and (when known) the CPU kernel in use."""
    import numpy as np

    name = "unknown"
    try:
        cfg = np.show_config(mode="dicts")
        b = cfg.get("Build Dependencies", {}).get("blas", {})
        name = " ".join(str(b[k]) for k in ("name", "version") if b.get(k)) or name
    except Exception:  # noqa: BLE001  (older numpy: no dict mode)
        pass
    try:
        from threadpoolctl import threadpool_info

        for info in threadpool_info():
            if info.get("user_api") == "blas":
                core = info.get("architecture")
                return f"{name} (core {core})" if core else name
    except Exception:  # noqa: BLE001  (threadpoolctl is optional)
        pass
    return name


@lru_cache(maxsize=1)
def environment() -> dict:
    """Python, platform, CPU, BLAS and library versions (cached: the same for a whole process)."""
    return {"python": platform.python_version(), "platform": platform.platform(), "host": platform.node(),
            "cpu": cpu_model(),
            "blas": blas(), "libraries": library_versions(),
            # settings that change which CPU kernels run (and so, possibly, the last bits of a result)
            "kernel_overrides": {k: os.environ[k] for k in KERNEL_VARIABLES if os.environ.get(k)}}


KERNEL_VARIABLES = ("OPENBLAS_CORETYPE", "NUMBA_CPU_NAME", "NUMBA_CPU_FEATURES", "MKL_CBWR", "MKL_DEBUG_CPU_TYPE")


def git_commit(root: Path = ROOT) -> str:
    """The checkout's commit (``+dirty`` when tracked files differ), or ``unknown``."""
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True,
                              timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return (head + ("+dirty" if dirty else "")) if head else "unknown"


class DamagedFileError(ValueError):
    """A file cannot be hashed: a damaged gzip stream (one line naming the file)."""


# the most a ``.gz`` file may decompress to when it is hashed (the problem-file cap of
# pipeline.io.problems, MAX_PROBLEM_TEXT_BYTES: a gzip bomb is refused, not hashed for minutes)
MAX_HASHED_TEXT_BYTES = 64 << 20


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file's content: of the decompressed text for a ``.gz`` file (a problem set), so
    the hash does not depend on the compressor's version. Read in 1 MiB blocks: memory stays flat.

    Raises
    ------
    DamagedFileError
        A ``.gz`` file that does not decompress (CRC mismatch, truncated stream, not gzip), or that
        decompresses past ``MAX_HASHED_TEXT_BYTES``.
    """
    import zlib

    h = hashlib.sha256()
    gz = str(path).endswith(".gz")
    d = zlib.decompressobj(16 + zlib.MAX_WBITS) if gz else None
    total = 0
    try:
        with open(path, "rb") as fh:
            while True:
                block = fh.read(1 << 20)
                if not block:
                    break
                if d is None:
                    h.update(block)
                    continue
                while block:
                    if d.eof:  # another gzip member follows: hashed on, as gzip.decompress would read it
                        d = zlib.decompressobj(16 + zlib.MAX_WBITS)
                    out = d.decompress(block, 1 << 20)
                    total += len(out)
                    if total > MAX_HASHED_TEXT_BYTES:
                        raise DamagedFileError(f"{path}: decompresses past {MAX_HASHED_TEXT_BYTES >> 20} MiB (the "
                                               "problem-file cap); not read")
                    h.update(out)
                    block = d.unused_data if d.eof else d.unconsumed_tail
        if d is not None and not d.eof:
            raise DamagedFileError(f"{path}: damaged gzip file (Compressed file ended before the end-of-stream "
                                   "marker was reached)")
    except zlib.error as exc:
        raise DamagedFileError(f"{path}: damaged gzip file ({exc})") from None
    return h.hexdigest()


def bytes_sha256(path: str | Path) -> str:
    """SHA-256 of a file's bytes as they are on disk (the build manifest's hash: compressed or not)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()
