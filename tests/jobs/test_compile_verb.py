"""``python -m pipeline compile``: methods bound to each arm they apply to and called once, with one progress
line per method; peers and unknown names refused in one line."""

from __future__ import annotations

from pipeline.cli import main


def test_compile_reports_each_method_and_the_arms_it_ran_on(capsys):
    assert main(["compile", "dls", "analytic_ur", "--robots", "ur5e", "planar2r"]) == 0
    out, err = capsys.readouterr()
    lines = [ln for ln in err.splitlines() if ln.startswith("[")]
    assert lines[0].startswith("[1/2] dls: 2 arm(s), ") and lines[1].startswith("[2/2] analytic_ur: 1 arm(s), ")
    assert out.startswith("compiled or loaded the kernels of 2 method(s) in ")


def test_compile_refuses_in_one_line(capsys):
    for argv, want in ([["compile"], "name the methods to compile, or --all"],
                       [["compile", "eaik"], "eaik: a peer library's method, not numba code"],
                       [["compile", "nosuch"], "unknown solver 'nosuch'"],
                       [["compile", "dls", "--robots", "no_such_arm"], "no_such_arm"]):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and want in err, err
