"""Malformed, hostile and absurd input files: each is refused with one line naming the file.

The corpus (``tests/malformed/``, written by ``make_corpus.py``; expected lines in ``expected.tsv``)
runs through ``check_inputs`` and the ``robot`` verb (robot files), ``make_problems`` and
``solve_problems`` (study files) in one process (``run_corpus.py``: a 10 s alarm per run, the
address space capped at +1 GiB over the imports). A sample of hostile cases also runs as real
``python -m pipeline`` processes with a 10 s timeout and a 1 GiB address-space limit.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.robots import RIGID_TOL, RobotFileError, load_robot, orthonormality_error
from pipeline.yamlio import MAX_BYTES, MAX_NODES, YAMLInputError, load_yaml

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT / "tests" / "malformed"
sys.path.insert(0, str(CORPUS))
import run_corpus  # noqa: E402

# study files that are valid on their own (the problem is elsewhere: a robot they name has no file);
# the verbs that take the study file alone fail later, naming the file they then miss
VALID_ON_THEIR_OWN = {"studies/s_robot_missing_file.yaml"}


def _one_line(text: str) -> str:
    lines = text.rstrip("\n").split("\n")
    assert len(lines) == 1, f"expected one line, got {len(lines)}:\n{text[:2000]}"
    return lines[0]


def test_corpus_size_and_manifest():
    files = run_corpus.corpus_files()
    expected = run_corpus.read_expected()
    by_kind = {k: sum(p.parent.name == k for p in files) for k in run_corpus.KINDS}
    assert len(files) >= 150 and by_kind["robots"] >= 90 and by_kind["studies"] >= 40 and by_kind["configs"] >= 20
    assert sorted(f"{p.parent.name}/{p.name}" for p in files) == sorted(expected), "expected.tsv out of date"


@pytest.fixture(scope="module")
def corpus_runs():
    """Every run of the corpus, in one subprocess (memory-capped), as dicts."""
    proc = subprocess.run([sys.executable, str(CORPUS / "run_corpus.py"), "--json", "--memory-limit"], cwd=ROOT,
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return [json.loads(line) for line in proc.stdout.splitlines()]


def test_every_corpus_file_gets_its_one_line(corpus_runs):
    expected = run_corpus.read_expected()
    seen = set()
    failures = []
    for r in corpus_runs:
        seen.add(r["case"])
        try:
            assert r["exception"] is None, f"exception:\n{r['exception']}"
            assert r["rc"] not in (0, None), f"exit status {r['rc']}"
            assert "Traceback" not in r["stderr"] + r["stdout"]
            line = _one_line(r["stderr"])
            assert r["seconds"] < run_corpus.TIME_LIMIT_S
            if r["verb"] == "check_inputs":
                want = expected[r["case"]].replace("{file}", r["file"]).replace("{data}", r["data"])
                assert line == want, f"got  {line}\nwant {want}"
            elif r["verb"] == "robot":  # the same message, naming the corpus file itself
                want = expected[r["case"]].replace("{file}", r["file"])
                assert line == want, f"got  {line}\nwant {want}"
            elif r["case"] not in VALID_ON_THEIR_OWN:
                assert line.startswith(f"error: {r['file']}: "), line
        except AssertionError as exc:
            failures.append(f"{r['case']} [{r['verb']}]: {exc}")
    assert not failures, "\n".join(failures[:20])
    assert seen == set(expected)


_STARTUP: list[float] = []


def _startup_s() -> float:
    """Seconds ``python -m pipeline`` takes on a valid file here and now (interpreter and imports: on a
    loaded machine several seconds, which the 10 s limit on handling an input must not count)."""
    if not _STARTUP:
        import time

        t0 = time.monotonic()
        subprocess.run([sys.executable, "-m", "pipeline", "robot", "data/robots/planar2r.yaml"], cwd=ROOT,
                       capture_output=True, timeout=120, check=True)
        _STARTUP.append(time.monotonic() - t0)
    return _STARTUP[0]


# Runs in a fresh, small interpreter between the test process and the child: sets the limit, runs the
# child, and writes "exit-code max-RSS-KiB" of that child alone to argv[1].
_LAUNCHER = """
import os, resource, sys
resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))
pid = os.fork()
if pid == 0:
    os.execv(sys.executable, [sys.executable, "-m", "pipeline", *sys.argv[2:]])
_, status, usage = os.wait4(pid, 0)
with open(sys.argv[1], "w") as f:
    f.write(f"{os.waitstatus_to_exitcode(status)} {usage.ru_maxrss}")
"""


def _run_limited(argv: list[str], tmp_path: Path) -> tuple[subprocess.CompletedProcess, float]:
    """``python -m pipeline ARGV`` with a 1 GiB address-space limit and a timeout of 10 s beyond the start-up
    time of a valid run; returns (process, max RSS of this child in MiB).

    The RSS is this child's own, measured by a small launcher interpreter (``_LAUNCHER``) that forks it.
    Measured from the test process itself it would not be: Linux carries the peak RSS of a process across
    ``exec``, so a child forked from a test process grown to 1 GiB (numba compiling every kernel on a
    fresh clone, with no cache) reports that 1 GiB whatever it does itself. ``RUSAGE_CHILDREN`` is no
    better: it is the maximum over every child the test process ever waited for.
    """
    timeout = run_corpus.TIME_LIMIT_S + 2 * _startup_s()
    out, err, res = tmp_path / "stdout.txt", tmp_path / "stderr.txt", tmp_path / "launcher.txt"
    res.unlink(missing_ok=True)
    with open(out, "w") as fo, open(err, "w") as fe:
        child = subprocess.Popen([sys.executable, "-c", _LAUNCHER, str(res), *argv], cwd=ROOT, stdout=fo,
                                 stderr=fe, start_new_session=True)

    def kill():
        try:
            os.killpg(child.pid, signal.SIGKILL)
        except ProcessLookupError:  # ended meanwhile
            pass

    timer = threading.Timer(timeout, kill)
    timer.start()
    try:
        child.wait()
    finally:
        timer.cancel()
    if child.returncode == -signal.SIGKILL or not res.exists():
        raise subprocess.TimeoutExpired(argv, timeout)
    code, rss_kib = (int(v) for v in res.read_text().split())
    if code == -signal.SIGKILL:
        raise subprocess.TimeoutExpired(argv, timeout)
    proc = subprocess.CompletedProcess(argv, code, out.read_text(), err.read_text())
    return proc, rss_kib / 1024


HOSTILE_SAMPLE = [
    ["robot", "tests/malformed/robots/r_alias_bomb_notes.yaml"],
    ["robot", "tests/malformed/robots/r_nested_brackets.yaml"],
    ["robot", "tests/malformed/robots/r_utf16_bom.yaml"],
    ["robot", "tests/malformed/robots/r_binary_junk.yaml"],
    ["robot", "tests/malformed/robots/r_theta_pi_over_0.yaml"],
    ["robot", "tests/malformed/robots/r_joints_20000.yaml"],
    ["robot", "tests/malformed/robots/r_tag_python_apply.yaml"],
    ["check_inputs", "--config", "tests/malformed/configs/c_alias_bomb_studies.yaml"],
    ["check_inputs", "--config", "tests/malformed/configs/c_scale_unknown.yaml"],
    ["make_problems", "--study", "tests/malformed/studies/s_count_quick_huge.yaml", "--problem-set", "warm",
     "--robot", "data/robots/planar2r.yaml", "--scale", "quick", "--out", "{tmp}/p.csv"],
    ["make_problems", "--study", "tests/malformed/studies/s_low_above_high.yaml", "--problem-set", "warm",
     "--robot", "data/robots/planar2r.yaml", "--out", "{tmp}/p.csv"],
    ["make_problems", "--study", "tests/malformed/studies/s_alias_bomb_interpretations.yaml", "--problem-set",
     "warm", "--robot", "data/robots/planar2r.yaml", "--out", "{tmp}/p.csv"],
    ["solve_problems", "--study", "tests/malformed/studies/s_max_iterations_huge.yaml", "--problem-set", "warm",
     "--robot", "data/robots/planar2r.yaml", "--solver", "dls", "--problems", "{tmp}/p.csv", "--out", "{tmp}/a.mcap"],
]


@pytest.mark.parametrize("argv", HOSTILE_SAMPLE, ids=lambda a: f"{a[0]}-{Path(a[-1] if a[0] != 'make_problems' and a[0] != 'solve_problems' else a[2]).stem}")
def test_hostile_sample_as_processes(argv, tmp_path):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    named = next(a for a in argv if a.startswith("tests/malformed/"))
    proc, rss_mib = _run_limited(argv, tmp_path)
    assert proc.returncode != 0
    assert "Traceback" not in proc.stderr
    assert _one_line(proc.stderr).startswith(f"error: {named}: ")
    assert rss_mib < 1024


def test_child_rss_is_the_childs_own(tmp_path):
    """A test process grown past 1 GiB (numba compiling with no cache, on a fresh clone) must not be charged
    to the child ``_run_limited`` measures: Linux keeps a process's peak RSS across ``exec``."""
    script = (f"import sys; sys.path.insert(0, {str(ROOT)!r}); import numpy as np; from pathlib import Path\n"
              "from tests.test_malformed_inputs import _run_limited\n"
              "big = np.ones(160_000_000)  # 1.2 GiB, touched\n"
              f"proc, rss = _run_limited(['robot', 'no/such/robot.yaml'], Path({str(tmp_path)!r}))\n"
              "print(proc.returncode, rss)\n")
    out = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    code, rss = out.stdout.split()
    assert int(code) != 0 and float(rss) < 512, out.stdout


def test_oversized_files_refused_fast(tmp_path):
    """Files beyond the size and node bounds (too large to keep in the corpus) are refused at once."""
    big = tmp_path / "big.yaml"  # 20 000 joints written out in full: 1.2 MB
    big.write_text("name: big\nsource: x\nlength_unit: m\nconvention: standard\njoints:\n"
                   + "  - {type: revolute, a: 0, alpha: 0, d: 0, theta_offset: 0}\n" * 20000)
    assert big.stat().st_size > MAX_BYTES
    many = tmp_path / "many.yaml"  # under the size bound, over the node bound
    many.write_text("notes: [" + ",".join(["0"] * (MAX_NODES + 10)) + "]\n")
    assert many.stat().st_size < MAX_BYTES
    for path, what in ((big, f"larger than {MAX_BYTES} bytes"), (many, f"more than {MAX_NODES} YAML nodes")):
        proc, rss_mib = _run_limited(["robot", str(path)], tmp_path)
        assert proc.returncode != 0 and "Traceback" not in proc.stderr
        line = _one_line(proc.stderr)
        assert line.startswith(f"error: {path}: ") and what in line, line
        assert rss_mib < 1024


def test_configfile_given_to_snakemake_is_named(tmp_path):
    """A bad value in a ``--configfile`` is reported against that file, not workflow/config/config.yaml."""
    bad = tmp_path / "my_config.yaml"
    bad.write_text("scale: quick\nstudies: [cerbaro2019]\nscale: full\n")
    proc = subprocess.run(["snakemake", "-n", "--configfile", str(bad)], cwd=ROOT, capture_output=True, text=True,
                          timeout=120)
    out = proc.stdout + proc.stderr
    assert proc.returncode != 0
    assert f"error: {bad}: line 3: duplicate key 'scale'" in out
    bad.write_text("scale: fast\nstudies: [cerbaro2019]\n")
    proc = subprocess.run(["snakemake", "-n", "--configfile", str(bad)], cwd=ROOT, capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode != 0 and f"error: {bad}: field 'scale': 'fast' is not one of" in proc.stdout + proc.stderr


def test_set_value_is_named():
    proc = subprocess.run([sys.executable, "-m", "pipeline", "check_inputs", "--set", "scale=fast"], cwd=ROOT,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert _one_line(proc.stderr) == "error: --set scale: field 'scale': 'fast' is not one of ['full', 'quick']"


def test_real_files_load_as_before():
    """Every YAML file of the project reads exactly as ``yaml.safe_load`` read it."""
    files = sorted((ROOT / "data").rglob("*.yaml")) + sorted((ROOT / "workflow").rglob("*.yaml"))
    assert len(files) > 40
    for f in files:
        assert load_yaml(f) == yaml.safe_load(f.read_text()), f
    for f in sorted((ROOT / "data" / "robots").glob("*.yaml")):
        assert load_robot(f).repairs == (), f


def _robot_with_tool(tmp_path: Path, tool: list) -> Path:
    p = tmp_path / "arm.yaml"
    p.write_text(yaml.safe_dump({"name": "arm", "source": "test", "length_unit": "m", "convention": "standard",
                                 "joints": [{"type": "revolute", "a": 0.4, "alpha": 0, "d": 0.1, "theta_offset": 0}],
                                 "tool": tool}))
    return p


def test_near_orthonormal_rotation_is_repaired_with_a_note(tmp_path):
    c = 0.7071  # cos 45 deg typed to four decimals: orthonormal only to ~1.4e-5
    p = _robot_with_tool(tmp_path, [[c, -c, 0, 0.1], [c, c, 0, 0], [0, 0, 1, 0.05], [0, 0, 0, 1]])
    model = load_robot(p)
    R = model.chain.tool[:3, :3]
    assert orthonormality_error(R) < 1e-15 and np.linalg.det(R) > 0
    assert np.allclose(R, [[np.sqrt(0.5), -np.sqrt(0.5), 0], [np.sqrt(0.5), np.sqrt(0.5), 0], [0, 0, 1]], atol=1e-15)
    assert model.chain.tool[:3, 3].tolist() == [0.1, 0.0, 0.05]
    assert len(model.repairs) == 1 and "field 'tool'" in model.repairs[0] and "nearest rotation" in model.repairs[0]
    assert model.in_unit("mm").repairs == model.repairs


def test_rotation_within_rigid_tol_is_kept_as_written(tmp_path):
    c = 0.70710678  # orthonormal to ~1e-8 < RIGID_TOL: used exactly as written, as before
    assert RIGID_TOL > 1e-8
    p = _robot_with_tool(tmp_path, [[c, -c, 0, 0], [c, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    model = load_robot(p)
    assert model.chain.tool[0, 0] == c and model.repairs == ()


def test_rotation_far_from_orthonormal_is_refused(tmp_path):
    p = _robot_with_tool(tmp_path, [[0.7, -0.7, 0, 0], [0.7, 0.7, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    with pytest.raises(RobotFileError, match=r"arm.yaml: field 'tool': not a rigid transform: the rotation block is "
                                             r"not a rotation"):
        load_robot(p)


def test_loader_refusals_name_the_source():
    from pipeline.yamlio import parse_yaml

    for text, what in (("a: 1\na: 2\n", "duplicate key 'a'"), ("d: 12:30\n", "base-60 number '12:30'"),
                       ("a: !!python/name:os.system\n", "YAML tag"), ("[" * 20000, "nested deeper"),
                       ("x: 0777\n", "octal"), ("x: Off\n", "YAML 1.1 boolean")):
        with pytest.raises(YAMLInputError) as err:
            parse_yaml(text, "src.yaml")
        assert str(err.value).startswith("src.yaml: ") and what in str(err.value) and "\n" not in str(err.value)
    assert parse_yaml("a: '12:30'\nb: 0x1F\nc: 1.5e+3\nd: null\ne: true\n", "s") == \
        {"a": "12:30", "b": 31, "c": 1500.0, "d": None, "e": True}
    assert parse_yaml("a: &x {p: 1}\nb: {<<: *x, q: 2}\n", "s") == {"a": {"p": 1}, "b": {"p": 1, "q": 2}}
