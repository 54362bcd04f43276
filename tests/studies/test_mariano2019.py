"""Study mariano2019 (003_8b306f4736fa5051.txt): counting, generic chains, closed forms, IK, MCU."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.kinematics import fk_dq, fk_htm, orientation_error_angle
from pipeline.robots import load_robot
from pipeline.studies.mariano2019 import algebra as A
from pipeline.studies.mariano2019 import avr, codegen
from pipeline.studies.mariano2019 import closed_form as CF
from pipeline.studies.mariano2019 import counting as K
from pipeline.studies.mariano2019.measure import arm_fk_counts, arm_ik_counts, mcu_records

ROOT = Path(__file__).resolve().parents[2]
ARM = load_robot(ROOT / "data/robots/mariano_4dof.yaml")
P = CF.arm_params(ARM)
FK_TOL = 1e-12        # same double-precision formulas in a different order: a few ulps of ~30 cm
IK_POS_TOL = 1e-9     # cm; near-stretched poses lose ~sqrt(eps) in theta3 (beta close to 1)
IK_ANG_TOL = 1e-9     # rad; same reason
MCU_TOL = 1e-3        # cm; float32 on the MCU (~1e-7 relative) through ~40 operations on a 30 cm arm
ROBOTS = sorted(p.stem for p in (ROOT / "data/robots").glob("*.yaml")
                if load_robot(p).chain.convention != "general")  # the counting chains take DH tables
angles = st.floats(-math.pi, math.pi, allow_nan=False)


@pytest.mark.parametrize("m", range(1, 9))
def test_general_chain_counts_equal_eqs_21_22(m):
    h = A.general_chain_counts(m, "htm")
    d = A.general_chain_counts(m, "dq")
    assert (h.trig, h.mul, h.add) == (4 * m, 70 * m - 64, 48 * m - 48)
    assert (d.trig, d.mul, d.add) == (4 * m, 60 * m - 48, 44 * m - 40)
    assert h.div == h.sqrt == d.div == d.sqrt == 0


@pytest.mark.parametrize("robot", ROBOTS)
def test_generic_chains_match_pipeline_kinematics(robot):
    model = load_robot(ROOT / "data/robots" / f"{robot}.yaml")
    c = model.chain
    rng = np.random.default_rng(5)
    for q in rng.uniform(-np.pi, np.pi, size=(5, c.n)):
        # the generic code has no base/tool: compare with the chain alone
        T_ref = np.linalg.inv(c.base) @ fk_htm(c, q) @ np.linalg.inv(c.tool)
        assert np.allclose(np.array(A.fk_htm_chain(c, list(q))), T_ref, atol=FK_TOL * max(1, np.abs(T_ref).max()))
        from pipeline.kinematics import dq_mul, dq_from_transform, dq_conj

        Q_ref = dq_mul(dq_mul(dq_conj(dq_from_transform(c.base)), fk_dq(c, q)), dq_conj(dq_from_transform(c.tool)))
        Q = np.array(A.fk_dq_chain(c, list(q)))
        Q_ref = Q_ref if np.dot(Q[:4], Q_ref[:4]) >= 0 else -Q_ref   # q and -q are the same pose
        assert np.allclose(Q, Q_ref, atol=FK_TOL * max(1, np.abs(Q_ref).max()))
        assert np.allclose(A.dq_translation(list(Q)), T_ref[:3, 3], atol=FK_TOL * max(1, np.abs(T_ref).max()))


def test_counting_chain_refuses_the_general_form():
    model = load_robot(ROOT / "data/robots/ur5e_urdf.yaml")
    with pytest.raises(ValueError, match="general URDF-style form"):
        A.fk_htm_chain(model.chain, [0.0] * 6)


@settings(max_examples=60, deadline=None)
@given(st.tuples(angles, angles, angles, angles))
def test_closed_form_fk_equals_htm_and_dq_chains(q):
    q = np.array(q)
    T = fk_htm(ARM.chain, q)
    for fn in (CF.fk_printed, CF.fk_factored):
        assert np.allclose(CF.pose_matrix(*fn(P, q)), T, atol=FK_TOL * 100)  # 100: tolerance is absolute in cm
    assert np.allclose(A.dq_translation(A.fk_dq_chain(ARM.chain, list(q))), T[:3, 3], atol=FK_TOL * 100)


def test_counting_does_not_change_values_and_does_not_depend_on_them():
    q = [0.3, -0.2, 0.9, 0.1]
    T = A.fk_dq_chain(ARM.chain, q)
    with K.counting():
        Tc = A.fk_dq_chain(ARM.chain, [K.Counted(v) for v in q])
    assert [K.value(v) for v in Tc] == pytest.approx(T, abs=0)
    a = arm_fk_counts(ARM, q) + arm_ik_counts(ARM, q)
    b = arm_fk_counts(ARM, [1.1, 0.4, -0.5, 0.7]) + arm_ik_counts(ARM, [1.1, 0.4, -0.5, 0.7])
    assert a == b


def test_counting_rules():
    x, y = K.Counted(2.0), K.Counted(3.0)
    with K.counting() as c:
        _ = x * y + x * 0.5 - x * 0.0 + 2.0 * 3.0 + (-x) + K.sin(x) + K.cos(math.pi / 2) + K.sqrt(y) / y
    assert (c.mul, c.scale, c.add, c.neg, c.trig, c.sqrt, c.div) == (1, 1, 5, 1, 1, 1, 1)
    assert K.cos(math.pi / 2) == 0.0


def test_printed_ik_roundtrip_1000_front_poses_both_branches():
    """The counted eqs. 29-32 (front solution of eq. 29) invert eqs. 23-28 on poses in front of the base axis."""
    rng = np.random.default_rng(11)
    Q = rng.uniform(ARM.limits[:, 0], ARM.limits[:, 1], size=(3000, 4))
    T0 = fk_htm(ARM.chain, Q)
    front = np.einsum("ij,ij->i", T0[:, :2, 3], np.c_[np.cos(Q[:, 0]), np.sin(Q[:, 0])]) > 1e-3 * 38.5
    Q, T0 = Q[front][:1000], T0[front][:1000]
    recovered = 0
    for elbow in (1, -1):
        S = np.array([CF.ik(P, *CF.fk_factored(P, q)[:4], elbow) for q in Q])
        T1 = fk_htm(ARM.chain, S)
        assert np.max(np.linalg.norm(T1[:, :3, 3] - T0[:, :3, 3], axis=-1)) < IK_POS_TOL
        assert np.max(orientation_error_angle(T0, T1)) < IK_ANG_TOL
        recovered += int(np.all(np.abs(np.angle(np.exp(1j * (S - Q)))) < 1e-9, axis=-1).sum())
    assert recovered >= 1000   # every pose's joints come back in one branch


def test_study_ik_roundtrip_through_the_registry(tmp_path):
    """Problem set ik_roundtrip, both solver labels (analytic_4dof per elbow), table from the archives."""
    from pipeline.cli import main
    from pipeline.io.archive import read_archive
    from pipeline.settings import load_study
    from pipeline.studies.mariano2019.report import _ik_roundtrip

    study_file = str(ROOT / "data/studies/mariano2019.yaml")
    study = load_study(study_file)
    assert {e.method for e in study.solvers.values()} == {"analytic_4dof"}
    robot = str(ROOT / "data/robots/mariano_4dof.yaml")
    problems = tmp_path / "p.csv"
    assert main(["make_problems", "--study", study_file, "--problem-set", "ik_roundtrip", "--robot", robot,
                 "--scale", "quick", "--out", str(problems)]) == 0
    archives = []
    for label in study.set_solvers("ik_roundtrip"):
        out = tmp_path / f"{label}.mcap"
        assert main(["solve_problems", "--study", study_file, "--problem-set", "ik_roundtrip", "--robot", robot,
                     "--solver", label, "--problems", str(problems), "--scale", "quick", "--out", str(out)]) == 0
        archives.append(read_archive(out))
    table = _ik_roundtrip(archives)
    assert list(table["elbow branch (sign in eq. 30)"]) == [1, -1]
    assert (table["reported unreachable"] == 0).all() and (table["poses"] == 100).all()
    assert (table["max |Δp| (ours)"] < IK_POS_TOL).all() and (table["max angle [rad] (ours)"] < IK_ANG_TOL).all()
    # the limits bend the elbow one way (theta3 in [-pi, 0]): the negative branch returns every pose's joints
    assert list(table["poses whose joints this branch returns"]) == [0, 100]


def test_host_timing_robots_are_listed_files():
    from pipeline.settings import load_study

    listed = load_study(ROOT / "data/studies/mariano2019.yaml").settings["host_timing"]["robots"]
    assert listed and all((ROOT / "data/robots" / f"{r}.yaml").is_file() for r in listed)


def test_ik_unreachable_is_reported():
    with pytest.raises(CF.UnreachableError, match="unreachable"):
        CF.ik(P, 100.0, 0.0, 8.0, 0.0)


def test_arm_params_rejects_other_robots():
    with pytest.raises(ValueError, match="not the 4-DOF arm"):
        CF.arm_params(load_robot(ROOT / "data/robots/kuka_lwr.yaml"))


def test_mcu_not_measured_without_toolchain(monkeypatch, tmp_path):
    monkeypatch.setattr(avr, "toolchain", lambda: {"available": False, "missing": ["simavr"], "versions": {}})
    s = {"mcu": "atmega328p", "freq_hz": 16_000_000, "cflags": ["-Os"], "timeout_s": 10,
         "op_values": {"a": [1.0], "b": [2.0]}}
    recs = mcu_records(ARM, np.zeros((1, 4)), s, tmp_path)
    assert recs["status"][0]["measured"] is False and "install_avr_toolchain" in recs["status"][0]["hint"]
    assert recs["fk"] == recs["sizes"] == recs["ops"] == []


def test_codegen_rejects_bad_input():
    with pytest.raises(ValueError, match="variant"):
        codegen.generate_fk_program("rpy", ARM.chain, np.zeros((1, 4)))
    with pytest.raises(ValueError, match="shape"):
        codegen.generate_fk_program("htm", ARM.chain, np.zeros(4))


@pytest.mark.skipif(not avr.toolchain()["available"], reason="AVR toolchain (avr-gcc, avr-size, simavr) not installed")
def test_mcu_fk_matches_python_fk(tmp_path):
    configs = np.array([[0.1, 0.5, -0.7, 0.3], [-1.2, 2.0, -1.0, 0.5]])
    s = {"mcu": "atmega328p", "freq_hz": 16_000_000, "timeout_s": 60, "op_values": {"a": [0.7], "b": [1.3]},
         "cflags": ["-Os", "-ffunction-sections", "-fdata-sections", "-Wl,--gc-sections"]}
    recs = mcu_records(ARM, configs, s, tmp_path)
    assert recs["status"][0]["measured"]
    ref = fk_htm(ARM.chain, configs)[:, :3, 3]
    assert len(recs["fk"]) == 4
    for r in recs["fk"]:
        assert np.allclose([r["x"], r["y"], r["z"]], ref[r["i"]], atol=MCU_TOL)
        assert r["total"] > r["links"] > 0
    sizes = {r["variant"]: r for r in recs["sizes"]}
    assert sizes["htm"]["flash"] > sizes["baseline"]["flash"] and sizes["dq"]["flash"] > sizes["baseline"]["flash"]
    assert {r["op"] for r in recs["ops"]} == set(codegen.OPS)


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_generic_chains_modified_and_prismatic(convention):
    from pipeline.kinematics import Chain

    rng = np.random.default_rng(3)
    c = Chain(rng.uniform(-1, 1, 5), rng.uniform(-3, 3, 5), rng.uniform(-1, 1, 5), rng.uniform(-1, 1, 5),
              np.array([False, True, False, False, True]), convention)
    q = rng.uniform(-1, 1, 5)
    assert np.allclose(np.array(A.fk_htm_chain(c, list(q))), fk_htm(c, q), atol=FK_TOL)
    Q, Q_ref = np.array(A.fk_dq_chain(c, list(q))), fk_dq(c, q)
    Q_ref = Q_ref if np.dot(Q[:4], Q_ref[:4]) >= 0 else -Q_ref
    assert np.allclose(Q, Q_ref, atol=FK_TOL)


# --- print variant: FK + print_array of the result inside the timed region -----------------------

def test_uart_setting_as_arduino_serial_begin():
    assert codegen.uart_setting(9600, 16e6) == {"baud": 9600, "ubrr": 207, "u2x": True,
                                                "baud_actual": pytest.approx(16e6 / 8 / 208)}
    assert codegen.uart_setting(115200, 16e6)["ubrr"] == 16
    s = codegen.uart_setting(57600, 16e6)          # Arduino's 16 MHz exception: no U2X at 57600
    assert (s["u2x"], s["ubrr"]) == (False, 16)
    assert codegen.uart_setting(codegen.PRINT_BUFFERED, 16e6)["baud_actual"] == 0.0
    with pytest.raises(ValueError, match="baud"):
        codegen.uart_setting(-1, 16e6)


def test_print_codegen_rejects_bad_input_and_leaves_fk_programs_alone():
    with pytest.raises(ValueError, match="print variant"):
        codegen.generate_print_program("htm", ARM.chain, np.zeros((1, 4)), 9600, 16e6)
    with pytest.raises(ValueError, match="shape"):
        codegen.generate_print_program("dq_print", ARM.chain, np.zeros(4), 9600, 16e6)
    q = np.zeros((1, 4))
    for v in ("htm", "dq"):
        fk_src = codegen.generate_fk_program(v, ARM.chain, q)
        assert "print_array" not in fk_src and "PRINT_" not in fk_src
        pr = codegen.generate_print_program(f"{v}_print", ARM.chain, q, 9600, 16e6)
        assert {"htm": codegen.HTM_CODE, "dq": codegen.DQ_CODE}[v] in pr   # the same FK functions
        assert "#define PRINT_UBRR 207" in pr and "#define PRINT_TO_RAM 0" in pr
    assert "#define PRINT_TO_RAM 1" in codegen.generate_print_program("dq_print", ARM.chain, q, 0, 16e6)


def test_parse_print_output_counts_bytes_through_simavr_echo():
    # simavr echoes bytes < ' ' as '.', ends its line after '\n' and after 127 bytes (forced newline)
    row = "12.34 -0.50 0.00 7.25 .."
    long = "1.00 " * 30 + ".."
    shown = long[:127] + "\n" + long[127:] + "\n"
    text = ("OVERHEAD 12.\nPRINT.\n" + (row + "\n") * 4 + "PCONF i=0 x=3f800000 y=40000000 z=c0400000 fk=100 "
            "print=50 total=150 chars=96 .\nPRINT.\n" + shown + "PCONF i=1 x=00000000 y=00000000 z=00000000 fk=1 "
            f"print=2 total=3 chars={len(long)} .\nEND.\n")
    r = avr.parse_print_output(text)
    a, b = r["confs"]
    assert r["overhead"] == 12 and (a["x"], a["y"], a["z"]) == (1.0, 2.0, -3.0)
    assert a["values"] == [12.34, -0.5, 0.0, 7.25] * 4 and len(a["text"]) == a["chars"] == 96
    assert b["values"] == [1.0] * 30 and len(b["text"]) == b["chars"]
    with pytest.raises(avr.AvrError, match="print-variant"):
        avr.parse_print_output("OVERHEAD 1.\nEND.\n")


def test_print_table_not_measured_without_toolchain():
    import pandas as pd

    from pipeline.studies.mariano2019.report import NOT_MEASURED, _print_variant_table

    st = {"measured": False, "missing": ["simavr"], "hint": avr.ENABLE_HINT}
    t = _print_variant_table({"fk": pd.DataFrame(), "print": pd.DataFrame()}, None, st, 16e6)
    assert t.name == "table04_print_variant" and t.frame["timed region"].iloc[0] == NOT_MEASURED
    assert "install_avr_toolchain" in t.note


@pytest.mark.skipif(not avr.toolchain()["available"], reason="AVR toolchain (avr-gcc, avr-size, simavr) not installed")
def test_mcu_print_variant_prints_the_pose_and_costs_more_than_the_fk(tmp_path):
    import pandas as pd

    from pipeline.studies.common import published
    from pipeline.studies.mariano2019.report import _print_variant_table

    configs = np.array([[0.1, 0.5, -0.7, 0.3], [-1.2, 2.0, -1.0, 0.5]])
    f = 16_000_000
    s = {"mcu": "atmega328p", "freq_hz": f, "timeout_s": 120, "op_values": {"a": [0.7], "b": [1.3]},
         "cflags": ["-Os", "-ffunction-sections", "-fdata-sections", "-Wl,--gc-sections"],
         "print_bauds": [codegen.PRINT_BUFFERED, 9600]}
    recs = mcu_records(ARM, configs, s, tmp_path)
    fk = {(r["variant"], r["i"]): r for r in recs["fk"]}
    pr = recs["print"]
    assert len(pr) == 2 * 2 * len(configs)
    for r in pr:
        n = codegen.PRINT_VALUES[f"{r['variant']}_print"]
        assert r["n_values"] == n == len(r["values_ref"]) and r["chars"] == len(r["text"])
        # 2 decimals: rounding (0.005) + float32
        assert np.allclose(r["values"], r["values_ref"], atol=0.005 + MCU_TOL)
        assert np.allclose([r["x"], r["y"], r["z"]], [fk[(r["variant"], r["i"])][k] for k in "xyz"], atol=0)
        only = fk[(r["variant"], r["i"])]["total"]
        assert r["total"] > only and r["total"] == pytest.approx(r["fk"] + r["print"], abs=2 * r["timer_overhead"])
        assert r["fk"] == pytest.approx(only, rel=0.01)      # the same FK code (Timer1 overflow ISR jitter)
        if r["mode"] == "uart":
            # simavr waits for each byte: at least a 10-bit frame per character after the first
            assert r["print"] >= (r["chars"] - 1) * 10 * f / r["baud_actual"]
    ram = {(r["variant"], r["i"]): r for r in pr if r["mode"] == "ram"}
    for r in pr:
        if r["mode"] == "uart":
            assert r["total"] > ram[(r["variant"], r["i"])]["total"] and r["chars"] == ram[(r["variant"], r["i"])]["chars"]
    mcu = {"fk": pd.DataFrame(recs["fk"]), "print": pd.DataFrame(pr)}
    t = _print_variant_table(mcu, published(ROOT / "data/published", "mariano2019", "table04_interrupt_timing"),
                             recs["status"][0], f)
    df = t.frame.set_index("timed region")
    assert list(df.index) == ["FK only (Table IV, table04_mcu_time)", "FK + print, text to RAM (formatting only, no UART)",
                              "FK + print at 9600 baud (simavr UART)", "FK + print at 9600 baud, 8N1 frame (computed)"]
    assert df["ratio HTM/DQ (published)"].iloc[0] == pytest.approx(233176 / 152770)
    assert (df["HTM cycles, median (ours)"].iloc[1:] > df["HTM cycles, median (ours)"].iloc[0]).all()
    # HTM prints twice the values of DQ: with the slow UART the ratio goes well above the FK-only tie
    assert df.loc["FK + print at 9600 baud (simavr UART)", "ratio HTM/DQ, median (ours)"] > 1.5
