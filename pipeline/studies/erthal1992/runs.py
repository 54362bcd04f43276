"""Problem sets of the study -> MCAP archives (the archive is the source of truth for every table).

Archives (``results/erthal1992/runs/``):

* ``catalogue.mcap``   — conversions (Stanford joint points -> DH, DH <-> PZ round trips) and the
  artropoidal jog FK (Tables 6.1-6.2); channel ``/erthal1992/catalogue``; no IK solves.
* ``<test>.mcap``      — Tests 1, 2, 3, 6: one solve record per (goal, method variant); channel
  ``/erthal1992/problem`` says which test point, method, strategy, precision each problem is.
* ``path_<run>.mcap``  — a path task: one solve record per IK solve; channel ``/erthal1992/path``
  holds every RES row (id, segment, index, q); the RES file is written beside it.
* ``puma_analytic.mcap`` — analytic PUMA: 8 solve records per random reachable pose, channel
  ``/erthal1992/puma`` with the ARM/ELBOW/WRIST flags.

Settings angles are degrees (revolute joints) and lengths mm, converted here.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numpy as np

import pipeline
from pipeline.io.archive import FORMAT_VERSION, ArchiveWriter, solve_record
from pipeline.kinematics import fk_htm, quat_from_matrix
from pipeline.robots import RobotModel, load_robot
from pipeline.settings import git_commit

from pipeline.studies.erthal1992 import solvers
from pipeline.studies.erthal1992.tasks import frame

PROBLEM_TOPIC = "/erthal1992/problem"
PATH_TOPIC = "/erthal1992/path"
CATALOGUE_TOPIC = "/erthal1992/catalogue"
PUMA_TOPIC = "/erthal1992/puma"
_OBJ = {"type": "object"}


class RunError(ValueError):
    """A run cannot start (bad settings, unknown test/run name); one line."""


ROBOT_BASES_FILE = "robot_bases.yaml"  # data/erthal1992/: DH frame 0 in the document's robot base frame


def robot_base(data_dir: Path, name: str) -> list | None:
    """Position [mm] of ``name``'s DH frame 0 in the document's base frame (A4.2), or None if not listed."""
    import yaml

    path = Path(data_dir) / "erthal1992" / ROBOT_BASES_FILE
    if not path.exists():
        return None
    doc = yaml.safe_load(path.read_text()) or {}
    entry = doc.get(name)
    if entry is None:
        return None
    try:
        pos = [float(v) for v in entry["position"]]
    except (TypeError, KeyError, ValueError):
        raise RunError(f"{path}: field '{name}/position': expected 3 numbers [mm]") from None
    if len(pos) != 3:
        raise RunError(f"{path}: field '{name}/position': expected 3 numbers [mm]")
    return pos


def study_robot(data_dir: Path, name: str) -> RobotModel:
    """Catalogue robot placed as in the document's IK tests and tasks (``robot_bases.yaml``)."""
    from dataclasses import replace

    model = load_robot(Path(data_dir) / "robots" / f"{name}.yaml")
    pos = robot_base(data_dir, name)
    if pos is None:
        return model
    B = np.eye(4)
    B[:3, 3] = pos
    return replace(model, chain=replace(model.chain, base=B @ np.asarray(model.chain.base)))


def q_from_settings(model: RobotModel, values) -> np.ndarray:
    """Joint values from settings: degrees for revolute joints, length for prismatic."""
    v = np.array(values, dtype=float)
    if v.shape != (model.n,):
        raise RunError(f"{model.name}: expected {model.n} joint values, got {list(values)}")
    return np.where(model.chain.prismatic, v, np.radians(v))


def goal_frame(g: dict) -> np.ndarray:
    """Goal pose from {p, u_a, u_t} (z = u_a, y = u_t; A5.1-A5.6) or {p} only (position)."""
    p = np.zeros(3)
    p[: len(g["p"])] = g["p"]
    if "u_a" in g:
        return frame(g["u_t"], g["u_a"], p)
    T = np.eye(4)
    T[:3, 3] = p
    return T


def _meta(study_id: str, robot: str, solver: str, block: dict, seed="-") -> dict:
    blob = json.dumps(block, sort_keys=True)
    return {"format_version": FORMAT_VERSION, "study": study_id, "robot": robot, "solver": solver,
            "settings": blob, "settings_hash": hashlib.sha256(blob.encode()).hexdigest()[:16],
            "seed": str(seed), "package_version": pipeline.__version__, "git_commit": git_commit()}


def _expand(methods: list[dict]) -> list[dict]:
    """Method variants: a list under ``precisions`` or ``strategies`` gives one variant per value."""
    out = []
    for m in methods:
        if "precisions" in m:
            out += [{**{k: v for k, v in m.items() if k != "precisions"}, "precision": p} for p in m["precisions"]]
        elif "strategies" in m:
            out += [{**{k: v for k, v in m.items() if k != "strategies"}, "strategy": s} for s in m["strategies"]]
        else:
            out.append(dict(m))
    return out


def run_solver(model: RobotModel, T_goal: np.ndarray, q0: np.ndarray, m: dict, position_only: bool):
    kind = m["method"]
    if kind == "zp":
        return solvers.zp_solve(model, T_goal, q0, int(m.get("strategy", 5)), float(m["precision"]),
                                int(m["max_iterations"]), use_orientation=not position_only)
    if kind == "nr":
        return solvers.nr_solve(model, T_goal, q0, float(m["precision"]), int(m["max_iterations"]),
                                int(m.get("step_halvings", 10)))
    if kind == "geometric":
        return solvers.geometric_planar_solve(model, T_goal[:2, 3], q0, float(m["precision"]),
                                              int(m["max_iterations"]))
    raise RunError(f"unknown method {kind!r} (allowed: zp, nr, geometric)")


def run_test(study, test: str, data_dir: Path, out: Path) -> int:
    """Solve every (goal, method variant) of ``study_settings.tests.<test>``; returns the solve count."""
    tests = study.settings.get("tests", {})
    if test not in tests:
        raise RunError(f"{study.path}: field 'study_settings/tests/{test}': no such test (have: {', '.join(tests)})")
    block = tests[test]
    model = study_robot(data_dir, block["robot"])
    q_start = q_from_settings(model, block["q_start"])
    position_only = bool(block.get("position_only", False))
    variants = _expand(block["methods"])
    meta = _meta(study.id, model.name, "mixed", {**block, "robot_base": robot_base(data_dir, block["robot"])})
    pid = 0
    with ArchiveWriter(out, meta) as w:
        w.add_channel(PROBLEM_TOPIC, {"title": "erthal1992.Problem", **_OBJ})
        for m in variants:
            prev = None
            for g in block["goals"]:
                Tg = goal_frame(g)
                q0 = prev if (m.get("start") == "previous" and prev is not None) else q_start
                res = run_solver(model, Tg, q0, m, position_only)
                prev = res.q
                label = m["name"] + (f"_s{m['strategy']}" if "strategy" in m and m["method"] == "zp" else "")
                rec, tr = solve_record(pid, model.name, label, model.length_unit, q0, Tg[:3, 3],
                                       quat_from_matrix(Tg), res)
                w.write(rec, tr)
                w.write_message(PROBLEM_TOPIC, {"problem_id": pid, "test": test, "point": int(g["point"]),
                                                "variant": m["name"], "method": m["method"],
                                                "strategy": m.get("strategy"), "precision": m["precision"],
                                                "max_iterations": m["max_iterations"], "solver": label})
                pid += 1
    return pid


def run_path(study, run: str, data_dir: Path, out: Path, res_out: Path | None) -> int:
    """Solve one path run of ``study_settings.paths``; write the archive and the RES file."""
    from pipeline.studies.erthal1992.tasks import cartesian_points, format_res, joint_points, load_task

    paths = study.settings.get("paths", {})
    if run not in paths:
        raise RunError(f"{study.path}: field 'study_settings/paths/{run}': no such run (have: {', '.join(paths)})")
    spec = paths[run]
    overrides = {}
    task = load_task(Path(data_dir) / "erthal1992" / spec["task"])
    robot = spec.get("robot", task.robot)
    model = study_robot(data_dir, robot)
    if "auxiliary_position" in spec:
        T_aux = task.T_aux.copy()
        T_aux[:3, 3] = spec["auxiliary_position"]
        overrides["T_aux"] = T_aux
    q = q_from_settings(model, spec["initial_position"]) if "initial_position" in spec else task.q_start
    if len(q) != model.n:
        raise RunError(f"{study.path}: paths/{run}: initial position has {len(q)} values, {model.name} has {model.n} joints")
    if overrides:
        from dataclasses import replace

        task = replace(task, **overrides)
    m = {"method": "zp", "strategy": spec["strategy"], "precision": spec["precision"],
         "max_iterations": spec["max_iterations"]}
    k = task.points_per_segment
    interp = spec["interpolation"]
    meta = _meta(study.id, model.name, f"zp_s{spec['strategy']}",
                 {**spec, "task_name": task.name, "robot_base": robot_base(data_dir, robot)})
    rows = []
    pid = 0
    with ArchiveWriter(out, meta) as w:
        w.add_channel(PATH_TOPIC, {"title": "erthal1992.PathRow", **_OBJ})

        def solve(T_aux_point, q0):
            nonlocal pid
            Tg = task.goal_in_base(T_aux_point)
            res = run_solver(model, Tg, q0, m, False)
            rec, tr = solve_record(pid, model.name, f"zp_s{spec['strategy']}", model.length_unit, q0, Tg[:3, 3],
                                   quat_from_matrix(Tg), res)
            w.write(rec, tr)
            pid += 1
            return res

        q_end = q
        for s in range(task.segments):
            if interp == "joint":
                r0 = solve(task.points[s], q_end) if s == 0 else None
                q_a = r0.q if r0 is not None else q_end
                r1 = solve(task.points[s + 1], q_a)
                seg_q = joint_points(q_a, r1.q, k)
                q_end = r1.q
            else:
                seg_q = []
                qq = q_end
                for j, Tp in enumerate(cartesian_points(task.points[s], task.points[s + 1], k)):
                    if s > 0 and j == 0:
                        seg_q.append(qq)  # the segment start is the previous end (already solved)
                        continue
                    qq = solve(Tp, qq).q
                    seg_q.append(qq)
                seg_q = np.array(seg_q)
                q_end = seg_q[-1]
            for j, qv in enumerate(seg_q):
                rows.append(qv)
                w.write_message(PATH_TOPIC, {"row": len(rows), "segment": s, "index": j,
                                             "q": [float(v) for v in qv], "interpolation": interp,
                                             "task": task.name, "res_name": spec.get("res_name", run)})
    if res_out is not None:
        Path(res_out).write_text(format_res(spec.get("res_name", task.name), task.segments, k, np.array(rows),
                                            model.chain.prismatic))
    return pid


def run_puma_analytic(study, count: int, seed: int, data_dir: Path, out: Path) -> int:
    """Random reachable PUMA poses (FK of uniform random joints), all 8 analytic solutions each."""
    from pipeline.studies.erthal1992.puma import puma_ik_all

    model = load_robot(Path(data_dir) / "robots" / "puma560.yaml")
    rng = np.random.default_rng(seed)
    block = {**study.settings.get("puma_analytic", {}), "count": count}
    meta = _meta(study.id, model.name, "puma_analytic", block, seed)
    pid = 0
    with ArchiveWriter(out, meta) as w:
        w.add_channel(PUMA_TOPIC, {"title": "erthal1992.PumaSolution", **_OBJ})
        for pose in range(count):
            q_true = rng.uniform(-math.pi, math.pi, 6)
            Tg = fk_htm(model.chain, q_true)
            for sol in puma_ik_all(model, Tg):
                rec, tr = solve_record(pid, model.name, "puma_analytic", model.length_unit, q_true, Tg[:3, 3],
                                       quat_from_matrix(Tg), sol.result)
                w.write(rec, tr)
                w.write_message(PUMA_TOPIC, {"problem_id": pid, "pose": pose, "arm": sol.arm, "elbow": sol.elbow,
                                             "wrist": sol.wrist, "degenerate_wrist": sol.degenerate})
                pid += 1
    return pid


def run_catalogue(study, data_dir: Path, out: Path, report_dir: Path | None) -> int:
    """Conversions and FK checks of the catalogue (no IK): Stanford Figs 6.5-6.7, DH <-> PZ round
    trips of every robot, artropoidal Tables 6.1-6.2. Writes the TXT reports to ``report_dir``."""
    import yaml

    from pipeline.studies.erthal1992.model import (dh_from_joint_points, dh_from_pz, dh_model_from_chain, pz_fk,
                                                   pz_from_dh, report_txt)

    st = study.settings
    meta = _meta(study.id, "-", "-", {k: st[k] for k in ("zero_positions", "joint_point_inputs", "jog", "workspace") if k in st})
    n_rec = 0
    if report_dir is not None:
        Path(report_dir).mkdir(parents=True, exist_ok=True)
    with ArchiveWriter(out, meta) as w:
        w.add_channel(CATALOGUE_TOPIC, {"title": "erthal1992.Catalogue", **_OBJ})
        for inp in st.get("joint_point_inputs", []):
            doc = yaml.safe_load((Path(data_dir) / "erthal1992" / inp).read_text())
            j = doc["joints"]
            e = doc["effector"]
            dh = dh_from_joint_points([x["type"] for x in j], [x["position"] for x in j], [x["axis"] for x in j],
                                      e["position"], e["u_a"], e["u_t"])
            pz = pz_from_dh(dh.chain(), dh.types, dh.q0)
            w.write_message(CATALOGUE_TOPIC, {"kind": "joint_points", "robot": doc["name"],
                                              "origins": dh.origins.tolist(), "x_axes": dh.x_axes.tolist(),
                                              "dh": {"a": dh.a.tolist(), "alpha": dh.alpha.tolist(),
                                                     "d": dh.d.tolist(), "theta": dh.theta.tolist()}})
            n_rec += 1
            if report_dir is not None:
                Path(report_dir, f"{doc['name'].upper()}_from_joint_points.TXT").write_text(
                    report_txt(doc["name"], dh, pz, [x["position"] for x in j], [x["axis"] for x in j]))
        rng = np.random.default_rng(int(st.get("roundtrip_seed", 0)))
        for name, q0_set in st.get("zero_positions", {}).items():
            model = load_robot(Path(data_dir) / "robots" / f"{name}.yaml")
            q0 = q_from_settings(model, q0_set)
            types = ["p" if p else "r" for p in model.chain.prismatic]
            pz = pz_from_dh(model.chain, types, q0)
            dh2 = dh_from_pz(pz)
            dq = rng.uniform(-1.0, 1.0, (int(st.get("roundtrip_samples", 20)), model.n))
            T_ref = fk_htm(model.chain, q0 + dq)
            err_pz = max(float(np.abs(pz_fk(pz, q0 + d) - T).max()) for d, T in zip(dq, T_ref))
            err_dh = float(np.abs(fk_htm(dh2.chain(), dh2.q0 + dq) - T_ref).max())
            w.write_message(CATALOGUE_TOPIC, {"kind": "roundtrip", "robot": name, "samples": len(dq),
                                              "max_abs_pz_fk_minus_dh_fk": err_pz,
                                              "max_abs_dh_pz_dh_fk_diff": err_dh,
                                              "pz_b": pz.b.tolist(), "pz_u": pz.u.tolist()})
            n_rec += 1
            if report_dir is not None:
                dh = dh_model_from_chain(model.chain, types, q0)
                Path(report_dir, f"{name.upper()}.TXT").write_text(report_txt(name, dh, pz, limits=model.limits))
        ws = st.get("workspace")
        if ws:
            from pipeline.studies.erthal1992.drawing import hull_measure, planar3r_workspaces, sample_workspace

            wrng = np.random.default_rng(int(ws["seed"]))
            for name in st.get("zero_positions", {}):
                model = load_robot(Path(data_dir) / "robots" / f"{name}.yaml")
                lim = model.limits.copy()
                for i in range(model.n):
                    if not np.all(np.isfinite(lim[i])):
                        lim[i] = ws.get("prismatic_range", {}).get(name, [0.0, 1000.0]) if model.chain.prismatic[i] \
                            else [-math.pi, math.pi]
                pts = sample_workspace(model.chain, lim, int(ws["samples"]), wrng)
                planar = bool(np.allclose(model.chain.alpha, 0) and np.allclose(pts[:, 2], pts[0, 2]))
                rec = {"kind": "workspace", "robot": name, "samples": len(pts), "planar": planar,
                       "hull": hull_measure(pts, planar), "sampling_limits": lim.tolist(),
                       "points": pts[: int(ws.get("plot_points", 1500))].tolist()}
                if name == "planar3r":
                    pw = planar3r_workspaces(model.chain.a, int(ws.get("grid", 600)), int(ws.get("orientations", 360)))
                    rec.update({"primary_area": pw["primary_area"], "secondary_area": pw["secondary_area"],
                                "radii": pw["r"].tolist(), "primary": pw["primary"].tolist(),
                                "secondary": pw["secondary"].tolist()})
                w.write_message(CATALOGUE_TOPIC, rec)
                n_rec += 1
        for jog in st.get("jog", []):
            model = load_robot(Path(data_dir) / "robots" / f"{jog['robot']}.yaml")
            q = q_from_settings(model, jog["q"])
            T = fk_htm(model.chain, q)
            w.write_message(CATALOGUE_TOPIC, {"kind": "jog", "robot": jog["robot"], "table": jog["table"],
                                              "q": q.tolist(), "T": T.tolist()})
            n_rec += 1
    return n_rec
