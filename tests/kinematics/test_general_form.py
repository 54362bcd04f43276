"""The general (URDF-style origin + axis) joint form: robot files, FK by DQ, Jacobian, zero position."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import Chain, dq_to_transform, fk_dq, fk_htm, geometric_jacobian
from pipeline.kinematics.zero_position import pz_axes, pz_fk, pz_from_chain, pz_from_dh
from pipeline.robots import RobotFileError, describe_general, load_robot, rpy_from_matrix, rpy_matrix
from tests.conftest import DATA, homogeneous, mutated, random_chain, random_rotation, random_transform, rodrigues

ROBOTS = sorted((DATA / "robots").glob("*.yaml"))
FD_STEP = 1e-6
FD_TOL = 1e-7

GOOD = {
    "name": "arm",
    "source": "test",
    "length_unit": "m",
    "convention": "general",
    "joints": [
        {"name": "j1", "type": "revolute", "xyz": [0, 0, 0.3], "rpy": [0, 0, "pi/2"], "axis": [0, 0, 2],
         "limits": [-3, 3]},
        {"name": "j2", "type": "prismatic", "xyz": [0.1, 0.2, 0], "rpy": ["-pi/2", 0.25, 0], "axis": [1, 1, 0]},
        {"type": "revolute", "xyz": [0, 0.05, 0.1], "rpy": [0.1, 0.2, 0.3], "axis": [0.2, -0.4, 1.0]},
    ],
    "tool": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.05], [0, 0, 0, 1]],
}


# ---------------------------------------------------------------------------------------------------------------
# independent reference (written out here, not taken from pipeline.kinematics)


_rot, _h = rodrigues, homogeneous  # shared test helpers (tests/conftest.py)


def _urdf_origin(xyz, rpy):
    r, p, y = rpy
    return _h(_rot([0, 0, 1], y) @ _rot([0, 1, 0], p) @ _rot([1, 0, 0], r), xyz)


def _reference_fk(base, origins, axes, prismatic, tool, q):
    T = np.array(base, float)
    for O, k, pr, qi in zip(origins, axes, prismatic, q):
        k = np.asarray(k, float) / np.linalg.norm(k)
        T = T @ O @ (_h(t=k * qi) if pr else _h(_rot(k, qi)))
    return T @ tool


def _general_of(chain: Chain) -> Chain:
    origins, axes, tool = chain.as_general()
    z = np.zeros(chain.n)
    return Chain(z, z, z, z, chain.prismatic, "general", chain.base, tool, origins, axes)


def _skew_chain(seed: int = 7) -> Chain:
    """A hand-built general chain: skew axes, a prismatic joint, base and tool."""
    rng = np.random.default_rng(seed)
    origins = np.array([_urdf_origin(rng.normal(scale=0.3, size=3), rng.uniform(-np.pi, np.pi, 3)) for _ in range(5)])
    axes = np.array([[0.3, -0.5, 0.8], [1, 0, 0], [0.0, 0.6, -0.8], [1, 2, 3], [-0.7, 0.1, 0.2]])
    prismatic = np.array([False, False, True, False, False])
    z = np.zeros(5)
    return Chain(z, z, z, z, prismatic, "general", random_transform(rng), random_transform(rng, 0.2), origins, axes)


@st.composite
def general_chains(draw, max_dof: int = 7):
    seed = draw(st.integers(0, 2**32 - 1))
    n = draw(st.integers(1, max_dof))
    rng = np.random.default_rng(seed)
    origins = np.array([random_transform(rng, 0.5) for _ in range(n)])
    axes = rng.normal(size=(n, 3))
    prismatic = rng.random(n) < 0.3
    z = np.zeros(n)
    return Chain(z, z, z, z, prismatic, "general", random_transform(rng), random_transform(rng, 0.2), origins, axes)


def _chains_for_checks():
    out = [("skew", _skew_chain())]
    for f in ROBOTS:
        out.append((f"{f.stem}(as_general)", _general_of(load_robot(f).chain)))
    rng = np.random.default_rng(11)
    for conv in ("standard", "modified"):
        out.append((f"random_{conv}(as_general)", _general_of(random_chain(rng, 6, conv, 0.4))))
    return out


CHAINS = _chains_for_checks()


# ---------------------------------------------------------------------------------------------------------------
# robot files


def _write(tmp_path, doc, name="arm"):
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


def test_general_file_loads_and_matches_urdf_meaning(tmp_path):
    m = load_robot(_write(tmp_path, GOOD))
    c = m.chain
    assert c.general and m.n == 3 and c.prismatic.tolist() == [False, True, False]
    assert m.joint_names == ("j1", "j2", "")
    np.testing.assert_allclose(np.linalg.norm(c.axes, axis=1), 1.0, atol=1e-15)
    assert np.isinf(m.limits[1:]).all() and m.limits[0].tolist() == [-3, 3]
    rpy = [[0, 0, math.pi / 2], [-math.pi / 2, 0.25, 0], [0.1, 0.2, 0.3]]  # GOOD's, pi expressions evaluated
    origins = [_urdf_origin(j["xyz"], r) for j, r in zip(GOOD["joints"], rpy)]
    q = np.array([0.4, 0.12, -1.1])
    ref = _reference_fk(np.eye(4), origins, [j["axis"] for j in GOOD["joints"]], c.prismatic,
                        np.array(GOOD["tool"], float), q)
    np.testing.assert_allclose(fk_htm(c, q), ref, atol=1e-14)
    with pytest.raises(ValueError):
        c.origins[0, 0, 0] = 2.0  # immutable
    # unit change scales the origins' translations, not the axes
    mm = m.in_unit("mm")
    np.testing.assert_allclose(fk_htm(mm.chain, q * [1, 1000, 1])[:3, 3], 1000 * ref[:3, 3], atol=1e-9)
    assert mm.joint_names == m.joint_names and mm.limits[0].tolist() == [-3, 3]


def _mutate(path, value):
    return mutated(GOOD, path, value)


@pytest.mark.parametrize(
    "path,value,expect",
    [
        (("joints", 0, "xyz"), KeyError, "joint 1: field 'xyz': missing"),
        (("joints", 1, "rpy"), KeyError, "joint 2: field 'rpy': missing"),
        (("joints", 2, "axis"), KeyError, "joint 3: field 'axis': missing"),
        (("joints", 0, "a"), 0.3, "joint 1: field 'a': a DH field, not allowed with convention general"),
        (("joints", 1, "theta_offset"), 0, "joint 2: field 'theta_offset': a DH field, not allowed"),
        (("joints", 1, "axis"), [0, 0, 0], "joint 2: field 'axis': must be a non-zero 3-vector"),
        (("joints", 0, "xyz"), [0, 0], "joint 1: field 'xyz': expected a list of 3 numbers"),
        (("joints", 0, "xyz"), [0, "pi", 0], "joint 1: field 'xyz': expected a number, got 'pi'"),
        (("joints", 0, "rpy"), [0, "tau", 0], "joint 1: field 'rpy': expected a number or a pi expression"),
        (("joints", 0, "rpy"), "0 0 0", "joint 1: field 'rpy': expected a list of 3 numbers"),
        (("joints", 2, "axis"), [1, float("nan"), 0], "joint 3: field 'axis': must be finite"),
        (("joints", 0, "type"), "continuous", "joint 1: field 'type': unknown joint type 'continuous'"),
        (("joints", 0, "limits"), [3, -3], "joint 1: field 'limits': lower limit 3 is above upper limit -3"),
        (("joints", 0, "colour"), "red", "joint 1: field 'colour': unknown field (allowed: type, xyz, rpy, axis"),
        (("joints", 0, "name"), ["x"], "joint 1: field 'name': expected a string"),
    ],
)
def test_bad_general_field_is_named(tmp_path, path, value, expect):
    p = _write(tmp_path, _mutate(path, value))
    with pytest.raises(RobotFileError) as err:
        load_robot(p)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(str(p) + ": ")
    assert expect in msg


@pytest.mark.parametrize("field,value", [("xyz", [0, 0, 1]), ("rpy", [0, 0, 0]), ("axis", [0, 0, 1])])
def test_general_field_in_dh_joint_is_refused(tmp_path, field, value):
    doc = {"name": "arm", "source": "t", "length_unit": "m", "convention": "modified",
           "joints": [{"type": "revolute", "a": 0, "alpha": 0, "d": 0, "theta_offset": 0, field: value}]}
    p = _write(tmp_path, doc)
    with pytest.raises(RobotFileError) as err:
        load_robot(p)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(str(p) + ": ")
    assert f"joint 1: field '{field}': a general-form field, not allowed with convention modified" in msg


def test_describe_general_prints_origins_axes_and_zero_position(tmp_path):
    m = load_robot(_write(tmp_path, GOOD))
    text = describe_general(m)
    assert "general joint form" in text and "ZERO-POSITION VECTORS" in text
    assert "\t90.0000" in text  # joint 1's yaw pi/2, in degrees
    with pytest.raises(ValueError, match="general-form robot"):
        describe_general(load_robot(DATA / "robots" / "kuka_lwr.yaml"))


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), lock=st.sampled_from([None, 1.0, -1.0]),
       eps=st.sampled_from([0, 1e-13, 1e-9, 1e-5]))
def test_rpy_from_matrix_round_trip(seed, lock, eps):
    """rpy_from_matrix inverts rpy_matrix everywhere, at and near gimbal lock included."""
    rng = np.random.default_rng(seed)
    if lock is None:
        R = random_rotation(rng)
    else:
        r, y = rng.uniform(-np.pi, np.pi, 2)
        R = rpy_matrix(r, lock * (np.pi / 2 - eps), y)
    rpy = rpy_from_matrix(R)
    assert -np.pi / 2 <= rpy[1] <= np.pi / 2
    np.testing.assert_allclose(rpy_matrix(*rpy), R, rtol=0, atol=2e-15)


# ---------------------------------------------------------------------------------------------------------------
# kinematics on general-form chains


@settings(max_examples=80, deadline=None)
@given(chain=general_chains(), seed=st.integers(0, 2**32 - 1))
def test_fk_htm_general_equals_origin_rodrigues_product(chain, seed):
    q = np.random.default_rng(seed).uniform(-2 * np.pi, 2 * np.pi, (3, chain.n))
    T = fk_htm(chain, q)
    for i in range(3):
        ref = _reference_fk(chain.base, chain.origins, chain.axes, chain.prismatic, chain.tool, q[i])
        np.testing.assert_allclose(T[i], ref, rtol=0, atol=1e-12 * (1 + np.abs(ref).max()))


@settings(max_examples=60, deadline=None)
@given(chain=general_chains(), seed=st.integers(0, 2**32 - 1))
def test_fk_dq_general_equals_fk_htm(chain, seed):
    q = np.random.default_rng(seed).uniform(-2 * np.pi, 2 * np.pi, (4, chain.n))
    np.testing.assert_allclose(dq_to_transform(fk_dq(chain, q)), fk_htm(chain, q), rtol=0, atol=1e-12)


@pytest.mark.parametrize("label,chain", CHAINS, ids=[c[0] for c in CHAINS])
def test_as_general_fk_equals_dh_and_dq(label, chain):
    rng = np.random.default_rng(5)
    q = rng.uniform(-np.pi, np.pi, (6, chain.n))
    T = fk_htm(chain, q)
    size = 1 + np.abs(T[..., :3, 3]).max()
    np.testing.assert_allclose(dq_to_transform(fk_dq(chain, q)), T, rtol=0, atol=1e-13 * size)
    if label.endswith("(as_general)") and not label.startswith("random"):
        dh = load_robot(DATA / "robots" / f"{label.split('(')[0]}.yaml").chain
        np.testing.assert_allclose(T, fk_htm(dh, q), rtol=0, atol=1e-13 * size)


def _fd_jacobian(chain, q, h=FD_STEP):
    J = np.zeros((6, chain.n))
    for i in range(chain.n):
        dq = np.zeros(chain.n)
        dq[i] = h
        Tp, Tm = fk_htm(chain, q + dq), fk_htm(chain, q - dq)
        J[:3, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        W = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ fk_htm(chain, q)[:3, :3].T  # skew(omega)
        J[3:, i] = [W[2, 1], W[0, 2], W[1, 0]]
    return J


@pytest.mark.parametrize("label,chain", CHAINS, ids=[c[0] for c in CHAINS])
def test_geometric_jacobian_general_matches_finite_differences(label, chain):
    rng = np.random.default_rng(9)
    for q in rng.uniform(-np.pi, np.pi, (3, chain.n)):
        J = geometric_jacobian(chain, q)
        size = 1 + np.abs(fk_htm(chain, q)[:3, 3]).max()
        np.testing.assert_allclose(J, _fd_jacobian(chain, q), rtol=0, atol=FD_TOL * size)


@settings(max_examples=40, deadline=None)
@given(chain=general_chains(), seed=st.integers(0, 2**32 - 1))
def test_geometric_jacobian_random_general_chains(chain, seed):
    q = np.random.default_rng(seed).uniform(-np.pi, np.pi, chain.n)
    size = 1 + np.abs(fk_htm(chain, q)[:3, 3]).max()
    np.testing.assert_allclose(geometric_jacobian(chain, q), _fd_jacobian(chain, q), rtol=0, atol=FD_TOL * size)


@pytest.mark.parametrize("label,chain", CHAINS, ids=[c[0] for c in CHAINS])
def test_zero_position_description_of_general_chain(label, chain):
    """pz_from_dh / pz_from_chain on a general chain: its zero-position FK reproduces fk_htm."""
    assert pz_from_chain is pz_from_dh
    rng = np.random.default_rng(13)
    q0 = rng.uniform(-1, 1, chain.n)
    pz = pz_from_chain(chain, q0)
    assert pz.types == tuple("p" if p else "r" for p in chain.prismatic)
    for q in rng.uniform(-np.pi, np.pi, (5, chain.n)):
        T = fk_htm(chain, q)
        size = 1 + np.abs(T[:3, 3]).max()
        np.testing.assert_allclose(pz_fk(pz, q), T, rtol=0, atol=1e-12 * size)
        # the axes at q agree with the Jacobian's angular rows (revolute joints)
        axes, _ = pz_axes(pz, q)
        J = geometric_jacobian(chain, q)
        rev = ~chain.prismatic
        np.testing.assert_allclose(axes[rev], J[3:, rev].T, rtol=0, atol=1e-12)


def test_dh_only_functions_refuse_general_chains():
    chain = _skew_chain()
    with pytest.raises(ValueError, match="no DH parameters"):
        chain.joint_dh(np.zeros(chain.n))
