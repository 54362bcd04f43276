"""Do two builds of the same commit reach the same verdicts? (e.g. one on a quiet machine, one loaded)

    python workflow/scripts/compare_verdicts.py RESULTS_A RESULTS_B

Checks, exit 1 on any difference:

1. every study's claims table: the same rows with the same verdicts (ours and on the published
   numbers) and the same count line;
2. every time-based table the claims read (a claim's table with a time column): the same row order
   by each time column (what a ranking or a "fastest" verdict rests on); the largest relative
   difference of each time column is printed, not judged (times are measured, so they are never
   bit-identical, but load should not move them: they are thread CPU time);
3. each build's load record (``machine_load.csv``) is printed beside.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pandas as pd

_TIME = re.compile(r"time|CPU|fastest|\bCV\b|Pearson|\bt (?:max|min|mean|median)\b", re.I)


def _time_columns(t: pd.DataFrame) -> list[str]:
    return [c for c in t.columns if _TIME.search(c) and "published" not in c and pd.api.types.is_numeric_dtype(t[c])]


def compare(a: Path, b: Path) -> list[str]:
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
            for c in _time_columns(ta):
                if c not in tb or len(ta) != len(tb):
                    problems.append(f"{sid}/{name}: column {c!r} or its rows missing in one build")
                    continue
                x, y = ta[c].to_numpy(float), tb[c].to_numpy(float)
                rel = float(pd.Series(abs(x - y) / abs(x).clip(min=1e-300)).max()) if len(x) else 0.0
                same_order = list(pd.Series(x).rank(method="min")) == list(pd.Series(y).rank(method="min"))
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


def main(argv: list[str]) -> int:
    if len(argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    problems = compare(Path(argv[1]), Path(argv[2]))
    for p in problems:
        print("DIFFERS:", p)
    print("same verdicts" if not problems else f"{len(problems)} difference(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
