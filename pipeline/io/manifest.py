"""The build manifest: the SHA-256 of every file a build produced, written last, checked by ``verify``.

``results/MANIFEST.sha256`` (the ``manifest`` verb and Snakemake rule, after the report) holds one line
per produced file, ``<sha256 of its bytes>  <path relative to the results folder>``, sorted by path: the
``sha256sum`` format, so ``cd results && sha256sum -c MANIFEST.sha256`` checks it without this package.
Every file under the results folder is listed (archives, problem sets, tables, figures, the report and
the studies' own outputs) except the job logs and benchmark files (``logs/``, ``benchmarks/``: they
record each run, not its results), hidden files (Snakemake's markers) and unfinished ``*.partial``
files.

What it protects against: any change to a listed file after the build (an archive rewritten with its
CRCs recomputed, a table or figure edited, a problem set replaced), a listed file deleted, and a file
added to the tree that the build did not write. What it does not: an edit by someone who also rewrites
the manifest (it is a checksum list, not a signature: keep a copy of the manifest, or its own hash,
where the tree's editors cannot reach it), and nothing outside the results folder (the data folder's
robot files and study settings are checked through the hashes the archives record).
"""

from __future__ import annotations

from pathlib import Path

from pipeline.provenance import bytes_sha256

MANIFEST = "MANIFEST.sha256"
SKIPPED_DIRS = ("logs", "benchmarks")  # per-run records, not results


def produced_files(results: Path) -> list[str]:
    """Every file the manifest covers (not logs, benchmarks, hidden or ``.partial`` files, nor the manifest).

    Parameters
    ----------
    results : Path
        The results tree.

    Returns
    -------
    list of str
        Paths relative to ``results``, POSIX, sorted.
    """
    results = Path(results)
    out = []
    for f in results.rglob("*"):
        rel = f.relative_to(results)
        if (not f.is_file() or rel.as_posix() == MANIFEST or f.name.endswith(".partial")
                or any(p.startswith(".") for p in rel.parts) or any(p in SKIPPED_DIRS for p in rel.parts[:-1])):
            continue
        out.append(rel.as_posix())
    return sorted(out)


def write_manifest(results: Path, out: Path | None = None) -> tuple[Path, int]:
    """Write the manifest of ``results``: one ``<sha256>  <path>`` line per produced file, atomically.

    Parameters
    ----------
    results : Path
        The results tree.
    out : Path, optional
        Where to write it (default ``results/MANIFEST.sha256``).

    Returns
    -------
    path : Path
        The manifest written.
    count : int
        The number of files it lists.
    """
    results = Path(results)
    out = Path(out) if out else results / MANIFEST
    lines = [f"{bytes_sha256(results / rel)}  {rel}\n" for rel in produced_files(results)]
    tmp = out.with_name(out.name + ".partial")
    tmp.write_text("".join(lines), encoding="utf-8")
    tmp.replace(out)
    return out, len(lines)


def check_manifest(results: Path) -> list[str]:
    """Compare a results tree with its manifest.

    Parameters
    ----------
    results : Path
        The results tree holding ``MANIFEST.sha256``.

    Returns
    -------
    list of str
        One line per file that differs from the manifest (changed, missing, or not listed); empty when
        the tree matches. A tree without a manifest (or with a malformed one) is one line saying so.
    """
    results = Path(results)
    path = results / MANIFEST
    if not path.is_file():
        return [f"{path}: missing (the build writes it last; rebuild with snakemake, or `python -m pipeline "
                f"manifest {results}` to vouch for the tree as it is now)"]
    recorded = {}
    for i, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), start=1):
        digest, sep, rel = line.partition("  ")
        if not sep or len(digest) != 64 or not rel:
            return [f"{path}: line {i}: not '<sha256>  <path>'"]
        recorded[rel] = digest
    problems = []
    present = set(produced_files(results))
    for rel, digest in sorted(recorded.items()):
        f = results / rel
        if rel not in present:
            problems.append(f"{f}: missing (listed in {MANIFEST})")
        elif bytes_sha256(f) != digest:
            problems.append(f"{f}: SHA-256 differs from the one the build recorded in {MANIFEST}")
    problems += [f"{results / rel}: not written by the build (not in {MANIFEST})" for rel in sorted(present - set(recorded))]
    return problems
