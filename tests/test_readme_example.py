"""The README's Python example runs as written, and solve() with a settings mapping is cached."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def _example() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text[text.index("## Use it as a library"):]
    m = re.search(r"```python\n(.*?)```", section, re.S)
    assert m, "no python block in the README's library section"
    return m.group(1)


def test_readme_example_runs_as_written(capsys):
    code = _example()
    assert len(code.strip().splitlines()) <= 9
    assert code.count("load_robot(") == 1 and code.count("solvers.bind(") == 1  # once each, outside the loop
    env: dict = {}
    exec(compile(code, "README.md", "exec"), env)  # noqa: S102  (our own README)
    from pipeline.kinematics import fk_htm

    ok = [r for r in env["results"] if r.success]
    assert len(ok) >= 990 and all(r.within_limits for r in ok)
    for r, T in list(zip(env["results"], env["goals"]))[:50]:
        if r.success:
            np.testing.assert_allclose(fk_htm(env["arm"].chain, r.q), T, atol=1e-9)
    out = capsys.readouterr().out
    assert re.match(r"\d+ of 1000 solved, [0-9.]+ µs per call \d+ solutions", out), out


def test_solve_with_a_mapping_reuses_its_binding():
    from pipeline import robots, solvers
    from pipeline.solvers.core import registry

    arm = robots.load_robot("ur5e")
    T = np.eye(4)
    T[:3, 3] = (0.4, 0.1, 0.3)
    solvers.solve("analytic", arm, T, np.zeros(6), {"require_limits": True})
    key = ("analytic", id(arm), (("require_limits", True),))
    first = registry._BY_VALUE[key][1]
    solvers.solve("analytic", arm, T, np.zeros(6), {"require_limits": True})
    assert registry._BY_VALUE[key][1] is first
    other = robots.load_robot("ur5e")  # another object: bound afresh, never confused with the first
    solvers.solve("analytic", other, T, np.zeros(6), {"require_limits": True})
    assert registry._BY_VALUE[("analytic", id(other), (("require_limits", True),))][1] is not first


def test_shipped_robots_load_by_name_and_a_wrong_name_is_one_line():
    import pytest

    from pipeline.robots import RobotFileError, load_robot, shipped_robots

    names = shipped_robots()
    assert {"ur5e", "franka_panda", "kuka_iiwa14", "abb_irb120"} <= set(names)
    assert load_robot("franka_panda").n == 7
    with pytest.raises(RobotFileError, match=r"^ur55: no such robot file, and not the name of a shipped robot"):
        load_robot("ur55")
