"""Cerbaro (2019), 000_7e3cb7ad5ee98ff0.txt: Tables 7-16 and Figures 19-25 from the archives."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from pipeline.studies import FigureSpec, TableSpec
from pipeline.studies.common import describe, published, solves_frame

STUDY = "cerbaro2019"
METHOD_LABEL = {"jacobian_transpose": "Jᵀ", "pseudoinverse": "J†", "dls": "DLS", "sdls": "SDLS"}
UNIT_NOTE = (
    "The document labels its IK-block and iteration times μs and its problem times ms, but mean "
    "iterations × mean iteration time is about 100× smaller than the mean problem time (notes §10.4); "
    "its values are copied as printed. Ours are measured per solve with a monotonic clock, in the units "
    "of each header."
)


def _label(solver: str, method: str) -> str:
    base = METHOD_LABEL.get(method, method)
    return base if solver == method else f"{base} [{solver}]"


def _pub_row(pub: pd.DataFrame | None, method: str) -> pd.Series | None:
    if pub is None:
        return None
    rows = pub[pub["method"] == method]
    return rows.iloc[0] if len(rows) else None


def _get(row, key):
    return np.nan if row is None else row[key]


def build_tables(study, archives, published_dir: Path) -> list[TableSpec]:
    df = solves_frame(archives)
    out = []
    groups = list(df.groupby("solver", sort=False))

    pub7 = published(published_dir, STUDY, "table07")
    rows = []
    for solver, g in groups:
        method = g["method"].iloc[0]
        p = _pub_row(pub7, method)
        rows.append({"method": _label(solver, method), "problems": len(g),
                     "successes (ours)": int(g["success"].sum()),
                     "success % (ours)": 100.0 * g["success"].mean(),
                     "successes (published)": _get(p, "successes"),
                     "success % (published)": _get(p, "success_pct")})
    out.append(TableSpec("table07_success", "Table 7 — success rate", pd.DataFrame(rows),
                         "Success = the method's stop test passed and an independent FK confirmed it."))

    pub8 = published(published_dir, STUDY, "table08_11")
    rows = []
    for solver, g in groups:
        method = g["method"].iloc[0]
        ok = g[g["success"]]
        it = np.maximum(ok["iterations"].to_numpy(), 1)
        cols = {
            "iterations": ok["iterations"],
            "IK-block time per iteration [µs]": 1e6 * ok["ik_time_s"] / it,
            "iteration time [µs]": 1e6 * ok["solve_time_s"] / it,
            "problem time [ms]": 1e3 * ok["solve_time_s"],
        }
        stats = {k: describe(v) for k, v in cols.items()}
        for s in ("min", "max", "mean", "std"):
            row = {"method": _label(solver, method), "statistic": s}
            row.update({f"{k} (ours)": stats[k][s] for k in cols})
            if pub8 is not None:
                pr = pub8[(pub8["method"] == method) & (pub8["statistic"] == s)]
                pr = pr.iloc[0] if len(pr) else None
                row["iterations (published)"] = _get(pr, "iterations")
                row["IK time, printed 'μs' (published)"] = _get(pr, "ik_time_us_as_printed")
                row["iteration time, printed 'μs' (published)"] = _get(pr, "iteration_time_us_as_printed")
                row["problem time [ms] (published)"] = _get(pr, "problem_time_ms")
            rows.append(row)
    out.append(TableSpec("table08_11_performance", "Tables 8–11 — performance over successful problems",
                         pd.DataFrame(rows), UNIT_NOTE))

    pub12 = published(published_dir, STUDY, "table12")
    rows = []
    for solver, g in groups:
        method = g["method"].iloc[0]
        t = g.loc[g["success"], "solve_time_s"]
        d = describe(t)
        rows.append({"method": _label(solver, method), "CV of problem time % (ours)": 100 * d["std"] / d["mean"],
                     "CV % (published)": _get(_pub_row(pub12, method), "cv_pct")})
    out.append(TableSpec("table12_cv", "Table 12 — coefficient of variation of problem time",
                         pd.DataFrame(rows), "CV = sample std / mean of the problem time over successes."))

    pub14 = published(published_dir, STUDY, "table14")
    rows = []
    for solver, g in groups:
        method = g["method"].iloc[0]
        ok = g[g["success"]]
        r = float(np.corrcoef(ok["solve_time_s"], ok["initial_error"])[0, 1]) if len(ok) > 2 else np.nan
        rows.append({"method": _label(solver, method), "Pearson r (ours)": r,
                     "r (published)": _get(_pub_row(pub14, method), "correlation")})
    out.append(TableSpec("table14_correlation", "Table 14 — correlation of problem time with the initial error norm",
                         pd.DataFrame(rows), "Pearson correlation over successful problems (the document used SPSS; type not stated)."))

    pub15 = published(published_dir, STUDY, "table15")
    rows = []
    for solver, g in groups:
        method = g["method"].iloc[0]
        p = _pub_row(pub15, method)
        codes = g["stop_reason"].value_counts()
        row = {"method": _label(solver, method)}
        for c in (2, 3, 4):
            row[f"cause {c} (ours)"] = int(codes.get(c, 0))
            row[f"cause {c} (published)"] = _get(p, f"cause_{c}")
        row["other: non-finite / FK contradicts (ours)"] = int(codes.get(5, 0) + codes.get(6, 0))
        rows.append(row)
    out.append(TableSpec("table15_failures", "Table 15 — failure causes",
                         pd.DataFrame(rows),
                         "2 = pose change below the stall threshold; 3 = error grew 5 iterations in a row; 4 = iteration cap."))
    return out


def build_figures(study, archives, out_dir: Path) -> list[FigureSpec]:
    from pipeline.report.plotting import plt, save

    df = solves_frame(archives)
    figs = []
    # Fig. 19 analogue: six error components vs iteration for one solved problem per solver
    for solver, g in df.groupby("solver", sort=False):
        ok = g[g["success"]]
        if ok.empty:
            continue
        pick = ok.iloc[(ok["iterations"] - ok["iterations"].median()).abs().argsort().iloc[0]]
        arch = next(a for a in archives if str(a.path) == pick["archive"])
        trace = next(arch.traces([pick["problem_id"]]))
        e = np.asarray(trace["error_vector"])
        fig, ax = plt.subplots(figsize=(7, 3.8))
        names = ["x", "y", "z"]
        unit = pick["length_unit"]
        for k in range(3):
            ax.plot(e[:, k], marker=".", label=f"position {names[k]} [{unit}]")
        for k in range(3):
            ax.plot(e[:, 3 + k], marker=".", linestyle="--", label=f"orientation {names[k]} [1]")
        ax.set_xlabel("iteration")
        ax.set_ylabel("error component")
        ax.axhline(0, color="k", lw=0.5)
        ax.legend(ncol=2, fontsize=8)
        ax.set_title(f"{_label(solver, pick['method'])}: problem {int(pick['problem_id'])}")
        files = save(fig, out_dir, f"fig19_error_trace_{solver}")
        figs.append(FigureSpec(files, f"Figure 19 — error components vs iteration ({_label(solver, pick['method'])})",
                               "Six components of the error vector for the successful problem whose iteration count "
                               "is closest to the median. The document shows one SDLS problem."))
    # beyond the document: success-vs-iterations CDF
    fig, ax = plt.subplots(figsize=(6, 3.8))
    for solver, g in df.groupby("solver", sort=False):
        its = np.sort(g.loc[g["success"], "iterations"].to_numpy())
        if its.size:
            ax.step(its, np.arange(1, its.size + 1) / len(g) * 100, where="post", label=_label(solver, g["method"].iloc[0]))
    ax.set_xscale("log")
    ax.set_xlabel("iterations")
    ax.set_ylabel("problems solved within [%]")
    ax.grid(alpha=0.3)
    ax.legend()
    figs.append(FigureSpec(save(fig, out_dir, "success_cdf"), "Success vs iterations (not in the document)",
                           "Share of all problems solved within a given number of iterations."))
    # problem-time distribution (Fig. 23 analogue)
    fig, ax = plt.subplots(figsize=(6, 3.8))
    data, labels = [], []
    for solver, g in df.groupby("solver", sort=False):
        data.append(1e3 * g.loc[g["success"], "solve_time_s"].to_numpy())
        labels.append(_label(solver, g["method"].iloc[0]))
    ax.boxplot(data, whis=(2.5, 97.5), flierprops={"marker": "*", "markersize": 3})
    ax.set_xticks(range(1, len(labels) + 1), labels)
    ax.set_ylabel("problem time [ms]")
    ax.set_yscale("log")
    figs.append(FigureSpec(save(fig, out_dir, "fig23_problem_time_box"), "Figure 23 — problem time distribution",
                           "Box = quartiles, line = median, whiskers cover the central 95 % (as the document describes), "
                           "stars = the rest. Log scale."))
    return figs
