"""numba's cache keyed on the package's whole source (``pipeline._numba_cache``): a kernel that inlines a
function of another module must not keep stale machine code after that module changes."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from pipeline._numba_cache import source_digest

ROOT = Path(__file__).resolve().parent.parent


def test_digest_follows_every_source_file(tmp_path):
    (tmp_path / "a.py").write_text("x = 1\n")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "b.py").write_text("y = 2\n")
    first = source_digest(tmp_path)
    assert source_digest(tmp_path) == first
    (tmp_path / "sub" / "b.py").write_text("y = 3\n")
    assert source_digest(tmp_path) != first
    (tmp_path / "sub" / "b.py").write_text("y = 2\n")
    assert source_digest(tmp_path) == first
    (tmp_path / "notes.txt").write_text("not source\n")
    assert source_digest(tmp_path) == first


def _cache_dir(env: dict) -> str:
    code = "import pipeline, numba; print(numba.config.CACHE_DIR)"
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True, check=True)
    return out.stdout.strip()


def test_cache_directory_is_named_after_the_source_and_a_users_choice_is_kept(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "PIPELINE_NUMBA_CACHE_DIR")}
    ours = _cache_dir(env)
    assert Path(ours).name == source_digest(ROOT / "pipeline") and Path(ours).parent.name == "numba"
    # a child of a process that chose it recomputes it (and gets the same for the same source)
    assert _cache_dir({**env, "NUMBA_CACHE_DIR": "/elsewhere", "PIPELINE_NUMBA_CACHE_DIR": "/elsewhere"}) == ours
    # the user's own setting is left alone
    assert _cache_dir({**env, "NUMBA_CACHE_DIR": str(tmp_path)}) == str(tmp_path)
