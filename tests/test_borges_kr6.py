"""Study borges_kr6 (002_56eb235931bf5f5d.txt): robot, the three methods, problem generators, archives."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import fk_htm, geometric_jacobian
from pipeline.robots import load_robot
from pipeline.settings import Study, load_study
from pipeline.studies.borges_kr6 import kernels as K
from pipeline.studies.borges_kr6 import methods as M
from pipeline.studies.borges_kr6 import problems as P

ROOT = Path(__file__).resolve().parent.parent
ROBOT = ROOT / "data/robots/kuka_kr6_r700_sixx.yaml"
STUDY = ROOT / "data/studies/borges_kr6.yaml"

FK_TOL_MM = 1e-9          # closed-form poses: only float rounding of mm-sized sums
URDF_TOL_MM = 1e-8        # two exact models of the same arm, rounding only
FD_TOL_MM = 0.05          # undivided forward difference: 1/2 delta^2 |d2p/dq2| <= 0.5 * 1e-4 * ~800 mm
PATH_TOL_MM = 1e-9        # curve formulas evaluated at t = 0
SOLVE_TOL_MM = 0.01       # the study's success tolerance (Table 2's convergence threshold)
PSO_KNOWN_MIN_TOL_MM = 1.0  # a converging swarm (w = 0.7) on a reachable goal gets within 1 mm

KUKA_SIGNS = np.array([-1, 1, 1, -1, 1, -1])  # q_dh = s * q_kuka (robot file comment)


@pytest.fixture(scope="module")
def model():
    return load_robot(ROBOT)


@pytest.fixture(scope="module")
def prep(model):
    return M.Prepared(model)


@pytest.fixture(scope="module")
def study():
    return load_study(STUDY)


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

@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-2.5, 2.5), min_size=6, max_size=6))
def test_undivided_fd_jacobian_is_analytic_times_delta(model, prep, q):
    q = np.array(q)
    delta = 0.01
    X = np.empty(6)
    T, C, L = np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4))
    K.fk_x(*prep.args, q, X, T, C, L)
    J = np.empty((6, 6))
    K.ji_jacobian(*prep.args, q, X, delta, J, np.empty(6), np.empty(6), T, C, L)
    Ja = geometric_jacobian(model.chain, q)[:3]
    np.testing.assert_allclose(J[:3], delta * Ja, atol=FD_TOL_MM)


def test_ji_converges_within_published_band(prep, study):
    s = study.settings
    q0 = np.radians(s["start_configuration_deg"])
    for target in s["points"]["targets_mm"].values():
        r = M.solve_ji(prep, np.array(target), q0, s["methods"]["ji"], s)
        assert r.success and r.position_error <= SOLVE_TOL_MM
        assert 15 <= r.iterations <= 35
        assert r.trace.shape == (r.iterations + 1, 8)


def test_ji_reach_mode_stops_below_threshold(prep, study, model):
    s = study.settings
    goal = fk_htm(model.chain, np.radians([20, -60, 60, 10, 40, 0]))[:3, 3]
    r = M.solve_ji(prep, goal, np.radians(s["start_configuration_deg"]), s["methods"]["ji"], s, reach_mm=0.01, gain=0.005)
    assert r.success and r.trace[-1, 0] < 0.01 <= r.trace[-2, 0]


# --- LM -----------------------------------------------------------------------------------------

@pytest.mark.parametrize("lam, nu, rho, expect", [
    (1.0, 2.0, 0.5, (1.0, 2.0)),          # 1 - 0^3 = 1
    (1.0, 8.0, 1.0, (0.33, 2.0)),         # perfect model: shrink to the floor, nu reset
    (1.0, 2.0, 0.25, (1.125, 2.0)),       # 1 - (-0.5)^3 = 1.125
    (3.0, 2.0, -0.1, (6.0, 4.0)),         # rejected: lam * nu, nu doubles
    (3.0, 4.0, 0.0, (12.0, 8.0)),         # rho = 0 is a rejection (MRPT: l > 0 accepts)
])
def test_nielsen_update(lam, nu, rho, expect):
    np.testing.assert_allclose(K.nielsen(lam, nu, rho, 0.33), expect)


@given(st.floats(1e-6, 1.0), st.floats(1e-9, 1e6))
def test_nielsen_accepted_factor_bounds(rho, lam):
    new, nu = K.nielsen(lam, 16.0, rho, 0.33)
    assert 0.33 * lam * (1 - 1e-12) <= new <= 2 * lam and nu == 2.0


@pytest.mark.parametrize("residual, max_iters", [("vector", 20), ("scalar", 200)])
def test_lm_small_least_squares(prep, study, model, residual, max_iters):
    """A goal near the start: the 3-residual LM is Gauss-Newton-fast, the scalar one still converges."""
    s = study.settings
    q0 = np.radians([10, -70, 80, 0, 30, 0])
    goal = fk_htm(model.chain, q0 + 0.05)[:3, 3]
    r = M.solve_lm(prep, goal, q0, dict(s["methods"]["lm"], residual=residual), s)
    assert r.success and r.position_error <= SOLVE_TOL_MM
    assert r.iterations < max_iters
    assert np.all(np.diff(r.trace[:, 0]) <= 1e-12)  # LM accepts only steps that lower the error


# --- PSO ----------------------------------------------------------------------------------------

def test_pso_finds_known_minimum(prep, study, model):
    """Fitness |FK(q*) - FK(q)| has its known minimum 0 at q*; a converging swarm gets close."""
    s = study.settings
    q_star = np.radians([30, -80, 70, 20, 50, 10])
    goal = fk_htm(model.chain, q_star)[:3, 3]
    box = np.stack([q_star - 0.3, q_star + 0.3], axis=1)
    cfg = dict(s["methods"]["pso"], inertia=0.7)
    r = M.solve_pso(prep, goal, box, cfg, s, seed=7)
    assert r.position_error < PSO_KNOWN_MIN_TOL_MM
    assert np.all(r.q >= box[:, 0]) and np.all(r.q <= box[:, 1])
    assert r.trace[-1, 0] == pytest.approx(r.position_error, abs=1e-9)
    assert np.all(np.diff(r.trace[:, 0]) <= 0)  # the global best never gets worse


def test_pso_velocity_clamp_bounds_every_move(prep, study):
    """pso-cpp's maxVel clamps every velocity: with maxVel = 1e-9 rad no personal best can move more than
    sqrt(6)*1e-9 rad in one iteration, so the library's x-stop (mean move <= 1e-6 rad) fires at once and
    the best error is unchanged to within the FK change of such a move; without the clamp the same
    seeded swarm keeps going."""
    s = study.settings
    goal = np.array(s["points"]["targets_mm"]["P2"])
    base = dict(s["methods"]["pso"], inertia=1.0)
    frozen = M.solve_pso(prep, goal, prep.limits, dict(base, max_velocity=1e-9), s, seed=11)
    free = M.solve_pso(prep, goal, prep.limits, dict(base, max_velocity=0.0), s, seed=11)
    assert frozen.iterations == 1
    assert abs(frozen.trace[1, 0] - frozen.trace[0, 0]) < 1e-5
    assert free.iterations > 5


def test_pso_settings_follow_the_document(study):
    """w = 1, c1 = c2 = 2, 100 particles, library stop tolerances; maxVel > 0 (random initial velocities, §3.6)."""
    p = study.settings["methods"]["pso"]
    assert (p["particles"], p["inertia"], p["c1"], p["c2"]) == (100, 1.0, 2.0, 2.0)
    assert (p["feps"], p["xeps"]) == (1e-6, 1e-6) and p["max_velocity"] > 0
    assert M.method_config(study.settings, "pso_v0")[1]["max_velocity"] == 0.0


def test_pso_same_seed_same_result(prep, study):
    s = study.settings
    goal = np.array(s["points"]["targets_mm"]["P1"])
    a = M.solve_pso(prep, goal, prep.limits, s["methods"]["pso"], s, seed=123)
    b = M.solve_pso(prep, goal, prep.limits, s["methods"]["pso"], s, seed=123)
    c = M.solve_pso(prep, goal, prep.limits, s["methods"]["pso"], s, seed=124)
    assert a.iterations == b.iterations and np.array_equal(a.q, b.q)
    assert not np.array_equal(a.q, c.q)


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


# --- archives, determinism, CLI ---------------------------------------------------------------

def _tiny_study(study) -> Study:
    doc = copy.deepcopy(study.doc)
    s = doc["study_settings"]
    s["points"]["runs"]["quick"] = 2
    s["points"]["targets_mm"] = {"P1": s["points"]["targets_mm"]["P1"]}
    s["paths"]["points"]["quick"] = 3
    s["paths"]["curves"] = ["rhodonea"]
    return Study(study.id, study.path, doc, {})


@pytest.mark.parametrize("pset, method", [("points", "pso"), ("paths", "lm"), ("paths", "pso")])
def test_same_seed_same_archive(tmp_path, study, pset, method):
    from pipeline.io.archive import read_archive
    from pipeline.studies.borges_kr6.run import write_archive

    tiny = _tiny_study(study)
    keys = ["problem_id", "iterations", "position_error", "q_solution", "stop_reason", "success"]
    frames = []
    for k in range(2):
        out = tmp_path / f"{k}.mcap"
        write_archive(tiny, ROBOT, pset, method, "quick", out)
        frames.append(read_archive(out).frame()[keys])
    assert frames[0].equals(frames[1])


def test_cli_rejects_method_not_run_on_set(tmp_path, capsys):
    from pipeline.cli import main

    rc = main(["solve_borges_kr6", "--study", str(STUDY), "--robot", str(ROBOT), "--set", "alpha_sweep",
               "--method", "pso", "--scale", "quick", "--out", str(tmp_path / "x.mcap")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and err.startswith("error:") and "\n" not in err and "alpha_sweep" in err
    assert not (tmp_path / "x.mcap").exists()


def test_workflow_dry_run_lists_one_archive_per_method_and_set(tmp_path):
    """`snakemake -n borges_kr6`: alpha sweep (JI) + points and paths x (JI, LM, PSO) + each variant on its sets."""
    import subprocess
    import sys

    study = load_study(STUDY)
    variants = study.settings["methods"].get("pso_variants") or {}
    runs_of = {k: len(v.get("problem_sets", ["points", "paths"])) for k, v in variants.items()}
    out = subprocess.run(
        [sys.executable, "-m", "snakemake", "borges_kr6", "-n", "--nolock", "--cores", "1", "--config",
         "studies=[borges_kr6]", "scale=quick", f"results_dir={tmp_path}"],
        cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    expected = 1 + 2 * 3 + sum(runs_of.values())
    line = next(ln for ln in out.stdout.splitlines() if ln.startswith("solve_borges_kr6"))
    assert int(line.split()[-1]) == expected


# --- PSO readings table ----------------------------------------------------------------------------

def _points_frame(iters: dict[str, list[int]]):
    import pandas as pd

    rows = [{"problem_set": "points", "label": "P1", "method": m, "iterations": i, "position_error": 0.1 * k,
             "success": False, "time_ms": float(i), "cpu_ms": float(i)}
            for m, its in iters.items() for k, i in enumerate(its)]
    return pd.DataFrame(rows)


@pytest.mark.parametrize("pso_iters, closest", [([210, 220], "pso"), ([30, 40], "pso_vmax002")])
def test_pso_readings_mark_the_reading_closest_to_table3(study, pso_iters, closest):
    """The table recomputes the selection rule (w = 1 reading with the mean iteration count nearest the
    published 215.9) from whatever the archives hold, and says so when it is not the used reading."""
    from pipeline.studies.borges_kr6.report import table_pso_readings

    df = _points_frame({"ji": [20, 20], "pso": pso_iters, "pso_v0": [35, 37], "pso_vmax002": [300, 320],
                        "pso_w07": [215, 216], "pso_v0_nostop": [216, 216]})
    spec = table_pso_readings(study, df, ROOT / "data/published")
    t = spec.frame
    marked = t[t["closest w = 1 reading"] == "yes"]["method key"].tolist()
    assert marked == [closest]  # pso_w07 (w = 0.7) and pso_v0_nostop (stop off) are nearer 215.9: never chosen
    assert t["reading"].iloc[-1] == "Table 3 PSO (published)"
    assert t["i mean"].iloc[-1] == pytest.approx((241.656 + 193.906 + 212.125) / 3)
    assert ("MISMATCH" in spec.note) == (closest != "pso")
