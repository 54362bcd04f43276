"""Problem sets of the study -> MCAP archives (the archive is the source of truth for every table).

Archives (``results/erthal1992/runs/``):

* ``runs/catalogue.mcap`` — conversions (Stanford joint points -> DH, DH <-> PZ round trips) and the
  artropoidal jog FK (Tables 6.1-6.2); channel ``/erthal1992/catalogue``; no IK solves.
* IK solves (Tests 1, 2, 3, 5, 6, the SCARA path, the analytic PUMA) are problem sets solved by
  the generic rule: ``runs/<problem set>/<robot>__<solver label>.mcap`` (generators in
  :mod:`.problems`).
* ``../paths/<set>__<robot>.mcap`` and ``.RES`` — a path task's RES rows, written from its solve
  archive (:func:`write_path_rows`, no solving); channel ``/erthal1992/path``.

Settings angles are degrees (revolute joints) and lengths mm, converted here.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from pipeline.io.archive import ArchiveWriter, run_metadata
from pipeline.kinematics import fk_htm
from pipeline.robots import load_robot

from pipeline.studies.erthal1992.inputs import RunError, q_from_settings  # noqa: F401  (re-exported)
from pipeline.yamlio import load_yaml

PATH_TOPIC = "/erthal1992/path"
CATALOGUE_TOPIC = "/erthal1992/catalogue"
_OBJ = {"type": "object"}


def _meta(study_id: str, robot: str, solver: str, block: dict, seed="-") -> dict:
    return run_metadata(study=study_id, robot=robot, solver=solver, settings=block, seed=seed)


def write_path_rows(study, pset: str, robot: str, archive: Path, data_dir: Path, out: Path, res_out: Path | None) -> int:
    """The RES rows of one path task from its solve archive (no solving): rows archive + RES file.

    Joint interpolation: each segment's k rows divide the joint travel between the archived
    endpoint solutions equally; Cartesian interpolation: every row is an archived solution, a
    segment's first row the previous segment's last (see :func:`.problems.path_layout`).
    """
    from pipeline.io.archive import read_archive
    from pipeline.studies.erthal1992.problems import path_task
    from pipeline.studies.erthal1992.tasks import format_res, joint_points

    sets = study.problem_sets
    if pset not in sets or pset not in study.settings.get("paths", {}):
        raise RunError(f"{study.path}: field 'study_settings/paths/{pset}': no such path set (have: "
                       f"{', '.join(study.settings.get('paths', {}))})")
    params = sets[pset].get("params") or {}
    spec = study.settings["paths"][pset]
    task = path_task(params, data_dir, robot)
    interp = params.get("interpolation", "joint")
    arch = read_archive(archive)
    if arch.metadata.get("problem_set") != pset or arch.metadata.get("robot") != robot:
        raise RunError(f"{archive}: metadata says problem set {arch.metadata.get('problem_set')!r}, robot "
                       f"{arch.metadata.get('robot')!r}; expected {pset!r}, {robot!r}")
    sol = [np.asarray(r["q_solution"], dtype=float) for r in sorted(arch.solves, key=lambda r: r["problem_id"])]
    k = task.points_per_segment
    segs = []
    if interp == "joint":
        segs = [joint_points(sol[s], sol[s + 1], k) for s in range(task.segments)]
    else:
        segs = [np.array(sol[:k])]
        for s in range(1, task.segments):
            first = k + (s - 1) * (k - 1)
            segs.append(np.array([segs[-1][-1]] + sol[first:first + k - 1]))
    res_name = (spec.get("res_name") or {}).get(robot, robot.upper())
    meta = _meta(study.id, robot, arch.metadata.get("solver", "-"),
                 {"problem_set": pset, "params": params, "res_name": res_name, "source_archive": Path(archive).name})
    rows = []
    with ArchiveWriter(out, meta) as w:
        w.add_channel(PATH_TOPIC, {"title": "erthal1992.PathRow", **_OBJ})
        for s, seg_q in enumerate(segs):
            for j, qv in enumerate(seg_q):
                rows.append(qv)
                w.write_message(PATH_TOPIC, {"row": len(rows), "segment": s, "index": j,
                                             "q": [float(v) for v in qv], "interpolation": interp,
                                             "task": task.name, "res_name": res_name, "problem_set": pset,
                                             "robot": robot})
    if res_out is not None:
        prism = load_robot(Path(data_dir) / "robots" / f"{robot}.yaml").chain.prismatic
        Path(res_out).write_text(format_res(res_name, task.segments, k, np.array(rows), prism))
    return len(rows)


def run_catalogue(study, data_dir: Path, out: Path, report_dir: Path | None) -> int:
    """Conversions and FK checks of the catalogue (no IK): Stanford Figs 6.5-6.7, DH <-> PZ round
    trips of every robot, artropoidal Tables 6.1-6.2. Writes the TXT reports to ``report_dir``."""

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
            doc = load_yaml(Path(data_dir) / "erthal1992" / inp, "joint-point robot file")
            j = doc["joints"]
            e = doc["effector"]
            dh = dh_from_joint_points([x["type"] for x in j], [x["position"] for x in j], [x["axis"] for x in j],
                                      e["position"], e["u_a"], e["u_t"])
            pz = pz_from_dh(dh.chain(), dh.q0)
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
            pz = pz_from_dh(model.chain, q0)
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
