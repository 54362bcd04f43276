"""The README's set-up commands are exactly what CI runs, and the README stays one screenful a question."""

from __future__ import annotations

import re

from tests.conftest import ROOT

README = ROOT / "README.md"
CI_RUN = ROOT / ".ci" / "run"
RUN_STEP = "snakemake --cores 2"  # step 3 builds the full report (10 min); CI runs the other steps


def _commands(lines) -> list[str]:
    """Shell lines without comments or blank lines."""
    out = []
    for line in lines:
        line = re.sub(r"\s+#.*$", "", line).strip()
        if line and not line.startswith("#"):
            out.append(line)
    return out


def readme_setup_commands() -> list[str]:
    """The indented code lines of the README's "Set-up" section, in order."""
    text = README.read_text(encoding="utf-8")
    section = text[text.index("## Set-up"):]
    section = section[:section.index("\n## ", 1)]
    return _commands(m.group(1) for m in re.finditer(r"^ {4,}(\S.*)$", section, flags=re.M)
                     if not re.match(r"^ {0,3}\d+\. ", m.group(0)))


def ci_commands() -> list[str]:
    """The lines of .ci/run between its README markers."""
    text = CI_RUN.read_text()
    start = text.index("# --- README set-up commands")
    end = text.index("# --- end of README set-up commands")
    return _commands(text[start:end].splitlines()[1:])


def test_ci_runs_the_readme_setup_commands_in_order():
    readme = readme_setup_commands()
    assert RUN_STEP in readme
    assert ci_commands() == [c for c in readme if c != RUN_STEP]


def test_the_readme_has_one_test_command_and_ci_ends_with_it():
    commands = [c for c in readme_setup_commands() if "pytest" in c]
    assert commands == ["python -m pytest -q"]
    assert ci_commands()[-1] == commands[0]


def test_no_setup_line_is_long_and_only_the_optional_step_needs_root():
    readme = readme_setup_commands()
    assert all(len(c) <= 100 for c in readme)
    root_scripts = {"bash data/mariano2019/install_avr_toolchain.sh", "bash workflow/install_system_packages.sh"}
    assert not any("sudo" in c or "apt-get" in c for c in readme)
    assert root_scripts <= set(readme)


def test_readme_is_under_10_kb_and_its_links_resolve():
    text = README.read_text(encoding="utf-8")
    assert len(text.encode("utf-8")) < 10240
    for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text):
        if "://" not in target:
            assert (ROOT / target).is_file(), target
