"""`python -m pipeline --help`: fast because it imports no heavy library (numpy, pandas, numba, ...), which is
what is checked here (no test asserts a wall time: a loaded machine moves it; ``python -X importtime -m
pipeline --help`` shows the cost), and every verb listed once."""

from __future__ import annotations

import re
import subprocess
import sys

from tests.conftest import ROOT


def _help() -> str:
    proc = subprocess.run([sys.executable, "-m", "pipeline", "--help"], cwd=ROOT, capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


def test_help_lists_every_verb_once_with_a_one_line_summary():
    from pipeline.cli import build_parser

    out = _help()
    verbs = [a for a in build_parser()._subparsers._group_actions[0].choices]
    names = [v for v in verbs if "-" not in v]  # import-urdf / export-urdf are aliases, shown beside their verb
    assert {"check_inputs", "solve_problems", "render_report", "verify", "mariano_count_ops"} <= set(names)
    block = out.split("verbs:", 1)[1]
    for v in names:
        lines = [ln for ln in block.splitlines() if re.match(rf"\s+{re.escape(v)}\b", ln)]
        assert len(lines) == 1, (v, lines)
        rest = re.sub(r"^\s+\S+(\s+\([^)]*\))?", "", lines[0]).strip()  # the summary, after any alias
        if not rest:  # a long name: argparse puts the summary on the next line
            rest = block.splitlines()[block.splitlines().index(lines[0]) + 1].strip()
        assert rest and not rest.startswith(v), (v, lines[0])
    assert len(re.findall(r"^\s+check_inputs\b", out, flags=re.M)) == 1


def test_help_imports_no_heavy_library():
    code = ("import sys\nfrom pipeline.cli import main\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in ('numpy', 'pandas', 'numba', 'matplotlib', 'scipy', 'mcap') if m in sys.modules))")
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert proc.stdout.strip().splitlines()[-1] == "[]", proc.stdout + proc.stderr
