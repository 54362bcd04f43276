"""The workflow only declares (issue 41, item 5): fixed includes, no library import in the Snakemake process
beyond the config validation (which runs in a process of its own, workflow/scripts/check_inputs.py), no
rule made in a loop, no global mutated by a rule file, every report caption wired,
and `snakemake --lint` flags nothing but the conda lint (see the Snakefile)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
RULES = ROOT / "workflow" / "rules"
RULE_FILES = sorted(RULES.rglob("*.smk"))
WORKFLOW_FILES = [ROOT / "Snakefile", *RULE_FILES]

# The lint every rule gets: the rules run in the hash-pinned venv of requirements.lock (see the Snakefile).
ACCEPTED_LINTS = {"Specify a conda environment or container for each rule."}


def _code(path: Path) -> list[tuple[int, str]]:
    """(line number, line) of a workflow file without comments and blank lines (no '#' sits inside a string
    in these files)."""
    out = []
    for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        line = line.split("#", 1)[0].rstrip()
        if line.strip():
            out.append((i, line))
    return out


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


@pytest.mark.parametrize("path", WORKFLOW_FILES, ids=_rel)
def test_no_library_import(path):
    """Only workflow/scripts/check_inputs.py (a process of its own) imports the library."""
    for i, line in _code(path):
        assert not re.match(r"\s*(from|import)\s+pipeline\b", line), f"{_rel(path)}:{i}: {line.strip()}"
        assert "importlib" not in line and "__import__" not in line, f"{_rel(path)}:{i}: {line.strip()}"


def test_includes_are_fixed_and_cover_every_rule_file():
    includes = []
    for path in WORKFLOW_FILES:
        for i, line in _code(path):
            if re.match(r"\s*include\s*:", line):
                m = re.fullmatch(r'include\s*:\s*"([^"{}]+)"', line)  # a literal path at top level, no f-string
                assert m, f"{_rel(path)}:{i}: {line.strip()}"
                includes.append((path.parent / m.group(1)).resolve())
            assert ".glob(" not in line, f"{_rel(path)}:{i}: {line.strip()}"
    assert sorted(includes) == sorted(p.resolve() for p in RULE_FILES)
    assert len(set(includes)) == len(includes)


@pytest.mark.parametrize("path", WORKFLOW_FILES, ids=_rel)
def test_no_rule_is_made_in_a_loop(path):
    loops, made = [], 0  # indentation of the enclosing `for`/`while` blocks
    for i, line in _code(path):
        indent = len(line) - len(line.lstrip())
        stripped = line.strip()
        if stripped[0] in ")]}":  # the end of a bracketed statement
            continue
        loops = [d for d in loops if d < indent]
        if re.match(r"(for|while)\s", stripped):
            loops.append(indent)
        elif re.match(r"(rule|checkpoint)\b.*:$", stripped) and loops:
            made += 1
        assert "workflow.rule(" not in stripped, f"{_rel(path)}:{i}: {stripped}"
    assert made == 0, _rel(path)


def test_no_rule_file_mutates_a_global():
    """A name is assigned at top level in one file only, and nothing changes a global's contents
    (subscript or augmented assignment, a mutating method, `global`)."""
    defined: dict[str, str] = {}
    for path in WORKFLOW_FILES:
        for i, line in _code(path):
            where = f"{_rel(path)}:{i}: {line.strip()}"
            m = re.match(r"([A-Za-z_]\w*)\s*=[^=]", line)  # top level: no indentation
            if m:
                assert defined.setdefault(m.group(1), _rel(path)) == _rel(path), where
            assert not re.match(r"\s*global\b", line), where
            assert not re.match(r"\s*[A-Za-z_][\w.]*\s*\[[^\]]*\]\s*=[^=]", line), where
            assert not re.match(r"\s*[A-Za-z_][\w.]*\s*(\+|-|\*|/|\||&)=", line), where
            assert not re.search(r"\b(config|[A-Z][A-Z0-9_]+)\.(append|extend|update|insert|pop|setdefault|"
                                 r"clear|remove)\(", line), where


def test_every_caption_is_wired():
    """Every file of workflow/report/ but the README's figure is the caption of a `report(...)` output."""
    wired = set()
    for path in RULE_FILES:
        for m in re.finditer(r'caption\s*=\s*"([^"]+)"', path.read_text(encoding="utf-8")):
            caption = (path.parent / m.group(1)).resolve()
            assert caption.is_file(), f"{_rel(path)}: {m.group(1)}"
            wired.add(caption)
    captions = {p.resolve() for p in (ROOT / "workflow" / "report").iterdir() if p.suffix == ".rst"}
    assert captions == wired


def _snakemake(*args, python_flags=()):
    return subprocess.run([sys.executable, *python_flags, "-m", "snakemake", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=600)


def test_lint_flags_nothing_but_the_conda_lint():
    proc = _snakemake("--lint")
    titles = set(re.findall(r"^    \* (.+?):?$", proc.stdout + proc.stderr, flags=re.M))
    assert proc.returncode == 0 or titles, proc.stderr[-2000:]  # a failure is lints, not an error
    assert titles <= ACCEPTED_LINTS, titles - ACCEPTED_LINTS


def test_parsing_the_workflow_imports_neither_the_library_nor_numba(tmp_path):
    """`python -X importtime` lists every module the Snakemake process imports (the validation's own
    process is not listed)."""
    proc = _snakemake("-n", "--nolock", "--cores", "1", "--config", "studies=[cerbaro2019]", "scale=quick",
                      f"results_dir={tmp_path}", python_flags=("-X", "importtime"))
    assert proc.returncode == 0, proc.stderr[-2000:]
    modules = {ln.rsplit("|", 1)[-1].strip() for ln in proc.stderr.splitlines() if ln.startswith("import time:")}
    assert "snakemake" in modules and "rule rerun_failures:" in proc.stdout
    heavy = sorted(m for m in modules if m.split(".")[0] in ("pipeline", "numba", "scipy", "llvmlite"))
    assert not heavy, heavy
