"""``python -m pipeline reproduce``: re-run an archive's solves and say how far the re-run is from it.

Reading an archive never re-runs anything; this is the one place that does, on purpose. For every
archive (one file, or every ``runs/**/*.mcap`` under a results folder) it re-runs a deterministic
sample of its solves exactly as the job ran them — the registered method and settings from the
metadata, the robot file (checked against ``robot_sha256``), the problem file's goal, the archived
start, the problem's seed — and compares every stored field but the times (:data:`COMPARED`), bit for
bit: ``q_solution`` (and max |Δq|), iterations and stop reason, the success, claimed-success and
within-limits flags, the four errors (position and orientation by the FK check, initial and final
from the trace), the method's ``info`` counters (its time-valued entries left out), the number of
analytic solutions and the solutions themselves, and the trace's row count and CRC-32 (``digest``
on ``/ik/trace``). A solve is bit-identical only when every one of them is; each differing field is
counted by name. A difference is a finding printed in the table, never an error: a solver that is
deterministic on one machine may round differently on another CPU or BLAS kernel, and the table
says which environment wrote the archive and which re-ran it.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from pipeline.errors import UsageError


@dataclass
class Finding:
    """The comparison of one archive with its re-run."""

    archive: str
    label: str = ""
    method: str = ""
    deterministic: bool = True
    rerun: int = 0
    identical: int = 0
    q_differ: int = 0
    max_dq: float = 0.0
    iterations_differ: int = 0
    max_diterations: int = 0
    traces_differ: int = 0
    solutions_differ: int = 0
    fields_differ: dict = field(default_factory=dict)  # field name -> solves in which it differs
    environment: str = ""
    note: str = ""

    def differs(self, name: str) -> None:
        self.fields_differ[name] = self.fields_differ.get(name, 0) + 1


# every stored field of a solve record a re-run is compared on (times left out: they are measurements);
# the trace is compared by its row count and digest, the solutions row by row
COMPARED = ("q_solution", "iterations", "stop_reason", "success", "claimed_success", "within_limits",
            "position_error", "orientation_error", "initial_error", "final_error", "info", "n_solutions",
            "solutions", "trace")


def _num(x) -> float:
    """A stored error as the archive gives it back: non-finite -> NaN (written absent)."""
    x = float(x)
    return x if math.isfinite(x) else math.nan


def _same_float(a, b) -> bool:
    a, b = _num(a), _num(b)
    return (math.isnan(a) and math.isnan(b)) or (a == b and math.copysign(1.0, a) == math.copysign(1.0, b))


def _info(d) -> dict:
    """``info`` as the archive stores it (strict JSON: NaN -> null, numpy -> Python), time-valued entries
    (``*time*``: measurements, not results) left out."""
    import orjson

    d = orjson.loads(orjson.dumps(dict(d), option=orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS))
    return {k: v for k, v in d.items() if "time" not in str(k)}


def _robot_file(path: Path, meta: dict, robot: str | None, data: str | Path):
    """The archive's robot file: given, next to the archive as written, as named, or in the data folder."""
    from pipeline.provenance import file_sha256

    from pipeline.io.archive import named_file
    from pipeline.names import is_name

    tries = [Path(robot)] if robot else [named_file(path, meta, "robot_path"), named_file(path, meta, "robot_file"),
                                         Path(data) / "robots" / f"{meta.get('robot')}.yaml"
                                         if is_name(meta.get("robot")) else None]
    tries = [t for t in tries if t is not None and t.suffix in (".yaml", ".yml")]
    rf = next((t for t in tries if t.is_file()), None)
    if rf is None:
        raise UsageError(f"{path}: metadata field 'robot_file': {meta.get('robot_file', '?')} not found "
                         f"(give it with --robot FILE)")
    if meta.get("robot_sha256") and not file_sha256(rf).startswith(meta["robot_sha256"]):
        raise UsageError(f"{path}: metadata field 'robot_sha256': {rf} changed since the archive was written")
    return rf


def _env_line(env: dict) -> str:
    libs = env.get("libraries", {})
    over = env.get("kernel_overrides") or {}
    return (f"{env.get('cpu', '?')}; BLAS {env.get('blas', '?')}"
            + (f" [{', '.join(f'{k}={v}' for k, v in over.items())}]" if over else "")
            + f"; numpy {libs.get('numpy', '?')}, numba {libs.get('numba', '?')}, scipy {libs.get('scipy', '?')}")


def _compare_solve(f: Finding, arch, key: tuple, rec: dict, res, k: int, idx: dict) -> None:
    """Compare solve ``k`` of the re-run batch ``res`` with its archived record ``rec`` (``key`` = problem id,
    repetition; ``idx`` the archive's trace index) and count what differs in ``f``."""
    from pipeline.io.archive import digest

    before = dict(f.fields_differ)
    qa, qb = np.asarray(rec["q_solution"], dtype=float), np.asarray(res.q[k], dtype=float)
    if not np.array_equal(qa, np.where(np.isfinite(qb).all(), qb, np.nan), equal_nan=True):
        f.differs("q_solution")
        f.q_differ += 1
        d = np.abs(qa - qb)
        f.max_dq = max(f.max_dq, float(np.nanmax(d)) if np.isfinite(d).any() else float("inf"))
    dit = abs(int(rec["iterations"]) - int(res.iterations[k]))
    if dit:
        f.differs("iterations")
    if int(rec["stop_reason"]) != int(res.stop_reason[k]):
        f.differs("stop_reason")
    if dit or int(rec["stop_reason"]) != int(res.stop_reason[k]):
        f.iterations_differ += 1
        f.max_diterations = max(f.max_diterations, dit)
    for name, got in (("success", res.success), ("claimed_success", res.claimed_success),
                      ("within_limits", res.within_limits)):
        if bool(rec[name]) != bool(got[k]):
            f.differs(name)
    for name, got in (("position_error", res.position_error[k]),
                      ("orientation_error", res.orientation_error[k])):
        if not _same_float(rec[name], got):
            f.differs(name)
    if res.trace_rows is not None:  # the archive's initial and final errors are its trace's first and last
        tr = res.trace(k)
        for name, got in (("initial_error", tr[0, 0]), ("final_error", tr[-1, 0])):
            if not _same_float(rec[name], got):
                f.differs(name)
    if res.info is not None and _info(rec.get("info") or {}) != _info(res.info[k]):
        f.differs("info")
    if key in idx and res.trace_rows is not None:
        tr = res.trace(k)[:, :8]
        if len(tr) != idx[key][0] or digest(tr) != idx[key][1]:
            f.differs("trace")
            f.traces_differ += 1
    stored_n = rec.get("_n_solutions")
    if (stored_n is None) != (res.solutions is None) or (
            stored_n is not None and int(stored_n) != int(res.n_solutions[k])):
        f.differs("n_solutions")
    if stored_n is not None and res.solutions is not None:
        want = arch.solutions(*key)
        got = res.solutions[k, : int(res.n_solutions[k])]
        got = np.where(np.isfinite(got), got, np.nan)
        if want is None or np.asarray(want, dtype=float).size != got.size or not np.array_equal(
                np.asarray(want, dtype=float).reshape(got.shape), got, equal_nan=True):
            f.differs("solutions")
            f.solutions_differ += 1
    f.rerun += 1
    f.identical += f.fields_differ == before


def reproduce_archive(path, *, sample: int | None = None, problem: int | None = None, problems=None,
                      robot: str | None = None, data="data") -> Finding:
    """Re-run (a sample of) one archive's solves and compare them with the archive."""
    from pipeline.io.archive import TracePolicy, problems_of, read_archive
    from pipeline.jobs.replay import ReplayError, settings_from_archive
    from pipeline.jobs.solve import deterministic
    from pipeline.robots import load_robot
    from pipeline.runner import solve_set_batches

    arch = read_archive(path, problems=problems)
    meta = arch.metadata
    f = Finding(archive=str(path), label=meta.get("solver", ""), method=meta.get("method", ""))
    try:
        f.environment = _env_line(json.loads(meta.get("environment", "{}")))
    except ValueError:
        f.environment = "unknown"
    if not arch.solves:
        f.note = "no solves (a measurement archive)"
        return f
    try:
        method, settings = settings_from_archive(meta, str(path))
    except ReplayError as exc:
        raise UsageError(str(exc)) from None
    f.method = method
    f.deterministic = meta.get("deterministic", str(deterministic(method, settings)).lower()) == "true"
    rows, ps, _ = problems_of(arch, problems) or (None, None, None)
    if ps is None:
        raise UsageError(f"{path}: metadata field 'problem_path': the archive names no problem file to re-run from")
    model = load_robot(_robot_file(Path(path), meta, robot, data))
    recs = arch.records()
    keys = sorted(k for k in recs if k[1] == 0)
    if problem is not None:
        keys = [k for k in keys if k[0] == int(problem)]
        if not keys:
            raise UsageError(f"{path}: problem {problem} is not in the archive")
    elif sample is not None:
        pick = TracePolicy(sample=sample).sample_ids([k[0] for k in keys])
        keys = [k for k in keys if k[0] in pick]
    sub = ps.take([rows[k[0]] for k in keys])
    sub = replace(sub, q_start=np.array([recs[k]["q_start"] for k in keys], dtype=float).reshape(len(keys), -1),
                  chain=np.full(len(keys), -1))
    seed = int(meta["seed"]) if str(meta.get("seed", "")).lstrip("-").isdigit() else 0
    idx = arch.trace_index()
    i = 0
    for _, _, _, res in solve_set_batches(method, settings, model, sub, set_seed=seed):
        for k in range(len(res)):
            key, rec = keys[i], recs[keys[i]]
            i += 1
            _compare_solve(f, arch, key, rec, res, k, idx)
    return f


def archives_under(target: Path) -> list[Path]:
    """The solve archives of a results folder (``<study>/runs/**/*.mcap``), or the one file given."""
    if target.is_file():
        return [target]
    if not target.is_dir():
        raise UsageError(f"{target}: no such archive or results folder")
    found = sorted(target.glob("*/runs/**/*.mcap")) or sorted(target.glob("**/*.mcap"))
    if not found:
        raise UsageError(f"{target}: no archives (*/runs/**/*.mcap) under this folder")
    return found


def reproduce(target, *, sample: int | None = None, problem: int | None = None, problems=None,
              robot: str | None = None, data="data", progress=True) -> str:
    """The table of :class:`Finding` rows for every archive of ``target``, and both environments.

    ``sample``: solves re-run per archive (evenly spaced over its problem ids); default every solve
    of a single archive, 20 per archive for a results folder.
    """
    import sys

    from pipeline.provenance import environment

    paths = archives_under(Path(target))
    if sample is None and len(paths) > 1:
        sample = 20
    if sample is not None and sample < 1:
        raise UsageError(f"--sample: must be at least 1, got {sample}")
    rows: list[Finding] = []
    for n, p in enumerate(paths, 1):
        if progress and len(paths) > 1:  # one archive: nothing to count, and an error stays one line
            print(f"[{n}/{len(paths)}] {p}", file=sys.stderr, flush=True)
        rows.append(reproduce_archive(p, sample=sample, problem=problem, problems=problems, robot=robot, data=data))
    base = Path(target) if Path(target).is_dir() else Path(target).parent
    head = ("archive", "label", "deterministic", "re-run", "bit-identical", "q differs", "max |Δq| [rad | length]",
            "iterations or stop differ", "max |Δiterations|", "trace digest differs", "solutions differ",
            "fields that differ (solves)")
    table = [head]
    for f in rows:
        rel = Path(f.archive).relative_to(base).as_posix() if Path(f.archive).is_relative_to(base) else f.archive
        if f.note:
            table.append((rel, f.label, "-", "0", "-", "-", "-", "-", "-", "-", "-", f.note))
            continue
        named = ",".join(f"{k}:{f.fields_differ[k]}" for k in COMPARED if k in f.fields_differ) or "-"
        table.append((rel, f.label, "yes" if f.deterministic else "no", str(f.rerun), str(f.identical),
                      str(f.q_differ), f"{f.max_dq:.3g}", str(f.iterations_differ), str(f.max_diterations),
                      str(f.traces_differ), str(f.solutions_differ), named))
    width = [max(len(r[c]) for r in table) for c in range(len(head))]
    out = ["  ".join(c.ljust(w) for c, w in zip(r, width)).rstrip() for r in table]
    det = [f for f in rows if not f.note and f.deterministic]
    differ = [f for f in det if f.identical < f.rerun]
    out.append("")
    out.append(f"{len(det)} deterministic archive(s): {len(det) - len(differ)} bit-identical on every re-run solve, "
               f"{len(differ)} with differences" + (f" ({', '.join(sorted({f.label for f in differ}))})" if differ else ""))
    envs = sorted({f.environment for f in rows if f.environment})
    out.append("written on: " + (" | ".join(envs) if envs else "unknown"))
    out.append("re-run on:  " + _env_line(environment()))
    return "\n".join(out)
