"""Contract tests of the registered solvers of 002_56eb235931bf5f5d.txt on any chain:
``inverse_jacobian_fd``, ``levenberg_marquardt`` and ``pso`` (pipeline/solvers/iterative/fd_jacobian.py, lm.py, pso.py).

Every claimed success is re-checked here with the numpy reference FK; unreachable goals must give a
reported failure (one stop reason), never an exception; PSO streams are reproducible from the seeds.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import fk_htm, geometric_jacobian
from pipeline.problems import warm_start
from pipeline.robots import LENGTH_UNITS, RobotModel, load_robot
from pipeline.solvers import Prepared, SettingsError, StopReason, make_settings, solve
from pipeline.solvers.iterative import fd_jacobian as FD
from pipeline.solvers.iterative import lm as LM
from pipeline.solvers.iterative import pso as PSO
from tests.conftest import DATA, chains, random_chain

TOL_POS_M = 1e-4           # 0.1 mm, the registry's warm-start target
TOL_ROT = 1e-3             # rad
FK_SLACK = 1 + 1e-9        # the FK check's relative slack
FD_TOL = 2e-3              # undivided forward difference vs delta * analytic Jacobian: 1/2 delta^2 |d2f/dq2|
                           # with delta = 0.01 and |d2f/dq2| up to ~ (sum of link lengths) ~ 10 on random chains
LOCAL = ("inverse_jacobian_fd", "levenberg_marquardt")
ALL = LOCAL + ("pso",)
ROBOTS = ("kuka_lwr", "ur5_nepomuceno")


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request):
    return load_robot(DATA / "robots" / f"{request.param}.yaml")


def _unit(model) -> float:
    """Metres per unit of the robot file."""
    return LENGTH_UNITS[model.length_unit]


def _fk_errors(model, T_goal, q):
    """(|dp| [m], rotation angle [rad]) by the numpy reference FK, goal in the robot file's unit."""
    T = fk_htm(model.chain, q)
    dp = np.linalg.norm(T[:3, 3] - T_goal[:3, 3]) * _unit(model)
    R = T_goal[:3, :3] @ T[:3, :3].T
    ang = np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))
    return dp, ang


def _check_claim(model, T_goal, r, pose=True, tol_pos=TOL_POS_M):
    """A success is FK-verified; a failure carries exactly one stop reason other than success."""
    assert r.stop_reason in {int(c) for c in StopReason}
    assert np.all(np.isfinite(r.q))
    if r.success:
        assert r.stop_reason == StopReason.SUCCESS
        dp, ang = _fk_errors(model, T_goal, r.q)
        assert dp <= tol_pos * FK_SLACK
        if pose:
            assert ang <= TOL_ROT * FK_SLACK
    else:
        assert r.stop_reason != StopReason.SUCCESS


# --- local methods: warm-start full-pose goals ----------------------------------------------------

@pytest.mark.parametrize("method, min_ok", [("levenberg_marquardt", 20), ("inverse_jacobian_fd", 19)])
def test_local_methods_solve_warm_start_pose_goals(robot, method, min_ok):
    """Defaults: starts within 0.3 rad of the goal angles, 0.1 mm / 1e-3 rad (500 goals give 100 % / >= 99 %)."""
    ps = warm_start(robot, 20, np.random.default_rng(3), spread=0.3)
    T = ps.goal_transforms()
    ok = 0
    for i in range(len(ps)):
        r = solve(method, robot, T[i], ps.q_start[i])
        _check_claim(robot, T[i], r)
        ok += r.success
    assert ok >= min_ok


@pytest.mark.parametrize("method", LOCAL)
def test_position_only_goals_leave_orientation_free(robot, method):
    ps = warm_start(robot, 5, np.random.default_rng(4), spread=0.3)
    T = ps.goal_transforms()
    T[:, :3, :3] = np.eye(3)  # position-only goals: identity orientation, criterion position
    for i in range(len(ps)):
        r = solve(method, robot, T[i], ps.q_start[i], {"criterion": "position"})
        _check_claim(robot, T[i], r, pose=False)
        assert r.success and np.isnan(r.orientation_error)


@pytest.mark.parametrize("method", ALL)
@pytest.mark.parametrize("criterion", ["pos_orient", "position"])
def test_unreachable_goal_is_a_reported_failure(robot, method, criterion):
    T = np.eye(4)
    T[:3, 3] = [10.0 / _unit(robot), 0.0, 0.0]  # 10 m away: beyond either arm's reach
    extra = {"max_iterations": 50} if method == "pso" else {}
    r = solve(method, robot, T, np.full(robot.n, 0.2), {"criterion": criterion, **extra}, seed=1)
    assert not r.success
    assert r.stop_reason in (StopReason.STALLED, StopReason.DIVERGING, StopReason.ITERATION_CAP, StopReason.NON_FINITE)
    assert np.all(np.isfinite(r.q))


@pytest.mark.parametrize("method", LOCAL)
def test_working_unit_does_not_change_the_solution(method):
    """LWR in cm solved in m and in cm (SI settings converted once): the same iterate sequence."""
    lwr = load_robot(DATA / "robots" / "kuka_lwr.yaml")
    ps = warm_start(lwr, 3, np.random.default_rng(5), spread=0.3)
    T = ps.goal_transforms()
    for i in range(len(ps)):
        a = solve(method, lwr, T[i], ps.q_start[i], {"length_unit": "m"})
        b = solve(method, lwr, T[i], ps.q_start[i], {"length_unit": "cm"})
        assert a.success and b.success
        assert a.iterations == b.iterations
        np.testing.assert_allclose(a.q, b.q, atol=1e-6)


@settings(max_examples=15, deadline=None)
@given(chain=chains(max_dof=7), seed=st.integers(0, 2**32 - 1))
def test_lm_takes_any_chain(chain, seed):
    """Standard or modified DH, prismatic joints, base and tool: LM converges from a near start."""
    model = RobotModel("random", "test", "m", chain, np.full((chain.n, 2), [-np.inf, np.inf]))
    rng = np.random.default_rng(seed)
    qg = rng.uniform(-np.pi, np.pi, chain.n)
    q0 = qg + rng.uniform(-0.05, 0.05, chain.n)
    T = fk_htm(chain, qg)
    crit = "pos_orient" if chain.n >= 6 else "position"
    r = solve("levenberg_marquardt", model, T, q0, {"criterion": crit, "max_iterations": 500})
    _check_claim(model, T, r, pose=crit == "pos_orient")


def test_modified_dh_prismatic_arm_all_methods():
    """A fixed modified-DH 6-joint chain with two prismatic joints and base/tool transforms."""
    rng = np.random.default_rng(21)
    chain = random_chain(rng, 6, "modified", prismatic_share=0.0)
    chain = type(chain)(chain.a, chain.alpha, chain.d, chain.theta_offset, np.array([0, 0, 1, 0, 0, 1], bool),
                        "modified", chain.base, chain.tool)
    lim = np.tile([-np.pi, np.pi], (6, 1))
    lim[[2, 5]] = [-1.0, 1.0]
    model = RobotModel("modified6", "test", "m", chain, lim)
    qg = np.array([0.3, -0.4, 0.2, 0.5, -0.6, 0.1])
    T = fk_htm(chain, qg)
    for method in LOCAL:
        r = solve(method, model, T, qg + 0.1)
        _check_claim(model, T, r)
        assert r.success
    r = solve("pso", model, T, qg + 0.02, {"criterion": "position", "tol_pos": 1e-3, "search": "window",
                                          "window_half_width": 0.05}, seed=2)
    _check_claim(model, T, r, pose=False, tol_pos=1e-3)


# --- PSO ------------------------------------------------------------------------------------------

def test_pso_solves_position_goals_in_a_window(robot):
    """Position-only goals, 1 mm, search window +-0.1 rad around a start near the goal angles."""
    ps = warm_start(robot, 5, np.random.default_rng(6), spread=0.05)
    T = ps.goal_transforms()
    s = {"criterion": "position", "tol_pos": 1e-3, "search": "window", "window_half_width": 0.1}
    for i in range(len(ps)):
        r = solve("pso", robot, T[i], ps.q_start[i], s, seed=i)
        _check_claim(robot, T[i], r, pose=False, tol_pos=1e-3)
        assert r.success and r.info["window"]
        assert np.all(np.abs(r.q - ps.q_start[i]) <= 0.1 + 1e-12)


def test_pso_box_search_stays_in_the_box(robot):
    ps = warm_start(robot, 1, np.random.default_rng(7), spread=0.3)
    T = ps.goal_transforms()[0]
    r = solve("pso", robot, T, ps.q_start[0], {"max_iterations": 30}, seed=3)
    box = Prepared(robot).search_box()
    assert np.all(r.q >= box[:, 0]) and np.all(r.q <= box[:, 1])
    assert not r.info["window"]


def test_pso_seeds_reproducible(robot):
    ps = warm_start(robot, 1, np.random.default_rng(8), spread=0.3)
    T = ps.goal_transforms()[0]
    s = {"max_iterations": 40}
    a = solve("pso", robot, T, ps.q_start[0], s, seed=10)
    b = solve("pso", robot, T, ps.q_start[0], s, seed=10)
    c = solve("pso", robot, T, ps.q_start[0], s, seed=11)
    d = solve("pso", robot, T, ps.q_start[0], {**s, "seed": 5}, seed=10)
    e = solve("pso", robot, T, ps.q_start[0], {**s, "seed": 5}, seed=10)
    assert np.array_equal(a.q, b.q) and a.iterations == b.iterations
    assert not np.array_equal(a.q, c.q)
    assert np.array_equal(d.q, e.q) and not np.array_equal(a.q, d.q)
    assert a.info["stream_seed"] == 10 and d.info["stream_seed"] == PSO.stream_seed(5, 10) != 10


def test_pso_refuses_an_unbounded_prismatic_joint_in_one_line():
    chain = random_chain(np.random.default_rng(1), 3, "standard", prismatic_share=1.0)
    model = RobotModel("slider", "test", "m", chain, np.full((3, 2), [-np.inf, np.inf]))
    from pipeline.solvers import NotApplicableError

    for search in ("box", "window"):
        with pytest.raises(NotApplicableError) as exc:
            solve("pso", model, fk_htm(chain, np.zeros(3)), np.zeros(3), {"search": search})
        assert "\n" not in str(exc.value) and "'pso'" in str(exc.value) and "prismatic" in str(exc.value)


# --- kernels against the numpy reference ---------------------------------------------------------

@settings(max_examples=25, deadline=None)
@given(chain=chains(max_dof=7), seed=st.integers(0, 2**32 - 1))
def test_undivided_fd_jacobian_is_delta_times_analytic(chain, seed):
    """Eq. 5 as used: position rows ~ delta J_v, rotation-vector rows ~ orientation_scale delta J_w."""
    q = np.random.default_rng(seed).uniform(-np.pi, np.pi, chain.n)
    n, delta, scale = chain.n, 1e-4, 0.5
    args = (chain.a, chain.alpha, chain.d, chain.theta_offset, chain.prismatic, chain.modified, chain.base, chain.tool)
    T = fk_htm(chain, q)
    J = np.empty((6, n))
    FD.fd_jacobian(*args, q, np.ascontiguousarray(T), np.empty(3), delta, FD.ROWS_POSE, scale, J, np.empty(n),
                   np.empty((4, 4)), np.empty(3), np.empty(4), np.empty(4), np.empty(3))
    Ja = geometric_jacobian(chain, q)
    np.testing.assert_allclose(J[:3], delta * Ja[:3], atol=FD_TOL * delta)
    np.testing.assert_allclose(J[3:], scale * delta * Ja[3:], atol=FD_TOL * delta)


def test_pinv_solve_square_wide_tall_and_singular():
    rng = np.random.default_rng(0)
    for m, n in ((3, 6), (6, 6), (6, 4)):
        J = rng.normal(size=(m, n))
        dx = rng.normal(size=m)
        np.testing.assert_allclose(FD.pinv_solve(J, dx), np.linalg.pinv(J) @ dx, atol=1e-10)
    J = np.zeros((3, 6))
    J[0, 0] = 1.0  # rank 1: J J^T singular
    np.testing.assert_allclose(FD.pinv_solve(J, np.array([2.0, 1.0, 1.0])), np.linalg.pinv(J) @ [2.0, 1.0, 1.0],
                               atol=1e-12)


@pytest.mark.parametrize("lam, nu, rho, expect", [
    (1.0, 2.0, 0.5, (1.0, 2.0)),          # 1 - 0^3 = 1
    (1.0, 8.0, 1.0, (0.33, 2.0)),         # perfect model: shrink to the floor, nu reset
    (1.0, 2.0, 0.25, (1.125, 2.0)),       # 1 - (-0.5)^3 = 1.125
    (3.0, 2.0, -0.1, (6.0, 4.0)),         # rejected: lam * nu, nu doubles
    (3.0, 4.0, 0.0, (12.0, 8.0)),         # rho = 0 is a rejection (MRPT: l > 0 accepts)
])
def test_nielsen_update(lam, nu, rho, expect):
    np.testing.assert_allclose(LM.nielsen(lam, nu, rho, 0.33), expect)


@given(st.floats(1e-6, 1.0), st.floats(1e-9, 1e6))
def test_nielsen_accepted_factor_bounds(rho, lam):
    new, nu = LM.nielsen(lam, 16.0, rho, 0.33)
    assert 0.33 * lam * (1 - 1e-12) <= new <= 2 * lam and nu == 2.0


# --- settings ---------------------------------------------------------------------------------------

def test_settings_are_si_and_checked():
    s = make_settings("levenberg_marquardt", {"length_unit": "mm", "error_change_stop": 1e-9})
    assert s.converted().error_change_stop == pytest.approx(1e-6)
    with pytest.raises(SettingsError, match="orientation_rows"):
        make_settings("inverse_jacobian_fd", {"criterion": "pos_orient", "orientation_rows": "position"})
    with pytest.raises(SettingsError, match="'search'"):
        make_settings("pso", {"search": "everywhere"})
    assert make_settings("inverse_jacobian_fd", {"criterion": "position"}).rows() == FD.ROWS_POSITION
    assert make_settings("inverse_jacobian_fd", {}).rows() == FD.ROWS_POSE


def test_pso_velocity_clamp_as_a_fraction_of_each_joints_range():
    """max_velocity_fraction k clamps joint j at k (hi_j - lo_j); a scalar max_velocity is the same for
    every joint; 0 means no clamp; setting both is one error naming the field."""
    s = make_settings("pso", {"max_velocity_fraction": 0.2})
    lo, hi = np.array([-1.0, 0.0, -3.0]), np.array([1.0, 0.5, 3.0])
    np.testing.assert_allclose(s.velocity_limits(lo, hi), [0.4, 0.1, 1.2])
    np.testing.assert_allclose(make_settings("pso", {"max_velocity": 0.03}).velocity_limits(lo, hi), [0.03] * 3)
    assert not make_settings("pso", None).velocity_limits(lo, hi).any()
    with pytest.raises(SettingsError, match="field 'max_velocity_fraction': set either"):
        make_settings("pso", {"max_velocity": 0.03, "max_velocity_fraction": 0.1})


def test_pso_with_equal_per_joint_clamps_matches_the_scalar_clamp(robot):
    """A fraction giving the same clamp on every joint reproduces the scalar-clamp run bit for bit."""
    prep = Prepared(robot, "m")
    q_goal = np.full(robot.chain.n, 0.2)  # the window q_start +- 0.25 stays inside every joint's limits
    T = fk_htm(robot.chain, q_goal)
    base = {"search": "window", "window_half_width": 0.25, "max_iterations": 40, "particles": 20}
    a = solve("pso", prep, T, q_goal + 0.1, {**base, "max_velocity": 0.05}, seed=2)
    b = solve("pso", prep, T, q_goal + 0.1, {**base, "max_velocity_fraction": 0.1}, seed=2)  # 0.1 x 0.5 rad
    assert a.iterations == b.iterations and np.array_equal(a.q, b.q)
