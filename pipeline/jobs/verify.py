"""``python -m pipeline verify``: prove that a results folder's tables and report match its archives.

Per study (every ``results/<id>/tables/provenance.json``):

1. every file an archive depends on has the SHA-256 the archive recorded: its problem set
   (``problem_path``, ``problem_sha256``) and its robot file (``<data>/robots/<robot>.yaml``,
   ``robot_sha256``); a changed or damaged one is named (with the study and the archive) before the
   archive is read, so that the archive is not blamed for it;
2. every archive the tables were built from exists, reads without error, holds as many solve
   records as its metadata promises, belongs to the study, and is the archive the tables recorded
   (study, solver, settings hash, problem-file hash, problem count);
3. every table is recomputed from those archives and compared byte for byte with the CSV on disk.

For the report: the digest of its inputs (every study's tables and figures) recorded in
``report.html`` equals the digest of the files on disk, and the digest of the report's own text
(without the build-time line) equals the one it records, so a hand-edited report is caught.

For the whole tree: every file the build produced has the SHA-256 the build recorded in
``MANIFEST.sha256`` (:mod:`pipeline.io.manifest`), which catches what the checks above cannot: an
archive rewritten with valid CRCs (a changed flag, a renamed solver, a value one ulp off), an edited
figure or problem set, a file added or deleted.
"""

from __future__ import annotations

import json
import re
import tempfile
from pathlib import Path

from pipeline.io.manifest import check_manifest, produced_files
from pipeline.report.seal import _META, INPUTS_DIGEST, REPORT_DIGEST, inputs_digest, report_digest

_CHECKED = ("study", "solver", "settings_hash", "problem_sha256", "problems", "problem_set", "robot")


def _archive_path(results: Path, sid: str, recorded: str) -> Path:
    parts = Path(recorded).parts
    return results.joinpath(*parts[parts.index(sid):]) if sid in parts else Path(recorded)


def _dependency_problems(path: Path, meta: dict, data: Path, seen: dict) -> list[str]:
    """The files archive ``path`` was solved from whose SHA-256 differs from the one it recorded (one line
    each, naming the file and the archive); an archive that records no hash of a file is not checked
    for it (the measurement and catalogue archives of some studies). ``seen``: (file, hash) -> problem
    or None, shared over a study's archives, so that a file many archives share is hashed once (the
    caller reports each line once)."""
    from pipeline.provenance import DamagedFileError, file_sha256

    deps = []
    if meta.get("problem_path") and meta.get("problem_sha256", "-") != "-":
        deps.append(("problem set", (path.parent / meta["problem_path"]).resolve(), meta["problem_sha256"]))
    if meta.get("robot_sha256", "-") != "-":
        robot = data / "robots" / f"{meta.get('robot')}.yaml"
        if not robot.is_file() and meta.get("robot_path"):
            robot = (path.parent / meta["robot_path"]).resolve()
        deps.append(("robot file", robot, meta["robot_sha256"]))
    problems = []
    for what, f, want in deps:
        if (f, want) not in seen:
            if not f.is_file():
                seen[(f, want)] = f"{f}: missing ({what} of archive {path.name})"
            else:
                try:
                    sha = file_sha256(f)
                    seen[(f, want)] = None if sha.startswith(want) else (
                        f"{f}: SHA-256 {sha[:16]} differs from the {want} archive {path.name} recorded (the {what} "
                        f"changed after the build)")
                except DamagedFileError as exc:
                    seen[(f, want)] = f"{exc} ({what} of archive {path.name})"
        if seen[(f, want)]:
            problems.append(seen[(f, want)])
    return problems


def verify_study(results: Path, data: Path, sid: str) -> list[str]:
    """What differs for study ``sid`` (empty list: everything matches)."""
    from pipeline.io.archive import archive_metadata, read_archive
    from pipeline.settings import load_study
    from pipeline.studies import build_study_tables, write_tables

    folder = results / sid
    prov = json.loads((folder / "tables" / "provenance.json").read_text())
    problems, archives, seen = [], [], {}
    for rec in prov:
        path = _archive_path(results, sid, rec["archive"])
        if not path.is_file():
            problems.append(f"{path}: archive missing")
            continue
        meta = archive_metadata(path)
        if meta.get("study") not in (None, sid):  # a foreign archive: its inputs are another study's
            problems.append(f"{path}: an archive of study {meta['study']!r}, not {sid!r}")
            continue
        deps = _dependency_problems(path, meta, data, seen)
        if deps:  # the archive is not read: its inputs changed (a file many archives share is named once)
            problems += [d for d in deps if d not in problems]
            continue
        try:
            a = read_archive(path)
        except Exception as exc:  # noqa: BLE001  (every reader error is one line)
            problems.append(f"{path}: unreadable archive ({str(exc).splitlines()[0]})")
            continue
        m = a.metadata
        if str(m.get("problems", "")).isdigit():  # a measurement archive (mariano2019) holds no solves: "-"
            want = int(m["problems"]) * int(m.get("repetitions", 1) or 1)
            if len(a.solves) != want:
                problems.append(f"{path}: {len(a.solves)} solve records, metadata promises {want}")
        if m.get("study") != sid:
            problems.append(f"{path}: an archive of study {m.get('study')!r}, not {sid!r}")
        diff = [k for k in _CHECKED if k in rec and k in m and str(rec[k]) != str(m[k])]
        if diff:
            problems.append(f"{path}: not the archive the tables were built from (differs in {', '.join(diff)})")
        archives.append(a)
    if problems:
        return problems
    study = load_study(data / "studies" / f"{sid}.yaml")
    with tempfile.TemporaryDirectory() as tmp:
        tables = build_study_tables(study, archives, data / "published")
        write_tables(tables, Path(tmp))
        index = json.loads((Path(tmp) / "index.json").read_text())
        for name in [t["file"] for t in index] + ["index.json"]:
            disk = folder / "tables" / name
            if not disk.is_file():
                problems.append(f"{disk}: missing (a recomputation from the archives writes it)")
            elif disk.read_bytes() != (Path(tmp) / name).read_bytes():
                problems.append(f"{disk}: differs from a recomputation from the archives")
        extra = {f.name for f in (folder / "tables").glob("*.csv")} - {t["file"] for t in index}
        problems += [f"{folder / 'tables' / x}: not a table the archives produce" for x in sorted(extra)]
    return problems


def verify_report(results: Path, study_ids) -> list[str]:
    report = results / "report.html"
    if not report.is_file():
        return [f"{report}: missing"]
    html = report.read_text()
    meta = dict(_META.findall(html))
    problems = []
    if meta.get(REPORT_DIGEST) != report_digest(html):
        problems.append(f"{report}: its text differs from what was rendered (edited after the build?)")
    if meta.get(INPUTS_DIGEST) != inputs_digest(results, study_ids):
        problems.append(f"{report}: embeds other tables or figures than the ones in {results}")
    return problems


def report_studies(results: Path) -> list[str]:
    """Study ids the report was rendered from (its section ids, in order)."""
    html = (results / "report.html").read_text() if (results / "report.html").is_file() else ""
    return re.findall(r'<section id="([a-z0-9_]+)" class="study">', html)


def verify(results: Path, data: Path) -> tuple[bool, list[str]]:
    """One line per study, one for the report and one for the manifest; True when everything matches."""
    lines, ok = [], True
    studies = sorted(p.parent.parent.name for p in results.glob("*/tables/provenance.json"))
    if not studies:
        return False, [f"{results}: no study tables (tables/provenance.json) to verify"]
    for sid in studies:
        diffs = verify_study(results, data, sid)
        ok &= not diffs
        lines.append(f"{sid}: ok" if not diffs else f"{sid}: " + "; ".join(diffs))
    diffs = verify_report(results, report_studies(results) or studies)
    ok &= not diffs
    lines.append("report: ok" if not diffs else "report: " + "; ".join(diffs))
    diffs = check_manifest(results)
    ok &= not diffs
    lines.append(f"manifest: ok ({len(produced_files(results))} files)" if not diffs else "manifest: " + "; ".join(diffs))
    return ok, lines
