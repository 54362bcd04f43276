"""Numbers in a study's prose filled in from its tables at build time, never typed by hand.

A reason, caption or interpretation that states one of our results writes a placeholder where the
number goes::

    {{ table07_success | SDLS | success % (ours) | .2f }}

``table | row | column | format``: the table's name (``tables/<name>.csv``), the row (the value of the
table's first column, or ``column=value, column=value`` to match several columns), the column, and a
Python format spec (default ``.4g``; ``,.0f`` prints ``1,234``). A placeholder whose table, row or value
is missing in a build (a quick build leaves some tables out) prints ``n/a``; one that names a column
the table does not have is a study-file error, caught by ``tests/studies/test_prose_numbers.py`` on a build.

The report's prose may hold numbers about our results only through placeholders: the same check
(:func:`untabled_numbers`, run by the build's ``check_prose`` rule and by the tests) reads every reason,
caption and interpretation of a built study. A number typed in the study file's prose (outside a
placeholder) must be the document's (a published file or column), a setting or a listed document fact
(``prose_facts``): matching some cell of ours is not enough, since it need not be the cell the
sentence describes. The notes and captions the code writes are held by any table of the study, unless
the code writes them bound (placeholders for our numbers: ``TableSpec.bound``), as cerbaro2019 does.
"""

from __future__ import annotations

import math
import re

import pandas as pd

from pipeline.errors import UsageError
from pipeline.io.csvfiles import read_csv

PLACEHOLDER = re.compile(r"\{\{\s*([^|{}]+?)\s*\|\s*([^|{}]*?)\s*\|\s*([^|{}]+?)\s*(?:\|\s*([^|{}]*?)\s*)?\}\}")
MISSING_VALUE = "n/a"


class ProseError(UsageError):
    """A placeholder that names a column its table does not have (a study-file error)."""


def lookup(tables: dict[str, pd.DataFrame], table: str, row: str, column: str) -> float | str | None:
    """The cell of ``tables[table]`` at ``row`` (first-column value, or ``col=value, ...``) and ``column``;
    None when the table or the row is missing. Raises :class:`ProseError` for an unknown column."""
    frame = tables.get(table)
    if frame is None or not len(frame):
        return None
    if column not in frame.columns:
        raise ProseError(f"placeholder {{{{ {table} | {row} | {column} }}}}: table {table!r} has no column {column!r}")
    parts = [[x.strip() for x in p.partition("=")[::2]] for p in row.split(",")] if "=" in row else []
    if parts and all(col in frame.columns for col, _ in parts):  # column=value, column=value
        keep = pd.Series(True, index=frame.index)
        for col, val in parts:
            keep &= frame[col].astype(str) == val
        hit = frame[keep]
    else:
        hit = frame[frame[frame.columns[0]].astype(str) == row]
    if len(hit) != 1:
        return None
    v = hit[column].iloc[0]
    return None if v is None or (isinstance(v, float) and math.isnan(v)) else v


def fill(text: str, tables: dict[str, pd.DataFrame]) -> str:
    """``text`` with every placeholder replaced by its formatted table value (``n/a`` when missing)."""
    if not text or "{{" not in text:
        return text

    def one(m: re.Match) -> str:
        table, row, column, spec = m.group(1), m.group(2), m.group(3), m.group(4) or ".4g"
        v = lookup(tables, table, row, column)
        if v is None:
            return MISSING_VALUE
        try:
            return format(float(v), spec)
        except (TypeError, ValueError):
            return str(v)

    return PLACEHOLDER.sub(one, text)


__all__ = ["MISSING_VALUE", "PLACEHOLDER", "ProseError", "fill", "lookup"]


# ---- the check: every number in a built study's prose is held by a table, a setting or a listed fact ----

_NUMBER = re.compile(r"(?<![\w.])(\d+(?:[ \u2009\u202f,]\d{3})*(?:\.\d+)?(?:[eE][-−+]?\d+)?)(?![\w])")
# a number right after one of these names a section, equation, table, item or reading, not a value
_LABEL = re.compile(r"(?:§|eqs?\.?|Tab(?:le|ela)s?|Fig(?:ure|ura)?s?\.?|Gráficos?|Tests?|Testes?|points?|P|strateg(?:y|ies)|"
                    r"codes?|causes?|stop code|step|Etapa|row|rows|column|columns|no\.|notes?|limit|limits|reading|"
                    r"Chapter|Cap\.|Sec\.|Section|appendix|ref\.|\[)\s*$", re.I)


# a later member of a range or list of labels: §6.4-6.5, eqs 3.5–3.17, Tables 6.12/6.14, Tables 7, 8-11 and 15
_RANGE_OF_LABELS = re.compile(r"(?:§|eqs?\.?|Tab(?:le|ela)s?|Fig(?:ure|ura)?s?\.?)\s*\d[\d.]*"
                              r"(?:\s*(?:,|and|e|[-–/])\s*\d[\d.]*)*\s*(?:,|and|e|[-–/])\s*$", re.I)


def _value_set(frames, extra) -> list[float]:
    vals = []
    for f in frames:
        for col in f.columns:
            vals.extend(pd.to_numeric(f[col], errors="coerce").dropna().astype(float).tolist())
            for cell in f[col].astype(str):  # numbers inside text cells ("SDLS 0.573, Jᵀ 0.42")
                vals.extend(float(x) for x in _numbers(cell))
            vals.extend(float(x) for x in _numbers(str(col)))
    vals.extend(extra)
    return sorted({abs(v) for v in vals if math.isfinite(v)})


def _numbers(text: str) -> list[str]:
    out = []
    for m in _NUMBER.finditer(text):
        tok = re.sub(r"[ \u2009\u202f,]", "", m.group(1)).replace("−", "-")
        try:
            float(tok)
        except ValueError:
            continue
        out.append(tok)
    return out


def _held(tok: str, values: list[float]) -> bool:
    """Whether a table value rounds to the printed ``tok`` (at the precision it is printed with)."""
    import bisect

    x = float(tok)
    mant, _, exp = tok.lower().partition("e")
    decimals = len(mant.split(".")[1]) if "." in mant else 0
    half = 0.5 * 10.0 ** (int(exp or 0) - decimals)
    if "." not in mant and not exp and x >= 100:  # 3787 printed from 3787.4, or 12,345 from 12345.2
        half = 0.5
    lo = bisect.bisect_left(values, x - half * (1 + 1e-9))
    return lo < len(values) and values[lo] <= x + half * (1 + 1e-9)


def _settings_numbers(doc: dict) -> list[float]:
    """Every number of a study file outside its prose (problem sets, solvers, readings, settings)."""
    out = []

    def walk(x):
        if isinstance(x, bool):
            return
        if isinstance(x, (int, float)):
            out.append(float(x))
        elif isinstance(x, str):
            out.extend(float(t) for t in _numbers(x))
        elif isinstance(x, dict):
            for v in x.values():
                walk(v)
        elif isinstance(x, list):
            for v in x:
                walk(v)

    for k in ("problem_sets", "solvers", "readings", "study_settings", "prose_facts", "trace_policy"):
        walk(doc.get(k))
    return out


def prose_of(study, folder) -> list[tuple[str, str]]:
    """(where, text) of every piece of a built study's prose: table notes, figure captions, the claims'
    reasons and the interpretations (filled from the tables), as the report shows them."""
    import json
    from pathlib import Path

    folder = Path(folder)
    pieces, frames = [], {}
    tindex = folder / "tables" / "index.json"
    for t in json.loads(tindex.read_text()) if tindex.is_file() else []:
        frames[t["name"]] = read_csv(folder / "tables" / t["file"], keep_default_na=False)
        if "note_bound" in t:  # written with placeholders: each number of ours is the cell its placeholder names
            pieces.append((f"table {t['name']} (note, bound)", PLACEHOLDER.sub(BOUND, t["note_bound"])))
        else:
            pieces.append((f"table {t['name']} (note)", t.get("note") or ""))
        if t["name"] == "claims":
            for i, why in enumerate(frames["claims"].get("why", [])):
                pieces.append((f"claims row {i + 1} (why)", str(why)))
    findex = folder / "figures" / "index.json"
    for f in json.loads(findex.read_text()) if findex.is_file() else []:
        bound = ", bound" if f.get("bound") else ""
        pieces.append((f"figure {f['files'][0]} (caption{bound})", PLACEHOLDER.sub(BOUND, f.get("caption") or "")))
    numeric = {k: read_csv(folder / "tables" / f"{k}.csv") for k in frames}
    for i in study.doc.get("interpretations", []):
        for field in ("choice", "evidence"):
            pieces.append((f"interpretation {i['topic']!r} ({field})", fill(str(i.get(field, "")), numeric)))
    return pieces


BOUND = "‹cell›"  # what a placeholder leaves in a study file's prose when its typed numbers are checked


def study_file_prose(study) -> list[tuple[str, str]]:
    """(where, text) of the prose a study file types: every claim's reasons (of every reading) and the
    interpretations, with each placeholder replaced by :data:`BOUND` (its number is the cell it names)."""
    pieces = []
    for k, c in enumerate(study.doc.get("claims") or []):  # the claim's own fields, then each reading's
        for label, r in [(c.get("reading") or "headline", c)] + [(x["label"], x) for x in c.get("readings") or []]:
            for field in ("reason", "not_comparable", "cannot_fail", "not_reproducible"):
                if r.get(field):
                    pieces.append((f"claims/{k} {label} ({field})", PLACEHOLDER.sub(BOUND, str(r[field]))))
    for i in study.doc.get("interpretations", []):
        for field in ("choice", "evidence"):
            pieces.append((f"interpretation {i['topic']!r} ({field})", PLACEHOLDER.sub(BOUND, str(i.get(field, "")))))
    return pieces


def _unheld(pieces, values: list[float]) -> list[tuple[str, str, str]]:
    """(where, number, context) of every number of ``pieces`` that is not a label and ``values`` do not hold."""
    bad = []
    for where, text in pieces:
        for m in _NUMBER.finditer(text):
            before, after = text[max(0, m.start() - 12):m.start()], text[m.end():m.end() + 2]
            if _LABEL.search(before) or _RANGE_OF_LABELS.search(text[max(0, m.start() - 30):m.start()]) or re.match(r"[-‑]?[A-Za-zµμ°×x]", after) and not re.match(r"\s", after) \
                    or re.search(r"[A-Za-zα-ωΑ-Ωθ_]$", before) or before.endswith("(") and after.startswith(")"):
                continue  # a label (Table 7, eq. 47, item (4)) or part of a name (UR5, 6-DoF, 3x3, θ1)
            tok = _numbers(m.group(1))
            if tok and not _held(tok[0], values):
                bad.append((where, m.group(1), text[max(0, m.start() - 40):m.end() + 20]))
    return bad


def untabled_numbers(study, folder, published_dir) -> list[tuple[str, str, str]]:
    """(where, number, context) of every number in a built study's prose that is not bound to a cell.

    The study file's own prose (claims' reasons, interpretations: :func:`study_file_prose`) states our
    results only through placeholders, each bound to the cell it names; a number typed there is held
    only by the document (its published files and the tables' published columns), the study's settings
    or its ``prose_facts``, never by any cell of ours that happens to match. The table notes and figure
    captions the study's code writes (from the values it computes) are held by any table of the study,
    unless the code wrote them bound (``TableSpec.bound``, ``FigureSpec.bound``): then, like the study file's
    prose, each number of ours is a placeholder bound to its cell and every other number must be the
    document's, a setting or a listed fact."""
    from pathlib import Path

    folder = Path(folder)
    frames = [read_csv(p, keep_default_na=False) for p in sorted((folder / "tables").glob("*.csv"))
              if p.name != "claims.csv"]
    claims = folder / "tables" / "claims.csv"
    if claims.is_file():  # the values a verdict rests on, not the prose beside them (the reasons are checked)
        frames.append(read_csv(claims, keep_default_na=False)[["our values", "published values"]])
    pub = Path(published_dir) / study.id
    documents = [read_csv(p, keep_default_na=False) for p in sorted(pub.glob("*.csv"))] if pub.is_dir() else []
    settings = _settings_numbers(study.doc)
    published_columns = [f[[c for c in f.columns if "published" in str(c)]] for f in frames]
    document_values = _value_set(documents + [f for f in published_columns if len(f.columns)], settings)
    built = [(w, t) for w, t in prose_of(study, folder)
             if not w.startswith(("claims row", "interpretation "))]  # the study file's prose: checked bound
    bound = [(w, t) for w, t in built if "bound)" in w]  # notes and captions written with placeholders
    free = [(w, t) for w, t in built if "bound)" not in w]
    return (_unheld(free, _value_set(frames + documents, settings))
            + _unheld(bound + study_file_prose(study), document_values))


__all__ += ["BOUND", "prose_of", "study_file_prose", "untabled_numbers"]
