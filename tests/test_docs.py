"""The documentation site builds offline with every warning an error, and its API pages cover the public names.

``mkdocs build --strict`` (MkDocs with mkdocstrings: griffe reads the source statically, nothing is
imported) into a temporary folder, with every proxy pointed at a closed port so that any download
(a theme, an inventory) would fail the build. The ``docs`` extra is in ``requirements.lock``; without
it the test skips, except under CI (``CI=true``), where it fails.
"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys

import pytest

from tests.conftest import ROOT

OFFLINE = "http://127.0.0.1:9"  # the discard port: nothing listens, every request fails at once


def _require_mkdocs() -> None:
    if importlib.util.find_spec("mkdocs") is None or importlib.util.find_spec("mkdocstrings_handlers") is None:
        reason = "mkdocs / mkdocstrings not installed (the docs extra of requirements.lock)"
        if os.environ.get("CI", "").lower() in ("1", "true", "yes"):
            pytest.fail(reason + ": the docs build must run in CI")
        pytest.skip(reason)


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    _require_mkdocs()
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "HTTP_PROXY": OFFLINE, "HTTPS_PROXY": OFFLINE, "http_proxy": OFFLINE,
           "https_proxy": OFFLINE, "NO_PROXY": "", "no_proxy": ""}
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "WARNING" not in proc.stderr, proc.stderr
    return out


def _ids(site, page: str) -> set[str]:
    return set(re.findall(r'id="(pipeline\.[^"]+)"', (site / page / "index.html").read_text(encoding="utf-8")))


def test_every_public_name_of_pipeline_solvers_is_in_the_reference(site):
    import pipeline.solvers

    ids = _ids(site, "api/solvers")
    assert {f"pipeline.solvers.{name}" for name in pipeline.solvers.__all__} <= ids


@pytest.mark.parametrize("package", ["robots", "kinematics", "io"])
def test_every_public_function_of_the_package_is_in_the_reference(site, package):
    from tests.test_docstrings import _modules, _plain, _public_defined

    ids = _ids(site, f"api/{package}")
    for module in _modules(f"pipeline.{package}"):
        for obj in _public_defined(module).values():
            name = _plain(obj).__name__  # an alias (pz_from_chain = pz_from_dh) is documented under its own name
            assert f"{module.__name__}.{name}" in ids or f"pipeline.{package}.{name}" in ids, (module.__name__, name)


def test_every_page_is_in_the_navigation_and_built(site):
    pages = sorted(p.relative_to(ROOT / "docs").with_suffix("") for p in (ROOT / "docs").rglob("*.md"))
    nav = (ROOT / "mkdocs.yml").read_text()
    for page in pages:
        assert f"{page.as_posix()}.md" in nav, page
        built = site / ("" if page.name == "index" else page.as_posix()) / "index.html"
        assert built.is_file(), built


def test_every_repository_path_the_docs_name_exists():
    """A file or folder named in code font (``pipeline/io/archive.py``) is there: moved code moves its docs."""
    pages = [*(ROOT / "docs").rglob("*.md"), ROOT / "README.md", *(ROOT / "benchmarks" / "results").glob("*.md")]
    missing = []
    for page in pages:
        for span in re.findall(r"`([^`\s]+)`", page.read_text(encoding="utf-8")):
            if not re.match(r"^(pipeline|tests|benchmarks|workflow|data|profiles|docs|\.ci)/", span):
                continue
            if re.search(r"[<*{|]|\b[A-Z]{2,}\b", span):  # a pattern or a placeholder (data/studies/ID.yaml)
                continue
            if not (ROOT / span).exists():
                missing.append(f"{page.relative_to(ROOT)}: {span}")
    assert not missing
