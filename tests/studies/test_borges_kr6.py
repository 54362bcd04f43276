"""Study borges_kr6 (002_56eb235931bf5f5d.txt): robot, the three methods with the study's settings, problem
generators, archives through the generic solve, the report's annotation. The solvers themselves (registered
inverse_jacobian_fd, levenberg_marquardt, pso) are tested on any robot in tests/solvers/iterative/test_solvers_borges.py."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import fk_htm
from pipeline.robots import load_robot
from pipeline.settings import load_study
from pipeline.solvers import solve
from pipeline.studies.borges_kr6 import problems as P

ROOT = Path(__file__).resolve().parents[2]
ROBOT = ROOT / "data/robots/kuka_kr6_r700_sixx.yaml"
STUDY = ROOT / "data/studies/borges_kr6.yaml"

FK_TOL_MM = 1e-9          # closed-form poses: only float rounding of mm-sized sums
URDF_TOL_MM = 1e-8        # two exact models of the same arm, rounding only
PATH_TOL_MM = 1e-9        # curve formulas evaluated at t = 0
SOLVE_TOL_MM = 0.01       # the study's success tolerance (Table 2's convergence threshold)
PSO_KNOWN_MIN_TOL_MM = 1.0  # a converging swarm (w = 0.7) on a reachable goal gets within 1 mm

KUKA_SIGNS = np.array([-1, 1, 1, -1, 1, -1])  # q_dh = s * q_kuka (robot file comment)


@pytest.fixture(scope="module")
def model():
    return load_robot(ROBOT)


@pytest.fixture(scope="module")
def study():
    return load_study(STUDY)


def _goal(p):
    T = np.eye(4)
    T[:3, 3] = p
    return T


def run(study, model, label, p_goal, q_start, seed=0, **overrides):
    """Solve a position goal [mm] with a solver label of the study (``ji``, ``lm``, ``pso``, a reading)."""
    e = study.solvers[label]
    return solve(e.method, model, _goal(p_goal), q_start, {**e.settings.as_dict(), **overrides}, seed=seed)


def _home(study):
    return np.radians(study.problem_sets["points"]["params"]["start_configuration_deg"])


def _targets(study):
    return study.problem_sets["points"]["params"]["targets_mm"]


# --- robot -----------------------------------------------------------------------------------

@pytest.mark.parametrize("q_deg, p_mm", [
    ([0, 0, 0, 0, 0, 0], [785, 0, 435]),                       # notes §2.1 [check]
    ([90, 0, 0, 0, 0, 0], [0, 785, 435]),                      # joint 1 turns about +z
    ([0, -90, 90, 0, 0, 0], [25 + 365 + 80, 0, 400 + 315 + 35]),   # KUKA home: upper arm up, forearm forward
    ([0, -90, 90, 0, 30, 0], [390 + 80 * np.cos(np.radians(30)), 0, 750 - 80 * np.sin(np.radians(30))]),
])
def test_fk_known_poses(model, q_deg, p_mm):
    T = fk_htm(model.chain, np.radians(q_deg))
    np.testing.assert_allclose(T[:3, 3], p_mm, atol=FK_TOL_MM)


def test_fk_zero_tool_axis(model):
    T = fk_htm(model.chain, np.zeros(6))
    np.testing.assert_allclose(T[:3, 2], [-1, 0, 0], atol=1e-12)


def _rot(axis, angle):
    axis = np.asarray(axis, float)
    K_ = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * K_ + (1 - np.cos(angle)) * K_ @ K_


def urdf_flange(q_kuka):
    """Flange (link_6 origin) of the ROS-Industrial kr6r700sixx URDF: joint origins and axes, mm."""
    joints = [((0, 0, 400), (0, 0, -1)), ((25, 0, 0), (0, 1, 0)), ((315, 0, 0), (0, 1, 0)),
              ((0, 0, 35), (-1, 0, 0)), ((365, 0, 0), (0, 1, 0)), ((80, 0, 0), (-1, 0, 0))]
    R, p = np.eye(3), np.zeros(3)
    for (o, ax), qi in zip(joints, q_kuka):
        p = p + R @ np.asarray(o, float)
        R = R @ _rot(ax, qi)
    return p


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0), min_size=6, max_size=6))
def test_dh_matches_urdf_with_sign_map(model, q):
    """The limits mapping q_dh = s q_kuka is right: both models put the flange at the same point."""
    q_kuka = np.array(q)
    p_dh = fk_htm(model.chain, KUKA_SIGNS * q_kuka)[:3, 3]
    np.testing.assert_allclose(p_dh, urdf_flange(q_kuka), atol=URDF_TOL_MM)


def test_limits_are_the_kuka_values(model):
    deg = np.degrees(model.limits)
    np.testing.assert_allclose(deg, [[-170, 170], [-190, 45], [-120, 156], [-185, 185], [-120, 120], [-350, 350]])


# --- JI -----------------------------------------------------------------------------------------

def test_study_settings_are_si_in_mm(study):
    """The document's numbers: 0.01 mm success tolerance, 1e-6 mm error-change stop, computed in mm."""
    methods = {"ji": "inverse_jacobian_fd", "lm": "levenberg_marquardt", "pso": "pso", "pso_w07": "pso",
               "ji_a0004": "inverse_jacobian_fd"}
    for label, method in methods.items():
        e = study.solvers[label]
        assert e.method == method
        assert e.settings.length_unit == "mm" and e.settings.criterion == "position"
        assert e.settings.converted().tol_pos == pytest.approx(0.01)
    for label in ("ji", "lm"):
        assert study.solvers[label].settings.converted().error_change_stop == pytest.approx(1e-6)
    sweep = {k: study.solvers[k].settings for k in study.set_solvers("alpha_sweep")}
    printed = [s for s in sweep.values() if s.delta == 0.01]  # the document's δ; δ = 0.005 is the Table 2 reading
    assert sorted(s.alpha for s in printed) == [0.004, 0.005, 0.006]
    assert sorted((s.delta, s.alpha) for s in sweep.values() if s.delta != 0.01) == [(0.005, 0.004), (0.005, 0.005),
                                                                                     (0.005, 0.006)]
    assert all(s.stop == "reach" for s in sweep.values()) and study.solvers["ji"].settings.stop == "error_change"


def test_ji_converges_within_published_band(model, study):
    q0 = _home(study)
    for target in _targets(study).values():
        r = run(study, model, "ji", np.array(target), q0)
        assert r.success and r.position_error <= SOLVE_TOL_MM
        assert 15 <= r.iterations <= 35
        assert r.trace.shape == (r.iterations + 1, 8)


def test_ji_reach_mode_stops_below_threshold(study, model):
    goal = fk_htm(model.chain, np.radians([20, -60, 60, 10, 40, 0]))[:3, 3]
    r = run(study, model, "ji_a0005", goal, _home(study))
    assert r.success and r.trace[-1, 0] < 0.01 <= r.trace[-2, 0]


# --- LM -----------------------------------------------------------------------------------------

@pytest.mark.parametrize("residual, max_iters", [("vector", 20), ("scalar", 200)])
def test_lm_small_least_squares(study, model, residual, max_iters):
    """A goal near the start: the 3-residual LM is Gauss-Newton-fast, the scalar one still converges."""
    q0 = np.radians([10, -70, 80, 0, 30, 0])
    goal = fk_htm(model.chain, q0 + 0.05)[:3, 3]
    r = run(study, model, "lm", goal, q0, residual=residual)
    assert r.success and r.position_error <= SOLVE_TOL_MM
    assert r.iterations < max_iters
    assert np.all(np.diff(r.trace[:, 0]) <= 1e-12)  # LM accepts only steps that lower the error


# --- PSO ----------------------------------------------------------------------------------------

def test_pso_finds_known_minimum(study, model):
    """Fitness |FK(q*) - FK(q)| has its known minimum 0 at q*; a converging swarm gets close."""
    q_star = np.radians([30, -80, 70, 20, 50, 10])
    goal = fk_htm(model.chain, q_star)[:3, 3]
    r = run(study, model, "pso", goal, q_star, seed=7, inertia=0.7, search="window", window_half_width=0.3,
            window_max_distance=0.0)
    assert r.position_error < PSO_KNOWN_MIN_TOL_MM
    assert np.all(r.q >= q_star - 0.3) and np.all(r.q <= q_star + 0.3)
    assert r.trace[-1, 0] == pytest.approx(r.position_error, abs=1e-9)
    assert np.all(np.diff(r.trace[:, 0]) <= 0)  # the global best never gets worse


def test_pso_velocity_clamp_bounds_every_move(study, model):
    """pso-cpp's maxVel clamps every velocity: with maxVel = 1e-9 rad no personal best can move more than
    sqrt(6)*1e-9 rad in one iteration, so the library's x-stop (mean move <= 1e-6 rad) fires at once and
    the best error is unchanged to within the FK change of such a move; without the clamp the same
    seeded swarm keeps going."""
    goal = np.array(_targets(study)["P2"])
    q0 = _home(study)
    frozen = run(study, model, "pso", goal, q0, seed=11, inertia=1.0, max_velocity=1e-9, max_velocity_fraction=0.0)
    free = run(study, model, "pso", goal, q0, seed=11, inertia=1.0, max_velocity=0.0, max_velocity_fraction=0.0)
    assert frozen.iterations == 1
    assert abs(frozen.trace[1, 0] - frozen.trace[0, 0]) < 1e-5
    assert free.iterations > 5


def test_pso_settings_follow_the_document(study):
    """w = 1, c1 = c2 = 2, 100 particles, library stop tolerances; a velocity clamp (random initial
    velocities, §3.6) from the literature, Vmax = 0.2 of each joint's range; the value fitted to Table 3
    is the labelled calibration pso_cal, never the default."""
    p = study.solvers["pso"].settings
    assert (p.particles, p.inertia, p.c1, p.c2) == (100, 1.0, 2.0, 2.0)
    assert (p.converted().feps, p.xeps) == (pytest.approx(1e-6), 1e-6)
    assert p.max_velocity_fraction == 0.2 and p.max_velocity == 0.0
    assert not p.stop_at_tolerance and p.seed == 0
    cal = study.solvers["pso_cal"].settings
    assert (cal.max_velocity, cal.max_velocity_fraction) == (0.03, 0.0)
    assert study.solvers["pso_v0"].settings.max_velocity == 0.0
    assert study.solvers["pso_v0"].settings.max_velocity_fraction == 0.0


def test_pso_same_seed_same_result(study, model):
    goal = np.array(_targets(study)["P1"])
    q0 = _home(study)
    a = run(study, model, "pso", goal, q0, seed=123)
    b = run(study, model, "pso", goal, q0, seed=123)
    c = run(study, model, "pso", goal, q0, seed=124)
    assert a.iterations == b.iterations and np.array_equal(a.q, b.q)
    assert not np.array_equal(a.q, c.q)


def test_pso_path_mode_searches_the_window_only_near_the_goal(study, model):
    """search: window with window_max_distance 200 mm: a single point (>= 511 mm away) searches the whole box,
    a path point near the previous solution the +-0.25 rad window (the behaviour of §3.6)."""
    q0 = _home(study)
    far = run(study, model, "pso", np.array(_targets(study)["P3"]), q0, seed=5)
    near_goal = fk_htm(model.chain, q0 + 0.05)[:3, 3]
    near = run(study, model, "pso", near_goal, q0, seed=5)
    assert far.info["window"] is False and near.info["window"] is True
    assert np.all(np.abs(near.q - q0) <= 0.25 + 1e-12)


# --- problem generators ----------------------------------------------------------------------

@pytest.mark.parametrize("curve, swap, first", [
    ("lemniscate", True, [100 * np.sqrt(2), -700, 430]),
    ("rhodonea", True, [100, -650, 430]),
    ("circle", True, [100, -650, 430]),
    ("circle", False, [100, 430, -650]),   # eq. 14 as printed
])
def test_path_first_points(curve, swap, first):
    np.testing.assert_allclose(P.curve_points(curve, np.array([0.0]), swap)[0], first, atol=PATH_TOL_MM)


def test_path_parameter_63_points():
    t = P.path_parameter(0.0, 0.1, 63)
    assert t.shape == (63,) and t[0] == 0.0 and t[-1] == pytest.approx(6.2)


def test_curves_are_reachable(model):
    """Every path point lies within the 761.67 mm reach from the shoulder (the printed circle does not)."""
    t = P.path_parameter(0.0, 0.1, 63)
    reach = 315 + np.hypot(365, 35) + 80
    for curve in P.CURVES:
        p = P.curve_points(curve, t)
        radial = np.hypot(p[:, 0], p[:, 1]) - 25
        assert np.all(np.hypot(radial, p[:, 2] - 400) < reach)
    p = P.circle(t, swap_yz=False)
    assert np.all(np.hypot(np.hypot(p[:, 0], p[:, 1]) - 25, p[:, 2] - 400) > reach)


def test_distance_pairs_hit_their_class(model):
    pairs = P.distance_pairs(model, [300.0, 1160.0], 3, 5.0, np.random.default_rng(0))
    assert len(pairs) == 6
    for p in pairs:
        d = np.linalg.norm(p.p_goal - fk_htm(model.chain, p.q_start)[:3, 3])
        assert abs(d - p.distance_class) <= 5.0
        assert np.all(p.q_start >= model.limits[:, 0]) and np.all(p.q_start <= model.limits[:, 1])


def _problems(study, model, pset, count):
    spec = study.problem_sets[pset]
    fn = getattr(P, pset)
    return fn(model, count, np.random.default_rng(0), spec["params"], ROOT / "data")


def test_generators_points_and_paths(study, model):
    pts = _problems(study, model, "points", 4)
    assert len(pts) == 12 and np.all(pts.chain == -1) and np.all(np.isnan(pts.q_goal))
    np.testing.assert_array_equal(pts.goal_position[4], _targets(study)["P2"])
    np.testing.assert_allclose(pts.goal_quat, np.tile([1.0, 0, 0, 0], (12, 1)))
    np.testing.assert_allclose(pts.q_start, np.tile(_home(study), (12, 1)))
    pa = _problems(study, model, "paths", 5)
    assert len(pa) == 15 and list(pa.chain) == [0] * 5 + [1] * 5 + [2] * 5
    np.testing.assert_allclose(pa.goal_position[5], P.rhodonea(np.array([0.0]))[0])


def test_generator_alpha_sweep_classes_in_order(study, model):
    ps = _problems(study, model, "alpha_sweep", 2)
    assert len(ps) == 6
    d = np.linalg.norm(ps.goal_position - fk_htm(model.chain, ps.q_start)[:, :3, 3], axis=1)
    for k, dc in enumerate(study.problem_sets["alpha_sweep"]["params"]["distances_mm"]):
        assert np.all(np.abs(d[2 * k:2 * k + 2] - dc) <= 5.0)
    np.testing.assert_allclose(fk_htm(model.chain, ps.q_goal)[:, :3, 3], ps.goal_position, atol=1e-9)


def _solve_cli(tmp_path, pset, label, limit, name="x"):
    from pipeline.cli import main

    problems = tmp_path / f"{pset}.csv"
    if not problems.exists():
        assert main(["make_problems", "--study", str(STUDY), "--problem-set", pset, "--robot", str(ROBOT),
                     "--scale", "quick", "--out", str(problems)]) == 0
    out = tmp_path / f"{name}.mcap"
    rc = main(["solve_problems", "--study", str(STUDY), "--problem-set", pset, "--robot", str(ROBOT), "--solver",
               label, "--problems", str(problems), "--scale", "quick", "--limit", str(limit), "--out", str(out)])
    return rc, out


@pytest.mark.parametrize("pset, label, limit", [("points", "pso", 2), ("paths", "lm", 3), ("paths", "pso", 3)])
def test_same_seed_same_archive(tmp_path, pset, label, limit):
    from pipeline.io.archive import read_archive

    keys = ["problem_id", "iterations", "position_error", "q_solution", "stop_reason", "success"]
    frames = []
    for k in range(2):
        rc, out = _solve_cli(tmp_path, pset, label, limit, name=str(k))
        assert rc == 0
        frames.append(read_archive(out).frame()[keys])
    assert frames[0].equals(frames[1])


def test_report_annotates_paths_from_the_archive(tmp_path, study):
    """Label, index, t, reached position and CPU time come from the archive and the set's definition."""
    from pipeline.io.archive import read_archive
    from pipeline.studies.borges_kr6.report import frame

    rc, out = _solve_cli(tmp_path, "paths", "ji", 3)
    assert rc == 0
    df = frame(study, [read_archive(out)])
    assert list(df["label"]) == ["lemniscate"] * 3 and list(df["index"]) == [0, 1, 2]
    np.testing.assert_allclose(df["t"], [0.0, 0.1, 0.2])
    reached = np.array(df["reached_mm"].tolist())
    goals = P.lemniscate(np.array([0.0, 0.1, 0.2]))
    np.testing.assert_allclose(np.linalg.norm(reached - goals, axis=1), df["position_error"], atol=1e-9)
    assert (df["cpu_time_s"] > 0).all() and (df["method"] == "ji").all() and (df["alpha"] == 0.005).all()
    # the chain: every point after the first starts from the previous solution
    q0 = np.array(df["q_start"].tolist())
    qs = np.array(df["q_solution"].tolist())
    np.testing.assert_array_equal(q0[1:], qs[:-1])


def test_cli_rejects_solver_not_run_on_set(tmp_path, capsys):
    rc, out = _solve_cli(tmp_path, "alpha_sweep", "pso", 1)
    err = capsys.readouterr().err.strip()
    assert rc == 2 and err.startswith("error:") and "\n" not in err and "alpha_sweep" in err
    assert not out.exists()


def test_workflow_dry_run_lists_one_archive_per_solver_and_set(tmp_path):
    """`snakemake -n borges_kr6`: the generic rules; alpha sweep (3 alphas) + points (JI, LM, PSO and 7 PSO readings)
    + paths (JI, LM, PSO, pso_v0, pso_w07); no rule of the study's own."""
    import subprocess
    import sys

    study = load_study(STUDY)
    out = subprocess.run(
        [sys.executable, "-m", "snakemake", f"{tmp_path}/borges_kr6/.built", "-n", "--nolock", "--cores", "1",
         "--config", "studies=[borges_kr6]", "scale=quick", f"results_dir={tmp_path}"],
        cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    counts = {ln.split()[0]: int(ln.split()[-1]) for ln in out.stdout.splitlines()
              if ln.strip() and ln.split()[0] in ("solve_problems", "make_problems")}
    assert counts["solve_problems"] == len(study.jobs()) == 6 + 12 + 6
    assert counts["make_problems"] == 3
    assert "solve_borges_kr6" not in out.stdout


# --- PSO readings table ----------------------------------------------------------------------------

def _points_frame(iters: dict[str, list[int]]):
    import pandas as pd

    rows = [{"problem_set": "points", "label": "P1", "method": m, "iterations": i, "position_error": 0.1 * k,
             "success": False, "time_ms": float(i), "cpu_ms": float(i)}
            for m, its in iters.items() for k, i in enumerate(its)]
    return pd.DataFrame(rows)


@pytest.mark.parametrize("cal_iters, closest", [([210, 220], "pso_cal"), ([30, 40], "pso_vmax002")])
def test_pso_readings_mark_the_reading_closest_to_table3(study, cal_iters, closest):
    """The table recomputes the calibration's fitting rule (scalar-maxVel w = 1 reading with the mean
    iteration count nearest the published 215.9) from whatever the archives hold, and says so when it is
    not the calibration; the default (literature clamp) is never a candidate."""
    from pipeline.studies.borges_kr6.report import table_pso_readings

    df = _points_frame({"ji": [20, 20], "pso": [215, 216], "pso_cal": cal_iters, "pso_v0": [35, 37],
                        "pso_vmax002": [300, 320], "pso_w07": [215, 216], "pso_v0_nostop": [216, 216]})
    spec = table_pso_readings(study, df, ROOT / "data/published")
    t = spec.frame
    marked = t[t["closest w = 1 reading"] == "yes"]["method key"].tolist()
    assert marked == [closest]  # pso_w07 (w = 0.7) and pso_v0_nostop (stop off) are nearer 215.9: never chosen
    assert t["reading"].iloc[-1] == "Table 3 PSO (published)"
    assert t["i mean"].iloc[-1] == pytest.approx((241.656 + 193.906 + 212.125) / 3)
    assert ("MISMATCH" in spec.note) == (closest != "pso_cal")
