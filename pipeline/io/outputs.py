"""Where a verb may write: never over a file it reads, never over a build's archive or problem set, and
over any other existing file only when asked (``--force``).

:func:`check_outputs` runs before every verb (``pipeline/cli.py``), on the arguments that name files to
write (``--out``, ``-o``, ``--csv``, ``--write-robot``, ``--res``; folders: ``--out-dir``, ``--report-dir``,
``--build-dir``) against every other argument that
names an existing file or folder. Snakemake removes a job's outputs before it runs the job, so the
rules never need ``--force``; a user re-running a verb by hand over its last output does.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from pipeline.errors import UsageError

# argument names (argparse ``dest``) that name a file a verb writes; ``out_dir`` names a folder
OUTPUT_ARGS = ("out", "csv", "write_robot", "res")
OUTPUT_DIR_ARGS = ("out_dir", "report_dir", "build_dir")
# folders of a results tree that hold a build's inputs to its tables: archives and problem sets
RESULT_INPUT_DIRS = ("runs", "race", "problems")
MCAP_MAGIC = b"\x89MCAP"
GZIP_MAGIC = b"\x1f\x8b"


def _flag(dest: str) -> str:
    return {"out": "--out", "csv": "--csv", "write_robot": "--write-robot", "out_dir": "--out-dir"}.get(
        dest, "--" + dest.replace("_", "-"))


def _stat(path: str):
    try:
        return os.stat(path)
    except (OSError, ValueError):
        return None


def _is_build_input(path: Path) -> str | None:
    """What ``path`` (an existing file) is, when it is an archive or a problem set of a results tree."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except OSError:
        return None
    parts = set(path.resolve().parent.parts)
    if head.startswith(MCAP_MAGIC) and parts & {"runs", "race"}:
        return "an archive of a results tree"
    if (path.name.endswith(".csv.gz") or path.name.endswith(".csv")) and "problems" in parts:
        return "a problem set of a results tree"
    return None


def check_outputs(args: dict, force: bool = False) -> None:
    """Refuse an output argument a verb must not write.

    An output argument is refused when it names

    - a folder (for a file output) or an existing file (for a folder output);
    - a file one of the other arguments names (the same inode: links and symbolic links count);
    - an existing archive or problem set of a results tree (even with ``force``);
    - any other existing file, unless ``force``.

    Parameters
    ----------
    args : dict
        A verb's parsed arguments (``vars(namespace)``).
    force : bool, optional
        The verb's ``--force``: overwrite an existing file that is none of the above.

    Raises
    ------
    UsageError
        One line naming the flag and the path.
    """
    inputs: list[tuple[str, os.stat_result]] = []
    for key, value in args.items():
        if key in OUTPUT_ARGS or key in OUTPUT_DIR_ARGS or key in ("func", "verb"):
            continue
        for v in value if isinstance(value, list) else [value]:
            if isinstance(v, str) and v:
                st = _stat(v)
                if st is not None and stat.S_ISREG(st.st_mode):
                    inputs.append((v, st))
    for key in OUTPUT_ARGS + OUTPUT_DIR_ARGS:
        values = args.get(key)
        for out in values if isinstance(values, list) else [values]:
            if not isinstance(out, str) or not out:
                continue
            st = _stat(out)
            if st is None:
                continue
            flag = _flag(key)
            if key in OUTPUT_DIR_ARGS:
                if not stat.S_ISDIR(st.st_mode):
                    raise UsageError(f"{flag} {out}: exists and is not a folder")
                continue
            if stat.S_ISDIR(st.st_mode):
                raise UsageError(f"{flag} {out}: is a folder; name the file to write")
            for name, ist in inputs:
                if (ist.st_dev, ist.st_ino) == (st.st_dev, st.st_ino):
                    raise UsageError(f"{flag} {out}: is also an input of this command ({name}); write elsewhere")
            what = _is_build_input(Path(out))
            if what:
                raise UsageError(f"{flag} {out}: is {what}; write elsewhere (it is never overwritten)")
            if not force:
                raise UsageError(f"{flag} {out}: exists (use --force to overwrite)")
