"""The checks of :func:`pipeline.io.archive.read_archive` beyond the bytes: the files an archive's
metadata names, the types of its metadata fields and the structure across its three channels."""

from __future__ import annotations

from pathlib import Path

from pipeline.io.archive_bounds import MAX_SOLVES
from pipeline.io.archive_format import BATCH, SOLUTIONS_TOPIC, SOLVE_TOPIC, ArchiveError, TracePolicy


_PROBLEM_CACHE: dict = {}


# What a file named by an archive's metadata may be: the archive is read from anywhere, so its
# metadata must not make a verb read any other file (``/proc/self/environ``, ``~/.ssh/id_rsa``): a
# problem set is a ``.csv``/``.csv.gz`` file named relative to the archive (as the writer records it),
# a robot file a ``.yaml`` file in a ``robots`` folder (``data/robots/<name>.yaml``).
NAMED_FILES = {"problem_path": (None, (".csv", ".csv.gz")), "robot_path": ("robots", (".yaml", ".yml")),
               "robot_file": ("robots", (".yaml", ".yml"))}


def named_file(path: Path, meta: dict, field: str) -> Path | None:
    """The file the metadata ``field`` of archive ``path`` names, resolved.

    Relative to the archive's folder, or as written for ``robot_file``. A field that names anything but
    what :data:`NAMED_FILES` allows (a problem set: a ``.csv``/``.csv.gz`` path relative to the archive;
    a robot file: a ``.yaml`` file in a ``robots`` folder) is refused: such a file is never opened.

    Parameters
    ----------
    path : Path
        The archive.
    meta : dict
        Its ``run`` record.
    field : {"problem_path", "robot_path", "robot_file"}

    Returns
    -------
    Path or None
        None when the field is empty or ``-``.

    Raises
    ------
    ArchiveError
    """
    value = meta.get(field)
    if not value or value == "-":
        return None
    folder, suffixes = NAMED_FILES[field]
    text = str(value)
    rel = Path(text)
    if "\0" in text or len(text) > 4096 or (rel.is_absolute() and field != "robot_file"):
        raise ArchiveError(f"{path}: metadata field '{field}': {text[:120]!r} is not a path relative to the archive; "
                           f"not read (give the file with --{'problems' if field == 'problem_path' else 'robot'})")
    target = (rel if field == "robot_file" else Path(path).parent / rel).resolve()
    if not target.name.endswith(suffixes) or (folder and folder not in target.parent.parts):
        where = f" in a '{folder}' folder" if folder else ""
        raise ArchiveError(f"{path}: metadata field '{field}': {text[:120]!r} is not a {' or '.join(suffixes)} file"
                           f"{where}; not read (give the file with --{'problems' if field == 'problem_path' else 'robot'})")
    return target


def problem_set_of(path: Path, meta: dict, given: str | Path | None = None):
    """The problem file an archive names (or ``given``), checked and cached.

    Parameters
    ----------
    path : Path
        The archive, named in errors; ``problem_path`` is relative to its folder.
    meta : dict
        The archive's ``run`` record.
    given : str or Path, optional
        The problem file when it is not where ``problem_path`` says.

    Returns
    -------
    tuple or None
        ``(problem id -> row, ProblemSet, goal length scale)`` (scale: from the problem file's length
        unit to the archive's), or None for an archive that stores its goals.

    Raises
    ------
    ArchiveError
        When the file is named but missing, unreadable, changed (SHA-256) or of an unknown length unit.
    """
    rel = meta.get("problem_path")
    if not rel:
        return None
    from pipeline.io.problems import load_problems
    from pipeline.robots import LENGTH_UNITS

    pf = Path(given).resolve() if given else named_file(path, meta, "problem_path")
    if not pf.is_file():
        where = f"--problems {given}: no such file" if given else f"problem file {rel} not found next to the archive"
        raise ArchiveError(f"{path}: metadata field 'problem_path': {where} (the archive stores no goals of its own: "
                           f"keep it in its results tree, or give its problem set {meta.get('problem_file', '')} "
                           f"with --problems FILE)")
    st = pf.stat()
    key = (str(pf), st.st_mtime_ns, st.st_size)
    hit = _PROBLEM_CACHE.get(key)
    if hit is None:
        try:  # within the problem-file caps (pipeline.io.problems): a gzip bomb is refused, never inflated
            ps, _, sha = load_problems(pf)
        except ValueError as exc:  # ProblemFileError: one line naming the problem file
            raise ArchiveError(f"{str(exc).splitlines()[0]} (the problem set of archive {path})") from None
        except (OSError, EOFError) as exc:
            raise ArchiveError(f"{pf}: unreadable problem file ({type(exc).__name__}: {exc}) (the problem set of "
                               f"archive {path})") from None
        hit = _PROBLEM_CACHE[key] = (sha, ps, {int(p): i for i, p in enumerate(ps.problem_id.tolist())})
    sha, ps, rows = hit
    want = meta.get("problem_sha256", "")
    if not want or not sha.startswith(want):
        raise ArchiveError(f"{pf}: SHA-256 {sha[:16]}, but archive {path} recorded {want!r} (metadata field "
                           f"'problem_sha256'): the problem file changed after the archive was written")
    unit = meta.get("length_unit") or ps.length_unit
    if unit not in LENGTH_UNITS:
        raise ArchiveError(f"{path}: metadata field 'length_unit': unknown unit {unit!r}")
    return rows, ps, LENGTH_UNITS[ps.length_unit] / LENGTH_UNITS[unit]


def _json_object(meta: dict, key: str, path: Path) -> None:
    import orjson

    if key in meta:
        try:
            ok = isinstance(orjson.loads(meta[key]), dict)
        except ValueError:
            ok = False
        if not ok:
            raise ArchiveError(f"{path}: metadata field '{key}' is not a JSON object")


def check_metadata(path: Path, meta: dict, traces: dict, timing: dict) -> int | None:
    """Check the types of the metadata fields a reader relies on.

    Parameters
    ----------
    path : Path
        The archive (named in errors).
    meta, traces, timing : dict[str, str]
        Its ``run``, ``traces`` and ``job_timing`` records.

    Returns
    -------
    int or None
        The solve records the ``run`` record promises (``problems`` x ``repetitions``), or None for an
        archive without a count (a measurement archive: ``problems`` is ``-`` or absent).

    Raises
    ------
    ArchiveError
        One line naming the file and the field.
    """
    for key in ("settings", "environment"):
        _json_object(meta, key, path)
    if "trace_policy" in meta:
        try:
            TracePolicy.from_json(meta["trace_policy"])
        except (ValueError, TypeError, KeyError):
            raise ArchiveError(f"{path}: metadata field 'trace_policy' is not a trace policy (JSON object of "
                               f"mode, sample and failed_rows)") from None
    seed = str(meta.get("seed", "-"))
    if seed != "-" and not (seed.lstrip("-").isdigit() and len(seed) <= 20):
        raise ArchiveError(f"{path}: metadata field 'seed' is {seed[:40]!r}, not an integer or '-'")
    sha = meta.get("problem_sha256", "")
    if meta.get("problem_path") and not (0 < len(sha) <= 64 and all(c in "0123456789abcdef" for c in sha)):
        raise ArchiveError(f"{path}: metadata field 'problem_sha256' is {sha[:40]!r}, not a hexadecimal SHA-256 prefix")
    for k, v in traces.items():
        if k != "policy" and not (v.isdigit() and len(v) <= 15):
            raise ArchiveError(f"{path}: metadata record 'traces': field '{k}' is {v[:40]!r}, not a count")
    for k, v in timing.items():
        try:
            float(v)
        except ValueError:
            raise ArchiveError(f"{path}: metadata record 'job_timing': field '{k}' is {v[:40]!r}, "
                               "not a number") from None
    probs, reps = str(meta.get("problems", "-")), str(meta.get("repetitions", "1") or "1")
    if probs != "-" and not probs.isdigit():
        raise ArchiveError(f"{path}: metadata field 'problems' is {probs[:40]!r}, not a count (or '-')")
    if not reps.isdigit() or int(reps) < 1:
        raise ArchiveError(f"{path}: metadata field 'repetitions' is {reps[:40]!r}, not a positive count")
    if probs == "-":
        return None
    want = int(probs) * int(reps)
    if want > MAX_SOLVES:
        raise ArchiveError(f"{path}: metadata fields 'problems' x 'repetitions' promise {want} solve records, past "
                           f"the {MAX_SOLVES} an archive may hold (MAX_SOLVES); not read")
    return want


class ChannelStructure:
    """The cross-channel checks of :func:`pipeline.io.archive.read_archive`, fed message by message in file order.

    The writer emits per batch one ``/ik/solve`` message, then (analytic methods) one
    ``/ik/solutions`` message for the same solves and (with traces) one ``/ik/trace`` message for
    some of them. So: a solve is one (labels, problem id, repetition) of the archive, at most once
    (the labels -- robot, solver, method, length unit -- are the metadata's unless ``labels_json``
    gives a solve its own); a solutions message lists exactly the solves of the solve message before
    it, in its order, with the counts its ``n_solutions`` field gives, and a solve message with
    ``n_solutions`` has one; a trace message lists each of its traces once, each a solve of the solve
    message before it; no solve has two traces or two solution lists.

    Parameters
    ----------
    path : Path
        The archive (named in errors).
    """

    def __init__(self, path: Path):
        self.path = path
        self.solved: dict = {}   # labels -> {(problem id, repetition)} of every solve so far
        self.traced: dict = {}   # idem, with a trace
        self.listed: dict = {}   # idem, with solutions
        self.batch: dict | None = None  # (problem id, repetition) -> labels, of the last solve message
        self.batch_ids = None
        self.pending_solutions = False

    def _fail(self, msg, text: str):
        raise ArchiveError(f"{self.path}: message {msg.sequence} on {msg.topic}: {text}")

    def _end_batch(self, msg=None) -> None:
        if self.pending_solutions:
            where = f"message {msg.sequence} on {msg.topic}" if msg is not None else "the end of the file"
            raise ArchiveError(f"{self.path}: the {SOLVE_TOPIC} message before {where} has field 'n_solutions' but "
                               f"no {SOLUTIONS_TOPIC} message: counts differ across channels")

    def _add(self, msg, seen: dict, pairs: list, labels: list, what: str) -> None:
        """Record ``pairs`` (with their ``labels``) in ``seen``; a pair met twice is one line."""
        if len(set(labels)) == 1:  # every solve of the message has the same labels: set operations
            have = seen.setdefault(labels[0], set())
            new = set(pairs)
            if len(new) == len(pairs) and have.isdisjoint(new):
                have |= new
                return
        for pair, lab in zip(pairs, labels):
            have = seen.setdefault(lab, set())
            if pair in have:
                self._fail(msg, f"field 'problem_id': problem {pair[0]} (repetition {pair[1]}) has {what} twice")
            have.add(pair)

    def solves(self, msg, pid: list, rep: list, labels: list, n_solutions: list | None) -> None:
        """Take a solve message: its solves are new to the file, and it closes the batch before it.

        Parameters
        ----------
        msg : pipeline.io.archive_bounds.ChunkMessage
        pid, rep : list of int
            Per solve: problem id and repetition.
        labels : list of tuple
            Per solve: (robot, solver, method, length unit).
        n_solutions : list of int or None
            Per solve: its number of solutions (None: the message has no ``n_solutions``).
        """
        self._end_batch(msg)
        pairs = list(zip(pid, rep))
        self._add(msg, self.solved, pairs, labels, "a solve record")
        self.batch = dict(zip(pairs, labels))
        self.batch_ids = (pid, rep, n_solutions)
        self.pending_solutions = n_solutions is not None

    def _of_batch(self, msg, pid: list, rep: list, what: str) -> tuple[list, list]:
        if self.batch is None:
            self._fail(msg, f"{what} before any {SOLVE_TOPIC} message")
        pairs = list(zip(pid, rep))
        labels = [self.batch.get(pair) for pair in pairs]
        if None in labels:
            p, r = pairs[labels.index(None)]
            self._fail(msg, f"field 'problem_id': problem {p} (repetition {r}) has {what} but no solve record in the "
                            f"{SOLVE_TOPIC} message before it")
        return pairs, labels

    def traces(self, msg, b: dict) -> None:
        """Take a trace message: each trace is of a solve of the batch, and the first for it.

        Parameters
        ----------
        msg : pipeline.io.archive_bounds.ChunkMessage
        b : dict
            The decoded ``TraceBatch`` (``problem_id`` and ``repetition``, (T,) int arrays).
        """
        n = len(b["problem_id"])
        if n > BATCH:
            self._fail(msg, f"field 'problem_id' holds {n} traces, a message holds at most {BATCH}")
        pairs, labels = self._of_batch(msg, b["problem_id"].tolist(), b["repetition"].tolist(), "a trace")
        self._add(msg, self.traced, pairs, labels, "a trace")

    def solutions(self, msg, b: dict) -> None:
        """Take a solutions message: exactly the solves of the batch, with the counts they promise.

        Parameters
        ----------
        msg : pipeline.io.archive_bounds.ChunkMessage
        b : dict
            The decoded ``SolutionBatch`` (``problem_id``, ``repetition`` and ``count``, (k,) int arrays).
        """
        pid, rep, cnt = b["problem_id"].tolist(), b["repetition"].tolist(), b["count"].tolist()
        if not self.pending_solutions:
            self._fail(msg, f"solutions for a {SOLVE_TOPIC} message without field 'n_solutions' (or a second "
                            f"solutions message for it)")
        want_pid, want_rep, want_n = self.batch_ids
        if pid != want_pid or rep != want_rep:
            self._fail(msg, f"field 'problem_id': {len(pid)} solves, not the {len(want_pid)} solves of the "
                            f"{SOLVE_TOPIC} message before it: counts differ across channels")
        if cnt != want_n:
            k = next(i for i, (c, w) in enumerate(zip(cnt, want_n)) if c != w)
            self._fail(msg, f"field 'count': problem {pid[k]} has {cnt[k]} solutions, its solve record's "
                            f"'n_solutions' says {want_n[k]}: counts differ across channels")
        pairs, labels = self._of_batch(msg, pid, rep, "solutions")
        self._add(msg, self.listed, pairs, labels, "solutions")
        self.pending_solutions = False

    def finish(self) -> None:
        """At the end of the file: the last solve message's solutions, if promised, were read."""
        self._end_batch()
