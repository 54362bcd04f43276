"""Peer IK libraries that read a URDF: pybullet and ikpy, as registered baselines.

As in :mod:`pipeline.solvers.peers.libraries`, nothing here re-implements a peer's method; a library
that cannot be imported makes its rows say so in one line ("not installed: pip install ...") and
every other solver runs; importing :mod:`pipeline.solvers` never imports a peer library (the first
``prepare`` does).

Both read the chain from :func:`pipeline.urdf.to_urdf` (links ``base_link`` ... ``tool0``, metres),
written to a temporary file once per :class:`~pipeline.solvers.core.Prepared` (the libraries read
files only), loaded, and checked once against our FK (``FK_MATCH_TOL``). Everything per job (the
loaded body or chain, the call's keyword arguments) is built then (``bind``); per call only the start and
goal are converted, outside the timed region, and ``solve_time_s`` is the library's one call.

``pybullet_ik``
    pybullet's ``calculateInverseKinematics`` (Coumans & Bai, PyBullet, https://pybullet.org; the
    Bullet physics SDK's damped-least-squares IK, C++ behind the CPython module). The URDF is
    loaded into a ``DIRECT`` (no GUI) physics client with ``useFixedBase=True``; the end effector
    is the link ``tool0`` (its URDF frame; the links carry no inertial frame). The call starts from
    ``currentPositions = q_start`` (pybullet's argument for the start; the body's state is never
    touched). The documented default call passes only body, link, target position and target
    orientation (quaternion x, y, z, w): pybullet 3.2.7 then iterates at most 20 times down to a
    position residual of 1e-4 m (its C defaults) and its step is the plain DLS step without joint
    damping. Measured on 100 goals each (Panda, iiwa 14, UR5): from starts within 0.3 rad it stops a
    median 6-8 mm short (orientation 1.2e-3 rad off), from uniform starts 9-12 cm short, and solves
    none; with ``{max_num_iterations: 100, residual_threshold: 1.0e-6, joint_damping: 0.01}`` it
    solves 84-91 % of those warm goals and 76-92 % of the cold ones (joint limits not enforced). That
    is pybullet's documented behaviour, kept as the ``pybullet_ik`` default row. The settings ``max_num_iterations``,
    ``residual_threshold`` and ``joint_damping`` (0 = not passed, pybullet's default) make the
    tuned row, written out in the study, e.g. ``{max_num_iterations: 100, residual_threshold:
    1.0e-6, joint_damping: 0.01}``. pybullet's ``IK_SDLS`` mode is not offered (it crashed the
    process in the issue's trials). Joint limits are not passed (pybullet then ignores them).
    pybullet reports no success flag and no iteration count: its angles are its claim, judged by
    the FK check (a miss is ``FK_CHECK_FAILED``), ``iterations`` = 0.
``ikpy``
    ikpy's ``Chain.inverse_kinematics`` (Manceron, ikpy, https://github.com/Phylliade/ikpy;
    pure Python on NumPy and SciPy): a least-squares fit of the full pose
    (``orientation_mode="all"``) by ``scipy.optimize.least_squares`` within the URDF's joint
    bounds, starting from ``initial_position`` (the chain's every link: fixed ones 0, the joints
    ``q_start`` moved into their limits first, since SciPy refuses a start outside its bounds).
    The chain is ``Chain.from_urdf_file(..., base_elements=["base_link"])`` with only the robot's
    joints active. ikpy reports no success flag and no iteration count: its angles are its claim,
    judged by the FK check (a miss is ``FK_CHECK_FAILED``), ``iterations`` = 0.

Traces: two rows, start and returned angles, computed after the timed call (as Robotics Toolbox's).
"""

from __future__ import annotations

import importlib
import os
import tempfile
import warnings
from dataclasses import dataclass

import numpy as np

from pipeline.kinematics import fk_htm
from pipeline.solvers.kernels.kin import quat_from_rot
from pipeline.solvers.core import Prepared, Raw, Settings, StopReason, setting
from pipeline.solvers.core.driver import run_of
from pipeline.solvers.core.models import metric
from pipeline.solvers.core.registry import Solver, register
from pipeline.solvers.core.timing import clock_ns
from pipeline.solvers.peers.libraries import TIME, model_applies, returned_angles, start_end_trace

SOURCE_PYBULLET = ("Coumans & Bai (2016-2025), PyBullet, https://pybullet.org; pybullet 3.2.7 "
                   "calculateInverseKinematics (Bullet's damped-least-squares IK, C++)")
SOURCE_IKPY = "Manceron, ikpy (https://github.com/Phylliade/ikpy); ikpy 4.2.1 Chain.inverse_kinematics (SciPy)"

FK_MATCH_TOL = 1e-9  # [m, 1] ikpy's chain must reproduce our FK to this (NumPy, double)
SUCCESS, NON_FINITE = int(StopReason.SUCCESS), int(StopReason.NON_FINITE)
PYBULLET_FK_TOL = 1e-6  # [m, 1] pybullet's: its link state comes back rounded (5e-8 m seen on the Panda)
_QS = np.random.default_rng(43).uniform(-1.0, 1.0, (3, 64))  # the models' check configurations (cut to n)


class _quiet_stdout:
    """Route the C-level stdout to /dev/null for a block (pybullet prints URDF warnings with printf)."""

    def __enter__(self):
        self.fd = os.dup(1)
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 1)
        os.close(null)
        return self

    def __exit__(self, *exc):
        os.dup2(self.fd, 1)
        os.close(self.fd)
        return False


def _urdf_file(prep: Prepared) -> str:
    """The robot's URDF in a temporary file (the caller deletes it)."""
    from pipeline.urdf import to_urdf

    fd, path = tempfile.mkstemp(suffix=".urdf", prefix="ik_peer_")
    with os.fdopen(fd, "w") as f:
        f.write(to_urdf(metric(prep).model))
    return path


def _check_fk(prep: Prepared, fk, what: str, tol: float = FK_MATCH_TOL) -> None:
    """Raise when ``fk(q) -> (4, 4)`` (metres) differs from ours at fixed joint vectors."""
    m = metric(prep)
    err = 0.0
    for row in _QS:
        q = row[: m.n].copy()
        q[m.prismatic] *= 0.1
        err = max(err, float(np.abs(np.asarray(fk(q), dtype=float) - fk_htm(m.model.chain, q)).max()))
    if err > tol:
        raise ValueError(f"{what}'s FK of the exported URDF differs from ours by {err:.3g} m")


# ---- pybullet ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class PybulletSettings(Settings):
    """Settings of pybullet's call (0 = the argument is not passed: pybullet's documented default)."""

    max_num_iterations: int = setting(0, "maxNumIterations of calculateInverseKinematics, 0 = not passed "
                                      "(pybullet's default, 20)", minimum=0, maximum=100_000)
    residual_threshold: float = setting(0.0, "residualThreshold: stop when the position residual is below "
                                        "this, 0 = not passed (pybullet's default, 1e-4 m)", unit="m", minimum=0.0)
    joint_damping: float = setting(0.0, "jointDamping (the same for every joint), 0 = not passed (pybullet's "
                                   "default: none)", minimum=0.0)


def one_call_raw(prep: Prepared, T_goal: np.ndarray, q_start: np.ndarray, q: np.ndarray, ns: int) -> Raw:
    """The Raw of a peer's one library call: joints ``q`` (n,) (NON_FINITE where any is not finite, else
    SUCCESS, the FK check judging it), no iteration count, ``ns`` the call's time [ns], the two-row trace."""
    code = SUCCESS if np.isfinite(q).all() else NON_FINITE
    return Raw(q=q, code=code, iterations=0, solve_ns=int(ns), trace=start_end_trace(prep, T_goal, q_start, q))


_PYBULLET_CLIENT: list = []  # this process's one DIRECT physics client (pybullet allocates ~30 MB a client)


def _pybullet_client(pb) -> int:
    """The process's DIRECT (no GUI) pybullet client, connected on first use; every robot is a body in it."""
    if not _PYBULLET_CLIENT or not pb.isConnected(physicsClientId=_PYBULLET_CLIENT[0]):
        with _quiet_stdout():
            _PYBULLET_CLIENT[:] = [pb.connect(pb.DIRECT)]
    return _PYBULLET_CLIENT[0]


def _pybullet_model(prep: Prepared):
    """(pybullet module, client id, body id, end-effector link index), the FK checked."""
    pb = importlib.import_module("pybullet")
    m = metric(prep)
    path = _urdf_file(prep)
    try:
        cid = _pybullet_client(pb)
        with _quiet_stdout():
            body = pb.loadURDF(path, useFixedBase=True, physicsClientId=cid)
    finally:
        os.unlink(path)
    # one client for every robot (a client per robot kept about 30 MB each: the contract tests' thousands of
    # drawn arms filled the memory); a body stays in it while the process lives (a prepared robot's memo may
    # be shared by another, so no body is removed)
    names = [pb.getJointInfo(body, j, physicsClientId=cid)[12].decode() for j in range(pb.getNumJoints(body, physicsClientId=cid))]
    if "tool0" not in names:
        raise ValueError("pybullet's body has no link tool0")
    ee = names.index("tool0")
    movable = [j for j in range(len(names)) if pb.getJointInfo(body, j, physicsClientId=cid)[2] != pb.JOINT_FIXED]
    if len(movable) != m.n:
        raise ValueError(f"pybullet's body has {len(movable)} movable joints, the robot {m.n}")

    def fk(q):
        for j, v in zip(movable, q):
            pb.resetJointState(body, j, float(v), physicsClientId=cid)
        st = pb.getLinkState(body, ee, computeForwardKinematics=True, physicsClientId=cid)
        T = np.eye(4)
        T[:3, :3] = np.array(pb.getMatrixFromQuaternion(st[5]), dtype=float).reshape(3, 3)
        T[:3, 3] = st[4]
        return T

    _check_fk(prep, fk, "pybullet", PYBULLET_FK_TOL)
    return pb, cid, body, ee


def _pybullet_applies(prep: Prepared) -> str | None:
    return model_applies(prep, "pybullet", "pybullet", _pybullet_model, "pybullet could not load the exported URDF")


def pybullet_arguments(s: PybulletSettings, n: int) -> dict:
    """The keyword arguments of pybullet's call that ``s`` sets (none for the documented default call).

    Parameters
    ----------
    s : PybulletSettings
        The settings (0 = not passed).
    n : int
        Number of joints (``jointDamping`` takes one value per joint).

    Returns
    -------
    dict
        ``maxNumIterations``, ``residualThreshold``, ``jointDamping`` where set.
    """
    kw = {}
    if s.max_num_iterations:
        kw["maxNumIterations"] = int(s.max_num_iterations)
    if s.residual_threshold:
        kw["residualThreshold"] = float(s.residual_threshold)
    if s.joint_damping:
        kw["jointDamping"] = [float(s.joint_damping)] * n
    return kw


def _pybullet_bind(prep: Prepared, s: PybulletSettings):
    """run1(T_goal, q_start, seed) -> Raw with everything per job made once (model, arguments, scratch)."""
    pb, cid, body, ee = prep.memo(("peers", "pybullet"), lambda: _pybullet_model(prep))
    m = metric(prep)
    kw = pybullet_arguments(s, m.n)
    calc, wxyz = pb.calculateInverseKinematics, np.empty(4)

    def run1(T_goal: np.ndarray, q_start: np.ndarray, seed: int) -> Raw:
        Tm = m.goal(T_goal)
        quat_from_rot(Tm, wxyz)  # compiled: numpy's quat_from_matrix cost ~60 µs a call here
        w, x, y, z = wxyz.tolist()
        pos, orn = Tm[:3, 3].tolist(), [x, y, z, w]
        q0 = m.q_in(q_start).tolist()
        t0 = clock_ns()
        out = calc(body, ee, pos, orn, currentPositions=q0, physicsClientId=cid, **kw)
        ns = clock_ns() - t0
        return one_call_raw(prep, T_goal, q_start, returned_angles(prep, m.q_out(out), s), ns)
    return run1


register(Solver("pybullet_ik", "pybullet calculateInverseKinematics (Bullet's damped least squares, C++), one call "
                f"from the start; its documented default call unless settings say otherwise (peer baseline; {TIME})",
                "local", PybulletSettings, run_of(_pybullet_bind), applies_to=_pybullet_applies, source=SOURCE_PYBULLET,
                bind=_pybullet_bind, library="pybullet"))


# ---- ikpy -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class IkpySettings(Settings):
    """Settings of ikpy's call (defaults: ikpy's)."""

    max_iter: int = setting(0, "max_iter of inverse_kinematics (SciPy's max_nfev), 0 = not passed (ikpy's "
                            "default: SciPy's own cap)", minimum=0, maximum=100_000)


def _ikpy_model(prep: Prepared):
    """(chain, indices of the joints among its links, number of links, limits (n, 2) [rad | m])."""
    chain_mod = importlib.import_module("ikpy.chain")
    m = metric(prep)
    path = _urdf_file(prep)
    try:
        with warnings.catch_warnings():  # ikpy warns that the fixed links are active before the mask is known
            warnings.simplefilter("ignore")
            probe = chain_mod.Chain.from_urdf_file(path, base_elements=["base_link"])
        mask = [link.joint_type != "fixed" for link in probe.links]
        chain = chain_mod.Chain.from_urdf_file(path, base_elements=["base_link"], active_links_mask=mask)
    finally:
        os.unlink(path)
    act = np.flatnonzero(mask)
    if len(act) != m.n:
        raise ValueError(f"ikpy's chain has {len(act)} joints, the robot {m.n}")
    full = np.zeros(len(chain.links))

    def fk(q):
        v = full.copy()
        v[act] = q
        return chain.forward_kinematics(v)

    _check_fk(prep, fk, "ikpy")
    return chain, act, len(chain.links), m.limits.copy()


def _ikpy_applies(prep: Prepared) -> str | None:
    return model_applies(prep, "ikpy.chain", "ikpy", _ikpy_model, "ikpy could not load the exported URDF")


def _ikpy_bind(prep: Prepared, s: IkpySettings):
    """run1(T_goal, q_start, seed) -> Raw with the chain and the link vector made once."""
    chain, act, n_links, lim = prep.memo(("peers", "ikpy"), lambda: _ikpy_model(prep))
    m = metric(prep)
    kw = {"max_iter": int(s.max_iter)} if s.max_iter else {}
    ik = chain.inverse_kinematics
    lo, hi = lim[:, 0].copy(), lim[:, 1].copy()  # NaN-free: unbounded joints are ±inf

    def run1(T_goal: np.ndarray, q_start: np.ndarray, seed: int) -> Raw:
        Tm = m.goal(T_goal)
        init = np.zeros(n_links)
        init[act] = np.minimum(np.maximum(m.q_in(q_start), lo), hi)  # SciPy refuses a start outside its bounds
        pos, rot = Tm[:3, 3].copy(), Tm[:3, :3].copy()
        t0 = clock_ns()
        out = ik(pos, rot, orientation_mode="all", initial_position=init, **kw)
        ns = clock_ns() - t0
        return one_call_raw(prep, T_goal, q_start, returned_angles(prep, m.q_out(np.asarray(out, dtype=float)[act]), s),
                            ns)
    return run1


register(Solver("ikpy", "ikpy Chain.inverse_kinematics (SciPy least squares on the full pose within the URDF's "
                f"joint bounds), one search from the start (peer baseline; {TIME})", "local", IkpySettings,
                run_of(_ikpy_bind), applies_to=_ikpy_applies, source=SOURCE_IKPY, bind=_ikpy_bind, library="ikpy"))
