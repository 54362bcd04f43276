"""Study 000 (cerbaro2019): each method's step on hand-checkable cases, every stop code, readings."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.kinematics import fk_htm, geometric_jacobian
from pipeline.robots import parse_robot
from pipeline.settings import load_study
from pipeline.solvers import make_settings, solve
from pipeline.solvers.kernels import pose as _jit
from pipeline.solvers.iterative.jacobian import packed
from tests.conftest import DATA

STEP_TOL = 1e-12  # closed forms vs the compiled step, same arithmetic up to rounding


def _planar(n):
    return parse_robot({"name": "planar", "source": "test", "length_unit": "m", "convention": "standard",
                        "joints": [{"type": "revolute", "a": 1.0, "alpha": 0, "d": 0, "theta_offset": 0}] * n})


def S(method="dls", **kw):
    """The study's default reading of a method (DQ-norm criterion), with overrides."""
    return make_settings(method, {"criterion": "dq_norm", **kw})


def _step(method, J, e, **kw):
    ip, fp = packed(method, S(method, **kw))
    return _jit.step(_jit.METHODS[method], J, e, ip, fp)


@pytest.fixture
def planar_case():
    m = _planar(3)
    q = np.array([0.3, 0.9, -0.4])
    J = geometric_jacobian(m.chain, q)
    e = np.array([0.05, -0.02, 0, 0, 0, 0.01])
    return J, e


def test_transpose_step_eq48(planar_case):
    J, e = planar_case
    g = J.T @ e
    alpha = (e @ (J @ g)) / ((J @ g) @ (J @ g))
    np.testing.assert_allclose(_step("jacobian_transpose", J, e), alpha * g, atol=STEP_TOL)


def test_pseudoinverse_step_eq49(planar_case):
    """A 2R arm at q = (0, pi/2): J restricted to (x, y) is [[-1, -1], [1, 0]], so J^-1 e by hand."""
    J = geometric_jacobian(_planar(2).chain, np.array([0.0, np.pi / 2]))[[0, 1]]
    np.testing.assert_allclose(_step("pseudoinverse", J, np.array([0.1, 0.2])), [0.2, -0.3], atol=STEP_TOL)
    J6, e = planar_case  # 6 x 3, rank 3: eq. 49 needs J J^T invertible, so the SVD fallback applies
    np.testing.assert_allclose(_step("pseudoinverse", J6, e), np.linalg.pinv(J6) @ e, atol=1e-10)


def test_dls_step_eq50(planar_case):
    J, e = planar_case
    expect = J.T @ np.linalg.solve(J @ J.T + 0.01 * np.eye(6), e)
    np.testing.assert_allclose(_step("dls", J, e, damping=0.1), expect, atol=1e-10)


def test_sdls_equals_pseudoinverse_without_clamping(planar_case):
    J, e = planar_case
    np.testing.assert_allclose(_step("sdls", J, e, gamma_max=1e6), np.linalg.pinv(J) @ e, atol=1e-10)


@pytest.mark.parametrize("norm,fn", [("maxabs", lambda x: np.abs(x).max()), ("one", lambda x: np.abs(x).sum())])
def test_sdls_clamps_to_gamma_max(planar_case, norm, fn):
    J, e = planar_case
    dq = _step("sdls", J, 100 * e, gamma_max=0.05, sdls_norm=norm)
    assert fn(dq) <= 0.05 + 1e-12


def _goal_m(lwr, q):
    """Goal pose in metres (for the LWR converted to metres: ``lwr.in_unit("m")``)."""
    T = fk_htm(lwr.chain, q)
    T[:3, 3] /= 100
    return T


def test_stop_code_1_success(lwr):
    qg = np.full(7, 0.7)
    res = solve("dls", lwr.in_unit("m"), _goal_m(lwr, qg), qg + 0.05, S(length_unit="m"))
    assert res.stop_reason == 1 and res.success


def test_stop_code_2_stall(lwr):
    s = S(length_unit="m", stall_dq=2.0)  # any move counts as "no progress"
    res = solve("dls", lwr.in_unit("m"), _goal_m(lwr, np.full(7, 0.7)), np.full(7, 0.2), s)
    assert res.stop_reason == 2 and res.iterations == 1 and not res.success


def test_stop_code_3_error_grows():
    m = _planar(3)
    T = np.eye(4)
    T[0, 3] = 5.0  # beyond the 3 m reach: the pseudoinverse overshoots back and forth
    res = solve("pseudoinverse", m, T, np.array([0.0, 0.1, 0.1]), S("pseudoinverse", grow_limit=1))
    assert res.stop_reason == 3 and not res.success


def test_stop_code_4_iteration_cap(lwr):
    s = S("jacobian_transpose", length_unit="m", max_iterations=3, grow_limit=100)
    res = solve("jacobian_transpose", lwr.in_unit("m"), _goal_m(lwr, np.full(7, 2.0)), np.zeros(7), s)
    assert res.stop_reason == 4 and res.iterations == 3 and res.trace.shape == (4, 8)


def test_disabling_codes_2_and_3():
    m = _planar(3)
    T = np.eye(4)
    T[0, 3] = 5.0
    s = S("pseudoinverse", grow_limit=1, disable_grow=True, disable_stall=True, max_iterations=50)
    res = solve("pseudoinverse", m, T, np.array([0.0, 0.1, 0.1]), s)
    assert res.stop_reason == 4 and res.iterations == 50


def test_readings_expand_and_switch_units():
    st = load_study(DATA / "studies" / "cerbaro2019.yaml")
    assert st.default_solvers() == ["jacobian_transpose", "pseudoinverse", "dls", "sdls"]
    sv = {k: v.settings for k, v in st.solvers.items()}
    assert sv["dls"].length_unit == "m" and sv["dls_cm_dqnorm"].length_unit == "cm"
    assert sv["dls_cm_dqnorm"].damping == sv["dls"].damping
    assert sv["sdls_m_posorient"].criterion == "pos_orient" and st.solvers["sdls_m_posorient"].method == "sdls"
    assert st.readings["sdls_m_axisangle"] == "m_axisangle" and st.readings["sdls"] == "m_dqnorm"
    assert st.solver_hash("random", "dls", "full") != st.solver_hash("random", "dls_cm_dqnorm", "full")
    # explicit text wins: SDLS clamps by the 1-norm of §3; Buss's max-abs is a reading for SDLS only
    assert sv["sdls"].sdls_norm == "one" and sv["sdls_maxabs"].sdls_norm == "maxabs"
    assert "dls_maxabs" not in sv and st.readings["sdls_maxabs"] == "maxabs"


def test_a_reading_limited_to_unknown_solvers_is_refused(tmp_path):
    import yaml

    from pipeline.settings import ConfigError

    doc = yaml.safe_load((DATA / "studies" / "cerbaro2019.yaml").read_text())
    doc["readings"]["variants"]["maxabs"]["only"] = ["sdsl"]
    bad = tmp_path / "cerbaro2019.yaml"
    bad.write_text(yaml.safe_dump(doc, allow_unicode=True))
    with pytest.raises(ConfigError, match=r"readings/variants/maxabs/only': unknown solver\(s\) \['sdsl'\]"):
        load_study(bad)


def test_unit_reading_changes_the_tolerance_meaning(lwr):
    """1 + 1e-6 on the DQ norm is |t| <= 2.83e-3 of the length unit: 2.8 mm in m, 0.028 mm in cm."""
    from pipeline.solvers import verify

    qg = np.full(7, 0.7)
    goal_cm = fk_htm(lwr.chain, qg)
    goal_cm[0, 3] += 0.1  # the goal is 1 mm (0.1 cm) away from FK(qg), same orientation
    goal_m = goal_cm.copy()
    goal_m[:3, 3] /= 100
    assert verify(lwr.in_unit("m"), goal_m, qg, S(length_unit="m").converted())[0]
    assert not verify(lwr, goal_cm, qg, S(length_unit="cm").converted())[0]


def test_same_seed_same_archive_columns(tmp_path):
    """Two solve jobs on the same problem file: identical success, iteration and stop-code columns."""
    from pipeline.cli import main
    from pipeline.io.archive import read_archive

    study, robot = str(DATA / "studies" / "cerbaro2019.yaml"), str(DATA / "robots" / "kuka_lwr.yaml")
    problems = tmp_path / "p.csv"
    assert main(["make_problems", "--study", study, "--problem-set", "random", "--robot", robot, "--scale", "quick", "--out", str(problems)]) == 0
    frames = []
    for k in range(2):
        out = tmp_path / f"a{k}.mcap"
        assert main(["solve_problems", "--study", study, "--problem-set", "random", "--robot", robot, "--solver", "sdls", "--problems",
                     str(problems), "--scale", "quick", "--limit", "40", "--out", str(out)]) == 0
        frames.append(read_archive(out).frame())
    cols = ["problem_id", "success", "iterations", "stop_reason", "q_solution", "final_error"]
    assert frames[0][cols].equals(frames[1][cols])
