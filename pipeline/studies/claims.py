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

``at_most: {row: ROW, value: X}`` / ``at_least: {row: ROW, value: X}``
                                  ROW's value <= X / >= X
``all_at_least: X``               every row's value >= X
``same_as: {rows: [ROW, ...], than: COL, than_published: PCOL, tol: T}``
                                  each ROW's value equals its value in column COL (within T, default 0)
``column_largest: {of: [COL, ...], of_published: [PCOL, ...]}``
                                  in every row the value exceeds the row's values in the columns ``of``
``nonzero_exactly: [ROW, ...]``   the rows whose value is not zero are exactly these (e.g. 1 = converged)
``close: {rows: [A, B], rel: R}``  A's and B's values lie within a relative R of each other (|A − B| <= R max(|A|, |B|))
``max_by: {row: ROW, factor: F}`` / ``min_by: {row: ROW, factor: F}``
                                  ROW's value is at least F times every other row's / every other row's
                                  value is at least F times ROW's ("by far the most / the fewest": a
                                  claim of degree, where ``max`` / ``min`` would hold on any margin)

An optional ``rows: {column: value, ...}`` keeps only the matching rows first (e.g. the ``mean``
rows of a table with a ``statistic`` column; a list of values keeps the rows matching any of them).

**Every reading.** Where a claim can be read on more than one row or measure (the whole firmware or
its FK share, position or orientation error), ``reading`` names the one the claim's own fields check
(the one that matches what the document measured: it alone counts toward the study's count) and
``readings`` lists the others, each a ``label`` plus the fields it changes (``table``, ``rows``,
``key``, ``ours``, ``published``, ``check``, ``reason``). The claims table shows a row per reading.

**Not comparable.** ``not_comparable: WHY`` marks a claim the build cannot check fairly (e.g. it
compares compiled code with an interpreted library): its verdict is *not comparable here*, its
values are still shown, and it does not count as holding or differing.

**Cannot fail.** ``cannot_fail: WHY`` marks a claim whose check holds by construction here (e.g. a
solver's tolerance guarantees it): its verdict is *cannot fail here*, its values are still shown, and
it does not count as holding.

**Not reproducible.** ``not_reproducible: WHY`` (instead of ``table``, ``key``, ``ours``, ``check``) is a
headline of the document that no table of the build can decide: its verdict is *not reproducible here*,
with the reason, and it counts among the study's headlines.

**Ties.** ``tie_within: R`` (``max``, ``min``, ``less``, ``order``): when the values the verdict turns on
lie within a relative R of each other (the measure's noise), the verdict is *tie*, not holds or differs.

**Missing values.** A claim *not reproduced* in a build shows no reason beyond "not measured in this
build": a reason explains a measured difference, and a build that did not measure has none to explain.

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

CHECKS = ("max", "min", "order", "less", "ratio_at_least", "within", "abs_at_most", "column_less", "at_most",
          "at_least", "all_at_least", "same_as", "column_largest", "nonzero_exactly", "close", "max_by", "min_by")
HOLDS, DIFFERS, MISSING, NOT_COMPARABLE = "holds", "differs", "not reproduced", "not comparable here"
TIE, CANNOT_FAIL, NOT_REPRODUCIBLE = "tie", "cannot fail here", "not reproducible here"
NOT_MEASURED = "not measured in this build"


class ClaimError(ValueError):
    """A claim that names a check the module does not know (caught by the schema first)."""


def _matches(column: pd.Series, value) -> pd.Series:
    """Cells of ``column`` equal to ``value``: as text, or as numbers when both are numbers (a CSV's
    ``960`` and a frame's ``960.0`` are the same row)."""
    text = column.astype(str) == str(value)
    try:
        num = float(value)
    except (TypeError, ValueError):
        return text
    return text | (pd.to_numeric(column, errors="coerce") == num)


def _values(frame: pd.DataFrame, key: str, col: str, rows: list[str]) -> dict[str, float] | None:
    """{row: value} of ``col`` for ``rows`` (None when the column, a row or a value is missing)."""
    if frame is None or key not in frame.columns or col not in frame.columns:
        return None
    out = {}
    for r in rows:
        hit = frame[_matches(frame[key], r)]
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
    out = {_name(k): float(v) for k, v in zip(frame[key], vals) if v is not None and math.isfinite(float(v))}
    return out or None


def _name(k) -> str:
    """A row's name as text; a whole number printed without ``.0`` (a CSV's ``1`` and a frame's ``1.0``)."""
    return str(int(k)) if isinstance(k, float) and k.is_integer() else str(k)


def _check_max_min(kind: str, arg, frame: pd.DataFrame | None, key: str, col: str, published_col: str | None,
                   on_published: bool) -> tuple[str, str]:
    """Check ``max`` / ``min``."""
    vals = _all_rows(frame, key, col)
    if vals is None or str(arg) not in vals:
        return MISSING, ""
    pick = (max if kind == "max" else min)(vals, key=vals.get)
    order = sorted(vals, key=vals.get, reverse=kind == "max")
    return (HOLDS if pick == str(arg) else DIFFERS), ", ".join(f"{r} {vals[r]:.4g}" for r in order)


def _check_order(kind: str, arg, frame: pd.DataFrame | None, key: str, col: str, published_col: str | None,
                 on_published: bool) -> tuple[str, str]:
    """Check ``order``."""
    vals = _values(frame, key, col, [str(a) for a in arg])
    if vals is None:
        return MISSING, ""
    v = [vals[str(a)] for a in arg]
    return (HOLDS if all(x < y for x, y in zip(v, v[1:])) else DIFFERS), " < ".join(f"{a} {vals[str(a)]:.4g}" for a in arg)


def _check_less(kind: str, arg, frame: pd.DataFrame | None, key: str, col: str, published_col: str | None,
                on_published: bool) -> tuple[str, str]:
    """Check ``less``."""
    a, b = (str(x) for x in arg)
    vals = _values(frame, key, col, [a, b])
    if vals is None:
        return MISSING, ""
    return (HOLDS if vals[a] < vals[b] else DIFFERS), f"{a} {vals[a]:.4g}, {b} {vals[b]:.4g}"


def _check_ratio_at_least(kind: str, arg, frame: pd.DataFrame | None, key: str, col: str, published_col: str | None,
                          on_published: bool) -> tuple[str, str]:
    """Check ``ratio_at_least``."""
    a, b, x = str(arg[0]), str(arg[1]), float(arg[2])
    vals = _values(frame, key, col, [a, b])
    if vals is None or vals[b] == 0:
        return MISSING, ""
    r = vals[a] / vals[b]
    return (HOLDS if r >= x else DIFFERS), f"{a} / {b} = {r:.4g} (claim: ≥ {x:g})"


def _check_within(kind: str, arg, frame: pd.DataFrame | None, key: str, col: str, published_col: str | None,
                  on_published: bool) -> tuple[str, str]:
    """Check ``within``."""
    row, rel = str(arg["row"]), float(arg["rel"])
    ours = _values(frame, key, col, [row])
    pub = _values(frame, key, published_col, [row]) if published_col else None
    if ours is None or pub is None:
        return MISSING, ""
    o, p = ours[row], pub[row]
    dev = abs(o - p) / abs(p) if p else math.inf
    return (HOLDS if dev <= rel else DIFFERS), f"{row}: {o:.4g} against {p:.4g} ({100 * dev:.3g} % off; claim: ≤ {100 * rel:g} %)"


def _check_abs_at_most(kind: str, arg, frame: pd.DataFrame | None, key: str, col: str, published_col: str | None,
                       on_published: bool) -> tuple[str, str]:
    """Check ``abs_at_most``."""
    vals = _all_rows(frame, key, col)
    if vals is None:
        return MISSING, ""
    worst = max(vals, key=lambda r: abs(vals[r]))
    return ((HOLDS if abs(vals[worst]) <= float(arg) else DIFFERS),
            f"largest |value|: {worst} {vals[worst]:.4g} (claim: ≤ {float(arg):g})")


def _check_column_less(kind: str, arg, frame: pd.DataFrame | None, key: str, col: str, published_col: str | None,
                       on_published: bool) -> tuple[str, str]:
    """Check ``column_less``."""
    row = str(arg["row"])
    other = arg["than_published"] if on_published else arg["than"]
    a = _values(frame, key, col, [row])
    b = _values(frame, key, other, [row])
    if a is None or b is None:
        return MISSING, ""
    return (HOLDS if a[row] < b[row] else DIFFERS), f"{row}: {a[row]:.4g} against {b[row]:.4g} ({other})"


def _check_at_most_at_least(kind: str, arg, frame: pd.DataFrame | None, key: str, col: str, published_col: str | None,
                            on_published: bool) -> tuple[str, str]:
    """Check ``at_most`` / ``at_least``."""
    row, x = str(arg["row"]), float(arg["value"])
    vals = _values(frame, key, col, [row])
    if vals is None:
        return MISSING, ""
    ok = vals[row] <= x if kind == "at_most" else vals[row] >= x
    return (HOLDS if ok else DIFFERS), f"{row} {vals[row]:.4g} (claim: {'≤' if kind == 'at_most' else '≥'} {x:g})"


def _check_all_at_least(kind: str, arg, frame: pd.DataFrame | None, key: str, col: str, published_col: str | None,
                        on_published: bool) -> tuple[str, str]:
    """Check ``all_at_least``."""
    vals = _all_rows(frame, key, col)
    if vals is None:
        return MISSING, ""
    worst = min(vals, key=vals.get)
    return (HOLDS if vals[worst] >= float(arg) else DIFFERS), f"smallest: {worst} {vals[worst]:.4g} (claim: ≥ {float(arg):g})"


def _check_same_as(kind: str, arg, frame: pd.DataFrame | None, key: str, col: str, published_col: str | None,
                   on_published: bool) -> tuple[str, str]:
    """Check ``same_as``."""
    rows = [str(r) for r in arg["rows"]]
    other = arg["than_published"] if on_published else arg["than"]
    a, b = _values(frame, key, col, rows), _values(frame, key, other, rows)
    if a is None or b is None:
        return MISSING, ""
    tol = float(arg.get("tol", 0.0))
    same = all(abs(a[r] - b[r]) <= tol + 1e-9 * max(abs(a[r]), abs(b[r])) for r in rows)
    return (HOLDS if same else DIFFERS), ", ".join(f"{r}: {a[r]:.4g} and {b[r]:.4g}" for r in rows)


def _check_column_largest(kind: str, arg, frame: pd.DataFrame | None, key: str, col: str, published_col: str | None,
                          on_published: bool) -> tuple[str, str]:
    """Check ``column_largest``."""
    others = arg["of_published"] if on_published else arg["of"]
    mine, theirs = _all_rows(frame, key, col), [_all_rows(frame, key, o) for o in others]
    if mine is None or any(t is None for t in theirs):
        return MISSING, ""
    bad = [r for r in mine if any(r not in t or not mine[r] > t[r] for t in theirs)]
    return ((HOLDS if not bad else DIFFERS),
            "; ".join(f"{r}: {mine[r]:.4g} against " + ", ".join(f"{t.get(r, math.nan):.4g}" for t in theirs)
                      for r in mine))


def _check_nonzero_exactly(kind: str, arg, frame: pd.DataFrame | None, key: str, col: str, published_col: str | None,
                           on_published: bool) -> tuple[str, str]:
    """Check ``nonzero_exactly``."""
    vals = _all_rows(frame, key, col)
    if vals is None:
        return MISSING, ""
    got = [r for r in vals if vals[r] != 0]
    return ((HOLDS if sorted(got) == sorted(str(a) for a in arg) else DIFFERS),
            f"not zero at: {', '.join(got) or 'none'} (claim: {', '.join(str(a) for a in arg)})")


def _check_close(kind: str, arg, frame: pd.DataFrame | None, key: str, col: str, published_col: str | None,
                 on_published: bool) -> tuple[str, str]:
    """Check ``close``."""
    a, b = (str(x) for x in arg["rows"])
    vals = _values(frame, key, col, [a, b])
    if vals is None:
        return MISSING, ""
    gap = abs(vals[a] - vals[b]) / max(abs(vals[a]), abs(vals[b]), 1e-300)
    return ((HOLDS if gap <= float(arg["rel"]) else DIFFERS),
            f"{a} {vals[a]:.4g}, {b} {vals[b]:.4g} ({100 * gap:.3g} % apart; claim: ≤ {100 * float(arg['rel']):g} %)")


def _check_by(kind: str, arg, frame: pd.DataFrame | None, key: str, col: str, published_col: str | None,
              on_published: bool) -> tuple[str, str]:
    """Check ``max_by`` / ``min_by``: the named row beats its nearest rival by a factor."""
    row, factor = str(arg["row"]), float(arg["factor"])
    vals = _all_rows(frame, key, col)
    if vals is None or row not in vals or len(vals) < 2:
        return MISSING, ""
    others = {r: v for r, v in vals.items() if r != row}
    rival = (max if kind == "max_by" else min)(others, key=others.get)
    big, small = (vals[row], others[rival]) if kind == "max_by" else (others[rival], vals[row])
    ok = big >= factor * small and big > small
    ratio = big / small if small else math.inf
    return ((HOLDS if ok else DIFFERS),
            f"{row} {vals[row]:.4g}, nearest {rival} {others[rival]:.4g} (ratio {ratio:.3g}; claim: ≥ {factor:g})")


_CHECKERS = {
    "max": _check_max_min, "min": _check_max_min, "order": _check_order, "less": _check_less,
    "ratio_at_least": _check_ratio_at_least, "within": _check_within, "abs_at_most": _check_abs_at_most,
    "column_less": _check_column_less, "at_most": _check_at_most_at_least, "at_least": _check_at_most_at_least,
    "all_at_least": _check_all_at_least, "same_as": _check_same_as, "column_largest": _check_column_largest,
    "nonzero_exactly": _check_nonzero_exactly, "close": _check_close, "max_by": _check_by, "min_by": _check_by
}  # check kind -> its function (CHECKS lists the kinds)


def _is_tie(check: dict, frame: pd.DataFrame | None, key: str, col: str, rel: float) -> bool:
    """Whether the values a ``max``/``min``/``less``/``order`` verdict turns on lie within a relative
    ``rel`` of each other (for ``max``/``min``: the named row and the best of the others)."""
    (kind, arg), = check.items()
    if kind in ("max", "min"):
        vals = _all_rows(frame, key, col)
        if vals is None or str(arg) not in vals or len(vals) < 2:
            return False
        others = [v for r, v in vals.items() if r != str(arg)]
        pairs = [(vals[str(arg)], max(others) if kind == "max" else min(others))]
    elif kind in ("less", "order"):
        names = [str(a) for a in arg]
        vals = _values(frame, key, col, names)
        if vals is None:
            return False
        pairs = list(zip([vals[r] for r in names], [vals[r] for r in names[1:]]))
    else:
        return False
    return any(abs(x - y) <= rel * max(abs(x), abs(y)) for x, y in pairs)


def evaluate(check: dict, frame: pd.DataFrame | None, key: str, col: str, published_col: str | None = None,
             *, on_published: bool = False) -> tuple[str, str]:
    """(verdict, the values the verdict rests on) of one check on column ``col`` of ``frame``
    (``on_published``: ``col`` is the published column, so ``column_less`` compares with ``than_published``)."""
    (kind, arg), = check.items()
    check_kind = _CHECKERS.get(kind)
    if check_kind is None:
        raise ClaimError(f"unknown claim check {kind!r} (known: {', '.join(CHECKS)})")
    return check_kind(kind, arg, frame, key, col, published_col, on_published)


def select(frame: pd.DataFrame | None, rows: dict | None) -> pd.DataFrame | None:
    """The rows of ``frame`` whose columns equal ``rows``' values (compared as text); None stays None."""
    if frame is None or not rows:
        return frame
    keep = pd.Series(True, index=frame.index)
    for col, val in rows.items():
        if col not in frame.columns:
            return None
        keep &= (pd.concat([_matches(frame[col], v) for v in val], axis=1).any(axis=1) if isinstance(val, list)
                 else _matches(frame[col], val))
    return frame[keep]


def evaluate_claim(c: dict, frame: pd.DataFrame | None) -> tuple[str, str, str, str]:
    """(our verdict, our values, verdict on the published numbers, those values) of one claim (or one
    reading of it, :func:`readings`) on its (row-selected) table; the published pair is empty when the
    claim has no published column. A ``not_comparable`` claim's verdict is :data:`NOT_COMPARABLE`, a
    ``cannot_fail`` one's :data:`CANNOT_FAIL`, a ``not_reproducible`` one's :data:`NOT_REPRODUCIBLE`; a
    ``tie_within`` claim whose deciding values are that close is a :data:`TIE`."""
    if c.get("not_reproducible"):
        return NOT_REPRODUCIBLE, "", "", ""
    kind, arg = next(iter(c["check"].items()))
    verdict, ours = evaluate(c["check"], frame, c["key"], c["ours"], c.get("published"))
    if verdict in (HOLDS, DIFFERS) and c.get("tie_within") is not None \
            and _is_tie(c["check"], frame, c["key"], c["ours"], float(c["tie_within"])):
        verdict = TIE
        ours += f" (within {100 * float(c['tie_within']):g} %: a tie)"
    if c.get("not_comparable"):
        verdict = NOT_COMPARABLE
    elif c.get("cannot_fail") and verdict != MISSING:
        verdict = CANNOT_FAIL
    two_columns = {"column_less": "than_published", "same_as": "than_published", "column_largest": "of_published"}
    if not c.get("published") or kind == "within" or (kind in two_columns and two_columns[kind] not in arg):
        return verdict, ours, "", ""
    pub_verdict, pub = evaluate(c["check"], frame, c["key"], c["published"], on_published=True)
    return verdict, ours, pub_verdict, pub


def readings(c: dict) -> list[tuple[str, dict, bool]]:
    """Every reading of claim ``c``: ``(label, the claim as that reading checks it, counts)``; the claim's
    own fields come first and alone count toward the study's count."""
    main = {k: v for k, v in c.items() if k != "readings"}
    out = [(c.get("reading", ""), main, True)]
    for r in c.get("readings") or []:
        merged = {**main, **{k: v for k, v in r.items() if k != "label"}}
        if "reason" not in r:
            merged.pop("reason", None)
        out.append((r["label"], merged, False))
    return out


def count_line(verdicts: list[str]) -> str:
    """``"n of m claims hold"`` and how many differ, are not comparable here or not reproduced."""
    counts = pd.Series(verdicts, dtype=object).value_counts()
    plural = {DIFFERS: "differ", TIE: "ties"}
    rest = [f"{int(counts[v])} {plural[v] if v in plural and counts[v] > 1 else v}"
            for v in (DIFFERS, TIE, CANNOT_FAIL, NOT_COMPARABLE, NOT_REPRODUCIBLE, MISSING) if counts.get(v, 0)]
    head = f"{int(counts.get(HOLDS, 0))} of {len(verdicts)} claims hold"
    return head + (f" ({', '.join(rest)})" if rest else "")


def _filled(study, k: int, text: str, tables: dict) -> str:
    """Claim ``k``'s reason with its placeholders filled; a placeholder naming an unknown column is an
    error naming the study file and the claim."""
    from pipeline.studies.prose import ProseError, fill

    try:
        return fill(text, tables)
    except ProseError as exc:
        raise ProseError(f"{study.path}: field 'claims/{k}': {exc}") from None


def claims_table(study, tables: list[TableSpec]) -> TableSpec | None:
    """The study's ``claims`` checked on ``tables`` (built from its archives), one row per reading, or
    None without claims. The reasons' placeholders are filled from ``tables`` (:mod:`pipeline.studies.prose`)."""
    claims = study.doc.get("claims") or []
    if not claims:
        return None
    by_name = {t.name: t.frame for t in tables}
    rows, headline = [], []
    for k, c in enumerate(claims):
        for label, r, counts in readings(c):
            frame = select(by_name.get(r.get("table")), r.get("rows"))
            verdict, ours, pub_verdict, pub = evaluate_claim(r, frame)
            why = {NOT_COMPARABLE: r.get("not_comparable", ""), CANNOT_FAIL: r.get("cannot_fail", ""),
                   NOT_REPRODUCIBLE: r.get("not_reproducible", ""), HOLDS: "",
                   MISSING: NOT_MEASURED if r.get("reason") else ""}.get(verdict, r.get("reason", ""))
            rows.append({"claim of the document": c["claim"] if counts else "↳ the same claim, another reading",
                         "reading": label or "—", "counts": "yes" if counts else "no (shown beside)",
                         "where": c.get("where", "") if counts else "", "table": r.get("table", "—"),
                         "our values": ours or "—", "published values": pub or "—",
                         "verdict (ours)": verdict, "verdict (published numbers)": pub_verdict or "—",
                         "why": _filled(study, k, why, by_name)})
            if counts:
                headline.append(verdict)
    return TableSpec("claims", "Claims of the document, checked on our archives", pd.DataFrame(rows),
                     f"{count_line(headline)}. Each verdict is computed from the named table (itself computed from "
                     "the archives): the check runs on our column and, where the document gives the numbers, on "
                     "the published column. Where a claim can be read on more than one row or measure, each "
                     "reading has a row and only the one matching what the document measured counts "
                     "('counts'). 'not reproduced' = the table, a row or a value is missing in this build; "
                     "'not comparable here' = the build cannot check the claim fairly (the reason says why); "
                     "'cannot fail here' = the check holds by construction in this build (the reason says why); "
                     "'not reproducible here' = no table of the build can decide it (the reason says why); "
                     "'tie' = the values the verdict turns on lie within the measure's noise. "
                     "The reasons are ours, one line each, their numbers filled in from the tables.")


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


__all__ = ["CANNOT_FAIL", "CHECKS", "ClaimError", "DIFFERS", "HOLDS", "MISSING", "NOT_COMPARABLE", "NOT_MEASURED",
           "NOT_REPRODUCIBLE", "TIE", "claims_table", "count_line",
           "evaluate", "evaluate_claim", "not_reproduced_table", "readings", "select", "with_claims"]
