"""``python -m pipeline`` verbs of study erthal1992 (each also a Snakemake rule of the same name).

robot                       convert and print a robot in the SCARA.TXT report layout (from a
                            robot file, DH -> PZ; or from a joint-point input, Appendix 1 Case 1)
erthal_catalogue            conversions + jog FK of the catalogue -> catalogue.mcap and TXT reports
erthal_path_rows            a path task's RES rows from its solve archive -> paths/<set>__<robot>.mcap + RES

The IK solves themselves (Tests 1-6, paths, analytic PUMA) are problem sets of the study YAML, run
by the generic verbs ``make_problems`` / ``solve_problems``.
"""

from __future__ import annotations

from pathlib import Path


def _cli_error(exc):
    from pipeline.errors import UsageError as CLIError

    return CLIError(str(exc).splitlines()[0] if str(exc) else type(exc).__name__)


def _known_errors():
    from pipeline.solvers import NotApplicableError, SettingsError
    from pipeline.studies.erthal1992.model import ConversionError
    from pipeline.studies.erthal1992.runs import RunError
    from pipeline.studies.erthal1992.tasks import TaskFileError

    return (ConversionError, NotApplicableError, RunError, SettingsError, TaskFileError, KeyError)


def cmd_robot(args) -> None:
    import numpy as np

    from pipeline.robots import check_joint_points, load_robot
    from pipeline.studies.erthal1992 import model as M
    from pipeline.yamlio import load_yaml

    try:
        path = Path(args.robot)
        doc = load_yaml(path, "robot file") if path.is_file() else None
        if isinstance(doc, dict) and "effector" in doc and "convention" not in doc:  # a joint-point input
            j, e = check_joint_points(doc, str(path))["joints"], doc["effector"]
            pts, axes = [x["position"] for x in j], [x["axis"] for x in j]
            try:
                dh = M.dh_from_joint_points([x["type"] for x in j], pts, axes, e["position"], e["u_a"], e["u_t"])
            except (M.ConversionError, ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
                raise M.ConversionError(f"{path}: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}") \
                    from None
            pz = M.pz_from_dh(dh.chain(), dh.q0)
            text = M.report_txt(doc["name"], dh, pz, pts, axes)
            if args.write_robot:
                Path(args.write_robot).write_text(M.robot_yaml(doc["name"], dh, f"converted from {path}"))
        else:
            model = load_robot(path)
            types = ["p" if p else "r" for p in model.chain.prismatic]
            if args.q0:
                vals = [float(v) for v in args.q0.split(",")]
                if len(vals) != model.n:
                    raise ValueError(f"--q0: expected {model.n} values, got {len(vals)}")
                q0 = np.where(model.chain.prismatic, vals, np.radians(vals))
            else:
                q0 = np.zeros(model.n)
            if model.chain.general:  # no DH table: origins, axes and zero-position vectors
                from pipeline.robots import describe_general

                text = describe_general(model, q0)
            else:
                dh = M.dh_model_from_chain(model.chain, types, q0)
                pz = M.pz_from_dh(model.chain, q0)
                text = M.report_txt(model.name, dh, pz, limits=model.limits)
            from pipeline.kinematics.geometry import classify, report

            text += "\n" + report(model.chain, args.geometry_tol, model.length_unit)
            six_revolute = model.n == 6 and not np.any(model.chain.prismatic)
            from pipeline.kinematics.nearfamily import NEAR_TOL, snap

            sn = snap(model.chain, args.geometry_tol, NEAR_TOL) if six_revolute else None
            if sn is not None:
                text += (f"{sn.describe(model.length_unit)} (near_tol {NEAR_TOL:g}): `analytic` solves it by that "
                         "family's closed form on the nearest exact arm, then polishes each candidate by Newton "
                         "steps on this arm and checks it by this arm's forward kinematics; this arm's own path "
                         "(what near_tol 0 would run) adds its solutions, so none is lost where the two arms "
                         "differ\n")
            if six_revolute and classify(model.chain, args.geometry_tol).family is None:
                from pipeline.solvers.closed_form import general6r
                from pipeline.solvers.core import Prepared

                why = general6r.degenerate(Prepared(model))
                text += ("general 6R: `analytic` solves it by algebraic elimination (the solver `general_6r`)\n"
                         if why is None else f"general 6R: not solved either: {why}\n")
    except _known_errors() + (ValueError,) as exc:
        raise _cli_error(exc) from None
    if args.out:
        Path(args.out).write_text(text)
        print(f"wrote {args.out}")
    else:
        print(text, end="")


def _study(args):
    from pipeline.settings import load_study

    return load_study(args.study)


def cmd_catalogue(args) -> None:
    from pipeline.studies.erthal1992.runs import run_catalogue

    try:
        n = run_catalogue(_study(args), Path(args.data), Path(args.out), Path(args.report_dir))
    except _known_errors() as exc:
        raise _cli_error(exc) from None
    print(f"wrote {args.out}: {n} catalogue records; reports in {args.report_dir}")


def cmd_path_rows(args) -> None:
    from pipeline.problems import ProblemSpecError
    from pipeline.studies.erthal1992.runs import write_path_rows

    try:
        n = write_path_rows(_study(args), args.problem_set, args.robot, Path(args.archive), Path(args.data),
                            Path(args.out), Path(args.res) if args.res else None)
    except _known_errors() + (ProblemSpecError,) as exc:
        raise _cli_error(exc) from None
    print(f"wrote {args.out}: {n} RES rows" + (f"; {args.res}" if args.res else ""))


def register_cli(sub) -> None:
    p = sub.add_parser("robot", help="erthal1992: convert a robot (DH <-> zero-position) and print its report")
    p.add_argument("robot", help="data/robots/<name>.yaml or a joint-point input (data/erthal1992/*_input.yaml)")
    p.add_argument("--q0", help="zero position for a robot file, comma-separated deg | mm (default all 0)")
    p.add_argument("--write-robot", metavar="YAML", help="joint-point input: also write the converted robot file")
    p.add_argument("--geometry-tol", type=float, default=1e-9,
                   help="robot file: axes meet within this x the arm's reach, parallel within this angle [rad] "
                        "(default 1e-9; the closed-form family section)")
    p.add_argument("--out", help="write the report here instead of stdout")
    p.set_defaults(func=cmd_robot)

    def common(p):
        p.add_argument("--study", required=True, help="data/studies/erthal1992.yaml")
        p.add_argument("--data", default="data", help="data folder (robots/, erthal1992/)")
        p.add_argument("--out", required=True, help="output .mcap")

    p = sub.add_parser("erthal_catalogue", help="erthal1992: conversions and jog FK of the catalogue")
    common(p)
    p.add_argument("--report-dir", required=True, help="folder for the TXT reports")
    p.set_defaults(func=cmd_catalogue)

    p = sub.add_parser("erthal_path_rows", help="erthal1992: a path task's RES rows from its solve archive")
    common(p)
    p.add_argument("--problem-set", required=True, help="a path set of study_settings.paths")
    p.add_argument("--robot", required=True, help="robot id")
    p.add_argument("--archive", required=True, help="the set's solve archive (runs/<set>/<robot>__<solver>.mcap)")
    p.add_argument("--res", help="RES file to write")
    p.set_defaults(func=cmd_path_rows)
