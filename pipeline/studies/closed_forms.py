"""Closed forms for every 6R and 7R arm, computed from the archives alone.

Tables
    ``coverage`` — one row per robot: the family the geometric closed form found (archived in its
    solves' ``info``), its success and solutions per goal, and EAIK's, IK-Geo's and TRAC-IK's on
    the same goals.
    ``methods`` — one row per (robot, solver label): goals, success, solutions per goal, median and
    95th-percentile solve and call time, p99 errors of the successes.
    ``seven_dof`` — the 7R arms: ours against TRAC-IK on the goals both ran (success, median call
    time, their ratio).
    ``not_applicable`` — every (robot, solver) pair skipped, with the solver's one-line reason.
Figures
    ``call_time`` — median call time per robot and label (log scale).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from pipeline.studies.specs import FigureSpec, TableSpec
from pipeline.studies.arm_answer import percentile
from pipeline.studies.arm_benchmark import refusal_table
from pipeline.studies.common import library_label
from pipeline.studies.generic import runs_frame

OURS = "analytic"


def _nsol(info) -> float:
    """FK-verified solutions of one solve, wherever they lie: a peer under ``require_limits`` lists only
    those within the limits and counts all in ``n_fk_valid``, the exact ones (not flagged
    least-squares by the library) in ``n_fk_valid_exact``; ours lists all (6R), every one exact."""
    if isinstance(info, dict):
        v = info.get("n_fk_valid_exact", info.get("n_fk_valid", info.get("n_solutions", info.get("solutions_valid"))))
        return float(v) if v is not None else float("nan")
    return float("nan")


def _mean_nsol(infos) -> float:
    """Mean solutions per goal over the records' ``info`` (NaN when none reports a count)."""
    x = np.array([_nsol(i) for i in infos], dtype=float)
    x = x[np.isfinite(x)]
    return float(x.mean()) if x.size else float("nan")


def _family(g: pd.DataFrame) -> str:
    fams = {i.get("family") for i in g["info"] if isinstance(i, dict) and i.get("family")}
    return ", ".join(sorted(fams)) if fams else ""


def method_table(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (robot, label), g in df.groupby(["robot", "solver"], sort=False):
        ok = g[g["success"].astype(bool)]
        rows.append({
            "robot": robot, "solver": label,
            "library": library_label(g["library"].iloc[0],
                                     g["library_version"].iloc[0] if "library_version" in g else ""),
            "goals": len(g), "success [%]": 100 * g["success"].astype(bool).mean(),
            "solutions per goal": _mean_nsol(g["info"]),
            "solve time p50 [µs]": 1e6 * percentile(g["solve_time_s"], 50),
            "solve time p95 [µs]": 1e6 * percentile(g["solve_time_s"], 95),
            "call time p50 [µs]": 1e6 * percentile(g["call_time_s"], 50),
            "position error p99, successes [mm]": percentile(ok["position_error_mm"], 99),
            "orientation error p99, successes [rad]": percentile(ok["orientation_error"], 99),
        })
    return pd.DataFrame(rows)


def coverage(df: pd.DataFrame) -> pd.DataFrame:
    """Per robot: ours and each peer on the goals both ran (problem ids in common)."""
    rows = []
    for robot, g in df.groupby("robot", sort=False):
        ours = g[g["solver"] == OURS]
        row = {"robot": robot, "family (ours)": _family(ours), "goals": len(ours),
               "ours success [%]": 100 * ours["success"].astype(bool).mean() if len(ours) else float("nan"),
               "ours solutions per goal": _mean_nsol(ours["info"]),
               "ours call time p50 [µs]": 1e6 * percentile(ours["call_time_s"], 50)}
        for peer in ("eaik", "ik_geo", "trac_ik"):
            pg = g[g["solver"] == peer]
            common = set(pg["problem_id"]) & set(ours["problem_id"])
            if not common:
                row[f"{peer} success [%]"] = row[f"{peer} solutions per goal"] = float("nan")
                row[f"{peer} call time p50 [µs]"] = float("nan")
                continue
            p = pg[pg["problem_id"].isin(common)]
            row[f"{peer} success [%]"] = 100 * p["success"].astype(bool).mean()
            row[f"{peer} solutions per goal"] = _mean_nsol(p["info"]) if peer != "trac_ik" else float("nan")
            row[f"{peer} call time p50 [µs]"] = 1e6 * percentile(p["call_time_s"], 50)
        rows.append(row)
    return pd.DataFrame(rows)


def seven_dof(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for robot, g in df.groupby("robot", sort=False):
        ours, tr = g[g["solver"] == OURS], g[g["solver"] == "trac_ik"]
        if ours.empty or tr.empty or len(ours["q_solution"].iloc[0]) != 7:
            continue
        common = set(ours["problem_id"]) & set(tr["problem_id"])
        o, t = ours[ours["problem_id"].isin(common)], tr[tr["problem_id"].isin(common)]
        co, ct = 1e6 * percentile(o["call_time_s"], 50), 1e6 * percentile(t["call_time_s"], 50)
        rows.append({"robot": robot, "family (ours)": _family(o), "goals": len(common),
                     "ours success [%]": 100 * o["success"].astype(bool).mean(),
                     "trac_ik success [%]": 100 * t["success"].astype(bool).mean(),
                     "ours call time p50 [µs]": co, "trac_ik call time p50 [µs]": ct,
                     "trac_ik / ours call time [x]": ct / co if co > 0 else float("nan")})
    return pd.DataFrame(rows)


def build_tables(study, archives, published_dir: Path) -> list[TableSpec]:
    df = runs_frame(archives)
    refused = refusal_table(study)
    if df.empty:
        return [TableSpec("coverage", "Coverage", pd.DataFrame(), "No solve records in the archives.")]
    return [
        TableSpec("coverage", "Closed forms per arm: ours beside EAIK, IK-Geo and TRAC-IK (same goals)", coverage(df),
                  "Cold goals: FK of joint angles uniform within the limits, so every goal has a solution within the "
                  "limits. Success = within 0.1 mm and 1e-3 rad by an independent FK and within the joint limits. "
                  "Solutions per goal = the FK-verified solutions the method returns (ours on a 7R arm: at most "
                  "max_solutions = 16 of its sweep). A peer's columns are read on the goals it ran in common with "
                  "ours (TRAC-IK: the first 300); blank: the peer does not apply to the arm (see not_applicable). "
                  "Call time = the whole pipeline.solvers.solve() call; a peer's solve time is its library call."),
        TableSpec("methods", "Every label on every arm", method_table(df),
                  "Solve time: ours = the method's computation, peers = the whole library call; call time = the "
                  "whole pipeline.solvers.solve() call for both. Errors: 99th percentile over the successes."),
        TableSpec("seven_dof", "7R arms through a free joint, against TRAC-IK on the same goals", seven_dof(df),
                  "Ours: one joint swept over its limits (49 values, the start's first), the other six by their "
                  "closed form, the solutions within the limits nearest to the start first. TRAC-IK at its default "
                  "5 ms budget (wall time of two threads; its results depend on the machine's load)."),
        TableSpec("not_applicable", "Solver and robot pairs skipped, and why", refused,
                  "Each refusal is the solver's own line: the geometry it needs and what the arm's joint axes give."),
    ]


def build_figures(study, archives, out_dir: Path) -> list[FigureSpec]:
    from pipeline.report.plotting import plt, save

    df = runs_frame(archives)
    if df.empty:
        return []
    mt = method_table(df)
    H = mt.pivot_table(index="robot", columns="solver", values="call time p50 [µs]", sort=False)
    fig, ax = plt.subplots(figsize=(11, 5.5))
    x = np.arange(H.shape[0])
    w = 0.8 / max(1, H.shape[1])
    for k, col in enumerate(H.columns):
        ax.bar(x + (k - (H.shape[1] - 1) / 2) * w, H[col].to_numpy(dtype=float), width=w, label=col)
    ax.set_yscale("log")
    ax.set_xticks(x, H.index, rotation=60, ha="right", fontsize=8)
    ax.set_ylabel("median call time [µs] (log)")
    ax.legend(fontsize=8, ncol=4, frameon=False)
    ax.set_title("Closed forms and TRAC-IK: median call time per arm (missing bar: does not apply)")
    fig.tight_layout()
    return [FigureSpec(save(fig, out_dir, "call_time"), "Median call time per arm and method",
                       "Median of the whole pipeline.solvers.solve() call over the cold goals each label ran.")]
