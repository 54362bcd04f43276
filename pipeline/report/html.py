"""The self-contained HTML report (images embedded as data URIs; opens offline).

Navigation: a table of contents beside the text down to every table and figure, and a stable anchor
on each (``tab-<study>-<table name>``, ``fig-<study>-<figure file stem>``). Figures are embedded as
SVG, or as the 2x PNG where the SVG is larger than :data:`SVG_MAX_BYTES`; tables wider than the text
column (:data:`TABLE_BUDGET_PX`) are transposed or split into column groups, so that nothing needs a
horizontal scroll at a 1 400 px wide window.
"""

from __future__ import annotations

import base64
from html import escape as html_escape
import math
import re
import struct
from urllib.parse import quote
import datetime as _dt
import json
import platform
from pathlib import Path

import jinja2
import pandas as pd
import yaml

import pipeline
from pipeline.io.csvfiles import read_csv
from pipeline.io.layout import SAMPLES_FILE
from pipeline.provenance import environment
from pipeline.settings import Study, git_commit
from pipeline.report.seal import INPUTS_DIGEST, REPORT_DIGEST, inputs_digest, seal_report
from pipeline.studies.claims import count_line
from pipeline.studies.prose import fill

TEMPLATES = Path(__file__).parent / "templates"


SVG_MAX_BYTES = 1_000_000  # larger SVGs (dense scatter plots) are embedded as their 2x PNG instead
TABLE_BUDGET_PX = 980  # width a table may take in the text column at a 1 400 px window (checked in a browser)
_SVG_SAFE = " !$'()*+,-./:;=?@_~[]{}|^`"  # left as is in an SVG data URI; the rest is %-encoded


def _img(path: Path) -> str:
    return "data:image/png;base64," + base64.b64encode(path.read_bytes()).decode()


def _png_css_width(path: Path) -> int | None:
    """Display width [CSS px] of a PNG: its pixel width scaled from its dpi (pHYs) to the figures' 110 dpi."""
    data = path.read_bytes()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    width = struct.unpack(">I", data[16:20])[0]
    k = data.find(b"pHYs", 8, 4096)
    if k < 0:
        return width
    ppm = struct.unpack(">I", data[k + 4:k + 8])[0]
    dpi = ppm * 0.0254 if data[k + 12] == 1 else 110.0
    return round(width * 110.0 / dpi) if dpi > 0 else width


def figure_image(folder: Path, files: list[str]) -> dict:
    """``src`` (data URI), ``kind`` (svg/png) and display ``width`` of a figure: SVG when small enough."""
    svg = next((folder / f for f in files if f.endswith(".svg")), None)
    if svg is not None and svg.is_file() and svg.stat().st_size <= SVG_MAX_BYTES:
        text = svg.read_text(encoding="utf-8")
        m = re.search(r'<svg[^>]*\swidth="([0-9.]+)pt"', text)
        return {"src": "data:image/svg+xml;charset=utf-8," + quote(text, safe=_SVG_SAFE), "kind": "svg",
                "width": round(float(m.group(1)) * 110.0 / 72.0) if m else None}
    png = folder / next(f for f in files if f.endswith(".png"))
    return {"src": _img(png), "kind": "png", "width": _png_css_width(png)}


def _fmt(x) -> str:
    """Settings values as typed (full precision: 1 + 1e-12 must not print as 1.0)."""
    return repr(x) if isinstance(x, float) else str(x)


def _cell(x) -> str:
    """A table cell: 4 significant digits, but no e-notation from 1 000 on (times in µs: 12,345)."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "—"
    if isinstance(x, float):
        return f"{x:,.0f}" if abs(x) >= 1000 else f"{x:.4g}"
    return str(x)


def _text_px(text: str, bold: bool = False) -> float:
    """Rough rendered width [px] of ``text`` in the tables' font (0.85 em of 16 px)."""
    return len(text) * (8.0 if bold else 7.4)


def _column_px(header: str, cells: list[str]) -> float:
    """Width a column needs: its longest unbreakable word (header or cell), or a short cell in full."""
    words = [w for c in [header, *cells] for w in c.split()] or [""]
    longest_word = max(_text_px(w, bold=w in header.split()) for w in words)
    short_cells = max((_text_px(c) for c in cells if len(c) <= 14), default=0.0)
    return max(longest_word, short_cells) + 14.0  # padding and borders


def _table_layout(df: pd.DataFrame, budget: float = TABLE_BUDGET_PX) -> list[pd.DataFrame]:
    """The table as one frame if it fits ``budget`` px; else transposed (few rows) or split into column
    groups, each repeating the leading label columns."""
    cells = df.map(_cell) if hasattr(df, "map") else df.applymap(_cell)
    cells.columns = [str(c) for c in df.columns]
    widths = [_column_px(c, list(cells[c])) for c in cells.columns]
    if sum(widths) <= budget or len(cells.columns) <= 2:
        return [cells]
    if len(cells) <= 12 and not cells.iloc[:, 0].duplicated().any():
        t = cells.set_index(cells.columns[0]).T.reset_index()
        t.columns = [str(cells.columns[0]) + " →"] + list(t.columns[1:])
        t_widths = [_column_px(c, list(t[c])) for c in t.columns]
        if sum(t_widths) <= budget:
            return [t]
    # leading label columns (text, not numbers) repeated in every group
    keys = []
    for c, w in zip(cells.columns, widths):
        numeric = pd.to_numeric(df[c], errors="coerce").notna().any() if df[c].dtype == object else df[c].dtype.kind in "biuf"
        if numeric or len(keys) >= 2 or sum(widths[:len(keys) + 1]) > 0.4 * budget:
            break
        keys.append(c)
    keys = keys or [cells.columns[0]]
    key_px = sum(widths[: len(keys)])
    groups, cur, cur_px = [], [], key_px
    for c, w in zip(cells.columns[len(keys):], widths[len(keys):]):
        if cur and cur_px + w > budget:
            groups.append(cur)
            cur, cur_px = [], key_px
        cur.append(c)
        cur_px += w
    groups.append(cur)
    return [cells[keys + g] for g in groups]


def _table_html(path: Path, text: bool = False) -> str:
    """A table CSV as HTML (``text``: every column left-aligned, for tables of prose)."""
    parts = _table_layout(read_csv(path))
    html = [p.to_html(index=False, classes="data text" if text else "data", border=0, escape=True) for p in parts]
    if len(parts) == 1:
        return html[0]
    return "".join(f'<p class="part">columns, part {k + 1} of {len(parts)}</p>{h}' for k, h in enumerate(html))


def _benchmarks(folder: Path) -> list[dict]:
    rows = []
    for f in sorted(folder.glob("*.tsv")):
        df = read_csv(f, sep="\t")
        rows.append({"job": f.stem, "wall_s": float(df["s"].iloc[0]), "max_rss_mb": float(df["max_rss"].iloc[0])
                     if "max_rss" in df and pd.notna(df["max_rss"].iloc[0]) else float("nan")})
    return rows


def archive_host(record: dict) -> str:
    """The machine an archive's solves ran on (``environment.host`` of its metadata; "" if not recorded)."""
    env = record.get("environment")
    return str(env.get("host") or env.get("hostname") or "") if isinstance(env, dict) else ""


def _answer(folder: Path, tables: list[dict], figures: list[dict]) -> dict | None:
    """The at-a-glance answer of a benchmark study (``tables/answer.csv``), or None.

    Per robot: the recommendation sentences and calls to copy, its key table ``key_<name>`` (shown),
    its full table ``robot_<name>`` (folded) and its figures (``extra.robot``); the heat maps
    (``extra.answer``) go first.
    """
    f = folder / "tables" / "answer.csv"
    if not f.is_file():
        return None
    ans = read_csv(f, keep_default_na=False)
    if ans.empty or "answer" not in ans:
        return None
    by_name = {t["name"]: t for t in tables}
    robots = []
    for robot, g in ans.groupby("robot", sort=False):
        table = by_name.get(f"robot_{robot}")
        if table is None:
            continue
        calls: dict[str, list[str]] = {}  # one call per distinct call, with the start sets it serves
        if "call" in g:
            for pset, call in zip(g["problem set"], g["call"]):
                if call:
                    calls.setdefault(call, []).append(str(pset))
        calls = [(" and ".join(sets), call) for call, sets in calls.items()]
        robots.append({"robot": robot, "sentences": list(g["answer"]), "table": table, "calls": calls,
                       "key": by_name.get(f"key_{robot}"), "race": by_name.get(f"race_{robot}"),
                       "figures": [x for x in figures if x.get("extra", {}).get("robot") == robot]})
    return {"robots": robots, "plain": by_name.get("answer_plain"),
            "figures": [x for x in figures if x.get("extra", {}).get("answer")]}


HEAD_TABLES = ("claims", "not_reproduced")  # pipeline.studies.claims: shown first in a study's section


def _interpretations(study: Study, folder: Path, tables: list[dict]) -> list[dict]:
    """The study's interpretations with their numbers filled in from the build's tables (prose.fill)."""
    frames = {t["name"]: read_csv(folder / t["file"]) for t in tables if (folder / t["file"]).is_file()}
    return [{k: fill(v, frames) if isinstance(v, str) else v for k, v in i.items()}
            for i in study.doc["interpretations"]]


def study_context(study: Study, results: Path) -> dict:
    folder = results / study.id
    tables = []
    tindex = folder / "tables" / "index.json"
    for t in json.loads(tindex.read_text()) if tindex.is_file() else []:
        tables.append({**t, "html": _table_html(folder / "tables" / t["file"], text=t["name"] in HEAD_TABLES),
                       "anchor": f"tab-{study.id}-{t['name']}"})
    figures = []
    findex = folder / "figures" / "index.json"
    for f in json.loads(findex.read_text()) if findex.is_file() else []:
        figures.append({**f, **figure_image(folder / "figures", f["files"]),
                        "anchor": f"fig-{study.id}-{Path(f['files'][0]).stem}"})
    prov_file = folder / "tables" / "provenance.json"
    provenance = [{**p, "host": archive_host(p)} for p in json.loads(prov_file.read_text())] if prov_file.is_file() else []
    if study.solvers:
        solvers = pd.DataFrame({k: {f: _fmt(x) for f, x in study.solvers[k].as_dict().items()}
                                for k in study.default_solvers()}).fillna("—")
        solvers = solvers.rename_axis("setting").reset_index()
        solvers_html = ("<p>Solver labels (columns): the registered method and its settings "
                        "(lengths in m, angles in rad; — = not a setting of that method).</p>"
                        + "".join(x.to_html(index=False, border=0, classes="data") for x in _table_layout(solvers)))
        variants = study.doc.get("readings", {}).get("variants", {})
        if variants:
            rows = [{"reading": study.doc["readings"]["default"], "overrides": "(the solvers above)"}]
            rows += [{"reading": k, "overrides": ", ".join(f"{f} = {_fmt(x)}" for f, x in v.items())}
                     for k, v in variants.items()]
            solvers_html += ("<p>Readings of the open questions (each runs every solver above, as "
                             "<code>&lt;solver&gt;_&lt;reading&gt;</code>):</p>"
                             + "".join(x.to_html(index=False, border=0, classes="data")
                                       for x in _table_layout(pd.DataFrame(rows))))
    else:
        solvers_html = ""
    if study.settings:
        solvers_html += ("<p>Study settings:</p><pre>" + html_escape(yaml.safe_dump(study.settings, sort_keys=False,
                                                                              allow_unicode=True)) + "</pre>")
    benchmarks = _benchmarks(folder / "benchmarks")
    samples = f"{study.id}/tables/{SAMPLES_FILE}" if (folder / "tables" / SAMPLES_FILE).is_file() else ""
    answer = _answer(folder, tables, figures)
    if answer:
        answer["id"] = study.id  # shown at the top of the report; the study's section keeps the rest
        answer["samples"] = samples
        shown = ({id(x) for r in answer["robots"] for x in (r["table"], r["key"], r["race"], *r["figures"]) if x is not None}
                 | {id(f) for f in answer["figures"]} | ({id(answer["plain"])} if answer["plain"] else set()))
        tables = [t for t in tables if id(t) not in shown and t["name"] != "answer"]
        figures = [f for f in figures if id(f) not in shown]
    claims_csv = folder / "tables" / "claims.csv"
    claim_count = ""
    if claims_csv.is_file():  # the one-line count the section opens with: the readings that count
        c = read_csv(claims_csv, keep_default_na=False)
        claim_count = count_line(list(c.loc[c["counts"] == "yes", "verdict (ours)"]) if "counts" in c else
                                 list(c["verdict (ours)"]))
    head = [t for t in tables if t["name"] in HEAD_TABLES]  # claims and not-reproduced: top of the section
    tables = [t for t in tables if t["name"] not in HEAD_TABLES]
    return {
        "answer": answer, "head_tables": head, "claim_count": claim_count,
        "id": study.id, "title": study.doc["title"], "document": study.doc["document"],
        "notes": study.doc.get("notes", ""), "robots": study.doc["robots"],
        "problems_yaml": yaml.safe_dump(study.problem_sets, sort_keys=False) if study.generic else "",
        "solvers_html": solvers_html,
        "interpretations": _interpretations(study, folder / "tables", tables), "tables": tables, "figures": figures,
        "provenance": provenance, "benchmarks": benchmarks,
        "samples": samples,
        # machines the solves ran on (a cluster run): timings of different machines are not comparable
        "hosts": sorted({p["host"] for p in provenance} - {""}),
    }


def performance_rows(path: Path) -> dict | None:
    """The speed table of the report from ``benchmarks/bench_fast.py --json`` output (None if absent).

    Returns ``{"source", "machine", "loads", "rows": [{"what", "unit", "values" (one per run), "target"}]}``.
    """
    if not path.is_file():
        return None
    doc = json.loads(path.read_text())
    runs = doc.get("runs", [])

    def get(run, *keys):
        for k in keys:
            if not isinstance(run, dict) or k not in run:
                return None
            run = run[k]
        return run

    spec = [
        ("LWR DLS, public call, median (methods in turn by blocks of 100 problems)", "us", ("public", "dls", "call_us", "p50"), ""),
        ("LWR DLS, kernel alone, median", "us", ("public", "dls", "solve_us", "p50"), ""),
        ("Robotics Toolbox ik_LM (C++), one search, median", "us", ("public", "rtb_ik_lm", "solve_us", "p50"), ""),
        ("our DLS public call / rtb ik_LM", "ratio", ("public", "ratio_dls_call_to_rtb_lm"), "<= 0.5"),
        ("TRAC-IK, median", "us", ("public", "trac_ik", "solve_us", "p50"), ""),
        ("DLS iteration in the hot loop, median over problems of the fastest of 5 passes", "ns",
         ("hotloop", "dls", "ns_per_iteration", "p50"), "<= 600"),
        ("DLS iteration in the hot loop, median over every pass", "ns",
         ("hotloop", "dls", "ns_per_iteration", "p50_all_passes"), ""),
        ("DLS iteration with the IK-block clock reads (time_ik_block: true, as cerbaro2019)", "ns",
         ("hotloop", "dls_timed", "ns_per_iteration", "p50"), ""),
        ("DLS iteration, flop floor", "ns", ("hotloop", "dls", "floor_ns"), ""),
        ("pseudoinverse iteration, median", "ns", ("hotloop", "pseudoinverse", "ns_per_iteration", "p50"), ""),
        ("Jacobian-transpose iteration, median", "ns", ("hotloop", "jacobian_transpose", "ns_per_iteration", "p50"), ""),
        ("batch DLS (cerbaro2019 settings), 1 thread", "solves/s", ("batch", "threads_1"), ""),
        ("batch DLS (cerbaro2019 settings), 2 threads", "solves/s", ("batch", "threads_2"), ">= 50 000"),
        ("UR5 analytic, all solutions, public call, median over poses of the fastest of 10 passes (alone)", "us",
         ("analytic", "ur5/analytic_ur", "call_alone_us", "p50"), "<= 10"),
        ("UR5 analytic, public call, median over every pass (alone)", "us",
         ("analytic", "ur5/analytic_ur", "call_alone_us", "p50_all_passes"), ""),
        ("UR5 analytic, public call, median (interleaved with ur_analytic_ik)", "us",
         ("analytic", "ur5/analytic_ur", "call_us", "p50"), ""),
        ("ur_analytic_ik (C++), median", "us", ("analytic", "ur5/ur_analytic_ik", "solve_us", "p50"), ""),
        ("UR5 analytic batch, 2 threads", "poses/s", ("analytic", "ur5/batch_threads_2"), ">= 400 000"),
        ("PUMA 560 analytic, all solutions, public call, median over poses of the fastest of 10 passes (alone)", "us",
         ("analytic", "puma560/analytic_puma", "call_alone_us", "p50"), "<= 20"),
    ]
    rows = []
    for what, unit, keys, target in spec:
        vals = [get(r, *keys) for r in runs]
        if any(v is not None for v in vals):
            fmt = (lambda v: "—" if v is None else (f"{v:,.0f}" if abs(v) >= 1000 else f"{v:.3g}"))
            rows.append({"what": what, "unit": unit, "values": [fmt(v) for v in vals], "target": target or "—"})
    return {"source": str(path), "machine": doc.get("machine", {}), "loads": [r.get("load", "?") for r in runs],
            "rows": rows}


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
        performance=performance_rows(Path(config.get("data_dir", "data")) / "performance" / "bench_fast.json"),
        built=_dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".partial")
    tmp.write_text(seal_report(html))
    tmp.replace(out)
