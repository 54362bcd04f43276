"""Figuras 5.1 and 5.2 of 004_957b32c2b06ea31d.txt, the TCP path in 3-D and the per-point joint jumps,
from the archives only."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from pipeline.studies.specs import FigureSpec
from pipeline.studies.nepomuceno2024.tables import MOTION_LABEL, is_analytic, joint_jumps, load_runs, method_label


def _fig5_1(st: dict, pts: pd.DataFrame, numeric: list, by_path: dict, colors: dict,
            out_dir: Path) -> list[FigureSpec]:
    """Figura 5.1: convergence of every numerical method at one trajectory point."""
    from pipeline.report.plotting import plt, save

    figs = []
    fp = st.get("figure_point", {"motion": "pick_and_place", "segment": "transfer", "index": 0})
    sel = pts[(pts["motion"] == fp["motion"]) & (pts["segment"] == fp["segment"])].sort_values("problem_id")
    if len(sel):
        pid = int(sel["problem_id"].unique()[min(fp["index"], sel["problem_id"].nunique() - 1)])
        fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
        for m in numeric:
            row = pts[(pts["method"] == m) & (pts["motion"] == fp["motion"]) & (pts["problem_id"] == pid)]
            if row.empty:
                continue
            tr = next(t for t in by_path[row["archive"].iloc[0]].traces([pid]) if t.get("repetition", 0) == 0)
            ev = np.asarray(tr["error_vector"])
            common = np.linalg.norm(ev, axis=1)
            own = np.asarray(tr["error"])
            kw = dict(color=colors[m], lw=1.3, label=f"{method_label(st, m)} ({len(own) - 1} it.)")
            axes[0].semilogy(np.arange(len(common)), np.maximum(common, 1e-17), **kw)
            axes[1].semilogy(np.arange(len(own)), np.maximum(own, 1e-17), **kw)
        axes[0].set_ylabel("‖e‖ = ‖[Δp; ½Σcᵢ×dᵢ]‖ (common measure)")
        axes[1].set_ylabel("the method's own measure (‖e‖ or cost A / B)")
        for ax in axes:
            ax.set_xlabel("iteration (SciPy callback / descent step)")
            ax.grid(True, which="both", alpha=0.3)
        axes[0].legend(fontsize=8)
        fig.suptitle(f"Convergence at point {pid} ({fp['segment']}) of {MOTION_LABEL.get(fp['motion'], fp['motion'])}")
        files = save(fig, out_dir, "fig5_1_convergence")
        figs.append(FigureSpec(files, "Figura 5.1 — convergence curve of one trajectory point",
                               "Error per iteration, log scale, warm start from the previous point's solution of "
                               "the same method. Left: one measure for every method (the descent's ‖e‖); right: "
                               "each method's own stop/cost measure. Nelder-Mead iterates are the best vertex per "
                               "iteration. The document's figure has no axis description."))
    return figs


def _fig5_2(st: dict, pts: pd.DataFrame, methods: list, out_dir: Path) -> list[FigureSpec]:
    """Figura 5.2: joint angles along the home motion, one panel per method."""
    from pipeline.report.plotting import plt, save

    figs = []
    home = pts[pts["motion"] == "home"]
    if len(home):
        fig, axes = plt.subplots(len(methods), 1, figsize=(11, 2.3 * len(methods)), sharex=True, squeeze=False)
        for ax, m in zip(axes[:, 0], methods):
            g = home[home["method"] == m].sort_values("problem_id")
            q = np.array(g["q_solution"].tolist())
            for j in range(q.shape[1]):
                ax.plot(g["problem_id"], q[:, j], marker="o", ms=2, lw=0.8, label=f"Joint {j + 1}")
            ax.set_title(method_label(st, m), fontsize=9)
            ax.set_ylabel("joint [rad]")
            ax.grid(True, alpha=0.3)
        axes[0, 0].legend(title="Juntas", fontsize=7, title_fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
        axes[-1, 0].set_xlabel("point on the trajectory (Ponto na Trajetória)")
        files = save(fig, out_dir, "fig5_2_joint_positions_home")
        figs.append(FigureSpec(files, "Figura 5.2 — joint positions along the home motion, per method",
                               "Solution of every interpolated point of Teste 1 (return to home), one panel per "
                               "method (the document's plot_joint_stability: 6 lines with 'o' markers). "
                               "Smooth curves = a stable motion; a step = a branch flip or a stalled solve."))
    return figs


def _tcp_path(study, pp: pd.DataFrame, methods: list, colors: dict, out_dir: Path) -> list[FigureSpec]:
    """The TCP path of the pick-and-place in 3-D: designed goals and the positions each method reached."""
    from pipeline.kinematics import fk_htm
    from pipeline.report.plotting import plt, save
    from pipeline.robots import load_robot
    from pipeline.settings import ROOT

    st = study.settings
    figs = []
    if len(pp):
        model = load_robot(ROOT / "data" / "robots" / f"{study.set_robots('pick_and_place')[0]}.yaml")
        fig = plt.figure(figsize=(8.5, 7))
        ax = fig.add_subplot(projection="3d")
        g0 = pp[pp["method"] == methods[0]].sort_values("problem_id")
        goal = np.array([[r["position"]["x"], r["position"]["y"], r["position"]["z"]] for r in g0["goal"]])
        ax.plot(goal[:, 0], goal[:, 1], goal[:, 2], color="k", lw=3, alpha=0.25, label="designed path (goals)")
        for m in methods:
            g = pp[pp["method"] == m].sort_values("problem_id")
            p = fk_htm(model.chain, np.array(g["q_solution"].tolist()), exact=True)[:, :3, 3]  # no BLAS
            ax.plot(p[:, 0], p[:, 1], p[:, 2], color=colors[m], lw=1, label=f"reached: {method_label(st, m)}")
        segs = g0["segment"].to_numpy()
        starts = np.flatnonzero(np.r_[True, segs[1:] != segs[:-1]])
        ends = np.r_[starts[1:], len(segs)]
        for a, b in zip(starts, ends):
            k = (a + b) // 2
            ax.text(goal[k, 0], goal[k, 1], goal[k, 2], f"  {segs[a]}", fontsize=7, color="0.3")
        ax.scatter(*goal[0], color="k", s=15)
        ax.text(*goal[0], "  start (home)", fontsize=7)
        span = np.ptp(goal, axis=0)
        ax.set_box_aspect(np.maximum(span, 0.05 * span.max()))
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_zlabel("z [m]")
        ax.legend(fontsize=7, loc="upper left")
        ax.set_title("Teste 2: TCP path of the pick-and-place (UR5 base frame)")
        files = save(fig, out_dir, "tcp_path_pick_and_place_3d")
        figs.append(FigureSpec(files, "TCP path of the pick-and-place in 3-D",
                               "Designed goal positions (grey) and the TCP positions reached by each method "
                               "(independent FK of the archived solutions). Brick on the conveyor at "
                               "(-0.50, -0.35) m, box at (-0.05, -0.55) m, tool pointing down."))
    return figs


def _jump_figure(st: dict, pp: pd.DataFrame, methods: list, colors: dict, out_dir: Path) -> list[FigureSpec]:
    """Continuity: the largest joint step between consecutive points of the pick-and-place."""
    from pipeline.report.plotting import plt, save

    figs = []
    if len(pp):
        fig, ax = plt.subplots(figsize=(10, 3.8))
        for m in methods:
            g = pp[pp["method"] == m].sort_values("problem_id")
            ax.semilogy(g["problem_id"], np.maximum(joint_jumps(g).max(axis=1), 1e-12), color=colors[m], lw=0.9,
                        label=method_label(st, m))
        ax.set_xlabel("point on the pick-and-place trajectory")
        ax.set_ylabel("max |q_k − q_(k−1)| [rad]")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        files = save(fig, out_dir, "joint_jumps_pick_and_place")
        figs.append(FigureSpec(files, "Continuity — largest joint step between consecutive points",
                               "Per point of Teste 2, the largest joint change from the previous point's solution. "
                               "A stalled solver shows as a run of ~0 steps followed by a catch-up step."))
    return figs


def build_figures(study, archives, out_dir: Path) -> list[FigureSpec]:
    """Figuras 5.1 and 5.2 from our runs, the pick-and-place TCP path and its joint jumps."""
    from pipeline.report.plotting import plt

    st = study.settings
    pts, _ = load_runs(study, archives)
    methods = [m for m in st["table_methods"] if m in set(pts["method"])]
    numeric = [m for m in methods if not is_analytic(study, m)]
    by_path = {str(a.path): a for a in archives}
    colors = dict(zip(methods, plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    pp = pts[pts["motion"] == "pick_and_place"]
    return (_fig5_1(st, pts, numeric, by_path, colors, out_dir) + _fig5_2(st, pts, methods, out_dir)
            + _tcp_path(study, pp, methods, colors, out_dir) + _jump_figure(st, pp, methods, colors, out_dir))
