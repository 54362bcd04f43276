"""List every number in a built report's prose that no table, setting or listed fact holds.

    python workflow/scripts/check_prose_numbers.py RESULTS [--study ID ...]

Reads each study's table notes, figure captions, claims' reasons and interpretations (filled from
its tables) in RESULTS (pipeline.studies.prose.untabled_numbers) and prints one line per number
that none of the study's tables (ours or published), published files, settings or ``prose_facts``
holds. Exit status 1 when there is any: such a number was typed by hand and may have drifted from
the build. tests/workflow/test_workflow.py runs the same check on the quick build.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pipeline.settings import load_study
from pipeline.studies.prose import untabled_numbers

ROOT = Path(__file__).resolve().parents[2]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", type=Path)
    ap.add_argument("--study", action="append", help="study id (default: every study built in RESULTS)")
    ap.add_argument("--data", type=Path, default=ROOT / "data")
    args = ap.parse_args(argv)
    ids = args.study or sorted(p.parent.parent.name for p in args.results.glob("*/tables/index.json"))
    bad = 0
    for sid in ids:
        study = load_study(args.data / "studies" / f"{sid}.yaml")
        for where, number, context in untabled_numbers(study, args.results / sid, args.data / "published"):
            print(f"{sid}: {where}: {number!r} in “…{context.strip()}…”")
            bad += 1
    print(f"{bad} number(s) in the prose of {len(ids)} studies that no table holds", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
