"""``python -m pipeline <verb>``: parse arguments, load, call a library function, write.

Verbs (each one is also a Snakemake rule of the same name):

check_inputs      validate config, study settings and robot files (one line per problem)
make_problems     write a study's seeded problem set for one robot
solve_problems    solve every problem of a set with one registered solver, write an MCAP archive
solvers           list the registered IK solvers, their settings, defaults and units
new_study         write a study YAML that runs registered solvers on your robots
rerun_failures    rerun one archive's failed problems with changed stop rules (Table 16 of 000)
race              time one arm's finalists against each other in one process, interleaved (after its solve jobs)
aggregate_tables  compute a study's tables from its archives, beside the published values
plot_figures      render a study's figures from its archives
check_prose       fail on a number in a built study's prose bound to no cell, setting or document fact
render_report     assemble results/report.html
inspect           summarise an archive per solver (counts, success, times with units), one problem, CSV
replay            re-run archived problems into a Foxglove-viewable MCAP (arm, goal, joints per iteration)
reproduce         re-run an archive's solves, report bit-identical and differing ones with both environments
verify            recompute every table from the archives, check archives, their inputs, report and manifest
manifest          write results/MANIFEST.sha256: the SHA-256 of every file the build produced (its last step)
import_urdf       write a robot file (general joint form) from a URDF or xacro chain (also: import-urdf)
import_mjcf       write a robot file (general joint form) from an MJCF chain, MuJoCo's parser (also: import-mjcf)
benchmark_arm     benchmark one arm alone (arm_benchmark on that robot only) and its report (also: benchmark-arm)
export_urdf       write a robot file as a URDF, base_link ... tool0, metres (also: export-urdf)
compile           warm the numba cache: build or load kernels ahead of their first call (rule: compile_kernels)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


# numpy and the pipeline's modules are imported inside the commands: `--help` stays fast


from pipeline.errors import UsageError as CLIError  # noqa: E402  (the one usage error, printed as ``error: ...``)

MAX_THREADS = 64  # --threads of solve_problems


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


def cmd_make_problems(args) -> None:
    from pipeline.jobs.solve import make_problems

    print(make_problems(args.study, args.problem_set, args.robot, args.scale, args.data, args.out))


def cmd_solve_problems(args) -> None:
    from pipeline.jobs.solve import solve_problems

    if args.limit < 0 or not 1 <= args.threads <= MAX_THREADS:
        raise CLIError(f"--limit: at least 0 (0 = every problem), got {args.limit}; --threads: 1 to {MAX_THREADS}, "
                       f"got {args.threads}")
    solve_problems(args.study, args.problem_set, args.problems, args.solver, args.robot, args.scale, args.out,
                   limit=args.limit, threads=args.threads)


def cmd_rerun_failures(args) -> None:
    from pipeline.jobs.solve import rerun_failures

    rerun_failures(args.study, args.solver, args.problem_set, args.robot, args.problems, args.scale, args.archive,
                   args.out)


def cmd_new_study(args) -> None:
    from pipeline.jobs.build import new_study

    print(new_study(args.id, args.robots, args.solvers, count=args.count, spread=args.spread, seed=args.seed,
                    title=args.title, data=args.data, force=args.force, protocol=args.protocol))


def cmd_solvers(args) -> None:
    from pipeline.jobs.build import solver_listing

    print(solver_listing(args.name, as_json=args.json))


def cmd_race(args) -> None:
    from pipeline.jobs.race import race_arm

    if (not 1 <= args.goals <= 100_000 or args.min_passes < 1 or not args.min_passes <= args.max_passes <= 1000
            or not 0 < args.budget <= 3600):
        raise CLIError("--goals: 1 to 100000; --min-passes: at least 1; --max-passes: --min-passes to 1000; "
                       "--budget: above 0 s, at most 3600 s")
    print(race_arm(args.study, args.robot, args.archives, args.out, goals=args.goals,
                   passes=(args.min_passes, args.max_passes), budget_s=args.budget))


def cmd_aggregate_tables(args) -> None:
    from pipeline.jobs.build import aggregate_tables

    print(aggregate_tables(args.study, args.archives, args.published, args.out_dir))


def cmd_plot_figures(args) -> None:
    from pipeline.jobs.build import plot_figures

    print(plot_figures(args.study, args.archives, args.out_dir))


def cmd_check_prose(args) -> None:
    from pipeline.settings import load_study
    from pipeline.studies.prose import untabled_numbers

    study = load_study(args.study)
    if not (Path(args.built) / "tables").is_dir():
        raise CLIError(f"--built {args.built}: no tables/ folder (build the study's tables first)")
    bad = untabled_numbers(study, args.built, args.published)
    for where, number, context in bad:
        print(f"{study.id}: {where}: {number!r} in “…{context.strip()}…”")
    if bad:
        raise CLIError(f"{args.study}: {len(bad)} number(s) in the prose bound to no cell (listed above)")
    print(f"{study.id}: every number in the prose is bound to a cell, a setting or a document fact")


def cmd_import_urdf(args) -> None:
    from pipeline.jobs.robot_files import import_urdf

    xargs = {}
    for item in args.xacro_arg or []:
        key, sep, value = item.partition(":=")
        if not sep or not key:
            raise CLIError(f"--xacro-arg {item!r}: expected NAME:=VALUE")
        xargs[key] = value
    print(import_urdf(args.urdf, args.base, args.tip, args.out, name=args.name, length_unit=args.length_unit,
                      xacro_args=xargs, xacro_paths=args.xacro_path or []))


def cmd_import_mjcf(args) -> None:
    from pipeline.jobs.robot_files import import_mjcf

    print(import_mjcf(args.mjcf, args.base, args.tip, args.out, name=args.name, length_unit=args.length_unit))


def cmd_benchmark_arm(args) -> None:
    from pipeline.jobs.arm import benchmark_arm

    print(benchmark_arm(args.robot, scale=args.scale, cores=args.cores, results=args.results, data=args.data,
                        dry_run=args.dry_run))


def cmd_compile(args) -> None:
    from pipeline.jobs.compile import compile_methods

    if args.studies:
        if args.all or args.methods or args.robots:
            raise CLIError("--studies compiles what the studies' solve jobs call; give no methods, --all or --robots")
        from pipeline.jobs.compile import compile_studies

        print(compile_studies(args.studies, args.data))
        return
    if not args.all and not args.methods:
        raise CLIError("name the methods to compile, or --all, or --studies")
    print(compile_methods(None if args.all else args.methods, args.robots, batch=args.batch))


def cmd_export_urdf(args) -> None:
    from pipeline.jobs.robot_files import export_urdf

    print(export_urdf(args.robot, args.out, name=args.name))


def cmd_reproduce(args) -> None:
    from pipeline.jobs.reproduce import reproduce

    print(reproduce(args.target, sample=args.sample, problem=args.problem, problems=args.problems, robot=args.robot,
                    data=args.data))


def cmd_render_report(args) -> None:
    from pipeline.report.html import render_report
    from pipeline.settings import check_inputs

    config = _load_config(args)
    studies = check_inputs(config, config_path=args.config)
    render_report(studies, config, Path(config["results_dir"]), Path(args.out))
    print(f"wrote {args.out}")


def cmd_verify(args) -> None:
    """Recompute every table from its archives, check the archives and the report; exit 1 on any difference."""
    from pipeline.jobs.verify import verify

    ok, lines = verify(Path(args.results), Path(args.data))
    print("\n".join(lines))
    if not ok:
        raise SystemExit(1)


def cmd_manifest(args) -> None:
    """Write the SHA-256 of every file under the results folder (the build's last step; ``verify`` checks it)."""
    from pipeline.io.manifest import write_manifest

    out, n = write_manifest(Path(args.results), Path(args.out) if args.out else None)
    print(f"wrote {out}: {n} files")


def cmd_inspect(args) -> None:
    from pipeline.io.archive import read_archive
    from pipeline.report.inspect import InspectError, describe

    arch = read_archive(args.archive, problems=args.problems)
    try:
        print(describe(arch, failed=args.failed, problem=args.problem, csv_out=args.csv, raw=args.json))
    except InspectError as exc:
        raise CLIError(str(exc)) from None


def cmd_replay(args) -> None:
    """Re-run archived problems and write them as a Foxglove-viewable MCAP (pipeline/replay.py)."""
    from pipeline.jobs.replay import ReplayError, replay

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


class _Parser(argparse.ArgumentParser):
    """argparse with a usage error on one line (``error: <prog>: <message> (see <prog> --help)``), like
    every other error of the verbs; the usage text stays in ``--help``."""

    def error(self, message):
        sys.stderr.write(f"error: {self.prog}: {message} (see {self.prog} --help)\n")
        raise SystemExit(2)


class _VerbHelp(argparse.HelpFormatter):
    """Help that lists each verb on one line (without argparse's extra ``VERB`` header line)."""

    def _format_action(self, action):
        if isinstance(action, argparse._SubParsersAction):
            return "".join(self._format_action(a) for a in action._get_subactions())
        return super()._format_action(action)


def _build_verbs(sub) -> None:
    """The verbs of a build: check the inputs, make problem sets, solve them, rerun failures."""
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


def _study_verbs(sub) -> None:
    """The verbs that write a study, list the solvers and race an arm's finalists."""
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
    p.add_argument("--protocol", choices=["warm", "answer"], default="warm",
                   help="warm: one warm-start set, every solver that fits (default); answer: arm_benchmark's cold and "
                   "warm sets, labels and recommendation tables on these robots")
    p.set_defaults(func=cmd_new_study)

    p = sub.add_parser("solvers", help="list the registered IK solvers with their settings and defaults")
    p.add_argument("name", nargs="?", help="show one solver")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=cmd_solvers)

    p = sub.add_parser("race", help="time one arm's finalists against each other in one process, interleaved, "
                       "into an MCAP archive (after the arm's solve jobs)")
    p.add_argument("--study", required=True, help="the study's settings file (the answer's protocol)")
    p.add_argument("--robot", required=True, help="the arm's robot file")
    p.add_argument("--archives", nargs="+", required=True, help="the arm's solve archives (every set, every label)")
    p.add_argument("--out", required=True, help="the race archive to write (.mcap)")
    p.add_argument("--goals", type=int, default=300, help="goals per problem set at most (default 300)")
    p.add_argument("--min-passes", type=int, default=3, help="passes over the goals at least (default 3)")
    p.add_argument("--max-passes", type=int, default=7, help="passes at most (default 7)")
    p.add_argument("--budget", type=float, default=60.0, help="a set's race adds no pass beyond the least once it "
                   "has taken this long [s] (default 60)")
    p.set_defaults(func=cmd_race)


def _report_verbs(sub) -> None:
    """The verbs of the report: tables, figures, the HTML report, verify and manifest."""
    for verb, fn, what in (("aggregate_tables", cmd_aggregate_tables, "tables (CSV)"),
                           ("plot_figures", cmd_plot_figures, "figures (PNG/SVG)")):
        p = sub.add_parser(verb, help=f"a study's {what} from its archives")
        p.add_argument("--study", required=True)
        p.add_argument("--archives", nargs="+", required=True)
        p.add_argument("--published", default="data/published", help="folder of the documents' tables")
        p.add_argument("--out-dir", required=True)
        p.set_defaults(func=fn)

    p = sub.add_parser("check_prose", help="fail on a number in a built study's prose that no bound cell, setting "
                       "or document fact gives (pipeline.studies.prose)")
    p.add_argument("--study", required=True)
    p.add_argument("--built", required=True, help="the study's results folder (tables/, figures/)")
    p.add_argument("--published", default="data/published", help="folder of the documents' tables")
    p.set_defaults(func=cmd_check_prose)

    p = sub.add_parser("render_report", help="assemble the self-contained HTML report")
    p.add_argument("--config", default="workflow/config/config.yaml")
    p.add_argument("--set", action="append", metavar="KEY=VALUE")
    p.add_argument("--out", required=True)
    p.set_defaults(func=cmd_render_report)

    p = sub.add_parser("verify", help="recompute every table from its archives; check archives, the files they were "
                       "solved from, the report and the build manifest")
    p.add_argument("results", nargs="?", default="results", help="results folder (default results)")
    p.add_argument("--data", default="data", help="data folder (study settings, published tables)")
    p.set_defaults(func=cmd_verify)

    p = sub.add_parser("manifest", help="write the SHA-256 of every file the build produced (MANIFEST.sha256)")
    p.add_argument("results", nargs="?", default="results", help="results folder (default results)")
    p.add_argument("--out", help="manifest file (default <results>/MANIFEST.sha256)")
    p.set_defaults(func=cmd_manifest)


def _archive_verbs(sub) -> None:
    """The verbs that read one archive: inspect, reproduce, replay."""
    p = sub.add_parser("inspect", help="summarise an archive")
    p.add_argument("archive")
    p.add_argument("--failed", action="store_true", help="list the failed solves")
    p.add_argument("--problem", type=int, help="a short summary of one problem (times, errors, joints, trace)")
    p.add_argument("--json", action="store_true", help="with --problem: print the raw record as JSON")
    p.add_argument("--csv", metavar="OUT", help="export the solve records as CSV (one column per joint and goal value)")
    p.add_argument("--problems", metavar="FILE", help="the archive's problem set, if it is not where the archive's "
                   "metadata says (an archive copied out of its results tree; its SHA-256 is still checked)")
    p.set_defaults(func=cmd_inspect)

    p = sub.add_parser("reproduce", help="re-run an archive's solves and report how far the re-runs are from it")
    p.add_argument("target", metavar="ARCHIVE|RESULTS_DIR", help="one archive, or a results folder (every */runs/**/*.mcap)")
    p.add_argument("--sample", type=int, help="solves re-run per archive, evenly spaced over its problems (default: "
                   "all of one archive, 20 per archive of a folder)")
    p.add_argument("--problem", type=int, help="re-run only this problem id")
    p.add_argument("--problems", metavar="FILE", help="the archive's problem set, if not where its metadata says")
    p.add_argument("--robot", metavar="FILE", help="the robot file, if not where the archive's metadata says")
    p.add_argument("--data", default="data", help="data folder (robot files <data>/robots/<robot>.yaml)")
    p.set_defaults(func=cmd_reproduce)

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
    p.add_argument("--max-frames", type=int, default=200, help="at most this many iteration frames per problem (2 to 100000)")
    p.add_argument("--dt", type=float, default=0.05, help="seconds between frames (log times; 1e-6 to 3600)")
    p.set_defaults(func=cmd_replay)


def _robot_verbs(sub) -> None:
    """The verbs about one robot: import a URDF, answer for an arm, compile kernels, export a URDF."""
    p = sub.add_parser("import_urdf", aliases=["import-urdf"],
                       help="write a robot file (general joint form) from a URDF chain")
    p.add_argument("urdf", help="the URDF file, or a xacro file (*.xacro or xmlns:xacro: expanded with the xacro "
                   "package first)")
    p.add_argument("--xacro-arg", action="append", metavar="NAME:=VALUE", help="a xacro argument (repeatable); "
                   "also the only value $(env NAME) / $(optenv NAME) may take (a xacro file may not read the "
                   "environment)")
    p.add_argument("--xacro-path", action="append", metavar="DIR", help="a folder, besides the xacro file's own, "
                   "that it may include or load YAML from (repeatable)")
    p.add_argument("--base", required=True, help="base link of the chain")
    p.add_argument("--tip", required=True, help="tip link of the chain (below --base)")
    p.add_argument("--out", required=True, help="robot file to write, data/robots/<name>.yaml")
    p.add_argument("--name", help="robot name (default and required: the --out file stem)")
    p.add_argument("--length-unit", choices=["m", "cm", "mm"], default="m", help="the robot file's length unit")
    p.set_defaults(func=cmd_import_urdf)

    p = sub.add_parser("import_mjcf", aliases=["import-mjcf"],
                       help="write a robot file (general joint form) from an MJCF chain (MuJoCo's own parser)")
    p.add_argument("mjcf", help="the MJCF file (root element <mujoco>, e.g. a MuJoCo Menagerie arm)")
    p.add_argument("--base", default="world", help="base body of the chain (default: world)")
    p.add_argument("--tip", required=True, help="tip body or site of the chain (below --base; a site's frame is the tool)")
    p.add_argument("--out", required=True, help="robot file to write, data/robots/<name>.yaml")
    p.add_argument("--name", help="robot name (default and required: the --out file stem)")
    p.add_argument("--length-unit", choices=["m", "cm", "mm"], default="m", help="the robot file's length unit")
    p.set_defaults(func=cmd_import_mjcf)

    p = sub.add_parser("benchmark_arm", aliases=["benchmark-arm"],
                       help="benchmark one arm alone: study arm_benchmark on that robot file only, and its report")
    p.add_argument("robot", help="the robot file (data/robots/<name>.yaml, e.g. from import-urdf)")
    p.add_argument("--scale", choices=["quick", "full"], default="full",
                   help="full: 2 000 goals per set (the catalogue's protocol); quick: 50, a smoke run")
    p.add_argument("--cores", type=int, default=2, help="cores Snakemake may use (default 2)")
    p.add_argument("--results", help="results folder (default results/arm_<name>)")
    p.add_argument("--data", default="data", help="data folder holding studies/arm_benchmark.yaml and published/")
    p.add_argument("--dry-run", action="store_true", help="write the study and print the Snakemake command only")
    p.set_defaults(func=cmd_benchmark_arm)

    p = sub.add_parser("compile", help="warm the numba cache: build or load the kernels of methods ahead of their first call")
    p.add_argument("methods", nargs="*", metavar="METHOD", help="registered methods of ours (`solvers` lists them)")
    p.add_argument("--all", action="store_true", help="every registered method of ours (the peers' are not numba)")
    p.add_argument("--robots", nargs="+", metavar="ROBOT", help="shipped robot names or robot files (default: every "
                   "shipped robot the method applies to)")
    p.add_argument("--batch", action="store_true", help="also compile the batch kernels (solve_batch)")
    p.add_argument("--studies", nargs="+", metavar="STUDY", help="study files: compile what their solve jobs call "
                   "(each robot and solver label with its settings; the workflow's first rule)")
    p.add_argument("--data", default="data", help="with --studies: the data folder (robots/)")
    p.set_defaults(func=cmd_compile)

    p = sub.add_parser("export_urdf", aliases=["export-urdf"],
                       help="write a robot file as a URDF (links base_link ... tool0, metres)")
    p.add_argument("robot", help="data/robots/<name>.yaml")
    p.add_argument("--out", required=True, help="URDF file to write")
    p.add_argument("--name", help="robot name in the URDF (default: the robot's)")
    p.set_defaults(func=cmd_export_urdf)


def build_parser() -> argparse.ArgumentParser:
    # the verbs are listed once, by the subparsers (one line each); the description is the first line
    ap = _Parser(
        prog="python -m pipeline", description=__doc__.splitlines()[0].replace("``", "")
        + " Each verb is also a Snakemake rule of the same name; `python -m pipeline VERB --help` for its options.",
        formatter_class=lambda prog: _VerbHelp(prog, max_help_position=34, width=140))
    sub = ap.add_subparsers(dest="verb", required=True, metavar="VERB", title="verbs")

    for verbs in (_build_verbs, _study_verbs, _report_verbs, _archive_verbs, _robot_verbs):
        verbs(sub)
    # study packages may add their own verbs (a module-level ``register_cli(subparsers)``)
    for mod in _study_cli_modules():
        mod.register_cli(sub)
    _add_force_flags(sub)
    return ap


def _add_force_flags(sub) -> None:
    """``--force`` on every verb that writes a named file (``--out``, ``-o``, ``--csv``, ``--write-robot``,
    ``--res``): without it an existing file is not overwritten (:func:`pipeline.io.outputs.check_outputs`)."""
    from pipeline.io.outputs import OUTPUT_ARGS

    seen = set()
    for p in sub.choices.values():
        if id(p) in seen:
            continue
        seen.add(id(p))
        dests = {a.dest for a in p._actions}
        if "force" not in dests and dests & set(OUTPUT_ARGS):
            p.add_argument("--force", action="store_true",
                           help="overwrite an existing output file (never a file this command reads, nor an archive "
                                "or problem set of a results tree)")


def _study_cli_modules() -> list:
    """``pipeline/studies/<id>/cli.py`` modules, loaded without importing ``pipeline.studies`` (pandas).

    Found on disk, not imported through :mod:`pipeline.studies` (which never imports them), so that
    ``--help`` and parsing stay fast; each module keeps its heavy imports inside its command functions.
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
    """Every file argument must be a regular file (or a folder, or not exist yet): a FIFO, a device or a
    socket is refused in one line before any verb opens it (reading a FIFO blocks). Then every YAML file
    named by a ``--robot``/``--study``/``robot`` argument goes through the one loader
    (:func:`pipeline.yamlio.load_yaml`) before the verb runs, so that no verb, a study's own included,
    parses a hostile file (alias bomb, deep nesting, binary junk) with a plain ``yaml.safe_load``."""
    from pipeline.errors import not_regular
    from pipeline.yamlio import load_yaml

    for key, value in vars(args).items():
        for v in value if isinstance(value, list) else [value]:
            why = not_regular(v) if isinstance(v, str) and key not in ("func", "verb") else None
            if why:
                raise CLIError(f"{v}: {why}")
    for key in ("robot", "study"):
        value = getattr(args, key, None)
        if isinstance(value, str) and Path(value).is_file():
            load_yaml(value, f"{key} file")


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)  # first: `--help` and usage errors need no heavy import

    from pipeline.io.archive import ArchiveError
    from pipeline.io.outputs import check_outputs
    from pipeline.io.problems import ProblemFileError
    from pipeline.provenance import DamagedFileError
    from pipeline.robots import RobotFileError
    from pipeline.settings import ConfigError
    from pipeline.solvers import NotApplicableError, SettingsError
    from pipeline.yamlio import YAMLInputError

    try:
        _check_yaml_arguments(args)
        check_outputs(vars(args), force=bool(getattr(args, "force", False)))
        args.func(args)
    except (CLIError, ArchiveError, ProblemFileError, RobotFileError, ConfigError, SettingsError,
            NotApplicableError, YAMLInputError, DamagedFileError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except FileNotFoundError as exc:
        print(f"error: {exc.filename}: no such file", file=sys.stderr)
        return 2
    except BrokenPipeError:
        return 0
    return 0
