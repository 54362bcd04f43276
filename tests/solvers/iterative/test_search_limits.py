"""The ``search_limits`` setting of the Jacobian-family methods (issue 43, item 2): every iterate stays inside
the joint limits, a success is confirmed by an independent forward kinematics, the setting is validated in
one line, and while it is off the settings record (archives, job hashes) is what it was before it existed."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline import robots, solvers
from pipeline.kinematics import fk_htm
from pipeline.solvers import SettingsError, make_settings
from pipeline.solvers.kernels.kin import SEARCH_LIMITS

METHODS = ("jacobian_transpose", "pseudoinverse", "dls", "sdls", "levenberg_marquardt")
MODES = tuple(m for m in SEARCH_LIMITS if m != "off")
ROBOT = "franka_panda"  # 7R with limits on every joint, some far from symmetric (joints 4 and 6)
N_PROBLEMS = 4
ITERATES = range(2, 16)  # the last iterate of a search capped at k iterations is iterate k of a longer one
POS_TOL = 1e-4  # [m] the registry default tol_pos: what a success promises
ROT_TOL = 1e-3  # [rad] the registry default tol_rot


@pytest.fixture(scope="module")
def panda():
    model = robots.load_robot(f"data/robots/{ROBOT}.yaml")
    rng = np.random.default_rng(43)
    lo, hi = model.limits[:, 0], model.limits[:, 1]
    goals = fk_htm(model.chain, lo + (hi - lo) * rng.random((N_PROBLEMS, model.n)))
    starts = lo - 0.5 + (hi - lo + 1.0) * rng.random((N_PROBLEMS, model.n))  # some starts outside the limits
    return model, goals, starts


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("method", METHODS)
def test_every_iterate_stays_inside_the_limits(panda, method, mode):
    """Search k stops after k iterations, so its returned q (no ``require_limits``: the raw last iterate) is
    iterate k; each lies inside the limits exactly (the clamp is the last operation), the start included."""
    model, goals, starts = panda
    prep = solvers.Prepared(model)
    lo, hi = prep.limits[:, 0], prep.limits[:, 1]
    for k in ITERATES:
        s = make_settings(method, {"max_iterations": k, "search_limits": mode})
        for T, q0 in zip(goals, starts):
            q = solvers.solve(method, prep, T, q0, s).q
            assert np.all(q >= lo) and np.all(q <= hi), (method, mode, k, q)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("method", ("pseudoinverse", "dls", "sdls", "levenberg_marquardt"))
def test_a_success_is_checked_by_forward_kinematics(panda, method, mode):
    """Every reported success reaches the goal by an independent FK and lies within the limits; the modes
    that work (clamp, reflect) succeed at least once on these goals."""
    model, goals, starts = panda
    s = make_settings(method, {"search_limits": mode, "require_limits": True, "restarts": 5})
    wins = 0
    for T, q0 in zip(goals, np.clip(starts, model.limits[:, 0], model.limits[:, 1])):
        res = solvers.solve(method, model, T, q0, s)
        if not res.success:
            continue
        wins += 1
        F = fk_htm(model.chain, res.q)
        assert np.linalg.norm(F[:3, 3] - T[:3, 3]) <= POS_TOL
        c = (np.trace(F[:3, :3].T @ T[:3, :3]) - 1.0) / 2.0
        assert np.arccos(np.clip(c, -1.0, 1.0)) <= ROT_TOL
        assert np.all(res.q >= model.limits[:, 0] - 1e-6) and np.all(res.q <= model.limits[:, 1] + 1e-6)
    if mode in ("clamp", "reflect"):
        assert wins > 0


@pytest.mark.parametrize("mode", MODES)
def test_batch_equals_single_calls(panda, mode):
    """The batch kernel reads the limits from the same packed vector as the single call."""
    model, goals, starts = panda
    s = make_settings("dls", {"search_limits": mode})
    batch = solvers.solve_batch("dls", model, goals, starts, s, threads=1)
    for i in range(len(goals)):
        one = solvers.solve("dls", model, goals[i], starts[i], s)
        assert np.array_equal(batch.q[i], one.q) and batch.iterations[i] == one.iterations


@pytest.mark.parametrize("bad, words", [("bogus", "is not one of"), (True, "expected str"), (3, "expected str")])
@pytest.mark.parametrize("method", ("dls", "levenberg_marquardt"))
def test_a_bad_value_is_one_line_naming_the_field(method, bad, words):
    with pytest.raises(SettingsError) as err:
        make_settings(method, {"search_limits": bad}, "study.yaml: solvers/x")
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("study.yaml: solvers/x: field 'search_limits'") and words in msg


def test_methods_without_the_setting_refuse_it():
    with pytest.raises(SettingsError, match="field 'search_limits': unknown setting"):
        make_settings("newton_raphson", {"search_limits": "clamp"})


@pytest.mark.parametrize("method", ("dls", "levenberg_marquardt"))
def test_off_is_left_out_of_the_settings_record(method):
    """Off (the default) is not recorded, so archives and job hashes of existing labels do not change; any
    other mode is recorded and reads back."""
    off = make_settings(method)
    assert "search_limits" not in off.as_dict()
    assert make_settings(method, off.as_dict()) == off
    on = make_settings(method, {"search_limits": "reflect"})
    assert on.as_dict()["search_limits"] == "reflect"
    assert make_settings(method, on.as_dict()) == on


def test_the_answer_names_the_setting_in_words():
    from pipeline.studies.arm_answer import in_words

    assert in_words("dls", {"search_limits": "reflect", "restarts": 20}, 7, "local") == \
        "damped least squares, kept within the limits (reflected), 20 random restarts"
    assert in_words("dls", {}, 7, "local") == "damped least squares, one search"
