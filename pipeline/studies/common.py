"""Helpers shared by study modules: archive frames, published tables, summary statistics."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from pipeline.io.archive import Archive
from pipeline.io.csvfiles import read_csv
from pipeline.studies.specs import TableSpec


def archive_method(a: Archive) -> tuple[str, str]:
    """(registered method, library) of an archive: the metadata's ``method`` and ``library`` fields (older
    archives: the settings' ``method``, and the registry's library for it), never a solver setting."""
    method = a.metadata.get("method") or json.loads(a.metadata["settings"]).get("method", a.metadata["solver"])
    library = a.metadata.get("library")
    if not library:
        from pipeline.solvers.core import registry

        library = registry.get(method).library if method in registry.names() else "ours"
    return method, library


def archive_library_version(a: Archive, library: str) -> str:
    """The version of ``library`` recorded in an archive's environment (``""`` for ours, for an archive
    without the record, or for a library it did not record)."""
    if library == "ours":
        return ""
    try:
        version = json.loads(a.metadata.get("environment") or "{}").get("libraries", {}).get(library, "")
    except (TypeError, ValueError, AttributeError):
        return ""
    return "" if version in ("", "not installed") else str(version)


def library_label(library: str, version: str) -> str:
    """A library as a table shows it: ``ours``, or the distribution's name and the version its archive
    recorded (``"ikpy 4.2.1"``)."""
    return f"{library} {version}" if version and library != "ours" else library


def solves_frame(archives: list[Archive]) -> pd.DataFrame:
    """All solve records of several archives, with ``solver``, ``method``, ``library`` and
    ``library_version`` columns (:func:`archive_method`, :func:`archive_library_version`)."""
    frames = []
    for a in archives:
        df = a.frame()
        method, library = archive_method(a)
        df["method"], df["library"] = method, library
        df["library_version"] = archive_library_version(a, library)
        df["archive"] = str(a.path)
        frames.append(df)
    return pd.concat(frames, ignore_index=True)


def cpu_time(df: pd.DataFrame) -> pd.Series:
    """Each solve's thread CPU time [s] (archives without it: the monotonic solve time): the time
    measure machine load does not move, which the document studies' time tables use."""
    cpu = df["cpu_time_s"] if "cpu_time_s" in df else pd.Series(np.nan, index=df.index)
    return cpu.where(np.isfinite(cpu), df["solve_time_s"])


def published(published_dir: Path, study: str, name: str) -> pd.DataFrame | None:
    """A published table ``data/published/<study>/<name>.csv`` or None when absent."""
    path = Path(published_dir) / study / f"{name}.csv"
    return read_csv(path) if path.is_file() else None


def describe(x, stats=("min", "max", "mean", "std")) -> dict:
    """min/max/mean/sample std (ddof=1, as SPSS and MATLAB std) of a 1-D sample; NaN when empty."""
    x = np.asarray(x, dtype=float)
    out = {}
    for s in stats:
        if x.size == 0 or (s == "std" and x.size < 2):
            out[s] = np.nan
        elif s == "std":
            out[s] = float(np.std(x, ddof=1))
        else:
            out[s] = float(getattr(np, s)(x))
    return out


def percentiles(x, qs=(50, 95, 99)) -> dict:
    x = np.asarray(x, dtype=float)
    return {f"p{q}": (float(np.percentile(x, q)) if x.size else np.nan) for q in qs}


def load_table(archives: list[Archive]):
    """The machine's load while the study's jobs solved (each archive's ``job_timing`` record), one row
    per problem set, or None when no archive records it: the record beside the times load may move."""
    rows = []
    for a in archives:
        t = a.job_timing or {}
        if "load_1min_start" in t:
            rows.append({"problem set": a.metadata.get("problem_set", ""), "share": float(t["cpu_share"]),
                         "load": max(float(t["load_1min_start"]), float(t["load_1min_end"])),
                         "cores": int(t.get("cores", 0))})
    if not rows:
        return None
    df = pd.DataFrame(rows)
    out = pd.DataFrame([{"problem set": k, "jobs": len(g), "cores": int(g["cores"].max()),
                         "job CPU share, smallest [-]": g["share"].min(), "job CPU share, median [-]": g["share"].median(),
                         "1-min load average, largest [-]": g["load"].max()}
                        for k, g in df.groupby("problem set", sort=False)])
    return TableSpec("machine_load", "Machine load while the jobs solved (the load record)", out,
                     "From each archive's job_timing record: the job's CPU share (CPU time / wall time of its solving) "
                     "and the 1-minute load average at its start and end. The time-based tables and claims use thread "
                     "CPU time, which time spent waiting for a core does not count, so their verdicts do not follow "
                     "this load; wall-clock columns (named so) do.")
