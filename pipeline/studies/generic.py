"""Tables and figures for any study, computed from its archives alone.

Used for a study written only in YAML (no ``pipeline/studies/<id>`` module), and available to any
study that wants the same summary. One row per (problem set, robot, solver label): success,
joint-limit compliance, stop reasons, iterations, solve-time and call-time percentiles, position and
orientation error percentiles. Errors are converted to mm whatever the archive's working unit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from pipeline.io.archive import Archive
from pipeline.robots import LENGTH_UNITS
from pipeline.solvers import STOP_REASONS
from pipeline.studies.specs import FigureSpec, TableSpec
from pipeline.studies.common import solves_frame


def runs_frame(archives: list[Archive]) -> pd.DataFrame:
    """Every solve record (:func:`~pipeline.studies.common.solves_frame`) with ``problem_set`` and the
    position error in mm (``position_error_mm``) whatever the archive's working unit."""
    archives = [a for a in archives if a.solves]
    if not archives:
        return pd.DataFrame(columns=["problem_set", "robot", "solver", "method", "success"])
    df = solves_frame(archives)
    df["problem_set"] = df["archive"].map({str(a.path): a.metadata.get("problem_set", "") for a in archives})
    df["position_error_mm"] = df["position_error"].astype(float) * df["length_unit"].map(LENGTH_UNITS) * 1e3
    return df


SAMPLE_COLUMNS = {  # per-sample file column -> its meaning (docs/archives.md "Per-sample data" lists them)
    "study": "study id", "robot": "robot name", "problem_set": "problem set", "solver": "solver label",
    "method": "registered method", "library": "ours or the peer library's package", "problem_id": "goal id in the "
    "problem file", "repetition": "repetition (timing runs)", "success": "FK-verified success (within limits where "
    "required)", "claimed_success": "the method's own claim", "within_limits": "returned angles within the limits",
    "stop_reason": "pipeline.solvers.StopReason code", "iterations": "iterations", "position_error_mm":
    "position error [mm]", "orientation_error_rad": "orientation error [rad]", "solve_time_us": "the method's own "
    "computation [µs]", "call_time_us": "wall time of the whole solve() call [µs]", "cpu_time_us": "CPU time of "
    "the call (the calling thread's; the process's for TRAC-IK) [µs]", "joint_distance_rad": "|q_solution - q_start|, differences wrapped by 2 pi [rad] (joint_distance)"}


def joint_distance(q_solution, q_start) -> np.ndarray:
    """Per solve: the Euclidean norm of ``q_solution - q_start`` over the joints, each difference
    wrapped into [-π, π) so that a 2π turn is no distance (every catalogue arm is all revolute);
    NaN where the two have different lengths. Arguments: sequences of joint vectors (N,)."""
    q, q0 = list(q_solution), list(q_start)
    out = np.full(len(q), np.nan)
    n, n0 = np.array([len(a) for a in q]), np.array([len(b) for b in q0])
    for k in np.unique(n):
        rows = np.flatnonzero((n == k) & (n0 == k))
        if rows.size:
            d = (np.array([q[i] for i in rows], float) - np.array([q0[i] for i in rows], float) + np.pi) \
                % (2 * np.pi) - np.pi
            out[rows] = np.sqrt((d * d).sum(axis=1))
    return out


def samples_frame(study_id: str, archives: list[Archive]) -> pd.DataFrame:
    """Every solve of a study as one row of :data:`SAMPLE_COLUMNS` (the per-sample file)."""
    df = runs_frame(archives)
    if df.empty:
        return pd.DataFrame(columns=list(SAMPLE_COLUMNS))
    dist = joint_distance(df["q_solution"], df["q_start"])
    out = pd.DataFrame({
        "study": study_id, "robot": df["robot"], "problem_set": df["problem_set"], "solver": df["solver"],
        "method": df["method"], "library": df.get("library", "ours"), "problem_id": df["problem_id"],
        "repetition": df["repetition"], "success": df["success"].astype(bool),
        "claimed_success": df["claimed_success"].astype(bool), "within_limits": df["within_limits"].astype(bool),
        "stop_reason": df["stop_reason"], "iterations": df["iterations"],
        "position_error_mm": df["position_error_mm"], "orientation_error_rad": df["orientation_error"],
        "solve_time_us": 1e6 * df["solve_time_s"].astype(float), "call_time_us": 1e6 * df["call_time_s"].astype(float),
        "cpu_time_us": 1e6 * df.get("cpu_time_s", pd.Series(np.nan, index=df.index)).astype(float),
        "joint_distance_rad": dist})
    return out[list(SAMPLE_COLUMNS)]


def _pct(x, q) -> float:
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    return float(np.percentile(x, q)) if x.size else float("nan")


def summary_table(df: pd.DataFrame) -> pd.DataFrame:
    """One row per (problem set, robot, solver): the generic benchmark summary (units in headers)."""
    rows = []
    for (pset, robot, solver), g in df.groupby(["problem_set", "robot", "solver"], sort=False):
        ok = g[g["success"]]
        within = g["within_limits"] if "within_limits" in g else pd.Series(True, index=g.index)
        rows.append({
            "problem set": pset, "robot": robot, "solver": solver, "method": g["method"].iloc[0],
            "solves": len(g), "success [%]": 100 * g["success"].mean(),
            "success within joint limits [%]": 100 * (g["success"] & within.astype(bool)).mean(),
            "mean iterations (successes)": ok["iterations"].mean() if len(ok) else np.nan,
            "solve time p50 [µs]": 1e6 * _pct(g["solve_time_s"], 50),
            "solve time p95 [µs]": 1e6 * _pct(g["solve_time_s"], 95),
            "solve time p99 [µs]": 1e6 * _pct(g["solve_time_s"], 99),
            "call time p50 [µs]": 1e6 * _pct(g.get("call_time_s", np.nan), 50),
            "position error p50 [mm]": _pct(g["position_error_mm"], 50),
            "position error p95 [mm]": _pct(g["position_error_mm"], 95),
            "orientation error p50 [rad]": _pct(g["orientation_error"], 50),
            "orientation error p95 [rad]": _pct(g["orientation_error"], 95),
        })
    return pd.DataFrame(rows)


def stop_table(df: pd.DataFrame) -> pd.DataFrame:
    """Count of each stop reason per (problem set, robot, solver)."""
    rows = []
    for (pset, robot, solver), g in df.groupby(["problem_set", "robot", "solver"], sort=False):
        row = {"problem set": pset, "robot": robot, "solver": solver}
        counts = g["stop_reason"].value_counts()
        for code, text in STOP_REASONS.items():
            row[f"{code}: {text} [count]"] = int(counts.get(code, 0))
        rows.append(row)
    return pd.DataFrame(rows)


def build_tables(study, archives, published_dir: Path) -> list[TableSpec]:
    df = runs_frame(archives)
    if df.empty:
        return [TableSpec("summary", "Summary", pd.DataFrame(), "No solve records in the archives.")]
    return [
        TableSpec("summary", "Per robot and solver: success, limits, iterations, times, errors", summary_table(df),
                  "Success = the method's stop test passed and an independent FK of the returned angles confirmed "
                  "it. Solve time = the method's own computation (monotonic clock); call time = the whole "
                  "pipeline.solvers.solve() call (pipeline/solvers/core/timing.py). Percentiles over all solves."),
        TableSpec("stop_reasons", "Stop reasons per robot and solver", stop_table(df),
                  "pipeline.solvers.StopReason; 6 = the method claimed success but FK disagreed."),
    ]


def build_figures(study, archives, out_dir: Path) -> list[FigureSpec]:
    from pipeline.report.plotting import plt, save

    df = runs_frame(archives)
    figs = []
    if df.empty:
        return figs
    for pset, g in df.groupby("problem_set", sort=False):
        robots = list(dict.fromkeys(g["robot"]))
        solvers = list(dict.fromkeys(g["solver"]))
        fig, axes = plt.subplots(1, 2, figsize=(11, 0.35 * len(solvers) * len(robots) + 2.0))
        labels, succ, times = [], [], []
        for r in robots:
            for s in solvers:
                h = g[(g["robot"] == r) & (g["solver"] == s)]
                if len(h):
                    labels.append(f"{r} / {s}")
                    succ.append(100 * h["success"].mean())
                    t = 1e6 * h["solve_time_s"].to_numpy(dtype=float)
                    times.append(t[np.isfinite(t) & (t > 0)])
        y = np.arange(len(labels))
        axes[0].barh(y, succ, color="tab:blue")
        axes[0].set_yticks(y, labels)
        axes[0].invert_yaxis()
        axes[0].set_xlabel("FK-verified success [%]")
        axes[0].set_xlim(0, 100)
        axes[1].boxplot([t if t.size else [np.nan] for t in times], vert=False, showfliers=False)
        axes[1].set_yticks(y + 1, [""] * len(labels))
        axes[1].invert_yaxis()
        axes[1].set_xscale("log")
        axes[1].set_xlabel("solve time [µs] (log scale; whiskers 1.5 IQR, outliers hidden)")
        fig.suptitle(f"{study.id}: problem set {pset}")
        files = save(fig, out_dir, f"summary_{pset}")
        figs.append(FigureSpec(files, f"Success and solve time per robot and solver — problem set {pset}",
                               "Left: share of problems with an FK-verified success. Right: distribution of the "
                               "per-solve time (the method's own computation)."))
    return figs
