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

Per archive, beyond reading it (:func:`pipeline.io.archive.read_archive` refuses duplicated problem
ids, traces or solutions of no solve, counts that differ across channels, a problem id not in the
problem set, metadata of the wrong type, and anything past its size caps), every solve record is
checked against what it stores itself, without re-running a solver (:func:`record_problems`):

4. the flags agree with the stop reason (success exactly when the stop reason is SUCCESS; a SUCCESS
   or FK_CHECK_FAILED stop only after a claimed success; a stop reason that exists);
5. the FK check is recomputed from the stored joints: the compiled dual-quaternion check every solve
   went through (:func:`pipeline.solvers.core.finish_batch`, the same floats as the solve job's
   finish) is run on the stored ``q_solution`` against the problem file's goal (converted as the job
   converted it) with the archive's settings; its position and orientation errors must equal the
   stored ones bit for bit, and its verdict -- stop reason, success, claimed success, within limits
   -- the stored one (the method's own stop code is SUCCESS for a claimed success, else the stored
   stop reason, so the check is a fixed point of the job's rule). Every solve archive of a full
   build passes this bit for bit;
6. a stored trace's first and last rows give the record's ``initial_error`` and ``final_error``.

What 5 can and cannot see. A forged error, a flipped success, within-limits or claimed-success flag
and a stop reason that contradicts the check are found. A forged solution is found when moving it
changes the check's floats: moving one joint of a solve by one ulp changes the recomputed errors in
84 to 95 % of the solves, depending on the joint (measured on every joint of cerbaro2019's DLS archive,
10 000 solves, and of closed_forms' analytic archive of the KUKA LWR, 2 000), so a forged archive of
many moved solutions is found, but a single moved solution is missed in 5 to 16 % of the cases: a
move of one ulp can vanish in the rounding of the forward kinematics, and the archive stores nothing
else derived from the joints at full precision (the trace's error vectors are float32, its digest
covers rows only a re-run gives). Nor can it see what the method alone decides and the archive
records without anything to check it against: the iteration count, the trace rows, the ``info``
counters, or a success turned into a consistent failure (success, claimed success and stop reason
all rewritten: the method's own stop code is not stored). These forgeries are left to ``reproduce``
(which re-runs and compares every stored field) and to the manifest. An archive that stores its
goals inline (no problem file) gets checks 4 and 6 only; a measurement archive (no solves) none of
them.

For the whole tree: every file the build produced has the SHA-256 the build recorded in
``MANIFEST.sha256`` (:mod:`pipeline.io.manifest`), which catches what the checks above cannot: an
archive rewritten with valid CRCs and a consistent forgery (a renamed solver, a solution moved by an
ulp that the FK check does not see), an edited figure or problem set, a file added or deleted. The
manifest is only as good as the tree it sits in: one rebuilt after a forgery matches it, which is why
the checks above never rely on it.
"""

from __future__ import annotations

import json
import re
import tempfile
from pathlib import Path

from pipeline.io.manifest import check_manifest, produced_files
from pipeline.report.seal import META_TAG, INPUTS_DIGEST, REPORT_DIGEST, inputs_digest, report_digest

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
    from pipeline.io.problems import ProblemFileError, problem_file_sha256
    from pipeline.provenance import DamagedFileError, file_sha256

    from pipeline.io.archive import ArchiveError, named_file

    deps, problems = [], []
    try:
        if meta.get("problem_path") and meta.get("problem_sha256", "-") != "-":
            deps.append(("problem set", named_file(path, meta, "problem_path"), meta["problem_sha256"]))
        if meta.get("robot_sha256", "-") != "-":
            deps.append(("robot file", _robot_path(path, meta, data), meta["robot_sha256"]))
    except ArchiveError as exc:  # metadata naming a file that is no problem set or robot file: never read
        problems.append(str(exc))
    for what, f, want in deps:
        if (f, want) not in seen:
            if not f.is_file():
                seen[(f, want)] = f"{f}: missing ({what} of archive {path.name})"
            else:
                try:  # a problem set within its caps (a gzip bomb is refused, never inflated)
                    sha = problem_file_sha256(f) if what == "problem set" else file_sha256(f)
                    seen[(f, want)] = None if sha.startswith(want) else (
                        f"{f}: SHA-256 {sha[:16]} differs from the {want} archive {path.name} recorded (the {what} "
                        f"changed after the build)")
                except (DamagedFileError, ProblemFileError) as exc:
                    seen[(f, want)] = f"{str(exc).splitlines()[0]} ({what} of archive {path.name})"
        if seen[(f, want)]:
            problems.append(seen[(f, want)])
    return problems


def _robot_path(path: Path, meta: dict, data: Path) -> Path:
    """The robot file an archive was solved with, found as :func:`_dependency_problems` finds it."""
    from pipeline.io.archive import named_file
    from pipeline.names import is_name

    robot = data / "robots" / f"{meta.get('robot')}.yaml" if is_name(meta.get("robot")) else None
    if (robot is None or not robot.is_file()) and meta.get("robot_path"):
        robot = named_file(path, meta, "robot_path")
    if robot is None:
        from pipeline.io.archive import ArchiveError

        raise ArchiveError(f"{path}: metadata field 'robot': {str(meta.get('robot'))[:80]!r} is not a robot name")
    return robot


def _first(path: Path, what: str, bad: list[tuple], count: int | None = None) -> list[str]:
    """One line for ``bad`` ((problem id, repetition, detail) of the failing solves, the first at least),
    naming the first; ``count``: how many fail (default ``len(bad)``)."""
    if not bad:
        return []
    pid, rep, detail = bad[0]
    return [f"{path}: {count or len(bad)} solve record(s) {what} (first: problem {pid}, repetition {rep}: {detail})"]


def flag_problems(arch) -> list[str]:
    """Check 4 of the module docstring: each record's flags against its stop reason."""
    from pipeline.io.layout import StopReason

    valid = {int(r) for r in StopReason}
    ok, fk_failed = int(StopReason.SUCCESS), int(StopReason.FK_CHECK_FAILED)
    bad = []
    for r in arch.solves:
        sr = int(r["stop_reason"])
        if sr not in valid:
            bad.append((r["problem_id"], r["repetition"], f"field 'stop_reason' is {sr}, not a stop reason"))
        elif bool(r["success"]) != (sr == ok):
            bad.append((r["problem_id"], r["repetition"],
                        f"field 'success' is {bool(r['success'])} with stop reason {sr}"))
        elif sr in (ok, fk_failed) and not r["claimed_success"]:
            bad.append((r["problem_id"], r["repetition"], f"stop reason {sr} without field 'claimed_success'"))
    return _first(arch.path, "whose flags contradict their stop reason", bad)


def trace_problems(arch) -> list[str]:
    """Check 6 of the module docstring: stored traces against the records' initial and final errors."""
    import numpy as np

    recs, bad = arch.records(), []
    for key, (_, _, full) in arch.trace_index().items():
        r = recs.get(key)
        if full is None or r is None or not len(full):
            continue
        for name, want in (("initial_error", full[0, 0]), ("final_error", full[-1, 0])):
            if not np.array_equal(r[name], want, equal_nan=True):
                bad.append((key[0], key[1], f"field '{name}' is {r[name]!r}, its stored trace says {want!r}"))
                break
    return _first(arch.path, "whose errors differ from their stored traces", bad)


def fk_problems(arch, robot_file: Path) -> list[str]:
    """Check 5 of the module docstring: the FK check and its verdict recomputed from the stored joints.

    Returns one line for the solves whose stored errors or verdict differ from the recomputation (and
    one line when the archive cannot be re-checked: its method or settings unknown); [] when every
    solve agrees or the archive has nothing to check (no solves, no problem file, no method)."""
    import numpy as np

    from pipeline.io.archive import problems_of
    from pipeline.jobs.replay import ReplayError, settings_from_archive
    from pipeline.robots import load_robot
    from pipeline.runner import model_goals
    from pipeline.solvers.core import BatchRaw, Prepared, finish_batch

    meta, path = arch.metadata, arch.path
    try:
        named = meta.get("method") or json.loads(meta.get("settings", "{}")).get("method")
    except (ValueError, AttributeError):
        named = None
    if not arch.solves or not meta.get("problem_path") or not named:
        return []
    try:
        method, settings = settings_from_archive(meta, str(path))
        s = settings.converted()
    except (ReplayError, ValueError) as exc:
        return [f"{str(exc).splitlines()[0]} (the FK check cannot be recomputed)"]
    rows, ps, _ = problems_of(arch)
    model = load_robot(robot_file)
    prep = Prepared(model, s.length_unit)
    recs = arch.solves
    goals = np.ascontiguousarray(model_goals(ps, model)[[rows[r["problem_id"]] for r in recs]])
    if prep.goal_scale != 1.0:  # as Prepared.working_goal converts a goal
        goals[:, :3, 3] *= prep.goal_scale
    q = np.ascontiguousarray([r["q_solution"] for r in recs], dtype=float)
    if q.shape[1] != prep.n:
        return [f"{path}: field 'q_solution' holds {q.shape[1]} joints, robot file {robot_file} has {prep.n}"]
    stop = np.array([r["stop_reason"] for r in recs], dtype=np.int64)
    claimed = np.array([r["claimed_success"] for r in recs], dtype=bool)
    n = len(recs)
    raw = BatchRaw(q=q, code=np.where(claimed, 1, stop), iterations=np.zeros(n, np.int64),
                   solve_ns=np.zeros(n), ik_ns=np.zeros(n))
    res = finish_batch(prep, goals, raw, s)
    stored = {"stop_reason": stop, "success": np.array([r["success"] for r in recs], dtype=bool),
              "claimed_success": claimed, "within_limits": np.array([r["within_limits"] for r in recs], dtype=bool),
              "position_error": np.array([r["position_error"] for r in recs], dtype=float),
              "orientation_error": np.array([r["orientation_error"] for r in recs], dtype=float)}
    got = {"stop_reason": res.stop_reason, "success": res.success, "claimed_success": res.claimed_success,
           "within_limits": res.within_limits,
           "position_error": np.where(np.isfinite(res.position_error), res.position_error, np.nan),
           "orientation_error": np.where(np.isfinite(res.orientation_error), res.orientation_error, np.nan)}
    bad = []
    differ = np.zeros(n, bool)
    for name, want in stored.items():
        d = ~((want == got[name]) | (np.isnan(want) & np.isnan(got[name])) if want.dtype.kind == "f"
              else want == got[name])
        differ |= d
    for i in np.flatnonzero(differ)[:1].tolist():
        name = next(k for k in stored
                    if not np.array_equal(stored[k][i], got[k][i], equal_nan=stored[k].dtype.kind == "f"))
        bad.append((recs[i]["problem_id"], recs[i]["repetition"],
                    f"field '{name}' is {stored[name][i].item()!r}, the FK check of its stored q_solution gives "
                    f"{got[name][i].item()!r}"))
    return _first(path, "disagree with the FK check of their stored joints", bad, int(differ.sum()))


def record_problems(arch, robot_file: Path | None) -> list[str]:
    """Checks 4 to 6 of the module docstring for one archive read without error (one line per check
    that fails); ``robot_file``: the archive's robot file (None: the FK check is skipped)."""
    out = flag_problems(arch) + trace_problems(arch)
    if robot_file is not None and robot_file.is_file():
        out += fk_problems(arch, robot_file)
    return out


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
        try:
            problems += record_problems(a, _robot_path(path, m, data) if m.get("robot_sha256", "-") != "-" else None)
        except Exception as exc:  # noqa: BLE001  (a check that cannot run is a finding, one line)
            problems.append(f"{path}: the solve records could not be re-checked ({type(exc).__name__}: "
                            f"{str(exc).splitlines()[0] if str(exc) else ''})")
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
    meta = dict(META_TAG.findall(html))
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
