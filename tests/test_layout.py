"""The test tree mirrors the package (issue 41, item 4): a test of ``pipeline/<a>/<b>/`` lives in
``tests/<a>/<b>/``; the tests of the workflow files (Snakefile, workflow/) in ``tests/workflow/``; the
front door (README, docs, docstrings, layers) and the top-level modules at the top."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TESTS = ROOT / "tests"
# folders of inputs the tests read, not tests
DATA_FOLDERS = {"data", "malformed", "malformed2", "__pycache__"}


def _test_folders():
    return sorted(p.parent for p in TESTS.rglob("test_*.py")
                  if not DATA_FOLDERS & set(p.relative_to(TESTS).parts[:-1]))


def test_every_test_folder_mirrors_a_package_folder():
    for folder in _test_folders():
        rel = folder.relative_to(TESTS)
        if rel.parts[:1] == ("workflow",):
            assert (ROOT / "workflow").is_dir()
            continue
        assert rel == Path(".") or (ROOT / "pipeline" / rel / "__init__.py").is_file(), \
            f"tests/{rel.as_posix()} mirrors no folder of pipeline/"


def test_test_file_names_are_unique():
    """pytest imports test files by their base name (no ``__init__.py`` in tests/), so two files of
    one name in different folders would collide."""
    names = [p.name for p in TESTS.rglob("test_*.py") if not DATA_FOLDERS & set(p.relative_to(TESTS).parts)]
    assert len(names) == len(set(names)), sorted(n for n in names if names.count(n) > 1)


def test_the_solver_tests_follow_the_solver_layers():
    """Each layer of pipeline/solvers/ has its folder of tests."""
    for layer in ("kernels", "core", "iterative", "closed_form", "peers"):
        assert list((TESTS / "solvers" / layer).glob("test_*.py")), f"tests/solvers/{layer}/ holds no test"
