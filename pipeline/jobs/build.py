"""Build jobs that are not solves: a study's tables and figures from its archives, a new study file,
the solver listing."""

from __future__ import annotations

import json
from pathlib import Path

from pipeline.errors import UsageError
from pipeline.names import check_name


def new_study(id: str, robots: list[str], solvers: list[str] | None = None, *, count: int = 500, spread: float = 0.3,
              seed: int = 1, title: str = "", data="data", force: bool = False, protocol: str = "warm") -> str:
    """Write ``data/studies/<id>.yaml``: a warm-start problem set on the given robots and solvers (``protocol``
    "warm"), or the answer's protocol (``"answer"``: arm_benchmark's problem sets, labels and rule on these
    robots, with its recommendation tables); returns what to print."""
    from pipeline.robots import load_robot
    from pipeline.settings import ConfigError, load_study
    from pipeline.solvers import NotApplicableError, get, make_settings, names, prepare

    check_name(id, "study id")
    for r in robots:
        check_name(r, "robot id")
    out = Path(data) / "studies" / f"{id}.yaml"
    if out.exists() and not force:
        raise UsageError(f"{out}: exists (use --force to overwrite)")
    if protocol == "answer":
        return _answer_protocol(id, robots, Path(data), out, title)
    if protocol != "warm":
        raise UsageError(f"--protocol {protocol!r}: one of warm, answer")
    models = [load_robot(Path(data) / "robots" / f"{r}.yaml") for r in robots]
    wanted = solvers or names()
    for name in wanted:
        get(name)
    solvers, skipped = [], []
    for name in wanted:
        fits = []
        for m in models:
            try:
                prepare(name, m, make_settings(name))
                fits.append(m.name)
            except NotApplicableError as exc:
                skipped.append(str(exc))
        if len(fits) == len(models):
            solvers.append(name)
    if not solvers:
        raise UsageError("no solver applies to every robot given: " + "; ".join(skipped[:3]))
    lines = [
        f"# Written by `python -m pipeline new_study {id}`; edit freely (schema: workflow/schemas/study.schema.yaml).",
        "# Settings of each solver: `python -m pipeline solvers NAME` (SI units; registry defaults where not written).",
        f"study: {id}",
        f"title: {json.dumps(title or 'IK methods on ' + ', '.join(robots))}",
        "document: \"none\"",
        f"robots: [{', '.join(robots)}]",
        "problem_sets:",
        "  warm:  # goals within the joint limits, starts within `spread` rad of the goal angles",
        f"    kind: warm_start\n    seed: {seed}\n    count: {{full: {count}, quick: 20}}\n    params: {{spread: {spread}}}",
        "solvers:",
        *[f"  {n}: {{method: {n}}}" for n in solvers],
        "interpretations: []",
    ]
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    try:
        load_study(out)
    except ConfigError:
        out.unlink()
        raise
    return "\n".join([f"skipped: {why}" for why in skipped]
                     + [f"wrote {out} ({len(solvers)} solvers); build it with: snakemake --cores 2 --config studies='[{id}]'"])



def answer_study_text(data: Path, header, **fields) -> str:
    """``<data>/studies/arm_benchmark.yaml`` (the answer's protocol: problem sets, labels,
    interpretations) with ``fields`` replaced, as YAML under ``header(src)`` (comment lines; ``src`` is
    the protocol file's path). ``header`` is a function, so that no user text goes through ``str.format``."""
    import yaml

    src = data / "studies" / "arm_benchmark.yaml"
    if not src.is_file():
        raise UsageError(f"{src}: no such study file (the answer's protocol is read from it; --data names the folder)")
    doc = yaml.safe_load(src.read_text(encoding="utf-8"))
    doc.update(fields)
    return header(str(src).encode("unicode_escape").decode()) + yaml.safe_dump(doc, sort_keys=False, allow_unicode=True, width=120)


def _answer_protocol(id: str, robots: list[str], data: Path, out: Path, title: str) -> str:
    """``new_study --protocol answer``: arm_benchmark's study file with this id and these robots."""
    from pipeline.robots import load_robot
    from pipeline.settings import ConfigError, load_study

    for r in robots:
        load_robot(data / "robots" / f"{r}.yaml")
    text = answer_study_text(
        data, lambda src: f"# Written by `python -m pipeline new_study {id} --protocol answer`: {src} (problem sets, "
                          f"labels,\n# interpretations) on robots {robots}; tables and figures as arm_benchmark's "
                          "(tables_from).\n",
        study=id, robots=list(robots), tables_from="arm_benchmark",
        title=title or f"Which IK method for {', '.join(robots)}: the answer's protocol")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text, encoding="utf-8")
    try:
        load_study(out)
    except ConfigError:
        out.unlink()
        raise
    return f"wrote {out} (the answer's protocol); build it with: snakemake --cores 2 --config studies='[{id}]'"


def solver_listing(name: str | None = None, as_json: bool = False) -> str:
    """Every registered solver with its settings, defaults and units (or one, or as JSON), as text."""
    from pipeline.solvers import catalogue, get

    cat = catalogue()
    if name:
        get(name)  # one-line error for an unknown name
        cat = [c for c in cat if c["name"] == name]
    if as_json:
        return json.dumps(cat, indent=1, default=str)
    lines = []
    for c in cat:
        lines.append(f"{c['name']}  [{c['kind']}]  {c['title']}")
        if c["source"]:
            lines.append(f"    source: {c['source']}")
        for row in c["settings"]:
            unit = f" [{row['unit']}]" if row["unit"] else ""
            rng = f" ({row['range']})" if row["range"] else ""
            lines.append(f"    {row['name']} = {row['default']!r}{unit}{rng}: {row['doc']}")
        lines.append("")
    return "\n".join(lines)




def _results_relative(path, sid: str) -> str:
    """An archive's path from the results folder on (``<study>/runs/...``), so a copied build stays valid."""
    parts = Path(path).parts
    return "/".join(parts[len(parts) - 1 - parts[::-1].index(sid):]) if sid in parts else Path(path).as_posix()



def aggregate_tables(study_path, archive_paths, published, out_dir) -> str:
    """A study's tables (CSV) and their provenance from its archives."""
    from pipeline.io.archive import read_archive
    from pipeline.settings import load_study
    from pipeline.studies import build_study_tables, write_tables
    from pipeline.io.layout import SAMPLES_FILE

    study = load_study(study_path)
    archives = [read_archive(p) for p in archive_paths]
    tables = build_study_tables(study, archives, Path(published))
    write_tables(tables, Path(out_dir))
    samples = write_samples(study.id, archives, Path(out_dir) / SAMPLES_FILE)
    prov = [{"archive": _results_relative(a.path, study.id), "problems": len(a.solves), **a.metadata}
            for a in archives]
    (Path(out_dir) / "provenance.json").write_text(json.dumps(prov, indent=1))
    return f"wrote {len(tables)} tables and {samples} per-solve rows ({SAMPLES_FILE}) to {out_dir}"



def write_samples(study_id: str, archives, path: Path) -> int:
    """The per-sample file of a study: one CSV row per solve (:data:`pipeline.studies.generic.SAMPLE_COLUMNS`),
    gzip-compressed without a timestamp (the same archives give the same bytes); returns the row count."""
    import gzip

    from pipeline.studies.generic import samples_frame

    df = samples_frame(study_id, archives)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(path.name + ".partial")
    with open(partial, "wb") as raw, gzip.GzipFile(fileobj=raw, mode="wb", mtime=0, filename="") as fh:
        fh.write(df.to_csv(index=False, float_format="%.9g", lineterminator="\n").encode())
    partial.replace(path)
    return len(df)



def plot_figures(study_path, archive_paths, out_dir) -> str:
    """A study's figures from its archives."""
    from pipeline.io.archive import read_archive
    from pipeline.settings import load_study
    from pipeline.studies import get_study_module, write_figure_index

    study = load_study(study_path)
    archives = [read_archive(p) for p in archive_paths]
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figs = get_study_module(study.id, study.doc.get("tables_from")).build_figures(study, archives, out)
    write_figure_index(figs, out)
    return f"wrote {len(figs)} figures to {out_dir}"
