"""URDF import/export: round trips of every robot file, a hand-checked URDF, refusals, the CLI verbs."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
import yourdfpy
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.cli import main
from pipeline.kinematics import fk_htm
from pipeline.robots import load_robot, parse_robot
from pipeline.urdf import (
    UNLIMITED_PRISMATIC_M,
    URDFImportError,
    fmt_float,
    import_urdf,
    imported_yaml,
    robot_yaml,
    to_urdf,
)
from tests.conftest import DATA, homogeneous, rodrigues

ROBOTS = sorted((DATA / "robots").glob("*.yaml"))


_rot, _h = rodrigues, homogeneous  # shared test helpers (tests/conftest.py)


def _sample_q(model, rng, count):
    """Angles within the limits (+-pi without), slides within +-0.5 m without limits."""
    slide = 0.5 / {"m": 1.0, "cm": 0.01, "mm": 0.001}[model.length_unit]
    free = np.where(model.chain.prismatic, slide, np.pi)
    lo = np.where(np.isfinite(model.limits[:, 0]), model.limits[:, 0], -free)
    hi = np.where(np.isfinite(model.limits[:, 1]), model.limits[:, 1], free)
    return rng.uniform(lo, hi, (count, model.n))


# ---------------------------------------------------------------------------------------------------------------
# round trips


@pytest.mark.parametrize("path", ROBOTS, ids=[p.stem for p in ROBOTS])
def test_round_trip_every_robot_file(tmp_path, path):
    """robot file -> to_urdf -> import_urdf -> load_robot: same FK (50 angles), limits and joint count."""
    model = load_robot(path)
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(to_urdf(model))
    out = tmp_path / f"{model.name}.yaml"
    out.write_text(imported_yaml(urdf, "base_link", "tool0", name=model.name, length_unit=model.length_unit))
    back = load_robot(out)
    assert back.chain.general and back.n == model.n and back.length_unit == model.length_unit
    assert back.chain.prismatic.tolist() == model.chain.prismatic.tolist()
    np.testing.assert_array_equal(back.limits, model.limits)
    if len(model.joint_names) == model.n and all(model.joint_names):
        assert back.joint_names == model.joint_names
    q = _sample_q(model, np.random.default_rng(50), 50)
    np.testing.assert_allclose(fk_htm(back.chain, q), fk_htm(model.chain, q), rtol=0, atol=1e-9)


@pytest.mark.parametrize("path", ROBOTS, ids=[p.stem for p in ROBOTS])
def test_exported_urdf_fk_by_yourdfpy(tmp_path, path):
    """The URDF's own meaning (yourdfpy's FK, tool0 in base_link, metres) equals the robot file's FK."""
    model = load_robot(path)
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(to_urdf(model))
    u = yourdfpy.URDF.load(str(urdf), build_scene_graph=True, load_meshes=False)
    assert u.validate(), u.errors
    m_si = model.in_unit("m")
    for q in _sample_q(model, np.random.default_rng(3), 5):
        q_si = np.where(model.chain.prismatic, q * {"m": 1, "cm": 0.01, "mm": 0.001}[model.length_unit], q)
        u.update_cfg(q_si)
        np.testing.assert_allclose(u.get_transform("tool0", "base_link"), fk_htm(m_si.chain, q_si), rtol=0, atol=1e-12)


def test_export_and_import_are_deterministic(tmp_path):
    model = load_robot(DATA / "robots" / "stanford.yaml")
    a, b = to_urdf(model), to_urdf(load_robot(DATA / "robots" / "stanford.yaml"))
    assert a == b
    assert f'lower="-{fmt_float(UNLIMITED_PRISMATIC_M)}"' in a and "stands for unlimited" in a
    (tmp_path / "one").mkdir()
    (tmp_path / "two").mkdir()
    (tmp_path / "one" / "s.urdf").write_text(a)
    (tmp_path / "two" / "s.urdf").write_text(a)
    y1 = imported_yaml(tmp_path / "one" / "s.urdf", "base_link", "tool0", name="s", length_unit="mm")
    y2 = imported_yaml(tmp_path / "two" / "s.urdf", "base_link", "tool0", name="s", length_unit="mm")
    assert y1 == y2  # same URDF -> byte-identical YAML, wherever it lies
    assert y1.startswith("# Imported from URDF s.urdf, links base_link -> tool0")
    assert "source: \"URDF s.urdf" in y1


@settings(max_examples=300, deadline=None)
@given(x=st.floats(allow_nan=False, allow_infinity=False))
def test_fmt_float_round_trips_through_yaml(x):
    assert yaml.safe_load(fmt_float(x)) == x and isinstance(yaml.safe_load(fmt_float(x)), float)


def test_robot_yaml_round_trips_a_dh_document():
    doc = yaml.safe_load((DATA / "robots" / "puma560.yaml").read_text())
    model = parse_robot(doc)
    again = parse_robot(yaml.safe_load(robot_yaml(doc, "header")))
    q = np.random.default_rng(0).uniform(-3, 3, (10, model.n))
    np.testing.assert_array_equal(fk_htm(model.chain, q), fk_htm(again.chain, q))
    np.testing.assert_array_equal(model.limits, again.limits)


# ---------------------------------------------------------------------------------------------------------------
# a hand-written URDF

HAND = """<?xml version="1.0"?>
<robot name="hand">
  <link name="world"/><link name="mount"/><link name="a"/><link name="b"/><link name="c"/><link name="d"/>
  <link name="e"/><link name="tip"/><link name="camera"/><link name="finger"/><link name="side"/>
  <joint name="mount_joint" type="fixed">
    <parent link="world"/><child link="mount"/>
    <origin xyz="1 0 0" rpy="0 0 1.5707963267948966"/>
  </joint>
  <joint name="j1" type="revolute">
    <parent link="mount"/><child link="a"/>
    <origin xyz="0 0 0.1"/>
    <axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="10" velocity="1"/>
  </joint>
  <joint name="middle" type="fixed">
    <parent link="a"/><child link="b"/>
    <origin xyz="0.2 0 0" rpy="0 1.5707963267948966 0"/>
  </joint>
  <joint name="j2" type="continuous">
    <parent link="b"/><child link="c"/>
    <origin xyz="0 0.05 0" rpy="0.3 0 0"/>
    <axis xyz="0 1 0"/>
  </joint>
  <joint name="j3" type="prismatic">
    <parent link="c"/><child link="d"/>
    <origin xyz="0 0 0.3"/>
    <axis xyz="1 0 0"/>
    <limit lower="0" upper="0.5" effort="10" velocity="1"/>
  </joint>
  <joint name="end1" type="fixed">
    <parent link="d"/><child link="e"/>
    <origin xyz="0 0 0.1"/>
  </joint>
  <joint name="end2" type="fixed">
    <parent link="e"/><child link="tip"/>
    <origin xyz="0 0 0" rpy="0 0 3.141592653589793"/>
  </joint>
  <joint name="camera_joint" type="floating">
    <parent link="a"/><child link="camera"/>
  </joint>
  <joint name="finger_joint" type="revolute">
    <parent link="c"/><child link="finger"/>
    <axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
    <mimic joint="j2" multiplier="2"/>
  </joint>
  <joint name="side_joint" type="planar">
    <parent link="world"/><child link="side"/>
  </joint>
</robot>
"""


def _hand_fk(q):
    q1, q2, q3 = q
    return (_h(_rot([0, 0, 1], math.pi / 2), [1, 0, 0]) @ _h(t=[0, 0, 0.1]) @ _h(_rot([0, 0, 1], q1))
            @ _h(_rot([0, 1, 0], math.pi / 2), [0.2, 0, 0]) @ _h(_rot([1, 0, 0], 0.3), [0, 0.05, 0])
            @ _h(_rot([0, 1, 0], q2)) @ _h(t=[0, 0, 0.3]) @ _h(t=[q3, 0, 0]) @ _h(t=[0, 0, 0.1])
            @ _h(_rot([0, 0, 1], math.pi)))


def test_hand_written_urdf_imports_and_matches_hand_fk(tmp_path):
    p = tmp_path / "hand.urdf"
    p.write_text(HAND)
    doc = import_urdf(p, "world", "tip")
    assert [j["name"] for j in doc["joints"]] == ["j1", "j2", "j3"]
    assert [j["type"] for j in doc["joints"]] == ["revolute", "revolute", "prismatic"]
    assert "limits" not in doc["joints"][1]  # continuous
    assert "'mount_joint' into 'j1'" in doc["notes"] and "'middle' into 'j2'" in doc["notes"]
    assert "'end1', 'end2' into the tool" in doc["notes"]
    assert doc["joints"][2]["xyz"] == [0.0, 0.0, 0.3]  # not folded: the file's own numbers
    model = parse_robot(doc, str(p))
    np.testing.assert_array_equal(model.limits, [[-1, 1], [-np.inf, np.inf], [0, 0.5]])
    np.testing.assert_array_equal(model.chain.base, np.eye(4))
    for q in np.random.default_rng(1).uniform(-1, 1, (20, 3)):
        np.testing.assert_allclose(fk_htm(model.chain, q), _hand_fk(q), rtol=0, atol=1e-14)
    # the same chain in millimetres
    mm = parse_robot(import_urdf(p, "world", "tip", name="hand_mm", length_unit="mm"))
    assert mm.limits[2].tolist() == [0.0, 500.0] and mm.chain.origins[2][2, 3] == 300.0
    q = np.array([0.3, -0.7, 0.25])
    np.testing.assert_allclose(fk_htm(mm.chain, q * [1, 1, 1000])[:3, 3], 1000 * _hand_fk(q)[:3, 3], atol=1e-10)
    # a sub-chain ending in a moving joint has an identity tool
    sub = import_urdf(p, "mount", "c")
    assert len(sub["joints"]) == 2 and "tool" not in sub  # 'middle' folds into j2; nothing after j2
    sub = parse_robot(sub)
    np.testing.assert_allclose(sub.chain.tool, np.eye(4))


def _one_line(exc, path):
    msg = str(exc.value)
    assert "\n" not in msg and msg.startswith(f"{path}: ")
    return msg


@pytest.mark.parametrize(
    "base,tip,expect",
    [
        ("world", "camera", "floating joint in the chain (only revolute, continuous, prismatic and fixed joints can be "
                            "imported) (joint 'camera_joint')"),
        ("world", "side", "planar joint in the chain"),
        ("world", "finger", "mimic joint in the chain (it follows joint 'j2'"),
        ("tip", "world", "tip link 'world' is not below base link 'tip' (link 'world')"),
        ("c", "a", "is not below base link 'c' (link 'a')"),
        ("world", "nowhere", "unknown link 'nowhere' given as --tip; candidates: "),
        ("base_link", "tip", "unknown link 'base_link' given as --base; candidates: world (roots of the tree)"),
        ("d", "tip", "no revolute, continuous or prismatic joint between links 'd' and 'tip' (link 'tip')"),
        ("tip", "tip", "no revolute, continuous or prismatic joint"),
    ],
)
def test_refusals_name_file_and_joint(tmp_path, base, tip, expect):
    p = tmp_path / "hand.urdf"
    p.write_text(HAND)
    with pytest.raises(URDFImportError) as err:
        import_urdf(p, base, tip)
    assert expect in _one_line(err, p)


@pytest.mark.parametrize(
    "old,new,expect",
    [
        ('<limit lower="-1" upper="1" effort="10" velocity="1"/>\n  </joint>\n  <joint name="middle"',
         '\n  </joint>\n  <joint name="middle"', "revolute joint without <limit lower=... upper=...> (an unlimited "
                                                "revolute joint is type continuous) (joint 'j1')"),
        ('<axis xyz="0 1 0"/>', '<axis xyz="0 0 0"/>', "joint axis must be a finite non-zero 3-vector"),
        ('type="continuous"', 'type="screw"', "unknown joint type 'screw'"),
        ('<limit lower="0" upper="0.5"', '<limit lower="0.6" upper="0.5"', "lower limit 0.6 is above upper limit 0.5"),
        ("</robot>", "", "not valid XML"),
        ('<robot name="hand">', '<robot name="hand">\n  <joint name="orphan" type="fixed"><child link="a"/></joint>',
         "joint without <parent link=...> (joint 'orphan')"),
    ],
)
def test_bad_urdf_is_refused_in_one_line(tmp_path, old, new, expect):
    assert old in HAND
    p = tmp_path / "bad.urdf"
    p.write_text(HAND.replace(old, new, 1))
    with pytest.raises(URDFImportError) as err:
        import_urdf(p, "world", "tip")
    assert expect in _one_line(err, p)


def test_missing_file_is_one_line(tmp_path):
    p = tmp_path / "none.urdf"
    with pytest.raises(URDFImportError) as err:
        import_urdf(p, "a", "b")
    assert "cannot read URDF" in _one_line(err, p)


def test_unlimited_prismatic_stand_in_reads_back_as_no_limits(tmp_path):
    p = tmp_path / "slide.urdf"
    p.write_text(HAND.replace('<limit lower="0" upper="0.5"', f'<limit lower="-{UNLIMITED_PRISMATIC_M}" upper="1e9"'))
    model = parse_robot(import_urdf(p, "world", "tip"))
    assert np.isinf(model.limits[2]).all()


# ---------------------------------------------------------------------------------------------------------------
# CLI


@pytest.mark.parametrize("spelling", ["-", "_"])
def test_cli_export_then_import(tmp_path, capsys, spelling):
    urdf, out = tmp_path / "lwr.urdf", tmp_path / "robots" / "lwr_general.yaml"
    assert main([f"export{spelling}urdf", str(DATA / "robots" / "kuka_lwr.yaml"), "--out", str(urdf)]) == 0
    assert main([f"import{spelling}urdf", str(urdf), "--base", "base_link", "--tip", "tool0", "--out", str(out),
                 "--length-unit", "cm"]) == 0
    model, back = load_robot(DATA / "robots" / "kuka_lwr.yaml"), load_robot(out)
    q = np.random.default_rng(2).uniform(-3, 3, (20, 7))
    np.testing.assert_allclose(fk_htm(back.chain, q), fk_htm(model.chain, q), rtol=0, atol=1e-9)
    assert sorted(p.name for p in out.parent.iterdir()) == ["lwr_general.yaml"]  # no temp files left
    assert "wrote" in capsys.readouterr().out


@pytest.mark.parametrize(
    "args,expect",
    [
        (["--base", "world", "--tip", "camera"], "error: URDFImportError: {urdf}: floating joint in the chain"),
        (["--base", "world", "--tip", "nowhere"], "error: URDFImportError: {urdf}: unknown link 'nowhere' given as --tip"),
        (["--base", "world", "--tip", "tip", "--name", "other"], "error: --name 'other': a robot file's name must"),
    ],
)
def test_cli_import_errors_write_nothing(tmp_path, capsys, args, expect):
    urdf = tmp_path / "hand.urdf"
    urdf.write_text(HAND)
    out = tmp_path / "robots" / "hand.yaml"
    assert main(["import-urdf", str(urdf), "--out", str(out), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(expect.format(urdf=urdf)) and "\n" not in err
    assert not out.exists() and (not out.parent.exists() or not any(out.parent.iterdir()))


def test_cli_export_error_is_one_line(tmp_path, capsys):
    assert main(["export-urdf", str(tmp_path / "nope.yaml"), "--out", str(tmp_path / "x.urdf")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "\n" not in err and not (tmp_path / "x.urdf").exists()


def test_xacro_file_expands_and_imports_like_its_urdf(tmp_path):
    """A xacro file (macro, properties, an argument) imports to the same chain as the URDF it expands to."""
    from pipeline.robots import load_robot, parse_robot
    from pipeline.urdf import import_urdf, is_xacro

    src = Path(__file__).parent / "data" / "xacro" / "my_ur5e.urdf.xacro"
    assert is_xacro(src)
    model = parse_robot(import_urdf(src, "base_link", "tool0"), str(src))
    ref = load_robot("ur5e_urdf")  # the same UR description values, written out as a URDF
    rng = np.random.default_rng(3)
    for q in rng.uniform(-3, 3, (20, 6)):
        np.testing.assert_allclose(fk_htm(model.chain, q), fk_htm(ref.chain, q), atol=1e-8)
    left = parse_robot(import_urdf(src, "left_base_link", "left_tool0", name="my_ur5e",
                                   xacro_args={"prefix": "left_"}), str(src))
    np.testing.assert_allclose(fk_htm(left.chain, np.ones(6)), fk_htm(model.chain, np.ones(6)), atol=1e-12)


def test_xacro_errors_name_the_file(tmp_path):
    from pipeline.urdf import URDFImportError, import_urdf

    bad = tmp_path / "arm.urdf.xacro"
    bad.write_text('<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="a">'
                   '<xacro:include filename="$(find my_description)/urdf/arm.xacro"/></robot>')
    with pytest.raises(URDFImportError, match=rf"^{re.escape(str(bad))}: xacro cannot expand the file"):
        import_urdf(bad, "base_link", "tool0")
    src = Path(__file__).parent / "data" / "xacro" / "my_ur5e.urdf.xacro"
    with pytest.raises(URDFImportError, match=r"unknown link 'tool' given as --tip; candidates: tool0 \(leaves"):
        import_urdf(src, "base_link", "tool")


def test_unseen_arm_urdf_imports():
    from pipeline.robots import parse_robot
    from pipeline.urdf import import_urdf

    src = Path(__file__).parent / "data" / "unseen_arm.urdf"
    model = parse_robot(import_urdf(src, "base_link", "flange"), str(src))
    assert model.n == 6
