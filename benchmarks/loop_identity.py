"""Bit-identity check of the iterative methods across a change of their compiled loops (issue 41, item 2).

Runs every iterative method on a fixed set of cases (several robots: UR5e, KUKA KR6, KUKA LWR and
iiwa 7-DoF, Franka Panda (modified DH), the Stanford arm and the Cartesian arm (prismatic joints), the
ELBOW arm of Erthal 1992, the SCARA; seeded goals, near and far starts; settings: defaults, restarts,
``require_limits``, the other success criteria, a millimetre working unit) through the single call
and the batch call, and records every result field but the timings (q, success, stop reason,
iterations, claimed success, within limits, errors, ``info`` counters) and each trace's bytes.

Usage::

    python benchmarks/loop_identity.py --record out.json [--only dls,newton_raphson]   # on the reference build
    python benchmarks/loop_identity.py --check out.json [--only ...]                   # on the changed build

``--extra`` runs instead each method's settings of ``EXTRA`` (iteration caps, other stop tests, tolerances
out of reach, the switches) so that every stop code a method has is reached.

``--check`` prints each method's number of cases and of cases that differ, and exits 1 on any difference.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
METHODS = ("jacobian_transpose", "pseudoinverse", "dls", "sdls", "inverse_jacobian_fd", "levenberg_marquardt",
           "pso", "jpinv_descent", "bfgs", "lbfgsb", "nelder_mead", "zero_position", "newton_raphson",
           "geometric_iterative")
ROBOTS = ("ur5e", "kuka_kr6_r700_sixx", "kuka_lwr", "kuka_iiwa14", "franka_panda", "stanford", "cartesiano", "elbow",
          "scara")
VARIANTS = (("default", {}), ("restarts", {"restarts": 2}), ("limits", {"require_limits": True}),
            ("limits_restarts", {"require_limits": True, "restarts": 1}), ("position", {"criterion": "position"}),
            ("dq_norm", {"criterion": "dq_norm"}), ("mm", {"length_unit": "mm"}))
_JAC = (("cap", {"max_iterations": 3}), ("ik_time", {"time_ik_block": True}),
        ("no_stops", {"disable_stall": True, "disable_grow": True, "max_iterations": 40, "tol_pos": 1e-13,
                      "tol_rot": 1e-13}))
EXTRA = {  # --extra: settings that reach each method's other stop codes
    **{m: _JAC for m in ("jacobian_transpose", "pseudoinverse", "dls", "sdls")},
    "newton_raphson": (("error_norm", {"stop_test": "error_norm"}), ("cap", {"max_iterations": 2}),
                       ("tight", {"tol_pos": 1e-13, "tol_rot": 1e-13, "max_iterations": 30})),
    "zero_position": (("error_norm", {"stop_test": "delta_sum"}), ("cap", {"max_iterations": 2}),
                      ("tight", {"tol_pos": 1e-13, "tol_rot": 1e-13, "max_iterations": 30})),
    "geometric_iterative": (("cap", {"max_iterations": 2}), ("base_to_tip", {"order": "base_to_tip"})),
    "levenberg_marquardt": (("vector", {"residual": "vector"}), ("cap", {"max_iterations": 3}),
                            ("tight", {"tol_pos": 1e-13, "tol_rot": 1e-13})),
    "inverse_jacobian_fd": (("change", {"stop": "error_change"}), ("cap", {"max_iterations": 3}),
                            ("tight", {"stop": "error_change", "tol_pos": 1e-13, "tol_rot": 1e-13})),
    "pso": (("no_stop", {"stop_at_tolerance": False, "max_iterations": 20}), ("cap", {"max_iterations": 3})),
    "jpinv_descent": (("listing", {"halvings": 0, "damping": 0.0, "stop_at_tolerance": False, "max_iterations": 30}),
                      ("cap", {"max_iterations": 3}), ("clamp", {"max_step": 0.05, "max_iterations": 100}),
                      ("tight", {"halvings": 2, "tol_pos": 1e-13, "tol_rot": 1e-13, "tolerance": 1e-16})),
}
SLOW = {"pso", "nelder_mead", "bfgs", "lbfgsb", "jpinv_descent", "levenberg_marquardt", "inverse_jacobian_fd"}


def problems(model, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` goals (4, 4) in the robot file's unit and starts (n,): two thirds near the goal's joint values."""
    from pipeline.kinematics import fk_htm
    from pipeline.solvers import NotApplicableError, Prepared

    try:
        box = Prepared(model, model.length_unit).search_box()
    except NotApplicableError:  # a prismatic joint without limits: 0 to half a metre
        reach = 500.0 if model.length_unit == "mm" else 0.5
        box = np.where(model.chain.prismatic[:, None], [0.0, reach], [-np.pi, np.pi])
    rng = np.random.default_rng(seed)
    qg = box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random((n, model.n))
    far = box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random((n, model.n))
    scale = np.where(model.chain.prismatic, 0.1 * (box[:, 1] - box[:, 0]), 1.0)
    near = qg + rng.normal(scale=0.3, size=qg.shape) * scale
    starts = np.where((np.arange(n) < (2 * n) // 3)[:, None], near, far)
    return np.array([fk_htm(model.chain, q) for q in qg]), starts


def fields(r) -> dict[str, str]:
    """One result's fields but timings, each as an exact text (floats by their bytes)."""
    def exact(a) -> str:
        a = np.ascontiguousarray(np.asarray(a, dtype=float))
        return f"{a.shape}:{hashlib.sha1(a.tobytes()).hexdigest()[:20]}"

    info = {k: v for k, v in sorted(r.info.items()) if "time" not in k}
    return {"q": exact(r.q), "trace": exact(r.trace), "success": str(bool(r.success)),
            "stop_reason": str(int(r.stop_reason)), "iterations": str(int(r.iterations)),
            "claimed_success": str(bool(r.claimed_success)), "within_limits": str(bool(r.within_limits)),
            "errors": exact([r.position_error, r.orientation_error]), "unit": r.length_unit,
            "info": json.dumps(info, sort_keys=True, default=str)}


def collect(only: set[str] | None, extra: bool = False) -> dict[str, dict[str, str]]:
    """case key ``method/robot/variant/way/i`` -> fields."""
    from pipeline.robots import load_robot
    from pipeline.solvers import NotApplicableError, SettingsError, bind, get, make_settings, prepare, solve_batch

    out = {}
    models = {r: load_robot(ROOT / "data" / "robots" / f"{r}.yaml") for r in ROBOTS}
    for name in METHODS:
        if only and name not in only:
            continue
        n_goals = 4 if name in SLOW else 9
        for k, (r, model) in enumerate(models.items()):
            goals, starts = problems(model, n_goals, 11 + k)
            seeds = np.arange(n_goals, dtype=np.int64) + 500
            for vname, mapping in EXTRA.get(name, ()) if extra else VARIANTS:
                try:
                    s = make_settings(name, mapping)
                    prep = prepare(name, model, s)
                except (SettingsError, NotApplicableError):
                    continue
                key = f"{name}/{r}/{vname}"
                b = bind(name, prep, s)
                for i in range(n_goals):
                    out[f"{key}/single/{i}"] = fields(b.solve(goals[i], starts[i], int(seeds[i])))
                for tr in (True, False) if get(name).batch is not None else (True,):
                    res = solve_batch(name, prep, goals, starts, s, seeds=seeds, threads=1, traces=tr)
                    for i in range(n_goals):
                        f = fields(res.result(i))
                        if not tr:
                            f.pop("trace")
                        out[f"{key}/batch{'' if tr else '_notrace'}/{i}"] = f
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--record", type=Path)
    ap.add_argument("--check", type=Path)
    ap.add_argument("--only", default="")
    ap.add_argument("--extra", action="store_true", help="the settings of EXTRA instead of VARIANTS")
    a = ap.parse_args()
    sys.path.insert(0, str(ROOT))
    only = set(a.only.split(",")) - {""} or None
    now = collect(only, a.extra)
    if a.record:
        a.record.write_text(json.dumps(now, sort_keys=True))
        print(f"{len(now)} cases recorded in {a.record}")
        return 0
    want = {k: v for k, v in json.loads(a.check.read_text()).items() if not only or k.split("/")[0] in only}
    bad = 0
    for m in sorted({k.split("/")[0] for k in want}):
        keys = [k for k in want if k.split("/")[0] == m]
        diff = [k for k in keys if now.get(k) != want[k]]
        bad += len(diff)
        print(f"{m:22s} {len(keys):5d} cases  {len(diff):4d} differ" + (f"  e.g. {diff[0]}: " + str(
            {f: (now.get(diff[0], {}).get(f), v) for f, v in want[diff[0]].items()
             if now.get(diff[0], {}).get(f) != v}) if diff else ""))
    missing = sorted(set(want) ^ set(now))
    if missing:
        print(f"{len(missing)} cases only on one side, e.g. {missing[:3]}")
    return 1 if bad or missing else 0


if __name__ == "__main__":
    sys.exit(main())
