"""numba's cache with each kernel stamped by the source it can reach (``pipeline._numba_cache``): a kernel
that inlines a function of another module must not keep stale machine code after that module changes,
and an edit that no kernel can reach (a study, the report, a job) recompiles nothing."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from pipeline._numba_cache import LAYOUT, PKG, closure, closure_digest

ROOT = Path(__file__).resolve().parent.parent


def _rel(files) -> set[str]:
    return {f.relative_to(PKG).as_posix() for f in files}


def test_a_kernels_stamp_covers_what_it_imports_and_nothing_above():
    """The solvers reach the kinematics (whose FK check they inline) but no study, report, job or CLI
    module: editing those recompiles no solver kernel."""
    kin = _rel(closure(PKG / "kinematics" / "fkcheck.py"))
    for method in ("closed_form/analytic.py", "iterative/jacobian.py", "iterative/lm.py", "iterative/optimizers.py"):
        assert (PKG / "solvers" / method).is_file(), method
        reach = _rel(closure(PKG / "solvers" / method))
        assert f"solvers/{method}" in reach and "kinematics/fkcheck.py" in reach and kin <= reach
        assert not {f for f in reach if f.startswith(("studies/", "report/", "jobs/")) or f == "cli.py"}, reach
    assert len(closure_digest(PKG / "solvers" / "closed_form" / "analytic.py")) == 16


def _run(code: str, env: dict) -> str:
    return subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True,
                          check=True).stdout.strip()


def test_cache_directory_and_a_users_choice(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "PIPELINE_NUMBA_CACHE_DIR")}
    code = "import pipeline, numba, sys; print(numba.config.CACHE_DIR)"
    ours = _run(code, env)
    assert Path(ours).name == LAYOUT and Path(ours).parent.name == "numba"
    # a child of a process that chose it recomputes it (and gets the same)
    assert _run(code, {**env, "NUMBA_CACHE_DIR": "/elsewhere", "PIPELINE_NUMBA_CACHE_DIR": "/elsewhere"}) == ours
    # the user's own setting is left alone
    assert _run(code, {**env, "NUMBA_CACHE_DIR": str(tmp_path)}) == str(tmp_path)
    # importing the package does not import numba (``--help`` stays fast); numba's import installs the stamp
    assert _run("import pipeline, sys; print('numba' in sys.modules)", env) == "False"


def test_a_second_process_loads_the_kernel_stamped_by_its_closure(tmp_path):
    env = {**{k: v for k, v in os.environ.items() if k != "PIPELINE_NUMBA_CACHE_DIR"}, "NUMBA_CACHE_DIR": str(tmp_path)}
    code = ("import pipeline\nfrom pipeline.kinematics.fkcheck import meets\nmeets(0, 1.0, 1.0, 1.0, 0.5, 0.5, 0.5)\n"
            "from numba.core import caching\n"
            "print(sum(meets.stats.cache_hits.values()), type(meets._cache._impl.locator).__name__)")
    assert _run(code, env) == "0 ClosureStampedLocator"
    assert _run(code, env) == "1 ClosureStampedLocator"


def test_the_first_compile_says_so_once_and_a_warm_cache_says_nothing(tmp_path):
    env = {**{k: v for k, v in os.environ.items() if k != "PIPELINE_NUMBA_CACHE_DIR"}, "NUMBA_CACHE_DIR": str(tmp_path),
           "PIPELINE_COMPILE_NOTICE": "1"}
    code = ("import pipeline\nfrom pipeline.kinematics.fkcheck import meets, pose_check\n"
            "meets(0, 1.0, 1.0, 1.0, 0.5, 0.5, 0.5)\nmeets(0, 1, 1, 1, 1, 1, 1)\n")
    cold = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True, check=True)
    lines = cold.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("ik-pipeline: compiling pipeline.kinematics.fkcheck.meets"), lines
    warm = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True, check=True)
    assert warm.stderr == ""
    quiet = subprocess.run([sys.executable, "-c", code.replace("0.5, 0.5, 0.5", "0.5, 0.5, 7")], cwd=ROOT,
                           env={**env, "NUMBA_CACHE_DIR": str(tmp_path / "other"), "PIPELINE_COMPILE_NOTICE": "0"},
                           capture_output=True, text=True, check=True)
    assert quiet.stderr == ""
