"""Solve one designed motion with one method, ``repetitions`` times, into one MCAP archive.

Archive content (besides the generic ``/ik/solve`` + ``/ik/trace`` of repetition 0, one record per
trajectory point, ``problem_id`` = point index):

``/nepomuceno2024/point``       per point of repetition 0: segment, nfev, njev, the document's
                                per-method error measure, the method's stop message, analytic
                                solution count and branch.
``/nepomuceno2024/repetition``  per repetition: per-point solve times, FK-checked position and
                                orientation errors, whether every solution equals repetition 0's.

Every solve of every repetition is checked by an independent numpy FK. Timings are the only fields
that differ between two runs with the same settings.
"""

from __future__ import annotations

import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np

POINT_TOPIC = "/nepomuceno2024/point"
REP_TOPIC = "/nepomuceno2024/repetition"
_NUMS = {"type": "array", "items": {"type": "number"}}
POINT_SCHEMA = {
    "title": "nepomuceno2024.Point",
    "type": "object",
    "properties": {
        "problem_id": {"type": "integer", "description": "point index along the motion"},
        "motion": {"type": "string"},
        "segment": {"type": "string"},
        "nfev": {"type": "integer", "description": "cost / FK evaluations"},
        "njev": {"type": "integer", "description": "gradient or Jacobian evaluations"},
        "doc_error": {"type": "number", "description": "the document's per-method error measure"},
        "doc_measure": {"type": "string"},
        "message": {"type": "string"},
        "n_solutions": {"type": "integer", "description": "analytic: FK-verified closed-form solutions"},
        "branch": {"type": "integer", "description": "analytic: chosen branch (0..7)"},
    },
}
REP_SCHEMA = {
    "title": "nepomuceno2024.Repetition",
    "type": "object",
    "properties": {
        "repetition": {"type": "integer"},
        "solve_time_s": {**_NUMS, "description": "per point [s]"},
        "total_time_s": {"type": "number", "description": "sum over the motion [s]"},
        "position_error": {**_NUMS, "description": "per point, independent FK [m]"},
        "orientation_error": {**_NUMS, "description": "per point, independent FK [rad]"},
        "success": {"type": "array", "items": {"type": "boolean"}},
        "same_as_repetition_0": {"type": "boolean", "description": "every solution bit-identical to repetition 0"},
    },
}


def doc_measure(cfg: dict) -> str:
    """Name of the document's per-method error measure for a method's settings."""
    if cfg["kind"] == "scipy":
        return f"cost {cfg['cost']}"
    return "‖e‖ = ‖[Δp; ½Σcᵢ×dᵢ]‖"


def settings_blob(settings: dict, method: str, motion: str, scale: str, motions_sha: str, robot_sha: str) -> dict:
    """Everything that determines one archive's content (timings aside)."""
    return {"method": settings["methods"][method], "costs": settings["costs"], "success": settings["success"],
            "interpolation": settings["interpolation"][scale], "repetitions": settings["repetitions"][scale],
            "motion": motion, "scale": scale, "motions_sha256": motions_sha, "robot_sha256": robot_sha}


def jacobian_dh(cfg: dict):
    """Packed DH table of a descent method's Jacobian model, or None for the FK model itself."""
    from pipeline.studies.nepomuceno2024.methods import pack_dh_table

    jac = cfg.get("jacobian", "model")
    if cfg["kind"] != "pinv_descent" or jac == "model":
        return None
    return pack_dh_table(jac["a"], jac["alpha"], jac["d"], jac.get("theta_offset"))


def solve_motion(study, robot_path: str | Path, motions_path: str | Path, motion: str, method: str, scale: str,
                 out: str | Path, log=sys.stderr) -> dict:
    """Run one (motion, method) job and write its archive; returns a summary dict."""
    import pipeline
    from pipeline.io.archive import FORMAT_VERSION, ArchiveWriter, solve_record
    from pipeline.kinematics import fk_htm, quat_from_matrix
    from pipeline.robots import load_robot
    from pipeline.settings import file_sha256, git_commit
    from pipeline.studies.nepomuceno2024.methods import MethodError, Prepared, check_ur, solve_point, warm_up
    from pipeline.studies.nepomuceno2024.trajectory import build_motion, load_motions

    st = study.settings
    if method not in st["methods"]:
        raise MethodError(f"{study.path}: field 'study_settings/methods/{method}': no such method "
                          f"(have: {', '.join(st['methods'])})")
    cfg = st["methods"][method]
    model = load_robot(robot_path)
    if cfg["kind"] == "analytic":
        check_ur(model)
    prep = Prepared(model, st["success"]["position"], st["success"]["orientation"])
    doc = load_motions(motions_path)
    mp = build_motion(doc, motion, lambda q: fk_htm(model.chain, q), **st["interpolation"][scale])
    reps = int(st["repetitions"][scale])
    jac = jacobian_dh(cfg)
    motions_sha = file_sha256(motions_path)
    blob = settings_blob(st, method, motion, scale, motions_sha, file_sha256(robot_path))
    meta = {
        "format_version": FORMAT_VERSION, "study": study.id, "robot": model.name, "solver": method,
        "settings": json.dumps(blob, sort_keys=True, ensure_ascii=False),
        "settings_hash": hashlib.sha256(json.dumps(blob, sort_keys=True).encode()).hexdigest()[:16],
        "seed": "-", "scale": scale, "problems": str(len(mp)), "problem_file": Path(motions_path).name,
        "problem_sha256": motions_sha[:16], "length_unit": model.length_unit, "motion": motion,
        "test": str(mp.test), "repetitions": str(reps), "method_kind": cfg["kind"],
        "package_version": pipeline.__version__, "git_commit": git_commit(),
    }
    warm_up(prep, {method: cfg}, st["costs"], {method: jac} if jac is not None else {})
    quats = quat_from_matrix(mp.T)
    measure = doc_measure(cfg)
    t_start = time.monotonic()
    first_q = None
    totals = []
    with ArchiveWriter(out, meta) as w:
        w.add_channel(POINT_TOPIC, POINT_SCHEMA)
        w.add_channel(REP_TOPIC, REP_SCHEMA)
        for rep in range(reps):
            q = mp.q_start.copy()
            results = []
            for k in range(len(mp)):
                r = solve_point(method, cfg, st["costs"], prep, mp.T[k], q, jac)
                results.append((q, r))
                q = r.ik.q
            qs = np.array([r.ik.q for _, r in results])
            if rep == 0:
                first_q = qs
                for k, (q0, r) in enumerate(results):
                    rec, tr = solve_record(k, model.name, method, model.length_unit, q0, mp.T[k, :3, 3], quats[k], r.ik)
                    w.write(rec, tr)
                    w.write_message(POINT_TOPIC, {
                        "problem_id": k, "motion": motion, "segment": str(mp.segment[k]), "nfev": r.nfev,
                        "njev": r.njev, "doc_error": r.doc_error, "doc_measure": measure, "message": r.message,
                        "n_solutions": r.n_solutions, "branch": r.branch})
            times = [r.ik.solve_time_s for _, r in results]
            totals.append(float(np.sum(times)))
            w.write_message(REP_TOPIC, {
                "repetition": rep, "solve_time_s": times, "total_time_s": totals[-1],
                "position_error": [r.ik.position_error for _, r in results],
                "orientation_error": [r.ik.orientation_error for _, r in results],
                "success": [bool(r.ik.success) for _, r in results],
                "same_as_repetition_0": bool(np.array_equal(qs, first_q))})
            print(f"[{time.monotonic() - t_start:7.1f} s] {motion}/{method} repetition {rep + 1}/{reps}: "
                  f"{len(mp)} points, IK time {totals[-1]:.3f} s", file=log, flush=True)
    return {"points": len(mp), "repetitions": reps, "mean_total_s": float(np.mean(totals)),
            "successes": int(sum(r.ik.success for _, r in results))}
