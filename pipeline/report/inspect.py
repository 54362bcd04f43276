"""Text summary of one archive for ``python -m pipeline inspect``."""

from __future__ import annotations

import json

import numpy as np

from pipeline.io.archive import Archive
from pipeline.solvers import STOP_REASONS


def describe(arch: Archive, failed: bool = False, problem: int | None = None, csv_out: str | None = None) -> str:
    df = arch.frame()
    lines = [f"archive: {arch.path}"]
    for k in sorted(arch.metadata):
        v = arch.metadata[k]
        lines.append(f"  {k}: {v if len(v) < 200 else v[:197] + '...'}")
    n = len(df)
    if n == 0:
        lines.append("no solve records")
        return "\n".join(lines)
    ok = df["success"].to_numpy(bool)
    lines.append(f"solves: {n}   FK-verified successes: {ok.sum()} ({100 * ok.mean():.2f} %)")
    if "within_limits" in df:
        inside = ok & df["within_limits"].to_numpy(bool)
        lines.append(f"  successes within the robot file's joint limits: {inside.sum()} ({100 * inside.mean():.2f} %)")
    for code, cnt in df["stop_reason"].value_counts().sort_index().items():
        lines.append(f"  stop {code} {STOP_REASONS.get(code, '?')}: {cnt}")
    t = df["solve_time_s"].to_numpy() * 1e3
    p50, p95, p99 = np.percentile(t, [50, 95, 99])
    lines.append(f"solve time [ms], all problems: p50 {p50:.4f}  p95 {p95:.4f}  p99 {p99:.4f}  max {t.max():.4f}")
    if "call_time_s" in df:
        c = df["call_time_s"].to_numpy(float) * 1e3
        c50, c95, c99 = np.nanpercentile(c, [50, 95, 99])
        lines.append(f"call time [ms] (whole solve() call): p50 {c50:.4f}  p95 {c95:.4f}  p99 {c99:.4f}")
    it = df["iterations"].to_numpy()
    lines.append(f"iterations: p50 {np.percentile(it, 50):.0f}  p95 {np.percentile(it, 95):.0f}  max {it.max()}")
    if failed:
        bad = df[~ok]
        lines.append(f"failed solves ({len(bad)}):")
        lines.append("  problem_id  stop  iterations  position_error  orientation_error[rad]")
        for _, r in bad.iterrows():
            lines.append(f"  {r.problem_id:10d}  {r.stop_reason:4d}  {r.iterations:10d}  {r.position_error:14.6g}  {r.orientation_error:14.6g}")
    if problem is not None:
        rec = df[df["problem_id"] == problem]
        if rec.empty:
            lines.append(f"problem {problem}: not in this archive (ids {df['problem_id'].min()}..{df['problem_id'].max()})")
        else:
            lines.append(f"problem {problem}:")
            lines.append(json.dumps(arch.solves[int(rec.index[0])], indent=1))
            tr = next(arch.traces([problem]), None)
            if tr:
                lines.append("  iteration  error  |dp|")
                for k, (e, dp) in enumerate(zip(tr["error"], tr["position_error"])):
                    lines.append(f"  {k:9d}  {e:.12g}  {dp:.6g}")
    if csv_out:
        flat = df.drop(columns=["goal"]).copy()
        for col in ("q_start", "q_solution"):
            flat[col] = flat[col].map(lambda v: " ".join(f"{x:.17g}" for x in v))
        for col in ("info", "solutions"):
            if col in flat:
                flat[col] = flat[col].map(lambda v: json.dumps(v, separators=(",", ":")) if isinstance(v, (dict, list)) else "")
        flat.to_csv(csv_out, index=False)
        lines.append(f"wrote {csv_out}")
    return "\n".join(lines)
