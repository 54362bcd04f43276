"""Peer closed forms by subproblem decomposition as registered baselines: EAIK and IK-Geo.

Both libraries solve the IK of a revolute arm given in product-of-exponentials form: joint axis
directions ``H`` and one point on each axis ``P`` at q = 0, decomposed into Paden-Kahan subproblems;
both return every solution of a goal. As in :mod:`pipeline.solvers.peers.libraries`, nothing here re-implements
a peer's method, a missing library is a one-line refusal ("not installed: pip install ...") and
importing :mod:`pipeline.solvers` never imports a peer library (the first ``prepare`` does).

The model (both peers), built once per :class:`~pipeline.solvers.core.Prepared` from
:meth:`~pipeline.kinematics.chain.Chain.as_general` in metres, base included: with ``F_i`` the frame
of joint i at q = 0 (``base · origin_1 ⋯ origin_i``) and ``F_T = F_n · tool``, ``h_i = R(F_i) axis_i``,
the point on axis i is ``F_i``'s origin, ``p_{0,1}`` runs from the world origin to axis 1,
``p_{i,i+1}`` between the points of consecutive axes, ``p_{n,T}`` to the flange/tool origin and
``R_{nT} = R(F_T)``. The libraries' joint angles are ours (q = 0 is our q = 0, joint offsets are
inside the origins), so goals go in as given (world frame, metres) and answers come back unchanged.

``eaik``
    EAIK (Ostermeier, Külz & Althoff 2025, "Automatic geometric decomposition for analytical
    inverse kinematics", IEEE RA-L; https://github.com/OstermD/EAIK; C++ behind pybind11): the
    library classifies the geometry itself (intersecting / parallel axes, moving the points along
    the axes as needed) and solves its kinematic family in closed form or by a 1-D/2-D search.
    Model: ``eaik.IK_Homogeneous.HomogeneousRobot`` of the frames ``(R: z -> h_i, p_i)`` and
    ``F_T`` (EAIK's H/P constructor with ``R6T``); checked once per robot: the library's H and P equal
    ours and its ``fwdKin`` reproduces our FK to 1e-9 m at fixed joint vectors. EAIK 1.2.2 solves
    revolute arms of 1 to 6 joints (it refuses more: "only 1-6R robots are solvable"), so the peer
    applies to those whose decomposition EAIK knows (``hasKnownDecomposition()``); the family it
    picked (``getKinematicFamily()``, e.g. ``6R-SPHERICAL_SECOND_TWO_PARALLEL``) is in ``info``.
    Call: ``robot.IK(T)`` and reading its ``Q`` / ``is_LS`` (the result object's conversion).
``ik_geo``
    IK-Geo (Elias & Wen, "IK-Geo: Unified robot inverse kinematics using subproblem
    decomposition", arXiv:2211.05737, Mechanism and Machine Theory 2025;
    https://github.com/rpiRobotics/ik-geo; its Rust port behind PyO3, PyPI ``ik-geo``). The caller
    names the decomposition; it is picked here from the geometry, tolerance ``GEO_TOL`` (parallel:
    ``|h_i × h_j| <= GEO_TOL``; intersecting: the axes' distance ``<= GEO_TOL ×`` the chain's length),
    in this order: spherical wrist (axes 4, 5, 6 through one point) with h2 ∥ h3 ->
    ``spherical_two_parallel``, with axes 1, 2 intersecting -> ``spherical_two_intersecting``, else
    ``spherical``; h2 ∥ h3 ∥ h4 with axes 5, 6 intersecting -> ``three_parallel_two_intersecting``,
    else ``three_parallel``. IK-Geo's searching families (``two_parallel``, ``two_intersecting``:
    1-D search; ``gen_six_dof``: 2-D search) are not used: their answers are not refined (about 1e-5
    to 1e-4 m off on random general 6R arms, so the 0.1 mm check rejects many) and their search
    panicked inside the library on the Kinova Gen3 lite (a Rust panic prints to stderr); an arm
    that only they would fit is refused naming its geometry. The points are moved along
    their axes onto the intersections the decomposition assumes (``p_45 = p_56 = 0`` for a spherical
    wrist, ``p_56 = 0`` for intersecting axes 5, 6, ``p_12 = 0`` for intersecting axes 1, 2), which
    leaves the kinematics unchanged. IK-Geo has no tool rotation: the goal's rotation goes in as
    ``R_0T R_{6T}ᵀ``. ik-geo 1.0.3's Python binding reads the 3×3 rotation of ``get_ik`` and returns
    that of ``forward_kinematics`` transposed (column-major), against its ``.pyi``; the convention is
    detected once per robot from ``forward_kinematics`` against our FK, and the model is then checked
    by solving the IK of fixed joint vectors (our FK must reproduce each goal from one answer to
    ``IK_MATCH_TOL``); a decomposition that fails the check gives way to the next one that fits.
    A Rust panic inside the library is still caught: no answer, and ``info["panic"]`` says so.
    Applies to 6R arms
    only (the library's ``Robot`` takes 6 axes and 7 points); anything else is refused in one line
    naming the geometry. Call: ``robot.get_ik(R, p)``.

Shared by both (and as ``ur_analytic_ik``): ``iterations`` = 0, no trace. Every solution the library
returns (least-squares ones included, counted in ``info``) is checked by our compiled FK (that of
:func:`pipeline.solvers.core.finish`) against the goal with the settings' criterion and tolerances,
the ones the result itself is judged by; the FK-valid ones are kept in ``solutions`` (wrapped to
(−π, π]; under ``require_limits`` only those that lie within the limits after moving revolute joints
by 2π, as they lie there) and ``info["n_solutions"]`` counts them. ``q`` is the kept solution nearest
``q_start`` (sum of squared wrapped joint differences), unwrapped to lie within π of ``q_start`` per
joint (under ``require_limits`` the 2π-representative within the limits nearest ``q_start``). No
FK-valid solution: ``NO_SOLUTION`` with ``q = q_start``; FK-valid ones but none within the limits
(``require_limits``): the nearest FK-valid one, which the result marks ``OUT_OF_LIMITS``.
``solve_time_s`` is the whole library call (``clock_ns`` around it, binding overhead included); the
choice of a solution and the FK checks of all of them are only in ``call_time_s``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from pipeline.kinematics import fk_htm
from pipeline.kinematics.fkcheck import check_one
from pipeline.solvers.core import CRITERION_CODE, Prepared, Raw, Settings
from pipeline.solvers.core.models import POE, metric, poe, revolute_only, six_revolute
from pipeline.solvers.kernels.kin import NO_SOLUTION, SUCCESS
from pipeline.solvers.peers.libraries import TIME, library, wrap_angle, z_to
from pipeline.solvers.core.registry import Solver, register
from pipeline.solvers.core.timing import clock_ns

SOURCE_EAIK = ("Ostermeier, Külz & Althoff (2025), Automatic geometric decomposition for analytical inverse "
               "kinematics, IEEE RA-L; eaik 1.2.2 (C++, pybind11)")
SOURCE_IKGEO = ("Elias & Wen, IK-Geo: Unified robot inverse kinematics using subproblem decomposition, "
                "arXiv:2211.05737 (Mechanism and Machine Theory 2025); ik-geo 1.0.3 (Rust, PyO3)")

FK_MATCH_TOL = 1e-9  # [m, 1] a peer model's FK must reproduce ours to this
IK_MATCH_TOL = 1e-3  # [m, 1] ik_geo's model check: one answer's FK reproduces each test goal to this (a wrong
# convention or decomposition is off by O(0.1-1); the searching families' answers are only ~1e-5-1e-4 m exact)
GEO_TOL = 1e-9  # parallel: |h_i x h_j| <= GEO_TOL; intersecting: distance <= GEO_TOL x the chain's length
EAIK_MAX_JOINTS = 6  # EAIK 1.2.2 solves 1-6R arms
_QS = np.random.default_rng(2025).uniform(-math.pi, math.pi, (4, 6))  # the models' check configurations


# ---- shared helpers -----------------------------------------------------------------------
def _panic(exc: BaseException) -> bool:
    """A Rust panic surfaced by PyO3 (``pyo3_runtime.PanicException`` derives from BaseException)."""
    return type(exc).__name__ == "PanicException"


def _fk_errors(T: np.ndarray, ours: np.ndarray) -> float:
    return float(np.abs(np.asarray(T, dtype=float) - ours).max())


_TWO_PI_STEPS = (0.0, -2 * math.pi, 2 * math.pi, -4 * math.pi, 4 * math.pi)  # nearest the start first
LIMIT_SLACK = 1e-9  # [rad | length] a representative this far outside a limit still counts as within it


@numba.njit(cache=True, error_model="numpy")
def _select(K, axis, offset, prism, S, ls, has_ls, q0, Tg, crit, tol_pos, tol_rot, tol_dq, limits, require, q_out,
            listed):
    """The all-solutions rule in one compiled call (see the module docstring): FK-check every row of ``S``
    (m, n), keep the valid ones (within the limits after whole turns under ``require``) in ``listed``, write
    the kept one nearest ``q0`` to ``q_out``; returns (code, chosen row of listed or -1, rows listed, FK-valid,
    FK-valid and not least-squares)."""
    m, n = S.shape
    buf = np.empty(8)
    valid = np.empty(m, np.int64)
    n_valid = n_exact = 0
    for i in range(m):
        finite = True
        for j in range(n):
            if not math.isfinite(S[i, j]):
                finite = False
        if finite and check_one(K, axis, offset, prism, S[i], Tg, crit, tol_pos, tol_rot, tol_dq, buf)[0]:
            valid[n_valid] = i
            n_valid += 1
            if not (has_ls and ls[i]):
                n_exact += 1
    y = np.empty(n)
    n_listed, best, best_d = 0, -1, math.inf
    for k in range(n_valid):
        i = valid[k]
        inside = True
        for j in range(n):
            v = q0[j] + wrap_angle(S[i, j] - q0[j])
            if require:
                hit = False
                for step in _TWO_PI_STEPS:
                    c = v + step
                    if c >= limits[j, 0] - LIMIT_SLACK and c <= limits[j, 1] + LIMIT_SLACK:
                        v, hit = c, True
                        break
                inside = inside and hit
            y[j] = v
        if not inside:
            continue
        d = 0.0
        for j in range(n):
            listed[n_listed, j] = y[j] if require else wrap_angle(S[i, j])
            d += (y[j] - q0[j]) ** 2
        if d < best_d:
            best_d, best = d, n_listed
            q_out[:] = y
        n_listed += 1
    if best >= 0:
        return SUCCESS, best, n_listed, n_valid, n_exact
    if n_valid == 0:
        q_out[:] = q0
        return NO_SOLUTION, -1, 0, 0, 0
    # require_limits: FK-valid, none within the limits -> the nearest FK-valid one (the result says OUT_OF_LIMITS)
    for k in range(n_valid):
        d = 0.0
        for j in range(n):
            y[j] = q0[j] + wrap_angle(S[valid[k], j] - q0[j])
            d += (y[j] - q0[j]) ** 2
        if d < best_d:
            best_d = d
            q_out[:] = y
    return SUCCESS, -1, 0, n_valid, n_exact


def _result(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: Settings, S, ls, ns: int,
            info: dict) -> Raw:
    """Raw of an all-solutions peer: the FK-valid solutions kept, the one nearest the start chosen."""
    n = prep.n
    S = np.ascontiguousarray(np.asarray(S, dtype=float).reshape(-1, n))  # EAIK's Q is column-major
    ls = np.asarray(ls, dtype=np.bool_).reshape(-1)
    has_ls = len(ls) == len(S)
    if not has_ls:
        ls = np.zeros(len(S), dtype=np.bool_)
    q0 = np.ascontiguousarray(q_start, dtype=float)
    K, axis, offset, prism = prep.check  # pipeline.solvers.core.finish's compiled FK check, set up once per robot
    q, listed = np.empty(n), np.empty_like(S)
    code, best, n_listed, n_valid, n_exact = _select(
        K, axis, offset, prism, S, ls, has_ls, q0, np.ascontiguousarray(T_goal, dtype=float),
        CRITERION_CODE[s.criterion], s.tol_pos, s.tol_rot, s.tol_dq, prep.limits, bool(s.require_limits), q, listed)
    return Raw(q=q, code=int(code), iterations=0, solve_ns=int(ns), solutions=listed[:n_listed].copy(),
               info={**info, "n_solutions": int(n_listed), "n_returned": int(len(S)),
                     "n_least_squares": int(ls.sum()) if has_ls else 0, "n_fk_valid": int(n_valid),
                     "n_fk_valid_exact": int(n_exact), "chosen": int(best)})


# ---- EAIK --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class EAIKSettings(Settings):
    """Only the base fields: EAIK has no settings of its own here (double precision, EAIK's default)."""


def _eaik_model(prep: Prepared):
    """(EAIK robot, kinematic family) or a one-line reason (str)."""
    mod = library("eaik.IK_Homogeneous")
    if isinstance(mod, str):
        return mod
    m = metric(prep)
    why = revolute_only(prep, "EAIK")
    if why:
        return why
    if not 1 <= m.n <= EAIK_MAX_JOINTS:
        return f"EAIK solves arms of 1 to {EAIK_MAX_JOINTS} revolute joints, the robot has {m.n}"
    g = poe(prep)
    frames = np.tile(np.eye(4), (m.n + 1, 1, 1))
    for i in range(m.n):
        frames[i, :3, :3] = z_to(g.H[i])[:3, :3]
        frames[i, :3, 3] = g.pts[i]
    frames[m.n] = g.T0
    try:
        robot = mod.HomogeneousRobot(frames)
    except Exception as exc:  # noqa: BLE001
        return f"EAIK could not build the model ({type(exc).__name__}: {str(exc).splitlines()[0][:120]})"
    family = str(robot.getKinematicFamily())
    if not robot.hasKnownDecomposition():
        return f"EAIK knows no subproblem decomposition of this geometry (family {family})"
    dh = max(float(np.abs(np.asarray(robot.getOriginal_H()) - g.H.T).max()),
             float(np.abs(np.asarray(robot.getOriginal_P()) - g.P().T).max()))
    err = max(_fk_errors(robot.fwdKin(q[: m.n]), fk_htm(m.model.chain, q[: m.n])) for q in _QS)
    if dh > FK_MATCH_TOL or err > FK_MATCH_TOL:
        return f"EAIK's model differs from ours (H/P by {dh:.3g}, FK by {err:.3g} m)"
    return robot, family


def _eaik_applies(prep: Prepared) -> str | None:
    r = prep.memo(("peers_geo", "eaik"), lambda: _eaik_model(prep))
    return r if isinstance(r, str) else None


def _eaik_run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: EAIKSettings, seed: int) -> Raw:
    robot, family = prep.memo(("peers_geo", "eaik"), lambda: _eaik_model(prep))
    Tm = metric(prep).goal(T_goal)
    t0 = clock_ns()
    sol = robot.IK(Tm)
    Q, ls = sol.Q, sol.is_LS
    ns = clock_ns() - t0
    return _result(prep, T_goal, q_start, s, Q, ls, ns, {"family": family})


register(Solver("eaik", f"EAIK (subproblem decomposition detected from the geometry: closed form or 1-D/2-D search), "
                f"all solutions, nearest to the start (peer baseline; {TIME})", "analytic", EAIKSettings, _eaik_run,
                applies_to=_eaik_applies, source=SOURCE_EAIK, library="eaik"))


# ---- IK-Geo ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class IKGeoSettings(Settings):
    """Only the base fields: IK-Geo's solvers have no settings of their own (the searches use fixed grids)."""


def _closest(c1, h1, c2, h2):
    """The closest points of two non-parallel lines (point, unit direction)."""
    w = c1 - c2
    b, d, e = h1 @ h2, h1 @ w, h2 @ w
    den = 1.0 - b * b
    return c1 + (b * e - d) / den * h1, c2 + (e - b * d) / den * h2


class _Geometry:
    """Which axes of a 6R arm are parallel or intersect (at q = 0, tolerances relative to its size)."""

    def __init__(self, g: POE):
        self.g = g
        self.tol = GEO_TOL * g.size

    def parallel(self, i: int, j: int) -> bool:
        return float(np.linalg.norm(np.cross(self.g.H[i], self.g.H[j]))) <= GEO_TOL

    def meet(self, i: int, j: int) -> np.ndarray | None:
        """Where axes i and j (0-based) intersect, or None."""
        if self.parallel(i, j):
            return None
        a, b = _closest(self.g.pts[i], self.g.H[i], self.g.pts[j], self.g.H[j])
        return (a + b) / 2 if np.linalg.norm(a - b) <= self.tol else None

    def wrist(self) -> np.ndarray | None:
        """The point axes 4, 5, 6 pass through, or None."""
        a, b = self.meet(3, 4), self.meet(4, 5)
        if a is None or b is None or np.linalg.norm(a - b) > self.tol:
            return None
        c = self.meet(3, 5)
        return (a + b) / 2 if c is None or np.linalg.norm(c - a) <= self.tol else None

    def describe(self) -> str:
        """The relations of consecutive axes (those of other pairs depend on the configuration)."""
        par = [f"{i + 1}-{i + 2}" for i in range(5) if self.parallel(i, i + 1)]
        meet = [f"{i + 1}-{i + 2}" for i in range(5) if self.meet(i, i + 1) is not None]
        parts = [f"parallel axes {', '.join(par) or 'none'}", f"intersecting axes {', '.join(meet) or 'none'}"]
        if self.wrist() is not None:
            parts.append("spherical wrist")
        return "; ".join(parts)

    def candidates(self) -> list[tuple[str, np.ndarray]]:
        """The decompositions that fit, preferred first, each with its points (moved along their axes)."""
        out = []
        pts = self.g.pts
        w, x12, x56 = self.wrist(), self.meet(0, 1), self.meet(4, 5)
        p23, p34 = self.parallel(1, 2), self.parallel(2, 3)
        if w is not None:
            pw = pts.copy()
            pw[3:6] = w
            if p23:
                out.append(("spherical_two_parallel", pw))
            if x12 is not None:
                p = pw.copy()
                p[0:2] = x12
                out.append(("spherical_two_intersecting", p))
            out.append(("spherical", pw))
        if p23 and p34:
            if x56 is not None:
                p = pts.copy()
                p[4:6] = x56
                out.append(("three_parallel_two_intersecting", p))
            out.append(("three_parallel", pts.copy()))
        # not the searching families (two_parallel, two_intersecting, gen_six_dof): unrefined answers
        # 1e-5 to 1e-4 m off, and Rust panics that print to stderr (seen on the Kinova Gen3 lite)
        return out


def _ikgeo_try(lib, prep: Prepared, g: POE, kind: str, pts: np.ndarray):
    """(robot, transposed) when decomposition ``kind`` reproduces our kinematics, else a reason (str)."""
    m = metric(prep)
    robot = getattr(lib.Robot, kind)(np.ascontiguousarray(g.H), np.ascontiguousarray(g.P(pts)))
    R6T = g.T0[:3, :3]
    ours = [fk_htm(m.model.chain, q) for q in _QS]
    fk = [robot.forward_kinematics(q) for q in _QS]
    perr = max(float(np.abs(np.asarray(p, dtype=float) - T[:3, 3]).max()) for (_, p), T in zip(fk, ours))
    rerr = {t: max(float(np.abs((np.asarray(R, dtype=float).T if t else np.asarray(R, dtype=float)) @ R6T
                                - T[:3, :3]).max()) for (R, _), T in zip(fk, ours)) for t in (False, True)}
    transposed = rerr[True] < rerr[False]
    if perr > FK_MATCH_TOL or rerr[transposed] > FK_MATCH_TOL:
        return f"{kind}: IK-Geo's FK differs from ours by {max(perr, rerr[transposed]):.3g}"
    for q, T in zip(_QS, ours):
        R = T[:3, :3] @ R6T.T
        sols = robot.get_ik(np.ascontiguousarray(R.T if transposed else R), np.ascontiguousarray(T[:3, 3]))
        best = math.inf
        for x, _ls in sols:
            x = np.asarray(x, dtype=float)
            if np.all(np.isfinite(x)):
                best = min(best, _fk_errors(fk_htm(m.model.chain, x), T))
        if best > IK_MATCH_TOL:
            return f"{kind} ({len(sols)} answers, none reproduces a test goal)"
    return robot, bool(transposed)


def _ikgeo_model(prep: Prepared):
    """(IK-Geo robot, decomposition, rotation transposed, R_6T) or a one-line reason (str)."""
    lib = library("ik_geo")
    if isinstance(lib, str):
        return lib
    why = six_revolute(prep, "IK-Geo")
    if why:
        return why
    g = poe(prep)
    geo = _Geometry(g)
    tried = []
    for kind, pts in geo.candidates():
        try:
            r = _ikgeo_try(lib, prep, g, kind, pts)
        except Exception as exc:  # noqa: BLE001
            r = f"{kind}: {type(exc).__name__}: {str(exc).splitlines()[0][:80]}"
        except BaseException as exc:  # a Rust panic inside the library
            if not _panic(exc):
                raise
            r = f"{kind}: the library panicked ({str(exc).splitlines()[0][:60]})"
        if not isinstance(r, str):
            return r[0], kind, r[1], np.ascontiguousarray(g.T0[:3, :3].T)
        tried.append(r)
    return f"no IK-Geo decomposition reproduces the arm ({geo.describe()}; tried {', '.join(tried)})"[:400]


def _ikgeo_applies(prep: Prepared) -> str | None:
    r = prep.memo(("peers_geo", "ik_geo"), lambda: _ikgeo_model(prep))
    return r if isinstance(r, str) else None


def _ikgeo_run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: IKGeoSettings, seed: int) -> Raw:
    robot, kind, transposed, R_T6 = prep.memo(("peers_geo", "ik_geo"), lambda: _ikgeo_model(prep))
    Tm = metric(prep).goal(T_goal)
    R = Tm[:3, :3] @ R_T6
    R = np.ascontiguousarray(R.T) if transposed else R
    p = np.ascontiguousarray(Tm[:3, 3])
    panic = ""
    t0 = clock_ns()
    try:
        sols = robot.get_ik(R, p)
    except BaseException as exc:  # a Rust panic (seen in the 1-D search of two_parallel): no answer
        if not _panic(exc):
            raise
        sols, panic = [], str(exc).splitlines()[0][:120]
    ns = clock_ns() - t0
    Q = [x for x, _ in sols]
    ls = [bool(b) for _, b in sols]
    info = {"family": kind, "panic": panic} if panic else {"family": kind}
    return _result(prep, T_goal, q_start, s, Q, ls, ns, info)


register(Solver("ik_geo", f"IK-Geo (subproblem decomposition picked from the arm's geometry: closed form or 1-D/2-D "
                f"search), all solutions, nearest to the start (peer baseline; {TIME})", "analytic", IKGeoSettings,
                _ikgeo_run, applies_to=_ikgeo_applies, source=SOURCE_IKGEO, library="ik-geo"))
