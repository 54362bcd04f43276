"""Which IK method for your arm: every registered method (ours and the peer libraries) on every
catalogue arm, cold and warm starts, computed from the archives alone.

Tables
    ``answer`` — one sentence per robot and problem set: the method that solves the most goals and
    the fastest among those within 1 percentage point of it (median solve time).
    ``robot_<name>`` — one table per robot: per solver label and problem set, success, returned
    solutions within the limits, median and p95 solve time, median iterations, p99 position and
    orientation error of the successes.
    ``heatmap`` — the robots x methods success rates behind the heat map.
    ``not_applicable`` — every (robot, solver) pair the study skipped, with the solver's reason.
Figures
    ``heatmap_<set>`` — success rate, robots x solver labels; ``tradeoff_<robot>`` — success versus
    median solve time, one point per method (ours circles, peers squares; cold filled, warm open).

A solver label's *search* is "single" or "restarts (<= N)" from its archived settings; the peers'
time is their whole library call, ours the method's own computation (the archive's ``timing``
metadata); call time (the whole ``pipeline.solvers.solve`` call, FK check included) is shown for both.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from pipeline.studies import FigureSpec, TableSpec
from pipeline.studies.generic import runs_frame

PEERS = ("rtb_ik_lm", "rtb_ik_nr", "rtb_ik_gn", "trac_ik", "pinocchio_clik", "ur_analytic_ik", "eaik", "ik_geo")
CLOSE_PP = 1.0  # "within 1 percentage point" of the best success rate
MIN_SHARE = 0.1  # labels run on at least this share of a set's goals compete for the answer


def _p(x, q) -> float:
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    return float(np.percentile(x, q)) if x.size else float("nan")


def _labels_meta(archives) -> dict:
    """Solver label -> (method, search) from the archives' settings."""
    out = {}
    for a in archives:
        s = json.loads(a.metadata["settings"])
        r = int(s.get("restarts", 0) or 0)
        out[a.metadata["solver"]] = (s.get("method", a.metadata["solver"]), f"restarts (<= {r})" if r else "single")
    return out


def method_table(df: pd.DataFrame, meta: dict) -> pd.DataFrame:
    """One row per (robot, problem set, solver label)."""
    rows = []
    for (robot, pset, label), g in df.groupby(["robot", "problem_set", "solver"], sort=False):
        method, search = meta.get(label, (g["method"].iloc[0], "single"))
        ok = g[g["success"].astype(bool)]
        rows.append({
            "robot": robot, "problem set": pset, "solver": label, "method": method,
            "library": "peer" if method in PEERS else "ours", "search": search, "problems": len(g),
            "success [%]": 100 * g["success"].astype(bool).mean(),
            "within limits [%]": 100 * g["within_limits"].astype(bool).mean(),
            "solve time p50 [µs]": 1e6 * _p(g["solve_time_s"], 50),
            "solve time p95 [µs]": 1e6 * _p(g["solve_time_s"], 95),
            "call time p50 [µs]": 1e6 * _p(g["call_time_s"], 50),
            "iterations p50": _p(g["iterations"], 50),
            "position error p99, successes [mm]": _p(ok["position_error_mm"], 99),
            "orientation error p99, successes [rad]": _p(ok["orientation_error"], 99),
        })
    return pd.DataFrame(rows)


def answers(mt: pd.DataFrame) -> pd.DataFrame:
    """Per (robot, problem set), among the labels run on at least ``MIN_SHARE`` of the goals: the one
    that solves the most goals (ties: faster) and the fastest label within 1 percentage point of it, both by median *call* time (the
    whole ``solve()`` call, the one time measured the same way for our methods and the peers)."""
    rows = []
    for (robot, pset), g in mt.groupby(["robot", "problem set"], sort=False):
        g = g[g["problems"] >= MIN_SHARE * g["problems"].max()]  # not the slow labels capped to a few goals
        g = g.sort_values(["success [%]", "problems", "call time p50 [µs]"],
                                             ascending=[False, False, True])
        top = g.iloc[0]
        near = g[g["success [%]"] >= top["success [%]"] - CLOSE_PP].sort_values("call time p50 [µs]")
        fast = near.iloc[0]
        text = (f"{robot}, {pset} starts: {top['solver']} solves the most goals ({top['success [%]']:.1f} % of "
                f"{int(top['problems'])}); the fastest within {CLOSE_PP:g} point of it is {fast['solver']} "
                f"({fast['success [%]']:.1f} % of {int(fast['problems'])}, median {fast['call time p50 [µs]']:.0f} µs "
                f"per call).")
        rows.append({"robot": robot, "problem set": pset, "most goals": top["solver"],
                     "success [%]": top["success [%]"], "goals": int(top["problems"]),
                     "fastest within 1 point": fast["solver"], "its success [%]": fast["success [%]"],
                     "its call time p50 [µs]": fast["call time p50 [µs]"], "answer": text})
    return pd.DataFrame(rows)


def _refusals(study) -> pd.DataFrame:
    from pipeline.robots import load_robot
    from pipeline.settings import refusals

    robots_dir = Path(study.path).parent.parent / "robots"
    names = sorted({r for ps in study.problem_sets for r in study.set_robots(ps)})
    models = {r: load_robot(robots_dir / f"{r}.yaml") for r in names}
    rows = {}
    for (pset, robot, label), why in refusals(study, models).items():
        rows.setdefault((robot, label), {"robot": robot, "solver": label, "method": study.solvers[label].method,
                                         "problem sets": [], "why it does not apply": why})["problem sets"].append(pset)
    out = pd.DataFrame(list(rows.values()), columns=["robot", "solver", "method", "problem sets", "why it does not apply"])
    out["problem sets"] = out["problem sets"].map(", ".join)
    return out


def build_tables(study, archives, published_dir: Path) -> list[TableSpec]:
    df = runs_frame(archives)
    refused = _refusals(study)
    if df.empty:
        return [TableSpec("answer", "Answer", pd.DataFrame(), "No solve records in the archives.")]
    mt = method_table(df, _labels_meta(archives))
    ans = answers(mt)
    tables = [TableSpec(
        "answer", "Which method for which arm (from the archives)", ans,
        f"Per robot and problem set: the solver label with the highest FK-verified success within the joint "
        f"limits (ties: faster), and the fastest label among those within {CLOSE_PP:g} "
        f"percentage point of it, by median call time (the whole pipeline.solvers.solve() call, measured the "
        f"same way for our methods and the peer libraries). Labels run on at least {MIN_SHARE:.0%} of the set's goals "
        f"compete (each rate is over the first N goals of the same file, N in the per-robot tables; the slow "
        f"labels capped to fewer goals by solver_counts are in those tables only).")]
    for robot, g in mt.groupby("robot", sort=False):
        g = g.sort_values(["problem set", "success [%]", "solve time p50 [µs]"], ascending=[True, False, True])
        tables.append(TableSpec(
            f"robot_{robot}", f"{robot}: every method, cold and warm starts", g.drop(columns=["robot"]),
            "Success = pose within 0.1 mm and 1e-3 rad by an independent FK AND the returned angles within the "
            "joint limits (revolute joints wrapped by 2 pi). Within limits = share of all returned solutions "
            "inside the limits. Solve time: ours = the method's computation, peers = the whole library call "
            "(with its Python binding); call time = the whole pipeline.solvers.solve() call for both. "
            "Errors: 99th percentile over the successes."))
    heat = mt.pivot_table(index="robot", columns=["problem set", "solver"], values="success [%]", sort=False)
    heat.columns = [f"{s} [{p}] success [%]" for p, s in heat.columns]
    tables.append(TableSpec("heatmap", "Success rate, robots x solver labels", heat.reset_index(),
                            "The numbers behind the heat-map figure (FK-verified, within limits) [%]."))
    tables.append(TableSpec("not_applicable", "Solver and robot pairs skipped, and why", refused,
                            "A solver that does not fit a robot's geometry, or a peer library that is not installed "
                            "on the machine that built this report, is skipped with the solver's own reason."))
    return tables


def build_figures(study, archives, out_dir: Path) -> list[FigureSpec]:
    from pipeline.report.plotting import plt, save

    df = runs_frame(archives)
    if df.empty:
        return []
    mt = method_table(df, _labels_meta(archives))
    figs = []
    for pset, g in mt.groupby("problem set", sort=False):
        H = g.pivot_table(index="robot", columns="solver", values="success [%]", sort=False)
        fig, ax = plt.subplots(figsize=(0.42 * H.shape[1] + 3.0, 0.42 * H.shape[0] + 2.6))
        im = ax.imshow(H.to_numpy(dtype=float), vmin=0, vmax=100, cmap="viridis", aspect="auto")
        ax.set_xticks(np.arange(H.shape[1]), H.columns, rotation=60, ha="right", fontsize=8)
        ax.set_yticks(np.arange(H.shape[0]), H.index, fontsize=8)
        for (i, j), v in np.ndenumerate(H.to_numpy(dtype=float)):
            if np.isfinite(v):
                ax.text(j, i, f"{v:.0f}", ha="center", va="center", fontsize=6, color="w" if v < 60 else "k")
        fig.colorbar(im, ax=ax, label="FK-verified success within limits [%]")
        ax.set_title(f"Success rate, {pset} starts (blank: solver does not apply)")
        fig.tight_layout()
        figs.append(FigureSpec(save(fig, out_dir, f"heatmap_{pset}"), f"Success rate: robots x methods, {pset} starts",
                               "Share of goals with an FK-verified success within the joint limits, per robot (rows) "
                               "and solver label (columns); blank cells: the solver does not apply to that robot.",
                               extra={"answer": True}))
    for robot, g in mt.groupby("robot", sort=False):
        fig, ax = plt.subplots(figsize=(8.5, 5.2))
        for _, r in g.iterrows():
            peer = r["library"] == "peer"
            cold = r["problem set"] == "cold"
            col = "tab:red" if peer else "tab:blue"
            ax.scatter(r["solve time p50 [µs]"], r["success [%]"], marker="s" if peer else "o", s=36,
                       facecolors=col if cold else "none", edgecolors=col)
            ax.annotate(r["solver"], (r["solve time p50 [µs]"], r["success [%]"]), fontsize=6,
                        xytext=(3, 2), textcoords="offset points")
        ax.set_xscale("log")
        ax.set_xlabel("median solve time [µs] (log; peers: whole library call)")
        ax.set_ylabel("FK-verified success within limits [%]")
        ax.set_ylim(-3, 103)
        from matplotlib.lines import Line2D

        handles = [Line2D([], [], marker="o", ls="", color="tab:blue", label="ours"),
                   Line2D([], [], marker="s", ls="", color="tab:red", label="peer library"),
                   Line2D([], [], marker="o", ls="", color="k", label="cold starts (filled)"),
                   Line2D([], [], marker="o", ls="", mfc="none", color="k", label="warm starts (open)")]
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
        ax.set_title(f"{robot}: success versus solve time, one point per method and start set")
        fig.tight_layout()
        figs.append(FigureSpec(save(fig, out_dir, f"tradeoff_{robot}"), f"{robot}: success versus median solve time",
                               "One point per solver label and problem set: ours (circles) and peer libraries "
                               "(squares), cold starts filled and warm starts open. Up and left is better.",
                               extra={"robot": robot}))
    return figs
