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

The rule (written once, here, and quoted in the tables' notes as :data:`RULE`)
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
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from pipeline.studies.specs import FigureSpec, TableSpec
from pipeline.studies.generic import joint_distance, runs_frame

MIN_SHARE = 0.1  # labels run on at least this share of a set's goals compete for the answer
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
    from pipeline.solvers.core import registry

    return registry.get(method).kind if method in registry.names() else "local"


def label_settings(archives) -> dict:
    """Solver label -> (method, non-default settings as a dict) from the archives' settings."""
    from pipeline.solvers.core import registry

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
    from pipeline.solvers.core import registry

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
    over its solves (shown); ``job CPU share`` its robot's job's (:func:`_job_shares`: the load record,
    shown beside the times, never a gate); ``timing`` (:func:`job_timing`) serves archives without per-solve CPU time."""
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
        dist = joint_distance(ok["q_solution"], ok["q_start"]) if len(ok) else np.array([])
        rows.append({
            "robot": robot, "problem set": pset, "solver": label, "method": method, "library": library,
            "kind": _kind(method), "search": f"restarts (<= {r})" if r else "single", "problems": n,
            "success [%]": 100 * k / n, "success CI low [%]": 100 * lo, "success CI high [%]": 100 * hi,
            "within limits [%]": 100 * g["within_limits"].astype(bool).mean(),
            "successes not nearest the seed": int(g["not nearest"].sum()) if "not nearest" in g else 0,
            "CPU time p50 [µs]": 1e6 * _p(cpu, 50), "CPU time p95 [µs]": 1e6 * _p(cpu, 95),
            "call time p50 [µs]": 1e6 * _p(call, 50), "call time p95 [µs]": 1e6 * _p(call, 95),
            "solve time p50 [µs]": 1e6 * _p(g["solve_time_s"], 50),
            "CPU share [%]": 100 * share,
            "iterations p50": _p(g["iterations"], 50),
            "joint distance to start p50, successes [rad]": _p(dist, 50),
            "joint distance to start p95, successes [rad]": _p(dist, 95),
            "position error p99, successes [mm]": _p(ok["position_error_mm"], 99),
            "orientation error p99, successes [rad]": _p(ok["orientation_error"], 99),
        })
    out = pd.DataFrame(rows)
    out["job CPU share [%]"] = out["robot"].map(_job_shares(df, timing))  # the load record: shown, never a gate
    out["success 95 % CI [%]"] = [f"{lo:.1f}-{hi:.1f}" for lo, hi in
                                  zip(out["success CI low [%]"], out["success CI high [%]"])]
    return out


def _ids(df: pd.DataFrame) -> dict:
    """(robot, problem set, label) -> Series success indexed by problem id (first repetition)."""
    out = {}
    for key, g in df[df["repetition"] == 0].groupby(["robot", "problem_set", "solver"], sort=False):
        out[key] = pd.Series(g["success"].astype(bool).to_numpy(), index=g["problem_id"].to_numpy())
    return out


# plain words for the answer table: registered method -> what a robotics engineer calls it
WORDS = {
    "analytic": "closed form", "analytic_ur": "closed form for UR arms (Hawkins)",
    "analytic_puma": "closed form for PUMA-type arms", "analytic_4dof": "closed form of the 4-DOF arm",
    "general_6r": "closed form by algebraic elimination", "eaik": "closed form (EAIK)", "ik_geo": "closed form (IK-Geo)",
    "ur_analytic_ik": "closed form for UR arms (ur_analytic_ik)", "jacobian_transpose": "Jacobian transpose",
    "pseudoinverse": "Jacobian pseudoinverse", "dls": "damped least squares",
    "sdls": "selectively damped least squares", "inverse_jacobian_fd": "inverse Jacobian (finite differences)",
    "levenberg_marquardt": "Levenberg-Marquardt", "jpinv_descent": "pseudoinverse gradient descent",
    "bfgs": "BFGS", "lbfgsb": "L-BFGS-B", "nelder_mead": "Nelder-Mead", "zero_position": "Zero-Position method",
    "newton_raphson": "Newton-Raphson", "pso": "particle swarm", "rtb_ik_lm": "Levenberg-Marquardt (Robotics Toolbox)",
    "rtb_ik_nr": "Newton-Raphson (Robotics Toolbox)", "rtb_ik_gn": "Gauss-Newton (Robotics Toolbox)",
    "pinocchio_clik": "closed-loop IK (Pinocchio)", "trac_ik": "TRAC-IK",
}


def in_words(method: str, settings: dict, dof: int, kind: str) -> str:
    """A label in plain words: "closed form, all solutions", "closed form, 1 free joint swept",
    "damped least squares, 20 random restarts"."""
    words = WORDS.get(method, method.replace("_", " "))
    if kind == "analytic":
        return words + (", 1 free joint swept" if dof == 7 else ", all solutions")
    r = int(settings.get("restarts", 0) or 0)
    if method == "trac_ik":
        return f"{words}, {1e3 * float(settings.get('timeout', 0.005)):.0f} ms budget"
    return words + (f", {r} random restarts" if r else ", one search")


def python_call(robot: str, method: str, settings: dict, robot_file: str = "", warm: bool = False,
                goals: int = 1000) -> str:
    """The program a user copies: the robot loaded once, the solver bound once with the label's settings
    (those that differ from the registry's defaults), then a loop solving ``goals`` goals (drawn here from
    random angles: replace them with yours), its first call (which compiles or loads the method's kernels)
    left out of the printed median. ``warm``: each start lies within 0.3 rad of its goal's angles."""
    from pipeline.robots import ROBOT_FILES

    where = robot if (ROBOT_FILES / f"{robot}.yaml").is_file() or not robot_file else robot_file
    args = ", ".join(f"{k!r}: {v!r}" for k, v in sorted(settings.items()))
    start = ("np.clip(q + rng.uniform(-0.3, 0.3, robot.n), lo, hi))  # a seed near the answer (tracking)" if warm
             else "rng.uniform(lo, hi))  # any start within the limits")
    return "\n".join([
        "import time",
        "",
        "import numpy as np",
        "",
        "from pipeline import robots, solvers",
        "from pipeline.kinematics import fk_htm",
        "",
        f"robot = robots.load_robot({where!r})  # once: a shipped arm's name or a robot file's path",
        f"ik = solvers.bind({method!r}, robot" + (f", {{{args}}})" if args else ")") + "  # once: method and settings",
        "lo, hi = np.clip(robot.limits, -np.pi, np.pi).T",
        "rng = np.random.default_rng(0)",
        "goals, starts = [], []  # your goals: 4x4 poses in the robot file's length unit",
        f"for q in rng.uniform(lo, hi, ({goals}, robot.n)):",
        "    goals.append(fk_htm(robot.chain, q))",
        f"    starts.append({start}",
        "ik.solve(goals[0], starts[0])  # the first call compiles or loads the kernels: not timed",
        "times, solved = [], 0",
        "for T_goal, q_start in zip(goals, starts):",
        "    t0 = time.perf_counter()",
        "    res = ik.solve(T_goal, q_start)  # res.q: joint angles [rad]; res.success: checked by FK",
        "    times.append(time.perf_counter() - t0)",
        "    solved += bool(res.success)",
        "print(f\"solved {solved} of {len(goals)}, median {1e6 * np.median(times):.1f} us per call\")",
    ])


TIE_RATIO = 1.15  # a finalist whose race time is within this factor of the fastest's ties with it (see RULE)
TRACK_FACTOR = 2.0  # warm sets: a median distance to the seed above this times the smallest is not for tracking
RACE_TOPIC = "/arm_benchmark/race"  # one JSON record per timed call (pipeline.jobs.race)
RACE_SET_TOPIC = "/arm_benchmark/race_set"  # one JSON record per (robot, problem set): who raced, the load


def is_warm(pset: str, warm_sets=None) -> bool:
    """Whether a problem set's starts are seeds near the answer (kind ``warm_start``); without the
    study's list, a set named ``warm``."""
    return pset in warm_sets if warm_sets is not None else pset == "warm"


def shortlist(g: pd.DataFrame, succ: dict, robot: str, pset: str, warm: bool) -> dict:
    """The labels of one (robot, problem set) that may be recommended, from the archives alone.

    ``g``: the set's rows of :func:`method_table`. Returns ``best`` (the highest success rate: more
    goals, then the label name break ties), ``pool`` (labels run on at least ``MIN_SHARE`` of the
    goals and not significantly worse than the best), ``far`` (warm sets: pool labels whose median
    distance to the seed is above ``TRACK_FACTOR`` times the pool's smallest: not for tracking),
    ``finalists`` (the closed forms left, else every label left) and ``closed`` (whether a closed form
    is among them). No timing enters here."""
    cand = g[g["problems"] >= MIN_SHARE * g["problems"].max()]
    best = cand.sort_values(["success [%]", "problems", "solver"], ascending=[False, False, True]).iloc[0]
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
    far = pool.iloc[0:0]
    left = pool
    if warm and len(pool):
        dist = pool["joint distance to start p50, successes [rad]"].astype(float)
        if dist.notna().any():
            far = pool[dist > TRACK_FACTOR * dist.min()]
            left = pool[~pool["solver"].isin(far["solver"])]
    closed = left[left["kind"] == "analytic"]
    finalists = closed if len(closed) else left
    return {"best": best, "pool": pool, "far": far, "finalists": finalists, "closed": bool(len(closed))}


def race_summary(calls: pd.DataFrame) -> pd.DataFrame:
    """Per (robot, problem set, label) of a race (:mod:`pipeline.jobs.race`): each goal's time is the
    fastest of its passes (a call the machine preempted is only slower); the label's time is the median
    over goals, and its ratio to the fastest label is the median of the paired per-goal ratios with a
    distribution-free 95 % interval (order statistics of the binomial)."""
    cols = ["robot", "problem set", "solver", "race goals", "passes", "race time p50 [µs]", "race time p95 [µs]",
            "race CPU time p50 [µs]", "ratio to fastest p50", "ratio CI low", "ratio CI high"]
    if calls is None or calls.empty:
        return pd.DataFrame(columns=cols)
    per = calls.groupby(["robot", "problem_set", "solver", "problem_id"], sort=False).agg(
        wall=("wall_ns", "min"), cpu=("cpu_ns", "min"), passes=("pass", "nunique")).reset_index()
    rows = []
    for (robot, pset), g in per.groupby(["robot", "problem_set"], sort=False):
        wide = g.pivot_table(index="problem_id", columns="solver", values="wall", sort=False).dropna()
        med = wide.median()
        lead = med.idxmin()
        for label in wide.columns:
            r = np.sort((wide[label] / wide[lead]).to_numpy(dtype=float))
            n = len(r)
            k = int(max(0, math.floor(n / 2 - Z95 * math.sqrt(n) / 2)))
            u = int(min(n - 1, math.ceil(n / 2 + Z95 * math.sqrt(n) / 2)))
            h = g[g["solver"] == label]
            rows.append({"robot": robot, "problem set": pset, "solver": label, "race goals": n,
                         "passes": int(h["passes"].max()), "race time p50 [µs]": 1e-3 * float(np.median(wide[label])),
                         "race time p95 [µs]": 1e-3 * float(np.percentile(wide[label], 95)),
                         "race CPU time p50 [µs]": 1e-3 * float(np.median(h["cpu"])),
                         "ratio to fastest p50": float(np.median(r)), "ratio CI low": float(r[k]) if n else math.nan,
                         "ratio CI high": float(r[u]) if n else math.nan})
    return pd.DataFrame(rows, columns=cols)


def pick_fastest(fin: pd.DataFrame, times: dict) -> tuple[str, set]:
    """The recommendation among ``fin`` (finalist rows) given each label's time (``times``: label -> µs,
    the race's ratio-consistent median where raced): the labels within ``TIE_RATIO`` of the fastest tie,
    and a tie goes to our own library first (nothing more to install), then the label's name, so that
    load that moves two near-equal times cannot move the answer. Returns (label, the tied labels)."""
    t = {lab: times.get(lab, math.nan) for lab in fin["solver"]}
    finite = {k: v for k, v in t.items() if np.isfinite(v)}
    if not finite:
        tied = set(fin["solver"])
    else:
        fastest = min(finite.values())
        tied = {k for k, v in finite.items() if v <= TIE_RATIO * fastest}
    lib = dict(zip(fin["solver"], fin["library"]))
    return sorted(tied, key=lambda k: (lib[k] != "ours", k))[0], tied


def answers(mt: pd.DataFrame, df: pd.DataFrame, meta: dict, scale: str = "", robot_files: dict | None = None,
            race: pd.DataFrame | None = None, race_sets: dict | None = None, warm_sets=None) -> pd.DataFrame:
    """One recommendation per (robot, problem set) by the module's rule (see the module docstring).

    ``race``: :func:`race_summary` of the arms' races (None or empty: times from the solve archives,
    which were timed in separate jobs, and the answer says so); ``race_sets``: (robot, set) -> the race's
    record (goals, passes, load); ``warm_sets``: the problem sets of kind ``warm_start``."""
    succ = _ids(df)
    race = race if race is not None else pd.DataFrame(columns=["robot", "problem set", "solver"])
    dofs = df.groupby("robot")["q_start"].first().map(len).to_dict() if "q_start" in df else {}
    rows = []
    for (robot, pset), g in mt.groupby(["robot", "problem set"], sort=False):
        warm = is_warm(pset, warm_sets)
        smoke = scale == "quick" or int(g["problems"].max()) < SMOKE_GOALS
        sl = shortlist(g, succ, robot, pset, warm)
        best, pool, far, fin = sl["best"], sl["pool"], sl["far"], sl["finalists"]
        rs = race[(race["robot"] == robot) & (race["problem set"] == pset)]
        raced = set(rs["solver"]) >= set(fin["solver"]) and len(fin) > 1
        if raced:
            r_by = rs.set_index("solver")
            lead_t = float(r_by["race time p50 [µs]"].min())
            times = {lab: lead_t * float(r_by.loc[lab, "ratio to fastest p50"]) for lab in fin["solver"]}
        else:
            times = dict(zip(fin["solver"], fin["call time p50 [µs]"]))
        label, tied = pick_fastest(fin, times)
        pick = fin[fin["solver"] == label].iloc[0]
        method, settings = meta.get(label, (pick["method"], {}))
        dof = int(dofs.get(robot, 0))
        words = in_words(method, settings, dof, pick["kind"])
        rec = race_sets.get((robot, pset), {}) if race_sets else {}
        if len(fin) == 1:
            how = ("the only " + ("closed form" if sl["closed"] else "label") + " left: no timing decides; its median "
                   "call time is from the solve archive")
            t_med = float(pick["call time p50 [µs]"])
        elif raced:
            rr = rs.set_index("solver").loc[label]
            how = (f"raced against {len(fin) - 1} other finalist(s) in one process, interleaved in shuffled order "
                   f"({int(rr['race goals'])} goals x {int(rr['passes'])} passes, each goal's fastest pass; load "
                   f"average {rec.get('load_start', '?')} -> {rec.get('load_end', '?')} on {rec.get('cores', '?')} "
                   f"cores)" + (f"; tied within {TIE_RATIO:.2f}x: {', '.join(sorted(tied))} (ours first, then by name)"
                                if len(tied) > 1 else ""))
            t_med = float(times[label])
        else:
            how = ("not raced (no race archive): median call times of the solve jobs, timed in separate jobs"
                   + (f"; tied within {TIE_RATIO:.2f}x: {', '.join(sorted(tied))}" if len(tied) > 1 else ""))
            t_med = float(pick["call time p50 [µs]"])
        dist = float(pick["joint distance to start p50, successes [rad]"])
        dist95 = float(pick.get("joint distance to start p95, successes [rad]", math.nan))
        base = {"robot": robot, "problem set": pset, "goals": int(g["problems"].max()), "smoke run": smoke}
        smoke_text = (f" Smoke run ({int(g['problems'].max())} goals at most, scale {scale or '?'}): the intervals "
                      f"are wide and most labels tie." if smoke else "")
        text = (f"{robot}, {pset} starts: use {words} ({label}, {pick['library']}): "
                f"{pick['success [%]']:.1f} % of {int(pick['problems'])} goals "
                f"(95 % CI {pick['success CI low [%]']:.1f}-{pick['success CI high [%]']:.1f}), median "
                f"{t_med:.0f} µs per call ({how})"
                + (f", median {dist:.2f} rad from the seed" if warm and np.isfinite(dist) else "")
                + f". The best rate is {best['solver']}'s {best['success [%]']:.1f} %; {len(pool)} label(s) are not "
                  f"significantly worse" + (" and a closed form among them wins" if sl["closed"] else "") + ".")
        if len(far):
            text += (" Not recommended for tracking (median distance to the seed more than "
                     f"{TRACK_FACTOR:.0f}x the smallest, "
                     f"{float(pool['joint distance to start p50, successes [rad]'].min()):.2f} rad): "
                     + ", ".join(f"{r['solver']} ({float(r['joint distance to start p50, successes [rad]']):.2f} rad)"
                                 for _, r in far.iterrows()) + ".")
        text += smoke_text
        call = python_call(robot, method, settings, (robot_files or {}).get(robot, ""), warm)
        rows.append({**base, "recommendation": label, "in words": words, "method": method,
                     "library": pick["library"], "settings": json.dumps(settings, sort_keys=True),
                     "success [%]": pick["success [%]"], "success CI low [%]": pick["success CI low [%]"],
                     "success CI high [%]": pick["success CI high [%]"], "its goals": int(pick["problems"]),
                     "call time p50 [µs]": t_med, "timing": how,
                     "distance to seed p50 [rad]": dist if warm else math.nan,
                     "distance to seed p95 [rad]": dist95 if warm else math.nan,
                     "best rate label": best["solver"], "best rate [%]": best["success [%]"],
                     "not significantly worse": ", ".join(pool["solver"]),
                     "not for tracking": ", ".join(far["solver"]), "finalists": ", ".join(fin["solver"]),
                     "call": call, "answer": text})
    return pd.DataFrame(rows, columns=ANSWER_COLUMNS)


ANSWER_COLUMNS = ["robot", "problem set", "goals", "smoke run", "recommendation", "in words", "method", "library",
                  "settings", "success [%]", "success CI low [%]", "success CI high [%]", "its goals",
                  "call time p50 [µs]", "timing", "distance to seed p50 [rad]", "distance to seed p95 [rad]",
                  "best rate label", "best rate [%]", "not significantly worse", "not for tracking", "finalists",
                  "call", "answer"]


def plain_table(ans: pd.DataFrame) -> pd.DataFrame:
    """The answer in plain words, one row per arm and start set (what the report opens with)."""
    return pd.DataFrame({
        "arm": ans["robot"], "starts": ans["problem set"], "method": ans["in words"], "library": ans["library"],
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


def _refusals(study) -> pd.DataFrame:
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
        if a is None or model is None or _kind(a.metadata.get("method", "")) != "analytic":
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


def warm_sets(study) -> set:
    """The study's problem sets whose starts are seeds near the answer (kind ``warm_start``)."""
    return {k for k, v in study.problem_sets.items() if v.get("kind") == "warm_start"}


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
    refused = _refusals(study)
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
                        f"differ from the registry's defaults, then a loop over 1 000 goals (tests/test_answer_calls.py "
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


def build_figures(study, archives, out_dir: Path) -> list[FigureSpec]:
    from pipeline.report.plotting import plt, save

    df = runs_frame(archives)
    if df.empty:
        return []
    meta = label_settings(archives)
    df = answer_frame(df, archives, study)
    mt = method_table(df, meta, job_timing(archives))
    calls, race_sets = race_records(archives)
    ans = answers(mt, df, meta, _scale(archives), _robot_files(archives), race_summary(calls), race_sets,
                  warm_sets(study))
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
