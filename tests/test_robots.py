"""Robot-file validation: every bad file gives one line naming the file, the joint and the field."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from pipeline.robots import RobotFileError, load_robot
from tests.conftest import DATA, mutated

GOOD = {
    "name": "arm",
    "source": "test",
    "length_unit": "m",
    "convention": "standard",
    "joints": [
        {"type": "revolute", "a": 0.3, "alpha": "pi/2", "d": 0.1, "theta_offset": 0, "limits": [-3, 3]},
        {"type": "prismatic", "a": 0.0, "alpha": 0, "d": 0.2, "theta_offset": "-pi/2"},
    ],
}


def _write(tmp_path, doc, name="arm"):
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump(doc) if not isinstance(doc, str) else doc)
    return p


def _mutate(path, value):
    return mutated(GOOD, path, value)


def test_good_file_loads(tmp_path):
    m = load_robot(_write(tmp_path, GOOD))
    assert m.n == 2 and m.chain.prismatic.tolist() == [False, True]
    assert math.isclose(m.chain.alpha[0], math.pi / 2) and math.isclose(m.chain.theta_offset[1], -math.pi / 2)
    assert np.isinf(m.limits[1]).all()
    with pytest.raises(ValueError):
        m.chain.a[0] = 1.0  # immutable


@pytest.mark.parametrize(
    "path,value,expect",
    [
        (("joints", 0, "alpha"), KeyError, "joint 1: field 'alpha': missing"),
        (("joints", 1, "twist"), 1.0, "joint 2: field 'twist': unknown field"),
        (("joints", 0, "a"), "long", "joint 1: field 'a': expected a number"),
        (("joints", 1, "d"), float("nan"), "joint 2: field 'd': must be finite"),
        (("joints", 0, "theta_offset"), float("inf"), "joint 1: field 'theta_offset': must be finite"),
        (("joints", 0, "limits"), [2, 1], "joint 1: field 'limits': lower limit 2 is above upper limit 1"),
        (("joints", 0, "type"), "spherical", "joint 1: field 'type': unknown joint type"),
        (("convention",), "craig", "field 'convention': unknown convention 'craig'"),
        (("length_unit",), "inch", "field 'length_unit': unknown unit"),
        (("source",), KeyError, "field 'source': missing"),
        (("colour",), "red", "field 'colour': unknown field"),
        (("joints",), [], "field 'joints': expected a non-empty list"),
        (("tool",), [[1, 0, 0, 0], [0, 2, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "field 'tool': not a rigid transform"),
        (("joints", 0, "a"), True, "joint 1: field 'a': expected a number"),
    ],
)
def test_bad_field_is_named(tmp_path, path, value, expect):
    p = _write(tmp_path, _mutate(path, value))
    with pytest.raises(RobotFileError) as err:
        load_robot(p)
    msg = str(err.value)
    assert "\n" not in msg
    assert msg.startswith(str(p) + ": ")
    assert expect in msg


def test_name_must_match_file(tmp_path):
    with pytest.raises(RobotFileError, match="field 'name'.*must equal the file name"):
        load_robot(_write(tmp_path, GOOD, name="other"))


def test_yaml_syntax_and_missing_file(tmp_path):
    with pytest.raises(RobotFileError, match=r"arm.yaml: line \d+: not valid YAML"):
        load_robot(_write(tmp_path, "name: [unclosed\n"))
    with pytest.raises(RobotFileError, match="cannot read robot file"):
        load_robot(tmp_path / "none.yaml")


@pytest.mark.parametrize("path", sorted((DATA / "robots").glob("*.yaml")), ids=lambda p: p.stem)
def test_shipped_robot_files_are_valid(path):
    assert load_robot(path).n >= 1


def test_unit_conversion(lwr):
    m = lwr.in_unit("m")
    np.testing.assert_allclose(m.chain.d, lwr.chain.d / 100)
    assert m.length_unit == "m"
