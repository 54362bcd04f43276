"""The solve job: a problem set through one registered solver into one archive (and its problem set).

:func:`solve_to_archive` is the one place a solve job runs: it loads the study, robot and problem
file, builds the archive's ``run`` metadata (:func:`pipeline.io.archive.run_metadata`), solves
through :func:`pipeline.runner.solve_set_batches` and writes the archive under the study's trace
policy. ``solve_problems`` runs several (set, label) jobs in one process; ``rerun_failures`` re-runs
an archive's failed problems with changed stop rules.
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from pipeline.errors import UsageError


def _progress(done: int, total: int, t0: float, extra: str = "") -> None:
    print(f"[{time.monotonic() - t0:7.1f} s] {done}/{total} {extra}", file=sys.stderr, flush=True)


def problem_set_spec(study, name: str) -> dict:
    """A study's problem-set settings, or a one-line error naming the sets it has."""
    if name not in study.problem_sets:
        raise UsageError(f"{study.path}: field 'problem_sets/{name}': no such problem set "
                         f"(have: {', '.join(study.problem_sets) or 'none'})")
    return study.problem_sets[name]


def make_problems(study_path, problem_set: str, robot_path, scale: str, data_dir, out) -> str:
    """Write a study's seeded problem set for one robot; returns the line to print."""
    from pipeline.io.problems import write_problems
    from pipeline.problems import ProblemSpecError, make_problem_set
    from pipeline.studies.generators import load_generator
    from pipeline.provenance import file_sha256
    from pipeline.robots import load_robot
    from pipeline.settings import ConfigError, load_study

    study = load_study(study_path)
    spec = problem_set_spec(study, problem_set)
    model = load_robot(robot_path)
    if model.name not in study.set_robots(problem_set):
        raise UsageError(f"{study_path}: field 'problem_sets/{problem_set}/robots': {model.name!r} is not one "
                         f"of {study.set_robots(problem_set)}")
    count = study.count(problem_set, scale)
    # one independent stream per robot, derived from the set's seed
    rng = np.random.default_rng([spec["seed"], sum(model.name.encode())])
    try:
        ps = make_problem_set(spec, model, count, rng, Path(data_dir), scale, load=load_generator)
    except ProblemSpecError as exc:
        raise ConfigError(f"{study_path}: problem_sets/{problem_set}: {exc}") from None
    if ps.robot != model.name or ps.q_start.shape[1:] != (model.n,):
        raise UsageError(f"problem set {problem_set}: the generator returned problems for {ps.robot!r} "
                         f"with {ps.q_start.shape[1]} joints, not {model.name!r} with {model.n}")
    write_problems(out, ps, {"study": study.id, "problem_set": problem_set, "kind": spec["kind"],
                             "seed": spec["seed"], "scale": scale, "count": len(ps),
                             "robot_sha256": file_sha256(robot_path)[:16]})
    return f"wrote {len(ps)} problems of set {problem_set} for {model.name} to {out}"


def deterministic(method: str, settings) -> bool:
    """Whether a re-run of a solve gives the same bits on the same machine: this package's own methods
    and ur_analytic_ik without a wall-time budget; not TRAC-IK (racing threads), the other peer
    libraries (C ``rand()`` state, their own clocks) or any run with a ``time_budget``."""
    from pipeline.solvers import get

    if float(getattr(settings, "time_budget", 0.0) or 0.0) > 0.0:
        return False
    return not get(method).run.__module__.startswith("pipeline.solvers.peers.") or method == "ur_analytic_ik"


def trace_policy(study):
    """The study's :class:`~pipeline.io.archive.TracePolicy` (setting ``trace_policy``)."""
    from pipeline.io.archive import TracePolicy
    from pipeline.settings import ConfigError

    try:
        return TracePolicy.from_setting(study.doc.get("trace_policy"), f"{study.path}: field 'trace_policy'")
    except ValueError as exc:
        raise ConfigError(str(exc)) from None


def _run_record(study, problem_set: str, entry, model, robot_path, problems_path, scale: str, out, spec: dict, *,
                n_problems: int, reps: int, runs: int, policy, extra_meta: dict | None) -> dict[str, str]:
    """The ``run`` metadata of a solve job's archive: settings, problem and robot files (relative to the
    archive), timing protocol and trace policy."""
    from pipeline.io.archive import run_metadata
    from pipeline.provenance import file_sha256
    from pipeline.solvers import get

    settings = entry.settings
    unit = settings.length_unit
    here = Path(out).resolve().parent
    return run_metadata(
        study=study.id, robot=model.name, solver=entry.label, settings=entry.as_dict(), seed=spec["seed"],
        settings_hash=study.solver_hash(problem_set, entry.label, scale), problem_set=problem_set,
        method=entry.method, library=get(entry.method).library, reading=entry.reading, scale=scale, problems=n_problems,
        repetitions=reps,
        problem_file=Path(problems_path).name, problem_sha256=file_sha256(problems_path)[:16],
        problem_path=os.path.relpath(Path(problems_path).resolve(), here),
        robot_file=str(robot_path), robot_sha256=file_sha256(robot_path)[:16],
        robot_path=os.path.relpath(Path(robot_path).resolve(), here),
        robot_repairs="; ".join(model.repairs) if model.repairs else None, length_unit=unit,
        deterministic=str(deterministic(entry.method, settings)).lower(),
        timing="solve_time_s = the method's own computation on the monotonic clock; call_time_s = the whole "
               "solve() call (pipeline/solvers/core/timing.py); cpu_time_s = the CPU time of the call "
               "(pipeline/runner.py)" + (f"; each the fastest of {runs} runs of the solve by CPU time, the "
                                         "result of the first (timing_runs)" if runs > 1 else ""),
        traces=policy.describe(), **(extra_meta or {}))


def _first_repetition(traces: dict) -> dict:
    """The traces of repetition 0 only (``problem_id``, ``repetition``, ``rows`` (T,), ``full`` (sum of rows, 8))."""
    keep = traces["repetition"] == 0
    return {"problem_id": traces["problem_id"][keep], "repetition": traces["repetition"][keep],
            "rows": traces["rows"][keep], "full": traces["full"][np.repeat(keep, traces["rows"])]}


def solve_to_archive(study, problem_set: str, entry, robot_path, problems_path, scale: str, out, *, limit: int = 0,
                     select=None, threads: int = 1, extra_meta: dict | None = None) -> str:
    """Solve the problems of ``problems_path`` (the first ``limit`` or all, or the ids in ``select``)
    with the study's solver ``entry`` into the archive ``out``; returns the summary line."""
    from pipeline.io.archive import ArchiveWriter, batch_columns
    from pipeline.io.problems import read_problems
    from pipeline.robots import LENGTH_UNITS, load_robot
    from pipeline.runner import solve_set_batches

    spec = problem_set_spec(study, problem_set)
    model = load_robot(robot_path)
    ps, _ = read_problems(problems_path)
    if ps.robot != model.name:
        raise UsageError(f"{problems_path}: header field 'robot': {ps.robot!r} but the robot file is {model.name!r}")
    if limit and limit < len(ps):
        ps = ps.head(limit)
    reps = study.repetitions(problem_set, scale)
    runs = study.timing_runs(problem_set, scale)
    settings = entry.settings
    unit = settings.length_unit
    to_unit = LENGTH_UNITS[ps.length_unit] / LENGTH_UNITS[unit]
    ids = ps.problem_id if select is None else ps.problem_id[np.isin(ps.problem_id, list(select))]
    policy = trace_policy(study)
    meta = _run_record(study, problem_set, entry, model, robot_path, problems_path, scale, out, spec,
                       n_problems=len(ids), reps=reps, runs=runs, policy=policy, extra_meta=extra_meta)
    t0 = time.monotonic()
    n_ok = done = 0
    total = len(ids) * reps
    shown = 0
    t_solve = t_write = 0.0
    cpu_ns = wall_ns = 0
    load_start = os.getloadavg()[0]  # the machine's load, recorded beside the times it may move
    with ArchiveWriter(out, meta, policy=policy, problem_ids=ids) as w:
        batches = solve_set_batches(entry.method, settings, model, ps, repetitions=reps, set_seed=spec["seed"],
                                    select=select, threads=max(1, threads), timing_runs=runs)
        while True:  # the solving alone is timed (CPU and wall), not the archiving between batches
            c0, w0 = time.process_time_ns(), time.perf_counter_ns()
            try:
                rows, rep, q0, res = next(batches)
            except StopIteration:
                break
            cpu_ns += time.process_time_ns() - c0
            wall_ns += time.perf_counter_ns() - w0
            t_solve += res.call_time_s
            tw = time.perf_counter()
            cols, traces = batch_columns(ps.problem_id[rows], rep, ps.chain[rows], model.name, entry.label, unit, q0,
                                         ps.goal_position[rows] * to_unit, ps.goal_quat[rows], res, method=entry.method,
                                         start_from_file=np.all(q0 == ps.q_start[rows], axis=1))
            if traces is not None and reps > 1:  # repetitions repeat the same iterates: one trace per problem
                traces = _first_repetition(traces)
            w.write_columns(cols, traces)
            t_write += time.perf_counter() - tw
            n_ok += int(res.success.sum())
            done += len(rows)
            if done * 10 // max(1, total) > shown or done == total:
                shown = done * 10 // max(1, total)
                _progress(done, total, t0, f"solved, {n_ok} FK-verified successes")
        w.job_timing = {"cpu_s": f"{cpu_ns * 1e-9:.6f}", "wall_s": f"{wall_ns * 1e-9:.6f}",
                        "cpu_share": f"{cpu_ns / max(wall_ns, 1):.4f}", "cores": str(os.cpu_count() or 0),
                        "load_1min_start": f"{load_start:.2f}", "load_1min_end": f"{os.getloadavg()[0]:.2f}"}
        tw = time.perf_counter()
    t_write += time.perf_counter() - tw  # the last chunks and the summary, written on closing
    return (f"wrote {out}: {total} solves, {n_ok} FK-verified successes; solving {t_solve:.3f} s "
            f"({cpu_ns / max(wall_ns, 1):.0%} of a core), "
            f"archiving {t_write:.3f} s ({t_write / max(t_solve, 1e-9):.2f} of the solving time)")


def solve_problems(study_path, problem_sets: list[str], problems: list, labels: list[str], robot_path, scale: str,
                   outs: list, *, limit: int = 0, threads: int = 1) -> None:
    """One archive per (problem set, solver label): ``problem_sets`` and ``problems`` pair up; ``outs``
    holds one archive per set and label, set-major (all labels of the first set, then of the second...)."""
    from pipeline.settings import load_study

    if len(problem_sets) != len(problems):
        raise UsageError(f"--problem-set names {len(problem_sets)} sets but --problems {len(problems)} files")
    jobs = [(ps, pf, label) for ps, pf in zip(problem_sets, problems) for label in labels]
    if len(jobs) != len(outs):
        raise UsageError(f"{len(problem_sets)} problem set(s) x {len(labels)} solver(s) need {len(jobs)} "
                         f"--out archives, got {len(outs)}")
    study = load_study(study_path)
    for k, ((pset, pfile, label), out) in enumerate(zip(jobs, outs)):
        problem_set_spec(study, pset)
        if label not in study.solvers:
            raise UsageError(f"{study_path}: field 'solvers/{label}': no such solver (have: {', '.join(study.solvers)})")
        if label not in study.set_solvers(pset):
            raise UsageError(f"{study_path}: field 'problem_sets/{pset}/solvers': {label!r} does not run on this set")
        if len(jobs) > 1:
            print(f"[{k + 1}/{len(jobs)}] {pset}: {label}", flush=True)
        cap = min(x for x in (study.solver_cap(pset, label, scale), limit or None, 10**12) if x is not None)
        print(solve_to_archive(study, pset, study.solvers[label], robot_path, pfile, scale, out, limit=cap,
                               threads=threads))


def rerun_failures(study_path, label: str, problem_set: str, robot_path, problems, scale: str, archive, out) -> None:
    """Re-run one archive's failed problems with the study's ``rerun`` setting overrides (Table 16 of 000)."""
    from pipeline.io.archive import read_archive
    from pipeline.settings import load_study
    from pipeline.solvers import SettingsError

    study = load_study(study_path)
    if label not in study.solvers:
        raise UsageError(f"{study_path}: field 'solvers/{label}': no such solver (have: {', '.join(study.solvers)})")
    entry = study.solvers[label]
    overrides = study.settings.get("rerun")
    if not overrides:
        raise UsageError(f"{study_path}: field 'study_settings/rerun': missing (the rerun's setting overrides)")
    try:
        rerun = replace(entry.settings, **overrides)
    except TypeError as exc:
        raise SettingsError(f"{study_path}: field 'study_settings/rerun': {exc}") from None
    rerun.validate(f"{study_path}: study_settings/rerun")
    original = read_archive(archive)
    if original.metadata["solver"] != label:
        raise UsageError(f"{archive}: metadata field 'solver' is {original.metadata['solver']!r}, expected {label!r}")
    failed = [r["problem_id"] for r in original.solves if not r["success"]]
    print(solve_to_archive(study, problem_set, replace(entry, settings=rerun), robot_path, problems, scale, out,
                           select=failed, extra_meta={"rerun_of": Path(archive).name,
                                                      "rerun_of_settings_hash": original.metadata["settings_hash"]}))
