"""Read and rebuild a finished build under other CPU kernels: the archives must stand on their own.

    python workflow/scripts/check_kernels.py RESULTS [--cores Haswell Prescott SkylakeX] [--problems 3]

For each OpenBLAS core type (``OPENBLAS_CORETYPE``; give only those this CPU accepts), with numba's
generic CPU target (``NUMBA_CPU_NAME=generic``):

1. ``inspect --problem N`` on every archive of RESULTS for its first few problems (one process per
   core type reading every archive, the same code as the verb);
2. ``python -m pipeline verify`` on a copy of RESULTS;
3. a rebuild of every table, figure and the report from the same archives (``snakemake --forcerun
   aggregate_tables plot_figures render_report`` on the copy), compared byte for byte with the
   originals (the report without its build-time line, its seal and the lines naming the machine and
   the commit that rendered it).

Prints one line per check and exits 1 on any failure.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
INSPECT = r"""
import sys
from pathlib import Path
from pipeline.io.archive import read_archive
from pipeline.report.inspect import describe
n_arch = n_views = 0
for p in sorted(Path(sys.argv[1]).glob("*/runs/**/*.mcap")):
    a = read_archive(p)
    n_arch += 1
    for r in a.solves[: int(sys.argv[2])]:
        describe(a, problem=r["problem_id"])
        n_views += 1
mods = sorted(m for m in sys.modules if m.startswith(("pipeline.solvers", "numba")))
print(f"{n_arch} archives, {n_views} problem views; solver modules imported: {mods or 'none'}")
"""


def _run(cmd, env, cwd=ROOT):
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True)


def check(results: Path, core: str, problems: int) -> tuple[list[str], list[str]]:
    """(lines of checks that passed, lines of checks that failed) under one core type."""
    env = {**os.environ, "OPENBLAS_CORETYPE": core, "NUMBA_CPU_NAME": "generic"}
    out, bad = [], []
    p = _run([sys.executable, "-c", INSPECT, str(results), str(problems)], env)
    (out if p.returncode == 0 else bad).append(f"{core}: inspect: " + (p.stdout.strip() or p.stderr.strip()[-500:]))
    with tempfile.TemporaryDirectory(dir=results.parent) as tmp:
        copy = Path(tmp) / "results"
        shutil.copytree(results, copy)
        p = _run([sys.executable, "-m", "pipeline", "verify", str(copy)], env)
        (out if p.returncode == 0 else bad).append(f"{core}: verify: " + " ".join(p.stdout.split()))
        p = _run([sys.executable, "-m", "snakemake", "--cores", "2", "--nolock", "--forcerun", "aggregate_tables",
                  "plot_figures", "render_report", "--config", f"results_dir={copy}"], env)
        if p.returncode:
            bad.append(f"{core}: rebuild failed: {p.stderr[-800:]}")
            return out, bad
        diff = []
        for f in sorted(results.rglob("*")):
            rel = f.relative_to(results)
            if f.is_file() and len(rel.parts) > 1 and rel.parts[1] in ("tables", "figures"):
                g = copy / rel
                if not g.is_file() or g.read_bytes() != f.read_bytes():
                    diff.append(str(rel))
        # the report names the machine that rendered it (its BLAS kernel included) and seals its text:
        # those lines may differ; any other line must not
        keep = lambda t: [ln for ln in t.splitlines() if not any(  # noqa: E731
            m in ln for m in ("data-build-time", "Rendered on CPU:", "ik-pipeline-report-sha256", ", commit <code>"))]
        if keep((results / "report.html").read_text()) != keep((copy / "report.html").read_text()):
            diff.append("report.html")
        n = sum(1 for f in results.rglob("*") if f.is_file() and len(f.relative_to(results).parts) > 1
                and f.relative_to(results).parts[1] in ("tables", "figures"))
        (bad if diff else out).append(f"{core}: rebuilt {n} table and figure files and the report: "
                                      + ("byte-identical" if not diff else f"{len(diff)} differ: {', '.join(diff[:10])}"))
    return out, bad


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", type=Path)
    ap.add_argument("--cores", nargs="+", default=["Haswell", "Prescott", "SkylakeX"])
    ap.add_argument("--problems", type=int, default=3, help="problems inspected per archive")
    args = ap.parse_args()
    ok = True
    for core in args.cores:
        good, bad = check(args.results.resolve(), core, args.problems)
        for line in good + [f"FAILED {b}" for b in bad]:
            print(line, flush=True)
        ok &= not bad
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
