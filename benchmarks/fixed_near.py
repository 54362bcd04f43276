"""Issue 42's checks of ``analytic``'s held joints and near-family arms, on many goals.

Usage::

    python benchmarks/fixed_near.py [--goals 2000] [--near-goals 500] [--robots franka_panda,kuka_iiwa14,kinova_gen3]
                                    [--joints 1,2,3,4,5,6,7] [--seed 42] [--out benchmarks/results/fixed_near.md]

Held joints
-----------
For each 7R robot and each joint j of ``--joints``: a value v drawn once in the joint's limits (seeded by
``--seed``, the robot and j); ``--goals`` goals are the FK of joint vectors drawn uniformly in the limits
with joint j set to v. ``analytic`` with ``{"fixed_joints": {j: v}}`` solves each from the zero start.
Counted: success (the result rule's independent FK check of ``q``), the generating vector among
``solutions`` (every joint within 1e-6 rad, wrapped), every solution FK-valid (|Δp| <= 1e-9 m,
|ΔR| <= 1e-9 per entry, ``fk_htm``), no two solutions within ``DISTINCT_TOL``, the family used.

Near-family arm
---------------
``tests/data/irb2400_rounded.urdf`` (the ABB IRB 2400 with every angle and length typed to four
decimals) against ``data/robots/abb_irb2400.yaml`` (the exact arm): ``--near-goals`` goals from the
rounded arm; the rounded arm's set must have the exact arm's count with each solution within 1e-3 rad (and, counted
apart, 5e-2 rad) of one of the exact arm's (two arms 0.3 µm and 7e-6 rad apart: ~1e-6 rad, up to ~1e-2
next to a singular configuration, where a joint moves by the offset over the distance to the
singularity), and every solution FK-valid on the rounded arm (as above). The same with ``near_tol`` 0 (the strict
classification, before this change) for comparison.
"""

from __future__ import annotations

import argparse
import time
import zlib
from pathlib import Path

import numpy as np

from pipeline.kinematics import fk_htm
from pipeline.robots import load_robot, parse_robot
from pipeline.solvers import NotApplicableError, bind
from pipeline.solvers.closed_form.analytic_kernels import DISTINCT_TOL
from pipeline.urdf import import_urdf

ROOT = Path(__file__).resolve().parents[1]
FK_TOL = 1e-9
GEN_TOL = 1e-6
SAME = (1e-3, 5e-2)  # [rad] two arms 0.3 um and 7e-6 rad apart: their solutions of one goal differ by ~1e-6 rad,
#                      by up to ~1e-2 next to a singular configuration (a wrist or an elbow stretched out)


def wrapped(a, b):
    return np.abs(np.angle(np.exp(1j * (np.asarray(a) - np.asarray(b)))))


def fk_valid(chain, S, T) -> bool:
    for x in S:
        F = fk_htm(chain, x)
        if np.abs(F[:3, 3] - T[:3, 3]).max() > FK_TOL or np.abs(F[:3, :3] - T[:3, :3]).max() > FK_TOL:
            return False
    return True


def distinct(S) -> bool:
    return all(wrapped(S[i], S[j]).max() > DISTINCT_TOL for i in range(len(S)) for j in range(i))


def held_row(name: str, j: int, n_goals: int, seed: int) -> str:
    m = load_robot(ROOT / "data" / "robots" / f"{name}.yaml")
    rng = np.random.default_rng([seed, zlib.crc32(name.encode()), j])
    lim = np.where(np.isfinite(m.limits), m.limits, [-np.pi, np.pi])
    v = float(rng.uniform(*lim[j - 1]))
    try:
        b = bind("analytic", m, {"fixed_joints": {j: v}})
    except NotApplicableError as e:
        return f"| {name} | {j} | {v:.3f} | refused: {str(e).split('does not apply: ')[-1][:80]} | | | | | |"
    ok = gen = valid = dist = 0
    fam, t0 = "", time.process_time()
    for _ in range(n_goals):
        q = rng.uniform(lim[:, 0], lim[:, 1])
        q[j - 1] = v
        T = fk_htm(m.chain, q)
        r = b.solve(T, np.zeros(m.n))
        S = r.solutions if r.solutions is not None else np.zeros((0, m.n))
        ok += bool(r.success)
        if r.info.get("continuum"):  # no finite set to hold it: the generating vector is on the continuum when
            gen += wrapped(b.solve(T, q).q, q).max() < GEN_TOL  # a start there is answered with it
        else:
            gen += bool(len(S)) and wrapped(S, q).max(axis=1).min() < GEN_TOL
        valid += fk_valid(m.chain, S, T)
        dist += distinct(S)
        fam = r.info.get("family", fam)
    cpu = (time.process_time() - t0) / n_goals * 1e3
    pc = lambda k: f"{100.0 * k / n_goals:.2f} %"  # noqa: E731
    return f"| {name} | {j} | {v:.3f} | {pc(ok)} | {pc(gen)} | {pc(valid)} | {pc(dist)} | {fam} | {cpu:.2f} |"


def near_rows(n_goals: int, seed: int) -> list[str]:
    src = ROOT / "tests" / "data" / "irb2400_rounded.urdf"
    arm = parse_robot(import_urdf(src, "base_link", "tool0"), str(src))
    be = bind("analytic", load_robot(ROOT / "data" / "robots" / "abb_irb2400.yaml"), {})
    rows = []
    for near_tol in (1e-3, 0.0):
        b = bind("analytic", arm, {"near_tol": near_tol})
        rng = np.random.default_rng([seed, 2400])
        same = near = valid = gen = dist = 0
        found = want = 0
        for _ in range(n_goals):
            q = rng.uniform(arm.limits[:, 0], arm.limits[:, 1])
            T = fk_htm(arm.chain, q)
            r, e = b.solve(T, np.zeros(6)), be.solve(T, np.zeros(6))
            A = r.solutions if r.solutions is not None else np.zeros((0, 6))
            B = e.solutions
            found, want = found + len(A), want + len(B)
            dev = max([wrapped(B, x).max(axis=1).min() for x in A], default=0.0) if len(B) else np.inf
            same += len(A) == len(B) and dev <= SAME[0]
            near += len(A) == len(B) and dev <= SAME[1]
            valid += bool(r.success) and fk_valid(arm.chain, A, T)
            gen += bool(len(A)) and wrapped(A, q).max(axis=1).min() < GEN_TOL
            dist += distinct(A)
        rows.append(f"| {near_tol:g} | {r.info['family']} | {same}/{n_goals} | {near}/{n_goals} | {valid}/{n_goals} | "
                    f"{gen}/{n_goals} | {dist}/{n_goals} | {found} / {want} |")
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--goals", type=int, default=2000)
    ap.add_argument("--near-goals", type=int, default=500)
    ap.add_argument("--robots", default="franka_panda,kuka_iiwa14,kinova_gen3")
    ap.add_argument("--joints", default="1,2,3,4,5,6,7")
    ap.add_argument("--seed", type=int, default=42)
    ap.add_argument("--out", default="")
    a = ap.parse_args(argv)
    out = [f"# Held joints and a near-family arm (`python benchmarks/fixed_near.py --goals {a.goals} "
           f"--near-goals {a.near_goals}`)", "",
           f"## One joint held, {a.goals} goals each", "",
           "| robot | held joint | value [rad] | success | generating solution returned | all solutions FK-valid "
           "| solutions distinct | family | CPU ms/goal (Python loop) |", "|---|---|---|---|---|---|---|---|---|"]
    for name in a.robots.split(","):
        for j in (int(x) for x in a.joints.split(",")):
            out.append(held_row(name, j, a.goals, a.seed))
            print(out[-1], flush=True)
    out += ["", "On a continuum arm (family `spherical_pair`) no finite set holds the generating vector: its "
            "column counts the goals where a start at that vector is answered with it (it lies on the continuum)."]
    if a.near_goals > 0:
        out += ["", f"## Rounded IRB 2400 URDF against the exact arm, {a.near_goals} goals", "",
                "| near_tol | family | same set as the exact arm (1e-3 rad) | same set (5e-2 rad) | success and all "
                "FK-valid on the rounded arm | generating solution returned | distinct | solutions found / exact arm's |",
                "|---|---|---|---|---|---|---|---|"]
        out += near_rows(a.near_goals, a.seed)
    print("\n".join(out[-2:]))
    if a.out:
        Path(a.out).write_text("\n".join(out) + "\n")
        print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
