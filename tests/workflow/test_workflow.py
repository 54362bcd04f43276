"""The Snakemake workflow itself: dry run, a quick full run, no-op rerun, targeted rebuild."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import ROOT, run_pipeline

pytestmark = pytest.mark.workflow


def _snakemake(results, *args, check=True, scale="quick", config=()):
    """Run snakemake on the repository's workflow; ``config``: more KEY=VALUE entries (one --config flag,
    since a second one would replace the first)."""
    env = dict(os.environ)
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    cmd = [sys.executable, "-m", "snakemake", "--cores", "2", "--nolock", *args,
           "--config", f"scale={scale}", f"results_dir={results}", *config]
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=1800)
    if check and proc.returncode != 0:
        raise AssertionError(f"snakemake failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
    return proc


def _jobs(proc):
    """Rule name -> number of jobs a dry run would execute (from its "Job stats" table)."""
    text = proc.stdout + proc.stderr
    if "Job stats:" not in text:
        return {}
    block = text.split("Job stats:", 1)[1].split("\n\n", 1)[0]
    return {m[0]: int(m[1]) for m in re.findall(r"^(\w+)\s+(\d+)\s*$", block, flags=re.M) if m[0] != "total"}


@pytest.fixture(scope="module")
def built(quick_build):
    return quick_build  # one quick build per session (tests/conftest.py), shared with tests/report/test_browser.py


def test_dry_run_plans_everything(tmp_path):
    proc = _snakemake(tmp_path / "r", "-n")
    assert {"make_problems", "solve_problems", "aggregate_tables", "plot_figures", "render_report"} <= set(_jobs(proc))


def test_quick_run_builds_report(built):
    report = built / "report.html"
    html = report.read_text()
    assert "data:image/png;base64," in html and "Table 7" in html and "(published)" in html
    leaked = re.findall(r"np\.(?:float|int|bool)\w*\(|array\(\[", html)  # numpy reprs in the prose
    assert not leaked, leaked[:5]
    # the YAML-only study gets the generic tables: one row per (problem set, robot, solver)
    import pandas as pd

    summary = pd.read_csv(built / "every_method" / "tables" / "summary.csv")
    assert len(summary) == 33 and set(summary["success [%]"].dropna().index) == set(summary.index)
    assert (built / "cerbaro2019" / "runs" / "random" / "kuka_lwr__dls.mcap").is_file()
    assert not list(built.rglob("*.partial"))


@pytest.mark.parametrize("sid", ["cerbaro2019", "erthal1992", "borges_kr6", "mariano2019", "nepomuceno2024"])
def test_each_study_opens_with_claims_whose_verdicts_are_computed_from_its_tables(built, sid):
    """Every claim's verdict is recomputed here from the named table's CSV (itself computed from the
    archives): none is typed in. Where the document's numbers are in the table, the claim as encoded
    holds on them (a miscoded claim fails here). The report shows the claims first in the section.
    (Before the tests below that delete parts of the shared build.)"""
    import pandas as pd

    from pipeline.settings import load_study
    from pipeline.studies.claims import MISSING, count_line, evaluate_claim, readings, select

    doc = load_study(ROOT / "data" / "studies" / f"{sid}.yaml").doc
    tables = built / sid / "tables"
    claims = pd.read_csv(tables / "claims.csv", keep_default_na=False)
    every = [(c, label, spec, counts) for c in doc["claims"] for label, spec, counts in readings(c)]
    assert len(claims) == len(every)
    headline = []
    for (c, label, spec, counts), (_, row) in zip(every, claims.iterrows()):
        path = tables / f"{spec.get('table', '')}.csv"  # a not_reproducible headline names no table
        frame = select(pd.read_csv(path) if spec.get("table") and path.is_file() else None, spec.get("rows"))
        verdict, _, pub, _ = evaluate_claim(spec, frame)
        assert row["verdict (ours)"] == verdict, (c["claim"], label)
        assert row["counts"] == ("yes" if counts else "no (shown beside)")
        if counts:  # the reading that matches what the document measured holds on the document's numbers
            assert pub in ("", "holds", MISSING), f"{sid}: claim {c['claim']!r} does not hold on the published numbers"
            headline.append(verdict)
    assert (tables / "not_reproduced.csv").is_file()
    html = (built / "report.html").read_text()
    section = html[html.index(f'<section id="{sid}"'):]
    assert section.index(f'id="tab-{sid}-claims"') < section.index(f'id="{sid}-settings"')
    # the section opens with its one-line count, before the claims table
    line = count_line(headline)
    assert f'<p class="claim-count">{line}.</p>' in section, line
    assert section.index('class="claim-count"') < section.index(f'id="tab-{sid}-claims"')


@pytest.mark.parametrize("sid", ["cerbaro2019", "erthal1992", "borges_kr6", "mariano2019", "nepomuceno2024",
                                 "arm_benchmark", "every_method", "closed_forms"])
def test_numbers_in_the_prose_come_from_the_tables(built, sid):
    """Every number in a reason, caption or interpretation of the built study is held by one of its tables,
    settings or listed document facts (prose.untabled_numbers): none is typed by hand. Every job records
    the machine's load beside its times (the machine_load table)."""
    import pandas as pd

    from pipeline.settings import load_study
    from pipeline.studies.prose import untabled_numbers

    study = load_study(ROOT / "data" / "studies" / f"{sid}.yaml")
    bad = untabled_numbers(study, built / sid, ROOT / "data" / "published")
    assert not bad, "\n".join(f"{w}: {n!r} in {c!r}" for w, n, c in bad)
    load = pd.read_csv(built / sid / "tables" / "machine_load.csv")
    assert len(load) and (load["1-min load average, largest [-]"] >= 0).all()


def test_rerun_has_nothing_to_do(built):
    proc = _snakemake(built, "-n")
    assert "Nothing to be done" in proc.stdout + proc.stderr


BLAS_CORES = ("Haswell", "Prescott")  # two OpenBLAS kernel families every x86-64 CPU here accepts


@pytest.mark.parametrize("core", BLAS_CORES)
def test_tables_figures_and_inspect_read_the_same_under_another_blas_core(built, tmp_path, core):
    """Reading never re-runs a solver: with another BLAS kernel family (and numba's generic CPU),
    every table and figure of the studies that draw traces rebuilds byte-identical from the same
    archives, and inspect shows a problem of every archive."""
    env = {"OPENBLAS_CORETYPE": core, "NUMBA_CPU_NAME": "generic"}
    for sid in ("cerbaro2019", "nepomuceno2024", "erthal1992"):
        # the archives the build's tables were made from, in the build's order (tables/provenance.json)
        prov = json.loads((built / sid / "tables" / "provenance.json").read_text())
        runs = [str(built / r["archive"]) for r in prov]
        for verb, sub in (("aggregate_tables", "tables"), ("plot_figures", "figures")):
            out = tmp_path / sid / sub
            proc = run_pipeline(verb, "--study", f"data/studies/{sid}.yaml", "--archives", *runs, "--out-dir", str(out),
                             env=env)
            assert proc.returncode == 0, proc.stderr[-2000:]
            for f in sorted(out.rglob("*")):
                if f.is_file() and f.name != "provenance.json":
                    assert f.read_bytes() == (built / sid / sub / f.relative_to(out)).read_bytes(), (core, f)
        for path in [r for r in runs if "/runs/" in r][:6]:
            proc = run_pipeline("inspect", path, "--problem", "0", env=env)
            assert proc.returncode == 0 or "is not in the archive" in proc.stderr, proc.stderr


def test_reproduce_reports_deterministic_labels_bit_identical_here_and_lists_differences_elsewhere(built):
    here = run_pipeline("reproduce", str(built / "cerbaro2019"), "--sample", "5")
    assert here.returncode == 0, here.stderr[-2000:]
    summary = next(ln for ln in here.stdout.splitlines() if "deterministic archive(s):" in ln)
    n = int(summary.split()[0])
    assert n >= 4 and f"{n} bit-identical on every re-run solve, 0 with differences" in summary, here.stdout
    assert "written on:" in here.stdout and "re-run on:" in here.stdout
    other = run_pipeline("reproduce", str(built / "cerbaro2019"), "--sample", "5", env={"OPENBLAS_CORETYPE": "Prescott"})
    assert other.returncode == 0, other.stderr[-2000:]
    assert "OPENBLAS_CORETYPE=Prescott" not in other.stdout.split("re-run on:")[0]  # the archive's environment
    assert "deterministic archive(s):" in other.stdout


def test_deleting_an_archive_rebuilds_only_its_dependents(built):
    (built / "cerbaro2019" / "runs" / "random" / "kuka_lwr__dls.mcap").unlink()
    jobs = _jobs(_snakemake(built, "-n"))
    # the archive itself, the rerun of its failures, the study's tables/figures, the report, the manifest
    assert jobs.get("solve_problems") == 1 and "make_problems" not in jobs
    assert set(jobs) <= {"solve_problems", "rerun_failures", "aggregate_tables", "plot_figures", "check_prose",
                         "render_report", "manifest", "all", "cerbaro2019"}


def test_deleting_a_tables_folder_rebuilds_it_and_the_report(built):
    import shutil

    shutil.rmtree(built / "borges_kr6" / "tables")
    proc = _snakemake(built, "-n")
    jobs = _jobs(proc)
    assert jobs.get("aggregate_tables", 0) >= 1 and jobs.get("render_report") == 1
    assert f"output: {built / 'borges_kr6' / 'tables'}" in proc.stdout + proc.stderr
    # its archives are intact: no borges_kr6 problem set or archive is planned (an earlier test of this
    # module deleted a cerbaro2019 archive, whose rebuild may be planned too)
    text = proc.stdout + proc.stderr
    assert f"output: {built / 'borges_kr6' / 'runs'}" not in text
    assert f"output: {built / 'borges_kr6' / 'problems'}" not in text


def test_bad_config_fails_before_any_job(tmp_path):
    proc = _snakemake(tmp_path / "r", "-n", check=False, scale="huge")
    assert proc.returncode != 0
    assert "field 'scale'" in proc.stderr + proc.stdout


def test_a_new_robot_and_a_new_study_build_end_to_end(tmp_path):
    """What the README promises: copy a robot file, `new_study`, snakemake -- nothing else."""
    import shutil

    import pandas as pd
    import yaml

    from pipeline.cli import main

    data = tmp_path / "data"
    shutil.copytree(ROOT / "data" / "robots", data / "robots")
    shutil.copytree(ROOT / "data" / "published", data / "published")
    doc = yaml.safe_load((data / "robots" / "ur5e.yaml").read_text())
    doc["name"] = "my_arm"
    doc["tool"] = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.1], [0, 0, 0, 1]]  # a 10 cm tool
    (data / "robots" / "my_arm.yaml").write_text(yaml.safe_dump(doc))
    assert main(["new_study", "my_arm", "--robots", "my_arm", "--data", str(data), "--solvers", "dls",
                 "levenberg_marquardt", "analytic_ur", "analytic_puma"]) == 0
    st = yaml.safe_load((data / "studies" / "my_arm.yaml").read_text())
    assert set(st["solvers"]) == {"dls", "levenberg_marquardt", "analytic_ur"}  # PUMA closed form refused
    results = tmp_path / "r"
    _snakemake(results, config=(f"data_dir={data}", "studies=[my_arm]"))
    summary = pd.read_csv(results / "my_arm" / "tables" / "summary.csv")
    assert list(summary["solver"]) == ["dls", "levenberg_marquardt", "analytic_ur"]
    assert (summary["success [%]"] > 90).all()
    assert (results / "report.html").is_file()


def _fk_errors(model, q, T_goal):
    """Independent numpy FK of q: (|dp| [m], rotation angle [rad])."""
    from pipeline.kinematics import fk_htm
    from pipeline.robots import LENGTH_UNITS

    T = fk_htm(model.chain, q)
    dp = float(np.linalg.norm(T[:3, 3] - T_goal[:3, 3])) * LENGTH_UNITS[model.length_unit]
    c = (np.trace(T_goal[:3, :3] @ T[:3, :3].T) - 1) / 2
    return dp, float(np.arccos(np.clip(c, -1, 1)))


def test_benchmark_successes_are_within_tolerance_and_limits(built):
    """Every success in every arm_benchmark archive of the quick run, re-checked from its record alone."""
    from pipeline.io.archive import goal_from_record, read_archive
    from pipeline.kinematics import matrix_from_quat
    from pipeline.robots import load_robot
    from pipeline.robots import LENGTH_UNITS
    from pipeline.solvers.core import within_limits

    archives = sorted((built / "arm_benchmark" / "runs").rglob("*.mcap"))
    assert len(archives) > 300
    models, n_ok, methods = {}, 0, set()
    for path in archives:
        a = read_archive(path)
        robot = a.metadata["robot"]
        m = models.setdefault(robot, load_robot(ROOT / "data" / "robots" / f"{robot}.yaml"))
        methods.add(a.metadata["solver"])
        for r in a.solves:
            if not r["success"]:
                continue
            n_ok += 1
            pos, quat = goal_from_record(r["goal"])
            T = np.eye(4)
            T[:3, :3] = matrix_from_quat(quat)
            T[:3, 3] = pos * LENGTH_UNITS[r["length_unit"]] / LENGTH_UNITS[m.length_unit]
            q = np.array(r["q_solution"], dtype=float)
            dp, ang = _fk_errors(m, q, T)
            assert dp <= 1e-4 * (1 + 1e-6) and ang <= 1e-3 * (1 + 1e-6), (path.name, r["problem_id"], dp, ang)
            assert within_limits(q, m.limits, m.chain.prismatic), (path.name, r["problem_id"], q)
    assert n_ok > 10000
    assert {"dls", "dls_restarts", "levenberg_marquardt", "analytic_ur"} <= methods


def _protobuf_class(schema):
    from google.protobuf import descriptor_pb2, message_factory

    fds = descriptor_pb2.FileDescriptorSet.FromString(schema.data)
    return message_factory.GetMessages(list(fds.file))[schema.name]


def test_every_message_of_every_archive_is_strict_json_or_decodes_with_its_protobuf_schema(built):
    """What a viewer (Foxglove: JSON.parse, or the schema's protobuf) does with each message: no NaN,
    no Infinity, in JSON text or in a decoded float field."""
    import json
    import math

    pytest.importorskip("google.protobuf", reason="protobuf (test extra) not installed")
    from mcap.reader import make_reader

    def strict(c):
        raise AssertionError(f"non-JSON constant {c}")

    archives = sorted(built.rglob("*.mcap"))
    assert len(archives) > 400
    counts = {"json": 0, "protobuf": 0}
    for path in archives:
        classes = {}
        with open(path, "rb") as fh:
            for schema, channel, msg in make_reader(fh, validate_crcs=True).iter_messages():
                if channel.message_encoding == "json":
                    json.loads(msg.data, parse_constant=strict)
                else:
                    assert channel.message_encoding == "protobuf", (path, channel.topic)
                    cls = classes.get(schema.id) or classes.setdefault(schema.id, _protobuf_class(schema))
                    m = cls.FromString(msg.data)
                    for field, value in m.ListFields():
                        if field.type in (field.TYPE_DOUBLE, field.TYPE_FLOAT):
                            assert all(math.isfinite(v) for v in value), (path, channel.topic, field.name)
                        elif field.type == field.TYPE_STRING and field.name.endswith("_json"):
                            json.loads(value, parse_constant=strict)
                counts[channel.message_encoding] += 1
    assert counts["json"] > 0 and counts["protobuf"] > 1000, counts


def test_every_stored_trace_agrees_with_its_record_and_the_policy_is_recorded(built):
    """Format 5: the stored traces start and end at the records' initial and final errors; every
    archive says what its trace policy kept; an analytic solve's solutions are all stored."""
    from pipeline.io.archive import TraceNotStored, read_archive

    archives = sorted((p for p in built.rglob("*.mcap") if "/runs/" in str(p)))
    with_traces = not_stored = 0
    for path in archives:
        a = read_archive(path)
        if not a.solves:
            continue
        recs = a.records()
        assert int(a.trace_summary["stored"]) <= int(a.trace_summary["traces"]), path
        for t in a.traces():
            r = recs[(t["problem_id"], t["repetition"])]
            if r["iterations"] and len(t["error"]) > 1:
                assert t["error"][0] == r["initial_error"] and t["error"][-1] == r["final_error"], path
            with_traces += 1
        for r in a.solves[:3]:
            if r.get("_n_solutions") is not None:
                assert len(a.solutions(r["problem_id"], r["repetition"])) == r["_n_solutions"]
        missing = [k for k, v in a.trace_index().items() if v[2] is None]
        if missing:
            not_stored += 1
            with pytest.raises(TraceNotStored, match="reproduce"):
                list(a.traces([missing[0][0]]))
    assert with_traces > 1000


@pytest.mark.parametrize("study, archive, how", [
    ("cerbaro2019", "random/kuka_lwr__pseudoinverse.mcap", "problem"),  # (an earlier test deletes the DLS one)
    ("nepomuceno2024", "pick_and_place/ur5_nepomuceno__bfgs.mcap", "all")])
def test_a_replay_of_a_built_archive_is_a_3d_scene_ending_at_the_archived_solution(built, tmp_path, study, archive, how):
    """One cerbaro2019 problem (iterate by iterate) and one nepomuceno2024 path (the arm following
    it), from the quick build's own archives: Foxglove's schemas on every channel, and the last
    frame's tool pose is the FK of the archived solution."""
    from pipeline.cli import main
    from pipeline.io.archive import read_archive
    from pipeline.robots import load_robot
    from tests.jobs.test_replay import TOPICS, _assert_pose, _decoder, _read, _tool_m

    src, out = built / study / "runs" / archive, tmp_path / "replay.mcap"
    arch = read_archive(src)
    rec = next(r for r in arch.solves if r["success"]) if how == "problem" else max(arch.solves, key=lambda r: r["problem_id"])
    args = ["--problem", str(rec["problem_id"])] if how == "problem" else ["--all"]
    assert main(["replay", str(src), *args, "-o", str(out)]) == 0
    chans, msgs, meta = _read(out)
    assert {t: sch.name for t, (sch, _) in chans.items()} == TOPICS
    assert meta["replay_check"]["mismatches"].startswith("none")
    model = load_robot(ROOT / "data" / "robots" / f"{arch.metadata['robot']}.yaml")
    T = _tool_m(model, rec["q_solution"])
    FT, PF = _decoder(chans["/tf"][0]), _decoder(chans["/reached"][0])
    tools = [FT.FromString(m.data) for t, m in msgs if t == "/tf" and FT.FromString(m.data).child_frame_id == "tool"]
    _assert_pose(tools[-1].translation, tools[-1].rotation, T)
    reached = PF.FromString([m.data for t, m in msgs if t == "/reached"][-1])
    _assert_pose(reached.pose.position, reached.pose.orientation, T)
    frames = [m for t, m in msgs if t == "/replay/frame"]
    if how == "all":  # the path: one frame per point after the start
        assert len(frames) == len({r["problem_id"] for r in arch.solves}) + 1


def test_report_opens_with_the_answer(built):
    import pandas as pd

    html = (built / "report.html").read_text()
    assert html.index('id="answer"') < html.index('id="cerbaro2019"')
    ans = pd.read_csv(built / "arm_benchmark" / "tables" / "answer.csv")
    assert len(ans) == 2 * 13
    # a recommendation for every row, whatever the machine's load
    assert ans["answer"].str.contains(": use ").all() and (ans["recommendation"].astype(str) != "").all()
    assert ans["smoke run"].all() and ans["answer"].str.contains("Smoke run").all()  # quick scale says so
    rec = ans
    assert (rec["success CI low [%]"] <= rec["success [%]"]).all() and (rec["success [%]"] <= rec["success CI high [%]"]).all()
    assert rec["call"].astype(str).str.contains("solvers.bind(", regex=False).all()
    warm = ans[ans["problem set"] == "warm"]
    assert warm["distance to seed p50 [rad]"].notna().all()
    plain = pd.read_csv(built / "arm_benchmark" / "tables" / "answer_plain.csv")
    assert list(plain.columns[:4]) == ["arm", "starts", "method", "library"] and len(plain) == len(ans)
    assert html.index("Which method for which arm, in plain words") < html.index('id="answer-ur5"')
    races = sorted((built / "arm_benchmark" / "race").glob("*.mcap"))
    assert len(races) == 13  # one race archive per arm, raced or not
    race = pd.read_csv(built / "arm_benchmark" / "tables" / "race_ur5.csv")  # several closed forms on a UR arm
    assert {"analytic", "analytic_ur"} <= set(race["solver"]) and (race["ratio to fastest p50"] >= 1).all()
    ur5 = ans[ans["robot"] == "ur5"]
    assert ur5["timing"].str.contains("raced against").all() and ur5["timing"].str.contains("load average").all()
    panda = ans[ans["robot"] == "franka_panda"]  # one closed form among the best: no timing decides
    assert (panda["recommendation"] == "analytic").all() and panda["timing"].str.contains("no timing decides").all()
    heat = pd.read_csv(built / "arm_benchmark" / "tables" / "heatmap.csv")
    assert len(heat) == 13
    for robot in ("ur5", "franka_panda"):
        key = pd.read_csv(built / "arm_benchmark" / "tables" / f"key_{robot}.csv")
        assert 1 <= key["solver"].nunique() <= 8
        full = pd.read_csv(built / "arm_benchmark" / "tables" / f"robot_{robot}.csv")
        lm = full[full["solver"] == "rtb_ik_lm"]
        # a peer's library with the version its archives recorded
        assert len(lm) and lm["library"].str.fullmatch(r"roboticstoolbox-python \d+(\.\d+)+").all()
    assert 'href="arm_benchmark/tables/solves.csv.gz"' in html


def test_per_sample_file_has_one_row_per_solve(built):
    """The per-sample file of arm_benchmark loads in pandas with one row per archived solve."""
    import pandas as pd

    from pipeline.io.archive import read_archive
    from pipeline.studies.generic import SAMPLE_COLUMNS

    df = pd.read_csv(built / "arm_benchmark" / "tables" / "solves.csv.gz")
    assert list(df.columns) == list(SAMPLE_COLUMNS)
    archives = sorted((built / "arm_benchmark" / "runs").rglob("*.mcap"))
    assert len(df) == sum(len(read_archive(a).solves) for a in archives)
    assert not df.duplicated(["robot", "problem_set", "solver", "problem_id", "repetition"]).any()
    assert df["cpu_time_us"].gt(0).all() and df["call_time_us"].gt(0).all()
    assert set(df.loc[df["solver"] == "rtb_ik_lm", "library"]) <= {"roboticstoolbox-python"}


def test_an_arm_from_a_xacro_file_is_benchmarked_alone(tmp_path):
    """The README's "Bring your own arm" steps on a xacro file the project has never built: one command
    benchmarks that arm alone, and the answer shows its recommendation, interval and call to copy."""
    import numpy as np
    import pandas as pd

    from pipeline.cli import main

    robot = tmp_path / "robots" / "my_ur5e.yaml"
    robot.parent.mkdir()
    assert main(["import-urdf", str(ROOT / "tests" / "data" / "xacro" / "my_ur5e.urdf.xacro"), "--base", "base_link",
                 "--tip", "tool0", "--out", str(robot)]) == 0
    results = tmp_path / "r"
    assert main(["benchmark-arm", str(robot), "--scale", "quick", "--results", str(results)]) == 0
    assert sorted(p.name for p in (results / "arm_benchmark" / "runs" / "cold").glob("*.mcap"))[0].startswith("my_ur5e__")
    assert {p.name.split("__")[0] for p in (results / "arm_benchmark" / "runs").rglob("*.mcap")} == {"my_ur5e"}
    table = pd.read_csv(results / "arm_benchmark" / "tables" / "robot_my_ur5e.csv")
    closed = table[table["solver"] == "analytic"]
    assert len(closed) == 2 and (closed["success [%]"] == 100).all(), closed
    ans = pd.read_csv(results / "arm_benchmark" / "tables" / "answer.csv")
    assert list(ans["robot"]) == ["my_ur5e", "my_ur5e"]
    assert ans["answer"].str.contains(": use ").all()
    assert (ans["success CI high [%]"] >= ans["success [%]"]).all()
    for call in ans["call"]:  # the program the report tells the user to copy, run as written
        where = re.search(r"robots\.load_robot\('([^']+)'\)", call).group(1)  # the benchmark's copy of the file
        assert Path(where).name == "my_ur5e.yaml" and Path(where).is_file(), where
        proc = subprocess.run([sys.executable, "-c", call.replace("1000", "50")], capture_output=True, text=True,
                              cwd=ROOT)
        assert proc.returncode == 0 and "solved 50 of 50" in proc.stdout, (call, proc.stderr[-1500:])
    html = (results / "report.html").read_text()
    assert 'id="answer-my_ur5e"' in html and "budget_my_ur5e" in html and "solvers.bind(" in html


def _verify(results, *args):
    return subprocess.run([sys.executable, "-m", "pipeline", "verify", str(results), *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=900)


@pytest.fixture(scope="module")
def verified_copy(built, tmp_path_factory):
    """A copy of the quick build that `verify` passes (the tests below each break one thing in a copy)."""
    import shutil

    copy = tmp_path_factory.mktemp("verify") / "results"
    shutil.copytree(built, copy)
    _snakemake(copy)  # earlier tests delete an archive and a tables folder of `built` (dry runs only)
    proc = _verify(copy)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "cerbaro2019: ok" in proc.stdout and "report: ok" in proc.stdout and "manifest: ok" in proc.stdout
    return copy


def _broken_copy(verified_copy, tmp_path):
    import shutil

    out = tmp_path / "results"
    shutil.copytree(verified_copy, out)
    return out


def test_verify_catches_an_edited_table(verified_copy, tmp_path):
    res = _broken_copy(verified_copy, tmp_path)
    csv = res / "every_method" / "tables" / "summary.csv"
    lines = csv.read_text().splitlines()
    cells = lines[1].split(",")
    k = next(i for i, c in enumerate(cells) if re.fullmatch(r"\d+(\.\d+)?", c))
    cells[k] = str(float(cells[k]) + 1)
    csv.write_text("\n".join([lines[0], ",".join(cells), *lines[2:]]) + "\n")
    proc = _verify(res)
    assert proc.returncode == 1
    assert "every_method: " in proc.stdout and "summary.csv: differs from a recomputation" in proc.stdout
    assert "report: " in proc.stdout and "embeds other tables" in proc.stdout


def test_verify_catches_an_edited_report(verified_copy, tmp_path):
    res = _broken_copy(verified_copy, tmp_path)
    report = res / "report.html"
    report.write_text(report.read_text().replace("Which IK method for your arm?", "Which IK method for my arm?", 1))
    proc = _verify(res)
    assert proc.returncode == 1 and "report.html: its text differs" in proc.stdout
    assert "cerbaro2019: ok" in proc.stdout


def test_verify_catches_an_archive_from_another_study(verified_copy, tmp_path):
    import shutil

    res = _broken_copy(verified_copy, tmp_path)
    target = res / "every_method" / "runs" / "warm" / "kuka_lwr__dls.mcap"
    shutil.copy(res / "cerbaro2019" / "runs" / "random" / "kuka_lwr__dls.mcap", target)
    proc = _verify(res)
    assert proc.returncode == 1
    assert "kuka_lwr__dls.mcap: an archive of study 'cerbaro2019', not 'every_method'" in proc.stdout


def test_verify_names_a_changed_robot_file(verified_copy, tmp_path):
    """The archives record the SHA-256 of the robot file they were solved with: an edit is named, with the study."""
    import shutil

    data = tmp_path / "data"
    shutil.copytree(ROOT / "data", data)
    robot = data / "robots" / "kuka_lwr.yaml"
    robot.write_text(robot.read_text() + "notes: edited after the build\n")
    proc = _verify(verified_copy, "--data", str(data))
    assert proc.returncode == 1
    line = next(ln for ln in proc.stdout.splitlines() if ln.startswith("cerbaro2019: "))
    assert f"{robot}: SHA-256 " in line and "the robot file changed after the build" in line


def test_verify_names_an_edited_or_damaged_problem_set(verified_copy, tmp_path):
    import gzip

    res = _broken_copy(verified_copy, tmp_path)
    pset = res / "cerbaro2019" / "problems" / "random" / "kuka_lwr.csv.gz"
    text = gzip.decompress(pset.read_bytes()).decode()
    pset.write_bytes(gzip.compress(text.replace(",0.", ",1.", 1).encode(), mtime=0))
    proc = _verify(res)
    assert proc.returncode == 1
    assert f"cerbaro2019: {pset}: SHA-256 " in proc.stdout and "the problem set changed after the build" in proc.stdout
    assert f"manifest: {pset}: SHA-256 differs" in proc.stdout
    damaged = bytearray(pset.read_bytes())
    damaged[-6] ^= 0xFF  # the gzip CRC
    pset.write_bytes(bytes(damaged))
    proc = _verify(res)
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    assert f"cerbaro2019: {pset}: damaged gzip file (CRC check failed)" in proc.stdout
    for argv in (["inspect", str(res / "cerbaro2019" / "runs" / "random" / "kuka_lwr__dls.mcap")],
                 ["aggregate_tables", "--study", "data/studies/cerbaro2019.yaml", "--archives",
                  str(res / "cerbaro2019" / "runs" / "random" / "kuka_lwr__dls.mcap"), "--out-dir", str(tmp_path / "t")]):
        p = run_pipeline(*argv)
        assert p.returncode == 2 and p.stderr.startswith(f"error: {pset}: damaged gzip file") and \
            p.stderr.count("\n") == 1, p.stderr


def test_verify_catches_an_archive_rewritten_with_valid_crcs(verified_copy, tmp_path):
    """An edit that recomputes the MCAP CRCs reads as a sound archive; the build manifest still names it."""
    import struct
    import zlib

    from pipeline.io.archive import archive_metadata, read_archive

    res = _broken_copy(verified_copy, tmp_path)
    arch = res / "cerbaro2019" / "runs" / "random" / "kuka_lwr__dls.mcap"
    old = archive_metadata(arch)["git_commit"][:12].encode()
    data = bytearray(arch.read_bytes())
    i = data.find(old)
    data[i:i + len(old)] = b"f" * len(old)
    summary_start = struct.unpack_from("<BQQQI", data, len(data) - 8 - 29)[2]
    end = summary_start - 13  # the DataEnd record: its CRC covers every byte before it
    struct.pack_into("<I", data, end + 9, zlib.crc32(bytes(data[:end])))
    arch.write_bytes(bytes(data))
    read_archive(arch)  # CRC-valid: the reader accepts it
    proc = _verify(res)
    assert proc.returncode == 1
    assert f"manifest: {arch}: SHA-256 differs from the one the build recorded in MANIFEST.sha256" in proc.stdout
    (res / "MANIFEST.sha256").unlink()
    proc = _verify(res)
    assert proc.returncode == 1 and "MANIFEST.sha256: missing" in proc.stdout


def test_rebuilding_from_the_same_archives_is_byte_identical(verified_copy, tmp_path):
    """Tables, figures (PNG and SVG) and the report rebuilt twice: identical but for the build-time line."""
    import shutil

    runs = []
    for k in range(2):
        res = tmp_path / f"r{k}"
        shutil.copytree(verified_copy, res)
        for d in list(res.glob("*/tables")) + list(res.glob("*/figures")) + [res / "report.html"]:
            shutil.rmtree(d) if d.is_dir() else d.unlink()
        _snakemake(res)
        runs.append(res)
    a, b = runs
    files = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file() and ("tables" in p.parts or "figures" in p.parts))
    assert files and any(f.suffix == ".svg" for f in files) and any(f.suffix == ".png" for f in files)
    for f in files:  # the two copies live in different folders: nothing may name the folder
        assert (a / f).read_bytes() == (b / f).read_bytes(), f
    ra, rb = ((r / "report.html").read_text().splitlines() for r in runs)
    diff = [(x, y) for x, y in zip(ra, rb) if x != y]
    assert len(ra) == len(rb) and all("data-build-time" in x for x, _ in diff), diff[:3]
