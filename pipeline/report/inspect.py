"""Text summary of one archive for ``python -m pipeline inspect``.

Views
-----
summary (default)   metadata, then one row per solver (solver label, registered method and, where
                    the records carry one, ``info["strategy"]``): solves, successes, time
                    percentiles and iterations, every column with its unit; stop reasons per solver
``--failed``        adds one line per failed solve
``--problem N``     a short summary of one problem (stop reason text, times in ms, errors with
                    units, start and solution joints, the error trace as a short table);
                    with ``--json`` the raw record (strict JSON, NaN written null)
``--csv OUT``       one row per solve, one column per joint (``q_start_1`` ... ``q_solution_n``)
                    and per goal value (``goal_x_<unit>`` ... ``goal_qw``), units in the names

Joint values are radians for revolute joints and the robot file's length unit for prismatic
ones (the archive does not say which joint is which; the robot file does). Lengths (position
errors, goal positions) are in the archive's ``length_unit``. Counts are marked ``[count]``.
Built on numpy alone (no pandas): a 10 000-solve archive summarises in well under 2 s.
"""

from __future__ import annotations

import csv
import json
import math

import numpy as np

from pipeline.io.archive import Archive

TRACE_HEAD = 5  # trace rows shown at the start and at the end of a long trace


class InspectError(ValueError):
    """A request the archive cannot answer (one line naming the archive)."""


def _stop_texts() -> dict[int, str]:
    from pipeline.io.layout import STOP_REASONS

    return STOP_REASONS


def _unit(arch: Archive) -> str:
    units = {r.get("length_unit") for r in arch.solves} - {None, ""}
    if len(units) == 1:
        return units.pop()
    return arch.metadata.get("length_unit", "length_unit") if not units else "/".join(sorted(units))


def _col(recs: list[dict], key: str, dtype=float, default=math.nan) -> np.ndarray:
    out = [r.get(key, default) for r in recs]
    if dtype is float:
        return np.array([math.nan if v is None else v for v in out], dtype=float)
    return np.array(out, dtype=dtype)


def _group_key(r: dict) -> tuple[str, str, str]:
    info = r.get("info") or {}
    strategy = info.get("strategy") if isinstance(info, dict) else None
    return (str(r.get("solver", "")), str(r.get("method", "")), "" if strategy is None else str(strategy))


def _table(header: list[str], rows: list[list[str]], indent: str = "  ") -> list[str]:
    """Aligned columns: numbers right-aligned, text left-aligned."""
    widths = [max([len(h)] + [len(r[i]) for r in rows]) for i, h in enumerate(header)]
    text = [not all(_numeric(r[i]) for r in rows) for i in range(len(header))]

    def fmt(cells):
        return indent + "  ".join(c.ljust(w) if t else c.rjust(w) for c, w, t in zip(cells, widths, text)).rstrip()

    return [fmt(header)] + [fmt(r) for r in rows]


def _numeric(cell: str) -> bool:
    try:
        float(cell)
        return True
    except ValueError:
        return cell in ("-", "...", "")


def _pct(x: np.ndarray, q) -> list[float]:
    x = x[np.isfinite(x)]
    return [math.nan] * len(q) if not len(x) else [float(v) for v in np.percentile(x, q)]


def _g(v: float, spec: str = ".4g") -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, spec)


def summary(arch: Archive, failed: bool = False) -> list[str]:
    recs = arch.solves
    n = len(recs)
    unit = _unit(arch)
    lines = []
    probs, reps = arch.metadata.get("problems", "?"), arch.metadata.get("repetitions", "1")
    ok = _col(recs, "success", bool)
    lines.append(f"solves: {n} [count] (metadata: {probs} problems x {reps} repetitions)   "
                 f"FK-verified successes: {int(ok.sum())} ({100 * ok.mean():.2f} %)")
    keys = [_group_key(r) for r in recs]
    groups: dict[tuple, list[int]] = {}
    for i, k in enumerate(keys):
        groups.setdefault(k, []).append(i)
    strategies = any(k[2] for k in groups)
    within = _col(recs, "within_limits", bool, True)
    st = _col(recs, "solve_time_s") * 1e3
    ct = _col(recs, "call_time_s") * 1e3
    it = _col(recs, "iterations", float)
    stop = _col(recs, "stop_reason", int)
    header = (["solver", "method"] + (["strategy"] if strategies else [])
              + ["solves [count]", "successes [count]", "successes [%]", "successes within limits [%]",
                 "solve time p50 [ms]", "p95 [ms]", "p99 [ms]", "max [ms]", "call time p50 [ms]",
                 "iterations p50 [count]", "p95 [count]", "max [count]"])
    rows = []
    for (solver, method, strategy), idx in groups.items():
        ix = np.array(idx)
        s50, s95, s99 = _pct(st[ix], [50, 95, 99])
        c50, = _pct(ct[ix], [50])
        i50, i95 = _pct(it[ix], [50, 95])
        smax = float(np.nanmax(st[ix])) if np.isfinite(st[ix]).any() else math.nan
        good = ok[ix]
        rows.append([solver or "-", method or "-"] + ([strategy or "-"] if strategies else [])
                    + [str(len(ix)), str(int(good.sum())), f"{100 * good.mean():.2f}",
                       f"{100 * (good & within[ix]).mean():.2f}", _g(s50), _g(s95), _g(s99), _g(smax), _g(c50),
                       _g(i50, ".0f"), _g(i95, ".0f"), _g(float(np.nanmax(it[ix])), ".0f")])
    lines.append(f"per solver ({len(groups)}):")
    lines += _table(header, rows)
    texts = _stop_texts()
    codes = sorted(set(stop.tolist()))
    names = [k[0] + (f" ({k[2]})" if k[2] else "") for k in groups]
    srows = []
    for c in codes:
        srows.append([str(c), texts.get(c, "?")]
                     + [str(int((stop[np.array(idx)] == c).sum())) for idx in groups.values()])
    lines.append("stop reasons (solves per solver):")
    lines += _table(["stop", "reason"] + [f"{nm} [count]" for nm in names], srows)
    if failed:
        bad = np.flatnonzero(~ok)
        lines.append(f"failed solves ({len(bad)}):")
        frows = []
        for i in bad.tolist():
            r = recs[i]
            frows.append([str(r["problem_id"]), str(r.get("repetition", 0)), str(r.get("solver", "")),
                          str(r["stop_reason"]), str(r["iterations"]), _g(r.get("position_error"), ".6g"),
                          _g(r.get("orientation_error"), ".6g"), _g(r.get("solve_time_s", math.nan) * 1e3)])
        lines += _table(["problem_id", "repetition", "solver", "stop", "iterations [count]", f"position_error [{unit}]",
                         "orientation_error [rad]", "solve time [ms]"], frows)
    return lines


def _records_of(arch: Archive, problem: int) -> list[dict]:
    recs = [r for r in arch.solves if int(r["problem_id"]) == int(problem)]
    if not recs:
        ids = [int(r["problem_id"]) for r in arch.solves]
        have = f"ids {min(ids)}..{max(ids)}" if ids else "no solve records"
        raise InspectError(f"{arch.path}: problem {problem} is not in the archive ({have})")
    return recs


def _joints(q) -> str:
    return " ".join(f"{v:.6f}" if math.isfinite(v) else "nan" for v in q)


def problem_view(arch: Archive, problem: int) -> list[str]:
    recs = _records_of(arch, problem)
    r = recs[0]
    unit = r.get("length_unit") or _unit(arch)
    texts = _stop_texts()
    meta = arch.metadata
    ok = "success (FK-verified)" if r["success"] else "failure"
    claim = "success" if r.get("claimed_success") else "no success"
    g = r["goal"]
    p, o = g["position"], g["orientation"]
    lines = [f"problem {problem} (repetition {r.get('repetition', 0)}), study {meta.get('study', '?')}, "
             f"robot {r.get('robot', meta.get('robot', '?'))}",
             f"  solver: {r.get('solver', '')} (method {r.get('method') or meta.get('method', '?')})",
             f"  result: {ok}; stop reason {r['stop_reason']}: {texts.get(int(r['stop_reason']), '?')}; "
             f"the method's own test: {claim}",
             f"  iterations: {r['iterations']} [count]   within joint limits: "
             f"{'yes' if r.get('within_limits', True) else 'no'}",
             f"  solve time: {_g(r.get('solve_time_s', math.nan) * 1e3)} ms   IK-block time: "
             f"{_g(r.get('ik_time_s', math.nan) * 1e3)} ms   call time: {_g(r.get('call_time_s', math.nan) * 1e3)} ms",
             f"  position error: {_g(r.get('position_error'), '.6g')} {unit}   orientation error: "
             f"{_g(r.get('orientation_error'), '.6g')} rad   method's error: initial "
             f"{_g(r.get('initial_error'), '.6g')}, "
             f"final {_g(r.get('final_error'), '.6g')} [method's own measure]",
             f"  goal position [{unit}]: {p['x']:.6g} {p['y']:.6g} {p['z']:.6g}   orientation (x y z w): "
             f"{o['x']:.6f} {o['y']:.6f} {o['z']:.6f} {o['w']:.6f}",
             f"  chain: {r.get('chain', -1)}" + (" (independent)" if r.get("chain", -1) < 0 else
                                                 " (starts from the previous solution of its chain)"),
             "  joints [rad; prismatic joints in the robot file's length unit]:",
             f"    q_start:    {_joints(r['q_start'])}",
             f"    q_solution: {_joints(r['q_solution'])}"]
    info = r.get("info") or {}
    if info:
        lines.append("  info: " + ", ".join(f"{k}={v:.6g}" if isinstance(v, float) else f"{k}={v}"
                                            for k, v in info.items()))
    sols = arch.solutions(problem, r.get("repetition", 0))
    if sols is not None:
        lines.append(f"  analytic solutions: {len(sols)} [count]:")
        lines += [f"    {k + 1}: {_joints(q)}" for k, q in enumerate(sols)]
    if len(recs) > 1:
        t = np.array([x.get("solve_time_s", math.nan) for x in recs]) * 1e3
        lines.append(f"  repetitions: {len(recs)} [count], solve time p50 {_g(_pct(t, [50])[0])} ms, "
                     f"successes {sum(bool(x['success']) for x in recs)} [count] "
                     f"(shown: repetition {r.get('repetition', 0)})")
    key = (int(problem), int(r.get("repetition", 0)))
    held = arch.trace_index().get(key) or arch.trace_index().get((key[0], 0))
    if held is None:
        lines.append("  trace: none archived")
        return lines
    if held[2] is None:
        lines.append(f"  trace: {held[0]} rows, not stored ({str(arch.not_stored(*key)).split(': ', 1)[1]})")
        return lines
    tr = next(arch.traces([problem]))
    e, dp = tr["error"], tr["position_error"]
    ev = np.asarray(tr["error_vector"], dtype=float).reshape(-1, 6)
    m = len(e)
    show = (list(range(m)) if m <= 2 * TRACE_HEAD + 1
            else list(range(TRACE_HEAD)) + [-1] + list(range(m - TRACE_HEAD, m)))
    rows = []
    for k in show:
        if k < 0:
            rows.append(["...", "", "", ""])
            continue
        rows.append([str(k), _g(e[k], ".6g"), _g(dp[k], ".6g"), _g(float(np.linalg.norm(ev[k, 3:])), ".6g")])
    lines.append(f"  trace ({m} rows: iterate 0 = the start):")
    lines += _table(["iteration", "error [method's own measure]", f"|dp| [{unit}]", "|e_omega| [rad]"], rows,
                    indent="    ")
    return lines


def raw_record(arch: Archive, problem: int) -> str:
    """The problem's record(s) as strict JSON (NaN -> null): one object, or a list for several repetitions."""
    import orjson

    recs = []
    for r in _records_of(arch, problem):
        out = {k: v for k, v in r.items() if not k.startswith("_")}
        sols = arch.solutions(problem, r.get("repetition", 0))
        if sols is not None:
            out["solutions"] = sols
        recs.append(out)
    return orjson.dumps(recs[0] if len(recs) == 1 else recs, option=orjson.OPT_INDENT_2).decode()


_SCALARS = (("problem_id", ""), ("repetition", ""), ("chain", ""), ("robot", ""), ("solver", ""), ("method", ""),
            ("success", ""), ("claimed_success", ""), ("within_limits", ""), ("stop_reason", ""),
            ("iterations", ""), ("solve_time_s", ""), ("ik_time_s", ""), ("call_time_s", ""),
            ("initial_error", ""), ("final_error", ""), ("position_error", "L"), ("orientation_error", "_rad"))


def write_csv(arch: Archive, out: str) -> int:
    """One row per solve; returns the number of rows. Columns: see the module docstring."""
    recs = arch.solves
    unit = _unit(arch)
    n = max((len(r["q_start"]) for r in recs), default=0)
    info_keys = sorted({k for r in recs for k, v in (r.get("info") or {}).items()
                        if v is None or isinstance(v, (bool, int, float, str))})
    any_sol = any(r.get("_n_solutions") is not None for r in recs)
    header = ([k + (f"_{unit}" if u == "L" else u) for k, u in _SCALARS] + ["length_unit"]
              + [f"q_start_{j}" for j in range(1, n + 1)] + [f"q_solution_{j}" for j in range(1, n + 1)]
              + [f"goal_{a}_{unit}" for a in "xyz"] + [f"goal_q{a}" for a in "xyzw"]
              + [f"info_{k}" for k in info_keys] + (["solutions_json"] if any_sol else []))

    def num(v):
        if v is None or (isinstance(v, float) and not math.isfinite(v)):
            return ""
        return repr(float(v)) if isinstance(v, float) else str(v)

    with open(out, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for r in recs:
            g = r["goal"]
            info = r.get("info") or {}
            qs, qe = list(r["q_start"]), list(r["q_solution"])
            row = ([num(r.get(k)) for k, _ in _SCALARS] + [r.get("length_unit", "")]
                   + [num(v) for v in qs + [None] * (n - len(qs))] + [num(v) for v in qe + [None] * (n - len(qe))]
                   + [num(g["position"][a]) for a in "xyz"] + [num(g["orientation"][a]) for a in "xyzw"]
                   + [num(info.get(k)) if not isinstance(info.get(k), str) else info[k] for k in info_keys])
            if any_sol:
                s = arch.solutions(r["problem_id"], r.get("repetition", 0))
                row.append("" if s is None else json.dumps(s, separators=(",", ":")))
            w.writerow(row)
    return len(recs)


def describe(arch: Archive, failed: bool = False, problem: int | None = None, csv_out: str | None = None,
             raw: bool = False) -> str:
    """The text ``inspect`` prints (see the module docstring); InspectError for a problem id not in the archive."""
    if raw:
        if problem is None:
            raise InspectError(f"{arch.path}: --json prints one problem's raw record: give --problem N")
        return raw_record(arch, problem)
    lines = [f"archive: {arch.path}"]
    if problem is not None:
        lines += problem_view(arch, problem)
    else:
        for k in sorted(arch.metadata):
            v = arch.metadata[k]
            lines.append(f"  {k}: {v if len(v) < 200 else v[:197] + '...'}")
        t = arch.trace_summary
        if t:
            lines.append(f"traces stored: {t.get('stored', '?')} of {t.get('traces', '?')} [count], "
                         f"{t.get('rows_stored', '?')} of {t.get('rows', '?')} rows ({t.get('policy', '')}; the others: "
                         f"`python -m pipeline reproduce {arch.path} --problem N`)")
        if not arch.solves:
            lines.append("no solve records")
        else:
            lines += summary(arch, failed)
    if csv_out:
        rows = write_csv(arch, csv_out)
        lines.append(f"wrote {csv_out}: {rows} rows")
    return "\n".join(lines)
