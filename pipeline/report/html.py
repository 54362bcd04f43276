"""The self-contained HTML report (images embedded as data URIs; opens offline)."""

from __future__ import annotations

import base64
from html import escape as html_escape
import datetime as _dt
import json
import platform
from pathlib import Path

import jinja2
import pandas as pd
import yaml

import pipeline
from pipeline.provenance import environment
from pipeline.settings import Study, git_commit
from pipeline.verify import INPUTS_DIGEST, REPORT_DIGEST, inputs_digest, seal_report

TEMPLATES = Path(__file__).parent / "templates"


def _img(path: Path) -> str:
    return "data:image/png;base64," + base64.b64encode(path.read_bytes()).decode()


def _fmt(x) -> str:
    """Settings values as typed (full precision: 1 + 1e-12 must not print as 1.0)."""
    return repr(x) if isinstance(x, float) else str(x)


def _table_html(path: Path) -> str:
    df = pd.read_csv(path)
    return df.to_html(index=False, na_rep="—", float_format=lambda x: f"{x:.4g}", classes="data", border=0)


def _benchmarks(folder: Path) -> list[dict]:
    rows = []
    for f in sorted(folder.glob("*.tsv")):
        df = pd.read_csv(f, sep="\t")
        rows.append({"job": f.stem, "wall_s": float(df["s"].iloc[0]), "max_rss_mb": float(df["max_rss"].iloc[0])
                     if "max_rss" in df and pd.notna(df["max_rss"].iloc[0]) else float("nan")})
    return rows


def _answer(folder: Path, tables: list[dict], figures: list[dict]) -> dict | None:
    """The at-a-glance answer of a benchmark study (``tables/answer.csv``), or None.

    Per robot: the answer sentences, its table ``robot_<name>`` and its figures (``extra.robot``);
    the heat maps (``extra.answer``) go first.
    """
    f = folder / "tables" / "answer.csv"
    if not f.is_file():
        return None
    ans = pd.read_csv(f)
    if ans.empty or "answer" not in ans:
        return None
    by_name = {t["name"]: t for t in tables}
    robots = []
    for robot, g in ans.groupby("robot", sort=False):
        table = by_name.get(f"robot_{robot}")
        if table is None:
            continue
        robots.append({"robot": robot, "sentences": list(g["answer"]), "table": table,
                       "figures": [x for x in figures if x.get("extra", {}).get("robot") == robot]})
    return {"robots": robots, "figures": [x for x in figures if x.get("extra", {}).get("answer")]}


def study_context(study: Study, results: Path) -> dict:
    folder = results / study.id
    tables = []
    tindex = folder / "tables" / "index.json"
    for t in json.loads(tindex.read_text()) if tindex.is_file() else []:
        tables.append({**t, "html": _table_html(folder / "tables" / t["file"])})
    figures = []
    findex = folder / "figures" / "index.json"
    for f in json.loads(findex.read_text()) if findex.is_file() else []:
        figures.append({**f, "src": _img(folder / "figures" / f["files"][0])})
    prov_file = folder / "tables" / "provenance.json"
    provenance = json.loads(prov_file.read_text()) if prov_file.is_file() else []
    if study.solvers:
        solvers = pd.DataFrame({k: {f: _fmt(x) for f, x in study.solvers[k].as_dict().items()}
                                for k in study.default_solvers()}).fillna("—")
        solvers_html = ("<p>Solver labels (columns): the registered method and its settings "
                        "(lengths in m, angles in rad; — = not a setting of that method).</p>"
                        + solvers.to_html(border=0, classes="data"))
        variants = study.doc.get("readings", {}).get("variants", {})
        if variants:
            rows = [{"reading": study.doc["readings"]["default"], "overrides": "(the solvers above)"}]
            rows += [{"reading": k, "overrides": ", ".join(f"{f} = {_fmt(x)}" for f, x in v.items())}
                     for k, v in variants.items()]
            solvers_html += ("<p>Readings of the open questions (each runs every solver above, as "
                             "<code>&lt;solver&gt;_&lt;reading&gt;</code>):</p>"
                             + pd.DataFrame(rows).to_html(index=False, border=0, classes="data"))
    else:
        solvers_html = ""
    if study.settings:
        solvers_html += ("<p>Study settings:</p><pre>" + html_escape(yaml.safe_dump(study.settings, sort_keys=False,
                                                                              allow_unicode=True)) + "</pre>")
    answer = _answer(folder, tables, figures)
    if answer:
        answer["id"] = study.id  # shown at the top of the report; the study's section keeps the rest
        shown = {id(x) for r in answer["robots"] for x in (r["table"], *r["figures"])} | {id(f) for f in answer["figures"]}
        tables = [t for t in tables if id(t) not in shown and t["name"] != "answer"]
        figures = [f for f in figures if id(f) not in shown]
    return {
        "answer": answer,
        "id": study.id, "title": study.doc["title"], "document": study.doc["document"],
        "notes": study.doc.get("notes", ""), "robots": study.doc["robots"],
        "problems_yaml": yaml.safe_dump(study.problem_sets, sort_keys=False) if study.generic else "",
        "solvers_html": solvers_html,
        "interpretations": study.doc["interpretations"], "tables": tables, "figures": figures,
        "provenance": provenance, "benchmarks": _benchmarks(folder / "benchmarks"),
    }


def render_report(studies: list[Study], config: dict, results: Path, out: Path) -> None:
    """Write ``out`` (normally results/report.html) from the studies' tables and figures."""
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(str(TEMPLATES)), autoescape=True,
                             undefined=jinja2.StrictUndefined)
    env_info = environment()
    contexts = [study_context(s, results) for s in studies]
    answers = [c for c in contexts if c["answer"]]
    html = env.get_template("report.html").render(
        studies=contexts, answer=answers[0]["answer"] if answers else None, config=config,
        version=pipeline.__version__, commit=git_commit(), python=platform.python_version(),
        machine=f"{platform.machine()} {platform.processor() or ''}".strip(), versions=env_info["libraries"],
        cpu=env_info["cpu"], blas=env_info["blas"], digest_names={"report": REPORT_DIGEST, "inputs": INPUTS_DIGEST},
        inputs_digest=inputs_digest(results, [s.id for s in studies]),
        built=_dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".partial")
    tmp.write_text(seal_report(html))
    tmp.replace(out)
