"""The closed forms' answers, recorded on one checkout and compared on another, bit for bit.

Usage::

    python benchmarks/closed_form_identity.py record out.npz      # in the reference checkout
    python benchmarks/closed_form_identity.py compare out.npz     # in the changed one: exit 1 on a difference
    python benchmarks/closed_form_identity.py compare a.npz b.npz # two recordings

For every case (an arm and a closed-form method: the geometric ``analytic`` on a spherical-wrist, a
three-parallel, a searching and a general 6R arm, the 4-DOF arm and 7R arms through the search; the
documents' ``analytic_ur``, ``analytic_puma``, ``analytic_4dof`` and ``general_6r``), with
``require_limits`` False and True: goals = FK of joint angles uniform within the limits (seed 11), some
moved out of reach; starts likewise. Recorded per goal through ``pipeline.solvers.solve``: the chosen
joints, every solution, success, stop code, iterations and the FK-check errors; the same through
``pipeline.solvers.solve_batch`` on all goals at once (the 8-goal lanes on spherical-wrist and
three-parallel arms). Every float is compared by its bits (NaN equal to NaN).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # this checkout's package, not an installed one
    sys.path.insert(0, str(ROOT))

from pipeline.kinematics import fk_htm
from pipeline.robots import load_robot, parse_robot
from pipeline.solvers import make_settings, prepare, solve, solve_batch


def _general_arm():
    """A 6R arm no family fits (skewed twists, every length non-zero): the general elimination."""
    joints = [{"type": "revolute", "a": a, "alpha": al, "d": d, "theta_offset": 0.0}
              for a, al, d in ((0.11, 0.7, 0.3), (0.42, -0.4, 0.05), (0.09, 1.1, 0.12), (0.05, -0.9, 0.38),
                               (0.07, 0.6, 0.04), (0.02, -0.3, 0.09))]
    return parse_robot({"name": "general6", "source": "identity", "length_unit": "m", "convention": "standard",
                        "joints": joints})


CASES = [  # (label, robot name or builder, method, goals)
    ("ur5e/analytic", "ur5e", "analytic", 40),
    ("ur5e/analytic_ur", "ur5e", "analytic_ur", 40),
    ("puma560/analytic", "puma560", "analytic", 40),
    ("puma560/analytic_puma", "puma560", "analytic_puma", 40),
    ("kuka_kr6/analytic", "kuka_kr6_r700_sixx", "analytic", 40),
    ("abb_irb2400/analytic", "abb_irb2400", "analytic", 40),
    ("fanuc_lrmate200id/analytic", "fanuc_lrmate200id", "analytic", 40),
    ("fanuc_crx10ia/analytic", "fanuc_crx10ia", "analytic", 16),
    ("kinova_gen3_lite/analytic", "kinova_gen3_lite", "analytic", 16),
    ("mariano_4dof/analytic_4dof", "mariano_4dof", "analytic_4dof", 40),
    ("franka_panda/analytic", "franka_panda", "analytic", 6),
    ("kuka_iiwa14/analytic", "kuka_iiwa14", "analytic", 6),
    ("rethink_sawyer/analytic", "rethink_sawyer", "analytic", 4),
    ("general6/analytic", _general_arm, "analytic", 8),
    ("general6/general_6r", _general_arm, "general_6r", 8),
]


def _problems(model, n: int, seed: int = 11):
    rng = np.random.default_rng(seed)
    lim = np.clip(np.asarray(model.limits, dtype=float), -np.pi, np.pi)
    lo, hi = lim[:, 0], lim[:, 1]
    qs = lo + (hi - lo) * rng.random((n, model.n))
    goals = np.array([fk_htm(model.chain, q) for q in qs])
    goals[5::7, :3, 3] *= 4.0  # out of reach
    starts = lo + (hi - lo) * rng.random((n, model.n))
    return goals, starts


def _record(label, arm, method, n) -> dict:
    model = load_robot(arm) if isinstance(arm, str) else arm()
    goals, starts = _problems(model, n)
    out = {}
    for rl in (False, True):
        s = make_settings(method, {"require_limits": rl})
        prep = prepare(method, model, s)
        key = f"{label}/rl={int(rl)}"
        q, sols, nsol, flags, errs, family = [], [], [], [], [], ""
        for T, q0 in zip(goals, starts):
            r = solve(method, prep, T, q0, s)
            family = family or str(r.info.get("family", ""))
            q.append(r.q)
            S = np.zeros((0, model.n)) if r.solutions is None else np.asarray(r.solutions, dtype=float)
            sols.append(S.reshape(-1, model.n))
            nsol.append(len(S))
            flags.append((int(r.success), int(r.stop_reason), int(r.iterations), int(r.claimed_success),
                          int(r.within_limits)))
            errs.append((r.position_error, r.orientation_error))
        out[f"{key}/solve/q"] = np.array(q)
        out[f"{key}/solve/solutions"] = np.concatenate(sols) if sols else np.zeros((0, model.n))
        out[f"{key}/solve/nsol"] = np.array(nsol)
        out[f"{key}/solve/flags"] = np.array(flags)
        out[f"{key}/solve/errors"] = np.array(errs)
        b = solve_batch(method, prep, goals, starts, s, traces=False)
        out[f"{key}/batch/q"] = b.q
        out[f"{key}/batch/flags"] = np.stack([b.success, b.stop_reason, b.iterations, b.claimed_success,
                                              b.within_limits]).T.astype(np.int64)
        out[f"{key}/batch/errors"] = np.stack([b.position_error, b.orientation_error]).T
        if b.solutions is not None:
            out[f"{key}/batch/solutions"] = np.asarray(b.solutions)
        if b.n_solutions is not None:
            out[f"{key}/batch/nsol"] = np.asarray(b.n_solutions)
        print(f"{key}: success solve {int(np.array(flags)[:, 0].sum())}/{n}, batch {int(b.success.sum())}/{n}, "
              f"solutions {sum(nsol)}; {family}", flush=True)
    return out


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    if a.dtype.kind == "f":
        return bool(np.array_equal(a.view(np.uint64 if a.itemsize == 8 else np.uint32),
                                   b.view(np.uint64 if b.itemsize == 8 else np.uint32)))
    return bool(np.array_equal(a, b))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mode", choices=["record", "compare"])
    ap.add_argument("file")
    ap.add_argument("other", nargs="?", help="compare: a second recording to compare with, instead of solving now")
    a = ap.parse_args(argv)
    now = {}
    if a.other:
        now = dict(np.load(a.other))
    else:
        for case in CASES:
            now.update(_record(*case))
    if a.mode == "record":
        np.savez(a.file, **now)
        print(f"recorded {len(now)} arrays to {a.file}")
        return 0
    ref = dict(np.load(a.file))
    bad = sorted(k for k in ref.keys() | now.keys() if k not in ref or k not in now or not _same(ref[k], now[k]))
    for k in bad:
        print(f"DIFFERENT: {k}")
    print(f"{len(ref)} arrays compared: {len(bad)} different")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
