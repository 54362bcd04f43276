"""The arm benchmark's recommendation rule (pipeline.studies.arm_benchmark), on synthetic solve frames."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.studies import arm_benchmark as ab


def _frame(rows):
    """rows: (label, method, library, successes (bool list), cpu µs, archive) -> a runs_frame-like frame."""
    out = []
    for label, method, library, ok, cpu, arch in rows:
        for i, s in enumerate(ok):
            out.append({"robot": "arm", "problem_set": "cold", "solver": label, "method": method, "library": library,
                        "problem_id": i, "repetition": 0, "success": bool(s), "within_limits": bool(s),
                        "solve_time_s": cpu * 1e-6, "call_time_s": cpu * 1e-6, "cpu_time_s": cpu * 1e-6,
                        "iterations": 1, "position_error_mm": 1e-6, "orientation_error": 1e-9,
                        "q_solution": [0.1, 0.2], "q_start": [0.0, 0.0], "archive": arch})
    return pd.DataFrame(out)


def _answer(rows, timing=None, scale="full"):
    df = _frame(rows)
    meta = {r[0]: (r[1], {}) for r in rows}
    mt = ab.method_table(df, meta, timing)
    return ab.answers(mt, df, meta, scale).iloc[0], mt


@given(st.integers(0, 400), st.integers(1, 400))
@settings(max_examples=200, deadline=None)
def test_wilson_interval_holds_the_rate_and_stays_in_0_1(k, n):
    k = min(k, n)
    lo, hi = ab.wilson(k, n)
    assert 0.0 <= lo <= k / n <= hi <= 1.0
    assert hi - lo <= ab.wilson(k, n, z=3.0)[1] - ab.wilson(k, n, z=3.0)[0] + 1e-12


def test_wilson_matches_a_known_value():
    lo, hi = ab.wilson(50, 50)  # 50 of 50: the classic 92.9 % lower bound
    assert math.isclose(lo, 0.928652, abs_tol=1e-6) and hi == 1.0


def test_a_closed_form_wins_among_labels_not_significantly_worse():
    n = 2000
    rows = [("analytic", "analytic", "ours", [True] * n, 20.0, "a"),
            ("dls", "dls", "ours", [True] * (n - 4) + [False] * 4, 8.0, "b")]  # 4 lost goals: p = 1/16
    ans, _ = _answer(rows)
    assert ans["recommendation"] == "analytic" and "closed form among them wins" in ans["answer"]


def test_a_significantly_worse_fast_label_is_not_recommended():
    n = 2000
    rows = [("analytic", "analytic", "ours", [True] * n, 20.0, "a"),
            ("dls", "dls", "ours", [True] * (n - 30) + [False] * 30, 8.0, "b")]  # 98.5 % of 2 000
    ans, _ = _answer(rows)
    assert ans["recommendation"] == "analytic"
    assert ans["not significantly worse"] == "analytic"


def test_fastest_wins_among_iterative_labels_that_tie():
    n = 200
    rows = [("lm", "levenberg_marquardt", "ours", [True] * n, 50.0, "a"),
            ("dls_restarts", "dls", "ours", [True] * (n - 1) + [False], 12.0, "b"),
            ("trac_ik", "trac_ik", "pytracik", [True] * n, 30.0, "c")]
    ans, _ = _answer(rows)
    assert ans["recommendation"] == "dls_restarts" and not ans["smoke run"]


def test_rates_are_compared_on_the_goals_both_ran():
    # the best ran 2 000 goals; a label ran only the first 300 (all solved): judged on those 300; one run on
    # fewer than a tenth of the goals does not compete
    rows = [("sdls", "sdls", "ours", [True] * 1900 + [False] * 100, 40.0, "a"),
            ("bfgs", "bfgs", "ours", [True] * 300, 5.0, "b"), ("pso", "pso", "ours", [True] * 100, 1.0, "c")]
    ans, mt = _answer(rows)
    assert ans["recommendation"] == "bfgs" and ans["best rate label"] == "bfgs"
    assert mt.set_index("solver").loc["bfgs", "problems"] == 300


def test_mcnemar_p_values():
    assert ab.worse_p(0, 5) == 1.0 and ab.worse_p(1, 0) == 0.5
    assert math.isclose(ab.worse_p(5, 0), 1 / 32) and ab.worse_p(4, 0) == 1 / 16
    assert math.isclose(ab.worse_p(3, 1), 5 / 16)
    assert ab.worse_p(1500, 1500) == pytest.approx(0.5, abs=0.02) and ab.worse_p(3000, 0) == 0.0  # 2 000+ goals


def test_a_busy_machine_never_withholds_the_answer():
    rows = [("analytic", "analytic", "ours", [True] * 300, 20.0, "a"),
            ("dls", "dls", "ours", [True] * 300, 8.0, "b"),
            ("trac_ik", "trac_ik", "pytracik", [True] * 300, 300.0, "c")]
    df = _frame(rows)
    df.loc[df["solver"] == "trac_ik", "call_time_s"] *= 3  # TRAC-IK idles while its threads race
    meta = {r[0]: (r[1], {}) for r in rows}
    mt = ab.method_table(df, meta)
    assert mt.set_index("solver").loc["trac_ik", "CPU share [%]"] == pytest.approx(100 / 3)
    df["call_time_s"] = df["cpu_time_s"] * 4  # the whole job got a quarter of a core
    mt = ab.method_table(df, meta)
    ans = ab.answers(mt, df, meta, "full").iloc[0]
    assert mt["job CPU share [%]"].iloc[0] == pytest.approx(25)  # recorded, shown
    assert ans["recommendation"] == "analytic" and "closed form" in ans["in words"]


def test_the_jobs_record_serves_archives_without_per_solve_cpu_time():
    rows = [("analytic", "analytic", "ours", [True] * 300, 20.0, "a")]
    df = _frame(rows)
    df["cpu_time_s"] = np.nan
    mt = ab.method_table(df, {"analytic": ("analytic", {})}, {"a": (1.0, 2.0)})
    assert mt.iloc[0]["job CPU share [%]"] == 50.0


def _race(times: dict, goals: int = 40, passes: int = 3, noise=None, robot="arm", pset="cold"):
    """Race records: label -> µs per call; ``noise(label, goal, pass) -> factor >= 1`` (load)."""
    out = []
    for p in range(passes):
        for g in range(goals):
            for lab, t in times.items():
                f = noise(lab, g, p) if noise else 1.0
                out.append({"robot": robot, "problem_set": pset, "solver": lab, "problem_id": g, "pass": p,
                            "wall_ns": int(1e3 * t * f * (1 + 0.01 * (g % 5))), "cpu_ns": int(1e3 * t),
                            "success": True})
    return pd.DataFrame(out)


def test_the_race_decides_not_the_solve_jobs_times():
    # the solve jobs (separate moments, load on one) say eaik is faster; the interleaved race says analytic
    rows = [("analytic", "analytic", "ours", [True] * 300, 90.0, "a"),
            ("eaik", "eaik", "eaik", [True] * 300, 20.0, "b")]
    df = _frame(rows)
    meta = {r[0]: (r[1], {}) for r in rows}
    mt = ab.method_table(df, meta)
    race = ab.race_summary(_race({"analytic": 12.0, "eaik": 60.0}))
    ans = ab.answers(mt, df, meta, "full", race=race, race_sets={("arm", "cold"): {"load_start": "5.0"}}).iloc[0]
    assert ans["recommendation"] == "analytic" and "raced" in ans["timing"] and "5.0" in ans["timing"]
    assert ans["call time p50 [µs]"] == pytest.approx(12.0, rel=0.05)
    r = race.set_index("solver")
    assert r.loc["eaik", "ratio to fastest p50"] == pytest.approx(5.0, rel=0.01)
    assert r.loc["eaik", "ratio CI low"] <= 5.0 <= r.loc["eaik", "ratio CI high"]


def test_a_tie_goes_to_our_library_then_the_name():
    fin = pd.DataFrame({"solver": ["ur_analytic_ik", "analytic_ur", "analytic"],
                        "library": ["ur-analytic-ik", "ours", "ours"]})
    assert ab.pick_fastest(fin, {"ur_analytic_ik": 10.0, "analytic_ur": 10.5, "analytic": 10.9}) == \
        ("analytic", {"ur_analytic_ik", "analytic_ur", "analytic"})
    assert ab.pick_fastest(fin, {"ur_analytic_ik": 10.0, "analytic_ur": 12.0, "analytic": 13.0})[0] == "ur_analytic_ik"


@given(st.lists(st.tuples(st.integers(0, 39), st.integers(1, 2), st.floats(1.0, 50.0)), max_size=200),
       st.sampled_from(["analytic", "eaik", "ik_geo"]))
@settings(max_examples=60, deadline=None)
def test_load_on_some_passes_does_not_move_the_race(hits, victim):
    """Load slows some calls (any label, any goal, passes 1-2): each goal keeps its fastest pass, so while
    pass 0 of every goal ran unloaded the race gives the same answer."""
    times = {"analytic": 12.0, "eaik": 18.0, "ik_geo": 11.5}
    slow = {(victim, g, p): f for g, p, f in hits}
    quiet = ab.race_summary(_race(times))
    busy = ab.race_summary(_race(times, noise=lambda lab, g, p: slow.get((lab, g, p), 1.0)))
    fin = pd.DataFrame({"solver": list(times), "library": ["ours", "eaik", "ik-geo"]})

    def pick(r):
        lead = r["race time p50 [µs]"].min()
        return ab.pick_fastest(fin, dict(zip(r["solver"], lead * r["ratio to fastest p50"])))[0]

    assert pick(quiet) == pick(busy) == "analytic"  # ik_geo within 1.15x of analytic: ours wins the tie


def test_warm_sets_weigh_the_distance_to_the_seed():
    n = 300
    rows = [("analytic", "analytic", "ours", [True] * n, 20.0, "a"),
            ("dls_restarts", "dls", "ours", [True] * n, 40.0, "b")]
    df = _frame(rows)
    df["problem_set"] = "warm"
    df.loc[df["solver"] == "analytic", "q_solution"] = pd.Series([[1.5, 1.5]] * n,
                                                                 index=df.index[df["solver"] == "analytic"])
    meta = {r[0]: (r[1], {}) for r in rows}
    mt = ab.method_table(df, meta)
    ans = ab.answers(mt, df, meta, "full").iloc[0]
    assert ans["recommendation"] == "dls_restarts" and ans["not for tracking"] == "analytic"
    assert "Not recommended for tracking" in ans["answer"] and ans["distance to seed p50 [rad]"] == pytest.approx(
        math.hypot(0.1, 0.2))


def test_key_rows_come_from_labels_run_on_200_goals():
    rows = [("analytic", "analytic", "ours", [True] * 2000, 20.0, "a"),
            ("nelder_mead", "nelder_mead", "ours", [True] * 10, 9000.0, "b"),
            ("dls", "dls", "ours", [True] * 1800 + [False] * 200, 30.0, "c")]
    ans, mt = _answer(rows)
    keys = ab.key_labels(mt, pd.DataFrame([ans]), "arm")
    assert "nelder_mead" not in keys and "dls" in keys


def test_quick_scale_says_smoke_run():
    rows = [("analytic", "analytic", "ours", [True] * 50, 20.0, "a")]
    ans, _ = _answer(rows, scale="quick")
    assert ans["smoke run"] and "Smoke run" in ans["answer"]


def test_library_and_method_come_from_the_frame_not_settings():
    rows = [("rtb_ik_lm", "rtb_ik_lm", "roboticstoolbox-python", [True] * 10, 80.0, "a")]
    _, mt = _answer(rows)
    r = mt.iloc[0]
    assert r["method"] == "rtb_ik_lm" and r["library"] == "roboticstoolbox-python"


def test_python_call_names_a_shipped_arm_or_the_file():
    call = ab.python_call("ur5e", "analytic", {"require_limits": True})
    assert "robots.load_robot('ur5e')" in call and "solvers.bind('analytic', robot, {'require_limits': True})" in call
    call = ab.python_call("my_arm", "dls", {}, "/x/my_arm.yaml", warm=True)
    assert "robots.load_robot('/x/my_arm.yaml')" in call and "solvers.bind('dls', robot)" in call
    assert "rng.uniform(-0.3, 0.3" in call
    compile(call, "call", "exec")


def test_registry_refuses_a_setting_named_method():
    from dataclasses import dataclass

    from pipeline.solvers.core import registry
    from pipeline.solvers.core import Settings, setting

    @dataclass(frozen=True)
    class Bad(Settings):
        method: str = setting("x", "clashes with the solver name")

    with pytest.raises(ValueError, match="may not be called 'method'"):
        registry.register(registry.Solver("bad_one", "t", "local", Bad, lambda *a: None))
    assert "bad_one" not in registry.names()


def test_every_peer_has_its_library_and_ours_say_ours():
    from pipeline.solvers.core import registry

    libs = {n: registry.get(n).library for n in registry.names()}
    assert libs["rtb_ik_lm"] == "roboticstoolbox-python" and libs["trac_ik"] == "pytracik"
    assert libs["eaik"] == "eaik" and libs["ur_analytic_ik"] == "ur-analytic-ik"
    assert libs["dls"] == "ours" and libs["analytic"] == "ours"
    assert registry.get("trac_ik").own_threads and not registry.get("dls").own_threads


def test_limit_tolerance_admits_float32_rounding_only():
    from pipeline.solvers.core import within_limits

    lim = np.array([[-1.0, 1.0]])
    prism = np.array([False])
    assert within_limits(np.array([1.0 + 1e-7]), lim, prism)
    assert not within_limits(np.array([1.0 + 1e-5]), lim, prism)
    assert within_limits(np.array([np.float32(2.8973) + 0.0]), np.array([[-2.8973, 2.8973]]), prism)


def test_new_study_writes_the_answers_protocol(tmp_path):
    """`new_study --protocol answer`: arm_benchmark's sets and labels on other robots, with its tables."""
    import shutil
    from pathlib import Path

    from pipeline.cli import main
    from pipeline.settings import load_study
    from pipeline.studies import get_study_module

    root = Path(__file__).resolve().parents[2]
    data = tmp_path / "data"
    (data / "studies").mkdir(parents=True)
    shutil.copytree(root / "data" / "robots", data / "robots")
    shutil.copy(root / "data" / "studies" / "arm_benchmark.yaml", data / "studies")
    assert main(["new_study", "my_arms", "--robots", "ur5e", "kuka_iiwa14", "--protocol", "answer",
                 "--data", str(data)]) == 0
    st = load_study(data / "studies" / "my_arms.yaml")
    ref = load_study(data / "studies" / "arm_benchmark.yaml")
    assert st.doc["robots"] == ["ur5e", "kuka_iiwa14"] and set(st.solvers) == set(ref.solvers)
    assert st.problem_sets == ref.problem_sets
    assert get_study_module(st.id, st.doc.get("tables_from")) is ab
