"""Compare two builds of the same config (e.g. a local and a SLURM quick build): identical apart from timings.

    python workflow/scripts/compare_builds.py RESULTS_A RESULTS_B [--tables-only | --verdicts | --answers]

``--tables-only`` leaves out step 2 (the archives): for builds written in different archive formats,
which one reader cannot both read.

``--verdicts`` compares what load could move instead (two builds of one commit, one on a quiet
machine and one while a second build loads it): every study's claims table must give the same
verdicts (ours and on the published numbers) row by row, and every time column of a table a claim
reads must rank its rows the same (tables with a ``statistic`` column aside); the largest relative
difference of each time column and each build's load record (``machine_load.csv``) are printed.

``--answers`` compares the benchmark's answers (two builds, e.g. one quiet and one loaded): both answer
tables side by side (arm, start set, the method each recommends, success, median call, distance to the
seed) with each build's load record (every race's load average and CPU share, the solve jobs' CPU share);
exit 1 when a row has no recommendation or the two builds recommend different labels.

Checks, exit 1 on any difference:

1. the two reports have the same sections, tables and figures (their anchors, in order) and the same
   text outside the tables once numbers are masked (timings, and everything computed from them, are
   numbers); the tables' contents are compared through their CSV files (3.), and ``verify`` checks
   that the report embeds exactly those;
2. every archive (``*/runs/**/*.mcap``, ``*/reruns/**``) holds the same solve records apart from the
   timing fields (``*time*``) and the run metadata apart from ``timing``/``environment``;
3. every table CSV has the same columns and rows, and equal values in every column whose header does
   not name a time or a speed.

Left out, because they depend on timings or are not deterministic by design (each is listed when
the script runs): the report's answer section (its picks break ties between equally successful
methods by call time), tables computed from times under other names (:data:`TIMING_TABLES`) or whose
rows are chosen by time (:data:`TIMING_CHOSEN`: the benchmark's key labels per robot), table rows
whose first column names a time, time fields inside a record's ``info``, and
the records of TRAC-IK, of the Robotics Toolbox solvers (a failed search returns a C ``rand()``
configuration) and of any label with a ``time_budget`` (``pipeline/solvers/peers/libraries.py``), with their
rows and columns in the tables.
"""

from __future__ import annotations

import fnmatch
import re
import sys
from pathlib import Path

_TIMING = re.compile(r"time|\[(?:s|ms|µs|us|ns)(?:/[^\]]*)?\]|speed|per call|wall|fastest|faster|ratio|cycles/s|Hz|"
                     r"\bt mean\b|×|CPU share", re.I)
# tables whose every value comes from measured times although no header says so
TIMING_TABLES = {"cerbaro2019/tables/table14_correlation.csv",  # Pearson r of problem time vs initial error
                 "nepomuceno2024/tables/orderings.csv",  # the document's speed orderings, checked on our times
                 "arm_benchmark/tables/answer.csv"}  # ties between equally successful methods go to the faster
# tables whose rows are chosen partly by measured times: the benchmark's key labels per robot (the best
# of each group by success, ties to the faster call)
TIMING_CHOSEN = ("arm_benchmark/tables/key_*.csv",)

# pipeline/solvers/peers/libraries.py: TRAC-IK has a wall-time budget and two racing threads; a failed Robotics
# Toolbox search returns a configuration drawn with C rand(), whose state depends on what else the
# process ran (TRAC-IK's restarts draw from it too)
NONDETERMINISTIC = ("trac_ik", "rtb_ik_")
_ANCHOR = re.compile(r'id="((?:tab|fig)-[^"]+|[a-z0-9_]+)"')
_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?", re.I)


def _from_times(rel: str) -> bool:
    """The table at ``rel`` (relative to the results tree) is computed or chosen from measured times."""
    return rel in TIMING_TABLES or any(fnmatch.fnmatch(rel, pat) for pat in TIMING_CHOSEN)


def _report_skeleton(results: Path) -> tuple[list[str], str]:
    html = (results / "report.html").read_text()
    body = re.sub(r"<img [^>]*>", "<img>", html.split("</style>", 1)[1])
    body = "\n".join(ln for ln in body.splitlines() if "data-build-time" not in ln)
    body = re.sub(r"<table class=\"data prov\">.*?</table>", "", body, flags=re.S)  # paths, hashes, hosts
    body = re.sub(r'<section id="answer">.*?</section>\s*</section>', "", body, flags=re.S)  # picks by call time
    # table contents are compared through their CSV files (below; `verify` checks the report embeds them)
    body = re.sub(r"<table\b.*?</table>", "<table/>", body, flags=re.S)
    return _ANCHOR.findall(html), _NUMBER.sub("#", body.replace(str(results), "RESULTS"))


def _deterministic_rows(t):
    """Rows that neither name a non-deterministic method nor measure a time (first two columns)."""
    import pandas as pd

    cells = t.astype(str)
    bad = cells.apply(lambda col: col.str.contains("|".join(NONDETERMINISTIC))).any(axis=1)
    for c in t.columns[:2]:  # a row label naming a time (e.g. "t mean [ms]")
        if not pd.api.types.is_numeric_dtype(t[c]):
            bad |= cells[c].str.contains(_TIMING)
    return t[~bad]


def _records(archive, keep: list[str]):
    """Solve records without their time fields (top level and inside ``info``), as text."""
    f = archive.frame()[keep].copy()
    if "info" in f:
        f["info"] = f["info"].map(lambda d: {k: v for k, v in d.items() if "time" not in k} if isinstance(d, dict) else d)
    return f.astype(str)


def _archives(results: Path) -> dict[str, Path]:
    return {p.relative_to(results).as_posix(): p for p in sorted(results.glob("*/*runs/**/*.mcap"))}


def compare(a: Path, b: Path, archives: bool = True) -> list[str]:
    import pandas as pd

    from pipeline.io.archive import read_archive

    problems = []
    ids_a, text_a = _report_skeleton(a)
    ids_b, text_b = _report_skeleton(b)
    if ids_a != ids_b:
        problems.append(f"report: other sections, tables or figures ({len(ids_a)} vs {len(ids_b)} anchors)")
    elif text_a != text_b:
        la, lb = text_a.splitlines(), text_b.splitlines()
        k = next((i for i, (x, y) in enumerate(zip(la, lb)) if x != y), min(len(la), len(lb)))
        problems.append(f"report: text differs beyond numbers, first at line {k + 1}")
    arch_a, arch_b = (_archives(a), _archives(b)) if archives else ({}, {})
    if set(arch_a) != set(arch_b):
        problems.append(f"archives: {sorted(set(arch_a) ^ set(arch_b))[:5]} in one build only")
    skipped = []
    for name in sorted(set(arch_a) & set(arch_b)):
        xa, xb = read_archive(arch_a[name]), read_archive(arch_b[name])
        settings = xa.metadata.get("settings", "")
        if any(m in xa.metadata.get("method", "") for m in NONDETERMINISTIC) or re.search(r'"time_budget": [1-9]', settings):
            skipped.append(name)
            continue
        keep = [c for c in xa.frame().columns if "time" not in c] if xa.solves else []
        fa = _records(xa, keep) if keep else None
        fb = _records(xb, keep) if keep and set(keep) <= set(xb.frame().columns) else None
        if (fa is None) != (fb is None) or (fa is not None and not fa.equals(fb)):
            problems.append(f"{name}: solve records differ (timing fields aside)")
        ma = {k: v for k, v in xa.metadata.items() if k not in ("timing", "environment")}
        mb = {k: v for k, v in xb.metadata.items() if k not in ("timing", "environment")}
        if ma != mb:
            diff = sorted(k for k in set(ma) | set(mb) if ma.get(k) != mb.get(k))
            problems.append(f"{name}: metadata differs in {diff}")
    tables_a = sorted(p.relative_to(a) for p in a.glob("*/tables/*.csv"))
    tables_b = sorted(p.relative_to(b) for p in b.glob("*/tables/*.csv"))
    if tables_a != tables_b:
        problems.append(f"tables: {sorted(set(map(str, tables_a)) ^ set(map(str, tables_b)))[:5]} in one build only")
    timing_only = 0
    for rel in sorted(set(tables_a) & set(tables_b)):
        if _from_times(rel.as_posix()) or rel.name == "machine_load.csv":  # the load record itself
            continue
        ta, tb = pd.read_csv(a / rel), pd.read_csv(b / rel)
        if list(ta.columns) != list(tb.columns) or len(ta) != len(tb):
            problems.append(f"{rel}: other columns or row count")
            continue
        ta, tb = _deterministic_rows(ta), _deterministic_rows(tb)
        if len(ta) != len(tb):
            problems.append(f"{rel}: other rows")
            continue
        cols = [c for c in ta.columns if not _TIMING.search(str(c)) and not any(m in str(c) for m in NONDETERMINISTIC)]
        # rows may be ordered by a time (the benchmark's per-robot tables): compare them as sorted sets
        sa = ta[cols].astype(str).sort_values(cols).reset_index(drop=True)
        sb = tb[cols].astype(str).sort_values(cols).reset_index(drop=True)
        if not sa.equals(sb):
            bad = [c for c in cols if not sa[c].equals(sb[c])]
            problems.append(f"{rel}: differs in {bad[:6]}")
        elif not ta.astype(str).equals(tb.astype(str)):
            timing_only += 1
    timed = sorted(t.as_posix() for t in tables_a if _from_times(t.as_posix()))
    print(f"compared {len(arch_a) - len(skipped)} archives, {len(tables_a) - len(timed)} "
          f"tables ({timing_only} differ in timing columns only) and the reports ({len(ids_a)} anchors, answer "
          f"section aside); not compared: {len(skipped)} archives of non-deterministic labels (TRAC-IK, "
          f"Robotics Toolbox, time budgets) and {len(timed)} tables computed or chosen from times ({', '.join(timed)})")
    return problems


def _time_columns(t, rel: str) -> list[str]:
    """Our numeric columns measured in time (their header names a time, :data:`_TIMING`, or the whole table
    is computed from times, :data:`TIMING_TABLES`)."""
    from pandas.api.types import is_numeric_dtype

    return [c for c in t.columns if "published" not in c and is_numeric_dtype(t[c])
            and (_from_times(rel) or _TIMING.search(c))]


def compare_verdicts(a: Path, b: Path) -> list[str]:
    """``--verdicts``: the same claim verdicts and the same ranking by every time column the claims read
    (see the module docstring); times themselves are printed, not judged."""
    import pandas as pd

    problems = []
    for claims in sorted(a.glob("*/tables/claims.csv")):
        sid = claims.parent.parent.name
        other = b / sid / "tables" / "claims.csv"
        if not other.is_file():
            problems.append(f"{sid}: no claims table in {b}")
            continue
        ca, cb = pd.read_csv(claims, keep_default_na=False), pd.read_csv(other, keep_default_na=False)
        cols = ["claim of the document", "reading", "verdict (ours)", "verdict (published numbers)"]
        if len(ca) != len(cb):
            problems.append(f"{sid}: {len(ca)} claim rows against {len(cb)}")
            continue
        diff = ca[cols].ne(cb[cols]).any(axis=1)
        for i in diff[diff].index:
            problems.append(f"{sid}: claim row {i + 1} ({ca.loc[i, 'claim of the document'][:60]!r}, reading "
                            f"{ca.loc[i, 'reading']!r}): {ca.loc[i, 'verdict (ours)']} against {cb.loc[i, 'verdict (ours)']}")
        print(f"{sid}: {len(ca)} claim rows, {int(diff.sum())} verdict(s) differ")
        for name in sorted(set(ca["table"])):
            pa, pb = a / sid / "tables" / f"{name}.csv", b / sid / "tables" / f"{name}.csv"
            if not (pa.is_file() and pb.is_file()):
                continue
            ta, tb = pd.read_csv(pa), pd.read_csv(pb)
            for c in _time_columns(ta, f"{sid}/tables/{name}.csv"):
                if c not in tb or len(ta) != len(tb):
                    problems.append(f"{sid}/{name}: column {c!r} or its rows missing in one build")
                    continue
                x, y = ta[c].to_numpy(float), tb[c].to_numpy(float)
                rel = float(pd.Series(abs(x - y) / abs(x).clip(min=1e-300)).max()) if len(x) else 0.0
                same_order = (list(pd.Series(x).rank(method="min").fillna(-1))
                              == list(pd.Series(y).rank(method="min").fillna(-1)))
                print(f"  {name}: {c}: largest relative difference {100 * rel:.3g} %, "
                      f"row order {'the same' if same_order else 'DIFFERS'}")
                if not same_order and "statistic" not in ta.columns:
                    problems.append(f"{sid}/{name}: rows ordered differently by {c!r}")
    for label, root in (("A", a), ("B", b)):
        for load in sorted(root.glob("*/tables/machine_load.csv")):
            t = pd.read_csv(load)
            print(f"load record {label} {load.parent.parent.name}: CPU share ≥ "
                  f"{t['job CPU share, smallest [-]'].min():.2f}, 1-min load ≤ {t['1-min load average, largest [-]'].max():.2f}")
    return problems


def compare_answers(a: Path, b: Path) -> list[str]:
    """``--answers``: the two builds' answer tables side by side and their load records (module docstring)."""
    import pandas as pd

    from pipeline.io.archive import read_archive
    from pipeline.studies.arm_benchmark import RACE_SET_TOPIC

    t = {}
    for label, root in (("A", a), ("B", b)):
        ans = pd.read_csv(root / "arm_benchmark" / "tables" / "answer.csv", keep_default_na=False)
        t[label] = ans.set_index(["robot", "problem set"])
        races = []
        for f in sorted((root / "arm_benchmark" / "race").glob("*.mcap")):
            for r in read_archive(f).messages(RACE_SET_TOPIC):
                if r.get("raced"):
                    races.append((float(r["load_start"]), float(r["load_end"]), float(r["cpu_share"])))
        load = pd.read_csv(root / "arm_benchmark" / "tables" / "machine_load.csv") \
            if (root / "arm_benchmark" / "tables" / "machine_load.csv").is_file() else None
        print(f"load record {label} ({root}): {len(races)} races, load average "
              f"{min((x for r in races for x in r[:2]), default=float('nan')):.2f}-"
              f"{max((x for r in races for x in r[:2]), default=float('nan')):.2f}, race CPU share "
              f"{min((r[2] for r in races), default=float('nan')):.2f}-{max((r[2] for r in races), default=float('nan')):.2f}"
              + ("" if load is None else f"; solve jobs: CPU share >= {load['job CPU share, smallest [-]'].min():.2f}, "
                                         f"1-min load <= {load['1-min load average, largest [-]'].max():.2f}"))
    rows, problems = [], []
    for key in t["A"].index.union(t["B"].index, sort=False):
        ra = t["A"].loc[key] if key in t["A"].index else None
        rb = t["B"].loc[key] if key in t["B"].index else None
        pick = [x["recommendation"] if x is not None else "" for x in (ra, rb)]
        rows.append({"arm": key[0], "set": key[1], "A": pick[0], "B": pick[1],
                     "A call [µs]": ra["call time p50 [µs]"] if ra is not None else "",
                     "B call [µs]": rb["call time p50 [µs]"] if rb is not None else "",
                     "A seed dist [rad]": ra["distance to seed p50 [rad]"] if ra is not None else "",
                     "B seed dist [rad]": rb["distance to seed p50 [rad]"] if rb is not None else "",
                     "same": pick[0] == pick[1] and bool(pick[0])})
        if not all(pick):
            problems.append(f"{key}: no recommendation in {'A' if not pick[0] else 'B'}")
        elif pick[0] != pick[1]:
            problems.append(f"{key}: {pick[0]} against {pick[1]}")
    print(pd.DataFrame(rows).to_string(index=False, float_format=lambda x: f"{x:.3g}"))
    return problems


def main(argv: list[str]) -> int:
    a, b = (Path(x) for x in argv[1:3])
    flags = argv[3:]
    if "--answers" in flags:
        problems, same = compare_answers(a, b), "same answers"
    elif "--verdicts" in flags:
        problems, same = compare_verdicts(a, b), "same verdicts"
    else:
        problems, same = compare(a, b, archives="--tables-only" not in flags), "same apart from timings"
    for p in problems:
        print("differs:", p)
    print(same if not problems else f"{len(problems)} differences")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
