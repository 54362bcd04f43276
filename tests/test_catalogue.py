"""The robot catalogue (pipeline.catalogue.CATALOGUE): every file's forward kinematics checked against
independent implementations and against published poses.

Three independent checks per arm:

1. Product of exponentials (always runs): the screw axes (direction and a point on the axis) and the
   flange pose M at the vendor's zero configuration are typed below from the published geometry
   (vendor dimension drawings / DH diagrams, in the vendor's own joint directions), never read from
   the robot file; ``T(q) = exp([S1] q1) ... exp([Sn] qn) M`` must equal ``fk_htm`` of the file at
   random joint vectors within the limits. Where the file's joint signs differ from the vendor's
   (KUKA KR 5 arc, documented in its header) the documented sign vector maps vendor angles to file
   angles, so the mapping is tested too.
2. roboticstoolbox-python (skipped without it): the shipped rtb models where rtb has one (UR3, UR5,
   UR10, IRB140, KR5, Panda, and the URDF model LBR = iiwa 14 R820), after the documented zero /
   sign / base / tool differences; and rtb's DH engine fed with the vendor's published DH table
   typed in here (UR family, Panda, iiwa, Kinova Gen3).
3. Published poses (always runs): flange positions at the vendor's zero (and a few other) poses as
   printed or derived in the sources cited in each robot file.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pytest
from numpy import pi

from pipeline.catalogue import CATALOGUE
from pipeline.kinematics import fk_htm
from pipeline.robots import load_robot
from tests.conftest import DATA

N_RANDOM = 50
ATOL = 1e-9  # m and rad (entries of the 4x4 pose)


def _model(name: str):
    return load_robot(DATA / "robots" / f"{name}.yaml")


def _random_q(model, seed: int, n: int = N_RANDOM) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform(model.limits[:, 0], model.limits[:, 1], size=(n, model.n))


def _pose(R, p) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = np.asarray(R, dtype=float)
    T[:3, 3] = p
    return T


def _Tz(z: float) -> np.ndarray:
    return _pose(np.eye(3), (0.0, 0.0, z))


RY90 = [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]  # Ry(+90 deg): ABB tool0 at the calibration position


# --------------------------------------------------------------------------------------------------
# Published zero-configuration geometry (vendor joint directions), for the product of exponentials
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Geometry:
    """Joint axes ``w_i`` through points ``p_i`` and flange pose ``M``, all at the vendor's zero.

    ``sign``: file angle = sign * vendor angle (all +1 unless the robot file documents otherwise).
    """

    axes: tuple
    points: tuple
    M: np.ndarray
    sign: tuple = field(default=())


# Universal Robots FAQ 45257 DH tables: (d1, a2, a3, d4, d5, d6) [m]
UR_DH = {
    "ur3": (0.1519, -0.24365, -0.21325, 0.11235, 0.08535, 0.0819),
    "ur5": (0.089159, -0.425, -0.39225, 0.10915, 0.09465, 0.0823),
    "ur10": (0.1273, -0.612, -0.5723, 0.163941, 0.1157, 0.0922),
    "ur3e": (0.15185, -0.24355, -0.2132, 0.13105, 0.08535, 0.0921),
    "ur5e": (0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996),
    "ur10e": (0.1807, -0.6127, -0.57155, 0.17415, 0.11985, 0.11655),
    "ur16e": (0.1807, -0.4784, -0.36, 0.17415, 0.11985, 0.11655),
}


def _ur_geometry(d1, a2, a3, d4, d5, d6) -> Geometry:
    # UR zero: shoulder at height d1, upper arm and forearm stretched along -x (a2, a3 < 0), the
    # three wrist offsets d4 (along -y), d5 (down), d6 (along -y); axes 2-4 and 6 along -y, 5 down.
    x = a2 + a3
    return Geometry(
        axes=((0, 0, 1), (0, -1, 0), (0, -1, 0), (0, -1, 0), (0, 0, -1), (0, -1, 0)),
        points=((0, 0, 0), (0, 0, d1), (a2, 0, d1), (x, 0, d1), (x, -d4, d1), (x, -d4, d1 - d5)),
        M=_pose([[1, 0, 0], [0, 0, -1], [0, 1, 0]], (x, -(d4 + d6), d1 - d5)),
    )


def _abb_geometry(shoulder_x, shoulder_z, lower_arm, elbow_z, forearm, flange) -> Geometry:
    # ABB zero (calibration position): lower arm vertical, upper arm + wrist along +x; axes
    # 1 +z, 2 +y, 3 +y, 4 +x, 5 +y, 6 +x; tool0 = Ry(90 deg) (z out of the flange).
    z3 = shoulder_z + lower_arm
    z4 = z3 + elbow_z
    xw = shoulder_x + forearm
    return Geometry(
        axes=((0, 0, 1), (0, 1, 0), (0, 1, 0), (1, 0, 0), (0, 1, 0), (1, 0, 0)),
        points=((0, 0, 0), (shoulder_x, 0, shoulder_z), (shoulder_x, 0, z3), (0, 0, z4), (xw, 0, z4), (xw, 0, z4)),
        M=_pose(RY90, (xw + flange, 0, z4)),
    )


GEOMETRY = {name: _ur_geometry(*dh) for name, dh in UR_DH.items()}
# ABB IRB 120 product specification dimension drawing: 290 / 270 / 70 / 302 / 72 mm.
GEOMETRY["abb_irb120"] = _abb_geometry(0.0, 0.290, 0.270, 0.070, 0.302, 0.072)
# ABB IRB 140 product specification dimension drawing: 70 (axis-2 offset) / 352 / 360 / 0 / 380 / 65 mm.
GEOMETRY["abb_irb140"] = _abb_geometry(0.070, 0.352, 0.360, 0.0, 0.380, 0.065)
# KUKA KR 5 arc (ros-industrial kuka_kr5_support, OPW set a1 .18, a2 -.12, c1 .4, c2 .6, c3 .62, c4 .115):
# zero = arm stretched along +x; KUKA's positive directions A1 -z, A2 +y, A3 +y, A4 -x, A5 +y, A6 -x;
# flange frame = ROS-Industrial tool0 (z out of the flange, x along -y).
GEOMETRY["kuka_kr5_arc"] = Geometry(
    axes=((0, 0, -1), (0, 1, 0), (0, 1, 0), (-1, 0, 0), (0, 1, 0), (-1, 0, 0)),
    points=((0, 0, 0), (0.18, 0, 0.4), (0.78, 0, 0.4), (0.78, 0, 0.52), (1.4, 0, 0.52), (1.4, 0, 0.52)),
    M=_pose([[0, 0, 1], [-1, 0, 0], [0, -1, 0]], (1.515, 0, 0.52)),
    sign=(-1, 1, 1, -1, 1, -1),
)
# KUKA LBR iiwa 14 R820: straight up, A2 at 0.36, A4 at 0.78, A6 at 1.18, flange at 1.306 m; axes
# A1 +z, A2 +y, A3 +z, A4 -y, A5 +z, A6 +y, A7 +z.
GEOMETRY["kuka_iiwa14"] = Geometry(
    axes=((0, 0, 1), (0, 1, 0), (0, 0, 1), (0, -1, 0), (0, 0, 1), (0, 1, 0), (0, 0, 1)),
    points=((0, 0, 0), (0, 0, 0.36), (0, 0, 0.36), (0, 0, 0.78), (0, 0, 0.78), (0, 0, 1.18), (0, 0, 1.18)),
    M=_pose(np.eye(3), (0, 0, 1.306)),
)
# Franka Emika Panda at q = 0 (Franka's DH frame drawing): J1 +z; J2 +y at 0.333; J3 +z; J4 -y at
# (0.0825, 0, 0.649); J5 +z and J6 -y at 0.333 + 0.316 + 0.384 = 1.033 on the base axis; J7 pointing
# down at x = 0.088; flange 0.107 below it, R = diag(1, -1, -1).
GEOMETRY["franka_panda"] = Geometry(
    axes=((0, 0, 1), (0, 1, 0), (0, 0, 1), (0, -1, 0), (0, 0, 1), (0, -1, 0), (0, 0, -1)),
    points=((0, 0, 0), (0, 0, 0.333), (0, 0, 0.333), (0.0825, 0, 0.649), (0, 0, 1.033), (0, 0, 1.033), (0.088, 0, 1.033)),
    M=_pose(np.diag([1.0, -1.0, -1.0]), (0.088, 0, 0.926)),
)
# Kinova Gen3 7-DoF at q = 0 (User Guide): straight up; the odd joints turn about -z, the even ones
# about +y; lateral offsets 0.0054 + 0.0064 between J2-J3 and 0.0064 + 0.0064 between J4-J5 (along -y).
_KZ = (0.1564 + 0.1284, 0.1564 + 0.1284 + 0.2104 + 0.2104)  # heights of J2 and J4
GEOMETRY["kinova_gen3"] = Geometry(
    axes=((0, 0, -1), (0, 1, 0), (0, 0, -1), (0, 1, 0), (0, 0, -1), (0, 1, 0), (0, 0, -1)),
    points=((0, 0, 0), (0, 0, _KZ[0]), (0, -0.0118, 0), (0, -0.0118, _KZ[1]), (0, -0.0246, 0),
            (0, -0.0246, _KZ[1] + 0.2084 + 0.1059), (0, -0.0246, 0)),
    M=_pose(np.eye(3), (0, -0.0246, 1.1873)),
)


def _skew(w: np.ndarray) -> np.ndarray:
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def _exp_twist(w, p, theta: float) -> np.ndarray:
    """exp([S] theta) of the revolute screw with unit axis w through point p (Rodrigues)."""
    w = np.asarray(w, dtype=float)
    v = -np.cross(w, np.asarray(p, dtype=float))
    W = _skew(w)
    s, c = np.sin(theta), np.cos(theta)
    T = np.eye(4)
    T[:3, :3] = np.eye(3) + s * W + (1 - c) * W @ W
    T[:3, 3] = (np.eye(3) * theta + (1 - c) * W + (theta - s) * W @ W) @ v
    return T


def poe(geom: Geometry, q_vendor: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    for w, p, th in zip(geom.axes, geom.points, q_vendor):
        T = T @ _exp_twist(w, p, th)
    return T @ geom.M


def _sign(geom: Geometry, n: int) -> np.ndarray:
    return np.asarray(geom.sign or (1,) * n, dtype=float)


# --------------------------------------------------------------------------------------------------
# The catalogue itself
# --------------------------------------------------------------------------------------------------


def test_catalogue_lists_files_that_load():
    assert len(CATALOGUE) >= 8 and len(set(CATALOGUE)) == len(CATALOGUE)
    assert set(CATALOGUE) == set(GEOMETRY), "every catalogue arm needs a published-geometry entry here"
    for name in CATALOGUE:
        m = _model(name)
        assert m.name == name and m.length_unit == "m" and m.source.strip()
    md = (DATA / "robots" / "CATALOGUE.md").read_text()
    for name in CATALOGUE:
        assert f"{name}.yaml" in md, f"{name} missing from data/robots/CATALOGUE.md"


@pytest.mark.parametrize("name", CATALOGUE)
def test_limits_finite_and_ordered(name):
    m = _model(name)
    assert m.limits.shape == (m.n, 2)
    assert np.all(np.isfinite(m.limits)), f"{name}: every catalogue joint needs finite limits"
    assert np.all(m.limits[:, 0] < m.limits[:, 1])
    text = (DATA / "robots" / f"{name}.yaml").read_text()
    assert "limits_source:" in text and text.startswith("#"), f"{name}: header comment and limits_source required"


@pytest.mark.parametrize("name", CATALOGUE)
def test_fk_matches_product_of_exponentials(name):
    m = _model(name)
    geom = GEOMETRY[name]
    s = _sign(geom, m.n)
    np.testing.assert_allclose(fk_htm(m.chain, np.zeros(m.n)), geom.M, atol=ATOL, err_msg=f"{name} zero pose")
    for q in _random_q(m, seed=11):
        np.testing.assert_allclose(fk_htm(m.chain, q), poe(geom, s * q), atol=ATOL, err_msg=f"{name} q={q}")


# --------------------------------------------------------------------------------------------------
# Published poses
# --------------------------------------------------------------------------------------------------

# (robot, vendor joint angles [deg], flange position [m], source)
PUBLISHED = [
    *[(ur, [0] * 6, (dh[1] + dh[2], -(dh[3] + dh[5]), dh[0] - dh[4]),
       "UR FAQ 45257: at q = 0, x = -(|a2| + |a3|), y = -(d4 + d6), z = d1 - d5") for ur, dh in UR_DH.items()],
    ("ur5", [0] * 6, (-0.81725, -0.19145, -0.005491), "UR5 CB3 numbers of FAQ 45257"),
    ("ur5e", [0] * 6, (-0.8172, -0.2329, 0.0628), "UR5e numbers of FAQ 45257"),
    ("abb_irb120", [0] * 6, (0.374, 0.0, 0.630), "IRB 120 calibration position: wrist centre (302, 0, 630) mm + 72 mm"),
    ("abb_irb140", [0] * 6, (0.515, 0.0, 0.712), "IRB 140 calibration position: wrist centre (450, 0, 712) mm + 65 mm"),
    ("kuka_kr5_arc", [0] * 6, (1.515, 0.0, 0.520), "KR 5 arc mechanical zero, arm stretched forward"),
    ("kuka_kr5_arc", [0, -90, 90, 0, 0, 0], (0.915, 0.0, 1.120), "KR 5 arc HOME (A2 -90, A3 +90)"),
    ("kuka_iiwa14", [0] * 7, (0.0, 0.0, 1.306), "iiwa 14 straight up: 0.36 + 0.42 + 0.4 + 0.126"),
    ("franka_panda", [0] * 7, (0.088, 0.0, 0.926), "Panda q = 0: a7 = 0.088, 0.333 + 0.316 + 0.384 - 0.107"),
    ("kinova_gen3", [0] * 7, (0.0, -0.0246, 1.1873), "Gen3 zero: sum of the User Guide lengths"),
]


@pytest.mark.parametrize("name,q_deg,p,source", PUBLISHED, ids=[f"{r[0]}-{i}" for i, r in enumerate(PUBLISHED)])
def test_published_flange_position(name, q_deg, p, source):
    m = _model(name)
    q = _sign(GEOMETRY[name], m.n) * np.deg2rad(q_deg)
    np.testing.assert_allclose(fk_htm(m.chain, q)[:3, 3], p, atol=1e-6, err_msg=source)


def test_published_orientations_at_zero():
    # UR: flange z along -y of the base, x along +x (FAQ diagram); Panda pointing down; iiwa and
    # Kinova upright; ABB tool0 = Ry(90 deg).
    R = {name: fk_htm(_model(name).chain, np.zeros(_model(name).n))[:3, :3] for name in CATALOGUE}
    for ur in UR_DH:
        np.testing.assert_allclose(R[ur], [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=ATOL)
    np.testing.assert_allclose(R["franka_panda"], np.diag([1, -1, -1]), atol=ATOL)
    np.testing.assert_allclose(R["kuka_iiwa14"], np.eye(3), atol=ATOL)
    np.testing.assert_allclose(R["kinova_gen3"], np.eye(3), atol=ATOL)
    np.testing.assert_allclose(R["abb_irb120"], RY90, atol=ATOL)
    np.testing.assert_allclose(R["abb_irb140"], RY90, atol=ATOL)


def test_kr5_arc_reach_matches_data_sheet():
    # KR 5 arc data sheet: maximum reach 1411 mm (wrist centre, from axis 1).
    m = _model("kuka_kr5_arc")
    reach = m.chain.a[0] + m.chain.a[1] + np.hypot(m.chain.d[3], m.chain.a[2])
    assert abs(reach - 1.411) < 1e-3


# --------------------------------------------------------------------------------------------------
# roboticstoolbox-python (peers extra)
# --------------------------------------------------------------------------------------------------


def _rtb_shipped(rtb, name):
    """(rtb model, q_file -> q_rtb, T_rtb -> T_ours, atol) for the arms rtb 1.5.0 ships."""
    DH = rtb.models.DH
    same = lambda q: q  # noqa: E731
    ident = lambda T: T  # noqa: E731
    if name == "ur3":
        return DH.UR3(), same, ident, ATOL
    if name == "ur10":
        return DH.UR10(), same, ident, ATOL
    if name == "ur5":
        # rtb's UR5 has d1 = 0.089459, the FAQ 0.089159: with joint 1 about z the difference is a
        # pure base shift, T_ours = Tz(0.089159 - 0.089459) T_rtb.
        return DH.UR5(), same, lambda T: _Tz(0.089159 - 0.089459) @ T, ATOL
    if name == "abb_irb140":
        # Same a, d, alpha; rtb's zero is not ABB's: q_rtb = q + (0, -pi/2, 0, 0, 0, pi).
        off = np.array([0, -pi / 2, 0, 0, 0, pi])
        return DH.IRB140(), lambda q: q + off, ident, ATOL
    if name == "kuka_kr5_arc":
        # rtb's KR5 zero has the upper arm pointing down and flipped axes 4 and 6:
        # q_rtb = S q + o, S = (1, 1, 1, -1, 1, -1), o = (0, 0, -pi/2, 0, 0, -pi/2); same flange frame.
        S = np.array([1, 1, 1, -1, 1, -1.0])
        o = np.array([0, 0, -pi / 2, 0, 0, -pi / 2])
        return DH.KR5(), lambda q: S * q + o, ident, ATOL
    if name == "franka_panda":
        # Same modified DH and flange; rtb appends the Franka hand, tool = Tz(0.103) Rz(-pi/4).
        r = DH.Panda()
        inv_tool = np.linalg.inv(r.tool.A)
        return r, same, lambda T: T @ inv_tool, ATOL
    if name == "kuka_iiwa14":
        # rtb's URDF model LBR (iiwa 14 R820, from the KUKA description) carries the +-0.436 mm x
        # offsets at A2/A4 of that URDF (a mesh artefact, zero at q = 0): compare to 1 mm.
        return rtb.models.LBR(), same, ident, 1e-3
    return None


RTB_SHIPPED = ["ur3", "ur5", "ur10", "abb_irb140", "kuka_kr5_arc", "franka_panda", "kuka_iiwa14"]


@pytest.mark.parametrize("name", RTB_SHIPPED)
def test_fk_matches_rtb_shipped_model(name):
    rtb = pytest.importorskip("roboticstoolbox")
    robot, qmap, fix, atol = _rtb_shipped(rtb, name)
    m = _model(name)
    kw = {"end": "tool0"} if name == "kuka_iiwa14" else {}
    for q in _random_q(m, seed=23):
        T_rtb = fix(robot.fkine(qmap(q), **kw).A)
        np.testing.assert_allclose(fk_htm(m.chain, q), T_rtb, atol=atol, err_msg=f"{name} q={q}")


def _rtb_from_vendor_dh(rtb, name):
    """rtb's DH engine fed with the vendor's published table (typed here, not read from the file)."""
    if name in UR_DH:
        d1, a2, a3, d4, d5, d6 = UR_DH[name]
        rows = [(d1, 0, pi / 2), (0, a2, 0), (0, a3, 0), (d4, 0, pi / 2), (d5, 0, -pi / 2), (d6, 0, 0)]
        return rtb.DHRobot([rtb.RevoluteDH(d=d, a=a, alpha=al) for d, a, al in rows], name=name)
    if name == "franka_panda":  # Franka docs, Craig convention: (a, d, alpha); flange d 0.107 as tool
        rows = [(0, 0.333, 0), (0, 0, -pi / 2), (0, 0.316, pi / 2), (0.0825, 0, pi / 2),
                (-0.0825, 0.384, -pi / 2), (0, 0, pi / 2), (0.088, 0, pi / 2)]
        links = [rtb.RevoluteMDH(a=a, d=d, alpha=al) for a, d, al in rows]
        return rtb.DHRobot(links, tool=_Tz(0.107), name=name)
    if name == "kuka_iiwa14":  # standard DH of the LBR iiwa 14 R820 (d = 0.36, 0.42, 0.4, 0.126)
        rows = [(0.36, -pi / 2), (0, pi / 2), (0.42, pi / 2), (0, -pi / 2), (0.4, -pi / 2), (0, pi / 2), (0.126, 0)]
        return rtb.DHRobot([rtb.RevoluteDH(d=d, alpha=al) for d, al in rows], name=name)
    if name == "kinova_gen3":  # Gen3 User Guide classical DH, base alpha = pi
        d = [-(0.1564 + 0.1284), -(0.0054 + 0.0064), -(0.2104 + 0.2104), -(0.0064 + 0.0064),
             -(0.2084 + 0.1059), 0.0, -(0.1059 + 0.0615)]
        alpha = [pi / 2] * 6 + [pi]
        offset = [0] + [pi] * 6
        links = [rtb.RevoluteDH(d=di, alpha=ai, offset=oi) for di, ai, oi in zip(d, alpha, offset)]
        return rtb.DHRobot(links, base=np.diag([1.0, -1.0, -1.0, 1.0]), name=name)  # Rx(pi)
    return None


RTB_VENDOR_DH = [*UR_DH, "franka_panda", "kuka_iiwa14", "kinova_gen3"]


@pytest.mark.parametrize("name", RTB_VENDOR_DH)
def test_fk_matches_rtb_on_vendor_dh_table(name):
    rtb = pytest.importorskip("roboticstoolbox")
    robot = _rtb_from_vendor_dh(rtb, name)
    m = _model(name)
    for q in _random_q(m, seed=29):
        np.testing.assert_allclose(fk_htm(m.chain, q), robot.fkine(q).A, atol=ATOL, err_msg=f"{name} q={q}")
