"""``python -m pipeline <verb>``: parse arguments, load, call a library function, write.

Verbs (each one is also a Snakemake rule of the same name):

check_inputs      validate config, study settings and robot files (one line per problem)
make_problems     write a study's seeded problem set for one robot
solve_problems    solve every problem of a set with one registered solver, write an MCAP archive
solvers           list the registered IK solvers, their settings, defaults and units
new_study         write a study YAML that runs registered solvers on your robots
rerun_failures    rerun one archive's failed problems with changed stop rules (Table 16 of 000)
aggregate_tables  compute a study's tables from its archives, beside the published values
plot_figures      render a study's figures from its archives
render_report     assemble results/report.html
inspect           summarise an archive per solver (counts, success, times with units), one problem, CSV
replay            re-run archived problems into a Foxglove-viewable MCAP (arm, goal, joints per iteration)
verify            recompute every table from the archives, check archives and report (exit 1 on a difference)
import_urdf       write a robot file (general joint form) from a URDF chain (also: import-urdf)
export_urdf       write a robot file as a URDF, base_link ... tool0, metres (also: export-urdf)
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import yaml

# numpy and the pipeline's modules are imported inside the commands: `--help` stays fast


class CLIError(Exception):
    """A usage problem found after parsing (one line, printed as ``error: ...``)."""


def _progress(done: int, total: int, t0: float, extra: str = "") -> None:
    print(f"[{time.monotonic() - t0:7.1f} s] {done}/{total} {extra}", file=sys.stderr, flush=True)


def _load_config(args) -> dict:
    """The run config file with ``--set KEY=VALUE`` overrides (values parsed as YAML); each source is
    validated on its own, so an error names the file or the ``--set`` that holds the bad value."""
    from pipeline.settings import ConfigError, load_config_file, validate_config_part
    from pipeline.yamlio import YAMLInputError, parse_yaml

    config = dict(load_config_file(args.config))
    for kv in args.set or []:
        k, sep, v = kv.partition("=")
        if not sep:
            raise CLIError(f"--set {kv!r}: expected KEY=VALUE")
        try:
            value = parse_yaml(v, f"--set {k}")
        except YAMLInputError as exc:
            raise ConfigError(str(exc)) from None
        validate_config_part({k: value}, f"--set {k}")
        config[k] = value
    return config


def cmd_check_inputs(args) -> None:
    from pipeline.settings import check_inputs

    config = _load_config(args)
    studies = check_inputs(config, config_path=args.config)
    print(f"ok: {len(studies)} studies, scale={config['scale']}: " + ", ".join(s.id for s in studies))


def _problem_set(study, args) -> dict:
    if args.problem_set not in study.problem_sets:
        raise CLIError(f"{args.study}: field 'problem_sets/{args.problem_set}': no such problem set "
                       f"(have: {', '.join(study.problem_sets) or 'none'})")
    return study.problem_sets[args.problem_set]


def cmd_make_problems(args) -> None:
    from pipeline.io.problems import write_problems
    from pipeline.problems import ProblemSpecError, make_problem_set
    from pipeline.robots import load_robot
    from pipeline.settings import ConfigError, file_sha256, load_study

    study = load_study(args.study)
    spec = _problem_set(study, args)
    model = load_robot(args.robot)
    if model.name not in study.set_robots(args.problem_set):
        raise CLIError(f"{args.study}: field 'problem_sets/{args.problem_set}/robots': {model.name!r} is not one "
                       f"of {study.set_robots(args.problem_set)}")
    count = study.count(args.problem_set, args.scale)
    import numpy as np

    # one independent stream per robot, derived from the set's seed
    rng = np.random.default_rng([spec["seed"], sum(model.name.encode())])
    try:
        ps = make_problem_set(spec, model, count, rng, Path(args.data), args.scale)
    except ProblemSpecError as exc:
        raise ConfigError(f"{args.study}: problem_sets/{args.problem_set}: {exc}") from None
    if ps.robot != model.name or ps.q_start.shape[1:] != (model.n,):
        raise CLIError(f"problem set {args.problem_set}: the generator returned problems for {ps.robot!r} "
                       f"with {ps.q_start.shape[1]} joints, not {model.name!r} with {model.n}")
    write_problems(args.out, ps, {"study": study.id, "problem_set": args.problem_set, "kind": spec["kind"],
                                  "seed": spec["seed"], "scale": args.scale, "count": len(ps),
                                  "robot_sha256": file_sha256(args.robot)[:16]})
    print(f"wrote {len(ps)} problems of set {args.problem_set} for {model.name} to {args.out}")


def _solve_to_archive(args, entry, out, limit=0, select=None, extra_meta=None) -> None:
    """Solve the problems of ``args.problems`` (the first ``limit`` or all, or the ids in ``select``) into ``out``."""
    import pipeline
    from pipeline.io.archive import FORMAT_VERSION, ArchiveWriter, batch_columns
    from pipeline.io.problems import read_problems
    from pipeline.robots import LENGTH_UNITS, load_robot
    from pipeline.runner import solve_set_batches
    from pipeline.provenance import environment
    from pipeline.settings import file_sha256, git_commit, load_study

    study = load_study(args.study)
    spec = _problem_set(study, args)
    model = load_robot(args.robot)
    ps, _ = read_problems(args.problems)
    if ps.robot != model.name:
        raise CLIError(f"{args.problems}: header field 'robot': {ps.robot!r} but the robot file is {model.name!r}")
    if limit and limit < len(ps):
        ps = ps.head(limit)
    reps = study.repetitions(args.problem_set, args.scale)
    settings = entry.settings
    unit = settings.length_unit
    to_unit = LENGTH_UNITS[ps.length_unit] / LENGTH_UNITS[unit]
    import numpy as np

    n_sel = len(ps) if select is None else int(np.isin(ps.problem_id, list(select)).sum())
    meta = {
        "format_version": FORMAT_VERSION, "study": study.id, "problem_set": args.problem_set, "robot": model.name,
        "solver": entry.label, "method": entry.method, "reading": entry.reading,
        "settings": json.dumps(entry.as_dict(), sort_keys=True),
        "settings_hash": study.solver_hash(args.problem_set, entry.label, args.scale),
        "seed": str(spec["seed"]), "scale": args.scale, "problems": str(n_sel), "repetitions": str(reps),
        "problem_file": Path(args.problems).name, "problem_sha256": file_sha256(args.problems)[:16],
        "problem_path": os.path.relpath(Path(args.problems).resolve(), Path(out).resolve().parent),
        "robot_file": str(args.robot), "robot_sha256": file_sha256(args.robot)[:16],
        "robot_path": os.path.relpath(Path(args.robot).resolve(), Path(out).resolve().parent),
        **({"robot_repairs": "; ".join(model.repairs)} if model.repairs else {}),
        "length_unit": unit, "package_version": pipeline.__version__, "git_commit": git_commit(),
        "timing": "solve_time_s = the method's own computation on the monotonic clock; call_time_s = the whole "
                  "solve() call (pipeline/solvers/timing.py)",
        "environment": json.dumps(environment(), sort_keys=True),
        **(extra_meta or {}),
    }
    keep_traces = bool(study.doc.get("archive_traces", True))
    derive = _derivable(entry.method, settings)
    meta["derive"] = derive
    meta["traces"] = ((f"derived ({derive}): digests stored, re-derived on demand (pipeline.io.archive.derive)"
                       if derive else "stored per problem") if keep_traces else "none (study setting archive_traces: false)")
    t0 = time.monotonic()
    n_ok = done = 0
    total = n_sel * reps
    shown = 0
    threads = max(1, int(getattr(args, "threads", 1) or 1))
    t_solve = t_write = 0.0
    with ArchiveWriter(out, meta, derive=bool(derive)) as w:
        for rows, rep, q0, res in solve_set_batches(entry.method, settings, model, ps, repetitions=reps,
                                                    set_seed=spec["seed"], select=select, threads=threads):
            t_solve += res.call_time_s
            tw = time.perf_counter()
            cols, traces = batch_columns(ps.problem_id[rows], rep, ps.chain[rows], model.name, entry.label, unit, q0,
                                         ps.goal_position[rows] * to_unit, ps.goal_quat[rows], res, method=entry.method,
                                         start_from_file=np.all(q0 == ps.q_start[rows], axis=1))
            # repetitions repeat the same iterates: one trace per problem (none when the study says so)
            if traces is not None and (not keep_traces or reps > 1):
                traces = None if not keep_traces else _first_repetition(traces)
            w.write_columns(cols, traces)
            t_write += time.perf_counter() - tw
            n_ok += int(res.success.sum())
            done += len(rows)
            if done * 10 // max(1, total) > shown or done == total:
                shown = done * 10 // max(1, total)
                _progress(done, total, t0, f"solved, {n_ok} FK-verified successes")
        tw = time.perf_counter()
    t_write += time.perf_counter() - tw  # the last chunks and the summary, written on closing
    print(f"wrote {out}: {total} solves, {n_ok} FK-verified successes; solving {t_solve:.3f} s, "
          f"archiving {t_write:.3f} s ({t_write / max(t_solve, 1e-9):.2f} of the solving time)")


def _first_repetition(traces: dict) -> dict:
    """The traces of repetition 0 only."""
    import numpy as np

    keep = traces["repetition"] == 0
    rows = np.repeat(keep, traces["rows"])
    return {"problem_id": traces["problem_id"][keep], "repetition": traces["repetition"][keep],
            "rows": traces["rows"][keep], "full": traces["full"][rows]}


def _derivable(method: str, settings) -> str:
    """How the traces and analytic solutions of a job can be re-derived from its archive, which then
    stores their digests only (``pipeline.io.archive.derive``):

    ``"rerun"``  re-run the solve bit for bit: this package's own methods and the closed forms of
                 ur_analytic_ik (deterministic), without a wall-time budget;
    ``"fk"``     recompute the trace from the record by this package's FK
                 (:func:`pipeline.solvers.peers.trace_from_record`): the other peers (racing threads,
                 C ``rand()`` state) run once from the archived start (no restarts, no time budget);
    ``""``       neither: traces and solutions stored in full.
    """
    from pipeline.solvers import get

    spec = get(method)
    budget = float(getattr(settings, "time_budget", 0.0) or 0.0) > 0.0
    peer = spec.run.__module__.startswith("pipeline.solvers.peers")
    if budget:
        return ""
    if not peer or method == "ur_analytic_ik":
        return "rerun"
    return "" if int(getattr(settings, "restarts", 0) or 0) else "fk"


def _study_solver(args):
    from pipeline.settings import load_study

    study = load_study(args.study)
    if args.solver not in study.solvers:
        raise CLIError(f"{args.study}: field 'solvers/{args.solver}': no such solver (have: {', '.join(study.solvers)})")
    return study, study.solvers[args.solver]


def cmd_solve_problems(args) -> None:
    """One archive per (problem set, solver label) given: several run in turn in one process.

    ``--problem-set`` and ``--problems`` pair up; ``--out`` holds one archive per set and label,
    set-major (all labels of the first set, then of the second...).
    """
    from argparse import Namespace

    from pipeline.settings import load_study

    if len(args.problem_set) != len(args.problems):
        raise CLIError(f"--problem-set names {len(args.problem_set)} sets but --problems {len(args.problems)} files")
    jobs = [(ps, pf, label) for ps, pf in zip(args.problem_set, args.problems) for label in args.solver]
    if len(jobs) != len(args.out):
        raise CLIError(f"{len(args.problem_set)} problem set(s) x {len(args.solver)} solver(s) need {len(jobs)} "
                       f"--out archives, got {len(args.out)}")
    study = load_study(args.study)
    for k, ((pset, pfile, label), out) in enumerate(zip(jobs, args.out)):
        one = Namespace(**{**vars(args), "problem_set": pset, "problems": pfile})
        _problem_set(study, one)
        if label not in study.solvers:
            raise CLIError(f"{args.study}: field 'solvers/{label}': no such solver (have: {', '.join(study.solvers)})")
        if label not in study.set_solvers(pset):
            raise CLIError(f"{args.study}: field 'problem_sets/{pset}/solvers': {label!r} does not run on this set")
        if len(jobs) > 1:
            print(f"[{k + 1}/{len(jobs)}] {pset}: {label}", flush=True)
        limit = min(x for x in (study.solver_cap(pset, label, args.scale), args.limit or None, 10**12)
                    if x is not None)
        _solve_to_archive(one, study.solvers[label], out, limit=limit)


def cmd_rerun_failures(args) -> None:
    from dataclasses import replace

    from pipeline.io.archive import read_archive
    from pipeline.solvers import SettingsError

    study, entry = _study_solver(args)
    overrides = study.settings.get("rerun")
    if not overrides:
        raise CLIError(f"{args.study}: field 'study_settings/rerun': missing (the rerun's setting overrides)")
    try:
        rerun = replace(entry.settings, **overrides)
    except TypeError as exc:
        raise SettingsError(f"{args.study}: field 'study_settings/rerun': {exc}") from None
    rerun.validate(f"{args.study}: study_settings/rerun")
    original = read_archive(args.archive)
    if original.metadata["solver"] != args.solver:
        raise CLIError(f"{args.archive}: metadata field 'solver' is {original.metadata['solver']!r}, expected {args.solver!r}")
    failed = [r["problem_id"] for r in original.solves if not r["success"]]
    _solve_to_archive(args, replace(entry, settings=rerun), args.out, select=failed, extra_meta={
        "rerun_of": Path(args.archive).name, "rerun_of_settings_hash": original.metadata["settings_hash"]})


def cmd_new_study(args) -> None:
    """Write ``data/studies/<id>.yaml``: a warm-start problem set on the given robots and solvers."""
    from pipeline.robots import load_robot
    from pipeline.settings import ConfigError, load_study
    from pipeline.solvers import NotApplicableError, get, make_settings, names, prepare

    if not args.id.replace("_", "a").isalnum() or not args.id.islower() or "__" in args.id:
        raise CLIError(f"study id {args.id!r}: use lowercase letters, digits and single underscores")
    out = Path(args.data) / "studies" / f"{args.id}.yaml"
    if out.exists() and not args.force:
        raise CLIError(f"{out}: exists (use --force to overwrite)")
    models = [load_robot(Path(args.data) / "robots" / f"{r}.yaml") for r in args.robots]
    wanted = args.solvers or names()
    for name in wanted:
        get(name)
    solvers, skipped = [], []
    for name in wanted:
        fits = []
        for m in models:
            try:
                prepare(name, m, make_settings(name))
                fits.append(m.name)
            except NotApplicableError as exc:
                skipped.append(str(exc))
        if len(fits) == len(models):
            solvers.append(name)
    if not solvers:
        raise CLIError("no solver applies to every robot given: " + "; ".join(skipped[:3]))
    lines = [
        f"# Written by `python -m pipeline new_study {args.id}`; edit freely (schema: workflow/schemas/study.schema.yaml).",
        "# Settings of each solver: `python -m pipeline solvers NAME` (SI units; registry defaults where not written).",
        f"study: {args.id}",
        f"title: {json.dumps(args.title or 'IK methods on ' + ', '.join(args.robots))}",
        "document: \"none\"",
        f"robots: [{', '.join(args.robots)}]",
        "problem_sets:",
        "  warm:  # goals within the joint limits, starts within `spread` rad of the goal angles",
        f"    kind: warm_start\n    seed: {args.seed}\n    count: {{full: {args.count}, quick: 20}}\n    params: {{spread: {args.spread}}}",
        "solvers:",
        *[f"  {n}: {{method: {n}}}" for n in solvers],
        "interpretations: []",
    ]
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    try:
        load_study(out)
    except ConfigError:
        out.unlink()
        raise
    for why in skipped:
        print(f"skipped: {why}")
    print(f"wrote {out} ({len(solvers)} solvers); build it with: snakemake --cores 2 --config studies='[{args.id}]'")


def cmd_solvers(args) -> None:
    """Print every registered solver with its settings, defaults and units (or one, or as JSON)."""
    from pipeline.solvers import catalogue, get

    cat = catalogue()
    if args.name:
        get(args.name)  # one-line error for an unknown name
        cat = [c for c in cat if c["name"] == args.name]
    if args.json:
        print(json.dumps(cat, indent=1, default=str))
        return
    for c in cat:
        print(f"{c['name']}  [{c['kind']}]  {c['title']}")
        if c["source"]:
            print(f"    source: {c['source']}")
        for row in c["settings"]:
            unit = f" [{row['unit']}]" if row["unit"] else ""
            rng = f" ({row['range']})" if row["range"] else ""
            print(f"    {row['name']} = {row['default']!r}{unit}{rng}: {row['doc']}")
        print()


def _results_relative(path, sid: str) -> str:
    """An archive's path from the results folder on (``<study>/runs/...``), so a copied build stays valid."""
    parts = Path(path).parts
    return "/".join(parts[len(parts) - 1 - parts[::-1].index(sid):]) if sid in parts else Path(path).as_posix()


def cmd_aggregate_tables(args) -> None:
    from pipeline.io.archive import read_archive
    from pipeline.settings import load_study
    from pipeline.studies import build_study_tables, write_tables

    study = load_study(args.study)
    archives = [read_archive(p) for p in args.archives]
    tables = build_study_tables(study, archives, Path(args.published))
    write_tables(tables, Path(args.out_dir))
    prov = [{"archive": _results_relative(a.path, study.id), "problems": len(a.solves), **a.metadata}
            for a in archives]
    (Path(args.out_dir) / "provenance.json").write_text(json.dumps(prov, indent=1))
    print(f"wrote {len(tables)} tables to {args.out_dir}")


def cmd_plot_figures(args) -> None:
    from pipeline.io.archive import read_archive
    from pipeline.settings import load_study
    from pipeline.studies import get_study_module, write_figure_index

    study = load_study(args.study)
    archives = [read_archive(p) for p in args.archives]
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figs = get_study_module(study.id).build_figures(study, archives, out)
    write_figure_index(figs, out)
    print(f"wrote {len(figs)} figures to {args.out_dir}")


def cmd_render_report(args) -> None:
    from pipeline.report.html import render_report
    from pipeline.settings import check_inputs

    config = _load_config(args)
    studies = check_inputs(config, config_path=args.config)
    render_report(studies, config, Path(config["results_dir"]), Path(args.out))
    print(f"wrote {args.out}")


def cmd_verify(args) -> None:
    """Recompute every table from its archives, check the archives and the report; exit 1 on any difference."""
    from pipeline.verify import verify

    ok, lines = verify(Path(args.results), Path(args.data))
    print("\n".join(lines))
    if not ok:
        raise SystemExit(1)


def cmd_inspect(args) -> None:
    from pipeline.io.archive import read_archive
    from pipeline.report.inspect import InspectError, describe

    arch = read_archive(args.archive, problems=args.problems)
    arch.robot_file = args.robot
    try:
        print(describe(arch, failed=args.failed, problem=args.problem, csv_out=args.csv, raw=args.json))
    except InspectError as exc:
        raise CLIError(str(exc)) from None


def cmd_replay(args) -> None:
    """Re-run archived problems and write them as a Foxglove-viewable MCAP (pipeline/replay.py)."""
    from pipeline.replay import ReplayError, replay

    try:
        s = replay(args.archive, args.out, problem=args.problem, failed=args.failed, data=args.data,
                   robot=args.robot, frames=args.frames, max_frames=args.max_frames, dt=args.dt,
                   problems=args.problems)
    except ReplayError as exc:
        raise CLIError(str(exc)) from None
    for line in s.mismatches:
        print(f"warning: {line}", file=sys.stderr)
    per = ", ".join(f"{p}: {n}" for p, n in list(s.frames_per_problem.items())[:5])
    more = " ..." if len(s.frames_per_problem) > 5 else ""
    print(f"wrote {s.out}: {len(s.problems)} problem(s), {s.frames} frames ({s.mode}; frames per problem {per}{more}); "
          f"topics {', '.join(s.topics)}")


def _write_checked(out: Path, text: str, check) -> None:
    """Write ``text`` to ``out`` only after ``check(tmp_path)`` accepted it (temp file, then rename)."""
    import os
    import shutil
    import tempfile

    out.parent.mkdir(parents=True, exist_ok=True)
    tmpdir = Path(tempfile.mkdtemp(prefix=".tmp-", dir=out.parent))
    try:
        tmp = tmpdir / out.name  # same file name: a robot file's name must equal its stem
        tmp.write_text(text)
        check(tmp)
        os.replace(tmp, out)
    finally:
        shutil.rmtree(tmpdir, ignore_errors=True)


def cmd_import_urdf(args) -> None:
    """Write ``--out`` (a robot file, general joint form) from the URDF chain ``--base`` ... ``--tip``."""
    from pipeline.robots import load_robot
    from pipeline.urdf import URDFImportError, imported_yaml

    out = Path(args.out)
    name = args.name or out.stem
    if name != out.stem:
        raise CLIError(f"--name {name!r}: a robot file's name must equal its file name; use --out "
                       f"{out.with_name(name + (out.suffix or '.yaml'))}")
    try:
        text = imported_yaml(args.urdf, args.base, args.tip, name=name, length_unit=args.length_unit)
    except URDFImportError as exc:
        raise CLIError(f"URDFImportError: {exc}") from None
    _write_checked(out, text, load_robot)
    model = load_robot(out)
    print(f"wrote {out}: {model.n} joints ({''.join('P' if p else 'R' for p in model.chain.prismatic)}), "
          f"links {args.base} -> {args.tip}, lengths in {model.length_unit}")


def cmd_export_urdf(args) -> None:
    """Write ``--out`` (URDF, metres, links base_link ... tool0) from a robot file; re-imported and checked first."""
    import numpy as np

    from pipeline.kinematics import fk_htm
    from pipeline.robots import load_robot, parse_robot
    from pipeline.urdf import URDFImportError, import_urdf, to_urdf

    model = load_robot(args.robot)
    text = to_urdf(model, name=args.name)

    def check(tmp: Path) -> None:
        try:
            back = parse_robot(import_urdf(tmp, "base_link", "tool0", name=model.name, length_unit=model.length_unit),
                               str(tmp))
        except URDFImportError as exc:
            raise CLIError(f"the written URDF does not import back ({exc})") from None
        rng = np.random.default_rng(0)
        lo = np.where(np.isfinite(model.limits[:, 0]), model.limits[:, 0], -np.pi)
        hi = np.where(np.isfinite(model.limits[:, 1]), model.limits[:, 1], np.pi)
        q = rng.uniform(lo, hi, (20, model.n))
        T0, T1 = fk_htm(model.chain, q), fk_htm(back.chain, q)
        tol = 1e-9 * (1.0 + np.abs(T0[..., :3, 3]).max())
        if back.n != model.n or not np.allclose(T0, T1, rtol=0, atol=tol):
            raise CLIError(f"{model.path}: the written URDF's forward kinematics differs from the robot file's "
                           f"(max {np.abs(T0 - T1).max():.3g}); not written")

    _write_checked(Path(args.out), text, check)
    print(f"wrote {args.out}: {model.n} joints, links base_link -> tool0, lengths in m")


class _VerbHelp(argparse.HelpFormatter):
    """Help that lists each verb on one line (without argparse's extra ``VERB`` header line)."""

    def _format_action(self, action):
        if isinstance(action, argparse._SubParsersAction):
            return "".join(self._format_action(a) for a in action._get_subactions())
        return super()._format_action(action)


def build_parser() -> argparse.ArgumentParser:
    # the verbs are listed once, by the subparsers (one line each); the description is the first line
    ap = argparse.ArgumentParser(
        prog="python -m pipeline", description=__doc__.splitlines()[0].replace("``", "")
        + " Each verb is also a Snakemake rule of the same name; `python -m pipeline VERB --help` for its options.",
        formatter_class=lambda prog: _VerbHelp(prog, max_help_position=34, width=140))
    sub = ap.add_subparsers(dest="verb", required=True, metavar="VERB", title="verbs")

    p = sub.add_parser("check_inputs", help="validate config, study settings and robot files")
    p.add_argument("--config", default="workflow/config/config.yaml")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a config key (like --config)")
    p.set_defaults(func=cmd_check_inputs)

    p = sub.add_parser("make_problems", help="write a seeded problem set")
    p.add_argument("--study", required=True, help="data/studies/<id>.yaml")
    p.add_argument("--problem-set", required=True, help="a key of the study's `problem_sets`")
    p.add_argument("--robot", required=True, help="data/robots/<name>.yaml")
    p.add_argument("--scale", choices=["full", "quick"], default="full")
    p.add_argument("--data", default="data", help="data folder (generators may read files there)")
    p.add_argument("--out", required=True, help="output CSV")
    p.set_defaults(func=cmd_make_problems)

    p = sub.add_parser("solve_problems", help="solve a problem set with one solver into an MCAP archive")
    p.add_argument("--study", required=True)
    p.add_argument("--problem-set", required=True, nargs="+", help="problem set(s) of the study")
    p.add_argument("--robot", required=True)
    p.add_argument("--solver", required=True, nargs="+",
                   help="solver label(s) of the study (`solvers` or a reading variant); several run in turn")
    p.add_argument("--problems", required=True, nargs="+", help="problem-set CSV(s) from make_problems, one per set")
    p.add_argument("--scale", choices=["full", "quick"], default="full")
    p.add_argument("--limit", type=int, default=0, help="solve only the first N problems (debugging)")
    p.add_argument("--threads", type=int, default=1,
                   help="compiled threads of batch-solved methods (default 1; results do not depend on it, "
                        "per-solve times do when the cores are shared)")
    p.add_argument("--out", required=True, nargs="+",
                   help="output .mcap, one per (set, label), set-major")
    p.set_defaults(func=cmd_solve_problems)

    p = sub.add_parser("rerun_failures", help="rerun a solver's failed problems with the study's rerun overrides")
    p.add_argument("--study", required=True)
    p.add_argument("--problem-set", required=True)
    p.add_argument("--robot", required=True)
    p.add_argument("--solver", required=True)
    p.add_argument("--problems", required=True)
    p.add_argument("--archive", required=True, help="the solver's archive (its failures are rerun)")
    p.add_argument("--scale", choices=["full", "quick"], default="full")
    p.add_argument("--out", required=True)
    p.set_defaults(func=cmd_rerun_failures)

    p = sub.add_parser("new_study", help="write a study YAML running registered solvers on your robots")
    p.add_argument("id", help="study id (file data/studies/<id>.yaml)")
    p.add_argument("--robots", nargs="+", required=True, help="robot ids (data/robots/<id>.yaml)")
    p.add_argument("--solvers", nargs="*", help="registered solver names (default: every one that applies)")
    p.add_argument("--count", type=int, default=500, help="problems per robot at full scale (default 500)")
    p.add_argument("--spread", type=float, default=0.3, help="start-angle noise around the goal angles [rad]")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--title", default="")
    p.add_argument("--data", default="data", help="data folder")
    p.add_argument("--force", action="store_true", help="overwrite an existing study file")
    p.set_defaults(func=cmd_new_study)

    p = sub.add_parser("solvers", help="list the registered IK solvers with their settings and defaults")
    p.add_argument("name", nargs="?", help="show one solver")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=cmd_solvers)

    for verb, fn, what in (("aggregate_tables", cmd_aggregate_tables, "tables (CSV)"),
                           ("plot_figures", cmd_plot_figures, "figures (PNG/SVG)")):
        p = sub.add_parser(verb, help=f"a study's {what} from its archives")
        p.add_argument("--study", required=True)
        p.add_argument("--archives", nargs="+", required=True)
        p.add_argument("--published", default="data/published", help="folder of the documents' tables")
        p.add_argument("--out-dir", required=True)
        p.set_defaults(func=fn)

    p = sub.add_parser("render_report", help="assemble the self-contained HTML report")
    p.add_argument("--config", default="workflow/config/config.yaml")
    p.add_argument("--set", action="append", metavar="KEY=VALUE")
    p.add_argument("--out", required=True)
    p.set_defaults(func=cmd_render_report)

    p = sub.add_parser("verify", help="recompute every table from its archives and check archives and report")
    p.add_argument("results", nargs="?", default="results", help="results folder (default results)")
    p.add_argument("--data", default="data", help="data folder (study settings, published tables)")
    p.set_defaults(func=cmd_verify)

    p = sub.add_parser("inspect", help="summarise an archive")
    p.add_argument("archive")
    p.add_argument("--failed", action="store_true", help="list the failed solves")
    p.add_argument("--problem", type=int, help="a short summary of one problem (times, errors, joints, trace)")
    p.add_argument("--json", action="store_true", help="with --problem: print the raw record as JSON")
    p.add_argument("--csv", metavar="OUT", help="export the solve records as CSV (one column per joint and goal value)")
    p.add_argument("--problems", metavar="FILE", help="the archive's problem set, if it is not where the archive's "
                   "metadata says (an archive copied out of its results tree; its SHA-256 is still checked)")
    p.add_argument("--robot", metavar="FILE", help="the robot file, to re-derive traces and analytic solutions, if "
                   "not where the archive's metadata says")
    p.set_defaults(func=cmd_inspect)

    p = sub.add_parser("replay", help="re-run archived problems into a Foxglove-viewable MCAP (arm per iteration)")
    p.add_argument("archive")
    which = p.add_mutually_exclusive_group(required=True)
    which.add_argument("--problem", type=int, help="replay one problem id")
    which.add_argument("--failed", action="store_true", help="replay every failed solve")
    which.add_argument("--all", action="store_true", help="replay every solve (a path study: the arm follows its path)")
    p.add_argument("-o", "--out", required=True, help="replay MCAP to write")
    p.add_argument("--data", default="data", help="data folder (robot file <data>/robots/<robot>.yaml)")
    p.add_argument("--robot", help="the robot file, if not <data>/robots/<robot>.yaml")
    p.add_argument("--problems", metavar="FILE", help="the archive's problem set, if it is not where the archive's "
                   "metadata says")
    p.add_argument("--frames", choices=["auto", "iterations", "solutions"], default="auto",
                   help="per-iteration frames, or one frame per problem (default: solutions for a chained path "
                        "under --all, else iterations)")
    p.add_argument("--max-frames", type=int, default=200, help="at most this many iteration frames per problem")
    p.add_argument("--dt", type=float, default=0.05, help="seconds between frames (log times)")
    p.set_defaults(func=cmd_replay)

    p = sub.add_parser("import_urdf", aliases=["import-urdf"],
                       help="write a robot file (general joint form) from a URDF chain")
    p.add_argument("urdf", help="the URDF file")
    p.add_argument("--base", required=True, help="base link of the chain")
    p.add_argument("--tip", required=True, help="tip link of the chain (below --base)")
    p.add_argument("--out", required=True, help="robot file to write, data/robots/<name>.yaml")
    p.add_argument("--name", help="robot name (default and required: the --out file stem)")
    p.add_argument("--length-unit", choices=["m", "cm", "mm"], default="m", help="the robot file's length unit")
    p.set_defaults(func=cmd_import_urdf)

    p = sub.add_parser("export_urdf", aliases=["export-urdf"],
                       help="write a robot file as a URDF (links base_link ... tool0, metres)")
    p.add_argument("robot", help="data/robots/<name>.yaml")
    p.add_argument("--out", required=True, help="URDF file to write")
    p.add_argument("--name", help="robot name in the URDF (default: the robot's)")
    p.set_defaults(func=cmd_export_urdf)

    # study packages may add their own verbs (a module-level ``register_cli(subparsers)``)
    for mod in _study_cli_modules():
        mod.register_cli(sub)
    return ap


def _study_cli_modules() -> list:
    """``pipeline/studies/<id>/cli.py`` modules, loaded without importing ``pipeline.studies`` (pandas).

    Like :func:`pipeline.studies.study_cli_modules`, but found on disk, so that ``--help`` and parsing
    stay fast; each module keeps its heavy imports inside its command functions.
    """
    import importlib.util

    mods = []
    for path in sorted((Path(__file__).parent / "studies").glob("*/cli.py")):
        name = f"pipeline.studies.{path.parent.name}.cli"
        mod = sys.modules.get(name)
        if mod is None:
            spec = importlib.util.spec_from_file_location(name, path)
            mod = importlib.util.module_from_spec(spec)
            sys.modules[name] = mod
            spec.loader.exec_module(mod)
        if hasattr(mod, "register_cli"):
            mods.append(mod)
    return mods


def _check_yaml_arguments(args) -> None:
    """Every YAML file named by a ``--robot``/``--study``/``robot`` argument goes through the one loader
    (:func:`pipeline.yamlio.load_yaml`) before the verb runs, so that no verb, a study's own included,
    parses a hostile file (alias bomb, deep nesting, binary junk) with a plain ``yaml.safe_load``."""
    from pipeline.yamlio import load_yaml

    for key in ("robot", "study"):
        value = getattr(args, key, None)
        if isinstance(value, str) and Path(value).is_file():
            load_yaml(value, f"{key} file")


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)  # first: `--help` and usage errors need no heavy import

    from pipeline.io.archive import ArchiveError
    from pipeline.io.problems import ProblemFileError
    from pipeline.robots import RobotFileError
    from pipeline.settings import ConfigError
    from pipeline.solvers import NotApplicableError, SettingsError
    from pipeline.yamlio import YAMLInputError

    try:
        _check_yaml_arguments(args)
        args.func(args)
    except (CLIError, ArchiveError, ProblemFileError, RobotFileError, ConfigError, SettingsError,
            NotApplicableError, YAMLInputError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except FileNotFoundError as exc:
        print(f"error: {exc.filename}: no such file", file=sys.stderr)
        return 2
    except BrokenPipeError:
        return 0
    return 0
