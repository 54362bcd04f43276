"""Study verb of nepomuceno2024 for ``python -m pipeline`` (imports stay light at module level).

plan_motion_nepomuceno2024    write the interpolated goal poses of one motion (a problem set of the
                              study) as CSV, with segment names (inspection)

Solving is the generic ``make_problems`` / ``solve_problems`` (one problem set per motion).
"""

from __future__ import annotations


def cmd_plan_motion(args) -> None:
    import numpy as np
    import pandas as pd

    from pipeline.errors import UsageError as CLIError
    from pipeline.kinematics import quat_from_matrix
    from pipeline.problems import ProblemSpecError
    from pipeline.settings import load_study
    from pipeline.studies.nepomuceno2024.problems import set_motion
    from pipeline.studies.nepomuceno2024.trajectory import MotionFileError

    study = load_study(args.study)
    if args.motion not in study.problem_sets:
        raise CLIError(f"{args.study}: field 'problem_sets/{args.motion}': no such motion "
                       f"(have: {', '.join(study.problem_sets)})")
    try:
        mp = set_motion(study, args.motion, args.scale, args.data)
    except (MotionFileError, ProblemSpecError) as exc:
        raise CLIError(str(exc)) from None
    quat = quat_from_matrix(mp.T)
    df = pd.DataFrame({"point": np.arange(len(mp)), "segment": mp.segment,
                       "x_m": mp.T[:, 0, 3], "y_m": mp.T[:, 1, 3], "z_m": mp.T[:, 2, 3],
                       "qw": quat[:, 0], "qx": quat[:, 1], "qy": quat[:, 2], "qz": quat[:, 3]})
    df.to_csv(args.out, index=False, float_format="%.9g")
    print(f"wrote {args.out}: {len(mp)} points of motion {args.motion!r}")


def register_cli(sub) -> None:
    p = sub.add_parser("plan_motion_nepomuceno2024", help="nepomuceno2024: interpolated goal poses of one motion as CSV")
    p.add_argument("--study", required=True, help="data/studies/nepomuceno2024.yaml")
    p.add_argument("--motion", required=True, help="a problem set (motion) of the study")
    p.add_argument("--scale", choices=["full", "quick"], default="full")
    p.add_argument("--data", default="data", help="data folder (robot and motion files)")
    p.add_argument("--out", required=True, help="output .csv")
    p.set_defaults(func=cmd_plan_motion)
