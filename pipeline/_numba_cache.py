"""numba's on-disk cache, keyed on the whole package's source.

numba checks a cached function against its own source file only. A kernel that inlines a function of
another module (the solvers inline the FK check of :mod:`pipeline.kinematics.fkcheck`, for example)
keeps its old machine code after that other module changes: a checkout or an edit could then run stale
code and give other numbers without any error. So the cache lives in a directory named after a digest
of every ``.py`` file of the package (``pipeline/__pycache__/numba/<digest>``, or the user's cache
directory where the package is not writable); a changed source starts an empty cache, and the caches
of earlier sources are removed. Hashing the sources takes about 6 ms per process.

A ``NUMBA_CACHE_DIR`` the user set is left alone.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
from pathlib import Path

_OURS = "PIPELINE_NUMBA_CACHE_DIR"  # the directory we chose (a NUMBA_CACHE_DIR equal to it is ours, not the user's)


def source_digest(root: Path) -> str:
    """16 hex digits of SHA-1 over every ``.py`` file under ``root`` (relative path and bytes, sorted)."""
    h = hashlib.sha1()
    for f in sorted(root.rglob("*.py")):
        h.update(f.relative_to(root).as_posix().encode())
        h.update(b"\0")
        h.update(f.read_bytes())
    return h.hexdigest()[:16]


def use_source_keyed_cache() -> None:
    """Point numba's cache at the directory of this source (see the module docstring)."""
    given = os.environ.get("NUMBA_CACHE_DIR")
    if given and given != os.environ.get(_OURS):
        return  # the user's own choice
    root = Path(__file__).resolve().parent
    try:
        digest = source_digest(root)
    except OSError:  # an unreadable source file: leave numba's default
        return
    base = root / "__pycache__" / "numba"
    if not os.access(root, os.W_OK):
        base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "ik-pipeline" / "numba"
    here = base / digest
    os.environ["NUMBA_CACHE_DIR"] = os.environ[_OURS] = str(here)
    if "numba" in sys.modules:  # imported before us: its configuration is read already
        sys.modules["numba"].config.CACHE_DIR = str(here)
    if base.is_dir():
        for old in base.iterdir():
            if old.name != digest and old.is_dir():
                shutil.rmtree(old, ignore_errors=True)
