"""Which IK method for your arm: every registered method (ours and the peer libraries) on every
catalogue arm, cold and warm starts, computed from the archives alone.

Tables
    ``answer`` — one row per robot and problem set: the recommendation (label, method, library,
    settings, success with its Wilson 95 % interval, median call time) and the Python call to copy.
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

The rule (written once, here, and quoted in the tables' notes)
    Labels compete on a problem set when they ran at least ``MIN_SHARE`` of its goals and their job
    (one per robot) got at least ``MIN_CPU_SHARE`` of a core (CPU time / wall time summed over the
    solves of its single-threaded labels; a starved job's labels are flagged and not ranked). The best is the label with the highest success rate. A label is *not
    significantly worse* when, on the goals both ran (paired), the one-sided exact McNemar test does
    not find it worse at the 5 % level (:func:`worse_p`); every rate is shown with its Wilson 95 %
    interval. Among those, a closed form (registry kind ``analytic``) wins; the
    recommendation is then the fastest by median wall time of the whole call: most calls of a few µs
    run unpreempted, so the median over hundreds of them barely moves with the machine's load
    (measured: 25-26 of 26 recommendations unchanged with a second build running, against 18 of 26
    by median CPU time, which this machine's thread clock under-reads under load), and the jobs that
    did not get a core are flagged besides. Method and library come from the registry (archived as metadata), never from a
    setting.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from pipeline.studies import FigureSpec, TableSpec
from pipeline.studies.generic import joint_distance, runs_frame

MIN_SHARE = 0.1  # labels run on at least this share of a set's goals compete for the answer
MIN_CPU_SHARE = 0.9  # a job whose solves got less CPU than this share of their wall time is starved
Z95 = 1.959963984540054  # two-sided 95 % normal quantile (Wilson interval)
ALPHA = 0.05  # a label is significantly worse than the best when the one-sided McNemar p-value is below this
SMOKE_GOALS = 200  # below this many goals per set the answer is a smoke run, not a recommendation
KEY_ROWS = 8
BUDGETS_US = np.logspace(1, 4, 61)  # 10 µs .. 10 ms


def wilson(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion k / n, as fractions (NaN, NaN when n = 0)."""
    if n <= 0:
        return math.nan, math.nan
    p = k / n
    den = 1 + z * z / n
    mid = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return (0.0 if k == 0 else max(0.0, mid - half)), (1.0 if k == n else min(1.0, mid + half))


def worse_p(only_best: int, only_other: int) -> float:
    """One-sided exact McNemar p-value that a label is worse than the best on the goals both ran:
    ``only_best`` goals the best solved and the label did not, ``only_other`` the reverse; under
    "equally good" each such goal is a fair coin, so p = P(X >= only_best), X ~ Binomial(sum, 1/2)."""
    n = only_best + only_other
    if only_best == 0:
        return 1.0
    return sum(math.comb(n, i) for i in range(only_best, n + 1)) / (1 << n)  # exact ints: no overflow


def _p(x, q) -> float:
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    return float(np.percentile(x, q)) if x.size else float("nan")


def _kind(method: str) -> str:
    from pipeline.solvers import registry

    return registry.get(method).kind if method in registry.names() else "local"


def label_settings(archives) -> dict:
    """Solver label -> (method, non-default settings as a dict) from the archives' settings."""
    from pipeline.solvers import registry

    from pipeline.studies.common import archive_method

    out = {}
    for a in archives:
        label = a.metadata["solver"]
        if label in out:
            continue
        s = json.loads(a.metadata["settings"])
        method = archive_method(a)[0]
        s.pop("method", None)
        try:
            defaults = registry.get(method).settings().as_dict()
        except Exception:  # noqa: BLE001  (a method this machine does not register: keep every setting)
            defaults = {}
        out[label] = (method, {k: v for k, v in s.items() if k not in defaults or defaults[k] != v})
    return out


def job_timing(archives) -> dict:
    """Archive path -> (CPU s, wall s) of its job's solving (the archive's ``job_timing`` record)."""
    out = {}
    for a in archives:
        t = a.job_timing or {}
        try:
            out[str(a.path)] = (float(t["cpu_s"]), float(t["wall_s"]))
        except (KeyError, ValueError):
            continue
    return out


def _own_threads(method: str) -> bool:
    from pipeline.solvers import registry

    return method in registry.names() and registry.get(method).own_threads


def _job_shares(df: pd.DataFrame, timing: dict | None) -> dict:
    """Robot -> the CPU share [%] of its job (one job per robot runs every label of both sets,
    ``job_per_robot``): CPU / wall time summed over the solves of its single-threaded labels. A method
    with threads of its own (TRAC-IK) idles while its threads race and join, so its own CPU / wall
    time is no sign of starvation and is left out."""
    out = {}
    single = ~df["method"].map(_own_threads)
    for robot, g in df[single].groupby("robot", sort=False):
        cpu = g["cpu_time_s"].to_numpy(dtype=float) if "cpu_time_s" in g else np.full(len(g), np.nan)
        call = g["call_time_s"].to_numpy(dtype=float)
        ok = np.isfinite(cpu) & np.isfinite(call)
        if ok.any() and call[ok].sum() > 0:
            out[robot] = 100 * float(cpu[ok].sum() / call[ok].sum())
        else:  # archives without per-solve CPU time: the jobs' records (they include loading the kernels)
            jobs = [timing[a] for a in g["archive"].unique() if a in (timing or {})]
            out[robot] = 100 * sum(c for c, _ in jobs) / max(sum(w for _, w in jobs), 1e-12) if jobs else math.nan
    return out


def method_table(df: pd.DataFrame, meta: dict, timing: dict | None = None) -> pd.DataFrame:
    """One row per (robot, problem set, solver label). ``CPU share`` is the label's own CPU / wall time
    over its solves (shown); ``job CPU share`` its robot's job's (:func:`_job_shares`, which decides
    ``starved``); ``timing`` (:func:`job_timing`) serves archives without per-solve CPU time."""
    rows = []
    for (robot, pset, label), g in df.groupby(["robot", "problem_set", "solver"], sort=False):
        method = g["method"].iloc[0]
        library = g["library"].iloc[0] if "library" in g else "ours"
        settings = meta.get(label, (method, {}))[1]
        r = int(settings.get("restarts", 0) or 0)
        ok = g[g["success"].astype(bool)]
        k, n = int(g["success"].astype(bool).sum()), len(g)
        lo, hi = wilson(k, n)
        cpu = g["cpu_time_s"].to_numpy(dtype=float) if "cpu_time_s" in g else np.full(n, np.nan)
        call = g["call_time_s"].to_numpy(dtype=float)
        ok_t = np.isfinite(cpu) & np.isfinite(call)
        share = float(cpu[ok_t].sum() / call[ok_t].sum()) if ok_t.any() and call[ok_t].sum() > 0 else math.nan
        rows.append({
            "robot": robot, "problem set": pset, "solver": label, "method": method, "library": library,
            "kind": _kind(method), "search": f"restarts (<= {r})" if r else "single", "problems": n,
            "success [%]": 100 * k / n, "success CI low [%]": 100 * lo, "success CI high [%]": 100 * hi,
            "within limits [%]": 100 * g["within_limits"].astype(bool).mean(),
            "CPU time p50 [µs]": 1e6 * _p(cpu, 50), "CPU time p95 [µs]": 1e6 * _p(cpu, 95),
            "call time p50 [µs]": 1e6 * _p(call, 50), "call time p95 [µs]": 1e6 * _p(call, 95),
            "solve time p50 [µs]": 1e6 * _p(g["solve_time_s"], 50),
            "CPU share [%]": 100 * share,
            "iterations p50": _p(g["iterations"], 50),
            "joint distance to start p50, successes [rad]": _p(joint_distance(ok["q_solution"], ok["q_start"]), 50) if len(ok) else math.nan,
            "position error p99, successes [mm]": _p(ok["position_error_mm"], 99),
            "orientation error p99, successes [rad]": _p(ok["orientation_error"], 99),
        })
    out = pd.DataFrame(rows)
    out["job CPU share [%]"] = out["robot"].map(_job_shares(df, timing))
    out["starved"] = out["job CPU share [%]"] < 100 * MIN_CPU_SHARE  # NaN (not measured) is not starved
    out["success 95 % CI [%]"] = [f"{lo:.1f}-{hi:.1f}" for lo, hi in
                                  zip(out["success CI low [%]"], out["success CI high [%]"])]
    return out


def _ids(df: pd.DataFrame) -> dict:
    """(robot, problem set, label) -> Series success indexed by problem id (first repetition)."""
    out = {}
    for key, g in df[df["repetition"] == 0].groupby(["robot", "problem_set", "solver"], sort=False):
        out[key] = pd.Series(g["success"].astype(bool).to_numpy(), index=g["problem_id"].to_numpy())
    return out


def python_call(robot: str, method: str, settings: dict, robot_file: str = "") -> str:
    """The call a user copies: ``pipeline.solvers.solve`` with the label's non-default settings."""
    from pipeline.robots import ROBOT_FILES

    where = robot if (ROBOT_FILES / f"{robot}.yaml").is_file() or not robot_file else robot_file
    args = ", ".join(f"{k!r}: {v!r}" for k, v in sorted(settings.items()))
    return (f"solvers.solve({method!r}, robots.load_robot({where!r}), T_goal, q_start"
            + (f", {{{args}}})" if args else ")"))


def answers(mt: pd.DataFrame, df: pd.DataFrame, meta: dict, scale: str = "", robot_files: dict | None = None
            ) -> pd.DataFrame:
    """One recommendation per (robot, problem set) by the module's rule (see the module docstring)."""
    succ = _ids(df)
    rows = []
    for (robot, pset), g in mt.groupby(["robot", "problem set"], sort=False):
        starved = g[g["starved"]]
        cand = g[(g["problems"] >= MIN_SHARE * g["problems"].max()) & ~g["starved"]]
        smoke = scale == "quick" or int(g["problems"].max()) < SMOKE_GOALS
        base = {"robot": robot, "problem set": pset, "goals": int(g["problems"].max()),
                "starved labels": ", ".join(starved["solver"]), "smoke run": smoke}
        smoke_text = (f" Smoke run ({int(g['problems'].max())} goals at most, scale {scale or '?'}): the intervals "
                      f"are wide and most labels tie; not a recommendation." if smoke else "")
        if cand.empty:
            share = g["job CPU share [%]"].iloc[0]
            rows.append({**base, "recommendation": "", "answer": (
                f"{robot}, {pset} starts: no recommendation: the job solving this arm got {share:.0f} % of a core "
                f"(less than {MIN_CPU_SHARE:.0%}), so its times are not its own; rebuild on a quiet machine."
                + smoke_text)})
            continue
        best = cand.sort_values(["success [%]", "problems", "call time p50 [µs]"], ascending=[False, False, True]).iloc[0]
        b = succ.get((robot, pset, best["solver"]))
        ok_rows = []
        for _, c in cand.iterrows():
            s = succ.get((robot, pset, c["solver"]))
            common = s.index.intersection(b.index) if s is not None and b is not None else []
            if len(common) == 0:
                continue
            sc, sb = s.loc[common].to_numpy(), b.loc[common].to_numpy()
            if worse_p(int((sb & ~sc).sum()), int((sc & ~sb).sum())) >= ALPHA:
                ok_rows.append(c)
        pool = pd.DataFrame(ok_rows)
        closed = pool[pool["kind"] == "analytic"]
        pick = (closed if len(closed) else pool).sort_values(["call time p50 [µs]", "success [%]"],
                                                              ascending=[True, False]).iloc[0]
        method, settings = meta.get(pick["solver"], (pick["method"], {}))
        call = python_call(robot, method, settings, (robot_files or {}).get(robot, ""))
        text = (f"{robot}, {pset} starts: use {pick['solver']} ({method}, {pick['library']}"
                f"{', ' + ', '.join(f'{k}={v}' for k, v in sorted(settings.items())) if settings else ''}): "
                f"{pick['success [%]']:.1f} % of {int(pick['problems'])} goals "
                f"(95 % CI {pick['success CI low [%]']:.1f}-{pick['success CI high [%]']:.1f}), median "
                f"{pick['call time p50 [µs]']:.0f} µs per call (median wall time); the best rate is {best['solver']}'s "
                f"{best['success [%]']:.1f} %, and {len(pool)} label(s) are not significantly worse"
                f"{' (a closed form among them wins)' if len(closed) else ''}.")
        text += smoke_text
        if len(starved):
            text += f" Not ranked (job starved of CPU): {', '.join(starved['solver'])}."
        rows.append({**base, "recommendation": pick["solver"], "method": method, "library": pick["library"],
                     "settings": json.dumps(settings, sort_keys=True),
                     "success [%]": pick["success [%]"], "success CI low [%]": pick["success CI low [%]"],
                     "success CI high [%]": pick["success CI high [%]"], "its goals": int(pick["problems"]),
                     "call time p50 [µs]": pick["call time p50 [µs]"], "best rate label": best["solver"],
                     "best rate [%]": best["success [%]"], "not significantly worse": ", ".join(pool["solver"]),
                     "call": call, "answer": text})
    # the same columns whether or not any job got a recommendation (a loaded machine can starve them all)
    return pd.DataFrame(rows, columns=ANSWER_COLUMNS)


ANSWER_COLUMNS = ["robot", "problem set", "goals", "starved labels", "smoke run", "recommendation", "method", "library",
                  "settings", "success [%]", "success CI low [%]", "success CI high [%]", "its goals",
                  "call time p50 [µs]", "best rate label", "best rate [%]", "not significantly worse", "call", "answer"]


def key_labels(mt: pd.DataFrame, ans: pd.DataFrame, robot: str) -> list[str]:
    """At most :data:`KEY_ROWS` labels of one robot: the recommendations, then the best (success, then
    call time, on the cold set where it ran) of each group: closed form ours / peer, single search,
    restarts, TRAC-IK, the Robotics Toolbox's LM (single and restarts), Pinocchio's CLIK."""
    g = mt[mt["robot"] == robot]
    big = g["problems"] >= MIN_SHARE * g.groupby("problem set")["problems"].transform("max")
    order = g.assign(_cold=g["problem set"] != "cold", _few=~big).sort_values(
        ["_cold", "_few", "success [%]", "call time p50 [µs]"], ascending=[True, True, False, True])
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


def _scale(archives) -> str:
    scales = {a.metadata.get("scale", "") for a in archives}
    return scales.pop() if len(scales) == 1 else ", ".join(sorted(scales))


def _robot_files(archives) -> dict:
    return {a.metadata["robot"]: a.metadata.get("robot_file", "") for a in archives}


RULE = (f"Labels run on at least {MIN_SHARE:.0%} of a set's goals whose job (one per arm) got at least "
        f"{MIN_CPU_SHARE:.0%} of a core compete; the best is the highest success rate; a label is not significantly worse when, on the "
        f"goals both ran, a one-sided exact McNemar test does not find it worse at the {ALPHA:.0%} level; "
        f"intervals are Wilson 95 %; among those a "
        f"closed form wins, then the fastest by median wall time of the whole call (a median of many short calls "
        f"barely moves with machine load; starved jobs are flagged)."
        f" Success = pose within 0.1 mm and 1e-3 rad by an independent FK AND the returned angles "
        f"within the joint limits (revolute joints wrapped by 2 pi; 1e-6 rad tolerance for every method, "
        f"pipeline.solvers._kin.LIMIT_TOL).")

_FULL_COLUMNS = ["problem set", "solver", "library", "problems", "success [%]", "success 95 % CI [%]",
                 "within limits [%]", "call time p50 [µs]", "CPU share [%]", "iterations p50",
                 "position error p99, successes [mm]"]  # fits the report's text column (TABLE_BUDGET_PX)
_KEY_COLUMNS = ["solver", "problem set", "library", "problems", "success [%]", "success 95 % CI [%]",
                "call time p50 [µs]", "call time p95 [µs]", "CPU time p50 [µs]",
                "joint distance to start p50, successes [rad]", "position error p99, successes [mm]"]


def build_tables(study, archives, published_dir: Path) -> list[TableSpec]:
    df = runs_frame(archives)
    refused = _refusals(study)
    if df.empty:
        return [TableSpec("answer", "Answer", pd.DataFrame(), "No solve records in the archives.")]
    meta = label_settings(archives)
    mt = method_table(df, meta, job_timing(archives))
    ans = answers(mt, df, meta, _scale(archives), _robot_files(archives))
    tables = [TableSpec("answer", "Which method for which arm (from the archives)", ans,
                        f"Per robot and problem set, one recommendation. {RULE} The call column is the "
                        f"pipeline.solvers.solve() call with the label's settings that differ from the registry's "
                        f"defaults (T_goal: 4x4 pose in the robot file's unit; q_start: start angles).")]
    for robot, g in mt.groupby("robot", sort=False):
        keys = key_labels(mt, ans, robot)
        k = g[g["solver"].isin(keys)].copy()
        k["_o"] = k["solver"].map({s: i for i, s in enumerate(keys)})
        k = k.sort_values(["_o", "problem set"])[_KEY_COLUMNS].rename(columns={
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
            full[_FULL_COLUMNS].rename(columns={"problem set": "set", "problems": "goals",
                                                "iterations p50": "iter. p50",
                                                "position error p99, successes [mm]": "position error p99 [mm]"}),
            "Within limits = share of all returned solutions inside the limits. The key table above adds the 95th "
            "percentile of the call time and the CPU time; the per-sample file has every solve's. CPU time = CPU "
            "time of the whole pipeline.solvers.solve() call (the calling thread's; TRAC-IK: the process's); call time = its wall time (peers: their whole library call "
            "inside it); CPU share = CPU / wall time summed over the label's solves; job CPU share = the same over "
            "every single-threaded label of the arm's job (below 90 %: starved, nothing ranked; TRAC-IK idles "
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


def build_figures(study, archives, out_dir: Path) -> list[FigureSpec]:
    from pipeline.report.plotting import plt, save

    df = runs_frame(archives)
    if df.empty:
        return []
    meta = label_settings(archives)
    mt = method_table(df, meta, job_timing(archives))
    ans = answers(mt, df, meta, _scale(archives), _robot_files(archives))
    figs = []
    for pset, g in mt.groupby("problem set", sort=False):
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
        figs.append(FigureSpec(save(fig, out_dir, f"heatmap_{pset}", svg=False),
                               f"Success rate: methods x robots, {pset} starts",
                               "Share of goals with an FK-verified success within the joint limits, per solver label "
                               "(rows) and robot (columns); blank cells: the solver does not apply to that robot.",
                               extra={"answer": True}))
    for robot, g in mt.groupby("robot", sort=False):
        keys = key_labels(mt, ans, robot)
        sets = list(dict.fromkeys(g["problem set"]))
        fig, axes = plt.subplots(2, 2, figsize=(11, 7.6))
        colors = {s: plt.cm.tab10(i % 10) for i, s in enumerate(keys)}
        for ax, pset in zip(axes[0], sets[:2]):
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
        axes[0][0].legend(fontsize=7.5, loc="upper left", frameon=False)
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
        for ax, data, label in ((axes[1][0], data_t, "wall time per call [µs]"),
                                (axes[1][1], data_e, "position error of the successes [mm]")):
            ax.boxplot(data, vert=False, showfliers=False, whis=(5, 95))
            ax.set_yticks(np.arange(1, len(names) + 1), names, fontsize=8)
            ax.invert_yaxis()
            ax.set_xscale("log")
            ax.set_xlabel(label)
            ax.grid(alpha=0.3, axis="x")
        axes[1][1].set_yticklabels([])
        fig.suptitle(f"{robot}: the key methods (solid: ours, dashed: peer libraries; both sets pooled below)",
                     fontsize=11)
        figs.append(FigureSpec(save(fig, out_dir, f"budget_{robot}"), f"{robot}: solve rate within a time budget, "
                               "time and error distributions",
                               "Top: share of the set's goals an FK-verified success within the limits reached within "
                               "a time budget b (wall time of the whole call; a method's curve ends at its success "
                               "rate). Bottom (log scales; boxes: quartiles, whiskers: 5th-95th percentile): wall time "
                               "per call and position error of the successes, cold and warm sets pooled, for the "
                               "labels of the key table only.",
                               extra={"robot": robot}))
    return figs
