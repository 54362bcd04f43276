"""Study verbs of nepomuceno2024 for ``python -m pipeline`` (imports stay light at module level).

solve_motion_nepomuceno2024   solve every point of one designed motion with one method, N times,
                              into one MCAP archive
plan_motion_nepomuceno2024    write the interpolated goal poses of one motion as CSV (inspection)
"""

from __future__ import annotations


def _cli_error(exc: Exception):
    from pipeline.cli import CLIError

    return CLIError(str(exc))


def cmd_solve_motion(args) -> None:
    from pipeline.settings import load_study
    from pipeline.studies.nepomuceno2024.methods import MethodError
    from pipeline.studies.nepomuceno2024.runner import solve_motion
    from pipeline.studies.nepomuceno2024.trajectory import MotionFileError

    study = load_study(args.study)
    try:
        s = solve_motion(study, args.robot, args.motions, args.motion, args.method, args.scale, args.out)
    except (MethodError, MotionFileError) as exc:
        raise _cli_error(exc) from None
    print(f"wrote {args.out}: {s['points']} points x {s['repetitions']} repetitions, "
          f"{s['successes']} FK-verified successes per repetition, mean IK time {s['mean_total_s']:.3f} s")


def cmd_plan_motion(args) -> None:
    import numpy as np
    import pandas as pd

    from pipeline.kinematics import fk_htm, quat_from_matrix
    from pipeline.robots import load_robot
    from pipeline.settings import load_study
    from pipeline.studies.nepomuceno2024.trajectory import MotionFileError, build_motion, load_motions

    study = load_study(args.study)
    model = load_robot(args.robot)
    try:
        doc = load_motions(args.motions)
        mp = build_motion(doc, args.motion, lambda q: fk_htm(model.chain, q),
                          **study.settings["interpolation"][args.scale])
    except MotionFileError as exc:
        raise _cli_error(exc) from None
    quat = quat_from_matrix(mp.T)
    df = pd.DataFrame({"point": np.arange(len(mp)), "segment": mp.segment,
                       "x_m": mp.T[:, 0, 3], "y_m": mp.T[:, 1, 3], "z_m": mp.T[:, 2, 3],
                       "qw": quat[:, 0], "qx": quat[:, 1], "qy": quat[:, 2], "qz": quat[:, 3]})
    df.to_csv(args.out, index=False, float_format="%.9g")
    print(f"wrote {args.out}: {len(mp)} points of motion {args.motion!r}")


def register_cli(sub) -> None:
    for verb, fn, help_ in (("solve_motion_nepomuceno2024", cmd_solve_motion, "nepomuceno2024: solve one motion with one method"),
                            ("plan_motion_nepomuceno2024", cmd_plan_motion, "nepomuceno2024: interpolated goal poses of one motion as CSV")):
        p = sub.add_parser(verb, help=help_)
        p.add_argument("--study", required=True, help="data/studies/nepomuceno2024.yaml")
        p.add_argument("--robot", required=True, help="data/robots/<name>.yaml")
        p.add_argument("--motions", required=True, help="data/nepomuceno2024/motions.yaml")
        p.add_argument("--motion", required=True, help="a key of the motion file's `motions`")
        p.add_argument("--scale", choices=["full", "quick"], default="full")
        p.add_argument("--out", required=True, help="output .mcap" if fn is cmd_solve_motion else "output .csv")
        if fn is cmd_solve_motion:
            p.add_argument("--method", required=True, help="a key of study_settings.methods")
        p.set_defaults(func=fn)
