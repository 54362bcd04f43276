"""MJCF import (pipeline/mjcf.py, ``import-mjcf``): a hand-written UR5e-sized arm read through MuJoCo's own
parser has MuJoCo's forward kinematics; bad files and chains are refused in one line, writing nothing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pipeline.cli import main
from pipeline.kinematics import fk_htm
from pipeline.robots import load_robot, parse_robot

mujoco = pytest.importorskip("mujoco")

from pipeline.mjcf import MJCFImportError, import_mjcf  # noqa: E402

ARM = Path(__file__).parent / "data" / "mjcf" / "ur5e_arm.xml"
TIP = "attachment_site"
EXACT = 1e-12  # [m, 1] our FK of the imported chain vs MuJoCo's mj_kinematics: the same transforms, rounding only
N_Q = 200


def _mujoco_fk(model, data, q, site: str) -> np.ndarray:
    """MuJoCo's pose of ``site`` in the world at joint values ``q`` (mj_kinematics)."""
    data.qpos[:] = q
    mujoco.mj_kinematics(model, data)
    sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
    T = np.eye(4)
    T[:3, :3] = data.site_xmat[sid].reshape(3, 3)
    T[:3, 3] = data.site_xpos[sid]
    return T


def _random_q(model, n: int, seed: int = 7) -> np.ndarray:
    lim = np.where(np.isfinite(model.limits), model.limits, [[-np.pi, np.pi]])
    return np.random.default_rng(seed).uniform(lim[:, 0], lim[:, 1], (n, model.n))


@pytest.mark.parametrize("unit", ["m", "mm"])
def test_fk_equals_mujoco(unit):
    robot = parse_robot(import_mjcf(ARM, "world", TIP, length_unit=unit), str(ARM))
    mj = mujoco.MjModel.from_xml_path(str(ARM))
    data = mujoco.MjData(mj)
    assert robot.n == mj.nq == 6
    scale = 1000.0 if unit == "mm" else 1.0
    worst_p = worst_r = 0.0
    for q in _random_q(robot, N_Q):
        ours, theirs = fk_htm(robot.chain, q), _mujoco_fk(mj, data, q, TIP)
        worst_p = max(worst_p, float(np.abs(ours[:3, 3] / scale - theirs[:3, 3]).max()))
        worst_r = max(worst_r, float(np.abs(ours[:3, :3] - theirs[:3, :3]).max()))
    assert worst_p <= EXACT and worst_r <= EXACT, (worst_p, worst_r)


def test_limits_and_reference_value_are_read():
    doc = import_mjcf(ARM, "world", TIP)
    names = [j["name"] for j in doc["joints"]]
    assert names == ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
                     "wrist_3_joint"]
    np.testing.assert_allclose(doc["joints"][2]["limits"], [-np.pi, np.pi], rtol=0, atol=1e-15)  # degrees -> rad
    assert "flange" in doc["notes"]  # the joint-less body folded into the tool


def test_a_sub_chain_from_a_body(tmp_path):
    """Base and tip as bodies: the chain between them only, FK relative to the base body."""
    robot = parse_robot(import_mjcf(ARM, "upper_arm_link", "wrist_3_link"), str(ARM))
    mj = mujoco.MjModel.from_xml_path(str(ARM))
    data = mujoco.MjData(mj)
    assert robot.n == 4
    b, t = (mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, x) for x in ("upper_arm_link", "wrist_3_link"))
    for q in _random_q(robot, 20):
        full = np.r_[0.3, -0.4, q]
        data.qpos[:] = full
        mujoco.mj_kinematics(mj, data)
        pose = []
        for i in (b, t):
            T = np.eye(4)
            T[:3, :3], T[:3, 3] = data.xmat[i].reshape(3, 3), data.xpos[i]
            pose.append(T)
        rel = np.linalg.inv(pose[0]) @ pose[1]
        assert np.abs(fk_htm(robot.chain, q) - rel).max() <= EXACT


def test_cli_import_mjcf_writes_a_robot_file(tmp_path, capsys):
    out = tmp_path / "robots" / "ur5e_mjcf.yaml"
    assert main(["import-mjcf", str(ARM), "--tip", TIP, "--out", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    model = load_robot(out)
    mj = mujoco.MjModel.from_xml_path(str(ARM))
    data = mujoco.MjData(mj)
    for q in _random_q(model, 20):
        assert np.abs(fk_htm(model.chain, q) - _mujoco_fk(mj, data, q, TIP)).max() <= EXACT


BALL = """<mujoco><worldbody><body name="a"><joint name="j1" type="ball"/><inertial pos="0 0 0" mass="1"
diaginertia="1 1 1"/><site name="s"/></body></worldbody></mujoco>"""
TWO = """<mujoco><worldbody><body name="a"><joint name="j1" axis="0 0 1"/><joint name="j2" axis="0 1 0"/>
<inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/><site name="s"/></body></worldbody></mujoco>"""
URDF = """<robot name="r"><link name="a"/></robot>"""
BROKEN = """<mujoco><worldbody><body name="a"><joint name="j1" type="nonsense"/></body></worldbody></mujoco>"""


@pytest.mark.parametrize("text,tip,expect", [
    (URDF, "s", "not an MJCF (root element <robot>)"),
    (BROKEN, "s", "MuJoCo cannot compile it"),
    (BALL, "s", "a ball or free joint"),
    (TWO, "s", "2 joints in one body"),
    (TWO, "nowhere", "no such body or site (body 'nowhere')"),
])
def test_refusals_are_one_line_and_write_nothing(tmp_path, capsys, text, tip, expect):
    src = tmp_path / "arm.xml"
    src.write_text(text)
    with pytest.raises(MJCFImportError) as exc:
        import_mjcf(src, "world", tip)
    assert str(exc.value).startswith(f"{src}: ") and expect in str(exc.value) and "\n" not in str(exc.value)
    out = tmp_path / "robots" / "arm.yaml"
    assert main(["import-mjcf", str(src), "--tip", tip, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: MJCFImportError: {src}: ") and "\n" not in err
    assert not out.exists()


def test_import_urdf_points_an_mjcf_file_to_import_mjcf(tmp_path, capsys):
    out = tmp_path / "robots" / "arm.yaml"
    assert main(["import-urdf", str(ARM), "--base", "world", "--tip", TIP, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "not a URDF (root element <mujoco>" in err and "use import-mjcf" in err and "\n" not in err
