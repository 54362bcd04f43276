"""Robot files imported from vendor URDFs (data/robots/urdf/<name>.urdf -> data/robots/<name>.yaml).

For every file: it loads, has the expected joint count, finite limits equal to the URDF's ``<limit>``
values, and its forward kinematics (``pipeline.kinematics.fk_htm``) equals Pinocchio's on the URDF
itself (an independent parser and FK) to 1e-9 m / 1e-9 rad, at q = 0, at the limit corners and at
random joint vectors within limits. Further independent checks of the published data:

- the xArm 6 / xArm 7 URDF chains equal UFactory's published standard DH tables (typed in below);
- ``ur5e_urdf`` (UR's ROS description) equals ``ur5e.yaml`` (UR's DH table) after base_link -> base = Rz(pi);
- the zero-pose joint-axis geometry (which consecutive axes meet / are parallel, spherical wrist or
  not), computed from Pinocchio's spatial Jacobian, is the one tabulated in data/robots/CATALOGUE.md.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from pipeline.kinematics import fk_htm
from pipeline.robots import load_robot

pin = pytest.importorskip("pinocchio")

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ROOT / "data" / "robots"
POS_TOL = 1e-9  # [m]
ROT_TOL = 1e-9  # [rad]
GEOM_TOL = 1e-9  # [m | rad] "meet" / "parallel" in the axis table

# name -> (joint count, tip link of the URDF chain)
NEW = {
    "fanuc_lrmate200id": (6, "tool0"),
    "abb_irb2400": (6, "tool0"),
    "staubli_tx2_60": (6, "tool0"),
    "ufactory_xarm6": (6, "link_eef"),
    "kinova_gen3_lite": (6, "end_effector_link"),
    "fanuc_crx10ia": (6, "flange"),
    "ur5e_urdf": (6, "tool0"),
    "ufactory_xarm7": (7, "link_eef"),
    "rethink_sawyer": (7, "right_hand"),
}


def _urdf(name: str) -> Path:
    return ROBOTS / "urdf" / f"{name}.urdf"


def _pin_model(name: str):
    return pin.buildModelFromXML(_urdf(name).read_text())


def _pin_fk(model, data, tip_id, q_by_name: dict) -> np.ndarray:
    """Pose of the tip frame in the URDF root frame, joints given by name (Pinocchio's q order differs)."""
    q = pin.neutral(model)
    for jid in range(1, model.njoints):
        q[model.joints[jid].idx_q] = q_by_name[model.names[jid]]
    pin.framesForwardKinematics(model, data, q)
    return np.array(data.oMf[tip_id].homogeneous)


def _test_vectors(limits: np.ndarray, rng, n_random: int = 40) -> np.ndarray:
    lo, hi = limits[:, 0], limits[:, 1]
    return np.vstack([np.zeros(len(lo)), lo, hi, np.where(np.arange(len(lo)) % 2, lo, hi),
                      rng.uniform(lo, hi, size=(n_random, len(lo)))])


def _rotation_angle(Ra: np.ndarray, Rb: np.ndarray) -> float:
    return float(np.linalg.norm(pin.log3(Ra.T @ Rb)))


@pytest.mark.parametrize("name", list(NEW))
def test_loads_with_finite_published_limits(name):
    n, _ = NEW[name]
    model = load_robot(ROBOTS / f"{name}.yaml")
    assert model.n == n and model.name == name
    assert model.chain.general and model.length_unit == "m"
    assert np.all(np.isfinite(model.limits)) and np.all(model.limits[:, 0] < model.limits[:, 1])
    # the limits are exactly the URDF's <limit> values (the published numbers), joint by joint
    root = ET.parse(_urdf(name)).getroot()
    urdf_limits = {j.get("name"): (float(j.find("limit").get("lower")), float(j.find("limit").get("upper")))
                   for j in root.findall("joint") if j.get("type") == "revolute"}
    assert list(model.joint_names) == list(urdf_limits)
    for jn, (lo, hi) in zip(model.joint_names, model.limits):
        assert (lo, hi) == urdf_limits[jn], jn
    text = (ROBOTS / f"{name}.yaml").read_text()
    assert "limits_source:" in text and "source:" in text and text.startswith("# ")


@pytest.mark.parametrize("name", list(NEW))
def test_fk_matches_pinocchio_on_the_urdf(name):
    n, tip = NEW[name]
    model = load_robot(ROBOTS / f"{name}.yaml")
    pm = _pin_model(name)
    assert pm.nq == n and pm.existFrame(tip, pin.FrameType.BODY)
    pd, tip_id = pm.createData(), pm.getFrameId(tip, pin.FrameType.BODY)  # the link (Sawyer names a joint alike)
    rng = np.random.default_rng(20240611)
    for q in _test_vectors(model.limits, rng):
        T = fk_htm(model.chain, q)
        P = _pin_fk(pm, pd, tip_id, dict(zip(model.joint_names, q)))
        dp = np.linalg.norm(T[:3, 3] - P[:3, 3])
        dr = _rotation_angle(T[:3, :3], P[:3, :3])
        assert dp <= POS_TOL and dr <= ROT_TOL, f"{name} q={q}: |dp| = {dp:.3e} m, |dR| = {dr:.3e} rad"


# ---------------------------------------------------------------------------------------------------------------
# the vendors' other published forms


def _dh(theta, d, a, alpha):
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1.0]])


def _fk_dh(rows, q):
    T = np.eye(4)
    for (d, a, alpha, offset), qi in zip(rows, q):
        T = T @ _dh(qi + offset, d, a, alpha)
    return T


_H = math.pi / 2
_A2 = math.hypot(284.5, 53.5) / 1000  # UFactory: a2 = sqrt(284.5^2 + 53.5^2) mm
_T2 = -math.atan(284.5 / 53.5)  # UFactory: T2_offset = -atan(284.5/53.5), T3_offset = -T2_offset
# UFactory "Kinematic and Dynamic Parameters of xArm 6 / xArm 7" (docs.ufactory.cc), standard DH rows
# (d [m], a [m], alpha, theta offset)
UFACTORY_DH = {
    "ufactory_xarm6": [(0.267, 0, -_H, 0), (0, _A2, 0, _T2), (0, 0.0775, -_H, -_T2), (0.3425, 0, _H, 0),
                       (0, 0.076, -_H, 0), (0.097, 0, 0, 0)],
    "ufactory_xarm7": [(0.267, 0, -_H, 0), (0, 0, _H, 0), (0.293, 0.0525, _H, 0), (0, 0.0775, _H, 0),
                       (0.3425, 0, _H, 0), (0, 0.076, -_H, 0), (0.097, 0, 0, 0)],
}


@pytest.mark.parametrize("name", list(UFACTORY_DH))
def test_xarm_urdf_equals_ufactory_dh_table(name):
    model = load_robot(ROBOTS / f"{name}.yaml")
    rng = np.random.default_rng(3)
    for q in _test_vectors(model.limits, rng):
        T, D = fk_htm(model.chain, q), _fk_dh(UFACTORY_DH[name], q)
        assert np.linalg.norm(T[:3, 3] - D[:3, 3]) <= POS_TOL and _rotation_angle(T[:3, :3], D[:3, :3]) <= ROT_TOL


def test_ur5e_urdf_form_equals_ur_dh_form():
    """UR's ROS base_link is rotated pi about z from UR's base frame; tool0 is UR's flange frame.
    The tolerance is 1e-8: default_kinematics.yaml writes pi/2 as 1.570796327 and 0 as -2.04e-11 m."""
    dh, urdf = load_robot(ROBOTS / "ur5e.yaml"), load_robot(ROBOTS / "ur5e_urdf.yaml")
    assert dh.length_unit == urdf.length_unit == "m"
    Rz = np.diag([-1.0, -1.0, 1.0, 1.0])
    rng = np.random.default_rng(5)
    for q in _test_vectors(urdf.limits, rng):
        A, B = fk_htm(dh.chain, q), Rz @ fk_htm(urdf.chain, q)
        assert np.linalg.norm(A[:3, 3] - B[:3, 3]) <= 1e-8 and _rotation_angle(A[:3, :3], B[:3, :3]) <= 1e-8
    np.testing.assert_array_equal(dh.limits, urdf.limits)


# ---------------------------------------------------------------------------------------------------------------
# zero-pose axis geometry (the CATALOGUE.md table)


def axis_lines(name: str):
    """Joint axis lines at q = 0 in the base frame, from Pinocchio: (point, unit direction) per joint, in
    chain order. Column j of the spatial (world-frame) Jacobian is (v, w) with w the axis and v = p x w for
    any point p on it, so w x v is the axis point closest to the base origin."""
    pm = _pin_model(name)
    pd = pm.createData()
    J = pin.computeJointJacobians(pm, pd, pin.neutral(pm))
    out = []
    for jid in range(1, pm.njoints):  # a serial chain: Pinocchio's joint order is the chain order
        col = J[:, pm.joints[jid].idx_v]
        v, w = col[:3], col[3:]
        out.append((np.cross(w, v), w / np.linalg.norm(w)))
    return out


def line_relation(l1, l2) -> tuple[float, float]:
    """(closest distance [m], angle between the axes [rad], 0 = parallel in either sense)."""
    (p1, u1), (p2, u2) = l1, l2
    c = np.cross(u1, u2)
    s = float(np.linalg.norm(c))
    angle = math.atan2(s, abs(float(np.dot(u1, u2))))
    dist = np.linalg.norm(np.cross(p2 - p1, u1)) if s < 1e-12 else abs(float(np.dot(p2 - p1, c))) / s
    return float(dist), angle


def common_point_residual(lines) -> float:
    """Largest distance from the least-squares common point to the lines [m] (0: they meet in one point)."""
    A, b = np.zeros((3, 3)), np.zeros(3)
    for p, u in lines:
        P = np.eye(3) - np.outer(u, u)
        A, b = A + P, b + P @ p
    x = np.linalg.lstsq(A, b, rcond=None)[0]
    return max(float(np.linalg.norm((np.eye(3) - np.outer(u, u)) @ (x - p))) for p, u in lines)


# consecutive pairs (i, i+1), 1-based: "meet" = intersect (distance 0, not parallel), "par" = parallel,
# "skew" = neither; and whether the last three axes meet in one point (spherical wrist)
AXIS_TABLE = {
    "fanuc_lrmate200id": (["skew", "par", "skew", "meet", "meet"], True),
    "abb_irb2400": (["skew", "par", "skew", "meet", "meet"], True),
    "staubli_tx2_60": (["meet", "par", "meet", "meet", "meet"], True),
    "ufactory_xarm6": (["meet", "par", "skew", "meet", "skew"], False),
    "kinova_gen3_lite": (["meet", "par", "meet", "meet", "meet"], False),
    "fanuc_crx10ia": (["meet", "par", "meet", "meet", "meet"], False),
    "ur5e_urdf": (["meet", "par", "par", "meet", "meet"], False),
    "ufactory_xarm7": (["meet", "meet", "skew", "skew", "meet", "skew"], False),
    "rethink_sawyer": (["skew", "meet", "meet", "meet", "meet", "meet"], False),
}


def classify(dist: float, angle: float) -> str:
    if angle <= GEOM_TOL:
        return "par"
    return "meet" if dist <= GEOM_TOL else "skew"


@pytest.mark.parametrize("name", list(NEW))
def test_zero_pose_axis_geometry(name):
    lines = axis_lines(name)
    # the same lines from the project's own frames (fk_frames) as a cross-check of axis_lines
    from pipeline.kinematics import fk_frames

    model = load_robot(ROBOTS / f"{name}.yaml")
    F = fk_frames(model.chain, np.zeros(model.n))
    for i, (p, u) in enumerate(lines):
        d, a = line_relation((p, u), (F[i + 1][:3, 3], F[i + 1][:3, :3] @ model.chain.axes[i]))
        assert d <= GEOM_TOL and a <= GEOM_TOL and np.dot(u, F[i + 1][:3, :3] @ model.chain.axes[i]) > 0
    kinds = [classify(*line_relation(lines[i], lines[i + 1])) for i in range(len(lines) - 1)]
    expected_kinds, spherical = AXIS_TABLE[name]
    assert kinds == expected_kinds
    assert (common_point_residual(lines[-3:]) <= GEOM_TOL) == spherical


def axis_report(name: str) -> str:
    """One table row: consecutive pairs as 'i-j: distance mm / angle deg' and the wrist residual."""
    lines = axis_lines(name)
    cells = []
    for i in range(len(lines) - 1):
        d, a = line_relation(lines[i], lines[i + 1])
        cells.append(f"{i + 1}-{i + 2}: {d * 1000:.1f} mm / {math.degrees(a):.1f}°")
    return f"{name}: " + "; ".join(cells) + f"; last-three residual {common_point_residual(lines[-3:]) * 1000:.1f} mm"
