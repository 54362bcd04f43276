"""Hostile names, paths and argument values given to the verbs, and every verb's output option pointed at
its own input (issue 44): each case is one line (``error: ...``) or a documented acceptance, no traceback,
no command run, no input overwritten.

Cases run in-process through :func:`pipeline.cli.main` on a workspace of real inputs (robot and study
files, an archive written by the archive writer, a problem file); every file of the workspace is hashed
before and after each refused case. A sample runs as real ``python -m pipeline`` processes with a
timeout and a 1 GiB address-space limit (``_run_limited`` of ``tests/test_malformed_inputs.py``), and
one through Snakemake itself.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from pipeline.cli import main
from pipeline.names import NAME_MAX, check_name, check_path, is_name
from pipeline.errors import UsageError

ROOT = Path(__file__).resolve().parent.parent
ARM = "data/studies/arm_benchmark.yaml"
UR5E = "data/robots/ur5e.yaml"
MARK = "PWNED"  # the file every shell payload tries to create


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    """A workspace: data folder copy, an archive, a problem file, a URDF, a results tree with both."""
    from tests.jobs.test_inspect import _write

    w = tmp_path_factory.mktemp("hostile_cli")
    (w / "d" / "studies").mkdir(parents=True)
    shutil.copytree(ROOT / "data" / "robots", w / "d" / "robots")
    shutil.copy(ROOT / ARM, w / "d" / "studies")
    (w / "d" / "published").mkdir()
    _write(w / "a.mcap")
    runs = w / "res" / "s" / "runs" / "cold"
    runs.mkdir(parents=True)
    _write(runs / "ur5e__dls.mcap")
    probs = w / "res" / "s" / "problems" / "cold"
    probs.mkdir(parents=True)
    (probs / "ur5e.csv.gz").write_bytes(b"\x1f\x8b" + b"\0" * 30)
    (w / "p.csv.gz").write_bytes((probs / "ur5e.csv.gz").read_bytes())
    assert main(["export-urdf", UR5E, "--out", str(w / "u.urdf")]) == 0
    (w / "existing.txt").write_text("keep me\n")
    text = (ROOT / UR5E).read_text()
    for stem in HOSTILE_STEMS:  # robot files whose name (= file name) is not a name
        (w / "d" / "robots" / f"{stem}.yaml").write_text(text.replace("name: ur5e", f"name: {stem!r}"))
    return w


def _snapshot(root: Path) -> dict:
    return {str(p): hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(root.rglob("*")) if p.is_file()}


def _run(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            rc = main(argv)
        except SystemExit as exc:  # argparse: exit 2 with a usage line
            rc = exc.code
    return rc, out.getvalue(), err.getvalue()


SHELL_TEXT = [
    "$(touch @W/PWNED)", "`touch @W/PWNED`", "a;touch @W/PWNED", "a|touch @W/PWNED", "a&&touch @W/PWNED",
    "a b", "a'b", 'a"b', "a>@W/PWNED", "a<b", "{src.__class__}", "{0}", "a*b", "a?b", "~x", "résultats",
    "a\nb", "a\tb", "a$HOME", "a,b", "a=b", "[a]", "a#b", "a!b",
]

HOSTILE_STEMS = ["{src.__class__.__new__.__globals__[os].environ}", "{0}", "{", "a;b", "a b", "UR5E", "résumé",
                 "$(touch PWNED)", "a`id`", "a__b"]

# (id, argv, expected fragment of the one line); "@W" is the workspace
CASES = [
    # --- names and folders that reach Snakemake config and its shell commands (benchmark-arm) ---
    *[(f"bench-results-{i}", ["benchmark-arm", UR5E, "--results", f"@W/{t}", "--dry-run"],
       "not allowed in a path the workflow passes to Snakemake") for i, t in enumerate(SHELL_TEXT)],
    *[(f"bench-data-{i}", ["benchmark-arm", UR5E, "--results", "@W/ok", "--data", f"@W/{t}", "--dry-run"],
       "not allowed in a path the workflow passes to Snakemake") for i, t in enumerate(SHELL_TEXT[:8])],
    *[(f"bench-robot-name-{i}", ["benchmark-arm", f"@W/d/robots/{t}.yaml", "--dry-run"], "not a valid name")
      for i, t in enumerate(HOSTILE_STEMS)],
    *[(f"bench-robot-name-results-{i}", ["benchmark-arm", f"@W/d/robots/{t}.yaml", "--results", "@W/ok",
                                         "--dry-run"], "field 'name'") for i, t in enumerate(HOSTILE_STEMS)],
    ("bench-cores-0", ["benchmark-arm", UR5E, "--cores", "0", "--dry-run"], "--cores 0: at least 1"),
    ("bench-cores-neg", ["benchmark-arm", UR5E, "--cores", "-3", "--dry-run"], "--cores -3: at least 1"),
    ("bench-no-robot", ["benchmark-arm", "@W/none.yaml", "--dry-run"], "no such robot file"),
    ("bench-folder-robot", ["benchmark-arm", "@W", "--dry-run"], "no such robot file"),
    # --- new_study: ids and robot ids are names ---
    *[(f"new-study-id-{i}", ["new_study", t, "--robots", "ur5e", "--data", "@W/d"], "not a valid name")
      for i, t in enumerate(["a" * 250, "a" * 300, "a" * (NAME_MAX + 1), "UR5", "a__b", "_a", "a_", "a-b", "a/b",
                             "../x", "$(touch @W/PWNED)", "{src}", "résumé", "a b", "a;b", ""])],
    *[(f"new-study-robot-{i}", ["new_study", "ok", "--robots", t, "--data", "@W/d"], "robot id")
      for i, t in enumerate(["../../etc/passwd", "/etc/passwd", "{0}", "$(id)", "UR5E", "ur5e.yaml", "a" * 65])],
    ("new-study-count-0", ["new_study", "ok", "--robots", "ur5e", "--count", "0", "--data", "@W/d"],
     "field 'problem_sets/warm/count/full': 0 is less than the minimum of 1"),
    ("new-study-count-huge", ["new_study", "ok", "--robots", "ur5e", "--count", "10000000000000", "--data", "@W/d"],
     "is greater than the maximum"),
    ("new-study-spread-nan", ["new_study", "ok", "--robots", "ur5e", "--spread", "nan", "--data", "@W/d"],
     "field 'params/spread': expected a number"),
    ("new-study-spread-neg", ["new_study", "ok", "--robots", "ur5e", "--spread", "-1", "--data", "@W/d"],
     "field 'params/spread': must be >= 0"),
    ("new-study-seed-neg", ["new_study", "ok", "--robots", "ur5e", "--seed", "-1", "--data", "@W/d"],
     "field 'problem_sets/warm/seed': -1 is less than the minimum of 0"),
    ("new-study-unknown-solver", ["new_study", "ok", "--robots", "ur5e", "--solvers", "{x}", "--data", "@W/d"],
     "unknown solver '{x}'"),
    # --- import-urdf: the robot's name is the file name, and a name ---
    *[(f"import-name-{i}", ["import-urdf", "@W/u.urdf", "--base", "base_link", "--tip", "tool0", "--out",
                            f"@W/{t}.yaml"], "not a valid name")
      for i, t in enumerate(["$(touch PWNED)", "UR5", "a b", "{src}", "résumé", "a;b", "a" * 70])],
    ("import-name-flag", ["import-urdf", "@W/u.urdf", "--base", "base_link", "--tip", "tool0", "--out",
                          "@W/x.yaml", "--name", "{0}"], "--name '{0}': not a valid name"),
    ("import-xacro-arg", ["import-urdf", "@W/u.urdf", "--base", "base_link", "--tip", "tool0", "--out",
                          "@W/x.yaml", "--xacro-arg", "novalue"], "expected NAME:=VALUE"),
    # --- argument edge values ---
    *[(f"replay-dt-{t}", ["replay", "@W/a.mcap", "--problem", "0", "-o", "@W/r.mcap", "--dt", t],
       "dt: must lie in [1e-06, 3600] s") for t in ["1e300", "1e10", "0", "-1", "nan", "inf", "1e-300"]],
    ("replay-dt-=-inf", ["replay", "@W/a.mcap", "--problem", "0", "-o", "@W/r.mcap", "--dt=-inf"],
     "dt: must lie in [1e-06, 3600] s"),
    ("replay-dt--inf", ["replay", "@W/a.mcap", "--problem", "0", "-o", "@W/r.mcap", "--dt", "-inf"],
     "replay: argument --dt: expected one argument (see python -m pipeline replay --help)"),
    ("unknown-verb", ["rm", "-rf", "/"], "argument VERB: invalid choice: 'rm'"),
    *[(f"replay-max-frames-{t}", ["replay", "@W/a.mcap", "--problem", "0", "-o", "@W/r.mcap", "--max-frames", t],
       "max_frames: must lie in [2, 100000]") for t in ["1", "0", "-5", "1000000000"]],
    ("replay-dt-text", ["replay", "@W/a.mcap", "--problem", "0", "-o", "@W/r.mcap", "--dt", "fast"],
     "argument --dt: invalid float value"),
    *[(f"solve-limit-{t}", ["solve_problems", "--study", ARM, "--problem-set", "cold", "--robot", UR5E, "--solver",
                            "analytic_ur", "--problems", "@W/p.csv.gz", "--out", "@W/s.mcap", "--limit", t],
       "--limit: at least 0") for t in ["-1", "-1000"]],
    *[(f"solve-threads-{t}", ["solve_problems", "--study", ARM, "--problem-set", "cold", "--robot", UR5E, "--solver",
                              "analytic_ur", "--problems", "@W/p.csv.gz", "--out", "@W/s.mcap", "--threads", t],
       "--threads: 1 to 64") for t in ["0", "-1", "100000"]],
    *[(f"race-{k}-{v}", ["race", "--study", ARM, "--robot", UR5E, "--archives", "@W/a.mcap", "--out", "@W/rr.mcap",
                         f"--{k}", v], "--goals: 1 to 100000")
      for k, v in [("goals", "0"), ("goals", "1000000000000"), ("budget", "inf"), ("budget", "nan"),
                   ("budget", "-1"), ("budget", "1e9"), ("max-passes", "1000000000"), ("min-passes", "0")]],
    *[(f"reproduce-sample-{t}", ["reproduce", "@W/a.mcap", "--sample", t], "--sample: must be at least 1")
      for t in ["0", "-1"]],
    *[(f"inspect-problem-{t}", ["inspect", "@W/a.mcap", "--problem", t], "is not in the archive")
      for t in ["-5", "100000000000000000000000"]],
    # --- output paths: never an input, never a folder, never a build's archive; --force for the rest ---
    ("inspect-csv-self", ["inspect", "@W/a.mcap", "--csv", "@W/a.mcap"], "is also an input of this command"),
    ("inspect-csv-problems", ["inspect", "@W/a.mcap", "--problems", "@W/p.csv.gz", "--csv", "@W/p.csv.gz"],
     "is also an input of this command"),
    ("inspect-csv-folder", ["inspect", "@W/a.mcap", "--csv", "@W"], "is a folder; name the file to write"),
    ("inspect-csv-existing", ["inspect", "@W/a.mcap", "--csv", "@W/existing.txt"], "exists (use --force"),
    ("inspect-csv-archive", ["inspect", "@W/a.mcap", "--csv", "@W/res/s/runs/cold/ur5e__dls.mcap", "--force"],
     "is an archive of a results tree"),
    ("inspect-csv-problem-set", ["inspect", "@W/a.mcap", "--csv", "@W/res/s/problems/cold/ur5e.csv.gz", "--force"],
     "is a problem set of a results tree"),
    ("replay-self", ["replay", "@W/a.mcap", "--problem", "0", "-o", "@W/a.mcap"], "is also an input of this command"),
    ("replay-self-force", ["replay", "@W/a.mcap", "--problem", "0", "-o", "@W/a.mcap", "--force"],
     "is also an input of this command"),
    ("replay-robot", ["replay", "@W/a.mcap", "--problem", "0", "--robot", UR5E, "-o", UR5E],
     "is also an input of this command"),
    ("replay-folder", ["replay", "@W/a.mcap", "--problem", "0", "-o", "@W"], "is a folder"),
    ("replay-existing", ["replay", "@W/a.mcap", "--problem", "0", "-o", "@W/existing.txt"], "exists (use --force"),
    ("replay-archive", ["replay", "@W/a.mcap", "--problem", "0", "-o", "@W/res/s/runs/cold/ur5e__dls.mcap",
                        "--force"], "is an archive of a results tree"),
    ("export-self", ["export-urdf", UR5E, "--out", UR5E], "is also an input of this command"),
    ("export-existing", ["export-urdf", UR5E, "--out", "@W/u.urdf"], "exists (use --force"),
    ("import-self", ["import-urdf", "@W/u.urdf", "--base", "base_link", "--tip", "tool0", "--out", "@W/u.urdf"],
     "is also an input of this command"),
    ("make-problems-robot", ["make_problems", "--study", ARM, "--problem-set", "cold", "--robot", UR5E, "--out", UR5E],
     "is also an input of this command"),
    ("make-problems-study", ["make_problems", "--study", ARM, "--problem-set", "cold", "--robot", UR5E, "--out", ARM],
     "is also an input of this command"),
    ("make-problems-existing", ["make_problems", "--study", ARM, "--problem-set", "cold", "--robot", UR5E, "--out",
                                "@W/existing.txt"], "exists (use --force"),
    ("solve-over-problems", ["solve_problems", "--study", ARM, "--problem-set", "cold", "--robot", UR5E, "--solver",
                             "analytic_ur", "--problems", "@W/p.csv.gz", "--out", "@W/p.csv.gz"],
     "is also an input of this command"),
    ("rerun-over-archive", ["rerun_failures", "--study", ARM, "--problem-set", "cold", "--robot", UR5E, "--solver",
                            "dls", "--problems", "@W/p.csv.gz", "--archive", "@W/a.mcap", "--out", "@W/a.mcap"],
     "is also an input of this command"),
    ("race-over-archive", ["race", "--study", ARM, "--robot", UR5E, "--archives", "@W/a.mcap", "--out", "@W/a.mcap"],
     "is also an input of this command"),
    ("report-over-config", ["render_report", "--out", "workflow/config/config.yaml"], "is also an input of this command"),
    ("manifest-over-archive", ["manifest", "@W/res", "--out", "@W/res/s/runs/cold/ur5e__dls.mcap", "--force"],
     "is an archive of a results tree"),
    ("aggregate-out-dir-file", ["aggregate_tables", "--study", ARM, "--archives", "@W/a.mcap", "--out-dir",
                                "@W/a.mcap"], "exists and is not a folder"),
    ("plot-out-dir-file", ["plot_figures", "--study", ARM, "--archives", "@W/a.mcap", "--out-dir", "@W/existing.txt"],
     "exists and is not a folder"),
    ("erthal-robot-out-self", ["robot", UR5E, "--out", UR5E], "is also an input of this command"),
    ("erthal-write-robot-self", ["robot", "data/erthal1992/stanford_input.yaml", "--write-robot",
                                 "data/erthal1992/stanford_input.yaml"], "is also an input of this command"),
    ("erthal-res-over-archive", ["erthal_path_rows", "--study", "data/studies/erthal1992.yaml", "--problem-set", "p",
                                 "--robot", "scara1", "--archive", "@W/a.mcap", "--out", "@W/rows.mcap", "--res",
                                 "@W/a.mcap"], "is also an input of this command"),
    ("erthal-out-over-archive", ["erthal_path_rows", "--study", "data/studies/erthal1992.yaml", "--problem-set", "p",
                                 "--robot", "scara1", "--archive", "@W/a.mcap", "--out", "@W/a.mcap"],
     "is also an input of this command"),
    ("erthal-report-dir-file", ["erthal_catalogue", "--study", "data/studies/erthal1992.yaml", "--out", "@W/c.mcap",
                                "--report-dir", "@W/existing.txt"], "exists and is not a folder"),
    ("nepomuceno-motion-over-study", ["plan_motion_nepomuceno2024", "--study", "data/studies/nepomuceno2024.yaml",
                                      "--motion", "m", "--out", "data/studies/nepomuceno2024.yaml"],
     "is also an input of this command"),
    ("mariano-build-dir-file", ["mariano_measure_mcu", "--study", "data/studies/mariano2019.yaml", "--robot",
                                "data/robots/mariano_4dof.yaml", "--out", "@W/m.mcap", "--build-dir",
                                "@W/existing.txt"], "exists and is not a folder"),
    ("mariano-out-robot", ["mariano_count_ops", "--study", "data/studies/mariano2019.yaml", "--robot",
                           "data/robots/mariano_4dof.yaml", "--out", "data/robots/mariano_4dof.yaml"],
     "is also an input of this command"),
]


def _sub(argv: list[str], w: Path) -> list[str]:
    return [a.replace("@W", str(w)) for a in argv]


def test_corpus_size():
    assert len(CASES) >= 120, len(CASES)  # with the xacro and archive corpora, well over 150
    assert len({c[0] for c in CASES}) == len(CASES)


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_case_is_one_line_and_changes_nothing(case, ws):
    _, argv, want = case
    argv = _sub(argv, ws)
    if argv[0].startswith("mariano") and argv[0] not in _verbs():
        pytest.skip(f"no {argv[0]} verb")
    before = _snapshot(ws)
    rc, out, err = _run(argv)
    assert rc == 2, (rc, out[-500:], err[-2000:])
    lines = err.rstrip("\n").split("\n")
    line = lines[-1]
    assert "Traceback" not in err
    assert len(lines) == 1, err
    assert want.replace("@W", str(ws)) in line, line
    assert not (ws / MARK).exists() and not (ROOT / MARK).exists()
    assert _snapshot(ws) == before, "a refused command changed the workspace"


def _verbs() -> set[str]:
    from pipeline.cli import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "verb")
    return set(sub.choices)


def test_force_overwrites_an_ordinary_output(ws, tmp_path):
    out = tmp_path / "records.csv"
    assert _run(["inspect", str(ws / "a.mcap"), "--csv", str(out)])[0] == 0
    first = out.read_bytes()
    rc, _, err = _run(["inspect", str(ws / "a.mcap"), "--csv", str(out)])
    assert rc == 2 and "exists (use --force to overwrite)" in err
    assert _run(["inspect", str(ws / "a.mcap"), "--csv", str(out), "--force"])[0] == 0
    assert out.read_bytes() == first


def test_every_verb_that_writes_a_file_has_force():
    from pipeline.cli import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "verb")
    for verb, p in sub.choices.items():
        dests = {a.dest for a in p._actions}
        if dests & {"out", "csv", "write_robot", "res"}:
            assert "force" in dests, verb


def test_hard_link_and_symlink_to_the_input_are_the_input(ws, tmp_path):
    link = tmp_path / "link.mcap"
    link.symlink_to(ws / "a.mcap")
    hard = tmp_path / "hard.mcap"
    os.link(ws / "a.mcap", hard)
    for out in (link, hard):
        rc, _, err = _run(["inspect", str(ws / "a.mcap"), "--csv", str(out), "--force"])
        assert rc == 2 and "is also an input of this command" in err, err


def test_name_and_path_patterns():
    for good in ("ur5e", "kuka_lwr", "a1_b2", "x" * NAME_MAX):
        assert is_name(good) and check_name(good, "id") == good
    for bad in ("", "A", "a__b", "_a", "a_", "a-b", "x" * (NAME_MAX + 1), "a\n", "\u0430", None, 5):
        assert not is_name(bad)
        with pytest.raises(UsageError):
            check_name(bad, "id")
    for good in ("results", "/tmp/x-y/z.1", "a+b/c_d"):
        assert check_path(good, "p") == good
    for bad in SHELL_TEXT + ["-rf", "", "a" * 2000]:
        with pytest.raises(UsageError, match="not allowed in a path"):
            check_path(bad.replace("@W", "/tmp"), "p")


def test_new_study_writes_nothing_through_format(ws):
    """A title with braces and quotes lands in the YAML as text; the file loads and says what was given."""
    from pipeline.settings import load_study

    rc, out, err = _run(["new_study", "fmt", "--robots", "ur5e", "--solvers", "dls", "--data", str(ws / "d"),
                            "--title", "{src.__class__} \"q\" $(x)\nsecond: line"])
    assert rc == 0, err
    st = load_study(ws / "d" / "studies" / "fmt.yaml")
    assert st.doc["title"] == "{src.__class__} \"q\" $(x)\nsecond: line"
    assert "second" not in st.doc


def test_lbfgsb_bounds_of_the_wrong_length_fail_check_inputs(tmp_path):
    """A study whose L-BFGS-B ``bounds`` give 3 pairs for a 6-joint arm is refused by check_inputs, naming
    the file, the label and the field (it used to pass and fail only at solve time)."""
    import yaml

    data = tmp_path / "d"
    (data / "studies").mkdir(parents=True)
    shutil.copytree(ROOT / "data" / "robots", data / "robots")
    (data / "published").mkdir()
    doc = {"study": "bnd", "title": "t", "document": "none", "robots": ["ur5e"],
           "problem_sets": {"warm": {"kind": "warm_start", "seed": 1, "count": {"full": 5, "quick": 5},
                                     "params": {"spread": 0.3}}},
           "solvers": {"lb": {"method": "lbfgsb", "bounds": "-1, 1; -1, 1; -1, 1"}}, "interpretations": []}
    (data / "studies" / "bnd.yaml").write_text(yaml.safe_dump(doc))
    cfg = tmp_path / "c.yaml"
    cfg.write_text(yaml.safe_dump({"scale": "quick", "studies": ["bnd"], "data_dir": str(data),
                                   "results_dir": str(tmp_path / "r")}))
    rc, _, err = _run(["check_inputs", "--config", str(cfg)])
    assert rc == 2
    assert "bnd.yaml: solvers/lb on robot 'ur5e': field 'bounds': 3 pairs for a robot with 6 joints" in err, err


@pytest.mark.parametrize("key", ["results_dir", "data_dir"])
@pytest.mark.parametrize("value", ["$(touch PWNED)", "a b", "a;b", "{x}", "-rf", "résultats"])
def test_config_folders_with_shell_text_are_refused(key, value):
    rc, _, err = _run(["check_inputs", "--set", f"{key}={value}"])
    assert rc == 2 and f"field '{key}'" in err and ("not allowed in a path" in err or "is not of type" in err), err


def test_snakemake_refuses_shell_text_in_results_dir(tmp_path):
    """Through Snakemake itself: the config schema stops the value before any rule's shell command runs."""
    mark = tmp_path / MARK
    proc = subprocess.run([sys.executable, "-m", "snakemake", "-n", "--cores", "1", "--config",
                           f"results_dir={tmp_path}/$(touch {mark})", "studies=[arm_benchmark]", "scale=quick"],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode != 0
    assert "field 'results_dir'" in proc.stdout + proc.stderr
    assert not mark.exists()


SUBPROCESS_SAMPLE = [
    ["benchmark-arm", UR5E, "--results", "@W/$(touch @W/PWNED)"],
    ["benchmark-arm", "@W/d/robots/{src.__class__}.yaml"],
    ["new_study", "a" * 300, "--robots", "ur5e", "--data", "@W/d"],
    ["replay", "@W/a.mcap", "--problem", "0", "-o", "@W/r.mcap", "--dt", "1e300"],
    ["inspect", "@W/a.mcap", "--csv", "@W/a.mcap"],
    ["replay", "@W/a.mcap", "--problem", "0", "-o", "@W/a.mcap"],
]


@pytest.mark.parametrize("argv", SUBPROCESS_SAMPLE, ids=lambda a: f"{a[0]}-{len(a)}-{abs(hash(a[-1])) % 1000}")
def test_sample_as_real_processes(argv, ws, tmp_path):
    from tests.test_malformed_inputs import _run_limited

    hostile = ws / "d" / "robots" / "{src.__class__}.yaml"
    if not hostile.exists():
        hostile.write_text((ROOT / UR5E).read_text().replace("name: ur5e", "name: '{src.__class__}'"))
    before = _snapshot(ws)
    proc, rss_mib = _run_limited(_sub(argv, ws), tmp_path)
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert proc.stderr.startswith("error: ")
    assert rss_mib < 1024
    assert not (ws / MARK).exists()
    assert _snapshot(ws) == before


def test_a_csv_past_its_cap_is_not_read(tmp_path):
    """Published and built tables go through one reader with a size cap, checked before pandas opens them."""
    from pipeline.io.csvfiles import MAX_CSV_BYTES, OversizeFileError, read_csv

    big = tmp_path / "published.csv"
    with open(big, "wb") as fh:  # sparse: no disk spent
        fh.truncate(MAX_CSV_BYTES + 1)
    with pytest.raises(OversizeFileError, match=r"published.csv: 64 MiB, past the 64 MiB CSV cap"):
        read_csv(big)
    small = tmp_path / "t.csv"
    small.write_text("a,b\n1,2\n")
    assert read_csv(small).to_dict("records") == [{"a": 1, "b": 2}]
