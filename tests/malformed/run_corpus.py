"""Run every file of the malformed-input corpus through the verbs, in one process, and report.

Each case calls ``pipeline.cli.main`` (the entry point of ``python -m pipeline``) in this process,
so that ~350 runs take seconds instead of ~350 interpreter start-ups:

- a robot file (``robots/``): ``check_inputs`` on a data folder holding it and a probe study that
  names it, then the ``robot`` verb on the corpus file itself;
- a study file (``studies/``): ``check_inputs`` on a data folder holding it (the real robots beside
  it), then ``make_problems`` and ``solve_problems`` with ``--study`` the corpus file;
- a config file (``configs/``): ``check_inputs --config`` the corpus file.

Every run gets a 10 s alarm; with ``--memory-limit`` the address space may grow by at most 1 GiB
over what the imports took (``RLIMIT_AS``), so an input that makes a verb allocate more fails here.
Output: one JSON object per run (``--json``), or a summary. ``--write-expected`` rewrites
``expected.tsv`` from the ``check_inputs`` lines (``{file}`` standing for the path it names,
``{data}`` for the data folder of the run).

Run from the repository root: ``python tests/malformed/run_corpus.py``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import resource
import shutil
import signal
import sys
import tempfile
import time
import traceback
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
KINDS = ("robots", "studies", "configs")
TIME_LIMIT_S = 10
MEMORY_LIMIT = 1 << 30  # bytes of address space a run may add

PROBE_STUDY = """\
study: probe
title: malformed-input corpus probe
document: "none"
robots: [{robot}]
problem_sets:
  warm:
    kind: warm_start
    seed: 1
    count: {{full: 10, quick: 5}}
solvers:
  dls: {{method: dls, criterion: position}}
interpretations: []
"""


class Timeout(Exception):
    pass


def corpus_files() -> list[Path]:
    """Every corpus file, ``robots/`` then ``studies/`` then ``configs/``, sorted by name."""
    return [p for kind in KINDS for p in sorted((HERE / kind).glob("*.yaml"))]


def read_expected() -> dict[str, str]:
    """``expected.tsv``: corpus path (from tests/malformed) -> the expected line, ``{file}`` standing for the file."""
    out = {}
    for line in (HERE / "expected.tsv").read_text(encoding="utf-8").splitlines():
        if line and not line.startswith("#"):
            rel, msg = line.split("\t", 1)
            out[rel] = msg
    return out


def _vm_bytes() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmSize:"):
            return int(line.split()[1]) * 1024
    return 0


def run_verb(argv: list[str]) -> dict:
    """``pipeline.cli.main(argv)`` with captured output, a 10 s alarm and any exception recorded."""
    from pipeline.cli import main

    out, err = io.StringIO(), io.StringIO()

    def alarm(signum, frame):
        raise Timeout(f"still running after {TIME_LIMIT_S} s")

    old = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(TIME_LIMIT_S)
    t0 = time.monotonic()
    rc, exc = None, None
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            rc = main(argv)
    except SystemExit as e:  # argparse usage errors
        rc = e.code
    except BaseException:  # noqa: BLE001  (a traceback is what the test looks for)
        exc = traceback.format_exc()
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    return {"argv": argv, "rc": rc, "stderr": err.getvalue(), "stdout": out.getvalue()[-2000:],
            "seconds": round(time.monotonic() - t0, 3), "exception": exc}


def runs_for(path: Path, tmp: Path) -> list[tuple[str, list[str], str]]:
    """(verb, argv, the path ``{file}`` stands for) of every run of one corpus file."""
    kind, stem = path.parent.name, path.stem
    rel = os.path.relpath(path, ROOT)
    work = tmp / kind / stem
    (work / "robots").parent.mkdir(parents=True, exist_ok=True)
    cfg = work / "config.yaml"
    if kind == "robots":
        (work / "robots").mkdir(parents=True, exist_ok=True)
        (work / "studies").mkdir(parents=True, exist_ok=True)
        shutil.copyfile(path, work / "robots" / path.name)
        (work / "studies" / "probe.yaml").write_text(PROBE_STUDY.format(robot=stem))
        cfg.write_text(f"scale: quick\nstudies: [probe]\ndata_dir: {work}\n")
        return [("check_inputs", ["check_inputs", "--config", str(cfg)], str(work / "robots" / path.name)),
                ("robot", ["robot", rel], rel)]
    if kind == "studies":
        (work / "studies").mkdir(parents=True, exist_ok=True)
        shutil.copyfile(path, work / "studies" / path.name)
        if not (work / "robots").exists():
            (work / "robots").symlink_to(ROOT / "data" / "robots")
        cfg.write_text(f"scale: quick\nstudies: [{stem}]\ndata_dir: {work}\n")
        robot = os.path.relpath(ROOT / "data" / "robots" / "planar2r.yaml", ROOT)
        return [("check_inputs", ["check_inputs", "--config", str(cfg)], str(work / "studies" / path.name)),
                ("make_problems", ["make_problems", "--study", rel, "--problem-set", "warm", "--robot", robot,
                                   "--scale", "quick", "--out", str(work / "warm.csv")], rel),
                ("solve_problems", ["solve_problems", "--study", rel, "--problem-set", "warm", "--robot", robot,
                                    "--solver", "dls", "--problems", str(work / "warm.csv"), "--scale", "quick",
                                    "--out", str(work / "warm.mcap")], rel)]
    return [("check_inputs", ["check_inputs", "--config", rel], rel)]


def parser(description: str, expected_help: str) -> argparse.ArgumentParser:
    """The options of a corpus runner (this one and ``tests/malformed2/run_corpus.py``)."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--json", action="store_true", help="one JSON object per run on stdout")
    ap.add_argument("--memory-limit", action="store_true", help="cap the address space at +1 GiB over the imports")
    ap.add_argument("--write-expected", action="store_true", help=expected_help)
    return ap


def prepare(args) -> None:
    """Run from the repository root, import the verbs, then cap the address space (``--memory-limit``)."""
    os.chdir(ROOT)
    sys.path.insert(0, str(ROOT))
    import pipeline.cli  # noqa: F401  (imports first: the memory cap is on top of them)
    import pipeline.studies.erthal1992.cli  # noqa: F401
    import pipeline.solvers  # noqa: F401

    if args.memory_limit:
        limit = _vm_bytes() + MEMORY_LIMIT
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))


def main(argv=None) -> int:
    ap = parser(__doc__.splitlines()[0], "rewrite expected.tsv from the check_inputs lines")
    ap.add_argument("only", nargs="*", help="corpus files to run (default all)")
    args = ap.parse_args(argv)
    prepare(args)
    files = [Path(p).resolve() for p in args.only] if args.only else corpus_files()
    expected = {}
    with tempfile.TemporaryDirectory(prefix="malformed-") as tmpdir:
        tmp = Path(tmpdir)
        for path in files:
            rel = f"{path.parent.name}/{path.name}"
            for verb, av, file in runs_for(path, tmp):
                res = run_verb(av)
                res.update(case=rel, verb=verb, file=file)
                line = res["stderr"].rstrip("\n")
                work = str(tmp / path.parent.name / path.stem)
                res["data"] = work
                if verb == "check_inputs" and "\n" not in line and file in line:
                    expected[rel] = line.replace(file, "{file}").replace(work, "{data}")
                if args.json:
                    print(json.dumps(res), flush=True)
                elif res["exception"] or res["rc"] in (0, None) or "\n" in line:
                    print(f"BAD {rel} {verb}: rc={res['rc']} {res['exception'] or line}")
    if args.write_expected:
        lines = ["# corpus file (under tests/malformed)\tthe one line check_inputs prints ({file}: the file it names, "
                 "{data}: the run's data folder)"]
        lines += [f"{rel}\t{msg}" for rel, msg in sorted(expected.items())]
        (HERE / "expected.tsv").write_text("\n".join(lines) + "\n", encoding="utf-8")
        print(f"wrote {len(expected)} lines to {HERE / 'expected.tsv'}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
