"""What the archives of a results folder cost, per study and per channel.

    python benchmarks/archive_sizes.py [results]

Per study: archives, solves, bytes on disk, bytes per solve, traces stored of all traces, and per
channel the zstd-compressed size of its message payloads per solve (each channel compressed on its
own at the writer's level 3, in batches as the writer's chunks hold them: an estimate of its share of
the file, not a parse of the chunks).
"""

from __future__ import annotations

import sys
from collections import defaultdict
from pathlib import Path


def main(results: Path) -> None:
    import zstandard
    from mcap.reader import make_reader

    from pipeline.io.archive import read_archive

    zc = zstandard.ZstdCompressor(level=3)
    rows = defaultdict(lambda: defaultdict(int))
    for path in sorted(results.glob("*/runs/**/*.mcap")):
        sid = path.relative_to(results).parts[0]
        r = rows[sid]
        r["archives"] += 1
        r["bytes"] += path.stat().st_size
        a = read_archive(path)
        r["solves"] += len(a.solves)
        r["traces"] += int(a.trace_summary.get("traces", 0) or 0)
        r["stored"] += int(a.trace_summary.get("stored", 0) or 0)
        per = defaultdict(list)
        with open(path, "rb") as fh:
            for _, channel, msg in make_reader(fh).iter_messages():
                per[channel.topic].append(msg.data)
        for topic, msgs in per.items():
            r[topic] += len(zc.compress(b"".join(msgs)))
    topics = sorted({k for r in rows.values() for k in r if str(k).startswith("/")})
    head = ["study", "archives", "solves", "MB", "bytes/solve", "traces stored / all"] + [f"{t} B/solve" for t in topics]
    print(" | ".join(head))
    tot = defaultdict(int)
    for sid, r in sorted(rows.items()):
        for k, v in r.items():
            tot[k] += v
        n = max(1, r["solves"])
        print(" | ".join([sid, str(r["archives"]), str(r["solves"]), f"{r['bytes'] / 1e6:.1f}", f"{r['bytes'] / n:.0f}",
                          f"{r['stored']} / {r['traces']}"] + [f"{r[t] / n:.1f}" for t in topics]))
    n = max(1, tot["solves"])
    print(" | ".join(["all", str(tot["archives"]), str(tot["solves"]), f"{tot['bytes'] / 1e6:.1f}", f"{tot['bytes'] / n:.0f}",
                      f"{tot['stored']} / {tot['traces']}"] + [f"{tot[t] / n:.1f}" for t in topics]))


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "results"))
