"""How many IK solutions does ``analytic`` find per goal, against an independent dense numerical search?

Usage::

    python benchmarks/solution_counts.py [--goals 200] [--starts 500] [--robots a,b,...] [--seed 11]
                                         [--jobs 2] [--no-flips] [--json out.json]

Method
------
For each robot (default: the three offset-wrist 6R arms ``ufactory_xarm6``, ``kinova_gen3_lite``,
``fanuc_crx10ia``, whose ``analytic`` IK is a one-dimensional search, and as a control the two
closed-form arms ``puma560`` and ``ur5``), ``--goals`` goals are the FK of joint vectors drawn
uniformly within the joint limits (±π where the file gives none), seeded by ``--seed`` and the
robot's name (the same goals whatever ``--robots`` lists alongside).

*Analytic*: ``pipeline.solvers.solve("analytic", model, T_goal, zeros, {})`` on the robot as loaded
(its own length unit). ``r.solutions`` are wrapped to (-π, π], and each is checked again here by
``fk_htm`` of the robot in metres: |Δp| <= 1e-9 m and rotation angle <= 1e-9 rad ("FK fail" counts
the ones that are not; they are still compared). Duplicates within 1e-6 are counted separately.

*Dense search* (knows nothing of the closed form; uses only the project's forward kinematics and
geometric Jacobian, the latter checked once against central differences of FK at start-up):
Levenberg-Marquardt on the 6-vector pose residual ``e = [p_goal - p (m), log(R_goal R^T)]``,
step ``dq = (J^T J + λ I)^-1 J^T e`` (geometric Jacobian, base frame, step capped at 1 rad per joint),
λ adapted per start (x0.2 on a decrease of |e|, x10 on an increase), vectorised over all starts of a
goal at once (batched ``fk_htm`` / ``geometric_jacobian`` on (N, 6) arrays), at most 150 iterations.
Starts: ``--starts`` uniform in [-π, π]^6 plus a 2^6 grid (joint values -π/2 + 0.1, π/2 + 0.1),
then ("flips", unless ``--no-flips``) from every distinct root found, 63 starts that add π to each
non-empty subset of joints (plus 0.05 rad of noise), repeated once more if the flips found new
roots -- a cheap way to reach roots whose basins of attraction are small. A start counts when its end
point passes |Δp| < 1e-9 m and rotation < 1e-9 rad (same independent check as above). End points are
wrapped to (-π, π] and clustered: two are the same root if their wrapped joint difference is < 1e-6
in every joint. **Joint limits are ignored** on both sides (for 6R arms ``analytic`` returns every
solution whatever the limits).

Reading the result
------------------
Per robot: ``agree`` = goals where both counts are equal; ``dense MORE`` = goals where the dense
search found more distinct roots than ``analytic`` (a root the closed form / 1-D search missed: these
are printed with goal index, both counts, the generating joint vector and each missing solution, its
FK residual and the smallest singular value of J there -- a near-singular / near-double root hints at
a tangent zero of the 1-D search residual); ``dense FEWER`` = the numerical search missed a root that
``analytic`` found and verified (a limitation of random-start Newton, not an error of ours).
For a ``dense FEWER`` goal the smallest singular value of J at the roots it missed is printed (tiny =
a goal next to a singularity, where Newton from random starts stalls on the singular set).
``sets differ`` counts goals whose counts agree but where some root of one side is not within 1e-6 of
the other's (should be 0). The count distributions ``{count: goals}`` of both sides and wall times
are printed. Solutions of a goal with a missing root are also written to ``--json``. For every goal
with a missing root, ``analytic`` is run again with ``search_samples=4096`` (default 64) and the
report says how many of the missing roots that finer grid still misses (0 = the roots were two sign
changes of the 1-D residual within one grid cell of the default grid).

Everything runs on ``--jobs`` processes (one goal per task, BLAS threads pinned to 1).
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import json  # noqa: E402
import multiprocessing as mp  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import zlib  # noqa: E402
from collections import Counter  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from pipeline.kinematics import fk_htm, geometric_jacobian  # noqa: E402
from pipeline.robots import load_robot  # noqa: E402

ROBOTS = ROOT / "data" / "robots"
OFFSET = ["ufactory_xarm6", "kinova_gen3_lite", "fanuc_crx10ia"]
CONTROL = ["puma560", "ur5"]
TOL_POS = 1e-9  # m
TOL_ROT = 1e-9  # rad
SAME = 1e-6  # rad, max wrapped joint difference of one root
STOP = 1e-12  # LM stops a start once |Δp| [m] and angle [rad] are both below this
MAX_IT = 150
LAM0, LAM_MIN, LAM_MAX = 1e-3, 1e-14, 1e8
FINE = 4096  # diagnostic re-run of analytic on goals with a missing root: search_samples (default 64)


# ----------------------------------------------------------------------------------------------- helpers

def wrap(q):
    """Angles to (-π, π]."""
    return np.pi - np.mod(np.pi - np.asarray(q, dtype=float), 2 * np.pi)


def pose_error(Tg, T):
    """Residual ``e = [p_g - p, log(R_g R^T)]`` (N, 6), |Δp| (N,) and rotation angle (N,).

    The angle is ``atan2(|vee(R_e - R_e^T)| / 2, (tr R_e - 1) / 2)``: accurate near 0 (unlike arccos)."""
    dp = Tg[..., :3, 3] - T[..., :3, 3]
    Re = Tg[..., :3, :3] @ np.swapaxes(T[..., :3, :3], -1, -2)
    v = 0.5 * np.stack([Re[..., 2, 1] - Re[..., 1, 2], Re[..., 0, 2] - Re[..., 2, 0], Re[..., 1, 0] - Re[..., 0, 1]], -1)
    s = np.linalg.norm(v, axis=-1)
    c = 0.5 * (Re[..., 0, 0] + Re[..., 1, 1] + Re[..., 2, 2] - 1.0)
    ang = np.arctan2(s, c)
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(s > 1e-10, ang / np.where(s > 0, s, 1.0), 1.0)
    w = v * f[..., None]
    big = ang > 2.5  # near π: axis from the symmetric part (v is small and inaccurate there)
    if np.any(big):
        B = Re[big]
        S = 0.5 * (B + np.swapaxes(B, -1, -2))  # = cos I + (1 - cos) a a^T
        cb = c[big][:, None, None]
        A = (S - cb * np.eye(3)) / (1.0 - cb)
        k = np.argmax(np.diagonal(A, axis1=-2, axis2=-1), axis=-1)
        ax = A[np.arange(len(B)), k]
        ax /= np.linalg.norm(ax, axis=-1, keepdims=True)
        vb = v[big]
        sgn = np.where(np.sum(ax * vb, -1) < 0, -1.0, 1.0)
        w[big] = ax * (sgn * ang[big])[:, None]
    return np.concatenate([dp, w], -1), np.linalg.norm(dp, axis=-1), ang


def cluster(Q):
    """Distinct roots of wrapped joint vectors Q (m, n): greedy, same root if max |wrap(a - b)| < SAME."""
    reps = []
    for q in Q:
        if not reps or np.min(np.max(np.abs(wrap(np.asarray(reps) - q)), axis=1)) >= SAME:
            reps.append(q)
    return np.asarray(reps).reshape(-1, Q.shape[1] if Q.ndim == 2 else 6)


def unmatched(A, B):
    """Rows of A with no row of B within SAME (wrapped)."""
    if len(A) == 0:
        return A
    if len(B) == 0:
        return A
    d = np.max(np.abs(wrap(A[:, None, :] - B[None, :, :])), axis=-1)
    return A[np.min(d, axis=1) >= SAME]


def check_jacobian(chain, rng):
    """The geometric Jacobian's linear rows against central differences of FK; angular rows against
    the rotation-vector difference. Returns the max abs difference."""
    q = rng.uniform(-np.pi, np.pi, (20, chain.n))
    J = geometric_jacobian(chain, q)
    h = 1e-6
    worst = 0.0
    for i in range(chain.n):
        dq = np.zeros(chain.n)
        dq[i] = h
        Tp, Tm = fk_htm(chain, q + dq), fk_htm(chain, q - dq)
        e, _, _ = pose_error(Tp, Tm)  # [p+ - p-, log(R+ R-^T)] ~ 2h J[:, i]
        worst = max(worst, float(np.max(np.abs(e / (2 * h) - J[:, :, i]))))
    return worst


# ----------------------------------------------------------------------------------------------- dense search

def lm(chain, Tg, Q0):
    """Vectorised Levenberg-Marquardt from every row of Q0 (N, n); returns end points (N, n)."""
    Q = np.array(Q0, dtype=float)
    N, n = Q.shape
    out = Q.copy()
    idx = np.arange(N)
    E, dp, da = pose_error(Tg, fk_htm(chain, Q))
    c = np.sum(E * E, -1)
    J = geometric_jacobian(chain, Q)
    lam = np.full(N, LAM0)
    eye = np.eye(n)
    for _ in range(MAX_IT):
        done = ((dp < STOP) & (da < STOP)) | (lam > LAM_MAX)
        if np.any(done):
            out[idx[done]] = Q[done]
            keep = ~done
            idx, Q, E, dp, da, c, J, lam = idx[keep], Q[keep], E[keep], dp[keep], da[keep], c[keep], J[keep], lam[keep]
        if len(idx) == 0:
            break
        Jt = np.swapaxes(J, -1, -2)
        A = Jt @ J + lam[:, None, None] * eye
        step = np.linalg.solve(A, (Jt @ E[..., None]))[..., 0]
        m = np.max(np.abs(step), axis=1)
        step *= np.minimum(1.0, 1.0 / np.maximum(m, 1e-300))[:, None]
        Qt = Q + step
        Et, dpt, dat = pose_error(Tg, fk_htm(chain, Qt))
        ct = np.sum(Et * Et, -1)
        acc = ct < c
        # Accept also an equal-or-tiny change at the round-off floor so the stop test can fire.
        acc |= (ct <= c) & (dpt < STOP) & (dat < STOP)
        Q[acc], E[acc], dp[acc], da[acc], c[acc] = Qt[acc], Et[acc], dpt[acc], dat[acc], ct[acc]
        if np.any(acc):
            J[acc] = geometric_jacobian(chain, Q[acc])
        lam = np.where(acc, np.maximum(lam * 0.2, LAM_MIN), lam * 10.0)
    out[idx] = Q
    return out


def converged_roots(chain, Tg, Qend):
    _, dp, da = pose_error(Tg, fk_htm(chain, Qend))
    ok = (dp < TOL_POS) & (da < TOL_ROT) & np.all(np.isfinite(Qend), axis=1)
    return wrap(Qend[ok]), int(ok.sum())


SUBSETS = np.array([[(k >> j) & 1 for j in range(6)] for k in range(1, 64)], dtype=float)  # (63, 6)


def dense_search(chain, Tg, n_starts, rng, flips=True):
    n = chain.n
    grid_levels = np.array([-np.pi / 2 + 0.1, np.pi / 2 + 0.1])
    grid = np.array(np.meshgrid(*([grid_levels] * n), indexing="ij")).reshape(n, -1).T
    starts = np.vstack([rng.uniform(-np.pi, np.pi, (n_starts, n)), grid])
    roots, n_conv = converged_roots(chain, Tg, lm(chain, Tg, starts))
    roots = cluster(roots) if len(roots) else np.zeros((0, n))
    n_tried = len(starts)
    from_flips = 0
    if flips and len(roots) and n == 6:
        expanded = np.zeros((0, n))
        for _round in range(2):
            new = unmatched(roots, expanded)
            if len(new) == 0:
                break
            S = (new[:, None, :] + np.pi * SUBSETS[None]).reshape(-1, n)
            S = S + rng.normal(0.0, 0.05, S.shape)
            r2, c2 = converged_roots(chain, Tg, lm(chain, Tg, S))
            n_tried += len(S)
            n_conv += c2
            expanded = np.vstack([expanded, new])
            if len(r2):
                extra = unmatched(cluster(r2), roots)
                from_flips += len(extra)
                if len(extra) == 0:
                    break
                roots = np.vstack([roots, extra])
    return roots, n_tried, n_conv, from_flips


# ----------------------------------------------------------------------------------------------- per goal

_W = {}


def _init(robot: str):
    model = load_robot(ROBOTS / f"{robot}.yaml")
    _W["chain_m"] = model.in_unit("m").chain


def _dense_task(args):
    g, Tg_m, n_starts, seed, arm_i, flips = args
    rng = np.random.default_rng([seed, arm_i, g])
    t0 = time.perf_counter()
    roots, tried, conv, ff = dense_search(_W["chain_m"], Tg_m, n_starts, rng, flips)
    return g, roots, tried, conv, ff, time.perf_counter() - t0


def run_robot(robot: str, arm_i: int, args, pool_factory) -> dict:
    from pipeline.solvers import solve

    model = load_robot(ROBOTS / f"{robot}.yaml")
    model_m = model.in_unit("m")
    chain_m = model_m.chain
    jac_err = check_jacobian(chain_m, np.random.default_rng(0))
    rng = np.random.default_rng([args.seed, arm_i])
    lim = np.where(np.isfinite(model.limits), model.limits, np.array([-np.pi, np.pi]))
    qg = rng.uniform(lim[:, 0], lim[:, 1], (args.goals, model.n))
    Tg = np.array([fk_htm(model.chain, q) for q in qg])
    Tg_m = np.array([fk_htm(chain_m, q) for q in qg])

    # analytic, in the main process, while the pool works on the dense search
    t_wall = time.perf_counter()
    tasks = [(g, Tg_m[g], args.starts, args.seed, arm_i, not args.no_flips) for g in range(args.goals)]
    with pool_factory(robot) as pool:
        it = pool.imap_unordered(_dense_task, tasks, chunksize=1)
        solve("analytic", model, Tg[0], np.zeros(model.n), {})  # compile once
        ana, ana_fail, ana_dup, t_ana = [], [], [], 0.0
        for g in range(args.goals):
            t0 = time.perf_counter()
            r = solve("analytic", model, Tg[g], np.zeros(model.n), {})
            t_ana += time.perf_counter() - t0
            S = np.zeros((0, model.n)) if r.solutions is None else np.asarray(r.solutions, dtype=float)
            S = wrap(S)
            if len(S):
                _, dp, da = pose_error(Tg_m[g], fk_htm(chain_m, S))
                bad = (dp > TOL_POS) | (da > TOL_ROT)
                ana_fail.append([(int(k), float(dp[k]), float(da[k])) for k in np.flatnonzero(bad)])
            else:
                ana_fail.append([])
            C = cluster(S) if len(S) else S
            ana_dup.append(len(S) - len(C))
            ana.append(C)
        dense = [None] * args.goals
        stats = [None] * args.goals
        for g, roots, tried, conv, ff, dt in it:
            dense[g] = roots
            stats[g] = (tried, conv, ff, dt)
    wall = time.perf_counter() - t_wall

    agree = more = fewer = sets_differ = 0
    more_goals, fewer_goals, differ_goals = [], [], []
    for g in range(args.goals):
        na, nd = len(ana[g]), len(dense[g])
        missing = unmatched(dense[g], ana[g])  # found by the dense search, not by analytic
        extra = unmatched(ana[g], dense[g])  # found by analytic, not by the dense search
        rec = {"goal": g, "q_goal": qg[g].tolist(), "n_analytic": na, "n_dense": nd,
               "missing_from_analytic": [], "missed_by_dense": extra.tolist()}
        for q in missing:
            _, dp, da = pose_error(Tg_m[g], fk_htm(chain_m, q))
            sv = np.linalg.svd(geometric_jacobian(chain_m, q), compute_uv=False)
            near = float(np.min(np.max(np.abs(wrap(ana[g] - q)), axis=1))) if na else float("nan")
            rec["missing_from_analytic"].append({"q": q.tolist(), "dp_m": float(dp), "angle_rad": float(da),
                                                 "sigma_min_J": float(sv[-1]), "nearest_analytic_rad": near})
        if len(extra):  # why the dense search missed them: near-singular roots attract poorly
            rec["missed_by_dense_sigma_min_J"] = [float(np.linalg.svd(geometric_jacobian(chain_m, q),
                                                                      compute_uv=False)[-1]) for q in extra]
        if len(missing):  # diagnostic: does a 64x finer 1-D search grid find them?
            r2 = solve("analytic", model, Tg[g], np.zeros(model.n), {"search_samples": FINE})
            S2 = cluster(wrap(np.asarray(r2.solutions, dtype=float))) if r2.solutions is not None and len(
                r2.solutions) else np.zeros((0, model.n))
            rec["fine_grid"] = {"search_samples": FINE, "n_analytic": len(S2),
                                "still_missing": len(unmatched(missing, S2))}
        if nd > na:
            more += 1
            more_goals.append(rec)
        elif nd < na:
            fewer += 1
            fewer_goals.append(rec)
        else:
            agree += 1
            if len(missing) or len(extra):
                sets_differ += 1
                differ_goals.append(rec)
    # goals with fewer dense roots may still hide a missing one (e.g. dense 7 = 6 shared + 1 new, analytic 8)
    hidden = [r for r in fewer_goals if r["missing_from_analytic"]]
    n_fail = sum(len(f) for f in ana_fail)
    tried = np.array([s[0] for s in stats])
    conv = np.array([s[1] for s in stats])
    return {
        "robot": robot, "length_unit": model.length_unit, "goals": args.goals, "agree": agree,
        "dense_more": more, "dense_fewer": fewer, "sets_differ_same_count": sets_differ,
        "fewer_but_missing_root": len(hidden),
        "analytic_solutions": int(sum(len(a) for a in ana)), "dense_solutions": int(sum(len(d) for d in dense)),
        "analytic_fk_fail": n_fail,
        "analytic_fk_fail_goals": [{"goal": g, "fails": f} for g, f in enumerate(ana_fail) if f],
        "analytic_duplicates": int(sum(ana_dup)),
        "counts_analytic": dict(sorted(Counter(len(a) for a in ana).items())),
        "counts_dense": dict(sorted(Counter(len(d) for d in dense).items())),
        "roots_from_flips": int(sum(s[2] for s in stats)),
        "starts_per_goal_mean": float(tried.mean()), "converged_fraction": float(conv.sum() / tried.sum()),
        "jacobian_check_max_err": jac_err,
        "time_wall_s": wall, "time_analytic_s": t_ana,
        "time_dense_cpu_s": float(sum(s[3] for s in stats)),
        "more_goals": more_goals, "fewer_goals": fewer_goals, "differ_goals": differ_goals,
    }


def fmt_counts(d: dict) -> str:
    return "{" + ", ".join(f"{k}: {v}" for k, v in d.items()) + "}"


def report(res: dict, out) -> None:
    p = lambda *a: print(*a, file=out)  # noqa: E731
    p(f"== {res['robot']}  ({res['goals']} goals)")
    p(f"   agree {res['agree']} | dense MORE {res['dense_more']} | dense FEWER {res['dense_fewer']} | "
      f"same count but sets differ {res['sets_differ_same_count']} | dense fewer yet has a root analytic lacks "
      f"{res['fewer_but_missing_root']}")
    p(f"   solutions: analytic {res['analytic_solutions']} (duplicates {res['analytic_duplicates']}, "
      f"failing independent FK check at 1e-9: {res['analytic_fk_fail']}), dense {res['dense_solutions']} "
      f"({res['roots_from_flips']} found only by the flip starts)")
    p(f"   counts analytic {fmt_counts(res['counts_analytic'])}")
    p(f"   counts dense    {fmt_counts(res['counts_dense'])}")
    p(f"   dense: {res['starts_per_goal_mean']:.0f} starts/goal, {100 * res['converged_fraction']:.1f}% converged; "
      f"Jacobian vs FD max err {res['jacobian_check_max_err']:.1e}")
    p(f"   time: wall {res['time_wall_s']:.1f} s, analytic {res['time_analytic_s']:.2f} s "
      f"({1e3 * res['time_analytic_s'] / res['goals']:.2f} ms/goal), dense CPU {res['time_dense_cpu_s']:.1f} s")
    for r in res["analytic_fk_fail_goals"]:
        p(f"   ANALYTIC FK FAIL goal {r['goal']}: " + ", ".join(f"sol {k} |dp| {a:.2e} m angle {b:.2e} rad"
                                                              for k, a, b in r['fails']))
    for tag, rows in (("DENSE MORE", res["more_goals"]), ("SETS DIFFER", res["differ_goals"]),
                      ("DENSE FEWER BUT NEW ROOT", [r for r in res["fewer_goals"] if r["missing_from_analytic"]])):
        for r in rows:
            p(f"   {tag}: goal {r['goal']} analytic {r['n_analytic']} dense {r['n_dense']}  "
              f"q_goal = {np.array2string(np.array(r['q_goal']), precision=17, separator=', ', max_line_width=10**4)}")
            if "fine_grid" in r:
                f = r["fine_grid"]
                p(f"      analytic with search_samples={f['search_samples']}: {f['n_analytic']} solutions, "
                  f"{f['still_missing']} of the missing still missing")
            for m in r["missing_from_analytic"]:
                p(f"      missing from analytic: q = "
                  f"{np.array2string(np.array(m['q']), precision=17, separator=', ', max_line_width=10**4)}"
                  f"  |dp| {m['dp_m']:.1e} m, angle {m['angle_rad']:.1e} rad, sigma_min(J) {m['sigma_min_J']:.2e}, "
                  f"nearest analytic {m['nearest_analytic_rad']:.2e} rad")
            for q in r["missed_by_dense"] if tag == "SETS DIFFER" else []:
                p(f"      analytic only: q = {np.array2string(np.array(q), precision=17, separator=', ', max_line_width=10**4)}")
    for r in res["fewer_goals"]:
        sv = r.get("missed_by_dense_sigma_min_J", [])
        p(f"   dense FEWER: goal {r['goal']} analytic {r['n_analytic']} dense {r['n_dense']}; sigma_min(J) at the "
          f"roots the dense search missed: {min(sv):.1e} .. {max(sv):.1e}" if sv else
          f"   dense FEWER: goal {r['goal']} analytic {r['n_analytic']} dense {r['n_dense']}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--goals", type=int, default=200, help="goals per robot (default 200)")
    ap.add_argument("--starts", type=int, default=500,
                    help="random Newton starts per goal (default 500; plus a 64-point grid and the flip starts)")
    ap.add_argument("--robots", default=",".join(OFFSET + CONTROL), help="comma-separated robot file names")
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1), help="processes for the dense search")
    ap.add_argument("--no-flips", action="store_true", help="no extra starts from found roots with joints + π")
    ap.add_argument("--json", metavar="OUT", help="write every number (and the suspicious goals' solutions) here")
    args = ap.parse_args(argv)

    ctx = mp.get_context("fork")

    def pool_factory(robot):
        return ctx.Pool(args.jobs, initializer=_init, initargs=(robot,))

    print(f"# python benchmarks/solution_counts.py {' '.join(argv if argv is not None else sys.argv[1:])}".rstrip())
    print(f"# {datetime.datetime.now().astimezone().isoformat(timespec='seconds')}, {args.jobs} processes, "
          f"goals {args.goals}, random starts {args.starts} + 64 grid" + ("" if args.no_flips else " + flips")
          + f", seed {args.seed}")
    import pipeline
    print(f"# pipeline package: {Path(pipeline.__file__).parent}")
    print(f"# converged: |dp| < {TOL_POS} m and angle < {TOL_ROT} rad; same root: max wrapped joint difference "
          f"< {SAME} rad; joint limits ignored")
    t0 = time.perf_counter()
    results = []
    for robot in args.robots.split(","):
        res = run_robot(robot.strip(), zlib.crc32(robot.strip().encode()), args, pool_factory)
        report(res, sys.stdout)
        sys.stdout.flush()
        results.append(res)
    total = time.perf_counter() - t0
    print()
    print(f"{'robot':18s} {'goals':>5s} {'agree':>5s} {'MORE':>5s} {'FEWER':>5s} {'differ':>6s} {'FKfail':>6s}  "
          f"{'time s':>6s}  counts analytic | dense")
    for r in results:
        print(f"{r['robot']:18s} {r['goals']:5d} {r['agree']:5d} {r['dense_more']:5d} {r['dense_fewer']:5d} "
              f"{r['sets_differ_same_count'] + r['fewer_but_missing_root']:6d} {r['analytic_fk_fail']:6d}  "
              f"{r['time_wall_s']:6.1f}  {fmt_counts(r['counts_analytic'])} | {fmt_counts(r['counts_dense'])}")
    print(f"total wall time {total:.1f} s")
    if args.json:
        Path(args.json).write_text(json.dumps({"argv": sys.argv, "total_wall_s": total, "robots": results}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
