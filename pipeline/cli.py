"""``python -m pipeline <verb>``: parse arguments, load, call a library function, write.

Verbs (each one is also a Snakemake rule of the same name):

check_inputs      validate config, study settings and robot files (one line per problem)
make_problems     write a study's seeded problem set for one robot
solve_problems    solve every problem with one solver, write an MCAP archive
rerun_failures    rerun one archive's failed problems with changed stop rules (Table 16 of 000)
aggregate_tables  compute a study's tables from its archives, beside the published values
plot_figures      render a study's figures from its archives
render_report     assemble results/report.html
inspect           summarise an archive (counts, success, time percentiles, metadata)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import yaml


class CLIError(Exception):
    """A usage problem found after parsing (one line, printed as ``error: ...``)."""


def _progress(done: int, total: int, t0: float, extra: str = "") -> None:
    print(f"[{time.monotonic() - t0:7.1f} s] {done}/{total} {extra}", file=sys.stderr, flush=True)


def _load_config(args) -> dict:
    """The run config file with ``--set KEY=VALUE`` overrides (values parsed as YAML)."""
    from pipeline.settings import ConfigError

    try:
        config = yaml.safe_load(Path(args.config).read_text()) or {}
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(f"{args.config}: cannot read the config ({exc})") from None
    for kv in args.set or []:
        k, sep, v = kv.partition("=")
        if not sep:
            raise CLIError(f"--set {kv!r}: expected KEY=VALUE")
        config[k] = yaml.safe_load(v)
    return config


def cmd_check_inputs(args) -> None:
    from pipeline.settings import check_inputs

    config = _load_config(args)
    studies = check_inputs(config)
    print(f"ok: {len(studies)} studies, scale={config['scale']}: " + ", ".join(s.id for s in studies))


def cmd_make_problems(args) -> None:
    from pipeline.io.problems import write_problems
    from pipeline.problems import random_joint_pairs
    from pipeline.robots import load_robot
    from pipeline.settings import file_sha256, load_study

    study = load_study(args.study)
    model = load_robot(args.robot)
    p = study.doc["problems"]
    count = study.count(args.scale)
    # one independent stream per robot, derived from the study seed
    rng = np.random.default_rng([p["seed"], sum(model.name.encode())])
    ps = random_joint_pairs(model, count, rng, p.get("low", 0.0), p.get("high", 2 * np.pi))
    write_problems(args.out, ps, {"study": study.id, "seed": p["seed"], "scale": args.scale, "count": count,
                                  "robot_sha256": file_sha256(args.robot)[:16]})
    print(f"wrote {count} problems for {model.name} to {args.out}")


def _solve_to_archive(args, settings, select=None, extra_meta=None) -> None:
    """Solve the problems of ``args.problems`` (all, or the ids in ``select``) into ``args.out``."""
    import pipeline
    from pipeline.io.archive import FORMAT_VERSION, ArchiveWriter, solve_record
    from pipeline.io.problems import read_problems
    from pipeline.robots import LENGTH_UNITS, load_robot
    from pipeline.settings import file_sha256, git_commit, load_study
    from pipeline.solvers import PreparedRobot, solve

    study = load_study(args.study)
    model = load_robot(args.robot)
    ps, _ = read_problems(args.problems)
    if ps.robot != model.name:
        raise CLIError(f"{args.problems}: header field 'robot': {ps.robot!r} but the robot file is {model.name!r}")
    if getattr(args, "limit", 0):
        ps = ps.head(args.limit)
    idx = np.arange(len(ps)) if select is None else np.flatnonzero(np.isin(ps.problem_id, list(select)))
    prep = PreparedRobot(model, settings.length_unit)
    unit = prep.model.length_unit
    T_goals = ps.goal_transforms()
    T_goals[:, :3, 3] *= LENGTH_UNITS[ps.length_unit] / LENGTH_UNITS[unit]
    meta = {
        "format_version": FORMAT_VERSION, "study": study.id, "robot": model.name, "solver": args.solver,
        "settings": json.dumps(settings.as_dict(), sort_keys=True), "settings_hash": study.solver_hash(args.solver, args.scale),
        "seed": str(study.doc["problems"]["seed"]), "scale": args.scale, "problems": str(len(idx)),
        "problem_file": Path(args.problems).name, "problem_sha256": file_sha256(args.problems)[:16],
        "length_unit": unit, "package_version": pipeline.__version__, "git_commit": git_commit(),
        **(extra_meta or {}),
    }
    if len(idx):
        solve(prep, T_goals[idx[0]], ps.q_start[idx[0]], settings)  # compile or load the cached code before timing
    t0 = time.monotonic()
    n_ok = 0
    every = max(1, len(idx) // 10)
    with ArchiveWriter(args.out, meta) as w:
        for k, i in enumerate(idx):
            res = solve(prep, T_goals[i], ps.q_start[i], settings)
            n_ok += res.success
            w.write(*solve_record(ps.problem_id[i], model.name, args.solver, unit, ps.q_start[i],
                                  T_goals[i, :3, 3], ps.goal_quat[i], res))
            if (k + 1) % every == 0 or k + 1 == len(idx):
                _progress(k + 1, len(idx), t0, f"solved, {n_ok} successes")
    print(f"wrote {args.out}: {len(idx)} problems, {n_ok} FK-verified successes")


def _study_solver(args):
    from pipeline.settings import load_study

    study = load_study(args.study)
    if args.solver not in study.solvers:
        raise CLIError(f"{args.study}: field 'solvers/{args.solver}': no such solver (have: {', '.join(study.solvers)})")
    return study, study.solvers[args.solver]


def cmd_solve_problems(args) -> None:
    _, settings = _study_solver(args)
    _solve_to_archive(args, settings)


def cmd_rerun_failures(args) -> None:
    from dataclasses import replace

    from pipeline.io.archive import read_archive
    from pipeline.solvers import SettingsError

    study, settings = _study_solver(args)
    overrides = study.settings.get("rerun")
    if not overrides:
        raise CLIError(f"{args.study}: field 'study_settings/rerun': missing (the rerun's setting overrides)")
    try:
        rerun = replace(settings, **overrides)
    except TypeError as exc:
        raise SettingsError(f"{args.study}: field 'study_settings/rerun': {exc}") from None
    rerun.validate(f"{args.study}: study_settings/rerun")
    original = read_archive(args.archive)
    if original.metadata["solver"] != args.solver:
        raise CLIError(f"{args.archive}: metadata field 'solver' is {original.metadata['solver']!r}, expected {args.solver!r}")
    failed = [r["problem_id"] for r in original.solves if not r["success"]]
    _solve_to_archive(args, rerun, select=failed, extra_meta={
        "rerun_of": Path(args.archive).name, "rerun_of_settings_hash": original.metadata["settings_hash"]})


def cmd_aggregate_tables(args) -> None:
    from pipeline.io.archive import read_archive
    from pipeline.settings import load_study
    from pipeline.studies import get_study_module, write_tables

    study = load_study(args.study)
    archives = [read_archive(p) for p in args.archives]
    tables = get_study_module(study.id).build_tables(study, archives, Path(args.published))
    write_tables(tables, Path(args.out_dir))
    prov = [{"archive": str(a.path), "problems": len(a.solves), **a.metadata} for a in archives]
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
    studies = check_inputs(config)
    render_report(studies, config, Path(config["results_dir"]), Path(args.out))
    print(f"wrote {args.out}")


def cmd_inspect(args) -> None:
    from pipeline.io.archive import read_archive
    from pipeline.report.inspect import describe

    arch = read_archive(args.archive)
    print(describe(arch, failed=args.failed, problem=args.problem, csv_out=args.csv))


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="python -m pipeline", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="verb", required=True, metavar="verb")

    p = sub.add_parser("check_inputs", help="validate config, study settings and robot files")
    p.add_argument("--config", default="workflow/config/config.yaml")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a config key (like --config)")
    p.set_defaults(func=cmd_check_inputs)

    p = sub.add_parser("make_problems", help="write a seeded problem set")
    p.add_argument("--study", required=True, help="data/studies/<id>.yaml")
    p.add_argument("--robot", required=True, help="data/robots/<name>.yaml")
    p.add_argument("--scale", choices=["full", "quick"], default="full")
    p.add_argument("--out", required=True, help="output CSV")
    p.set_defaults(func=cmd_make_problems)

    p = sub.add_parser("solve_problems", help="solve a problem set with one solver into an MCAP archive")
    p.add_argument("--study", required=True)
    p.add_argument("--robot", required=True)
    p.add_argument("--solver", required=True, help="a key of the study's `solvers`")
    p.add_argument("--problems", required=True, help="problem-set CSV from make_problems")
    p.add_argument("--scale", choices=["full", "quick"], default="full")
    p.add_argument("--limit", type=int, default=0, help="solve only the first N problems (debugging)")
    p.add_argument("--out", required=True, help="output .mcap")
    p.set_defaults(func=cmd_solve_problems)

    p = sub.add_parser("rerun_failures", help="rerun a solver's failed problems with the study's rerun overrides")
    p.add_argument("--study", required=True)
    p.add_argument("--robot", required=True)
    p.add_argument("--solver", required=True)
    p.add_argument("--problems", required=True)
    p.add_argument("--archive", required=True, help="the solver's archive (its failures are rerun)")
    p.add_argument("--scale", choices=["full", "quick"], default="full")
    p.add_argument("--out", required=True)
    p.set_defaults(func=cmd_rerun_failures)

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

    p = sub.add_parser("inspect", help="summarise an archive")
    p.add_argument("archive")
    p.add_argument("--failed", action="store_true", help="list the failed solves")
    p.add_argument("--problem", type=int, help="show one problem's record and error trace")
    p.add_argument("--csv", metavar="OUT", help="export the solve records as CSV")
    p.set_defaults(func=cmd_inspect)

    # study packages may add their own verbs (a module-level ``register_cli(subparsers)``)
    from pipeline.studies import study_cli_modules

    for mod in study_cli_modules():
        mod.register_cli(sub)
    return ap


def main(argv: list[str] | None = None) -> int:
    from pipeline.io.archive import ArchiveError
    from pipeline.io.problems import ProblemFileError
    from pipeline.robots import RobotFileError
    from pipeline.settings import ConfigError
    from pipeline.solvers import SettingsError

    args = build_parser().parse_args(argv)
    try:
        args.func(args)
    except (CLIError, ArchiveError, ProblemFileError, RobotFileError, ConfigError, SettingsError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except FileNotFoundError as exc:
        print(f"error: {exc.filename}: no such file", file=sys.stderr)
        return 2
    except BrokenPipeError:
        return 0
    return 0
