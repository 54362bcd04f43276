"""Every program to copy that the quick build's answer generates runs as written, in a fresh process:
it loads the robot once, binds the recommended solver once, solves 1 000 goals and prints how many it
solved, no fewer than the answer's interval allows."""

from __future__ import annotations

import re
import subprocess
import sys

import pandas as pd
import pytest

from tests.conftest import ROOT


@pytest.fixture(scope="module")
def calls(quick_build):
    ans = pd.read_csv(quick_build / "arm_benchmark" / "tables" / "answer.csv", keep_default_na=False)
    assert len(ans) and (ans["recommendation"] != "").all(), "every arm x set row has a recommendation"
    out = {}
    for _, r in ans.iterrows():  # one run per distinct program; the lowest interval end of the rows it serves
        lo = float(r["success CI low [%]"])
        out[r["call"]] = min(lo, out.get(r["call"], lo))
    return out


def test_every_row_has_a_program_and_a_plain_row(quick_build):
    ans = pd.read_csv(quick_build / "arm_benchmark" / "tables" / "answer.csv", keep_default_na=False)
    plain = pd.read_csv(quick_build / "arm_benchmark" / "tables" / "answer_plain.csv", keep_default_na=False)
    assert len(plain) == len(ans) and list(plain["arm"]) == list(ans["robot"])
    for call in ans["call"]:
        assert "robots.load_robot(" in call and "solvers.bind(" in call and "for T_goal, q_start in zip" in call
        assert call.count("load_robot(") == 1 and call.count("solvers.bind(") == 1  # once, outside the loop


def test_every_generated_program_runs_as_written(calls):
    for call, ci_low in calls.items():
        proc = subprocess.run([sys.executable, "-c", call], capture_output=True, text=True, cwd=ROOT, timeout=900)
        assert proc.returncode == 0, f"{call}\n{proc.stderr[-2000:]}"
        m = re.search(r"solved (\d+) of 1000, median ([0-9.]+) us per call", proc.stdout)
        assert m, proc.stdout
        # the quick build's interval comes from 50 goals: the 1 000 here may not fall far below its low end
        assert int(m.group(1)) >= 10 * (ci_low - 10), f"{call}\nsolved {m.group(1)} of 1000, interval from {ci_low} %"
