"""Study erthal1992 (001_7601717b50b5e768.txt): golden values from the document and properties."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import fk_htm
from pipeline.robots import load_robot
from pipeline.settings import load_study
from pipeline.solvers import solve
from pipeline.solvers.iterative.zero_position import step_revolute, strategy_weights
from pipeline.studies.erthal1992 import model as M
from pipeline.problems import ProblemSpecError, make_problem_set
from pipeline.studies.generators import load_generator
from pipeline.runner import solve_set
from pipeline.studies.erthal1992.problems import placement
from pipeline.studies.erthal1992.runs import q_from_settings
from pipeline.studies.erthal1992.tasks import parse_res

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data"
STUDY = load_study(DATA / "studies" / "erthal1992.yaml")
SETS = STUDY.problem_sets

RES_POS_TOL = 0.1    # [mm] Done-when tolerance for SCARA1.RES endpoints
RES_ANG_TOL = 1e-3   # [rad] Done-when tolerance for SCARA1.RES rows (the file prints 4 decimals)
FIG_TOL = 5e-4       # Figs 6.6-6.7 print 3 decimals
TABLE_TOL = 5e-5     # Tables 6.1-6.2 print up to 4 decimals (424.2641)
FK_TOL = 1e-9        # [mm | 1] two exact FK formulations agree to rounding
TEST6_TOL = 1e-3     # [rad] Done-when tolerance for the Test 6 ZP rows (printed to 4 decimals)


def robot(name):
    return load_robot(DATA / "robots" / f"{name}.yaml")


def problems(pset, robot_name=None):
    """A problem set of the study YAML, drawn by its generator (as `make_problems` does)."""
    model = robot(robot_name or STUDY.set_robots(pset)[0])
    return model, make_problem_set(SETS[pset], model, STUDY.count(pset, "quick"), np.random.default_rng(0), DATA,
                                   load=load_generator)


def solve_label(pset, label, robot_name=None):
    """Every result of one solver label of the study on one of its problem sets (the runner's loop)."""
    model, ps = problems(pset, robot_name)
    entry = STUDY.solvers[label]
    return [res for _, _, _, res in solve_set(entry.method, entry.settings, model, ps)]


# --- catalogue and conversions ------------------------------------------------------------

def _stanford():
    doc = yaml.safe_load((DATA / "erthal1992" / "stanford_input.yaml").read_text())
    j, e = doc["joints"], doc["effector"]
    return M.dh_from_joint_points([x["type"] for x in j], [x["position"] for x in j], [x["axis"] for x in j],
                                  e["position"], e["u_a"], e["u_t"])


def test_stanford_origins_and_x_axes_equal_figs_6_6_and_6_7():
    import pandas as pd

    dh = _stanford()
    pub = pd.read_csv(DATA / "published" / "erthal1992" / "fig06_06_07_stanford.csv")
    np.testing.assert_allclose(dh.origins, pub[["origin_x", "origin_y", "origin_z"]].to_numpy(), atol=FIG_TOL)
    np.testing.assert_allclose(dh.x_axes, pub[["x_axis_x", "x_axis_y", "x_axis_z"]].to_numpy(), atol=FIG_TOL)


def test_stanford_conversion_equals_robot_file():
    dh = _stanford()
    model = robot("stanford")
    q0 = q_from_settings(model, STUDY.settings["zero_positions"]["stanford"])
    np.testing.assert_allclose(dh.q0, q0, atol=1e-12)
    dq = np.random.default_rng(0).uniform(-1, 1, (10, 6))
    np.testing.assert_allclose(fk_htm(dh.chain(), dh.q0 + dq), fk_htm(model.chain, q0 + dq), atol=FK_TOL)


def test_scara_pz_vectors_equal_scara_par():
    model = robot("scara")
    pz = M.pz_from_dh(model.chain, np.array([0, 0, 0, 250.0]))
    par_bodies = [[0, 0, 0], [425, 0, 980], [375, 0, 130], [0, 0, 0], [0, 0, -250]]  # SCARA.PAR body vectors
    np.testing.assert_allclose(pz.b, par_bodies, atol=1e-9)
    np.testing.assert_allclose(pz.u, [[0, 0, 1], [0, 0, 1], [0, 0, 1], [0, 0, -1]], atol=1e-12)
    np.testing.assert_allclose(pz.u_a, [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(pz.u_t, [0, -1, 0], atol=1e-12)


@pytest.mark.parametrize("name", ["scara", "stanford", "puma560", "artropoidal", "planar2r", "planar3r", "elbow"])
@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_dh_pz_dh_round_trip_and_pz_fk(name, seed):
    model = robot(name)
    q0 = q_from_settings(model, STUDY.settings["zero_positions"][name])
    pz = M.pz_from_dh(model.chain, q0)
    dh2 = M.dh_from_pz(pz)
    dq = np.random.default_rng(seed).uniform(-1.5, 1.5, model.n)
    T = fk_htm(model.chain, q0 + dq)
    np.testing.assert_allclose(M.pz_fk(pz, q0 + dq), T, atol=FK_TOL * 1e3)
    np.testing.assert_allclose(fk_htm(dh2.chain(), dh2.q0 + dq), T, atol=FK_TOL * 1e3)


@pytest.mark.parametrize("q_deg, expected", [
    ([0, 0, -90, 90, 90, -90], [[0, 0, 1, 450], [0, 1, 0, 0], [-1, 0, 0, -200]]),            # Table 6.1
    ([90, 45, -90, -45, 90, 0], [[-1, 0, 0, 0], [0, 1, 0, 424.2641], [0, 0, -1, -50]]),     # Table 6.2
])
def test_artropoidal_matrices_equal_tables_6_1_6_2(q_deg, expected):
    T = fk_htm(robot("artropoidal").chain, np.radians(q_deg))
    np.testing.assert_allclose(T[:3], expected, atol=TABLE_TOL)


# --- SCARA1.RES ---------------------------------------------------------------------------

def _cli(*args):
    return subprocess.run([sys.executable, "-m", "pipeline", *args], capture_output=True, text=True, cwd=ROOT, timeout=300)


@pytest.fixture(scope="module")
def scara_res(tmp_path_factory):
    """SCARA1.RES through the workflow's own verbs: make_problems, solve_problems, erthal_path_rows."""
    d = tmp_path_factory.mktemp("scara")
    study = "data/studies/erthal1992.yaml"
    for args in (["make_problems", "--study", study, "--problem-set", "scara1", "--robot", "data/robots/scara.yaml",
                  "--scale", "quick", "--data", "data", "--out", str(d / "p.csv")],
                 ["solve_problems", "--study", study, "--problem-set", "scara1", "--robot", "data/robots/scara.yaml",
                  "--solver", "zp_scara", "--problems", str(d / "p.csv"), "--scale", "quick", "--out", str(d / "a.mcap")],
                 ["erthal_path_rows", "--study", study, "--data", "data", "--problem-set", "scara1", "--robot", "scara",
                  "--archive", str(d / "a.mcap"), "--out", str(d / "rows.mcap"), "--res", str(d / "SCARA1.RES")]):
        p = _cli(*args)
        assert p.returncode == 0, p.stderr[-2000:]
    ours = parse_res((d / "SCARA1.RES").read_text())
    pub = parse_res((DATA / "published" / "erthal1992" / "SCARA1.RES").read_text())
    return ours, pub


def test_scara1_res_layout(scara_res):
    (n1, s1, k1, r1), (n2, s2, k2, r2) = scara_res
    assert (n1, s1, k1) == (n2, s2, k2) == ("SCARA", 4, 10)
    np.testing.assert_array_equal(r1[:, :3], r2[:, :3])


def test_scara1_res_endpoints(scara_res):
    (_, _, k, r1), (_, _, _, r2) = scara_res
    ends = np.r_[np.arange(0, len(r1), k), np.arange(k - 1, len(r1), k)]
    np.testing.assert_allclose(r1[ends, 3:6], r2[ends, 3:6], atol=RES_ANG_TOL)
    np.testing.assert_allclose(r1[ends, 6], r2[ends, 6], atol=RES_POS_TOL)


def test_scara1_res_all_rows_joint_interpolated(scara_res):
    (_, _, _, r1), (_, _, _, r2) = scara_res
    np.testing.assert_allclose(r1[:, 3:6], r2[:, 3:6], atol=RES_ANG_TOL)
    np.testing.assert_allclose(r1[:, 6], r2[:, 6], atol=RES_ANG_TOL)


# --- Zero-Position step and strategies ----------------------------------------------------

def _rot(axis, ang):
    return M.axis_angle_matrix(ang, axis / np.linalg.norm(axis))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), c=st.floats(0, 1))
def test_zp_revolute_step_minimises_delta(seed, c):
    rng = np.random.default_rng(seed)
    u = rng.normal(size=3)
    u /= np.linalg.norm(u)
    M_ = _rot(rng.normal(size=3), rng.uniform(-3, 3))
    dv, h = rng.normal(size=3) * 100, rng.normal(size=3) * 100
    phi = step_revolute(M_, dv, u, h, c, 1.0)

    def delta(x):
        R = _rot(u, x)
        return (1 - c) * np.sum((M_ - R) ** 2) + c * np.sum((dv - (R - np.eye(3)) @ h) ** 2)

    grid = np.linspace(-math.pi, math.pi, 2001)
    assert delta(phi) <= min(delta(x) for x in grid) + 1e-9 * (1 + abs(delta(phi)))


def test_strategy_weights_ends():
    prism = np.zeros(6, bool)
    for s in (6, 7, 8, 9, 10):  # eqs 6.1 / 6.2: c = 1 at j = 1, c = 0 at j = N
        c = strategy_weights(s, prism)
        assert c[0] == pytest.approx(1) and c[-1] == pytest.approx(0)
        assert np.all(np.diff(c) <= 0)
    assert np.isnan(strategy_weights(5, prism)[:3]).all() and (strategy_weights(5, prism)[3:] == 0).all()
    assert (strategy_weights(3, prism) == [1, 1, 1, 0, 0, 0]).all()


# --- Tests 1, 2, 3, 6 shapes --------------------------------------------------------------

def test_test1_zp_stable_at_unreachable_point_nr_fails():
    zp = solve_label("test1", "zp_test1")[-1]
    assert not zp.success and abs(zp.position_error - 180.0) < 0.1  # shortfall 2700 - 2520
    assert np.all(np.isfinite(zp.trace)) and abs(zp.trace[-1, 7] - zp.trace[-10, 7]) < 0.1  # settled
    nr = solve_label("test1", "nr_test1")[-1]
    assert not nr.success


def test_test1_previous_is_one_chain():
    _, ps = problems("test1_previous")
    assert (ps.chain == 0).all() and (problems("test1")[1].chain == -1).all()
    assert np.isnan(ps.q_goal).all()  # the document's goals: angles unknown


TABLE_6_9_SHAPE = 0.5  # Done-when: ZP iterations within +-50 % of Table 6.9 at every precision


def test_test2_nr_fast_zp_grows_with_precision():
    pub_zp = {1: 18, 2: 25, 3: 31, 4: 38, 5: 44, 6: 50, 7: 56}  # Table 6.9, precision 10^-k
    its = []
    for k, p in pub_zp.items():
        zp, = solve_label("test2", f"zp_test2_1em{k}")
        nr, = solve_label("test2", f"nr_test2_1em{k}")
        assert STUDY.solvers[f"zp_test2_1em{k}"].settings.epsilon == pytest.approx(10.0**-k)
        assert zp.success and nr.success and nr.iterations <= 6
        assert (1 - TABLE_6_9_SHAPE) * p <= zp.iterations <= (1 + TABLE_6_9_SHAPE) * p
        its.append(zp.iterations)
    assert np.all(np.diff(its) > 0)
    assert max(np.diff(its)) <= 2 * min(np.diff(its))  # linear per decade: no slow tail


def test_fk_check_tolerances_are_the_ones_the_stop_tests_imply():
    """A claimed success must pass the FK check exactly when the document's stop test holds."""
    for label, entry in STUDY.solvers.items():
        s = entry.settings
        if entry.method == "zero_position" and s.stop_test == "delta_sum":
            assert s.tol_pos >= math.sqrt(s.epsilon) * s.length_scale * (1 - 1e-12), label
            if s.criterion != "position":
                assert s.tol_rot >= 2 * math.asin(math.sqrt(s.epsilon / 8)) * (1 - 1e-12), label
        if entry.method == "newton_raphson" and s.stop_test == "error_norm":
            assert s.tol_pos >= s.epsilon * s.length_scale * (1 - 1e-12) and s.tol_rot >= s.epsilon, label


def test_robot_base_places_puma_below_shoulder():
    assert placement(DATA, "puma560")[2, 3] == 672.0
    _, ps = problems("test2")
    assert abs(ps.goal_position[0, 2] - (370.0 - 672.0)) < FK_TOL  # the document's goal in the file's frame
    assert (placement(DATA, "elbow") == np.eye(4)).all()  # Test 1 residual 180 needs the shoulder at z = 0


def test_generator_count_must_match_the_documents_points():
    with pytest.raises(ProblemSpecError, match="field 'count'") as exc:
        make_problem_set(SETS["test1"], robot("elbow"), 7, np.random.default_rng(0), DATA, load=load_generator)
    assert "\n" not in str(exc.value)


def test_test3_strategies_3_and_5_fastest():
    res = {s: solve_label("test3", f"zp_test3_s{s}")[0] for s in range(1, 11)}
    best = min(r.iterations if r.success else 10**9 for r in res.values())
    assert res[3].success and res[5].success and res[3].iterations == res[5].iterations == best
    assert not any(res[s].success for s in (1, 2, 4, 6, 7, 8, 9, 10))  # §6.3c: none of 1, 2, 4, 6-10 within 100
    final = {s: res[s].trace[-1, 0] for s in range(6, 11)}
    assert min(final, key=final.get) == 8  # "Das estratégias 6 a 10, a que melhor se comportou foi a 8"


@pytest.mark.parametrize("name, published", [
    ("test6_2dof", {2: [2.2280, -1.6444], 3: [1.5845, -1.6444], 4: [0.7919, -0.8007]}),              # Table 6.16
    ("test6_3dof", {2: [2.0419, -1.4186, 1.1512], 3: [1.3984, -1.4186, 1.1512]}),                    # Table 6.17
])
def test_test6_zp_rows_match_published(name, published):
    goals = SETS[name]["params"]["goals"]
    for g, r in zip(goals, solve_label(name, "zp_test6")):
        if g["point"] in published:
            assert r.success
            np.testing.assert_allclose(r.q, published[g["point"]], atol=TEST6_TOL)


# --- analytic PUMA ------------------------------------------------------------------------

PUMA_LABEL = STUDY.solvers["analytic_puma"].settings


def puma_ik_all(model, T):
    res = solve("analytic_puma", model, T, np.zeros(6), PUMA_LABEL)
    return res, res.info["branches"].split()


@settings(max_examples=40, deadline=None)
@given(q=st.lists(st.floats(-math.pi, math.pi), min_size=6, max_size=6))
def test_puma_analytic_eight_fk_verified_solutions(q):
    model = robot("puma560")
    T = fk_htm(model.chain, np.array(q))
    res, flags = puma_ik_all(model, T)
    assert len(res.solutions) == 8 and res.success
    assert res.info["valid"] == "1" * 8 and res.info["solutions_valid"] == 8
    assert len({f[:3] for f in flags}) == 8 == res.info["distinct_branches"]
    for s in res.solutions:  # independent check here too
        np.testing.assert_allclose(fk_htm(model.chain, s), T, atol=1e-6)


def test_puma_degenerate_wrist_sets_theta4_zero():
    model = robot("puma560")
    T = fk_htm(model.chain, np.radians([10, 20, 30, 0, 0, 40]))
    res, flags = puma_ik_all(model, T)
    assert res.info["valid"] == "1" * len(flags)
    deg = [f.endswith("d") for f in flags]
    assert all(s[3] == 0.0 for s, d in zip(res.solutions, deg) if d) and any(deg)
    assert res.info["degenerate_wrist"] == sum(deg)


# --- CLI ------------------------------------------------------------------------------------

def test_cli_robot_prints_report_layout():
    p = _cli("robot", "data/robots/scara.yaml", "--q0", "0,0,0,250")
    assert p.returncode == 0, p.stderr
    for head in ("NOME: SCARA", "PARÂMETROS DE DENAVIT-HARTENBERG", "VETORES DA POSIÇÃO-ZERO"):
        assert head in p.stdout
    assert "3\t0.00\t180.00\t0.00\t0.00" in p.stdout


def test_cli_robot_bad_input_is_one_line():
    p = _cli("robot", "data/robots/scara.yaml", "--q0", "0,0")
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and p.stderr.startswith("error:")


# --- path interpolation -------------------------------------------------------------------

@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(2, 12))
def test_cartesian_interpolation_equal_division(seed, k):
    from pipeline.studies.erthal1992.tasks import cartesian_points, rotation_vector

    rng = np.random.default_rng(seed)
    T0, T1 = np.eye(4), np.eye(4)
    T0[:3, :3] = _rot(rng.normal(size=3), rng.uniform(-3, 3))
    T1[:3, :3] = _rot(rng.normal(size=3), rng.uniform(-3, 3))
    T0[:3, 3], T1[:3, 3] = rng.normal(size=3) * 300, rng.normal(size=3) * 300
    P = cartesian_points(T0, T1, k)
    np.testing.assert_allclose(P[0], T0, atol=1e-9)
    np.testing.assert_allclose(P[-1], T1, atol=1e-7)
    steps = [np.linalg.norm(rotation_vector(P[j][:3, :3].T @ P[j + 1][:3, :3])) for j in range(k - 1)]
    dists = np.linalg.norm(np.diff(P[:, :3, 3], axis=0), axis=1)
    np.testing.assert_allclose(steps, steps[0], atol=1e-7)   # equal division of the equivalent rotation
    np.testing.assert_allclose(dists, dists[0], atol=1e-7)   # and of the distance


def test_task_file_error_is_one_line(tmp_path):
    from pipeline.studies.erthal1992.tasks import TaskFileError, load_task

    bad = tmp_path / "t.yaml"
    bad.write_text((DATA / "erthal1992" / "scara_task.yaml").read_text().replace("segments: 4", "segments: 3"))
    with pytest.raises(TaskFileError, match=r"field 'points'") as exc:
        load_task(bad)
    assert "\n" not in str(exc.value)


def test_cartesiano_axes_are_decoupled():
    """Assumed CARTESIANO: carriages along world x, y, z; flange 100 mm above the carriage at q = 0."""
    from pipeline.kinematics import fk_htm
    from pipeline.robots import load_robot

    m = load_robot(Path(__file__).resolve().parents[2] / "data" / "robots" / "cartesiano.yaml")
    q = np.array([1000.0, 800.0, 650.0, 0.0, 0.0, np.pi])  # Table 6.13 initial configuration
    np.testing.assert_allclose(fk_htm(m.chain, q)[:3, 3], [1000, 800, 750], atol=1e-9)
    for i in range(3):
        dq = np.zeros(6)
        dq[i] = 10.0
        np.testing.assert_allclose(fk_htm(m.chain, q + dq)[:3, 3] - fk_htm(m.chain, q)[:3, 3], 10.0 * np.eye(3)[i], atol=1e-9)


# --- workflow -------------------------------------------------------------------------------

def test_workflow_dry_run_uses_the_generic_solve_rule(tmp_path):
    """IK tests and paths are generic solve jobs; study rules only for the catalogue and the RES rows;
    the full-only path sets are absent at scale=quick."""
    out = subprocess.run(
        [sys.executable, "-m", "snakemake", f"{tmp_path}/erthal1992/.built", "-n", "--nolock", "--cores", "1",
         "--config", "studies=[erthal1992]", "scale=quick", f"results_dir={tmp_path}"],
        cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    log = out.stdout
    rules = {ln.split()[1].rstrip(":") for ln in log.splitlines() if ln.startswith(("rule ", "localrule "))}
    assert rules <= {"compile_kernels", "make_problems", "solve_problems", "erthal_catalogue", "erthal_path_rows",
                     "aggregate_tables", "plot_figures", "check_prose", "study"}, rules
    n_jobs = sum(1 for p in SETS if p not in STUDY.settings["full_only_problem_sets"]
                 for _ in STUDY.set_robots(p) for _ in STUDY.set_solvers(p))
    assert log.count("rule solve_problems:") == n_jobs
    assert "runs/test2/puma560__nr_test2_1em7.mcap" in log and "paths/scara1__scara.RES" in log
    assert "test5_stage1" not in log and "scara_cartesian" not in log
