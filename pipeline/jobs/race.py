"""The race: the finalists of one arm timed against each other in one process, interleaved.

The solve jobs decide correctness (success, intervals, distance to the seed) from the archives; where
more than one label is left to choose from (:func:`pipeline.studies.arm_benchmark.shortlist`), speed
decides. Timing those labels in separate jobs, at different moments, lets load that lands on one job
and not another decide the ranking. The race job runs after an arm's solve jobs and times the
finalists of each of its problem sets together:

1. every finalist bound once (:func:`pipeline.solvers.bind`) with the settings of its archive, and
   called once on the first goal untimed (kernels compiled or loaded);
2. ``passes`` passes over the same goals (the first ``goals`` goals every finalist ran); per goal,
   every finalist once, in an order shuffled per goal by a seeded generator, each call timed on the
   wall clock and the calling thread's CPU clock (the process's for a method with threads of its own);
3. one JSON record per timed call on :data:`~pipeline.studies.arm_benchmark.RACE_TOPIC` and one per set
   on :data:`~pipeline.studies.arm_benchmark.RACE_SET_TOPIC` (the finalists, goals, passes, the load
   average at start and end, the race's CPU share), written to one MCAP archive (``measurement: race``).

A set with one finalist (a closed form alone among the best, say) is not raced: nothing is timed,
and its set record says so. The tables read the race from the archive alone
(:func:`pipeline.studies.arm_benchmark.race_summary`).
"""

from __future__ import annotations

import os
import sys
import time
import zlib
from pathlib import Path

import numpy as np

from pipeline.errors import UsageError

GOALS = 300  # goals per set in the race (at most: the goals every finalist ran)
PASSES = (3, 7)  # passes over the goals: at least, at most
BUDGET_S = 60.0  # a set's race stops adding passes (beyond the least) once it has taken this long [s]


def _schema(title: str, desc: str) -> dict:
    return {"title": f"ik_pipeline.{title}", "type": "object", "description": desc}


def _race_goals(study, model, df, arch, pset: str, fin: list, goals: int) -> tuple:
    """The goals of a race: the first ``goals`` problem ids every finalist ran, their goal poses
    ``T`` (k, 4, 4), starts ``Q0`` (k, n) [rad or length unit] and per-problem seeds."""
    from pipeline.io.archive import problems_of
    from pipeline.runner import model_goals, problem_seed

    ids = None
    for lab in fin:
        have = set(df.loc[(df["problem_set"] == pset) & (df["solver"] == lab), "problem_id"].astype(int))
        ids = have if ids is None else ids & have
    found = problems_of(arch)
    if found is None:
        raise UsageError(f"{arch.path}: its problem file is not beside it (run the solve jobs first)")
    row_of, ps, _ = found
    ids = sorted(ids)[:goals]
    rows = np.array([row_of[i] for i in ids], dtype=np.int64)
    T = model_goals(ps, model)[rows]
    Q0 = ps.q_start[rows]
    set_seed = int(study.problem_sets[pset]["seed"])
    seeds = [problem_seed(set_seed, i, 0) for i in ids]
    return ids, T, Q0, seeds


def _timed_passes(w, pset: str, fin: list, bound: dict, clocks: dict, ids: list, T, Q0, seeds: list, rng,
                  passes: tuple, budget_s: float, w0: int) -> int:
    """Call every finalist on every goal, in a fresh random order each pass, one JSON record per call on
    :data:`~pipeline.studies.arm_benchmark.RACE_TOPIC`; at least ``passes[0]`` passes, at most
    ``passes[1]``, no new pass after ``budget_s`` [s] from ``w0`` [ns]. Returns the passes done."""
    from pipeline.studies import arm_benchmark as ab

    done = 0
    for p in range(passes[1]):
        if p >= passes[0] and (time.perf_counter_ns() - w0) * 1e-9 > budget_s:
            break
        for k in rng.permutation(len(ids)):
            for j in rng.permutation(len(fin)):
                lab = fin[j]
                clock = clocks[lab]
                b = bound[lab]
                tc = clock()
                tw = time.perf_counter_ns()
                res = b.solve(T[k], Q0[k], seeds[k])
                tw = time.perf_counter_ns() - tw
                tc = clock() - tc
                w.write_message(ab.RACE_TOPIC, {"problem_set": pset, "solver": lab, "problem_id": int(ids[k]),
                                                "pass": p, "wall_ns": int(tw), "cpu_ns": int(tc),
                                                "success": bool(res.success)})
        done = p + 1
        print(f"{pset}: pass {done}: {len(ids)} goals x {len(fin)} finalists "
              f"({(time.perf_counter_ns() - w0) * 1e-9:.1f} s)", file=sys.stderr, flush=True)
    return done


def race_arm(study_path, robot_path, archive_paths: list, out, *, goals: int = GOALS, passes: tuple = PASSES,
             budget_s: float = BUDGET_S, seed: int = 0) -> str:
    """Race the finalists of every problem set of one arm (see the module docstring); returns the summary line."""
    from pipeline.io.archive import ArchiveError, ArchiveWriter, read_archive, run_metadata
    from pipeline.provenance import file_sha256
    from pipeline.robots import load_robot
    from pipeline.settings import load_study
    from pipeline.solvers import bind, get
    from pipeline.studies import arm_benchmark as ab
    from pipeline.studies.generic import runs_frame

    study = load_study(study_path)
    model = load_robot(robot_path)
    try:
        archives = [read_archive(p) for p in archive_paths]
    except ArchiveError as exc:
        raise UsageError(str(exc)) from None
    archives = [a for a in archives if a.solves and a.metadata.get("robot") == model.name]
    if not archives:
        raise UsageError(f"{robot_path}: no solve archive of robot {model.name!r} among the {len(archive_paths)} given")
    df = ab.answer_frame(runs_frame(archives), archives, study)  # the tables' own frame: the same finalists
    meta = ab.label_settings(archives)
    mt = ab.method_table(df, meta, ab.job_timing(archives))
    succ = ab.success_by_problem(df)
    warm = ab.warm_sets(study)
    by_set = {a.metadata["problem_set"]: a for a in archives}
    rng = np.random.default_rng([seed, zlib.crc32(model.name.encode())])
    settings = {"goals": goals, "passes": list(passes), "budget_s": budget_s, "seed": seed,
                "tie_ratio": ab.TIE_RATIO, "track_factor": ab.TRACK_FACTOR}
    meta_run = run_metadata(study=study.id, robot=model.name, solver="-", settings=settings, seed=seed,
                            measurement="race", problems="-", problem_file="-", problem_sha256="-",
                            robot_file=str(robot_path), robot_sha256=file_sha256(robot_path)[:16],
                            scale=ab._scale(archives))
    lines = []
    with ArchiveWriter(out, meta_run) as w:
        w.add_channel(ab.RACE_TOPIC, _schema("Race.call", "one timed call: wall and CPU time [ns]"))
        w.add_channel(ab.RACE_SET_TOPIC, _schema("Race.set", "one raced problem set: finalists, goals, load"))
        for (robot, pset), g in mt.groupby(["robot", "problem set"], sort=False):
            fin = list(ab.shortlist(g, succ, robot, pset, ab.is_warm(pset, warm))["finalists"]["solver"])
            record = {"problem_set": pset, "finalists": fin, "raced": len(fin) > 1, "goals": 0, "passes": 0,
                      "cores": os.cpu_count() or 0}
            if len(fin) < 2:
                record["why"] = "one finalist: no timing decides"
                w.write_message(ab.RACE_SET_TOPIC, record)
                lines.append(f"{pset}: {fin[0] if fin else 'nothing'} alone, not raced")
                continue
            ids, T, Q0, seeds = _race_goals(study, model, df, by_set[pset], pset, fin, goals)
            bound = {}
            for lab in fin:
                entry = study.solvers[lab]
                bound[lab] = bind(entry.method, model, entry.settings)
                bound[lab].solve(T[0], Q0[0], seeds[0])  # compile or load the kernels: not timed
            clocks = {lab: time.process_time_ns if get(study.solvers[lab].method).own_threads else time.thread_time_ns
                      for lab in fin}
            load0 = os.getloadavg()[0]
            c0, w0 = time.process_time_ns(), time.perf_counter_ns()
            done = _timed_passes(w, pset, fin, bound, clocks, ids, T, Q0, seeds, rng, passes, budget_s, w0)
            wall = time.perf_counter_ns() - w0
            record.update({"goals": len(ids), "passes": done, "load_start": f"{load0:.2f}",
                           "load_end": f"{os.getloadavg()[0]:.2f}",
                           "cpu_share": f"{(time.process_time_ns() - c0) / max(wall, 1):.2f}"})
            w.write_message(ab.RACE_SET_TOPIC, record)
            lines.append(f"{pset}: {', '.join(fin)} raced on {len(ids)} goals x {done} passes "
                         f"(load {record['load_start']} -> {record['load_end']})")
    return f"wrote {out}: " + "; ".join(lines)
