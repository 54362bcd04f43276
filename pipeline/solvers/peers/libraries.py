"""Peer IK libraries as registered baselines: Robotics Toolbox, TRAC-IK, Pinocchio, ur_analytic_ik.

Each solver calls an installed third-party library (``pip install -e '.[peers]'``); nothing here
re-implements a peer's method. A peer that is not installed is refused by its ``applies_to`` with
"not installed: pip install ..." and every other solver runs (importing :mod:`pipeline.solvers`
never imports a peer library; the first ``prepare`` of a peer solver does).

``rtb_ik_lm``, ``rtb_ik_nr``, ``rtb_ik_gn``
    Robotics Toolbox for Python's compiled solvers ``ETS.ik_LM`` (Levenberg-Marquardt, Chan's
    damping ``W_n = k E I`` by default), ``ETS.ik_NR`` (Newton-Raphson, ``q += J^+ e``) and
    ``ETS.ik_GN`` (Gauss-Newton, ``q += (J^T J)^+ J^T e``), C++ loops behind one Python call
    (Corke & Haviland 2021, "Not your grandmother's toolbox - the Robotics Toolbox reinvented for
    Python", ICRA 2021; https://github.com/petercorke/robotics-toolbox-python). The ETS is built
    from :meth:`~pipeline.kinematics.chain.Chain.as_general` (exact for standard/modified DH and
    the general form, joint offsets folded into the fixed transforms, since rtb's C++ solvers
    refuse an ``ET.offset``): base, then per joint its fixed origin (``ET.SE3``) and its motion
    (``ET.Rx/Ry/Rz`` or ``ET.tx/ty/tz``, flipped for a negative axis; an axis off the coordinate
    axes is conjugated by fixed rotations), then the tool. rtb's error is
    ``E = ½ eᵀ e``, ``e = (p_goal − p [m], angle-axis of R_goal Rᵀ [rad])``, stop ``E < tol``; the
    default ``tol = 0`` here means ``½ min(tol_pos [m], tol_rot)²``, matched to the FK check (rtb's own
    default 1e-6 lets a claim sit up to 1.4 mm / 1.4e-3 rad off, and the 0.1 mm check then rejected
    30-50 % of warm starts on the LWR, PUMA and UR5e; set ``tol: 1.0e-6`` for rtb's default).
    One search from ``q_start`` by default (``slimit = 1``; rtb's default is 100 with random
    restarts). rtb's ``joint_limits`` test rejects a converged search outside the ETS's ``qlim``
    (the robot file's limits; an unbounded revolute joint gets [−2π, 2π], an unbounded prismatic
    one ± the chain's total length, since rtb samples its restarts in that box). After a failed
    search rtb draws the next start with Eigen's ``Random`` (C ``rand()``), also after the last
    one: a failed call returns that random configuration, not the last iterate. ``srand(seed)`` of
    the C library is called before every call (outside the timed region), which makes restarts and
    a failed call's returned configuration repeatable (before, a failed single search returned an
    unseeded draw: the contract test found it).
    Stop reasons: success; every search used its iterations -> iteration cap; otherwise a search
    converged and rtb rejected it for its joint limits -> ``OUT_OF_LIMITS``. ``iterations`` is
    rtb's own counter (1.5.0 counts error evaluations, i.e. steps + 1 per search).
``trac_ik``
    TRAC-IK (Beeson & Ames 2015, "TRAC-IK: An open-source library for improved solving of generic
    inverse kinematics", IEEE-RAS Humanoids) through ``pytracik``: KDL's joint-limited
    Newton-Raphson with random restarts and an NLopt SQP run concurrently on two threads until one
    succeeds or the time budget (``timeout``) is spent. The chain is exported with
    :func:`pipeline.urdf.to_urdf` (links ``base_link`` ... ``tool0``, metres) and checked against
    our FK once per robot. TRAC-IK respects the URDF joint limits (continuous joints unbounded).
    It reports no iteration count (``iterations`` = 0). Results are NOT deterministic: the restarts
    are random, the two threads race and the budget is wall time, so ``seed`` has no effect and
    the same problem may give other angles (or a failure) on another run or machine; its solve
    time is wall time of two busy threads, not of one core. A failure (budget spent) is reported
    as the iteration cap with ``q = q_start`` (TRAC-IK returns no angles then).
``pinocchio_clik``
    Closed-loop inverse kinematics, the loop of Pinocchio's example ``inverse-kinematics.py``
    (Carpentier et al. 2019, "The Pinocchio C++ library", IEEE/SICE SII;
    https://github.com/stack-of-tasks/pinocchio), written in Python around Pinocchio's C++ calls:
    ``forwardKinematics``, ``err = log6(oMtool⁻¹ oMdes)``, stop ``‖err‖ < eps``;
    ``J = computeJointJacobian`` (local frame) moved to the tool frame, ``J = −Jlog6(iMd⁻¹) J``
    (``jlog6``; the older example omits this), ``v = −Jᵀ (J Jᵀ + damp I)⁻¹ err``,
    ``q = integrate(q, v DT)``. Defaults are the example's (eps 1e-4, IT_MAX 1000, DT 0.1,
    damp 1e-12). The ``pin.Model`` is built in code from ``as_general()``: one joint per axis
    (``JointModelRX/RY/RZ``, ``PX/PY/PZ`` for a positive coordinate axis, else
    ``Revolute/PrismaticUnaligned``), the base folded into the first joint's placement, the
    tool a frame ``tool0``. Joint limits are not used (as the example).
``ur_analytic_ik``
    The closed form of the ``ur_analytic_ik`` package (https://github.com/Victorlouisdg/ur-analytic-ik,
    C++ with Python bindings; modules ``ur3`` ... ``ur30``), all solutions of one goal. It applies
    only when the robot's standard-DH table (joint offsets aside) reproduces one built-in model's
    ``forward_kinematics`` to 1e-9 m at fixed joint vectors; base and tool are stripped from the
    goal first, offsets subtracted from its angles. The solution nearest ``q_start`` (wrapped joint
    distance) is returned, unwrapped to lie within π of ``q_start``; all (wrapped to (−π, π]) in
    ``solutions``. No solution: ``NO_SOLUTION`` with ``q = q_start``. ``iterations`` = 0 (none
    reported).

Conventions shared by every peer:

* Units: peers compute in metres whatever ``length_unit`` (which then only sets the unit of the
  reported errors): the goal, the model and prismatic joint values are converted to metres for the
  call and back afterwards. Their tolerance settings are the library's own, in m and rad.
* Timing: ``solve_time_s`` is the whole library call (``clock_ns`` around it), including its
  Python binding overhead (argument checks, conversions, result objects) - for
  ``pinocchio_clik`` the whole Python loop. Our own conversions before and after it (goal to
  metres, quaternion, choice of the nearest analytic solution) are only in ``call_time_s``.
* Success is never decided by the peer: the returned angles go through
  :func:`pipeline.solvers.core.finish` (independent FK check, joint-limit record); the peer's own
  success flag only sets the claimed stop reason. Peers always solve full-pose IK; a position-only
  criterion only relaxes the FK check.
* Traces (rtb, Pinocchio): two rows, start and returned angles, computed after the timed call:
  ``[|e|, e (6), |Δp|]`` with ``e = (p_goal − p, rotation vector of R_goal Rᵀ)`` in the working unit.
  TRAC-IK and ur_analytic_ik report no iterations (``iterations`` = 0): no trace, as the other closed
  forms (the result's one row holds |Δp| only).
* Peer models (ETS, ``pin.Model``, TRAC-IK object, UR model match) are built once per
  :class:`~pipeline.solvers.core.Prepared` (``prep.memo``).
"""

from __future__ import annotations

import ctypes
import importlib
import math
from dataclasses import dataclass

import numba
import numpy as np

from pipeline.kinematics import fk_htm
from pipeline.kinematics.chain import Chain
import pipeline.solvers.kernels.kin as _kin
from pipeline.solvers.kernels.kin import TRACE_COLS, TRACE_DP
from pipeline.solvers.core import (MAX_LIBRARY_TIMEOUT_S, Prepared, Raw, Settings, StopReason, inv_rigid, setting,
                                   wrap_into_limits)
from pipeline.solvers.core.models import Metric, metric
from pipeline.solvers.core.registry import Solver, register
from pipeline.solvers.core.timing import clock_ns

SOURCE_RTB = ("Corke & Haviland (2021), Robotics Toolbox for Python, ICRA 2021; roboticstoolbox-python 1.5.0 "
              "ETS.ik_LM / ik_NR / ik_GN (C++)")
SOURCE_TRACIK = "Beeson & Ames (2015), TRAC-IK, IEEE-RAS Humanoids; pytracik bindings"
SOURCE_PIN = ("Carpentier et al. (2019), The Pinocchio C++ library, IEEE/SICE SII; the CLIK loop of Pinocchio's "
              "examples/inverse-kinematics.py")
SOURCE_UR = "ur_analytic_ik (https://github.com/Victorlouisdg/ur-analytic-ik), closed-form UR IK"

# import name -> how to install it
INSTALL = {"roboticstoolbox": "pip install roboticstoolbox-python==1.5.0", "pytracik": "pip install pytracik",
           "pinocchio": "pip install pin", "ur_analytic_ik": "pip install ur-analytic-ik",
           "eaik": "pip install eaik==1.2.2", "ik_geo": "pip install ik-geo==1.0.3",
           "pybullet": "pip install pybullet==3.2.7", "ikpy": "pip install ikpy==4.2.1",
           "pink": "pip install pin-pink==4.4.0 daqp", "qpsolvers": "pip install qpsolvers daqp",
           "mink": "pip install mink==1.3.0", "mujoco": "pip install mujoco", "placo": "pip install placo==0.10.2"}
UR_MATCH_TOL = 1e-9  # [m, 1] a robot file matches a built-in UR model when FK agrees to this
URDF_MATCH_TOL = 1e-9  # [m, 1] the URDF TRAC-IK reads must reproduce our FK to this
TIME = "time = the whole library call incl. its Python binding overhead"


# ---- shared helpers -----------------------------------------------------------------------
def library(name: str):
    """The peer module ``name`` (a dotted name imports its package first), or a one-line reason why it
    cannot be used (a str)."""
    top = name.split(".")[0]
    try:
        return importlib.import_module(name)
    except ImportError:
        return f"not installed: {INSTALL[top]}"
    except Exception as exc:  # noqa: BLE001  (a broken install must not break prepare())
        return f"{top} cannot be imported ({type(exc).__name__}: {str(exc).splitlines()[0][:120]})"


def _missing(name: str) -> str | None:
    lib = library(name)
    return lib if isinstance(lib, str) else None


_NO_TRACE = ("trac_ik", "ur_analytic_ik")  # peers whose Raw carries no trace


def _returned(prep: Prepared, q: np.ndarray, s: Settings) -> np.ndarray:
    """The angles a peer returns: under ``require_limits`` already wrapped into the limits as
    :func:`pipeline.solvers.core.finish` would (a no-op there then), so that the trace's last row is
    the FK of the returned angles."""
    return wrap_into_limits(q, prep.limits, prep.prismatic) if s.require_limits else q


@numba.njit(cache=True)
def _trace_rows(a, alpha, d, offs, prism, form, base, tool, Tg, q0, q, out):
    """The two trace rows of :func:`_trace` into ``out`` (2, TRACE_COLS), NaN rows for non-finite angles."""
    T = np.empty((4, 4))
    qa, qb, rv = np.empty(4), np.empty(4), np.empty(3)
    for k in range(2):
        qq = q0 if k == 0 else q
        finite = True
        for j in range(qq.shape[0]):
            if not math.isfinite(qq[j]):
                finite = False
        if not finite:
            continue
        _kin.forward_pose(a, alpha, d, offs, prism, form, base, tool, qq, T)
        _kin.rotation_vector(Tg, T, qa, qb, rv)
        for r in range(3):
            out[k, 1 + r] = Tg[r, 3] - T[r, 3]
            out[k, 4 + r] = rv[r]


def _trace(prep: Prepared, T_goal: np.ndarray, q0: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Rows [|e|, e (6), |dp|] at the start and the returned angles (working unit; compiled FK and errors in
    one call, the norms by numpy's dot as before, so the rows keep their bits)."""
    out = np.full((2, TRACE_COLS), np.nan)
    _trace_rows(*prep.args, np.ascontiguousarray(T_goal, dtype=float), np.ascontiguousarray(q0, dtype=float),
                np.ascontiguousarray(q, dtype=float), out)
    for k in range(2):
        dp, rv = out[k, 1:4], out[k, 4:7]
        if dp[0] == dp[0]:  # not NaN: the row was computed
            out[k, 0] = math.sqrt(float(dp @ dp + rv @ rv))
            out[k, TRACE_DP] = math.sqrt(float(dp @ dp))
    return out


def _coordinate_axis(axis: np.ndarray) -> tuple[int, float] | None:
    """(index, sign) when ``axis`` is exactly ±x, ±y or ±z, else None."""
    nz = np.flatnonzero(axis != 0.0)
    if len(nz) == 1 and abs(abs(axis[nz[0]]) - 1.0) <= 1e-15:
        return int(nz[0]), float(np.sign(axis[nz[0]]))
    return None


def z_to(axis: np.ndarray) -> np.ndarray:
    """A rotation (4, 4) taking the z axis to the unit vector ``axis``."""
    z = np.array([0.0, 0.0, 1.0])
    v = np.cross(z, axis)
    s, c = np.linalg.norm(v), float(z @ axis)
    T = np.eye(4)
    if s < 1e-15:
        T[:3, :3] = np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
        return T
    k = v / s
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    T[:3, :3] = np.eye(3) + s * K + (1 - c) * (K @ K)
    return T


def _peer_code(ok: bool, fail: StopReason) -> int:
    return int(StopReason.SUCCESS if ok else fail)


# ---- Robotics Toolbox: ik_LM, ik_NR, ik_GN ----------------------------------------------------
_JOINT_LIMITS_DOC = ("rtb's joint_limits flag: a search that converges outside the joint box is rejected "
                     "(a failure, or a restart when slimit > 1); the box is the robot file's limits, "
                     "[-2 pi, 2 pi] for an unbounded revolute joint, +- the chain's length for an unbounded "
                     "prismatic one (rtb wraps converged angles to about [-pi, pi) first; rtb default True)")


@dataclass(frozen=True)
class RtbSettings(Settings):
    """Settings of rtb's compiled solvers (defaults: rtb 1.5.0's, except slimit)."""

    ilimit: int = setting(30, "iterations per search (rtb default 30)", minimum=1, maximum=10_000_000)
    slimit: int = setting(1, "searches: the first from q_start, then random restarts within the joint box "
                          "(rtb default 100; 1 = a single local search)", minimum=1, maximum=1_000_000)
    tol: float = setting(0.0, "rtb's stop test E = 1/2 e^T e < tol, e = (position error [m], angle-axis error "
                         "[rad]); 0 = matched to the FK check: 1/2 min(tol_pos [m], tol_rot)^2, so that a claim "
                         "implies both tolerances (rtb's own default is 1e-6, i.e. |e| < 1.4e-3: claims up to "
                         "1.4 mm off, which the 0.1 mm check rejects in 30-50 % of warm starts)", minimum=0.0)
    joint_limits: bool = setting(True, _JOINT_LIMITS_DOC)


@dataclass(frozen=True)
class RtbLMSettings(RtbSettings):
    k: float = setting(1.0, "gain of the damping matrix W_n (chan: k E I; wampler: k I; sugihara: E I + k I) "
                       "(rtb default 1.0)", above=0.0)
    damping: str = setting("chan", "damping rule of ik_LM, its argument 'method' (rtb default chan); named damping "
                                   "here because 'method' names the registered solver", choices=("chan", "wampler", "sugihara"))


@dataclass(frozen=True)
class RtbPinvSettings(RtbSettings):
    pinv: bool = setting(True, "use the pseudo-inverse (ik_NR: of J, always for n != 6; ik_GN: SVD solve of "
                         "J^T J) instead of the plain inverse (rtb default True)")
    pinv_damping: float = setting(0.0, "damping of the pseudo-inverse (rtb default 0)", minimum=0.0)


def _rtb_box(m: Metric) -> np.ndarray:
    box = m.limits.copy()
    reach = m.reach()
    for i in range(m.n):
        lo, hi = box[i]
        w = reach if m.prismatic[i] else 2 * math.pi
        box[i] = (lo if math.isfinite(lo) else -w, hi if math.isfinite(hi) else w)
    return box


def _matched_tol(m: Metric, s: Settings) -> float:
    """rtb's ``tol`` on ``E = ½ |e|²`` that implies the FK check's tolerances (settings in the working unit):
    ``½ min(b_pos [m], b_rot)²``; ``b_pos`` = tol_pos, or for the dq_norm criteria the translation
    bound ``2 sqrt(tol_dq² − 1)``; ``b_rot`` = tol_rot for pos_orient only."""
    if s.criterion in ("dq_norm", "dq_norm_body"):
        b_pos = 2.0 * math.sqrt(max(s.tol_dq ** 2 - 1.0, 0.0)) * m.to_m
    else:
        b_pos = s.tol_pos * m.to_m
    b = min(b_pos, s.tol_rot) if s.criterion == "pos_orient" else b_pos
    return max(0.5 * b * b, 1e-300)


def _rtb_ets(prep: Prepared):
    """The robot as an rtb ETS in metres (exact; see the module docstring)."""
    rtb = importlib.import_module("roboticstoolbox")
    ET, ETS = rtb.ET, rtb.ETS
    m = metric(prep)
    box = _rtb_box(m)
    els = []

    def fixed(T):
        if not np.array_equal(T, np.eye(4)):
            els.append(ET.SE3(np.array(T, dtype=float)))

    rot = (ET.Rx, ET.Ry, ET.Rz)
    lin = (ET.tx, ET.ty, ET.tz)
    fixed(m.base)
    for i in range(m.n):
        fixed(m.origins[i])
        kinds = lin if m.prismatic[i] else rot
        ca = _coordinate_axis(m.axes[i])
        if ca is not None:
            els.append(kinds[ca[0]](jindex=i, flip=ca[1] < 0, qlim=list(box[i])))
        else:
            R = z_to(m.axes[i])
            fixed(R)
            els.append(kinds[2](jindex=i, qlim=list(box[i])))
            fixed(inv_rigid(R))
    fixed(m.tool)
    return ETS(els)


_libc = None


def _srand(seed: int) -> None:
    """Seed the C library's rand(), which rtb's restarts draw from (Eigen's Random)."""
    global _libc
    if _libc is None:
        _libc = ctypes.CDLL(None)
    _libc.srand(ctypes.c_uint(seed & 0xFFFFFFFF))


def _model_applies(prep: Prepared, module: str, key: str, build, what: str) -> str | None:
    """A peer applies when its library imports and it can build its model of the robot (memoised)."""
    why = _missing(module)
    if why:
        return why
    try:
        prep.memo(("peers", key), lambda: build(prep))
    except Exception as exc:  # noqa: BLE001
        return f"{what} ({type(exc).__name__}: {str(exc).splitlines()[0][:120]})"
    return None


def _rtb_applies(prep: Prepared) -> str | None:
    return _model_applies(prep, "roboticstoolbox", "rtb_ets", _rtb_ets, "rtb could not build the ETS")


def _rtb_run(method: str):
    def run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: RtbSettings, seed: int) -> Raw:
        m = metric(prep)
        ets = prep.memo(("peers", "rtb_ets"), lambda: _rtb_ets(prep))
        Tm = m.goal(T_goal)
        q0 = m.q_in(q_start)
        extra = ({"k": float(s.k), "method": s.damping} if method == "ik_LM"
                 else {"pinv": bool(s.pinv), "pinv_damping": float(s.pinv_damping)})
        _srand(seed)
        fn = getattr(ets, method)
        tol = float(s.tol) if s.tol > 0 else prep.memo(("peers", "rtb_tol", s), lambda: _matched_tol(m, s))
        t0 = clock_ns()
        sol = fn(Tm, q0=q0, ilimit=int(s.ilimit), slimit=int(s.slimit), tol=tol,
                 joint_limits=bool(s.joint_limits), **extra)
        ns = clock_ns() - t0
        q = _returned(prep, m.q_out(sol.q), s)
        it = int(sol.iterations)
        capped = it >= s.slimit * (s.ilimit + 1)  # rtb 1.5.0: a capped search counts ilimit + 1
        code = _peer_code(bool(sol.success), StopReason.ITERATION_CAP if capped else StopReason.OUT_OF_LIMITS)
        if not np.all(np.isfinite(q)):
            code = int(StopReason.NON_FINITE)
        return Raw(q=q, code=code, iterations=it, solve_ns=int(ns), trace=_trace(prep, T_goal, q_start, q),
                   info={"searches": int(sol.searches), "residual": float(sol.residual), "tol": tol,
                         "peer_success": bool(sol.success)})
    return run


for _name, _method, _cls, _what in (
        ("rtb_ik_lm", "ik_LM", RtbLMSettings, "Levenberg-Marquardt"),
        ("rtb_ik_nr", "ik_NR", RtbPinvSettings, "Newton-Raphson"),
        ("rtb_ik_gn", "ik_GN", RtbPinvSettings, "Gauss-Newton")):
    register(Solver(_name, f"Robotics Toolbox (Python) ETS.{_method}, C++ {_what}, one search from the start by "
                    f"default (peer baseline; {TIME})", "local", _cls, _rtb_run(_method),
                    applies_to=_rtb_applies, source=SOURCE_RTB,
                    library="roboticstoolbox-python"))


# ---- TRAC-IK ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class TracIKSettings(Settings):
    """Settings of TRAC-IK (defaults: TRAC-IK's)."""

    timeout: float = setting(0.005, "TRAC-IK's wall-time budget per solve (TRAC-IK default 0.005 s)", unit="s",
                             above=0.0, maximum=MAX_LIBRARY_TIMEOUT_S)
    solve_type: str = setting("Speed", "TRAC-IK's solve type: Speed returns the first solution; Distance, Manip1, "
                              "Manip2 use the whole budget to minimise joint displacement / maximise "
                              "manipulability (TRAC-IK default Speed)", choices=("Speed", "Distance", "Manip1",
                                                                                  "Manip2"))
    eps: float = setting(1e-5, "TRAC-IK's convergence tolerance on each component of the pose-error twist, "
                         "m and rad (TRAC-IK default 1e-5)", above=0.0)


def _urdf_solver(prep: Prepared, timeout: float, eps: float, solve_type: str):
    """(TRAC_IK object, base correction (4, 4) or None) for these constructor arguments."""
    pytracik = importlib.import_module("pytracik")
    from pipeline.urdf import to_urdf

    m = metric(prep)
    urdf = to_urdf(m.model)
    t = pytracik.TRAC_IK("base_link", "tool0", urdf, float(timeout), float(eps),
                         getattr(pytracik.SolveType, solve_type))
    n = int(pytracik.get_num_joints(t))
    if n != m.n:
        raise ValueError(f"the URDF chain base_link..tool0 has {n} joints, the robot {m.n}")
    # which frame is base_link? the robot's world frame (base inside the URDF) or the base frame
    qs = np.random.default_rng(0).uniform(-1.0, 1.0, (3, m.n))
    qs[:, m.prismatic] *= 0.1
    ours = [fk_htm(m.model.chain, q) for q in qs]
    theirs = [np.asarray(pytracik.fk(t, q), dtype=float).reshape(4, 4) for q in qs]
    binv = inv_rigid(m.base)
    errs = {None: max(np.abs(a - b).max() for a, b in zip(ours, theirs)),
            "base": max(np.abs(binv @ a - b).max() for a, b in zip(ours, theirs))}
    key = min(errs, key=errs.get)
    if errs[key] > URDF_MATCH_TOL:
        raise ValueError(f"the exported URDF's FK differs from ours by {errs[None]:.3g} m")
    return t, (binv if key == "base" else None)


def _tracik_applies(prep: Prepared) -> str | None:
    why = _missing("pytracik")
    if why:
        return why
    try:
        importlib.import_module("pipeline.urdf").to_urdf  # noqa: B018
    except (ImportError, AttributeError):
        return "needs pipeline.urdf.to_urdf (URDF export), which is not available"
    d = TracIKSettings()
    try:
        prep.memo(("peers", "tracik", d.timeout, d.eps, d.solve_type),
                  lambda: _urdf_solver(prep, d.timeout, d.eps, d.solve_type))
    except Exception as exc:  # noqa: BLE001
        return f"TRAC-IK could not load the exported URDF ({str(exc).splitlines()[0][:160]})"
    return None


def _tracik_run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: TracIKSettings, seed: int) -> Raw:
    pytracik = importlib.import_module("pytracik")

    m = metric(prep)
    t, corr = prep.memo(("peers", "tracik", s.timeout, s.eps, s.solve_type),
                        lambda: _urdf_solver(prep, s.timeout, s.eps, s.solve_type))
    Tm = m.goal(T_goal)
    if corr is not None:
        Tm = corr @ Tm
    wxyz = np.empty(4)
    _kin.quat_from_rot(Tm, wxyz)  # compiled (numpy's quat_from_matrix cost ~60 µs a call)
    w, x, y, z = wxyz.tolist()
    px, py, pz = (float(v) for v in Tm[:3, 3])
    q0 = m.q_in(q_start)
    t0 = clock_ns()
    r = pytracik.ik(t, q0, px, py, pz, x, y, z, w)
    ns = clock_ns() - t0
    rc = int(r[0])
    ok = rc > 0
    q = m.q_out(r[1:]) if ok else np.array(q_start, dtype=float)  # no angles on failure
    code = _peer_code(ok, StopReason.ITERATION_CAP)
    if not np.all(np.isfinite(q)):
        code = int(StopReason.NON_FINITE)
    return Raw(q=q, code=code, iterations=0, solve_ns=int(ns), info={"return_code": rc, "peer_success": ok})


register(Solver("trac_ik", f"TRAC-IK via pytracik: KDL Newton-Raphson restarts and NLopt SQP racing on two threads "
                f"within a time budget (not deterministic; peer baseline; {TIME})", "global", TracIKSettings,
                _tracik_run, applies_to=_tracik_applies, source=SOURCE_TRACIK, library="pytracik",
                own_threads=True))


# ---- Pinocchio CLIK --------------------------------------------------------------------------
@dataclass(frozen=True)
class PinocchioCLIKSettings(Settings):
    """Settings of the CLIK loop (defaults: Pinocchio's inverse-kinematics.py example)."""

    eps: float = setting(1e-4, "stop when ||log6 error|| < eps (m and rad mixed; example default 1e-4)", above=0.0)
    max_iterations: int = setting(1000, "IT_MAX (example default 1000)", minimum=1, maximum=10_000_000)
    dt: float = setting(0.1, "DT: integration step of v (example default 0.1)", above=0.0)
    damp: float = setting(1e-12, "damping of J J^T (example default 1e-12)", minimum=0.0)
    jlog6: bool = setting(True, "premultiply J by -Jlog6 (the current example; False = the older example, "
                          "err's Jacobian taken as J)")


def _pin_model(prep: Prepared):
    """(pin, model, data, last joint id, tool SE3, tool-inverse action (6, 6)) in metres."""
    pin = importlib.import_module("pinocchio")
    m = metric(prep)
    model = pin.Model()
    model.name = prep.source.name or "robot"
    parent = 0
    for i in range(m.n):
        placement = m.base @ m.origins[0] if i == 0 else m.origins[i]
        ca = _coordinate_axis(m.axes[i])
        if ca is not None and ca[1] > 0:
            jm = getattr(pin, ("JointModelP" if m.prismatic[i] else "JointModelR") + "XYZ"[ca[0]])()
        elif m.prismatic[i]:
            jm = pin.JointModelPrismaticUnaligned(np.array(m.axes[i], dtype=float))
        else:
            jm = pin.JointModelRevoluteUnaligned(np.array(m.axes[i], dtype=float))
        parent = model.addJoint(parent, jm, pin.SE3(np.array(placement, dtype=float)), f"joint{i + 1}")
    tool = pin.SE3(np.array(m.tool, dtype=float))
    model.addFrame(pin.Frame("tool0", parent, tool, pin.FrameType.OP_FRAME))
    return pin, model, model.createData(), parent, tool, np.array(tool.inverse().action)


def _pin_applies(prep: Prepared) -> str | None:
    return _model_applies(prep, "pinocchio", "pin", _pin_model, "Pinocchio could not build the model")


def _clik(pin, model, data, jid, tool, tool_inv_action, oMdes, q, eps, it_max, dt, damp, jlog6):
    """The example's loop; returns (q, success, iterations, final ||err||)."""
    I6 = np.eye(6)
    i = 0
    while True:
        pin.forwardKinematics(model, data, q)
        iMd = (data.oMi[jid] * tool).actInv(oMdes)
        err = pin.log6(iMd).vector
        en = float(np.linalg.norm(err))
        if en < eps:
            return q, True, i, en
        if i >= it_max or not math.isfinite(en):
            return q, False, i, en
        J = tool_inv_action @ pin.computeJointJacobian(model, data, q, jid)
        if jlog6:
            J = -pin.Jlog6(iMd.inverse()) @ J
        v = -J.T @ np.linalg.solve(J @ J.T + damp * I6, err)
        q = pin.integrate(model, q, v * dt)
        i += 1


def _pin_run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: PinocchioCLIKSettings, seed: int) -> Raw:
    m = metric(prep)
    pin, model, data, jid, tool, tia = prep.memo(("peers", "pin"), lambda: _pin_model(prep))
    oMdes = pin.SE3(m.goal(T_goal))
    q0 = m.q_in(q_start)
    t0 = clock_ns()
    qm, ok, it, en = _clik(pin, model, data, jid, tool, tia, oMdes, q0, float(s.eps), int(s.max_iterations),
                           float(s.dt), float(s.damp), bool(s.jlog6))
    ns = clock_ns() - t0
    q = _returned(prep, m.q_out(qm), s)
    code = _peer_code(ok, StopReason.ITERATION_CAP)
    if not (math.isfinite(en) and np.all(np.isfinite(q))):
        code = int(StopReason.NON_FINITE)
    return Raw(q=q, code=code, iterations=int(it), solve_ns=int(ns), trace=_trace(prep, T_goal, q_start, q),
               info={"log6_error": en, "peer_success": bool(ok)})


register(Solver("pinocchio_clik", "Pinocchio CLIK (damped least squares on log6, the library's example loop written "
                f"in Python around its C++ calls; peer baseline; {TIME}, Python loop included)", "local",
                PinocchioCLIKSettings, _pin_run, applies_to=_pin_applies, source=SOURCE_PIN, library="pin"))


# ---- ur_analytic_ik --------------------------------------------------------------------------
@dataclass(frozen=True)
class URAnalyticIKSettings(Settings):
    """Only the base fields: the closed form has no settings of its own."""


_UR_QS = np.random.default_rng(2024).uniform(-math.pi, math.pi, (4, 6))


def _ur_models(lib) -> list[str]:
    return sorted(k for k, v in vars(lib).items()
                  if not k.startswith("_") and hasattr(v, "inverse_kinematics") and hasattr(v, "forward_kinematics"))


def _ur_match(prep: Prepared):
    """(module name, joint offsets) of the built-in model that the robot is, or a one-line reason (str)."""
    lib = library("ur_analytic_ik")
    if isinstance(lib, str):
        return lib
    m = metric(prep)
    c = m.model.chain
    if c.n != 6:
        return f"ur_analytic_ik solves 6-joint UR arms, the robot has {c.n} joints"
    if c.prismatic.any():
        return "ur_analytic_ik solves 6 revolute joints, the robot has prismatic ones"
    if c.convention != "standard":
        return f"ur_analytic_ik needs a standard-DH table to compare with its models (the file is {c.convention})"
    bare = Chain(np.array(c.a), np.array(c.alpha), np.array(c.d), np.zeros(6), np.zeros(6, dtype=bool), "standard")
    names = _ur_models(lib)
    best = (math.inf, "")
    for name in names:
        fk = getattr(lib, name).forward_kinematics
        err = max(float(np.abs(np.asarray(fk(*map(float, q))) - fk_htm(bare, q)).max()) for q in _UR_QS)
        if err <= UR_MATCH_TOL:
            return name, np.array(c.theta_offset, dtype=float)
        best = min(best, (err, name))
    return (f"the DH table matches none of ur_analytic_ik's models ({', '.join(names)}; nearest {best[1]} "
            f"differs by {best[0]:.3g} m)")


def _ur_applies(prep: Prepared) -> str | None:
    r = prep.memo(("peers", "ur_match"), lambda: _ur_match(prep))
    return r if isinstance(r, str) else None


@numba.njit(cache=True, error_model="numpy")
def wrap_angle(x):
    """One angle wrapped to (−π, π] [rad] (compiled; as :func:`pipeline.solvers.core.models.wrap_angles`)."""
    y = (x + math.pi) % (2 * math.pi) - math.pi
    return y + 2 * math.pi if y <= -math.pi else y


@numba.njit(cache=True, error_model="numpy")
def _ur_pick(S, offs, q0, q_out, listed):
    """The finite rows of ``S`` minus the offsets, wrapped, into ``listed``; the one nearest ``q0`` (wrapped
    joint distance) unwrapped to within π of ``q0`` into ``q_out``. Returns (rows listed, chosen row or -1)."""
    m, n = S.shape
    k, best, best_d = 0, -1, math.inf
    for i in range(m):
        finite = True
        for j in range(n):
            if not math.isfinite(S[i, j]):
                finite = False
        if not finite:
            continue
        d = 0.0
        for j in range(n):
            listed[k, j] = wrap_angle(S[i, j] - offs[j])
            d += wrap_angle(listed[k, j] - q0[j]) ** 2
        if d < best_d:
            best_d, best = d, k
        k += 1
    for j in range(n):
        q_out[j] = q0[j] + wrap_angle(listed[best, j] - q0[j]) if best >= 0 else q0[j]
    return k, best


def _ur_bind(prep: Prepared, s: URAnalyticIKSettings):
    """run1(T_goal, q_start, seed) -> Raw with the model, base and tool inverses made once per job."""
    lib = importlib.import_module("ur_analytic_ik")
    name, offs = prep.memo(("peers", "ur_match"), lambda: _ur_match(prep))
    ik = getattr(lib, name).inverse_kinematics
    m = metric(prep)
    B, Ti = inv_rigid(m.base), inv_rigid(np.array(m.model.chain.tool, dtype=float))
    offs = np.ascontiguousarray(offs, dtype=float)

    def run1(T_goal: np.ndarray, q_start: np.ndarray, seed: int) -> Raw:
        Tb = np.ascontiguousarray(B @ m.goal(T_goal) @ Ti)
        t0 = clock_ns()
        sols = ik(Tb)
        ns = clock_ns() - t0
        S = np.array(sols, dtype=float).reshape(-1, 6)
        q, listed = np.empty(6), np.empty_like(S)
        k, best = _ur_pick(S, offs, np.ascontiguousarray(q_start, dtype=float), q, listed)
        code = int(StopReason.SUCCESS) if k else int(StopReason.NO_SOLUTION)
        return Raw(q=q, code=code, iterations=0, solve_ns=int(ns), solutions=listed[:k].copy(),
                   info={"model": name, "n_solutions": int(k), "chosen": int(best)})
    return run1


def _ur_run(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, s: URAnalyticIKSettings, seed: int) -> Raw:
    return _ur_bind(prep, s)(T_goal, q_start, seed)


register(Solver("ur_analytic_ik", f"ur_analytic_ik closed form of UR arms (built-in vendor models), all solutions, "
                f"nearest to the start (peer baseline; {TIME})", "analytic", URAnalyticIKSettings, _ur_run,
                applies_to=_ur_applies, source=SOURCE_UR, bind=_ur_bind, library="ur-analytic-ik"))


# ---- shared with the other peer modules (python_ik, qp_ik) ---------------------------------
def pin_model(prep: Prepared):
    """The Pinocchio model of the CLIK peer, built once per ``prep``: (pin, model, data, last joint id,
    tool SE3, tool-inverse action (6, 6)), metres, no joint limits set."""
    return prep.memo(("peers", "pin"), lambda: _pin_model(prep))


start_end_trace = _trace  # rows [|e|, e (6), |dp|] at the start and the returned angles
returned_angles = _returned  # the returned angles, wrapped into the limits under require_limits
model_applies = _model_applies  # a peer applies when its library imports and its model builds (memoised)
peer_code = _peer_code  # SUCCESS when the peer claims success, else ``fail``
