"""Which IK method for your arm: every registered method (ours and the peer libraries) on every
catalogue arm, cold and warm starts, computed from the archives alone.

Tables
    ``answer_plain`` — the answer in plain words: arm x start set -> method, library, success with its
    interval, median call time, median distance to the seed (warm starts); what the report opens with.
    ``answer`` — the same rows in full: label, settings, how the time was taken, the labels not
    significantly worse, the finalists, those not for tracking, and the program to copy.
    ``race_<robot>`` — the race of the arm's finalists (:mod:`pipeline.jobs.race`): per label the race
    time (median over goals of each goal's fastest pass), its paired ratio to the fastest with a 95 %
    interval, and the load record.
    ``key_<robot>`` — at most 8 key labels per robot (the recommendation, best closed form of ours
    and of a peer, best single search, best with restarts, TRAC-IK, the Robotics Toolbox's LM), both
    problem sets, with intervals, time percentiles and the joint distance to the start.
    ``robot_<name>`` — every label on that robot, both problem sets, in one table.
    ``heatmap`` — the robots x methods success rates behind the heat map.
    ``not_applicable`` — every (robot, solver) pair the study skipped, with the solver's reason.
Figures
    ``heatmap_<set>`` — success rate, robots x solver labels; ``budget_<robot>`` — per key label, the
    share of goals solved within a time budget (10 µs to 10 ms) and the distributions of call time and
    of the position error of the successes.

The rule (computed in :mod:`pipeline.studies.arm_answer`, quoted in the tables' notes as :data:`RULE`)
    Correctness from the archives: labels compete on a problem set when they ran at least
    ``MIN_SHARE`` of its goals; the best is the label with the highest success rate; a label is *not
    significantly worse* when, on the goals both ran (paired), the one-sided exact McNemar test does
    not find it worse at the 5 % level (:func:`worse_p`); every rate is shown with its Wilson 95 %
    interval. On a warm set, a label whose median joint distance to the seed is above
    ``TRACK_FACTOR`` times the smallest among them is not recommended for tracking (:func:`shortlist`).
    Among those left, a closed form (registry kind ``analytic``) wins. Speed from a race: where more
    than one finalist is left, the arm's race job (after its solve jobs, :mod:`pipeline.jobs.race`)
    calls them on the same goals in one process, interleaved, and they are ranked on paired per-goal
    ratios (:func:`race_summary`); finalists within ``TIE_RATIO`` of the fastest tie, and a tie goes
    to our own library, then the label's name (:func:`pick_fastest`), so that load moving two
    near-equal times does not move the answer. Load is recorded beside the times (the race's load
    average, each job's CPU share) and never withholds an answer. Method and library come from the
    registry (archived as metadata), never from a setting.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pandas as pd

from pipeline.studies.specs import FigureSpec, TableSpec
from pipeline.studies.arm_answer import (ALPHA, ANSWER_COLUMNS, BUDGETS_US, KEY_ROWS, MIN_SHARE,  # noqa: F401
                                         RACE_SET_TOPIC, RACE_TOPIC, SMOKE_GOALS, TIE_RATIO, TRACK_FACTOR, WORDS,
                                         Z95, answers, in_words, is_warm, job_timing, label_settings, method_table,
                                         percentile, pick_fastest, python_call, race_summary, shortlist,
                                         method_kind, success_by_problem, warm_sets, wilson, worse_p)
from pipeline.studies.common import library_label
from pipeline.studies.generic import runs_frame


def plain_table(ans: pd.DataFrame) -> pd.DataFrame:
    """The answer in plain words, one row per arm and start set (what the report opens with)."""
    return pd.DataFrame({
        "arm": ans["robot"], "starts": ans["problem set"], "method": ans["in words"],
        "library": [library_label(lib, ver) for lib, ver in
                    zip(ans["library"], ans.get("library version", pd.Series([""] * len(ans))).fillna(""))],
        "success [%] (95 % CI)": [f"{s:.1f} ({lo:.1f}-{hi:.1f})" for s, lo, hi in
                                  zip(ans["success [%]"], ans["success CI low [%]"], ans["success CI high [%]"])],
        "median call [µs]": ans["call time p50 [µs]"].round(1),
        "median distance to seed [rad]": ans["distance to seed p50 [rad]"].round(3),
        "label": ans["recommendation"]})


def key_labels(mt: pd.DataFrame, ans: pd.DataFrame, robot: str) -> list[str]:
    """At most :data:`KEY_ROWS` labels of one robot: the recommendations, then the best of each group
    (closed form ours / peer, single search, restarts, TRAC-IK, the Robotics Toolbox's LM single and with
    restarts, Pinocchio's CLIK) among the labels run on at least ``SMOKE_GOALS`` goals of a set (all of
    a smaller set), by the lower end of the success interval, then the rate, on the cold set where it ran.
    A group with no such label has no key row."""
    g = mt[mt["robot"] == robot]
    big = g["problems"] >= np.minimum(SMOKE_GOALS, g.groupby("problem set")["problems"].transform("max"))
    order = g[big].assign(_cold=g["problem set"] != "cold").sort_values(
        ["_cold", "success CI low [%]", "success [%]", "solver"], ascending=[True, False, False, True])
    picks = [x for x in ans.loc[ans["robot"] == robot, "recommendation"] if isinstance(x, str) and x]
    ours = order["library"] == "ours"
    groups = [order[ours & (order["kind"] == "analytic")], order[~ours & (order["kind"] == "analytic")],
              order[ours & (order["kind"] != "analytic") & (order["search"] == "single")],
              order[ours & (order["kind"] != "analytic") & (order["search"] != "single")],
              order[order["solver"] == "trac_ik"], order[(order["method"] == "trac_ik") & (order["solver"] != "trac_ik")],
              order[order["solver"] == "rtb_ik_lm"],
              order[order["solver"] == "rtb_ik_lm_restarts"], order[order["method"] == "pinocchio_clik"]]
    for grp in groups:
        if len(grp):
            picks.append(grp["solver"].iloc[0])
    return list(dict.fromkeys(picks))[:KEY_ROWS]


def refusal_table(study) -> pd.DataFrame:
    """Every (robot, solver) pair the study skips, with its problem sets and the solver's reason (the
    ``not_applicable`` table)."""
    from pipeline.settings import refusals

    models = _models(study)
    rows = {}
    for (pset, robot, label), why in refusals(study, models).items():
        rows.setdefault((robot, label), {"robot": robot, "solver": label, "method": study.solvers[label].method,
                                         "problem sets": [], "why it does not apply": why})["problem sets"].append(pset)
    out = pd.DataFrame(list(rows.values()), columns=["robot", "solver", "method", "problem sets", "why it does not apply"])
    out["problem sets"] = out["problem sets"].map(", ".join)
    return out


def _scale(archives) -> str:
    scales = {a.metadata.get("scale", "") for a in archives}
    return scales.pop() if len(scales) == 1 else ", ".join(sorted(scales))


def _robot_files(archives) -> dict:
    return {a.metadata["robot"]: a.metadata.get("robot_file", "") for a in archives}


RULE = (f"Correctness from the archives, speed from a race. Labels run on at least {MIN_SHARE:.0%} of a set's goals "
        f"compete; the best is the highest success rate; a label is not significantly worse when, on the "
        f"goals both ran, a one-sided exact McNemar test does not find it worse at the {ALPHA:.0%} level; "
        f"intervals are Wilson 95 %. On a warm set (seeds near the answer) a label whose median distance to the seed "
        f"is more than {TRACK_FACTOR:.0f}x the smallest among them is not recommended for tracking. Among those left a "
        f"closed form wins; where more than one finalist is left they are raced per arm after its solve jobs: bound "
        f"once, called on the same goals in one process, interleaved in shuffled order over several passes, each "
        f"goal's fastest pass kept, ranked on the median of paired per-goal ratios; finalists within "
        f"{TIE_RATIO:.2f}x of the fastest tie and a tie goes to our own library, then the label's name. Load is "
        f"recorded beside every time and never withholds an answer."
        f" Success = pose within 0.1 mm and 1e-3 rad by an independent FK AND the returned angles "
        f"within the joint limits (revolute joints wrapped by 2 pi; 1e-6 rad tolerance for every method, "
        f"pipeline.solvers.kernels.kin.LIMIT_TOL).")

_FULL_COLUMNS = ["problem set", "solver", "library", "problems", "success [%]", "success 95 % CI [%]",
                 "within limits [%]", "call time p50 [µs]", "CPU share [%]", "iterations p50",
                 "position error p99, successes [mm]"]  # fits the report's text column (TABLE_BUDGET_PX)
_KEY_COLUMNS = ["solver", "problem set", "library", "problems", "success [%]", "success 95 % CI [%]",
                "call time p50 [µs]", "call time p95 [µs]", "CPU time p50 [µs]",
                "joint distance to start p50, successes [rad]", "position error p99, successes [mm]"]


def _versioned(t: pd.DataFrame) -> pd.DataFrame:
    """``t`` with its ``library`` column showing each peer's version (:func:`library_label`)."""
    versions = t["library version"].fillna("") if "library version" in t else [""] * len(t)
    return t.assign(library=[library_label(lib, v) for lib, v in zip(t["library"], versions)])


NEAREST_TOL = 1e-9  # [rad] a returned solution is the nearest when no admissible one is nearer by more than this


def travel(q, q0, limits: np.ndarray, prismatic: np.ndarray, turns: bool) -> float:
    """How far the joints move from ``q0`` to ``q`` (Euclidean norm of the per-joint moves [rad | length]).
    ``turns``: each revolute joint may first take ``q``'s value moved by whole turns to the one within its
    limits nearest ``q0`` (a solution row, whose representative is free); inf when some joint has none.
    Otherwise the moves are ``q - q0`` as given (the angles a method returned are what the arm is sent)."""
    from pipeline.solvers.core import LIMIT_TOL, nearest_rep

    q, q0 = np.array(q, dtype=float), np.array(q0, dtype=float)  # writable copies: one kernel signature
    if not turns:
        d = q - q0
        return float(np.sqrt((d * d).sum()))
    return float(nearest_rep(q, q0, np.array(limits, dtype=float), np.array(prismatic, dtype=np.bool_), LIMIT_TOL,
                             np.empty_like(q)))


def nearest_flags(df: pd.DataFrame, archives, warm: set, models: dict) -> np.ndarray:
    """Per row of ``df`` (a :func:`runs_frame`): whether the returned angles are the solution nearest the
    seed among the method's own solutions: no solution the method returned moves the joints less
    (:func:`travel`: each solution row by whole turns to its representative within the limits nearest
    the seed; the returned angles as they are). Only warm sets of methods that return several solutions
    (the archive's ``/ik/solutions``) are checked; every other row is True. On a warm set a success
    counts as the answer only when it holds: a tracking user is given the solution beside the seed."""
    out = np.ones(len(df), dtype=bool)
    by_path = {str(a.path): a for a in archives}
    rows = np.flatnonzero(df["problem_set"].isin(warm).to_numpy())
    for path, idx in pd.Series(rows, index=df["archive"].iloc[rows].to_numpy()).groupby(level=0):
        a, model = by_path.get(path), models.get(df["robot"].iloc[idx.iloc[0]])
        if a is None or model is None or method_kind(a.metadata.get("method", "")) != "analytic":
            continue
        lim, prism = np.asarray(model.limits, float), np.asarray(model.chain.prismatic, bool)
        for i in idx.to_numpy():
            r = df.iloc[i]
            sols = a.solutions(int(r["problem_id"]), int(r["repetition"]))
            if not sols or len(sols) < 2 or not bool(r["success"]):
                continue
            near = min(travel(s, r["q_start"], lim, prism, True) for s in sols)
            out[i] = travel(r["q_solution"], r["q_start"], lim, prism, False) <= near + NEAREST_TOL
    return out


def race_records(archives) -> tuple[pd.DataFrame, dict]:
    """The timed calls of every race archive (``measurement: race``) as a frame (robot, problem_set,
    solver, problem_id, pass, wall_ns, cpu_ns, success), and (robot, set) -> the race's set record."""
    calls, sets = [], {}
    for a in archives:
        if a.metadata.get("measurement") != "race":
            continue
        robot = a.metadata.get("robot", "")
        calls += [{**r, "robot": robot} for r in a.messages(RACE_TOPIC)]
        for r in a.messages(RACE_SET_TOPIC):
            sets[(robot, r["problem_set"])] = r
    cols = ["robot", "problem_set", "solver", "problem_id", "pass", "wall_ns", "cpu_ns", "success"]
    return pd.DataFrame(calls, columns=cols), sets


def _models(study) -> dict:
    """The study's robots, loaded once per process (the refusals and the nearest-solution check share them)."""
    return _models_at(str(Path(study.path).parent.parent / "robots"),
                      tuple(sorted({r for ps in study.problem_sets for r in study.set_robots(ps)})))


@functools.lru_cache(maxsize=4)
def _models_at(robots_dir: str, names: tuple) -> dict:
    from pipeline.robots import load_robot

    return {r: load_robot(Path(robots_dir) / f"{r}.yaml") for r in names}


def answer_frame(df: pd.DataFrame, archives, study) -> pd.DataFrame:
    """``df`` with a warm set's success kept only where the returned solution is the nearest to the seed
    among the method's admissible solutions (:func:`nearest_flags`); ``not nearest`` counts the others."""
    near = nearest_flags(df, archives, warm_sets(study), _models(study))
    df = df.copy()
    df["not nearest"] = df["success"].astype(bool) & ~near
    df["success"] = df["success"].astype(bool) & near
    return df


def build_tables(study, archives, published_dir: Path) -> list[TableSpec]:
    df = runs_frame(archives)
    refused = refusal_table(study)
    if df.empty:
        return [TableSpec("answer", "Answer", pd.DataFrame(), "No solve records in the archives.")]
    meta = label_settings(archives)
    df = answer_frame(df, archives, study)
    mt = method_table(df, meta, job_timing(archives))
    calls, race_sets = race_records(archives)
    race = race_summary(calls)
    ans = answers(mt, df, meta, _scale(archives), _robot_files(archives), race, race_sets, warm_sets(study))
    tables = [TableSpec("answer_plain", "Which method for which arm, in plain words", plain_table(ans),
                        "One row per arm and start set (cold: any start within the limits; warm: a seed within 0.3 rad "
                        "of the answer, as when tracking a path). Success: FK-verified within 0.1 mm and 1e-3 rad and "
                        "within the joint limits, with its Wilson 95 % interval. Median call: wall time of the whole "
                        "call [µs], from the arm's race where more than one finalist was left (one process, "
                        "interleaved, each goal's fastest of several passes; the load average of the race is in the "
                        "answer table's timing column), else from its solve job. Median distance to seed: wrapped "
                        "joint distance [rad] of the successes. The answer table below says why each was chosen."),
              TableSpec("answer", "Which method for which arm (from the archives)", ans,
                        f"Per robot and problem set, one recommendation. {RULE} The call column is a complete "
                        f"program: the robot loaded once, the solver bound once with the label's settings that "
                        f"differ from the registry's defaults, then a loop over 1 000 goals (tests/studies/test_answer_calls.py "
                        f"runs every one in a fresh process).")]
    for robot, g in race.groupby("robot", sort=False):
        g = g.drop(columns="robot").copy()
        for col, key in (("load average, start [-]", "load_start"), ("load average, end [-]", "load_end"),
                         ("race CPU share [-]", "cpu_share")):
            g[col] = [float(race_sets.get((robot, p), {}).get(key, "nan")) for p in g["problem set"]]
        tables.append(TableSpec(
            f"race_{robot}", f"{robot}: the race of the finalists (one process, interleaved)", g,
            "Each finalist bound once and called on the same goals, round robin in a shuffled order per goal, "
            "over several passes; a goal's time is its fastest pass [µs] (a preempted call is only slower), the "
            "label's race time the median over goals; ratio to fastest = median of the paired per-goal ratios, "
            f"with a distribution-free 95 % interval. Finalists within {TIE_RATIO:.2f}x tie. The load record: the "
            "1-minute load average when the set's race started and ended, and the race's CPU time over its wall "
            "time (below 1: the machine was busy; the ratios are paired, so load lands on every label alike)."))
    for robot, g in mt.groupby("robot", sort=False):
        keys = key_labels(mt, ans, robot)
        k = g[g["solver"].isin(keys)].copy()
        k["_o"] = k["solver"].map({s: i for i, s in enumerate(keys)})
        k = _versioned(k.sort_values(["_o", "problem set"]))[_KEY_COLUMNS].rename(columns={
            "problem set": "set", "joint distance to start p50, successes [rad]": "joint distance to start p50 [rad]",
            "position error p99, successes [mm]": "position error p99 [mm]"})
        tables.append(TableSpec(
            f"key_{robot}", f"{robot}: the key methods, with 95 % intervals", k,
            "At most 8 labels: the recommendation(s), then the best closed form (ours, then a peer's), best single "
            "search, best with restarts, TRAC-IK at its default 5 ms and at 20 ms, the Robotics Toolbox's LM (then "
            "with restarts, and Pinocchio's CLIK, while there is room). Joint distance (warm set: to the seed) and position error over the successes. Call "
            "time = wall time of the whole solve() call; CPU time = its CPU time (the calling thread's; the "
            "process's for TRAC-IK, whose two threads both count), shown, not ranked on: on a loaded machine this "
            "VM's thread clock read a third of the wall time of calls that ran unpreempted. " + RULE))
        full = g.sort_values(["problem set", "success [%]", "call time p50 [µs]"], ascending=[True, False, True])
        job = g["job CPU share [%]"].iloc[0]
        tables.append(TableSpec(
            f"robot_{robot}", f"{robot}: every method, cold and warm starts (its job got {job:.0f} % of a core)",
            _versioned(full)[_FULL_COLUMNS].rename(columns={"problem set": "set", "problems": "goals",
                                                "iterations p50": "iter. p50",
                                                "position error p99, successes [mm]": "position error p99 [mm]"}),
            "Within limits = share of all returned solutions inside the limits. The key table above adds the 95th "
            "percentile of the call time and the CPU time; the per-sample file has every solve's. CPU time = CPU "
            "time of the whole pipeline.solvers.solve() call (the calling thread's; TRAC-IK: the process's); call time = its wall time (peers: their whole library call "
            "inside it); CPU share = CPU / wall time summed over the label's solves; job CPU share = the same over "
            "every single-threaded label of the arm's job (the load record: below 100 % the machine was busy; nothing is withheld for it; TRAC-IK idles "
            "while its two threads race, so its own share says nothing of the machine). "
            "Errors: 99th percentile over the successes. " + RULE))
    heat = mt.pivot_table(index="robot", columns=["problem set", "solver"], values="success [%]", sort=False)
    heat.columns = [f"{s} [{p}] success [%]" for p, s in heat.columns]
    tables.append(TableSpec("heatmap", "Success rate, robots x solver labels", heat.reset_index(),
                            "The numbers behind the heat-map figure (FK-verified, within limits) [%]."))
    tables.append(TableSpec("not_applicable", "Solver and robot pairs skipped, and why", refused,
                            "A solver that does not fit a robot's geometry, or a peer library that is not installed "
                            "on the machine that built this report, is skipped with the solver's own reason."))
    return tables


def _heatmap(pset: str, g: pd.DataFrame, out_dir: Path) -> FigureSpec:
    """The success heat map of one problem set: solver labels x robots."""
    from pipeline.report.plotting import plt, save

    # labels as rows, robots as columns: 9 in wide (the report's text column at 1 400 px, shown 1:1), cell
    # numbers at 8.5 pt, one row per label
    H = g.pivot_table(index="solver", columns="robot", values="success [%]", sort=False)
    fig, ax = plt.subplots(figsize=(9.0, 0.24 * H.shape[0] + 2.4))
    im = ax.imshow(H.to_numpy(dtype=float), vmin=0, vmax=100, cmap="viridis", aspect="auto")
    ax.xaxis.tick_top()
    ax.set_xticks(np.arange(H.shape[1]), H.columns, rotation=40, ha="left", fontsize=9)
    ax.set_yticks(np.arange(H.shape[0]), H.index, fontsize=9)
    for (i, j), v in np.ndenumerate(H.to_numpy(dtype=float)):
        if np.isfinite(v):
            ax.text(j, i, f"{v:.0f}", ha="center", va="center", fontsize=8.5, color="w" if v < 60 else "k")
    fig.colorbar(im, ax=ax, label="FK-verified success within limits [%]", fraction=0.04, pad=0.02)
    ax.set_xlabel(f"Success rate, {pset} starts (blank: the solver does not apply)", fontsize=10)
    fig.tight_layout()
    return FigureSpec(save(fig, out_dir, f"heatmap_{pset}", svg=False),
                      f"Success rate: methods x robots, {pset} starts",
                      "Share of goals with an FK-verified success within the joint limits, per solver label "
                      "(rows) and robot (columns); blank cells: the solver does not apply to that robot.",
                      extra={"answer": True})


def _budget_curves(axes_row, df: pd.DataFrame, robot: str, sets: list, keys: list, colors: dict) -> None:
    """Per problem set (the first two), the share of goals each key label solved within a time budget."""
    for ax, pset in zip(axes_row, sets[:2]):
        for s in keys:
            h = df[(df["robot"] == robot) & (df["problem_set"] == pset) & (df["solver"] == s)]
            if h.empty:
                continue
            t = 1e6 * h["call_time_s"].to_numpy(dtype=float)
            ok = h["success"].astype(bool).to_numpy()
            share = [(ok & (t <= b)).mean() * 100 for b in BUDGETS_US]
            peer = h["library"].iloc[0] != "ours"
            ax.plot(BUDGETS_US, share, color=colors[s], ls="--" if peer else "-", lw=1.6,
                    label=f"{s} ({h['library'].iloc[0]})")
        ax.set_xscale("log")
        ax.set_xlim(BUDGETS_US[0], BUDGETS_US[-1])
        ax.set_ylim(-2, 102)
        ax.set_xlabel("time budget b: wall time of the whole call [µs]")
        ax.set_ylabel("goals solved within b [%]")
        ax.set_title(f"{pset} starts: solve rate within a time budget", fontsize=10)
        ax.grid(alpha=0.3, which="both")


def _distributions(axes_row, df: pd.DataFrame, robot: str, keys: list) -> None:
    """Box plots of each key label's call time and of the position error of its successes, sets pooled."""
    h = df[(df["robot"] == robot) & df["solver"].isin(keys)]
    data_t, data_e, names = [], [], []
    for s in keys:
        x = h[h["solver"] == s]
        if x.empty:
            continue
        t = 1e6 * x["call_time_s"].to_numpy(dtype=float)
        t = t[np.isfinite(t) & (t > 0)]
        e = x.loc[x["success"].astype(bool), "position_error_mm"].to_numpy(dtype=float)
        e = np.maximum(e[np.isfinite(e)], 1e-12)
        data_t.append(t if t.size else [np.nan])
        data_e.append(e if e.size else [np.nan])
        names.append(s)
    for ax, data, label in ((axes_row[0], data_t, "wall time per call [µs]"),
                            (axes_row[1], data_e, "position error of the successes [mm]")):
        ax.boxplot(data, vert=False, showfliers=False, whis=(5, 95))
        ax.set_yticks(np.arange(1, len(names) + 1), names, fontsize=8)
        ax.invert_yaxis()
        ax.set_xscale("log")
        ax.set_xlabel(label)
        ax.grid(alpha=0.3, axis="x")
    axes_row[1].set_yticklabels([])


def _budget_figure(robot: str, g: pd.DataFrame, df: pd.DataFrame, keys: list, out_dir: Path) -> FigureSpec:
    """One robot's figure: budget curves per problem set (top), time and error distributions (bottom)."""
    from pipeline.report.plotting import plt, save

    sets = list(dict.fromkeys(g["problem set"]))
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.6))
    colors = {s: plt.cm.tab10(i % 10) for i, s in enumerate(keys)}
    _budget_curves(axes[0], df, robot, sets, keys, colors)
    axes[0][0].legend(fontsize=7.5, loc="upper left", frameon=False)
    _distributions(axes[1], df, robot, keys)
    fig.suptitle(f"{robot}: the key methods (solid: ours, dashed: peer libraries; both sets pooled below)",
                 fontsize=11)
    return FigureSpec(save(fig, out_dir, f"budget_{robot}"), f"{robot}: solve rate within a time budget, "
                      "time and error distributions",
                      "Top: share of the set's goals an FK-verified success within the limits reached within "
                      "a time budget b (wall time of the whole call; a method's curve ends at its success "
                      "rate). Bottom (log scales; boxes: quartiles, whiskers: 5th-95th percentile): wall time "
                      "per call and position error of the successes, cold and warm sets pooled, for the "
                      "labels of the key table only.",
                      extra={"robot": robot})


def build_figures(study, archives, out_dir: Path) -> list[FigureSpec]:
    """The heat map per problem set and the budget figure per robot (see the module docstring)."""
    df = runs_frame(archives)
    if df.empty:
        return []
    meta = label_settings(archives)
    df = answer_frame(df, archives, study)
    mt = method_table(df, meta, job_timing(archives))
    calls, race_sets = race_records(archives)
    ans = answers(mt, df, meta, _scale(archives), _robot_files(archives), race_summary(calls), race_sets,
                  warm_sets(study))
    figs = [_heatmap(pset, g, out_dir) for pset, g in mt.groupby("problem set", sort=False)]
    for robot, g in mt.groupby("robot", sort=False):
        figs.append(_budget_figure(robot, g, df, key_labels(mt, ans, robot), out_dir))
    return figs
