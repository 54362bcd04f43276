"""Registered methods of 004 (Nepomuceno 2024): jpinv_descent, bfgs, lbfgsb, nelder_mead, analytic_ur.

Compiled pieces against numpy formulas on random DH chains (standard/modified, prismatic joints,
base/tool), warm-start goals on the KUKA LWR (cm) and the UR5 with the registry defaults, reported
(not raised) failures, settings errors, and the UR closed form against the numpy reference FK.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import Chain, fk_htm
from pipeline.problems import warm_start
from pipeline.robots import RobotModel, load_robot, parse_robot
from pipeline.solvers import NotApplicableError, Prepared, SettingsError, StopReason, make_settings, prepare, solve
from pipeline.solvers.iterative import optimizers as opt
from tests.conftest import chains

ROOT = Path(__file__).resolve().parents[3]
LWR = load_robot(ROOT / "data/robots/kuka_lwr.yaml")          # lengths in cm
UR5 = load_robot(ROOT / "data/robots/ur5_nepomuceno.yaml")
UR5E = load_robot(ROOT / "data/robots/ur5e.yaml")
LOCAL = ["jpinv_descent", "bfgs", "lbfgsb", "nelder_mead"]
FORMULA_TOL = 1e-12   # compiled vs numpy: same formula, rounding only
FD_REL = 1e-5         # central differences (h = 1e-6) vs analytic gradient
IK_VERIFY = 1e-9      # closed-form solutions are exact up to rounding


def _model(chain: Chain, unit: str = "m") -> RobotModel:
    n = chain.n
    joints = [{"type": "prismatic" if chain.prismatic[i] else "revolute", "a": float(chain.a[i]),
               "alpha": float(chain.alpha[i]), "d": float(chain.d[i]), "theta_offset": float(chain.theta_offset[i])}
              for i in range(n)]
    return parse_robot({"name": "random", "source": "test", "length_unit": unit,
                        "convention": "modified" if chain.modified else "standard", "joints": joints,
                        "base": chain.base.tolist(), "tool": chain.tool.tolist()})


def _numpy_cost(T, Tg, wp, wr, squared):
    dp = np.linalg.norm(T[:3, 3] - Tg[:3, 3])
    dr = np.linalg.norm(T[:3, :3] - Tg[:3, :3])
    return wp * dp * dp + wr * dr * dr if squared else wp * dp + wr * dr


# compiled pieces ---------------------------------------------------------------------------------

@settings(max_examples=30, deadline=None)
@given(chain=chains(), seed=st.integers(0, 2**32 - 1), squared=st.booleans())
def test_cost_and_gradient_match_numpy_on_any_dh_chain(chain, seed, squared):
    rng = np.random.default_rng(seed)
    model = _model(chain)
    prep = Prepared(model)
    q = rng.uniform(-np.pi, np.pi, chain.n)
    Tg = fk_htm(model.chain, rng.uniform(-np.pi, np.pi, chain.n))
    s = make_settings("bfgs", {"position_weight": 0.7, "rotation_weight": 0.3, "squared": squared})
    P = opt.packed_cost(prep, Tg, s)
    T = fk_htm(model.chain, q)
    assert opt.cost(q, P) == pytest.approx(_numpy_cost(T, Tg, 0.7, 0.3, squared), rel=FORMULA_TOL, abs=FORMULA_TOL)
    f, g = opt.cost_grad(q, P)
    assert f == pytest.approx(opt.cost(q, P), rel=FORMULA_TOL, abs=FORMULA_TOL)
    h = 1e-6
    fd = np.array([(opt.cost(q + h * e, P) - opt.cost(q - h * e, P)) / (2 * h) for e in np.eye(chain.n)])
    np.testing.assert_allclose(g, fd, rtol=FD_REL, atol=FD_REL * max(1.0, np.abs(fd).max()))


def test_cost_is_in_si_whatever_the_working_unit():
    q_goal = np.array([0.3, -0.5, 0.4, 1.2, -0.3, 0.8, 0.1])
    Tg = fk_htm(LWR.chain, q_goal)
    q = q_goal + 0.05
    vals = []
    for unit in ("m", "cm", "mm"):
        s = make_settings("bfgs", {"length_unit": unit})
        prep = prepare("bfgs", LWR, s)
        vals.append(opt.cost(q, opt.packed_cost(prep, prep.working_goal(Tg), s)))
    np.testing.assert_allclose(vals, vals[0], rtol=1e-12)


def test_document_error_vector_is_sin_angle_axis_and_position():
    T = fk_htm(UR5.chain, np.array([0.1, -1.0, 1.0, 1.5, 1.5, 0.3]))
    e = np.empty(6)
    assert opt.doc_error(T, T, e) == 0.0 and np.allclose(e, 0.0, atol=1e-15)
    a = 1e-4  # a small rotation about z of the goal: ½Σc×d ≈ the rotation vector (base frame)
    G = T.copy()
    G[:3, :3] = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]]) @ T[:3, :3]
    G[:3, 3] += [1e-3, 0, 0]
    assert opt.doc_error(T, G, e) == pytest.approx(1e-3, rel=1e-9)
    np.testing.assert_allclose(e, [1e-3, 0, 0, 0, 0, math.sin(a)], atol=1e-12)


def test_bounds_setting_parses_pi_expressions_and_rejects_bad_text():
    assert opt.parse_bounds("limits") == "limits"
    assert opt.parse_bounds("-pi, pi; -pi/2, 2*pi/3") == [(-math.pi, math.pi), (-math.pi / 2, 2 * math.pi / 3)]
    for bad in ("1, 0", "0, 1, 2", "a, b"):
        with pytest.raises(SettingsError, match="field 'bounds'") as exc:
            make_settings("lbfgsb", {"bounds": bad})
        assert "\n" not in str(exc.value)


def test_settings_errors_are_one_line_naming_the_field():
    for name, d, field in (("bfgs", {"gradient": "3-point"}, "gradient"), ("jpinv_descent", {"rate": 0.0}, "rate"),
                           ("nelder_mead", {"xatol": -1.0}, "xatol"), ("bfgs", {"max_iter": 3}, "max_iter")):
        with pytest.raises(SettingsError, match=f"field '{field}'") as exc:
            make_settings(name, d)
        assert "\n" not in str(exc.value)
    with pytest.raises(SettingsError, match="bounds"):  # wrong number of joints: reported at the solve
        solve("lbfgsb", UR5, np.eye(4), np.zeros(6), {"bounds": "-1, 1; -1, 1"})


# warm starts with the registry defaults ---------------------------------------------------------

@pytest.mark.parametrize("name", LOCAL)
@pytest.mark.parametrize("robot", ["kuka_lwr", "ur5_nepomuceno"])
def test_defaults_solve_warm_start_goals_to_a_tenth_of_a_millimetre(name, robot):
    """start within 0.3 rad of the goal angles, full pose, 0.1 mm / 1e-3 rad (defaults)."""
    model = LWR if robot == "kuka_lwr" else UR5
    ps = warm_start(model, 30, np.random.default_rng(17))
    s = make_settings(name, {})
    prep = prepare(name, model, s)
    ok = 0
    for T, q0 in zip(ps.goal_transforms(), ps.q_start):
        r = solve(name, prep, T, q0, s)
        assert r.stop_reason in {int(x) for x in StopReason} and np.all(np.isfinite(r.q))
        if r.success:
            ok += 1
            assert r.position_error <= 1e-4 and r.orientation_error <= 1e-3  # working unit m
            Tq = fk_htm(model.chain, r.q)  # numpy FK in the robot file's unit (cm for the LWR)
            scale = 100.0 if robot == "kuka_lwr" else 1.0
            assert np.linalg.norm(Tq[:3, 3] - T[:3, 3]) <= 1e-4 * scale * (1 + 1e-9)
    assert ok >= 29


@pytest.mark.parametrize("name", LOCAL)
def test_methods_take_any_dh_chain_with_base_and_tool(name):
    """Modified DH, a prismatic joint, base and tool: a nearby goal is solved."""
    rng = np.random.default_rng(5)
    from tests.conftest import random_chain

    done = 0
    for _ in range(40):
        chain = random_chain(rng, 6, str(rng.choice(["standard", "modified"])), prismatic_share=0.2)
        if not chain.prismatic.any() or done >= 3:
            continue
        model = _model(chain, "m")
        q_goal = rng.uniform(-1, 1, 6)
        r = solve(name, model, fk_htm(model.chain, q_goal), q_goal + 0.02, {})
        assert r.success, (name, r.stop_reason, r.position_error)
        done += 1
    assert done == 3


@pytest.mark.parametrize("name", LOCAL)
def test_unreachable_goal_is_reported_not_raised(name):
    T = np.eye(4)
    T[:3, 3] = [3.0, 0.0, 0.2]  # the UR5 reaches about 1.1 m
    s = {"max_iterations": 300} if name != "lbfgsb" else {"max_iterations": 300, "max_evaluations": 600}
    r = solve(name, UR5, T, np.array([0.1, -1.0, 1.0, 1.5, 1.5, 0.3]), s)
    assert not r.success and r.stop_reason in (StopReason.STALLED, StopReason.ITERATION_CAP)
    assert np.all(np.isfinite(r.q)) and r.position_error > 1.5


def test_lbfgsb_stays_in_its_box():
    q_goal = np.array([0.43, -0.75, 0.95, 1.37, 1.2, 1.48])
    box = "-pi, pi; -pi/2, pi/2; -pi/2, pi/2; -pi, pi; -pi/2, pi/2; -pi, pi"
    r = solve("lbfgsb", UR5, fk_htm(UR5.chain, q_goal), q_goal + 0.2, {"bounds": box})
    b = np.array(opt.parse_bounds(box))
    assert r.success and np.all(r.q >= b[:, 0]) and np.all(r.q <= b[:, 1])


def test_descent_with_its_own_robot_file_as_jacobian_model_is_the_same_run():
    q_goal = np.array([0.1, -1.0, 1.0, 1.5, 1.5, 0.3])
    T = fk_htm(UR5.chain, q_goal)
    a = solve("jpinv_descent", UR5, T, q_goal + 0.1, {})
    b = solve("jpinv_descent", UR5, T, q_goal + 0.1, {"jacobian_robot": "data/robots/ur5_nepomuceno.yaml"})
    assert np.array_equal(a.q, b.q) and a.iterations == b.iterations
    with pytest.raises(SettingsError, match="jacobian_robot"):
        solve("jpinv_descent", UR5, T, q_goal, {"jacobian_robot": "data/robots/kuka_lwr.yaml"})


def test_descent_listing_mode_takes_every_step():
    """halvings = 0, damping = 0, no tolerance stop: θ += rate J⁺e until ‖e‖ < tolerance (Apêndice E)."""
    q_goal = np.array([0.1, -1.0, 1.0, 1.5, 1.5, 0.3])
    s = {"rate": 0.05, "halvings": 0, "damping": 0.0, "stop_at_tolerance": False, "tol_pos": 1e-3, "tol_rot": 1e-2}
    r = solve("jpinv_descent", UR5, fk_htm(UR5.chain, q_goal), q_goal + 1e-3, s)
    assert r.success and r.trace[-1, 0] < 1e-6 <= r.trace[-2, 0]
    ratio = r.trace[1:, 0] / r.trace[:-1, 0]
    np.testing.assert_allclose(ratio[-20:], 0.95, atol=2e-3)  # linear rate 1 - rate with the exact Jacobian


# the UR closed form ------------------------------------------------------------------------------

def _ur_variant(base=None, tool=None, offsets=(0, 0, 0, 0, 0, 0), d23=(0.0, 0.0), convention="standard"):
    c = UR5E.chain
    d = c.d.copy()
    d[1], d[2] = d23
    joints = [{"type": "revolute", "a": float(c.a[i]), "alpha": float(c.alpha[i]), "d": float(d[i]),
               "theta_offset": float(offsets[i])} for i in range(6)]
    doc = {"name": "ur_variant", "source": "test", "length_unit": "m", "convention": convention, "joints": joints}
    if base is not None:
        doc["base"] = base.tolist()
    if tool is not None:
        doc["tool"] = tool.tolist()
    return parse_robot(doc)


def _transform(rng, scale):
    from tests.conftest import random_transform

    return random_transform(rng, scale)


ANGLES = st.lists(st.floats(-math.pi, math.pi, allow_nan=False), min_size=6, max_size=6).map(np.array)


@settings(max_examples=40, deadline=None)
@given(q=ANGLES, seed=st.integers(0, 2**32 - 1), robot=st.sampled_from(["ur5", "ur5e", "variant"]))
def test_analytic_solutions_are_all_fk_valid_by_numpy_fk(q, seed, robot):
    """Every returned solution reaches the goal by the numpy reference FK; base/tool, offsets, d2/d3."""
    rng = np.random.default_rng(seed)
    model = {"ur5": UR5, "ur5e": UR5E}.get(robot) or _ur_variant(
        _transform(rng, 0.5), _transform(rng, 0.1), rng.uniform(-1, 1, 6), (0.03, -0.02))
    T = fk_htm(model.chain, q)
    r = solve("analytic_ur", model, T, q + 0.05, {})
    assert r.solutions is not None and r.solutions.shape[1] == 6
    for qs in r.solutions:
        Tq = fk_htm(model.chain, qs)
        assert np.linalg.norm(Tq[:3, 3] - T[:3, 3]) < 10 * IK_VERIFY
        assert np.linalg.norm(Tq[:3, :3] - T[:3, :3]) < 10 * IK_VERIFY
    if abs(math.sin(q[4])) > 1e-3 and abs(math.sin(q[2])) > 1e-3:  # away from wrist and elbow singularities
        assert r.success and len(r.solutions) >= 1
        dist = np.abs((r.solutions - q + np.pi) % (2 * np.pi) - np.pi).max(axis=1)
        assert dist.min() < 1e-6  # the generating angles are among the solutions
        # the solution nearest the start (sum of squared wrapped joint differences), unwrapped near the
        # start; near an elbow or wrist fold two branches can lie closer to each other than the start's
        # 0.05 rad offset, so "nearest the start" is not always the generating angles
        wrapped = lambda a: (a + np.pi) % (2 * np.pi) - np.pi  # noqa: E731
        near = r.solutions[np.argmin((wrapped(r.solutions - (q + 0.05)) ** 2).sum(axis=1))]
        assert np.abs(wrapped(r.q - near)).max() < 1e-9 and np.abs(r.q - (q + 0.05)).max() <= math.pi


def test_analytic_unreachable_goal_is_no_solution_with_finite_angles():
    T = np.eye(4)
    T[:3, 3] = [3.0, 0.0, 0.2]
    q0 = np.array([0.1, -1.0, 1.0, 1.5, 1.5, 0.3])
    r = solve("analytic_ur", UR5, T, q0, {})
    assert not r.success and r.stop_reason == StopReason.NO_SOLUTION
    assert np.array_equal(r.q, q0) and r.solutions.shape == (0, 6) and r.info["n_solutions"] == 0


@pytest.mark.parametrize("robot,reason", [
    ("kuka_lwr", "not a UR-type"), ("puma560", "not a UR-type"), ("stanford", "not a UR-type"),
])
def test_analytic_refuses_non_ur_robots_with_one_line(robot, reason):
    with pytest.raises(NotApplicableError, match=reason) as exc:
        solve("analytic_ur", load_robot(ROOT / f"data/robots/{robot}.yaml"), np.eye(4), np.zeros(6 if robot != "kuka_lwr" else 7), {})
    assert "\n" not in str(exc.value) and "analytic_ur" in str(exc.value)


def test_analytic_ur_judges_the_geometry_not_the_file_form():
    """UR's numbers read as a modified-DH table are another arm: solved if its joint axes still give
    the UR family (by the geometric closed form), else refused naming the geometry, never the form."""
    from pipeline.kinematics.geometry import classify

    model = _ur_variant(convention="modified")
    fam = classify(model.chain).family
    if fam == "three_parallel":
        q = np.array([0.3, -0.8, 1.1, 0.4, -0.6, 0.2])
        r = solve("analytic_ur", model, fk_htm(model.chain, q), q + 0.1, {})
        assert r.success
    else:
        with pytest.raises(NotApplicableError) as exc:
            prepare("analytic_ur", model, make_settings("analytic_ur"))
        msg = str(exc.value)
        assert "axes" in msg and "DH" not in msg and "URDF" not in msg and "\n" not in msg
    # the official URDF form of the UR5e (joint origins with rpy) is solved under the same name
    ur5e_urdf = load_robot(ROOT / "data/robots/ur5e_urdf.yaml")
    q = np.array([0.5, -1.2, 1.0, -0.4, 0.9, 2.0])
    r = solve("analytic_ur", ur5e_urdf, fk_htm(ur5e_urdf.chain, q), q + 0.05, {})
    assert r.success and len(r.solutions) >= 2 and np.allclose(r.q, q, atol=1e-9)
