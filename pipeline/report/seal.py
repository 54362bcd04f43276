"""The report's seal: digests of its inputs and of its own text (written by the report, checked by ``verify``)."""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

REPORT_DIGEST = "ik-pipeline-report-sha256"
INPUTS_DIGEST = "ik-pipeline-inputs-sha256"
BUILD_MARK = "data-build-time"
META_TAG = re.compile(r'<meta name="(ik-pipeline-[a-z0-9-]+)" content="([0-9a-f]*)">')


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def inputs_digest(results: Path, study_ids) -> str:
    """sha256 over every file of the studies' ``tables/`` and ``figures/`` folders (names and bytes)."""
    h = hashlib.sha256()
    for sid in study_ids:
        for sub in ("tables", "figures"):
            folder = results / sid / sub
            for f in sorted(folder.rglob("*")) if folder.is_dir() else []:
                if f.is_file():
                    h.update(f"{sid}/{sub}/{f.relative_to(folder).as_posix()}\0{_sha(f)}\n".encode())
    return h.hexdigest()


def report_digest(html: str) -> str:
    """sha256 of the report's text without its build-time line and its own digest line."""
    keep = [ln for ln in html.splitlines() if BUILD_MARK not in ln and REPORT_DIGEST not in ln]
    return hashlib.sha256("\n".join(keep).encode()).hexdigest()


def seal_report(html: str) -> str:
    """Write the report's own digest into its (empty) ``REPORT_DIGEST`` meta line."""
    digest = report_digest(html)
    return html.replace(f'<meta name="{REPORT_DIGEST}" content="">', f'<meta name="{REPORT_DIGEST}" content="{digest}">')
