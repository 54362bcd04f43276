"""A study's headline claims checked on its own tables, and what it does not reproduce.

A study file may list the document's headline conclusions under ``claims`` and the tables, figures
and tests it leaves out under ``not_reproduced`` (schema: workflow/schemas/study.schema.yaml). Each
claim names a table the study builds from its archives, the column that holds the rows' names
(``key``), the column of our values (``ours``), optionally the column of the published values
(``published``), and one check:

``max: ROW`` / ``min: ROW``       ROW has the largest / smallest value
``order: [ROW, ...]``             the rows' values increase in this order
``less: [ROW_A, ROW_B]``          ROW_A's value < ROW_B's
``ratio_at_least: [A, B, X]``     A's value / B's value >= X
``within: {row: ROW, rel: R}``    ours within a relative R of the published value of ROW
``abs_at_most: X``                every row's |value| <= X
``column_less: {row: ROW, than: COL, than_published: PCOL}``
                                  ROW's value < its value in column COL (the published check
                                  compares ``published`` with PCOL): two quantities of one row

An optional ``rows: {column: value, ...}`` keeps only the matching rows first (e.g. the ``mean``
rows of a table with a ``statistic`` column).

The verdict is computed, never typed: *holds* when the check passes on our values, *differs* when
it fails, *not reproduced* when the table, a row or a value is missing (e.g. a quick build without
that table). The same check on the published column (when given) says whether the claim, as
encoded, is what the document's own numbers say (``published`` verdict; a test requires *holds*
there, so a miscoded claim cannot pass unnoticed). The one-line ``reason`` the study file gives is
shown beside any verdict but *holds*.
"""

from __future__ import annotations

import math

import pandas as pd

from pipeline.studies.specs import TableSpec

CHECKS = ("max", "min", "order", "less", "ratio_at_least", "within", "abs_at_most", "column_less")
HOLDS, DIFFERS, MISSING = "holds", "differs", "not reproduced"


class ClaimError(ValueError):
    """A claim that names a check the module does not know (caught by the schema first)."""


def _values(frame: pd.DataFrame, key: str, col: str, rows: list[str]) -> dict[str, float] | None:
    """{row: value} of ``col`` for ``rows`` (None when the column, a row or a value is missing)."""
    if frame is None or key not in frame.columns or col not in frame.columns:
        return None
    out = {}
    for r in rows:
        hit = frame[frame[key].astype(str) == str(r)]
        if len(hit) != 1:
            return None
        v = pd.to_numeric(hit[col], errors="coerce").iloc[0]
        if v is None or not math.isfinite(float(v)):
            return None
        out[r] = float(v)
    return out


def _all_rows(frame: pd.DataFrame, key: str, col: str) -> dict[str, float] | None:
    if frame is None or key not in frame.columns or col not in frame.columns:
        return None
    vals = pd.to_numeric(frame[col], errors="coerce")
    out = {str(k): float(v) for k, v in zip(frame[key], vals) if v is not None and math.isfinite(float(v))}
    return out or None


def evaluate(check: dict, frame: pd.DataFrame | None, key: str, col: str, published_col: str | None = None,
             *, on_published: bool = False) -> tuple[str, str]:
    """(verdict, the values the verdict rests on) of one check on column ``col`` of ``frame``
    (``on_published``: ``col`` is the published column, so ``column_less`` compares with ``than_published``)."""
    (kind, arg), = check.items()
    if kind in ("max", "min"):
        vals = _all_rows(frame, key, col)
        if vals is None or str(arg) not in vals:
            return MISSING, ""
        pick = (max if kind == "max" else min)(vals, key=vals.get)
        order = sorted(vals, key=vals.get, reverse=kind == "max")
        return (HOLDS if pick == str(arg) else DIFFERS), ", ".join(f"{r} {vals[r]:.4g}" for r in order)
    if kind == "order":
        vals = _values(frame, key, col, [str(a) for a in arg])
        if vals is None:
            return MISSING, ""
        v = [vals[str(a)] for a in arg]
        return (HOLDS if all(x < y for x, y in zip(v, v[1:])) else DIFFERS), " < ".join(f"{a} {vals[str(a)]:.4g}" for a in arg)
    if kind == "less":
        a, b = (str(x) for x in arg)
        vals = _values(frame, key, col, [a, b])
        if vals is None:
            return MISSING, ""
        return (HOLDS if vals[a] < vals[b] else DIFFERS), f"{a} {vals[a]:.4g}, {b} {vals[b]:.4g}"
    if kind == "ratio_at_least":
        a, b, x = str(arg[0]), str(arg[1]), float(arg[2])
        vals = _values(frame, key, col, [a, b])
        if vals is None or vals[b] == 0:
            return MISSING, ""
        r = vals[a] / vals[b]
        return (HOLDS if r >= x else DIFFERS), f"{a} / {b} = {r:.4g} (claim: ≥ {x:g})"
    if kind == "within":
        row, rel = str(arg["row"]), float(arg["rel"])
        ours = _values(frame, key, col, [row])
        pub = _values(frame, key, published_col, [row]) if published_col else None
        if ours is None or pub is None:
            return MISSING, ""
        o, p = ours[row], pub[row]
        dev = abs(o - p) / abs(p) if p else math.inf
        return (HOLDS if dev <= rel else DIFFERS), f"{row}: {o:.4g} against {p:.4g} ({100 * dev:.3g} % off; claim: ≤ {100 * rel:g} %)"
    if kind == "abs_at_most":
        vals = _all_rows(frame, key, col)
        if vals is None:
            return MISSING, ""
        worst = max(vals, key=lambda r: abs(vals[r]))
        return ((HOLDS if abs(vals[worst]) <= float(arg) else DIFFERS),
                f"largest |value|: {worst} {vals[worst]:.4g} (claim: ≤ {float(arg):g})")
    if kind == "column_less":
        row = str(arg["row"])
        other = arg["than_published"] if on_published else arg["than"]
        a = _values(frame, key, col, [row])
        b = _values(frame, key, other, [row])
        if a is None or b is None:
            return MISSING, ""
        return (HOLDS if a[row] < b[row] else DIFFERS), f"{row}: {a[row]:.4g} against {b[row]:.4g} ({other})"
    raise ClaimError(f"unknown claim check {kind!r} (known: {', '.join(CHECKS)})")


def select(frame: pd.DataFrame | None, rows: dict | None) -> pd.DataFrame | None:
    """The rows of ``frame`` whose columns equal ``rows``' values (compared as text); None stays None."""
    if frame is None or not rows:
        return frame
    keep = pd.Series(True, index=frame.index)
    for col, val in rows.items():
        if col not in frame.columns:
            return None
        keep &= frame[col].astype(str) == str(val)
    return frame[keep]


def evaluate_claim(c: dict, frame: pd.DataFrame | None) -> tuple[str, str, str, str]:
    """(our verdict, our values, verdict on the published numbers, those values) of one claim on its
    (row-selected) table; the published pair is empty when the claim has no published column."""
    kind = next(iter(c["check"]))
    verdict, ours = evaluate(c["check"], frame, c["key"], c["ours"], c.get("published"))
    if not c.get("published") or kind == "within":
        return verdict, ours, "", ""
    pub_verdict, pub = evaluate(c["check"], frame, c["key"], c["published"], on_published=True)
    return verdict, ours, pub_verdict, pub


def claims_table(study, tables: list[TableSpec]) -> TableSpec | None:
    """The study's ``claims`` checked on ``tables`` (built from its archives), or None without claims."""
    claims = study.doc.get("claims") or []
    if not claims:
        return None
    by_name = {t.name: t.frame for t in tables}
    rows = []
    for c in claims:
        frame = select(by_name.get(c["table"]), c.get("rows"))
        verdict, ours, pub_verdict, pub = evaluate_claim(c, frame)
        rows.append({"claim of the document": c["claim"], "where": c.get("where", ""), "table": c["table"],
                     "our values": ours or "—", "published values": pub or "—",
                     "verdict (ours)": verdict, "verdict (published numbers)": pub_verdict or "—",
                     "why": "" if verdict == HOLDS else c.get("reason", "")})
    counts = pd.Series([r["verdict (ours)"] for r in rows]).value_counts()
    summary = ", ".join(f"{int(counts.get(v, 0))} {v}" for v in (HOLDS, DIFFERS, MISSING))
    return TableSpec("claims", "Claims of the document, checked on our archives", pd.DataFrame(rows),
                     f"{summary}. Each verdict is computed from the named table (itself computed from the "
                     "archives): the check runs on our column and, where the document gives the numbers, on "
                     "the published column. 'not reproduced' = the table, a row or a value is missing in "
                     "this build. The reasons are ours, one line each.")


def not_reproduced_table(study) -> TableSpec | None:
    """The study's ``not_reproduced`` list (document items left out and why), or None."""
    items = study.doc.get("not_reproduced") or []
    if not items:
        return None
    return TableSpec("not_reproduced", "What this study does not reproduce",
                     pd.DataFrame([{"document item": i["item"], "why not": i["why"]} for i in items]),
                     "Every table, figure and test of the document that has no counterpart here.")


def with_claims(study, tables: list[TableSpec]) -> list[TableSpec]:
    """``tables`` with the claims and not-reproduced tables first (the report opens each study with them)."""
    head = [t for t in (claims_table(study, tables), not_reproduced_table(study)) if t is not None]
    return head + list(tables)


__all__ = ["CHECKS", "ClaimError", "DIFFERS", "HOLDS", "MISSING", "claims_table", "evaluate", "evaluate_claim",
           "not_reproduced_table", "select", "with_claims"]
