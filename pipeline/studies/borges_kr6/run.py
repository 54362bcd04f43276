"""Run one problem set with one method and write its MCAP archive (the source of truth).

Problem sets: ``alpha_sweep`` (JI only, Table 2), ``points`` (Table 3), ``paths`` (Figs. 5-10).
Each solve is one ``/ik/solve`` + ``/ik/trace`` record; the channel ``/borges_kr6/problem`` adds
what the generic records lack (set, label, run or path index, t, alpha, PSO seed, reached position).
"""

from __future__ import annotations

import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np

from pipeline.kinematics import fk_htm
from pipeline.studies.borges_kr6 import methods as M
from pipeline.studies.borges_kr6 import problems as P

PROBLEM_SETS = ("alpha_sweep", "points", "paths")
SET_CODE = {"alpha_sweep": 0, "points": 1, "paths": 2}
PROBLEM_TOPIC = "/borges_kr6/problem"
IDENTITY_WXYZ = np.array([1.0, 0.0, 0.0, 0.0])  # position-only goals: no orientation is asked for
PROBLEM_SCHEMA = {
    "title": "borges_kr6.Problem",
    "type": "object",
    "properties": {
        "problem_id": {"type": "integer"},
        "set": {"type": "string", "description": "alpha_sweep | points | paths"},
        "label": {"type": "string", "description": "d300/d960/d1160, P1-P3 or the curve name"},
        "index": {"type": "integer", "description": "pair index, run index or path point index"},
        "t": {"type": "number", "description": "curve parameter [rad] (paths)"},
        "alpha": {"type": "number", "description": "JI attenuation factor used"},
        "distance_mm": {"type": "number", "description": "|p_goal - p(q_start)| [mm]"},
        "seed": {"type": "integer", "description": "PSO run seed (-1 for deterministic methods)"},
        "reached_mm": {"type": "array", "items": {"type": "number"}, "description": "FK of q_solution [mm]"},
        "cpu_time_s": {"type": "number", "description": "thread CPU time of the solve [s] (solve_time_s is wall time)"},
    },
}


class RunError(ValueError):
    """A problem set or method name that does not exist, or a method not run on a set (one line)."""


def set_methods(pset: str, settings: dict) -> tuple[str, ...]:
    """Methods run on a problem set (the alpha sweep is the JI tuning of Table 2; the three methods run
    on the points and paths, each PSO variant on the sets of its ``problem_sets``)."""
    if pset == "alpha_sweep":
        return ("ji",)
    return tuple(m for m in M.all_methods(settings) if pset in M.variant_sets(settings, m))


def job_settings(settings: dict, pset: str, method: str, scale: str) -> dict:
    """Everything that determines one archive's content (timings aside)."""
    keys = ("seed", "success_tolerance_mm", "error_change_stop_mm", "start_configuration_deg")
    kind, cfg = M.method_config(settings, method)
    return {"method": method, "kind": kind, "problem_set": pset, "scale": scale, **{k: settings[k] for k in keys},
            "method_settings": cfg, "set_settings": settings[pset]}


def settings_hash(js: dict) -> str:
    return hashlib.sha256(json.dumps(js, sort_keys=True).encode()).hexdigest()[:16]


def problem_hash(settings: dict, pset: str, scale: str) -> str:
    """Hash of what defines a problem set (its settings block, seed, start configuration, scale)."""
    blob = {"set": pset, "scale": scale, "seed": settings["seed"], "start": settings["start_configuration_deg"],
            "definition": settings[pset]}
    return hashlib.sha256(json.dumps(blob, sort_keys=True).encode()).hexdigest()[:16]


def iter_solves(settings: dict, model, pset: str, method: str, scale: str):
    """Yield ``(extra, q_start, p_goal, IKResult)`` for every problem of ``pset`` solved by ``method``.

    ``extra`` holds the ``/borges_kr6/problem`` fields except problem_id and reached_mm.
    """
    if pset not in PROBLEM_SETS:
        raise RunError(f"unknown problem set {pset!r} (have: {', '.join(PROBLEM_SETS)})")
    if method not in set_methods(pset, settings):
        have = ", ".join(set_methods(pset, settings))
        raise RunError(f"method {method!r} is not run on problem set {pset!r} (have: {have})")
    prep = M.Prepared(model)
    mcfg = settings["methods"]
    kind, cfg = M.method_config(settings, method)
    seed = int(settings["seed"])
    q_home = np.radians(np.asarray(settings["start_configuration_deg"], float))
    M.warm_up(prep, mcfg, settings)
    if pset == "alpha_sweep":
        s = settings["alpha_sweep"]
        rng = np.random.default_rng([seed, SET_CODE[pset]])
        pairs = P.distance_pairs(model, s["distances_mm"], int(s["pairs"][scale]), float(s["distance_tolerance_mm"]), rng)
        counter = {}
        for pair in pairs:
            idx = counter.setdefault(pair.distance_class, 0)
            counter[pair.distance_class] += 1
            for a in s["alphas"]:
                tm = {}
                res = M.solve_ji(prep, pair.p_goal, pair.q_start, cfg, settings, reach_mm=float(s["reach_tolerance_mm"]),
                                 gain=float(a), max_iterations=int(s["max_iterations"]), timing=tm)
                extra = {"set": pset, "label": f"d{pair.distance_class:g}", "index": idx, "t": 0.0, "alpha": float(a),
                         "distance_mm": pair.distance, "seed": -1, "cpu_time_s": tm["cpu_time_s"]}
                yield extra, pair.q_start, pair.p_goal, res
    elif pset == "points":
        s = settings["points"]
        p_home = fk_htm(model.chain, q_home)[:3, 3]
        for k, (label, target) in enumerate(s["targets_mm"].items()):
            goal = np.asarray(target, float)
            for run in range(int(s["runs"][scale])):
                run_seed, tm = -1, {}
                if kind == "ji":
                    res = M.solve_ji(prep, goal, q_home, cfg, settings, timing=tm)
                elif kind == "lm":
                    res = M.solve_lm(prep, goal, q_home, cfg, settings, timing=tm)
                else:
                    run_seed = M.run_seed(np.random.default_rng([seed, SET_CODE[pset], k, run]))
                    res = M.solve_pso(prep, goal, prep.limits, cfg, settings, run_seed, timing=tm)
                extra = {"set": pset, "label": label, "index": run, "t": 0.0,
                         "alpha": float(mcfg["ji"]["alpha"]) if kind == "ji" else 0.0,
                         "distance_mm": float(np.linalg.norm(goal - p_home)), "seed": run_seed,
                         "cpu_time_s": tm["cpu_time_s"]}
                yield extra, q_home, goal, res
    else:
        s = settings["paths"]
        t = P.path_parameter(float(s["t_start"]), float(s["t_step"]), int(s["points"][scale]))
        for c, curve in enumerate(s["curves"]):
            pts = P.curve_points(curve, t, bool(s["circle_swap_yz"]))
            q_prev = q_home.copy()
            for k in range(len(t)):
                run_seed, tm = -1, {}
                p_prev = fk_htm(model.chain, q_prev)[:3, 3]
                if kind == "ji":
                    res = M.solve_ji(prep, pts[k], q_prev, cfg, settings, timing=tm)
                elif kind == "lm":
                    res = M.solve_lm(prep, pts[k], q_prev, cfg, settings, timing=tm)
                else:
                    run_seed = M.run_seed(np.random.default_rng([seed, SET_CODE[pset], c, k]))
                    # first point: the robot leaves its start pose, the whole joint space is searched;
                    # afterwards the box is a window around the previous solution (§3.6)
                    box = prep.limits if k == 0 else M.window_bounds(prep.limits, q_prev, float(cfg["path_window_rad"]))
                    res = M.solve_pso(prep, pts[k], box, cfg, settings, run_seed, timing=tm)
                extra = {"set": pset, "label": curve, "index": k, "t": float(t[k]),
                         "alpha": float(mcfg["ji"]["alpha"]) if kind == "ji" else 0.0,
                         "distance_mm": float(np.linalg.norm(pts[k] - p_prev)), "seed": run_seed,
                         "cpu_time_s": tm["cpu_time_s"]}
                yield extra, q_prev.copy(), pts[k], res
                if np.all(np.isfinite(res.q)):
                    q_prev = res.q.copy()


def write_archive(study, robot_path: str | Path, pset: str, method: str, scale: str, out: str | Path) -> tuple[int, int]:
    """Solve ``pset`` with ``method`` and write ``out`` (MCAP). Returns (problems, FK-verified successes)."""
    import pipeline
    from pipeline.io.archive import FORMAT_VERSION, ArchiveWriter, solve_record
    from pipeline.robots import load_robot
    from pipeline.settings import file_sha256, git_commit

    model = load_robot(robot_path)
    if model.name not in study.doc["robots"]:
        raise RunError(f"{robot_path}: robot {model.name!r} is not one of the study's robots {study.doc['robots']}")
    js = job_settings(study.settings, pset, method, scale)
    meta = {"format_version": FORMAT_VERSION, "study": study.id, "robot": model.name, "solver": method,
            "settings": json.dumps(js, sort_keys=True), "settings_hash": settings_hash(js),
            "seed": str(study.settings["seed"]), "scale": scale, "problem_set": pset,
            "robot_sha256": file_sha256(robot_path)[:16], "length_unit": model.length_unit,
            # no problem file: the set is generated from the settings; hash its definition instead
            "problem_file": "-", "problem_sha256": problem_hash(study.settings, pset, scale),
            "package_version": pipeline.__version__, "git_commit": git_commit()}
    n = ok = 0
    t0 = time.monotonic()
    with ArchiveWriter(out, meta) as w:
        w.add_channel(PROBLEM_TOPIC, PROBLEM_SCHEMA)
        for extra, q_start, goal, res in iter_solves(study.settings, model, pset, method, scale):
            rec, tr = solve_record(n, model.name, method, model.length_unit, q_start, goal, IDENTITY_WXYZ, res)
            w.write(rec, tr)
            reached = fk_htm(model.chain, res.q)[:3, 3]
            w.write_message(PROBLEM_TOPIC, {"problem_id": n, **extra, "reached_mm": [float(v) for v in reached]})
            n += 1
            ok += bool(res.success)
            if n % 50 == 0:
                print(f"[{time.monotonic() - t0:7.1f} s] {n} solved, {ok} successes", file=sys.stderr, flush=True)
    return n, ok
