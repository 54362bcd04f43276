"""Write the malformed-input corpus: robot files, study settings and run configs that must each be
refused with one line naming the file (``tests/test_malformed_inputs.py``).

Run from the repository root after adding a case, then regenerate the expected lines and read them::

    python tests/malformed/make_corpus.py
    python tests/malformed/run_corpus.py --write-expected

The files are committed; this script documents how each one was made (several are binary or
hostile and hard to edit by hand). Every robot file's stem is its ``name`` (unless the case is the
mismatch) and every study's stem is its ``study`` id, so that the file names the error.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

ROBOT = """\
name: {stem}
source: "malformed-input corpus (tests/malformed)"
length_unit: m
convention: standard
joints:
  - {{type: revolute, a: 0.4, alpha: 0, d: 0.1, theta_offset: 0, limits: [-3, 3]}}
  - {{type: revolute, a: 0.3, alpha: 0, d: 0, theta_offset: 0, limits: [-3, 3]}}
"""

GENERAL = """\
name: {stem}
source: "malformed-input corpus (tests/malformed)"
length_unit: m
convention: general
joints:
  - {{type: revolute, xyz: [0, 0, 0.3], rpy: [0, 0, 0], axis: [0, 0, 1], limits: [-3, 3]}}
  - {{type: revolute, xyz: [0.4, 0, 0], rpy: [0, 0, 0], axis: [0, 1, 0]}}
"""

STUDY = """\
study: {stem}
title: malformed-input corpus
document: "none"
robots: [planar2r]
problem_sets:
  warm:
    kind: warm_start
    seed: 1
    count: {{full: 10, quick: 5}}
    params: {{spread: 0.3}}
solvers:
  dls: {{method: dls, criterion: position}}
interpretations: []
"""

CONFIG = """\
scale: quick
studies: [every_method]
data_dir: data
"""

BOMB_LEVELS = "".join(f"{chr(98 + i)}: &{chr(98 + i)} [" + ", ".join([f"*{chr(97 + i)}"] * 9) + "]\n" for i in range(9))
BOMB = 'a: &a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]\n' + BOMB_LEVELS


def _bomb_under(key: str) -> str:
    """A billion-laughs alias bomb as the value of ``key`` (nine levels of nine-fold aliases)."""
    lines = [f"{key}:", '  - &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for i in range(1, 10):
        lines.append(f"  - &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]")
    return "\n".join(lines) + "\n"


def sub(template: str, stem: str, old: str, new: str, count: int = 1) -> str:
    text = template.format(stem=stem)
    assert old in text, (stem, old)
    return text.replace(old, new, count)


def robots() -> dict[str, str | bytes]:
    R = lambda stem, old, new, count=1: sub(ROBOT, stem, old, new, count)  # noqa: E731
    G = lambda stem, old, new: sub(GENERAL, stem, old, new)  # noqa: E731
    out: dict[str, str | bytes] = {}

    def add(stem, content):
        out[stem] = content(stem) if callable(content) else content

    # --- YAML level: hostile or broken text ---------------------------------------------
    add("r_alias_bomb_notes", lambda s: ROBOT.format(stem=s) + _bomb_under("notes"))
    add("r_alias_bomb_top", lambda s: ROBOT.format(stem=s) + BOMB)
    add("r_alias_bomb_joints", lambda s: ROBOT.format(stem=s).replace("joints:\n", "joints_x:\n") + _bomb_under("joints"))
    add("r_alias_fanout", lambda s: ROBOT.format(stem=s) + "big: &big [" + ", ".join(["0"] * 1000) + "]\n"
        + "notes: [" + ", ".join(["*big"] * 200) + "]\n")
    add("r_alias_undefined", lambda s: R(s, "d: 0.1", "d: *nowhere"))
    add("r_alias_as_key", lambda s: ROBOT.format(stem=s) + "x: &k notes\n*k : 1\n")
    add("r_nested_brackets", "[" * 20000)
    add("r_nested_braces", "{a: " * 20000)
    add("r_nested_block", "".join("  " * i + f"k{i}:\n" for i in range(40)) + "  " * 40 + "x: 1\n")
    add("r_nested_in_joint", lambda s: R(s, "d: 0.1", "d: " + "[" * 50 + "]" * 50))
    add("r_utf16_bom", lambda s: ROBOT.format(stem=s).encode("utf-16"))
    add("r_utf16_le_nobom", lambda s: ROBOT.format(stem=s).encode("utf-16-le"))
    add("r_utf16_be_bom", lambda s: b"\xfe\xff" + ROBOT.format(stem=s).encode("utf-16-be"))
    add("r_utf32", lambda s: ROBOT.format(stem=s).encode("utf-32"))
    add("r_latin1", lambda s: (ROBOT.format(stem=s) + "notes: Sim\xe3o, m\xe9todo\n").encode("latin-1"))
    add("r_invalid_utf8", lambda s: ROBOT.format(stem=s).encode() + b"notes: \xff\xfe\xfd\n")
    add("r_truncated_utf8", lambda s: ROBOT.format(stem=s).encode() + b"notes: caf\xc3\n")
    add("r_binary_junk", bytes((i * 37 + 11) % 256 for i in range(4096)))
    add("r_png_header", b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(64))
    add("r_gzip", b"\x1f\x8b\x08\x00\x00\x00\x00\x00\x00\x03" + bytes(range(1, 200)))
    add("r_nul_bytes", b"\x00" * 64)
    add("r_control_char", lambda s: ROBOT.format(stem=s) + "notes: bell \x07 here\n")
    add("r_escape_char", lambda s: ROBOT.format(stem=s) + "notes: \x1b[31mred\n")
    add("r_empty", "")
    add("r_only_comments", "# nothing here\n# at all\n")
    add("r_scalar_document", "just a sentence\n")
    add("r_list_document", "- a\n- b\n")
    add("r_unclosed_bracket", lambda s: R(s, "limits: [-3, 3]}", "limits: [-3, 3}"))
    add("r_unclosed_quote", lambda s: ROBOT.format(stem=s) + 'notes: "never closed\n')
    add("r_tab_indent", lambda s: ROBOT.format(stem=s).replace("  - {type", "\t- {type", 1))
    add("r_bad_indent", lambda s: ROBOT.format(stem=s).replace("length_unit: m", "  length_unit: m"))
    add("r_two_documents", lambda s: ROBOT.format(stem=s) + "---\nname: other\n")
    add("r_dup_top_key", lambda s: R(s, "length_unit: m\n", "length_unit: cm\nlength_unit: mm\n"))
    add("r_dup_joint_key", lambda s: R(s, "d: 0.1,", "d: 0.1, d: 0.2,"))
    add("r_dup_quoted_key", lambda s: ROBOT.format(stem=s) + '"name": again\n')
    add("r_dup_name", lambda s: ROBOT.format(stem=s) + f"name: {s}\n")
    add("r_tag_python_apply", lambda s: ROBOT.format(stem=s) + "notes: !!python/object/apply:os.system ['echo pwned']\n")
    add("r_tag_python_name", lambda s: R(s, "d: 0.1", "d: !!python/name:os.system"))
    add("r_tag_python_module", lambda s: ROBOT.format(stem=s) + "notes: !!python/module:os\n")
    add("r_tag_str", lambda s: R(s, "a: 0.4", "a: !!str 0.4"))
    add("r_tag_float", lambda s: R(s, "a: 0.4", "a: !!float 0.4"))
    add("r_tag_local", lambda s: R(s, "- {type", "- !joint {type"))
    add("r_tag_binary", lambda s: ROBOT.format(stem=s) + "notes: !!binary aGVsbG8=\n")
    add("r_tag_set", lambda s: ROBOT.format(stem=s) + "notes: !!set {a, b}\n")
    add("r_tag_nonspecific", lambda s: R(s, "a: 0.4", "a: ! 0.4"))
    add("r_base60_d", lambda s: R(s, "d: 0.1", "d: 12:30"))
    add("r_base60_float", lambda s: R(s, "a: 0.4", "a: 1:30.5"))
    add("r_yaml11_bool", lambda s: R(s, "limits: [-3, 3]", "limits: [no, yes]"))
    add("r_yaml11_on", lambda s: ROBOT.format(stem=s) + "notes: on\n")
    add("r_octal", lambda s: R(s, "d: 0.1", "d: 0755"))
    add("r_underscore_number", lambda s: R(s, "a: 0.4", "a: 1_000"))
    add("r_binary_number", lambda s: R(s, "a: 0.4", "a: 0b101"))
    add("r_date", lambda s: ROBOT.format(stem=s) + "notes: 2019-01-01\n")
    add("r_complex_key", lambda s: ROBOT.format(stem=s) + "? [a, b]\n: 1\n")

    # --- structure and fields --------------------------------------------------------------
    add("r_missing_name", lambda s: R(s, f"name: {s}\n", ""))
    add("r_missing_joints", lambda s: ROBOT.format(stem=s).split("joints:")[0])
    add("r_missing_source", lambda s: R(s, 'source: "malformed-input corpus (tests/malformed)"\n', ""))
    add("r_unknown_top_field", lambda s: ROBOT.format(stem=s) + "mass: 12\n")
    add("r_name_list", lambda s: R(s, f"name: {s}", "name: [a, b]"))
    add("r_name_empty", lambda s: R(s, f"name: {s}", 'name: ""'))
    add("r_name_mismatch", lambda s: R(s, f"name: {s}", "name: some_other_robot"))
    add("r_unit_inch", lambda s: R(s, "length_unit: m", "length_unit: inch"))
    add("r_convention_unknown", lambda s: R(s, "convention: standard", "convention: craig"))
    add("r_joints_empty", lambda s: ROBOT.format(stem=s).split("joints:")[0] + "joints: []\n")
    add("r_joints_null", lambda s: ROBOT.format(stem=s).split("joints:")[0] + "joints:\n")
    add("r_joints_mapping", lambda s: ROBOT.format(stem=s).split("joints:")[0] + "joints: {j1: revolute}\n")
    add("r_joints_100", lambda s: ROBOT.format(stem=s).split("joints:")[0] + "joints:\n"
        + "  - {type: revolute, a: 0.1, alpha: 0, d: 0, theta_offset: 0}\n" * 100)
    add("r_joints_20000", lambda s: ROBOT.format(stem=s).split("joints:")[0] + "joints:\n" + "- {}\n" * 20000)
    add("r_joints_20000_aliased", lambda s: ROBOT.format(stem=s).split("joints:")[0] + "joints:\n"
        + "- &j {type: revolute, a: 0.1, alpha: 0, d: 0, theta_offset: 0}\n" + "- *j\n" * 19999)
    add("r_joint_scalar", lambda s: R(s, "  - {type: revolute, a: 0.3", "  - revolute\n  - {type: revolute, a: 0.3"))
    add("r_joint_missing_type", lambda s: R(s, "{type: revolute, a: 0.4", "{a: 0.4"))
    add("r_joint_type_unknown", lambda s: R(s, "type: revolute", "type: spherical"))
    add("r_joint_type_list", lambda s: R(s, "type: revolute", "type: [revolute]"))
    add("r_joint_missing_d", lambda s: R(s, "d: 0.1, ", ""))
    add("r_joint_unknown_field", lambda s: R(s, "d: 0.1,", "d: 0.1, mass: 3,"))
    add("r_dh_with_xyz", lambda s: R(s, "d: 0.1,", "d: 0.1, xyz: [0, 0, 0],"))
    add("r_general_with_a", lambda s: G(s, "xyz: [0, 0, 0.3],", "xyz: [0, 0, 0.3], a: 0.1,"))
    add("r_a_1e300", lambda s: R(s, "a: 0.4", "a: 1.0e+300"))
    add("r_d_1e10", lambda s: R(s, "d: 0.1", "d: -1.0e+10"))
    add("r_a_huge_int", lambda s: R(s, "a: 0.4", "a: 1" + "0" * 400))
    add("r_a_inf", lambda s: R(s, "a: 0.4", "a: .inf"))
    add("r_d_nan", lambda s: R(s, "d: 0.1", "d: .nan"))
    add("r_alpha_neg_inf", lambda s: R(s, "alpha: 0", "alpha: -.inf"))
    add("r_theta_pi_over_0", lambda s: R(s, "theta_offset: 0", "theta_offset: pi/0"))
    add("r_theta_minus_pi_over_0", lambda s: R(s, "theta_offset: 0", "theta_offset: -pi/0.0"))
    add("r_alpha_3pi_over_0", lambda s: R(s, "alpha: 0", "alpha: 3*pi/0"))
    add("r_theta_expression", lambda s: R(s, "theta_offset: 0", "theta_offset: pi/2 + 1"))
    add("r_theta_1e300", lambda s: R(s, "theta_offset: 0", "theta_offset: 1.0e+300"))
    add("r_alpha_degrees_text", lambda s: R(s, "alpha: 0", "alpha: 90deg"))
    add("r_alpha_huge_multiple", lambda s: R(s, "alpha: 0", "alpha: 99999999*pi"))
    add("r_a_string", lambda s: R(s, "a: 0.4", 'a: "0.4"'))
    add("r_a_bool", lambda s: R(s, "a: 0.4", "a: true"))
    add("r_a_null", lambda s: R(s, "a: 0.4", "a: null"))
    add("r_a_list", lambda s: R(s, "a: 0.4", "a: [0.4]"))
    add("r_limits_reversed", lambda s: R(s, "limits: [-3, 3]", "limits: [5, 1]"))
    add("r_limits_one", lambda s: R(s, "limits: [-3, 3]", "limits: [1]"))
    add("r_limits_inf", lambda s: R(s, "limits: [-3, 3]", "limits: [-.inf, .inf]"))
    add("r_limits_nan", lambda s: R(s, "limits: [-3, 3]", "limits: [.nan, 3]"))
    add("r_limits_absurd", lambda s: R(s, "limits: [-3, 3]", "limits: [-1.0e+9, 1.0e+9]"))
    add("r_limits_string", lambda s: R(s, "limits: [-3, 3]", 'limits: "[-3, 3]"'))
    add("r_prismatic_limit_absurd", lambda s: R(s, "{type: revolute, a: 0.4, alpha: 0, d: 0.1, theta_offset: 0, limits: [-3, 3]}",
                                                "{type: prismatic, a: 0.4, alpha: 0, d: 0.1, theta_offset: 0, limits: [0, 1.0e+7]}"))
    add("r_tool_scaled", lambda s: ROBOT.format(stem=s) + "tool: [[1, 0, 0, 0], [0, 2, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n")
    add("r_tool_reflection", lambda s: ROBOT.format(stem=s) + "tool: [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 0], [0, 0, 0, 1]]\n")
    add("r_tool_three_decimals", lambda s: ROBOT.format(stem=s)
        + "tool: [[0.707, -0.707, 0, 0], [0.707, 0.707, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n")
    add("r_tool_shear", lambda s: ROBOT.format(stem=s) + "tool: [[1, 0.5, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n")
    add("r_base_last_row", lambda s: ROBOT.format(stem=s) + "base: [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 1]]\n")
    add("r_base_3x3", lambda s: ROBOT.format(stem=s) + "base: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\n")
    add("r_base_nan", lambda s: ROBOT.format(stem=s) + "base: [[1, 0, 0, .nan], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n")
    add("r_base_far", lambda s: ROBOT.format(stem=s) + "base: [[1, 0, 0, 1.0e+300], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n")
    add("r_base_zero", lambda s: ROBOT.format(stem=s) + "base: [[0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1]]\n")
    add("r_general_axis_zero", lambda s: G(s, "axis: [0, 0, 1]", "axis: [0, 0, 0]"))
    add("r_general_axis_short", lambda s: G(s, "axis: [0, 0, 1]", "axis: [1, 2]"))
    add("r_general_rpy_pi_over_0", lambda s: G(s, "rpy: [0, 0, 0], axis: [0, 0, 1]", "rpy: [pi/0, 0, 0], axis: [0, 0, 1]"))
    add("r_general_xyz_1e300", lambda s: G(s, "xyz: [0, 0, 0.3]", "xyz: [0, 0, 1.0e+300]"))
    add("r_general_xyz_nan", lambda s: G(s, "xyz: [0, 0, 0.3]", "xyz: [0, .nan, 0.3]"))
    add("r_general_rpy_text", lambda s: G(s, "rpy: [0, 0, 0], axis: [0, 0, 1]", "rpy: [pi/2x, 0, 0], axis: [0, 0, 1]"))
    add("r_general_axis_huge", lambda s: G(s, "axis: [0, 0, 1]", "axis: [0, 0, 1.0e+300]"))
    return out


def studies() -> dict[str, str | bytes]:
    S = lambda stem, old, new: sub(STUDY, stem, old, new)  # noqa: E731
    out: dict[str, str | bytes] = {}

    def add(stem, content):
        out[stem] = content(stem) if callable(content) else content

    add("s_alias_bomb_interpretations", lambda s: STUDY.format(stem=s).replace("interpretations: []\n", "")
        + _bomb_under("interpretations"))
    add("s_alias_bomb_top", lambda s: STUDY.format(stem=s) + BOMB)
    add("s_nested_brackets", lambda s: STUDY.format(stem=s) + "notes: " + "[" * 20000 + "\n")
    add("s_utf16", lambda s: STUDY.format(stem=s).encode("utf-16"))
    add("s_binary_junk", bytes((i * 101 + 7) % 256 for i in range(2048)))
    add("s_invalid_utf8", lambda s: STUDY.format(stem=s).encode() + b"notes: \xc0\xaf\n")
    add("s_empty", "")
    add("s_syntax_error", lambda s: S(s, "count: {full: 10, quick: 5}", "count: {full: 10, quick: 5"))
    add("s_dup_solver_label", lambda s: S(s, "  dls: {method: dls, criterion: position}\n",
                                          "  dls: {method: dls, criterion: position}\n  dls: {method: sdls}\n"))
    add("s_dup_problem_set_key", lambda s: S(s, "    seed: 1\n", "    seed: 1\n    seed: 2\n"))
    add("s_tag_python", lambda s: STUDY.format(stem=s) + "notes: !!python/object/apply:subprocess.call [[ls]]\n")
    add("s_base60_seed", lambda s: S(s, "seed: 1", "seed: 1:30"))
    add("s_yaml11_bool", lambda s: STUDY.format(stem=s) + "skip_inapplicable: yes\n")
    add("s_low_above_high", lambda s: S(s, "kind: warm_start", "kind: random_joint_pairs").replace(
        "params: {spread: 0.3}", "params: {low: 5, high: 1}"))
    add("s_high_nan", lambda s: S(s, "params: {spread: 0.3}", "params: {spread: 0.3, high: .nan}"))
    add("s_high_inf", lambda s: S(s, "params: {spread: 0.3}", "params: {spread: 0.3, high: .inf}"))
    add("s_low_absurd", lambda s: S(s, "params: {spread: 0.3}", "params: {spread: 0.3, low: -1.0e+9}"))
    add("s_spread_negative", lambda s: S(s, "params: {spread: 0.3}", "params: {spread: -0.3}"))
    add("s_spread_inf", lambda s: S(s, "params: {spread: 0.3}", "params: {spread: .inf}"))
    add("s_clip_string", lambda s: S(s, "params: {spread: 0.3}", 'params: {spread: 0.3, clip: "yes"}'))
    add("s_param_unknown", lambda s: S(s, "params: {spread: 0.3}", "params: {sprede: 0.3}"))
    add("s_param_string", lambda s: S(s, "params: {spread: 0.3}", "params: {spread: wide}"))
    add("s_count_quick_huge", lambda s: S(s, "quick: 5}", "quick: 1000000000000}"))
    add("s_count_full_huge", lambda s: S(s, "full: 10,", "full: 5000000,"))
    add("s_count_zero", lambda s: S(s, "full: 10,", "full: 0,"))
    add("s_count_missing_quick", lambda s: S(s, "count: {full: 10, quick: 5}", "count: {full: 10}"))
    add("s_count_float", lambda s: S(s, "quick: 5}", "quick: 5.5}"))
    add("s_count_inf", lambda s: S(s, "quick: 5}", "quick: .inf}"))
    add("s_repetitions_huge", lambda s: S(s, "    seed: 1\n", "    seed: 1\n    repetitions: {full: 1000000, quick: 1}\n"))
    add("s_count_times_repetitions", lambda s: S(s, "count: {full: 10, quick: 5}",
                                                 "count: {full: 100000, quick: 5}\n    repetitions: {full: 100, quick: 1}"))
    add("s_solver_counts_huge", lambda s: S(s, "    seed: 1\n", "    seed: 1\n    solver_counts: {dls: {full: 1000000000000, quick: 1}}\n"))
    add("s_max_iterations_huge", lambda s: S(s, "{method: dls, criterion: position}",
                                             "{method: dls, criterion: position, max_iterations: 1000000000000}"))
    add("s_max_iterations_negative", lambda s: S(s, "{method: dls, criterion: position}",
                                                 "{method: dls, criterion: position, max_iterations: -1}"))
    add("s_grow_limit_huge", lambda s: S(s, "{method: dls, criterion: position}",
                                         "{method: dls, criterion: position, grow_limit: 1000000000000}"))
    add("s_tol_nan", lambda s: S(s, "{method: dls, criterion: position}", "{method: dls, criterion: position, tol_pos: .nan}"))
    add("s_seed_inf", lambda s: S(s, "seed: 1", "seed: .inf"))
    add("s_seed_negative", lambda s: S(s, "seed: 1", "seed: -1"))
    add("s_unknown_method", lambda s: S(s, "method: dls", "method: magic"))
    add("s_missing_method", lambda s: S(s, "{method: dls, criterion: position}", "{criterion: position}"))
    add("s_unknown_setting", lambda s: S(s, "criterion: position}", "criterion: position, speed: 3}"))
    add("s_study_id_mismatch", lambda s: S(s, f"study: {s}", "study: other_study"))
    add("s_missing_interpretations", lambda s: S(s, "interpretations: []\n", ""))
    add("s_robots_empty", lambda s: S(s, "robots: [planar2r]", "robots: []"))
    add("s_robot_missing_file", lambda s: S(s, "robots: [planar2r]", "robots: [no_such_robot]"))
    add("s_unknown_solver_label", lambda s: S(s, "    seed: 1\n", "    seed: 1\n    solvers: [nope]\n"))
    add("s_kind_unknown", lambda s: S(s, "kind: warm_start", "kind: spiral"))
    add("s_generator_missing", lambda s: S(s, "kind: warm_start", "kind: generator"))
    add("s_problem_sets_list", lambda s: STUDY.format(stem=s).split("problem_sets:")[0]
        + "problem_sets: [warm]\nsolvers:\n  dls: {method: dls}\ninterpretations: []\n")
    add("s_top_level_list", "- study\n- title\n")
    add("s_reading_clash", lambda s: S(s, "  dls: {method: dls, criterion: position}\n",
                                       "  dls: {method: dls, criterion: position}\n  dls_x: {method: dls}\n").replace(
        "interpretations: []", "readings: {default: d, variants: {x: {tol_pos: 0.001}}}\ninterpretations: []"))
    return out


def configs() -> dict[str, str | bytes]:
    C = lambda old, new: CONFIG.replace(old, new)  # noqa: E731
    return {
        "c_alias_bomb_studies": "scale: quick\ndata_dir: data\n" + _bomb_under("studies"),
        "c_alias_bomb_top": CONFIG + BOMB,
        "c_nested_brackets": "[" * 20000,
        "c_utf16": CONFIG.encode("utf-16"),
        "c_binary_junk": bytes((i * 53 + 3) % 256 for i in range(1024)),
        "c_invalid_utf8": CONFIG.encode() + b"results_dir: r\xe9sultats\n",
        "c_syntax_error": C("studies: [every_method]", "studies: [every_method"),
        "c_two_documents": CONFIG + "---\nscale: full\n",
        "c_dup_scale": CONFIG + "scale: full\n",
        "c_tag": CONFIG + "results_dir: !!python/object/apply:os.getcwd []\n",
        "c_scale_unknown": C("scale: quick", "scale: fast"),
        "c_scale_yes": C("scale: quick", "scale: yes"),
        "c_scale_base60": C("scale: quick", "scale: 1:30"),
        "c_studies_empty": C("studies: [every_method]", "studies: []"),
        "c_studies_missing_file": C("studies: [every_method]", "studies: [no_such_study]"),
        "c_studies_uppercase": C("studies: [every_method]", "studies: [Every_Method]"),
        "c_studies_duplicated": C("studies: [every_method]", "studies: [every_method, every_method]"),
        "c_studies_string": C("studies: [every_method]", "studies: every_method"),
        "c_unknown_key": CONFIG + "threads: 4\n",
        "c_data_dir_number": C("data_dir: data", "data_dir: 5"),
        "c_data_dir_nan": C("data_dir: data", "data_dir: .nan"),
        "c_results_dir_list": CONFIG + "results_dir: [a, b]\n",
        "c_top_level_list": "- scale\n- quick\n",
        "c_huge_int": CONFIG + "results_dir: " + "9" * 40 + "\n",
        "c_missing_studies": "scale: quick\n",
    }


def write_corpus(here: Path, kinds) -> None:
    """Write each kind's cases as ``here/<kind>/<stem><suffix>`` (the folder emptied first); ``kinds``:
    (kind, {stem: text or bytes}, suffix) triples. Shared with ``tests/malformed2/make_corpus.py``."""
    for kind, cases, suffix in kinds:
        folder = here / kind
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir(parents=True)
        for stem, content in cases.items():
            path = folder / f"{stem}{suffix}"
            if isinstance(content, bytes):
                path.write_bytes(content)
            else:
                path.write_text(content, encoding="utf-8", newline="\n")
        print(f"{len(cases)} {kind} in {folder.relative_to(here.parent.parent)}")


def main() -> int:
    write_corpus(HERE, (("robots", robots(), ".yaml"), ("studies", studies(), ".yaml"), ("configs", configs(), ".yaml")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
