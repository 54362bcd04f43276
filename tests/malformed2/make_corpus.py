"""Write the second malformed-input corpus (issue 28): URDFs, joint-point inputs of the ``robot`` verb,
solver settings, generators, robot files and configs, none of them in ``tests/malformed/``.

Run from the repository root after adding a case, then regenerate the expected lines and read them::

    python tests/malformed2/make_corpus.py
    python tests/malformed2/run_corpus.py --write-expected

Cases made at run time (FIFOs and devices given to every verb, damaged problem sets and archives of a
small solve) are listed in ``run_corpus.py``. The robot, study and config templates are the first
corpus's (``tests/malformed/make_corpus.py``), imported, not copied.
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "malformed"))
import make_corpus as M1  # noqa: E402  (tests/malformed/make_corpus.py: its templates, ``sub`` and writer)

ROBOT, GENERAL, STUDY, CONFIG, sub = M1.ROBOT, M1.GENERAL, M1.STUDY, M1.CONFIG, M1.sub


def _joint(name: str, parent: str, child: str, xyz: str, axis: str, lower: str) -> str:
    return (f'  <joint name="{name}" type="revolute">\n    <parent link="{parent}"/>\n    <child link="{child}"/>\n'
            f'    <origin xyz="{xyz}" rpy="0 0 0"/>\n    <axis xyz="{axis}"/>\n'
            f'    <limit lower="{lower}" upper="{lower.lstrip("-")}" effort="10" velocity="1"/>\n  </joint>\n')


URDF = ('<?xml version="1.0"?>\n<robot name="{stem}">\n  <link name="base"/>\n  <link name="l1"/>\n  <link name="tip"/>\n'
        + _joint("j1", "base", "l1", "0 0 0.1", "0 0 1", "-3") + _joint("j2", "l1", "tip", "0.4 0 0", "0 1 0", "-2")
        + "</robot>\n")


POINTS = """\
name: {stem}
source: "malformed-input corpus 2 (tests/malformed2)"
length_unit: mm
joints:
  - {{type: r, position: [0, 0, 200], axis: [0, 0, 1]}}
  - {{type: r, position: [150, 0, 400], axis: [1, 0, 0]}}
  - {{type: p, position: [300, 0, 400], axis: [0, 1, 0]}}
  - {{type: r, position: [300, 300, 400], axis: [0, 1, 0]}}
  - {{type: r, position: [300, 400, 400], axis: [0, 0, 1]}}
  - {{type: r, position: [300, 500, 400], axis: [0, 1, 0]}}
effector:
  position: [300, 580, 400]
  u_a: [0, 1, 0]
  u_t: [0, 0, -1]
"""


def _adder(out: dict):
    def add(stem, content):
        out[stem] = content(stem) if callable(content) else content
    return add


def urdfs() -> dict[str, str | bytes]:
    U = lambda stem, old, new, count=1: sub(URDF, stem, old, new, count)  # noqa: E731
    out: dict[str, str | bytes] = {}
    add = _adder(out)
    j2 = '<origin xyz="0.4 0 0" rpy="0 0 0"/>'
    # --- numbers of <origin>, <axis>, <limit>, <mimic> ------------------------------------------
    for stem, xyz in (("u_xyz_nan", "nan 0 0.1"), ("u_xyz_nan_last", "0 0 nan"), ("u_xyz_NaN", "NaN 0 0.1"),
                      ("u_xyz_inf", "inf 0 0.1"), ("u_xyz_minus_inf", "0 -inf 0.1"), ("u_xyz_infinity", "Infinity 0 0"),
                      ("u_xyz_1e400", "1e400 0 0.1"), ("u_xyz_minus_1e400", "0 0 -1e400"), ("u_xyz_5000", "5000 0 0.1"),
                      ("u_xyz_minus_1001", "0 -1001 0"), ("u_xyz_four", "0 0 0.1 7"), ("u_xyz_two", "0 0.1"),
                      ("u_xyz_empty", ""), ("u_xyz_commas", "0,0,0.1"), ("u_xyz_words", "a b c"),
                      ("u_xyz_hex", "0x1 0 0"), ("u_xyz_long", " ".join(["0.1"] * 5000))):
        add(stem, lambda s, xyz=xyz: U(s, 'xyz="0 0 0.1"', f'xyz="{xyz}"'))
    for stem, rpy in (("u_rpy_nan", "nan 0 0"), ("u_rpy_inf", "0 inf 0"), ("u_rpy_1e400", "0 0 1e400"),
                      ("u_rpy_2000", "2000 0 0"), ("u_rpy_four", "0 0 0 0"), ("u_rpy_two", "0 0"),
                      ("u_rpy_pi", "pi 0 0")):
        add(stem, lambda s, rpy=rpy: U(s, j2, f'<origin xyz="0.4 0 0" rpy="{rpy}"/>'))
    for stem, axis in (("u_axis_nan", "nan 0 1"), ("u_axis_inf", "0 0 inf"), ("u_axis_1e400", "1e400 0 0"),
                       ("u_axis_zero", "0 0 0"), ("u_axis_two", "0 1"), ("u_axis_four", "0 0 1 0"),
                       ("u_axis_words", "x y z"), ("u_axis_1e7", "0 0 1e7")):
        add(stem, lambda s, axis=axis: U(s, '<axis xyz="0 0 1"/>', f'<axis xyz="{axis}"/>'))
    for stem, lim in (("u_limit_lower_nan", 'lower="nan" upper="3"'), ("u_limit_upper_nan", 'lower="-3" upper="nan"'),
                      ("u_limit_lower_word", 'lower="low" upper="3"'), ("u_limit_lower_two", 'lower="-3 -2" upper="3"'),
                      ("u_limit_reversed", 'lower="3" upper="-3"'), ("u_limit_inf_revolute", 'lower="-inf" upper="inf"'),
                      ("u_limit_1e400", 'lower="-1e400" upper="1e400"'), ("u_limit_5000", 'lower="-5000" upper="5000"'),
                      ("u_limit_effort_nan", 'lower="-3" upper="3" effort="nan"'),
                      ("u_limit_velocity_word", 'lower="-3" upper="3" velocity="fast"')):
        add(stem, lambda s, lim=lim: U(s, 'lower="-3" upper="3" effort="10" velocity="1"', lim))
    add("u_limit_missing", lambda s: U(s, '<limit lower="-3" upper="3" effort="10" velocity="1"/>', ""))
    add("u_prismatic_limit_5000", lambda s: U(s, 'type="revolute"', 'type="prismatic"').replace(
        'lower="-3" upper="3"', 'lower="0" upper="5000"'))
    add("u_mimic_nan", lambda s: U(s, '<axis xyz="0 1 0"/>', '<axis xyz="0 1 0"/><mimic joint="j1" multiplier="nan"/>'))
    add("u_mimic_in_chain", lambda s: U(s, '<axis xyz="0 1 0"/>', '<axis xyz="0 1 0"/><mimic joint="j1"/>'))
    # --- the tree: links, joints, loops -----------------------------------------------------------
    add("u_parent_undefined", lambda s: U(s, '<parent link="l1"/>', '<parent link="nowhere"/>'))
    add("u_child_undefined", lambda s: U(s, '<child link="l1"/>', '<child link="l9"/>', 1).replace(
        '<parent link="l1"/>', '<parent link="l9"/>'))
    add("u_parent_is_child", lambda s: U(s, '<parent link="l1"/>', '<parent link="tip"/>'))
    add("u_loop_through_base", lambda s: U(s, "</robot>", '  <joint name="j3" type="fixed">\n    <parent link="tip"/>\n'
                                            '    <child link="base"/>\n  </joint>\n</robot>'))
    add("u_loop_aside", lambda s: U(s, "</robot>", '  <link name="a"/>\n  <link name="b"/>\n'
                                     '  <joint name="ja" type="fixed"><parent link="a"/><child link="b"/></joint>\n'
                                     '  <joint name="jb" type="fixed"><parent link="b"/><child link="a"/></joint>\n</robot>'))
    add("u_child_of_two", lambda s: U(s, "</robot>", '  <joint name="j3" type="fixed"><parent link="base"/>'
                                       '<child link="tip"/></joint>\n</robot>'))
    add("u_link_twice", lambda s: U(s, '<link name="l1"/>', '<link name="l1"/>\n  <link name="l1"/>'))
    add("u_joint_twice", lambda s: U(s, '<joint name="j2"', '<joint name="j1"'))
    add("u_joint_no_name", lambda s: U(s, '<joint name="j2" ', '<joint '))
    add("u_link_no_name", lambda s: U(s, '<link name="l1"/>', '<link name="l1"/>\n  <link/>'))
    add("u_joint_no_parent", lambda s: U(s, '    <parent link="l1"/>\n', ""))
    add("u_joint_no_child", lambda s: U(s, '    <child link="tip"/>\n', ""))
    add("u_no_tip", lambda s: U(s, '"tip"', '"end"', 2))
    add("u_no_base", lambda s: U(s, '"base"', '"world"', 2))
    add("u_floating", lambda s: U(s, '<joint name="j2" type="revolute">', '<joint name="j2" type="floating">'))
    add("u_planar", lambda s: U(s, '<joint name="j1" type="revolute">', '<joint name="j1" type="planar">'))
    add("u_type_ball", lambda s: U(s, '<joint name="j1" type="revolute">', '<joint name="j1" type="ball">'))
    add("u_70_joints", lambda s: _long_chain(s, 70))
    # --- not a URDF ---------------------------------------------------------------------------------
    add("u_empty", "")
    add("u_binary", bytes((i * 41 + 5) % 256 for i in range(2048)))
    add("u_nul_bytes", b"\x00" * 128)
    add("u_utf16", lambda s: URDF.format(stem=s).encode("utf-16"))
    add("u_truncated", lambda s: URDF.format(stem=s)[:300])
    add("u_root_sdf", lambda s: URDF.format(stem=s).replace("<robot", "<sdf").replace("</robot>", "</sdf>"))
    add("u_yaml_text", "name: arm\njoints: []\n")
    # --- XML tricks (refused before: kept as regressions) ------------------------------------------
    add("u_xxe_passwd", lambda s: '<?xml version="1.0"?>\n<!DOCTYPE robot [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n'
        + URDF.format(stem=s).split("\n", 1)[1].replace('name="l1"/>', 'name="l1">&x;</link>', 1))
    add("u_entity_bomb", lambda s: '<?xml version="1.0"?>\n<!DOCTYPE robot [<!ENTITY a "aaaaaaaaaa">'
        + "".join(f'<!ENTITY {c} "' + f"&{p};" * 10 + '">' for p, c in zip("abcdefgh", "bcdefghi"))
        + "]>\n" + URDF.format(stem=s).split("\n", 1)[1].replace('<robot name="' + s + '">', '<robot name="&i;">'))
    add("u_xinclude", lambda s: URDF.format(stem=s).replace("<robot ", '<robot xmlns:xi="http://www.w3.org/2001/XInclude" ')
        .replace("</robot>", '  <xi:include href="/etc/passwd" parse="text"/>\n</robot>'))
    # --- correct acceptances -------------------------------------------------------------------------
    add("u_ok_plain", lambda s: URDF.format(stem=s))
    add("u_ok_whitespace", lambda s: U(s, 'xyz="0 0 0.1"', 'xyz=" 0\t0\n 0.1 "'))
    add("u_ok_continuous_and_fixed", lambda s: U(s, '<joint name="j2" type="revolute">', '<joint name="j2" type="continuous">')
        .replace("</robot>", '  <link name="tool"/>\n  <joint name="jt" type="fixed"><parent link="tip"/>'
                 '<child link="tool"/><origin xyz="0 0 0.05"/></joint>\n</robot>'))
    return out


def _long_chain(stem: str, n: int) -> str:
    links = ['  <link name="base"/>'] + [f'  <link name="l{i}"/>' for i in range(1, n)] + ['  <link name="tip"/>']
    names = ["base"] + [f"l{i}" for i in range(1, n)] + ["tip"]
    joints = [f'  <joint name="j{i + 1}" type="revolute"><parent link="{names[i]}"/><child link="{names[i + 1]}"/>'
              f'<origin xyz="0 0 0.01"/><axis xyz="0 0 1"/><limit lower="-1" upper="1"/></joint>' for i in range(n)]
    return f'<?xml version="1.0"?>\n<robot name="{stem}">\n' + "\n".join(links + joints) + "\n</robot>\n"


def points() -> dict[str, str | bytes]:
    P = lambda stem, old, new: sub(POINTS, stem, old, new)  # noqa: E731
    out: dict[str, str | bytes] = {}
    add = _adder(out)
    add("p_u_a_missing", lambda s: P(s, "  u_a: [0, 1, 0]\n", ""))
    add("p_u_t_missing", lambda s: P(s, "  u_t: [0, 0, -1]\n", ""))
    add("p_effector_position_missing", lambda s: P(s, "  position: [300, 580, 400]\n", ""))
    add("p_effector_list", lambda s: POINTS.format(stem=s).split("effector:")[0] + "effector: [1, 2, 3]\n")
    add("p_effector_null", lambda s: POINTS.format(stem=s).split("effector:")[0] + "effector:\n")
    add("p_effector_unknown_field", lambda s: P(s, "  u_t: [0, 0, -1]\n", "  u_t: [0, 0, -1]\n  speed: 3\n"))
    add("p_joints_empty", lambda s: P(s, "joints:\n", "joints: []\nx_joints:\n"))
    add("p_joints_mapping", lambda s: POINTS.format(stem=s).split("joints:")[0] + "joints: {j1: r}\n"
        + "effector:" + POINTS.format(stem=s).split("effector:")[1])
    add("p_joint_scalar", lambda s: P(s, "  - {type: r, position: [0, 0, 200], axis: [0, 0, 1]}", "  - r"))
    add("p_joint_missing_axis", lambda s: P(s, "position: [0, 0, 200], axis: [0, 0, 1]", "position: [0, 0, 200]"))
    add("p_joint_missing_type", lambda s: P(s, "{type: r, position: [0, 0, 200]", "{position: [0, 0, 200]"))
    add("p_joint_type_word", lambda s: P(s, "{type: r, position: [0, 0, 200]", "{type: revolute, position: [0, 0, 200]"))
    add("p_joint_unknown_field", lambda s: P(s, "axis: [0, 0, 1]}", "axis: [0, 0, 1], mass: 3}"))
    add("p_position_two", lambda s: P(s, "position: [0, 0, 200]", "position: [0, 200]"))
    add("p_position_string", lambda s: P(s, "position: [0, 0, 200]", 'position: "0 0 200"'))
    add("p_position_nan", lambda s: P(s, "position: [0, 0, 200]", "position: [0, .nan, 200]"))
    add("p_position_inf", lambda s: P(s, "position: [300, 580, 400]", "position: [300, .inf, 400]"))
    add("p_position_huge", lambda s: P(s, "position: [150, 0, 400]", "position: [1.0e+10, 0, 400]"))
    add("p_position_bool", lambda s: P(s, "position: [0, 0, 200]", "position: [0, true, 200]"))
    add("p_axis_zero", lambda s: P(s, "axis: [1, 0, 0]", "axis: [0, 0, 0]"))
    add("p_axis_nan", lambda s: P(s, "axis: [1, 0, 0]", "axis: [.nan, 0, 0]"))
    add("p_u_a_zero", lambda s: P(s, "u_a: [0, 1, 0]", "u_a: [0, 0, 0]"))
    add("p_u_a_not_perpendicular", lambda s: P(s, "u_a: [0, 1, 0]", "u_a: [0, 0, 1]"))
    add("p_top_unknown_field", lambda s: POINTS.format(stem=s) + "mass: 12\n")
    add("p_unit_inch", lambda s: P(s, "length_unit: mm", "length_unit: inch"))
    add("p_name_missing", lambda s: P(s, f"name: {s}\n", ""))
    add("p_name_list", lambda s: P(s, f"name: {s}", "name: [a, b]"))
    add("p_joints_70", lambda s: POINTS.format(stem=s).split("joints:")[0] + "joints:\n"
        + "".join(f"  - {{type: r, position: [0, 0, {10 * i}], axis: [0, 0, 1]}}\n" for i in range(70))
        + "effector:" + POINTS.format(stem=s).split("effector:")[1])
    add("p_ok_stanford", lambda s: POINTS.format(stem=s))
    return out


def robots() -> dict[str, str | bytes]:
    R = lambda stem, old, new: sub(ROBOT, stem, old, new)  # noqa: E731
    G = lambda stem, old, new: sub(GENERAL, stem, old, new)  # noqa: E731
    out: dict[str, str | bytes] = {}
    add = _adder(out)
    add("r2_xyz_four", lambda s: G(s, "xyz: [0, 0, 0.3]", "xyz: [0, 0, 0.3, 1]"))
    add("r2_xyz_two", lambda s: G(s, "xyz: [0, 0, 0.3]", "xyz: [0, 0.3]"))
    add("r2_rpy_four", lambda s: G(s, "rpy: [0, 0, 0], axis: [0, 0, 1]", "rpy: [0, 0, 0, 0], axis: [0, 0, 1]"))
    add("r2_axis_four", lambda s: G(s, "axis: [0, 0, 1]", "axis: [0, 0, 1, 0]"))
    add("r2_xyz_nested", lambda s: G(s, "xyz: [0, 0, 0.3]", "xyz: [[0, 0, 0.3]]"))
    add("r2_xyz_1e400", lambda s: G(s, "xyz: [0, 0, 0.3]", "xyz: [0, 0, 1e400]"))
    add("r2_xyz_5000", lambda s: G(s, "xyz: [0, 0, 0.3]", "xyz: [5000, 0, 0.3]"))
    add("r2_rpy_2000", lambda s: G(s, "rpy: [0, 0, 0], axis: [0, 0, 1]", "rpy: [2000, 0, 0], axis: [0, 0, 1]"))
    add("r2_limits_three", lambda s: R(s, "limits: [-3, 3]", "limits: [-3, 0, 3]"))
    add("r2_limits_nested", lambda s: R(s, "limits: [-3, 3]", "limits: [[-3, 3]]"))
    add("r2_limits_pi", lambda s: R(s, "limits: [-3, 3]", "limits: [-pi, pi]"))
    add("r2_limits_2000", lambda s: R(s, "limits: [-3, 3]", "limits: [-2000, 2000]"))
    add("r2_name_slash", lambda s: R(s, f"name: {s}", "name: ../../etc/passwd"))
    add("r2_name_unicode", lambda s: R(s, f"name: {s}", "name: robô"))
    add("r2_unit_upper", lambda s: R(s, "length_unit: m", "length_unit: M"))
    add("r2_convention_capital", lambda s: R(s, "convention: standard", "convention: Standard"))
    add("r2_type_capital", lambda s: R(s, "type: revolute", "type: Revolute"))
    add("r2_tool_five_rows", lambda s: ROBOT.format(stem=s)
        + "tool: [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1], [0, 0, 0, 1]]\n")
    add("r2_tool_4x3", lambda s: ROBOT.format(stem=s) + "tool: [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0]]\n")
    add("r2_tool_string", lambda s: ROBOT.format(stem=s) + 'tool: "identity"\n')
    add("r2_base_bool", lambda s: ROBOT.format(stem=s) + "base: [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, true], [0, 0, 0, 1]]\n")
    add("r2_joints_65", lambda s: ROBOT.format(stem=s).split("joints:")[0] + "joints:\n"
        + "  - {type: revolute, a: 0.1, alpha: 0, d: 0, theta_offset: 0}\n" * 65)
    add("r2_joint_name_list", lambda s: R(s, "{type: revolute, a: 0.4", "{name: [a], type: revolute, a: 0.4"))
    add("r2_a_1e400", lambda s: R(s, "a: 0.4", "a: 1e400"))
    add("r2_alpha_double_division", lambda s: R(s, "alpha: 0", "alpha: pi/2/2"))
    add("r2_theta_2pi", lambda s: R(s, "theta_offset: 0", "theta_offset: 2pi"))
    add("r2_theta_pi_times_2", lambda s: R(s, "theta_offset: 0", "theta_offset: pi*2"))
    add("r2_source_number", lambda s: R(s, 'source: "malformed-input corpus (tests/malformed)"', "source: 12"))
    add("r2_limits_source_list", lambda s: ROBOT.format(stem=s) + "limits_source: [a, b]\n")
    add("r2_effector_field", lambda s: ROBOT.format(stem=s) + "effector: {position: [0, 0, 0]}\n")
    return out


def studies() -> dict[str, str | bytes]:
    S = lambda stem, old, new: sub(STUDY, stem, old, new)  # noqa: E731
    out: dict[str, str | bytes] = {}
    add = _adder(out)
    dls = "{method: dls, criterion: position}"

    def solver(stem, settings):
        return S(stem, dls, settings)

    def generator(stem, ref, extra=""):
        return S(stem, "kind: warm_start", f"kind: generator\n    generator: {ref}{extra}").replace(
            "params: {spread: 0.3}", "params: {}")

    # --- generators: a closed registry -------------------------------------------------------------
    for stem, ref in (("s2_gen_main", '"pipeline.__main__:main"'), ("s2_gen_cli_main", '"pipeline.cli:main"'),
                      ("s2_gen_load_generator", '"pipeline.problems:load_generator"'),
                      ("s2_gen_exception_class", '"pipeline.studies.erthal1992.problems:RunError"'),
                      ("s2_gen_unregistered", '"pipeline.studies.borges_kr6.problems:points_x"'),
                      ("s2_gen_os_system", '"os:system"'), ("s2_gen_trailing_space",
                                                              '"pipeline.studies.erthal1992.problems:test_goals "'),
                      ("s2_gen_int", "5"), ("s2_gen_list", '["pipeline.studies.borges_kr6.problems:points"]'),
                      ("s2_gen_settings_rmtree", '"pipeline.settings:shutil"')):
        add(stem, lambda s, ref=ref: generator(s, ref))
    reg = '"pipeline.studies.erthal1992.problems:path_goals"'
    add("s2_gen_files_passwd", lambda s: generator(s, reg, "\n    files: [../../../../etc/passwd]"))
    add("s2_gen_files_absolute", lambda s: generator(s, reg, "\n    files: [/etc/passwd]"))
    add("s2_gen_param_task_absolute", lambda s: generator(s, reg).replace("params: {}", "params: {task: /etc/passwd}"))
    add("s2_gen_param_task_dotdot", lambda s: generator(s, reg).replace("params: {}",
                                                                        "params: {task: ../../../etc/passwd}"))
    add("s2_gen_param_motions_dotdot", lambda s: generator(s, '"pipeline.studies.nepomuceno2024.problems:motion_points"')
        .replace("params: {}", "params: {motions_file: ../../../etc/hosts.yaml}"))
    # --- file-valued solver settings: inside the data folder ---------------------------------------
    for stem, value in (("s2_jac_passwd", "../../../../etc/passwd"), ("s2_jac_absolute", "/etc/passwd"),
                        ("s2_jac_data_dotdot", "data/../../../etc/passwd"),
                        ("s2_jac_robots_dotdot", "data/robots/../../../etc/passwd"),
                        ("s2_jac_missing", "data/robots/no_such_robot.yaml"), ("s2_jac_folder", "data/robots"),
                        ("s2_jac_backslash", '"data\\\\robots\\\\planar2r.yaml"'), ("s2_jac_home", "~/robot.yaml"),
                        ("s2_jac_nul", '"data/robots/planar2r.yaml\\0"'), ("s2_jac_number", "5"),
                        ("s2_jac_outside_root", "pipeline/__init__.py")):
        add(stem, lambda s, value=value: solver(s, f"{{method: jpinv_descent, jacobian_robot: {value}}}"))
    # --- numeric caps: no solve runs unbounded ------------------------------------------------------
    for stem, settings in (
            ("s2_tracik_timeout_1e9", "{method: trac_ik, timeout: 1.0e+9}"),
            ("s2_tracik_timeout_2", "{method: trac_ik, timeout: 2}"),
            ("s2_tracik_timeout_inf", "{method: trac_ik, timeout: .inf}"),
            ("s2_tracik_timeout_zero", "{method: trac_ik, timeout: 0}"),
            ("s2_tracik_timeout_string", '{method: trac_ik, timeout: "5 ms"}'),
            ("s2_time_budget_1e9", "{method: dls, time_budget: 1.0e+9}"),
            ("s2_time_budget_61", "{method: dls, time_budget: 61}"),
            ("s2_time_budget_nan", "{method: dls, time_budget: .nan}"),
            ("s2_restarts_times_iterations", "{method: dls, restarts: 100000, max_iterations: 1000}"),
            ("s2_restarts_default_iterations", "{method: dls, restarts: 20000}"),
            ("s2_pso_particles_times_iterations", "{method: pso, particles: 1000000}"),
            ("s2_rtb_ilimit_times_slimit", "{method: rtb_ik_lm, ilimit: 1000000, slimit: 100}"),
            ("s2_damping_1e300", "{method: dls, damping: 1.0e+300}"),
            ("s2_tol_pos_1e12", "{method: dls, tol_pos: 1.0e+12}"),
            ("s2_gamma_max_1e10", "{method: jacobian_transpose, gamma_max: 1.0e+10}"),
            ("s2_max_step_1e20", "{method: jpinv_descent, max_step: 1.0e+20}"),
            ("s2_position_weight_1e10", "{method: bfgs, position_weight: 1.0e+10}"),
            ("s2_bounds_path", "{method: lbfgsb, bounds: ../../../../etc/passwd}"),
            ("s2_max_iterations_float", "{method: dls, max_iterations: 1.0e+6}"),
            ("s2_restarts_negative", "{method: dls, restarts: -1}")):
        add(stem, lambda s, settings=settings: solver(s, settings))
    add("s2_reading_time_budget", lambda s: S(s, "interpretations: []", "readings: {default: d, variants: {slow: "
                                              "{time_budget: 1.0e+9}}}\ninterpretations: []"))
    add("s2_reading_jacobian_passwd", lambda s: solver(s, "{method: jpinv_descent}").replace(
        "interpretations: []", "readings: {default: d, variants: {x: {jacobian_robot: /etc/passwd}}}\ninterpretations: []"))
    add("s2_ok_jacobian_in_data", lambda s: solver(s, "{method: jpinv_descent, jacobian_robot: data/robots/planar2r.yaml}"))
    return out


def configs() -> dict[str, str | bytes]:
    C = lambda old, new: CONFIG.replace(old, new)  # noqa: E731
    return {
        "c2_data_dir_dotdot": C("data_dir: data", "data_dir: ../../../../etc"),
        "c2_data_dir_absolute": C("data_dir: data", "data_dir: /etc"),
        "c2_data_dir_dev_null": C("data_dir: data", "data_dir: /dev/null"),
        "c2_data_dir_empty": C("data_dir: data", 'data_dir: ""'),
        "c2_data_dir_nul": C("data_dir: data", 'data_dir: "data\\0"'),
        "c2_data_dir_list": C("data_dir: data", "data_dir: [data]"),
        "c2_studies_dotdot": C("studies: [every_method]", "studies: [../every_method]"),
        "c2_studies_slash": C("studies: [every_method]", "studies: [studies/every_method]"),
        "c2_studies_null_item": C("studies: [every_method]", "studies: [null]"),
        "c2_studies_mapping": C("studies: [every_method]", "studies: {every_method: 1}"),
        "c2_scale_null": C("scale: quick", "scale: null"),
        "c2_scale_list": C("scale: quick", "scale: [quick]"),
        "c2_unknown_timeout": CONFIG + "timeout: 1.0e+9\n",
        "c2_results_dir_number": CONFIG + "results_dir: 5\n",
        "c2_results_dir_bool": CONFIG + "results_dir: false\n",
        "c2_data_dir_no_studies": C("data_dir: data", "data_dir: tests"),
        "c2_empty_mapping": "{}\n",
        "c2_only_comment": "# scale: quick\n",
    }


def main() -> int:
    M1.write_corpus(HERE, (("robots", robots(), ".yaml"), ("studies", studies(), ".yaml"),
                           ("configs", configs(), ".yaml"), ("urdfs", urdfs(), ".urdf"), ("points", points(), ".yaml")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
