"""Run every case of the second malformed-input corpus through the verbs it reaches, in one process.

Like ``tests/malformed/run_corpus.py`` (whose ``run_verb`` and ``runs_for`` this script imports: a 10 s
alarm per run, the address space capped with ``--memory-limit``), with more kinds:

- ``robots/``, ``studies/``, ``configs/``: as in the first corpus (``check_inputs``, the ``robot`` verb,
  ``make_problems``, ``solve_problems``);
- ``urdfs/``: ``import-urdf --base base --tip tip``;
- ``points/``: the ``robot`` verb on a joint-point input;
- ``fifo/<verb>`` and ``device/<verb>`` (made at run time): a FIFO or ``/dev/zero`` given to each verb;
- ``damaged/<what>`` (made at run time): a small solve (``make_problems`` + ``solve_problems`` on
  planar2r), then its problem set or archive damaged, and every verb that reads it run on it.

Every run also records the files Python opened (an audit hook on ``open``) outside the corpus, the
run's temporary folder, the data folder and the installed code (``outside`` in the output): a case
like ``jacobian_robot: ../../../../etc/passwd`` must be refused before anything is read.

Output: one JSON object per run (``--json``) or a summary; ``--write-expected`` rewrites
``expected.tsv`` (``case<TAB>verb<TAB>line``; ``{file}`` stands for the path the run names, ``{repo}`` for the project folder, ``{data}``
for the run's data folder, ``{tmp}`` for the temporary folder, ``{sha16}`` for a hash prefix;
``(accepted)``: exit 0). Run from the
repository root: ``python tests/malformed2/run_corpus.py``.
"""

from __future__ import annotations

import gzip
import importlib.metadata
import json
import os
import re
import shutil
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
FILE_KINDS = ("robots", "studies", "configs", "urdfs", "points")
ACCEPTED = "(accepted)"


sys.path.insert(0, str(HERE.parent / "malformed"))
import run_corpus as BASE  # noqa: E402  (tests/malformed/run_corpus.py: run_verb, runs_for, options, set-up)

TIME_LIMIT_S = BASE.TIME_LIMIT_S
PROBE = BASE.PROBE_STUDY.format(robot="planar2r")  # study 'probe': set warm, solver dls

# the verbs a FIFO or a device is given to, with the argument that names it ({x}: the FIFO or device)
NON_REGULAR = {
    "robot": ["robot", "{x}"],
    "check_inputs": ["check_inputs", "--config", "{x}"],
    "make_problems_study": ["make_problems", "--study", "{x}", "--problem-set", "warm", "--robot",
                            "data/robots/planar2r.yaml", "--out", "{tmp}/nr.csv"],
    "make_problems_robot": ["make_problems", "--study", "{probe}", "--problem-set", "warm", "--robot", "{x}",
                            "--out", "{tmp}/nr.csv"],
    "solve_problems_problems": ["solve_problems", "--study", "{probe}", "--problem-set", "warm", "--robot",
                                "data/robots/planar2r.yaml", "--solver", "dls", "--problems", "{x}", "--out",
                                "{tmp}/nr.mcap"],
    "import_urdf": ["import-urdf", "{x}", "--base", "base", "--tip", "tip", "--out", "{tmp}/nr.yaml"],
    "export_urdf": ["export-urdf", "{x}", "--out", "{tmp}/nr.urdf"],
    "inspect": ["inspect", "{x}"],
    "aggregate_tables": ["aggregate_tables", "--study", "{probe}", "--archives", "{x}", "--out-dir", "{tmp}/nr_t"],
    "plot_figures": ["plot_figures", "--study", "{probe}", "--archives", "{x}", "--out-dir", "{tmp}/nr_f"],
    "reproduce": ["reproduce", "{x}"],
    "replay": ["replay", "{x}", "--problem", "0", "-o", "{tmp}/nr_replay.mcap"],
    "rerun_failures": ["rerun_failures", "--study", "{probe}", "--problem-set", "warm", "--robot",
                       "data/robots/planar2r.yaml", "--solver", "dls", "--problems", "{tmp}/base/warm.csv.gz",
                       "--archive", "{x}", "--out", "{tmp}/nr_rerun.mcap"],
    "benchmark_arm": ["benchmark-arm", "{x}", "--dry-run", "--results", "{tmp}/nr_bench"],
}
DEVICE_VERBS = ("robot", "check_inputs", "import_urdf", "inspect")


def _damage(kind: str, data: bytes) -> bytes:
    """A problem set's or archive's bytes damaged one way."""
    if kind == "gzip_crc":
        return data[:-8] + bytes([data[-8] ^ 0xFF]) + data[-7:]
    if kind == "flipped_middle":
        i = len(data) // 2
        return data[:i] + bytes([data[i] ^ 0x55]) + data[i + 1:]
    if kind == "truncated":
        return data[: len(data) // 2]
    if kind == "empty":
        return b""
    if kind == "not_gzip":
        return b"problem_id,chain\n0,-1\n"
    if kind == "edited":  # a valid gzip of changed text: its hash differs from the archive's record
        text = gzip.decompress(data).decode().replace(",0.", ",1.", 1)
        return gzip.compress(text.encode(), mtime=0)
    raise ValueError(kind)


PROBLEM_DAMAGE = ("gzip_crc", "flipped_middle", "truncated", "empty", "not_gzip", "edited")
ARCHIVE_DAMAGE = ("flipped_middle", "truncated", "empty")
PROBLEM_VERBS = ("inspect", "aggregate_tables", "plot_figures", "solve_problems", "reproduce", "replay")
ARCHIVE_VERBS = ("inspect", "aggregate_tables", "reproduce", "replay")


def _verb_argv(verb: str, archive: str, problems: str, probe: str, tmp: Path) -> list[str]:
    return {
        "inspect": ["inspect", archive],
        "aggregate_tables": ["aggregate_tables", "--study", probe, "--archives", archive, "--out-dir", f"{tmp}/t"],
        "plot_figures": ["plot_figures", "--study", probe, "--archives", archive, "--out-dir", f"{tmp}/f"],
        "solve_problems": ["solve_problems", "--study", probe, "--problem-set", "warm", "--robot",
                           "data/robots/planar2r.yaml", "--solver", "dls", "--problems", problems, "--scale", "quick",
                           "--out", f"{tmp}/again.mcap"],
        "reproduce": ["reproduce", archive],
        "replay": ["replay", archive, "--problem", "0", "-o", f"{tmp}/replay.mcap"],
    }[verb]


def _base_solve(tmp: Path) -> Path:
    """A problem set and its archive (planar2r, 5 problems, dls) under ``tmp/base``; returns the study file."""
    from pipeline.cli import main

    base = tmp / "base"
    (base / "studies").mkdir(parents=True, exist_ok=True)
    probe = base / "studies" / "probe.yaml"
    probe.write_text(PROBE)
    robot = "data/robots/planar2r.yaml"
    assert main(["make_problems", "--study", str(probe), "--problem-set", "warm", "--robot", robot, "--scale", "quick",
                 "--out", str(base / "warm.csv.gz")]) == 0
    assert main(["solve_problems", "--study", str(probe), "--problem-set", "warm", "--robot", robot, "--solver", "dls",
                 "--problems", str(base / "warm.csv.gz"), "--scale", "quick", "--out", str(base / "dls.mcap")]) == 0
    return probe


def runtime_cases(tmp: Path) -> list[tuple[str, str, list[str], str]]:
    """(case, verb, argv, the path ``{file}`` stands for) of every case made at run time."""
    probe = str(_base_solve(tmp))
    out = []
    fifo = tmp / "fifo.yaml"
    os.mkfifo(fifo)
    for name, argv in NON_REGULAR.items():
        for kind, x in (("fifo", str(fifo)), ("device", "/dev/zero")):
            if kind == "device" and name not in DEVICE_VERBS:
                continue
            av = [a.replace("{x}", x).replace("{tmp}", str(tmp)).replace("{probe}", probe) for a in argv]
            out.append((f"{kind}/{name}", name, av, x))
    for what, damages, verbs in (("problems", PROBLEM_DAMAGE, PROBLEM_VERBS), ("archive", ARCHIVE_DAMAGE, ARCHIVE_VERBS)):
        for dmg in damages:
            work = tmp / "damaged" / f"{what}_{dmg}"
            shutil.copytree(tmp / "base", work)
            target = work / ("warm.csv.gz" if what == "problems" else "dls.mcap")
            target.write_bytes(_damage(dmg, target.read_bytes()))
            for verb in verbs:
                out.append((f"damaged/{what}_{dmg}", verb,
                            _verb_argv(verb, str(work / "dls.mcap"), str(work / "warm.csv.gz"), probe, work),
                            str(target)))
    return out


def file_cases() -> list[Path]:
    return [p for kind in FILE_KINDS for p in sorted((HERE / kind).glob("*.*"))]


def file_runs(path: Path, tmp: Path) -> list[tuple[str, list[str], str]]:
    """(verb, argv, ``{file}``) of one corpus file."""
    kind, stem = path.parent.name, path.stem
    rel = os.path.relpath(path, ROOT)
    if kind == "urdfs":
        name = re.sub("[^a-z0-9]+", "_", stem.lower()).strip("_")  # a robot name (pipeline/names.py)
        return [("import_urdf", ["import-urdf", rel, "--base", "base", "--tip", "tip", "--out",
                                 str(tmp / "urdfs" / stem / f"{name}.yaml")], rel)]
    if kind == "points":
        return [("robot", ["robot", rel], rel)]
    return BASE.runs_for(path, tmp)


class OpenAudit:
    """Files opened by Python while :attr:`on`, outside the allowed folders (an ``open`` audit hook)."""

    def __init__(self, allowed):
        self.allowed = [os.path.realpath(a) for a in allowed]
        self.on, self.outside = False, []
        sys.addaudithook(self._hook)

    def _hook(self, event, args):
        if not self.on or event != "open" or not isinstance(args[0], (str, bytes, os.PathLike)):
            return
        p = os.path.realpath(os.fsdecode(args[0]))
        if os.path.exists(p) and not any(p == a or p.startswith(a + os.sep) for a in self.allowed):  # (an import
            #   hook's probe of a name that is no file reads nothing)
            self.outside.append(p)

    def run(self, argv):
        self.outside = []
        self.on = True
        try:
            res = BASE.run_verb(argv)
        finally:
            self.on = False
        res["outside"] = sorted(set(self.outside))
        return res


def read_expected() -> dict[tuple[str, str], str]:
    out = {}
    for line in (HERE / "expected.tsv").read_text(encoding="utf-8").splitlines():
        if line and not line.startswith("#"):
            case, verb, msg = line.split("\t", 2)
            out[(case, verb)] = msg
    return out


def placeholders(line: str, file: str, data: str | None, tmp: str) -> str:
    """The line with ``{file}``, ``{data}`` (None: a case without a data folder of its own), ``{tmp}`` and
    ``{repo}`` (the project folder, wherever the clone lives)."""
    line = line.replace(file, "{file}")
    line = (line.replace(data, "{data}") if data else line).replace(tmp, "{tmp}").replace(str(ROOT), "{repo}")
    return re.sub(r"\b[0-9a-f]{16}\b", "{sha16}", line)  # hash prefixes follow the robot file's bytes


def main(argv=None) -> int:
    args = BASE.parser(__doc__.splitlines()[0], "rewrite expected.tsv from this run's lines").parse_args(argv)
    BASE.prepare(args)
    expected = {}
    with tempfile.TemporaryDirectory(prefix="malformed2-") as tmpdir:
        tmp = Path(tmpdir)
        code = [p for p in sys.path if p and os.path.isdir(p) and os.path.realpath(p) not in (str(ROOT), "/", "/tmp")]
        code += [sys.prefix, sys.base_prefix, HERE.parent / "malformed"]  # the interpreter, libraries, the first runner
        # installed packages' metadata (an editable install keeps ours beside the clone it was made from)
        code += [str(d._path) for d in importlib.metadata.distributions() if getattr(d, "_path", None)]
        audit = OpenAudit([HERE, ROOT / "data", ROOT / "pipeline", ROOT / "workflow", tmp, *code, "/proc", "/sys",
                           "/usr/share/zoneinfo"])
        runs = [(f"{p.parent.name}/{p.name}", verb, av, file, str(tmp / p.parent.name / p.stem))
                for p in file_cases() for verb, av, file in file_runs(p, tmp)]
        runs += [(case, verb, av, file, None) for case, verb, av, file in runtime_cases(tmp)]
        for case, verb, av, file, data in runs:
            res = audit.run(av)
            res.update(case=case, verb=verb, file=file, data=data, tmp=str(tmp))
            line = res["stderr"].rstrip("\n")
            ok = res["rc"] == 0 and res["exception"] is None  # (stderr may hold a solve's progress lines)
            expected[(case, verb)] = ACCEPTED if ok else placeholders(line, file, data, str(tmp))
            if args.json:
                print(json.dumps(res), flush=True)
            elif res["exception"] or "\n" in line or res["outside"] or (res["rc"] != 0 and not line):
                print(f"BAD {case} {verb}: rc={res['rc']} outside={res['outside']} {res['exception'] or line}")
    if args.write_expected:
        lines = ["# case\tverb\tthe one line it prints ({file}: the path the run names, {data}: its data folder, "
                 "{tmp}: the temporary folder; (accepted): exit 0)"]
        lines += [f"{case}\t{verb}\t{msg}" for (case, verb), msg in sorted(expected.items())]
        (HERE / "expected.tsv").write_text("\n".join(lines) + "\n", encoding="utf-8")
        print(f"wrote {len(expected)} lines to {HERE / 'expected.tsv'}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
