"""Per-study aggregation: each study module turns archives into the document's tables and figures.

A study module or package ``pipeline.studies.<id>`` provides (a study written only in YAML has no
module and gets the generic tables and figures of :mod:`pipeline.studies.generic`)::

    build_tables(study, archives, published_dir) -> list[TableSpec]
    build_figures(study, archives, out_dir) -> list[FigureSpec]

A study package may also hold ``cli.py`` with ``register_cli(subparsers)`` adding its own verbs to
``python -m pipeline`` (keep its imports light: heavy ones go inside the command functions); the
command line finds them on disk (:mod:`pipeline.cli`), this package never imports them.

Tables and figures are computed from archives only (the archive is the source of truth) plus the
published values under ``data/published/<id>/``. Figure modules import matplotlib through
:mod:`pipeline.report.plotting` (a departure from "matplotlib only in pipeline/report": a study's
figures live beside its tables so that one study is one folder of code).
"""

from __future__ import annotations

import importlib
import importlib.util
import json
from pathlib import Path



from pipeline.studies.specs import FigureSpec, TableSpec  # noqa: E402,F401  (re-exported)


def get_study_module(study_id: str, tables_from: str | None = None):
    """The study's own table/figure module, or :mod:`pipeline.studies.generic` for a YAML-only study;
    ``tables_from`` (the study file's field) names another study's module instead."""
    study_id = tables_from or study_id
    name = f"pipeline.studies.{study_id}"
    if study_id == "generic" or importlib.util.find_spec(name) is None:
        return importlib.import_module("pipeline.studies.generic")
    return importlib.import_module(name)


def build_study_tables(study, archives, published_dir: Path) -> list[TableSpec]:
    """The study module's tables, opened by its claims and not-reproduced tables (:mod:`pipeline.studies.claims`)."""
    from pipeline.studies.claims import with_claims
    from pipeline.studies.common import load_table

    tables = get_study_module(study.id, study.doc.get("tables_from")).build_tables(study, archives, published_dir)
    load = load_table(archives)
    return with_claims(study, tables + ([load] if load is not None else []))


def write_tables(tables: list[TableSpec], out_dir: Path) -> None:
    """Each table as ``<name>.csv`` plus ``index.json`` (order, titles, notes)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    from pipeline.studies.prose import fill

    index = []
    frames = {t.name: t.frame for t in tables}
    for t in tables:
        t.frame.to_csv(out_dir / f"{t.name}.csv", index=False, float_format="%.6g")
        entry = {"name": t.name, "title": t.title, "note": fill(t.note, frames), "file": f"{t.name}.csv"}
        index.append({**entry, "note_bound": t.note} if t.bound else entry)  # the template the prose check reads
    (out_dir / "index.json").write_text(json.dumps(index, indent=1, ensure_ascii=False))


def write_figure_index(figs: list[FigureSpec], out_dir: Path) -> None:
    index = [{"files": f.files, "title": f.title, "caption": f.caption, **({"extra": f.extra} if f.extra else {}),
              **({"bound": True} if f.bound else {})} for f in figs]
    (out_dir / "index.json").write_text(json.dumps(index, indent=1, ensure_ascii=False))
