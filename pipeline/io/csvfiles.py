"""CSV tables read with a size cap: the published tables (``data/published``), a study's own tables and
claims (``results/<study>/tables``) and the Snakemake benchmark files the report reads.

A CSV file is parsed whole by pandas, which takes several times the file's size in memory, so a file
past :data:`MAX_CSV_BYTES` is refused before it is opened, in one line naming it and the cap. The
largest CSV of a full build is the arm benchmark's per-solve samples, written gzip-compressed and
never read back by the report; the largest table read back is under 1 MiB.
"""

from __future__ import annotations

import os
from pathlib import Path

from pipeline.provenance import DamagedFileError

MAX_CSV_BYTES = 64 << 20  # 64 MiB: over 60x the largest table a full build reads back


class OversizeFileError(DamagedFileError):
    """A file past its size cap (one line naming the file and the cap)."""


def read_csv(path: str | Path, **kwargs):
    """``pandas.read_csv(path, **kwargs)`` after checking the file is at most :data:`MAX_CSV_BYTES`.

    Parameters
    ----------
    path : str or Path
        The CSV file (plain or compressed, as pandas reads it).
    **kwargs
        Passed to :func:`pandas.read_csv`.

    Returns
    -------
    pandas.DataFrame

    Raises
    ------
    OversizeFileError
        The file is larger than the cap (it is not opened).
    """
    import pandas as pd

    size = os.stat(path).st_size
    if size > MAX_CSV_BYTES:
        raise OversizeFileError(f"{path}: {size / 2**20:.0f} MiB, past the {MAX_CSV_BYTES >> 20} MiB CSV cap "
                                "(pipeline/io/csvfiles.py MAX_CSV_BYTES); not read")
    return pd.read_csv(path, **kwargs)
