"""The arm benchmark's recommendation rule (:mod:`pipeline.studies.arm_benchmark` states it and builds the
tables): success intervals and the paired test, the per-label method table, the shortlist, the race
summary, the tie-break and the answer rows. Read by the tables and by the race job (:mod:`pipeline.jobs.race`).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd

from pipeline.studies.generic import joint_distance

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


def percentile(x, q) -> float:
    """The ``q``-th percentile of the finite values of ``x`` (NaN when there are none)."""
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    return float(np.percentile(x, q)) if x.size else float("nan")


def method_kind(method: str) -> str:
    """The registry kind of a method (``analytic``, ``local``, ...); ``local`` for one not registered."""
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
        version = g["library_version"].iloc[0] if "library_version" in g else ""
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
            "library version": version, "kind": method_kind(method),
            "search": f"restarts (<= {r})" if r else "single", "problems": n,
            "success [%]": 100 * k / n, "success CI low [%]": 100 * lo, "success CI high [%]": 100 * hi,
            "within limits [%]": 100 * g["within_limits"].astype(bool).mean(),
            "successes not nearest the seed": int(g["not nearest"].sum()) if "not nearest" in g else 0,
            "CPU time p50 [µs]": 1e6 * percentile(cpu, 50), "CPU time p95 [µs]": 1e6 * percentile(cpu, 95),
            "call time p50 [µs]": 1e6 * percentile(call, 50), "call time p95 [µs]": 1e6 * percentile(call, 95),
            "solve time p50 [µs]": 1e6 * percentile(g["solve_time_s"], 50),
            "CPU share [%]": 100 * share,
            "iterations p50": percentile(g["iterations"], 50),
            "joint distance to start p50, successes [rad]": percentile(dist, 50),
            "joint distance to start p95, successes [rad]": percentile(dist, 95),
            "position error p99, successes [mm]": percentile(ok["position_error_mm"], 99),
            "orientation error p99, successes [rad]": percentile(ok["orientation_error"], 99),
        })
    out = pd.DataFrame(rows)
    out["job CPU share [%]"] = out["robot"].map(_job_shares(df, timing))  # the load record: shown, never a gate
    out["success 95 % CI [%]"] = [f"{lo:.1f}-{hi:.1f}" for lo, hi in
                                  zip(out["success CI low [%]"], out["success CI high [%]"])]
    return out


def success_by_problem(df: pd.DataFrame) -> dict:
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
    "pybullet_ik": "damped least squares (pybullet)", "ikpy": "ikpy (SciPy least squares)",
    "pink": "differential IK by QP (pink)", "mink": "differential IK by QP (mink)", "placo": "placo",
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
    limits = settings.get("search_limits", "off")
    if limits != "off":
        words += ", kept within the limits" + (" (reflected)" if limits == "reflect" else " (clamped)")
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
    succ = success_by_problem(df)
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
                     "library": pick["library"], "library version": pick.get("library version", ""),
                     "settings": json.dumps(settings, sort_keys=True),
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
                  "library version",
                  "settings", "success [%]", "success CI low [%]", "success CI high [%]", "its goals",
                  "call time p50 [µs]", "timing", "distance to seed p50 [rad]", "distance to seed p95 [rad]",
                  "best rate label", "best rate [%]", "not significantly worse", "not for tracking", "finalists",
                  "call", "answer"]


def warm_sets(study) -> set:
    """The study's problem sets whose starts are seeds near the answer (kind ``warm_start``)."""
    return {k for k, v in study.problem_sets.items() if v.get("kind") == "warm_start"}
