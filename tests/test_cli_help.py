"""`python -m pipeline --help`: fast (no numpy/pandas/numba import) and every verb listed once."""

from __future__ import annotations

import re
import statistics
import subprocess
import sys
import time

from tests.conftest import ROOT


def _help() -> tuple[float, str]:
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "pipeline", "--help"], cwd=ROOT, capture_output=True, text=True,
                          timeout=60)
    dt = time.perf_counter() - t0
    assert proc.returncode == 0, proc.stderr
    return dt, proc.stdout


def test_help_lists_every_verb_once_with_a_one_line_summary():
    from pipeline.cli import build_parser

    _, out = _help()
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


def test_help_is_fast():
    """Median of repeated runs under 1 s (hyperfine-style: one warm-up run, then 7 timed)."""
    _help()
    times = [_help()[0] for _ in range(7)]
    assert statistics.median(times) < 1.0, times


def test_help_imports_no_heavy_library():
    code = ("import sys\nfrom pipeline.cli import main\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in ('numpy', 'pandas', 'numba', 'matplotlib', 'scipy', 'mcap') if m in sys.modules))")
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert proc.stdout.strip().splitlines()[-1] == "[]", proc.stdout + proc.stderr
