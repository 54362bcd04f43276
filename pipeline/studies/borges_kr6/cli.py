"""Study verb ``solve_borges_kr6``: one problem set solved by one method into one MCAP archive.

    python -m pipeline solve_borges_kr6 --study data/studies/borges_kr6.yaml \
        --robot data/robots/kuka_kr6_r700_sixx.yaml --set points --method pso --scale quick \
        --out results/borges_kr6/runs/points__pso.mcap
"""

from __future__ import annotations

SETS = ("alpha_sweep", "points", "paths")


def cmd_solve_borges_kr6(args) -> None:
    from pipeline.cli import CLIError
    from pipeline.settings import load_study
    from pipeline.studies.borges_kr6.methods import MethodError
    from pipeline.studies.borges_kr6.run import RunError, write_archive

    study = load_study(args.study)
    if study.id != "borges_kr6":
        raise CLIError(f"{args.study}: field 'study': {study.id!r} is not borges_kr6")
    try:
        n, ok = write_archive(study, args.robot, args.set, args.method, args.scale, args.out)
    except (RunError, MethodError, ValueError) as exc:
        raise CLIError(str(exc)) from None
    print(f"wrote {args.out}: {n} solves of set {args.set} by {args.method}, {ok} FK-verified successes")


def register_cli(subparsers) -> None:
    p = subparsers.add_parser("solve_borges_kr6", help="borges_kr6: solve one problem set with one method (MCAP)")
    p.add_argument("--study", required=True, help="data/studies/borges_kr6.yaml")
    p.add_argument("--robot", required=True, help="data/robots/kuka_kr6_r700_sixx.yaml")
    p.add_argument("--set", required=True, choices=SETS, help="problem set")
    p.add_argument("--method", required=True, help="ji, lm, pso or a key of methods.pso_variants")
    p.add_argument("--scale", choices=["full", "quick"], default="full")
    p.add_argument("--out", required=True, help="output .mcap")
    p.set_defaults(func=cmd_solve_borges_kr6)
