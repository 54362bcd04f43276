"""The second malformed-input corpus (issue 28): every case is one line naming the file, or a correct
acceptance, in every verb it reaches; no traceback, no run past 10 s, no file read outside the input,
the run's folder and the data folder.

The corpus (``tests/malformed2/``, written by ``make_corpus.py``; runs in ``run_corpus.py``; exact lines
in ``expected.tsv``) covers URDFs, joint-point inputs of the ``robot`` verb, solver settings and
generators, robot files, configs, and, made at run time, FIFOs and devices given to every verb and
damaged problem sets and archives. A sample also runs as real ``python -m pipeline`` processes
(``_run_limited`` of ``tests/test_malformed_inputs.py``: 10 s beyond start-up, 1 GiB of address space).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

from tests.test_malformed_inputs import _one_line, _run_limited

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT / "tests" / "malformed2"


def _load_runner():
    """``tests/malformed2/run_corpus.py`` under its own name (the first corpus's runner is ``run_corpus``)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("malformed2_run_corpus", CORPUS / "run_corpus.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


corpus2 = _load_runner()

MIN_CASES = {"robots": 25, "studies": 40, "configs": 18, "urdfs": 70, "points": 25, "fifo": 10, "device": 4,
             "damaged": 9}


def _kind(case: str) -> str:
    return case.split("/", 1)[0]


def test_corpus_size_and_expected_lines():
    expected = corpus2.read_expected()
    cases = {case for case, _ in expected}
    by_kind = Counter(_kind(c) for c in cases)
    assert len(cases) >= 200, len(cases)
    assert all(by_kind[k] >= n for k, n in MIN_CASES.items()), by_kind
    files = {f"{p.parent.name}/{p.name}" for p in corpus2.file_cases()}
    assert files == {c for c in cases if _kind(c) in corpus2.FILE_KINDS}, "expected.tsv out of date"


@pytest.fixture(scope="module")
def corpus_runs():
    """Every run of the corpus, in one subprocess (memory-capped), as dicts."""
    proc = subprocess.run([sys.executable, str(CORPUS / "run_corpus.py"), "--json", "--memory-limit"], cwd=ROOT,
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]


def test_every_case_gets_its_one_line_or_is_accepted(corpus_runs):
    expected = corpus2.read_expected()
    failures, seen = [], set()
    for r in corpus_runs:
        key = (r["case"], r["verb"])
        seen.add(key)
        try:
            assert r["exception"] is None, f"exception:\n{r['exception']}"
            assert "Traceback" not in r["stderr"] + r["stdout"]
            assert r["seconds"] < corpus2.TIME_LIMIT_S
            assert not r["outside"], f"read outside the input and the data folder: {r['outside']}"
            want = expected[key]
            if want == corpus2.ACCEPTED:
                assert r["rc"] == 0 and "error:" not in r["stderr"], r["stderr"][-500:]
                continue
            assert r["rc"] not in (0, None), f"exit status {r['rc']}"
            line = _one_line(r["stderr"])
            assert line.startswith("error: "), line
            got = corpus2.placeholders(line, r["file"], r["data"], r["tmp"])
            assert got == want, f"got  {got}\nwant {want}"
            assert "{file}" in want, "the line does not name the file"
        except AssertionError as exc:
            failures.append(f"{r['case']} [{r['verb']}]: {exc}")
    assert not failures, "\n".join(failures[:20])
    assert seen == set(expected)


def test_hostile_paths_are_refused_before_any_read(corpus_runs):
    """A setting or generator naming /etc/passwd is refused by check_inputs, make_problems and solve_problems
    with nothing opened outside the corpus, the run's folder and the data folder."""
    hostile = [r for r in corpus_runs if "passwd" in Path(r["case"]).stem or "absolute" in Path(r["case"]).stem]
    assert len(hostile) >= 20
    for r in hostile:
        assert r["rc"] == 2 and not r["outside"], (r["case"], r["verb"], r["outside"])


def _fifo(tmp_path: Path) -> str:
    fifo = tmp_path / "input.yaml"
    os.mkfifo(fifo)
    return str(fifo)


@pytest.mark.parametrize("argv", [
    ["robot", "{fifo}"],
    ["import-urdf", "{fifo}", "--base", "base", "--tip", "tip", "--out", "{tmp}/x.yaml"],
    ["check_inputs", "--config", "{fifo}"],
    ["inspect", "{fifo}"],
    ["make_problems", "--study", "tests/malformed2/studies/s2_gen_main.yaml", "--problem-set", "warm", "--robot",
     "data/robots/planar2r.yaml", "--out", "{tmp}/p.csv"],
    ["solve_problems", "--study", "tests/malformed2/studies/s2_tracik_timeout_1e9.yaml", "--problem-set", "warm",
     "--robot", "data/robots/planar2r.yaml", "--solver", "dls", "--problems", "{tmp}/p.csv", "--out", "{tmp}/a.mcap"],
    ["solve_problems", "--study", "tests/malformed2/studies/s2_jac_passwd.yaml", "--problem-set", "warm",
     "--robot", "data/robots/planar2r.yaml", "--solver", "dls", "--problems", "{tmp}/p.csv", "--out", "{tmp}/a.mcap"],
    ["import-urdf", "tests/malformed2/urdfs/u_xyz_nan.urdf", "--base", "base", "--tip", "tip", "--out",
     "{tmp}/u_xyz_nan.yaml"],
    ["robot", "tests/malformed2/points/p_effector_list.yaml"],
], ids=lambda a: f"{a[0]}-{Path(a[1] if a[1] != '--study' and a[1] != '--config' else a[2]).stem}")
def test_sample_as_processes(argv, tmp_path):
    fifo = _fifo(tmp_path) if "{fifo}" in argv else None
    argv = [a.replace("{fifo}", fifo or "").replace("{tmp}", str(tmp_path)) for a in argv]
    named = fifo or next(a for a in argv if a.startswith("tests/malformed2/"))
    proc, rss_mib = _run_limited(argv, tmp_path)  # raises TimeoutExpired past the limit
    assert proc.returncode != 0 and "Traceback" not in proc.stderr
    line = _one_line(proc.stderr)
    assert line.startswith("error: ") and named in line, line
    assert rss_mib < 1024


def test_manifest_and_dependency_checks_name_the_file(tmp_path):
    """The pieces of `verify` on a small tree: the manifest names a changed, missing or added file; the
    archive's problem set and robot file are checked against the hashes the archive records."""
    import shutil

    from pipeline.io.archive import archive_metadata
    from pipeline.io.manifest import MANIFEST, check_manifest, write_manifest
    from pipeline.jobs.verify import _dependency_problems

    probe = corpus2._base_solve(tmp_path)
    res = tmp_path / "base"
    probe.unlink()  # the tree: problem set and archive
    shutil.rmtree(res / "studies")
    _, n = write_manifest(res)
    assert n == 2 and check_manifest(res) == []
    arch = res / "dls.mcap"
    meta = archive_metadata(arch)
    data = tmp_path / "data"
    (data / "robots").mkdir(parents=True)
    shutil.copy(ROOT / "data" / "robots" / "planar2r.yaml", data / "robots")
    assert _dependency_problems(arch, meta, data, {}) == []
    robot = data / "robots" / "planar2r.yaml"
    robot.write_text(robot.read_text() + "notes: edited\n")
    (line,) = _dependency_problems(arch, meta, data, {})
    assert line.startswith(f"{robot}: SHA-256 ") and "the robot file changed after the build" in line
    pset = res / "warm.csv.gz"
    pset.write_bytes(pset.read_bytes()[:-3])
    lines = _dependency_problems(arch, meta, data, {})
    assert lines[0].startswith(f"{pset}: damaged gzip file")
    assert check_manifest(res) == [f"{pset}: SHA-256 differs from the one the build recorded in {MANIFEST}"]
    (res / "extra.csv").write_text("x\n")
    arch.unlink()
    assert check_manifest(res) == [f"{arch}: missing (listed in {MANIFEST})",
                                   f"{pset}: SHA-256 differs from the one the build recorded in {MANIFEST}",
                                   f"{res / 'extra.csv'}: not written by the build (not in {MANIFEST})"]
