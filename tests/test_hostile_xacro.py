"""Hostile xacro files: importing one never runs code, reads outside the folders it may read, reads the
environment or hangs; each refusal is one line naming the file (and the line, where it can be found).

The corpus (:data:`CASES`) runs through ``pipeline.cli.main(["import-urdf", ...])`` in this process (the
expansion itself runs in the sandbox child, :mod:`pipeline.xacro_sandbox`); a sample (:data:`PROCESS_CASES`)
runs as real ``python -m pipeline import-urdf`` processes whose peak RSS, children included, is measured.
Every code-execution payload tries to create :func:`marker` (``os.system('touch ...')`` or ``open(...,
'w')``); a sentinel string sits in a file outside the input's folder and in the environment variable
``IKP_SECRET``: neither may appear in any output or written file.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SENTINEL = "IKP-FILE-SECRET-5d1e8a"
ENV_SENTINEL = "IKP-ENV-SECRET-93bc27"
NS = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'
CHAIN = ('<link name="base"/><link name="tip"/><joint name="j1" type="revolute"><parent link="base"/>'
         '<child link="tip"/><origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 0 1"/>'
         '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')
REFUSED = "xacro expression refused"
FILE_REFUSED = "xacro file access refused"
OUTSIDE = "is outside the folders this xacro file may read"


def robot(body: str, chain: bool = True) -> str:
    """A xacro robot: the body starts on line 3."""
    return f'<?xml version="1.0"?>\n<robot {NS} name="r">\n{body}\n{CHAIN if chain else ""}\n</robot>\n'


@dataclass
class Case:
    name: str
    text: str                        # the input file (@MARKER@, @SECRET@, @ROBOT@, @ROOT@ replaced)
    expect: str | None               # fragment of the one error line; None: the import succeeds
    argv: list = field(default_factory=list)
    suffix: str = ".xacro"
    time_limit: float | None = None  # pipeline.xacro_sandbox.TIME_LIMIT_S for this case
    base: str = "base"
    tip: str = "tip"
    written: str | None = None       # a fragment the written robot file must contain


SYS = "__import__('os').system('touch @MARKER@')"
WALK = "''.__class__.__mro__[1].__subclasses__()"
WALK_SYS = ("[c for c in ().__class__.__base__.__subclasses__() if c.__name__ == 'catch_warnings'][0]()"
            "._module.__builtins__['__import__']('os').system('touch @MARKER@')")
ATTR_SYS = "().__class__.__base__.__subclasses__()[0].__init__.__globals__['os'].system('touch @MARKER@')"
OPEN_W = "open('@MARKER@', 'w').write('x')"
GETATTR = "getattr(getattr(xacro, 'os'), 'system')('touch @MARKER@')"


def doubling(levels: int, leaf: str, prefix: str = "") -> str:
    """Macros m0 ... mN, each calling the one below twice: 2**N leaves."""
    out = [f'<xacro:macro name="m0" params="n">{leaf}</xacro:macro>']
    for i in range(1, levels + 1):
        out.append(f'<xacro:macro name="m{i}" params="n"><xacro:m{i - 1} n="${{n}}a"/><xacro:m{i - 1} n="${{n}}b"/>'
                   "</xacro:macro>")
    return robot(prefix + "\n".join(out) + f'\n<xacro:m{levels} n="x"/>')


LAUGHS = ('<?xml version="1.0"?>\n<!DOCTYPE robot [\n<!ENTITY a "aaaaaaaaaa">\n'
          + "".join(f'<!ENTITY {chr(98 + i)} "{("&" + chr(97 + i) + ";") * 10}">\n' for i in range(9))
          + f']>\n<robot {NS} name="r"><link name="&j;"/>{CHAIN}</robot>\n')

CASES = [
    # --- code execution, through every place an expression is evaluated -----------------------------------
    Case("prop_walk", robot(f'<xacro:property name="p" value="${{{WALK}}}"/>\n<link name="${{p}}"/>'),
         f"line 3: {REFUSED} (attribute access '__class__' is not allowed; xacro expressions may use arithmetic"),
    Case("prop_walk_sys", robot(f'<xacro:property name="p" value="${{{WALK_SYS}}}"/><link name="${{p}}"/>'),
         "line 3: xacro expression refused (comprehensions are not allowed"),
    Case("prop_eager", robot(f'<xacro:property name="p" value="${{{ATTR_SYS}}}" lazy_eval="false"/>'),
         "line 3: xacro expression refused (attribute access '__class__'"),
    Case("prop_import", robot(f'<xacro:property name="p" value="${{{SYS}}}"/><link name="${{p}}"/>'),
         "line 3: xacro expression refused (the name '__import__' is not allowed"),
    Case("origin_attr", robot(f'<joint name="j0" type="fixed"><parent link="base"/><child link="tip"/>'
                              f'<origin xyz="${{{SYS}}} 0 0"/></joint>'), "line 3: xacro expression refused"),
    Case("origin_rpy_walk", robot(f'<link name="x"/><joint name="j0" type="fixed"><parent link="base"/>'
                                  f'<child link="x"/><origin rpy="0 0 ${{{ATTR_SYS}}}"/></joint>'),
         "attribute access '__class__'"),
    Case("if_value", robot(f'<xacro:if value="${{{SYS}}}"><link name="y"/></xacro:if>'),
         "line 3: xacro expression refused (the name '__import__'"),
    Case("unless_value", robot(f'<xacro:unless value="${{{WALK}}}"><link name="y"/></xacro:unless>'),
         "line 3: xacro expression refused (attribute access '__class__'"),
    Case("macro_default", robot(f'<xacro:macro name="m" params="a:=${{{GETATTR}}}"><link name="${{a}}"/>'
                                '</xacro:macro>\n<xacro:m/>'),
         "line 3: xacro expression refused (the Python builtin 'getattr' is not allowed"),
    Case("macro_param", robot('<xacro:macro name="m" params="a"><link name="${a}"/></xacro:macro>\n'
                              f'<xacro:m a="${{{OPEN_W}}}"/>'),
         "line 4: xacro expression refused (the Python builtin 'open' is not allowed"),
    Case("link_name", robot(f'<link name="${{{WALK_SYS}}}"/>'), "line 3: xacro expression refused"),
    Case("joint_name", robot(f'<link name="x"/><joint name="${{{ATTR_SYS}}}" type="fixed"><parent link="base"/>'
                             '<child link="x"/></joint>'), "line 3: xacro expression refused"),
    Case("element_name", robot(f'<xacro:element xacro:name="${{{SYS}}}"/>'), "line 3: xacro expression refused"),
    Case("attribute_name", robot(f'<link name="x"><xacro:attribute name="${{{WALK}}}" value="1"/></link>'),
         "line 3: xacro expression refused"),
    Case("attribute_value", robot(f'<link name="x"><xacro:attribute name="k" value="${{{OPEN_W}}}"/></link>'),
         "line 3: xacro expression refused (the Python builtin 'open'"),
    Case("call_macro", robot('<xacro:macro name="m"><link name="x"/></xacro:macro>\n'
                             f'<xacro:call macro="${{{GETATTR}}}"/>'),
         "line 4: xacro expression refused (the Python builtin 'getattr'"),
    Case("eval_subst", robot('<link name="$(eval [].__class__.__base__)"/>'),
         "line 3: xacro expression refused (attribute access '__class__'"),
    Case("eval_subst_import", robot("<link name=\"$(eval __import__)\"/>"),
         "line 3: xacro expression refused (the name '__import__'"),
    Case("property_name_expr", robot(f'<xacro:property name="${{{SYS}}}" value="1"/>'),
         "line 3: xacro expression refused"),
    Case("arg_default", robot(f'<xacro:arg name="a" default="${{{WALK}}}"/>'), "line 3: xacro expression refused"),
    Case("text_node", robot(f'<link name="x"><visual>${{{SYS}}}</visual></link>'), "line 3: xacro expression refused"),
    Case("eval_comment", robot(f'<!-- xacro:eval-comments -->\n<!-- ${{{WALK}}} -->'),
         "line 4: xacro expression refused (attribute access '__class__'"),
    Case("include_name_expr", robot(f'<xacro:include filename="${{{SYS}}}"/>'), "line 3: xacro expression refused"),
    Case("nested_lazy", robot('<xacro:property name="p1" value="${p2 * 2}"/>\n'
                              f'<xacro:property name="p2" value="${{{ATTR_SYS}}}"/>\n<link name="${{p1}}"/>'),
         "line 4: xacro expression refused (attribute access '__class__'"),
    Case("plain_urdf_ns", robot(f'<link name="${{{WALK_SYS}}}"/>'), "line 3: xacro expression refused",
         suffix=".urdf"),
    Case("type_builtin", robot("<link name=\"${type('X', (), dict())}\"/>"),
         "line 3: xacro expression refused (the Python builtin 'type' is not allowed"),
    Case("python_ns_type", robot('<link name="${python.type(1)}"/>'),
         "line 3: xacro expression refused (the Python builtin 'type'"),
    Case("lambda", robot('<link name="${(lambda: 0)()}"/>'), "line 3: xacro expression refused (lambda is not allowed"),
    Case("generator", robot('<link name="${sum(x for x in range(3))}"/>'), "(comprehensions are not allowed"),
    Case("fstring", robot("<link name=\"${f'abc'}\"/>"), "line 3: xacro expression refused (f-strings are not"),
    Case("walrus", robot('<link name="${(x := 5)}"/>'), "(assignment expressions (:=) are not allowed"),
    Case("eval_builtin", robot("<link name=\"${eval('1')}\"/>"), "(the Python builtin 'eval' is not allowed"),
    Case("exec_builtin", robot("<link name=\"${exec('import os')}\"/>"), "(the Python builtin 'exec'"),
    Case("globals_builtin", robot('<link name="${globals()}"/>'), "(the Python builtin 'globals'"),
    Case("vars_ns", robot('<link name="${python.vars()}"/>'), "(the Python builtin 'vars'"),
    Case("xacro_dict", robot('<link name="${xacro.__dict__}"/>'), "(attribute access '__dict__'"),
    Case("load_yaml_globals", robot("<link name=\"${xacro.load_yaml.__globals__['os'].environ['IKP_SECRET']}\"/>"),
         "(attribute access '__globals__'"),
    Case("string_method", robot("<link name=\"${'a'.join(['b'])}\"/>"), "(attribute access 'join' is not allowed"),
    Case("format_method", robot("<link name=\"${'x'.format(1)}\"/>"), "(attribute access 'format'"),
    Case("math_self", robot('<link name="${math.sin.__self__}"/>'), "(attribute access '__self__'"),
    Case("call_number", robot('<link name="${(1)(2)}"/>'), "(calling a value of type 'int' is not allowed"),
    Case("starred", robot('<link name="${[*range(3)]}"/>'), "(unpacking (*) is not allowed"),
    Case("yaml_unit_code", robot('<xacro:property name="c" value="${xacro.load_yaml(\'evil_units.yaml\')}"/>'
                                 '<link name="${c}"/>'),
         "evil_units.yaml, line 1: xacro expression refused (the name '__import__'"),
    Case("yaml_python_tag", robot('<xacro:property name="c" value="${xacro.load_yaml(\'pytag.yaml\')}"/>'
                                  '<link name="${c}"/>'), "not valid YAML"),
    Case("included_macro", robot('<xacro:include filename="inc/evil_macro.xacro"/>\n<xacro:evil/>'),
         "inc/evil_macro.xacro, line 2: xacro expression refused (attribute access '__class__'"),
    Case("dynamic_include_element",
         robot('<xacro:element xacro:name="xacro:include" filename="@SECRET@/secret.xacro"/>'),
         f"{FILE_REFUSED} ("),
    # --- files outside the allowed folders, or not regular files ----------------------------------------------
    Case("yaml_absolute", robot("<xacro:property name=\"c\" value=\"${xacro.load_yaml('@SECRET@/secret.yaml')}\"/>"
                                '<link name="${c}"/>'), f"line 3: {FILE_REFUSED} (@SECRET@/secret.yaml {OUTSIDE}"),
    Case("yaml_dotdot", robot("<xacro:property name=\"c\" value=\"${load_yaml('../secret/secret.yaml')}\"/>"
                              '<link name="${c}"/>'), f"{FILE_REFUSED} (@SECRET@/secret.yaml {OUTSIDE}"),
    Case("yaml_symlink_out", robot("<link name=\"${xacro.load_yaml('link_out.yaml')['value']}\"/>"),
         f"line 3: {FILE_REFUSED} (link_out.yaml {OUTSIDE}"),
    Case("yaml_proc_environ", robot("<link name=\"${xacro.load_yaml('/proc/self/environ')}\"/>"),
         f"{FILE_REFUSED} (/proc/self/environ {OUTSIDE}"),
    Case("yaml_fifo", robot("<link name=\"${xacro.load_yaml('fifo.yaml')}\"/>"),
         f"line 3: {FILE_REFUSED} (fifo.yaml is not a regular file (a FIFO))"),
    Case("yaml_dev_zero", robot("<link name=\"${xacro.load_yaml('/dev/zero')}\"/>"), f"(/dev/zero {OUTSIDE}"),
    Case("yaml_dirname_dotdot", robot("<link name=\"${xacro.load_yaml('$(dirname)/../secret/secret.yaml')}\"/>"),
         f"{FILE_REFUSED} (@SECRET@/secret.yaml {OUTSIDE}"),
    Case("include_absolute", robot('<xacro:include filename="@SECRET@/secret.xacro"/>'),
         f"line 3: {FILE_REFUSED} (@SECRET@/secret.xacro {OUTSIDE}"),
    Case("include_dotdot", robot('<xacro:include filename="../secret/secret.xacro"/>'),
         f"line 3: {FILE_REFUSED} (@SECRET@/secret.xacro {OUTSIDE}"),
    Case("include_symlink_out", robot('<xacro:include filename="link_out.xacro"/>'),
         f"line 3: {FILE_REFUSED} (link_out.xacro {OUTSIDE}"),
    Case("include_fifo", robot('<xacro:include filename="fifo.xacro"/>'),
         f"line 3: {FILE_REFUSED} (fifo.xacro is not a regular file (a FIFO))"),
    Case("include_dev_zero", robot('<xacro:include filename="/dev/zero"/>'), f"(/dev/zero {OUTSIDE}"),
    Case("include_glob_etc", robot('<xacro:include filename="/etc/*.conf"/>'), f"(/etc/*.conf {OUTSIDE}"),
    Case("include_glob_dotdot", robot('<xacro:include filename="../secret/*.xacro"/>'), f"{OUTSIDE}"),
    Case("include_glob_recursive", robot('<xacro:include filename="**/*.xacro"/>'),
         "recursive include patterns (**) are not allowed"),
    Case("include_arg_path", robot('<xacro:arg name="f" default="x.xacro"/><xacro:include filename="$(arg f)"/>'),
         f"(/etc/passwd {OUTSIDE}", argv=["--xacro-arg", "f:=/etc/passwd"]),
    Case("include_abs_filename", robot("<xacro:include filename=\"${xacro.abs_filename('/etc/hostname')}\"/>"),
         f"(/etc/hostname {OUTSIDE}"),
    Case("include_big", robot('<xacro:include filename="big.xacro"/>'), "line 3: xacro expansion refused "
         "(big.xacro is larger than 16 MiB)"),
    Case("package_without_path", "@pkg", f"{FILE_REFUSED} (", base="world", tip="tool0"),
    Case("xacro_path_missing", robot(""), "--xacro-path @ROOT@/nowhere: no such folder",
         argv=["--xacro-path", "@ROOT@/nowhere"]),
    Case("xxe_entity", '<?xml version="1.0"?>\n<!DOCTYPE robot [<!ENTITY x SYSTEM "file://@SECRET@/secret.yaml">]>\n'
         f'<robot {NS} name="r"><link name="&x;"/>{CHAIN}</robot>\n',
         "line 2: xacro expansion refused (XML entity declarations (<!ENTITY>) are not allowed"),
    # --- the environment --------------------------------------------------------------------------------------
    Case("env_home", robot('<link name="$(env HOME)"/>'),
         "line 3: $(env HOME) refused (xacro files may not read environment variables; pass the value with "
         "--xacro-arg HOME:=VALUE)"),
    Case("env_secret", robot('<link name="$(env IKP_SECRET)"/>'), "$(env IKP_SECRET) refused"),
    Case("optenv_secret", robot('<link name="$(optenv IKP_SECRET fallback)"/>'),
         "line 3: $(optenv IKP_SECRET fallback) refused (xacro files may not read environment variables; pass the "
         "value with --xacro-arg IKP_SECRET:=VALUE)"),
    Case("optenv_bare", robot('<link name="$(optenv IKP_SECRET)"/>'), "$(optenv IKP_SECRET) refused"),
    Case("eval_name_not_env", robot('<link name="$(eval IKP_SECRET)"/>'), "name 'IKP_SECRET' is not defined"),
    Case("optenv_prop", robot('<xacro:property name="h" value="$(optenv PATH /bin)"/><link name="${h}"/>'),
         "line 3: $(optenv PATH /bin) refused"),
    Case("xacro_arg_secret", robot("<link name=\"${xacro.arg('IKP_SECRET')}\"/>"),
         "undefined xacro argument 'IKP_SECRET'"),
    Case("arg_undefined", robot('<link name="$(arg IKP_SECRET)"/>'), "undefined substitution argument IKP_SECRET"),
    Case("env_given", robot('<link name="l_$(env IKP_SECRET)"/><joint name="j_$(optenv IKP_SECRET x)" '
                            'type="revolute"><parent link="tip"/><child link="l_$(env IKP_SECRET)"/>'
                            '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'),
         None, argv=["--xacro-arg", "IKP_SECRET:=given_by_user"], tip="l_given_by_user", written="j_given_by_user"),
    # --- ROS-only substitutions -------------------------------------------------------------------------------
    Case("ros_find", robot('<xacro:include filename="$(find my_description)/urdf/arm.xacro"/>'),
         "xacro cannot expand the file (line 3: $(find my_description) needs ROS"),
    Case("ros_anon", robot('<link name="$(anon node)"/>'), "$(anon node) needs ROS"),
    Case("cwd", robot('<link name="$(cwd)"/>'), "$(cwd) is not supported"),
    Case("unknown_subst", robot('<link name="$(shell ls)"/>'), "unknown substitution $(shell ls)"),
    # --- hangs and bombs --------------------------------------------------------------------------------------
    Case("doubling_2_22", doubling(22, '<link name="${n}"/>'), "more than 20,000 elements expanded"),
    Case("doubling_2_40", doubling(40, '<link name="${n}"/>'), "more than 20,000 elements expanded"),
    Case("pow_tower", robot('<link name="${9**9**9}"/>'), "line 3: xacro expression refused (** with an exponent"),
    Case("string_bomb", robot("<link name=\"${'a'*10**10}\"/>"), "(a string longer than 100,000 items"),
    Case("list_bomb", robot('<link name="${[0]*10**9}"/>'), "(a list longer than 100,000 items"),
    Case("huge_range", robot('<link name="${len(range(10**12))}"/>'), "(range() of more than 100,000 items"),
    Case("big_int", robot('<link name="${2**64*2**64}"/>'), "(integer beyond 2**64"),
    Case("float_overflow", robot('<link name="${10.0**400}"/>'), "(a number beyond 1e308"),
    Case("factorial", robot('<link name="${factorial(10**6)}"/>'), "(factorial() of more than 20"),
    Case("comb", robot('<link name="${math.comb(10**6, 5000)}"/>'), "(comb() of more than 1000"),
    Case("shift", robot('<link name="${1 &lt;&lt; 10**6}"/>'), "(integer beyond 2**64"),
    Case("format_width", robot("<link name=\"${'%0999999d' % 1}\"/>"), "width or precision above 1000"),
    Case("nested_str", robot('<link name="${str([[0]*100000]*100000)}"/>'),
         "(a value larger than 1,000,000 items and characters"),
    Case("nested_compare", robot('<link name="${[[0]*99999]*99999 == [[0]*99999]*99999}"/>'),
         "(a value larger than 1,000,000"),
    Case("int_digits", robot("<link name=\"${int('9'*5000)}\"/>"), "(int() of a string longer than 100"),
    Case("deep_parens", robot('<link name="${' + "(" * 300 + "1" + ")" * 300 + '}"/>'), "nested more than 200 levels"),
    Case("deep_unary", robot('<link name="${' + "-" * 5000 + '1}"/>'), "nested more than 200 levels"),
    Case("long_expression", robot('<link name="${' + "+".join(["1"] * 6000) + '}"/>'),
         "(an expression longer than 10,000 characters"),
    Case("recursive_macro", robot('<xacro:macro name="r"><xacro:r/></xacro:macro><xacro:r/>'), "nested too deeply"),
    Case("include_self", robot('<xacro:include filename="include_self.xacro"/>'), "xacro cannot expand"),
    Case("circular_props", robot('<xacro:property name="a" value="${b}"/><xacro:property name="b" value="${a}"/>'
                                 '<link name="${a}"/>'), "circular variable definition"),
    Case("many_includes", robot("\n".join(['<xacro:include filename="inc/tiny.xacro"/>'] * 1100)),
         "more than 1000 files included"),
    Case("deep_xml", robot("<a>" * 5000 + "</a>" * 5000), "nested too deeply"),
    Case("billion_laughs", LAUGHS, "line 3: xacro expansion refused (XML entity declarations"),
    Case("billion_laughs_utf16", "@laughs16", "line 3: xacro expansion refused (XML entity declarations"),
    Case("billion_laughs_include", robot('<xacro:include filename="inc/laughs.xacro"/>'),
         "inc/laughs.xacro, line 3: xacro expansion refused (XML entity declarations"),
    Case("yaml_alias_bomb", robot("<link name=\"${len(xacro.load_yaml('bomb.yaml'))}\"/>"),
         "bomb.yaml expands to more than 4,000,000 values"),
    Case("big_input", "@big", "xacro expansion refused (big.xacro is larger than 16 MiB)"),
    Case("redos_params", robot('<xacro:macro name="m" params="a:=' + "x" * 40 + "'" + '"><link name="q"/>'
                               '</xacro:macro><xacro:m/>'), "xacro cannot expand the file"),
    Case("cpu_within_bounds", doubling(9, '<link name="' + "${sorted(range(100000))[0]}" * 20 + '${n}"/>'),
         "xacro expansion stopped after 3 s (time limit", time_limit=3.0),
    Case("memory", doubling(10, '<link name="' + "${s}" * 10 + '${n}"/>',
                            prefix="<xacro:property name=\"s\" value=\"${'a'*100000}\"/>\n"),
         "passed the 768 MiB memory limit"),
    # --- plain errors, still one line -------------------------------------------------------------------------
    Case("syntax_error", robot('<link name="${1 +}"/>'), "xacro cannot expand the file (line 3: invalid expression "
         "syntax"),
    Case("undefined_property", robot('<link name="${nope}"/>'), "name 'nope' is not defined"),
    Case("division_by_zero", robot('<link name="${1/0}"/>'), "xacro cannot expand the file (line 3: division by zero"),
    Case("unknown_macro", robot("<xacro:nope/>"), "unknown macro name: xacro:nope"),
    Case("broken_xml", f'<robot {NS} name="r"><link name="a"></robot>', "not valid XML: mismatched tag"),
    Case("fatal", robot("<link name=\"${xacro.fatal('boom')}\"/>"), "boom"),
    Case("yaml_not_string", robot('<link name="${xacro.load_yaml(1)}"/>'), "load_yaml() takes a file name"),
    # --- benign: must still work ------------------------------------------------------------------------------
    Case("ok_repo_ur5e", "@ur5e", None, argv=["--xacro-arg", "prefix:=left_"], base="left_base_link",
         tip="left_tool0", written="left_shoulder_pan_joint"),
    Case("ok_package", "@pkg", None, argv=["--xacro-path", "@ROBOT@/pkg"], base="world", tip="tool0",
         written="shoulder_lift_joint"),
    Case("ok_properties", robot('<xacro:property name="a" value="${radians(90)}"/>'
                                '<xacro:property name="v" value="${[0.5, 2, 3]}"/>'
                                '<link name="l2"/><joint name="j2" type="revolute"><parent link="tip"/>'
                                '<child link="l2"/><origin xyz="${v[0]} 0 0" rpy="${a} 0 ${-pi/4}"/>'
                                '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'),
         None, tip="l2", written="-pi/4"),
    Case("ok_expressions", "@expressions", None, tip="l3", written="j_3_link"),
    Case("ok_include_ns_glob", "@includes", None, tip="l_glob", written="j_from_ns"),
    Case("ok_env_given", "@envgiven", None, argv=["--xacro-arg", "HOME:=/nowhere", "--xacro-arg", "IKP_SECRET:=mine"],
         tip="l_mine", written="j_mine"),
    Case("ok_dynamic", "@dynamic", None, tip="l_called", written="j_called"),
    Case("ok_doctype_system", '<?xml version="1.0"?>\n<!DOCTYPE robot SYSTEM "file://@SECRET@/secret.yaml">\n'
         f'<robot {NS} name="r">{CHAIN}</robot>\n', None),
    Case("ok_plain_urdf", f'<?xml version="1.0"?>\n<robot name="r">{CHAIN}</robot>\n', None, suffix=".urdf"),
]

# a xacro file with an expression for each kind of thing the evaluator admits
EXPRESSIONS = robot("""<xacro:property name="type" value="revolute"/>
<xacro:property name="prefix" value="j_"/>
<xacro:property name="lst" value="${[0.1, 0.2, 0.3]}"/>
<xacro:property name="d" value="${dict([('a', 1), ('b', 2)])}"/>
<xacro:macro name="joint" params="name parent child type:=^ xyz:='0 0 0' *origin">
  <link name="${child}"/>
  <joint name="${prefix}${name}" type="${type}">
    <parent link="${parent}"/><child link="${child}"/>
    <xacro:insert_block name="origin"/>
    <axis xyz="0 0 1"/>
    <limit lower="${-pi}" upper="${pi if type == 'revolute' else 1}" effort="${max(1, 2, 3)}"
           velocity="${round(3.14159, 2)}"/>
  </joint>
</xacro:macro>
<xacro:joint name="1" parent="tip" child="l1">
  <origin xyz="${lst[0]} ${sqrt(2) / 2} ${abs(-0.1)}" rpy="${radians(90)} ${pi / 2} ${atan2(1, 1)}"/>
</xacro:joint>
<xacro:joint name="2" parent="l1" child="l2">
  <origin xyz="${hypot(3, 4) / 10} ${fabs(-0.2)} ${floor(1.7) / 10}"
          rpy="${degrees(0.1) / 100} ${log(e)} ${exp(0) - 1}"/>
</xacro:joint>
<xacro:joint name="${'%d_link' % 3}" parent="l2" child="l3">
  <origin xyz="${d['b'] / 10} ${len(lst) / 10} ${int('3') / 10}"
          rpy="${1 if 'a' in d else 0} ${min(lst)} ${pow(2, 2) / 8}"/>
</xacro:joint>
<xacro:if value="${type == 'revolute' and not False}"><link name="if_ok"/></xacro:if>
<xacro:unless value="${1 &lt; 2}"><link name="never"/></xacro:unless>
<link name="${str(ceil(0.5)) + '_' + str(bool(1))}"/>
<link name="$(eval 'ev' + 'x')"/>
<link name="${sum([1, 2]) == 3 and sorted([3, 1])[0] == 1}"/>
<link name="pi_${math.pi > 3}"/>""")

INCLUDES = robot("""<xacro:include filename="inc/parts.xacro" ns="parts"/>
<xacro:include filename="inc/glob/*.xacro"/>
<xacro:parts.arm_link name="from_ns" size="${parts.size}"/>
<xacro:glob_joint/>""")

ENVGIVEN = robot("""<xacro:property name="home" value="$(env HOME)"/>
<xacro:property name="who" value="$(optenv IKP_SECRET nobody)"/>
<link name="l_${who}"/>
<joint name="j_${who}" type="revolute"><parent link="tip"/><child link="l_${who}"/>
<origin xyz="0 0 ${len(home) / 100}"/><axis xyz="0 0 1"/>
<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>""")

DYNAMIC = robot("""<xacro:macro name="add_joint" params="n">
<link name="l_${n}"/>
<joint name="j_${n}" type="revolute"><parent link="tip"/><child link="l_${n}"/><axis xyz="0 0 1"/>
<xacro:element xacro:name="limit" lower="-1" upper="1"><xacro:attribute name="effort" value="${str(2 * 0.5)}"/>
<xacro:attribute name="velocity" value="1"/></xacro:element></joint>
</xacro:macro>
<xacro:property name="which" value="add_joint"/>
<xacro:call macro="${which}" n="called"/>""")

PKG_MAIN = """<?xml version="1.0"?>
<robot xmlns:xacro="http://wiki.ros.org/xacro" name="arm6">
  <xacro:arg name="arm_type" default="arm6"/>
  <xacro:arg name="kinematics_params" default="$(dirname)/../config/$(arg arm_type)/kinematics.yaml"/>
  <xacro:arg name="safety" default="false"/>
  <xacro:include filename="inc/arm_macro.xacro"/>
  <link name="world"/>
  <xacro:arm prefix="" parent="world" kinematics_file="$(arg kinematics_params)" safety="$(arg safety)">
    <origin xyz="0 0 0" rpy="0 0 0"/>
  </xacro:arm>
</robot>
"""

PKG_MACRO = """<?xml version="1.0"?>
<robot xmlns:xacro="http://wiki.ros.org/xacro">
  <xacro:include filename="common.xacro"/>
  <xacro:macro name="arm" params="prefix parent kinematics_file safety:=false *origin">
    <xacro:property name="config" value="${xacro.load_yaml(kinematics_file)}"/>
    <xacro:property name="kin" value="${config['kinematics']}"/>
    <xacro:property name="lim" value="${config.limits.position}"/>
    <link name="${prefix}base_link"/>
    <joint name="${prefix}base_joint" type="fixed">
      <parent link="${parent}"/><child link="${prefix}base_link"/>
      <xacro:insert_block name="origin"/>
    </joint>
    <xacro:joint_link name="shoulder_pan_joint" parent="${prefix}base_link" child="${prefix}shoulder_link"
                      k="${kin.shoulder}" lim="${radians(lim)}"/>
    <xacro:joint_link name="shoulder_lift_joint" parent="${prefix}shoulder_link" child="${prefix}upper_arm_link"
                      k="${kin['upper_arm']}" lim="${radians(lim)}"/>
    <xacro:joint_link name="elbow_joint" parent="${prefix}upper_arm_link" child="${prefix}forearm_link"
                      k="${kin.forearm}" lim="${pi}"/>
    <xacro:if value="${safety}">
      <link name="${prefix}safety_marker"/>
    </xacro:if>
    <xacro:unless value="${safety}">
      <link name="${prefix}tool0"/>
      <joint name="${prefix}flange-tool0" type="fixed">
        <parent link="${prefix}forearm_link"/><child link="${prefix}tool0"/>
        <origin xyz="0 0 0" rpy="${pi/2} 0 ${pi/2}"/>
      </joint>
    </xacro:unless>
  </xacro:macro>
</robot>
"""

PKG_COMMON = """<?xml version="1.0"?>
<robot xmlns:xacro="http://wiki.ros.org/xacro">
  <xacro:macro name="joint_link" params="name parent child k lim">
    <link name="${child}"/>
    <joint name="${name}" type="revolute">
      <parent link="${parent}"/><child link="${child}"/>
      <origin xyz="${k.x} ${k['y']} ${k.z}" rpy="${k.roll} ${k.pitch} ${k.yaw}"/>
      <axis xyz="0 0 1"/>
      <limit lower="${-lim}" upper="${lim}" effort="150" velocity="3.14"/>
    </joint>
  </xacro:macro>
</robot>
"""

PKG_YAML = """kinematics:
  shoulder: {x: 0, y: 0, z: 0.1625, roll: 0, pitch: 0, yaw: 0}
  upper_arm: {x: 0, y: 0, z: 0, roll: !degrees 90, pitch: 0, yaw: 0}
  forearm: {x: -0.425, y: 0, z: 0, roll: 0, pitch: 0, yaw: 0}
limits:
  position: 360
"""


class World:
    """The folders of the corpus: ``robot/`` (the inputs), ``secret/`` (outside), the marker path."""

    def __init__(self, root: Path):
        self.root = root
        self.robot = root / "robot"
        self.secret = root / "secret"
        self.marker = root / "marker"
        self.out = root / "out"

    def fill(self):
        r, s = self.robot, self.secret
        for d in (r, s, r / "inc" / "glob", self.out, r / "pkg" / "urdf" / "inc", r / "pkg" / "config" / "arm6"):
            d.mkdir(parents=True, exist_ok=True)
        (s / "secret.yaml").write_text(f"value: {SENTINEL}\n")
        (s / "secret.xacro").write_text(f'<robot {NS} name="s"><link name="{SENTINEL}"/></robot>\n')
        (r / "link_out.yaml").symlink_to(s / "secret.yaml")
        (r / "link_out.xacro").symlink_to(s / "secret.xacro")
        os.mkfifo(r / "fifo.yaml")
        os.mkfifo(r / "fifo.xacro")
        with open(r / "big.xacro", "wb") as f:  # 20 MiB, sparse
            f.write(f"<robot {NS}>".encode())
            f.truncate(20 << 20)
        (r / "evil_units.yaml").write_text("angle: !degrees __import__('os').system('touch @MARKER@')\n"
                                           .replace("@MARKER@", str(self.marker)))
        (r / "pytag.yaml").write_text(f"x: !!python/object/apply:os.system ['touch {self.marker}']\n")
        (r / "bomb.yaml").write_text("a: &a [x, x, x, x, x, x, x, x, x, x]\n"
                                     + "".join(f"{chr(98 + i)}: &{chr(98 + i)} [" + ", ".join([f"*{chr(97 + i)}"] * 10)
                                               + "]\n" for i in range(8)))
        (r / "inc" / "evil_macro.xacro").write_text(
            f'<robot {NS}>\n<xacro:macro name="evil"><link name="${{{ATTR_SYS}}}"/></xacro:macro>\n</robot>\n'
            .replace("@MARKER@", str(self.marker)))
        (r / "inc" / "tiny.xacro").write_text(f"<robot {NS}/>\n")
        (r / "inc" / "laughs.xacro").write_text(LAUGHS)
        (r / "inc" / "parts.xacro").write_text(
            f'<robot {NS}>\n<xacro:property name="size" value="${{0.1 * 2}}"/>\n'
            '<xacro:macro name="arm_link" params="name size"><link name="l_${name}"/>'
            '<joint name="j_${name}" type="revolute"><parent link="tip"/><child link="l_${name}"/>'
            '<origin xyz="0 0 ${size}"/><axis xyz="0 0 1"/>'
            '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></xacro:macro>\n</robot>\n')
        (r / "inc" / "glob" / "a.xacro").write_text(
            f'<robot {NS}><xacro:macro name="glob_joint"><link name="l_glob"/>'
            '<joint name="j_from_glob" type="fixed"><parent link="l_from_ns"/><child link="l_glob"/></joint>'
            "</xacro:macro></robot>\n")
        pkg = r / "pkg"
        (pkg / "urdf" / "arm.urdf.xacro").write_text(PKG_MAIN)
        (pkg / "urdf" / "inc" / "arm_macro.xacro").write_text(PKG_MACRO)
        (pkg / "urdf" / "inc" / "common.xacro").write_text(PKG_COMMON)
        (pkg / "config" / "arm6" / "kinematics.yaml").write_text(PKG_YAML)
        return self

    def sub(self, s: str) -> str:
        return (s.replace("@MARKER@", str(self.marker)).replace("@SECRET@", str(self.secret))
                .replace("@ROBOT@", str(self.robot)).replace("@ROOT@", str(self.root)))

    def input_for(self, case: Case) -> Path:
        special = {"@ur5e": ROOT / "tests" / "data" / "xacro" / "my_ur5e.urdf.xacro",
                   "@pkg": self.robot / "pkg" / "urdf" / "arm.urdf.xacro", "@big": self.robot / "big.xacro"}
        if case.text in special:
            return special[case.text]
        if case.text == "@laughs16":  # the same bomb in UTF-16: no "<!ENTITY" among the bytes
            path = self.robot / f"{case.name}{case.suffix}"
            path.write_bytes(LAUGHS.replace('version="1.0"', 'version="1.0" encoding="UTF-16"').encode("utf-16"))
            return path
        text = {"@expressions": EXPRESSIONS, "@includes": INCLUDES, "@envgiven": ENVGIVEN,
                "@dynamic": DYNAMIC}.get(case.text, case.text)
        path = self.robot / f"{case.name}{case.suffix}"
        path.write_text(self.sub(text))
        return path


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    w = World(tmp_path_factory.mktemp("hostile_xacro")).fill()
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("IKP_SECRET", ENV_SENTINEL)
        yield w


def _argv(world: World, case: Case, src: Path, out: Path) -> list[str]:
    return ["import-urdf", str(src), "--base", case.base, "--tip", case.tip, "--out", str(out),
            *[world.sub(a) for a in case.argv]]


def _no_leak(world: World, *texts: str) -> None:
    for t in texts:
        assert SENTINEL not in t and ENV_SENTINEL not in t, t[-2000:]
    assert not world.marker.exists(), "a payload ran: the marker file exists"


def test_corpus_size():
    assert len(CASES) >= 70
    assert len({c.name for c in CASES}) == len(CASES)
    assert sum(c.expect is None for c in CASES) >= 8


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_case(case, world, capsys, monkeypatch):
    from pipeline import xacro_sandbox
    from pipeline.cli import main

    if case.time_limit is not None:
        monkeypatch.setattr(xacro_sandbox, "TIME_LIMIT_S", case.time_limit)
    src = world.input_for(case)
    out = world.out / case.name / f"{case.name}.yaml"
    before = sorted(p.name for p in world.robot.iterdir())
    t0 = time.monotonic()
    rc = main(_argv(world, case, src, out))
    elapsed = time.monotonic() - t0
    captured = capsys.readouterr()
    _no_leak(world, captured.out, captured.err)
    assert "Traceback" not in captured.out + captured.err
    assert elapsed < 10, f"{elapsed:.1f} s"
    assert sorted(p.name for p in world.robot.iterdir()) == before, "the expansion wrote into the input folder"
    if case.expect is None:
        assert rc == 0, captured.err
        text = out.read_text()
        _no_leak(world, text)
        if case.written:
            assert case.written in text, text
        return
    assert rc == 2, captured.out
    lines = captured.err.rstrip("\n").split("\n")
    assert len(lines) == 1, captured.err
    line = lines[0]
    assert line.startswith(f"error: URDFImportError: {src}: "), line
    assert world.sub(case.expect) in line, line
    assert not out.exists()


def test_package_outside_folder_names_the_yaml_file(world, capsys):
    """Without --xacro-path the package's config folder is outside: the line names the YAML file and the
    line of the include that loads it, and says how to allow it."""
    from pipeline.cli import main

    src = world.robot / "pkg" / "urdf" / "arm.urdf.xacro"
    assert main(["import-urdf", str(src), "--base", "world", "--tip", "tool0", "--out",
                 str(world.out / "pkg_no_path" / "arm.yaml")]) == 2
    line = capsys.readouterr().err.strip()
    assert (f"{src}: inc/arm_macro.xacro, line 5: xacro file access refused "
            f"({world.robot}/pkg/config/arm6/kinematics.yaml {OUTSIDE}") in line, line
    assert "name its folder with --xacro-path DIR" in line


def test_benign_package_matches_unsandboxed_xacro(world):
    """The sandboxed expansion of the package equals what the xacro package itself writes."""
    import xacro

    from pipeline.urdf import expand_xacro

    src = world.robot / "pkg" / "urdf" / "arm.urdf.xacro"
    ours = expand_xacro(src, {"safety": "true"}, [world.robot / "pkg"])
    xacro.substitution_args_context["filename"] = str(src)  # what its own CLI gives $(dirname)
    try:
        ref = xacro.process_file(str(src), mappings={"safety": "true"}).toprettyxml(indent="  ")
    finally:
        xacro.substitution_args_context.pop("filename", None)
    assert ours == ref
    assert "safety_marker" in ours and "tool0" not in ours


def test_errors_name_the_users_file_not_a_temporary_one(world):
    """A URDF error in the expanded text names the xacro file (the text is parsed from memory)."""
    from pipeline.urdf import URDFImportError, import_urdf

    src = world.robot / "dup_link.xacro"
    src.write_text(robot('<link name="base"/>'))
    with pytest.raises(URDFImportError) as info:
        import_urdf(src, "base", "tip")
    msg = str(info.value)
    assert msg.startswith(f"{src} (expanded by xacro): <link> defined twice (link 'base')"), msg
    assert "/tmp" not in msg.replace(str(src), "") and "\n" not in msg


# --- real processes: peak RSS of the process and its children ---------------------------------------------------

# runs in a small fresh interpreter: runs `python -m pipeline ARGV`, then writes "exit-code max-RSS-KiB" of
# its children (the pipeline process and the sandbox it waited for) to argv[1]
_LAUNCHER = """
import resource, subprocess, sys
proc = subprocess.run([sys.executable, "-m", "pipeline", *sys.argv[2:]])
with open(sys.argv[1], "w") as f:
    f.write(f"{proc.returncode} {resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss}")
"""

PROCESS_CASES = ["prop_walk_sys", "env_secret", "include_dotdot", "memory", "doubling_2_40", "ok_repo_ur5e"]


@pytest.mark.parametrize("name", PROCESS_CASES)
def test_as_process(name, world, tmp_path):
    case = next(c for c in CASES if c.name == name)
    src = world.input_for(case)
    out = world.out / f"proc_{name}" / f"proc_{name}.yaml"
    res = tmp_path / "res.txt"
    env = {**os.environ, "IKP_SECRET": ENV_SENTINEL}
    t0 = time.monotonic()
    proc = subprocess.run([sys.executable, "-c", _LAUNCHER, str(res), *_argv(world, case, src, out)], cwd=ROOT,
                          capture_output=True, text=True, timeout=60, env=env)
    elapsed = time.monotonic() - t0
    code, rss_kib = (int(v) for v in res.read_text().split())
    _no_leak(world, proc.stdout, proc.stderr)
    assert "Traceback" not in proc.stderr
    assert rss_kib / 1024 < 1024, f"peak RSS {rss_kib / 1024:.0f} MiB"
    assert elapsed < 20, f"{elapsed:.1f} s"  # start-up (about 1.5 s here) + the 8 s limit at most
    if case.expect is None:
        assert code == 0, proc.stderr
        _no_leak(world, out.read_text())
        return
    assert code == 2
    (line,) = proc.stderr.strip().split("\n")
    assert line.startswith(f"error: URDFImportError: {src}: ") and world.sub(case.expect) in line, line


def test_time_limit_in_a_process(world, tmp_path):
    """The default 8 s wall-time limit, in a real process: a file whose expansion stays within every
    bound of the evaluator but would run for minutes is stopped."""
    case = next(c for c in CASES if c.name == "cpu_within_bounds")
    src = world.input_for(case)
    out = tmp_path / "cpu.yaml"
    t0 = time.monotonic()
    proc = subprocess.run([sys.executable, "-m", "pipeline", *_argv(world, case, src, out)], cwd=ROOT,
                          capture_output=True, text=True, timeout=60)
    elapsed = time.monotonic() - t0
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    (line,) = proc.stderr.strip().split("\n")
    assert f"{src}: xacro expansion stopped after 8 s (time limit" in line, line
    assert elapsed < 30, elapsed  # 8 s of expansion plus the interpreter's start-up (seconds on a loaded machine)


def test_audit_hook_and_limits_in_the_child(world):
    """Defence in depth: in the expanding process, after its imports, the audit hook refuses what the
    evaluator should never let a file reach (processes, imports, exec, environment changes, writes,
    reads and listings outside the allowed folders); the limits are set; the environment is empty."""
    from pipeline.xacro_sandbox import MEMORY_MIB, self_check

    inside = world.robot / "inc" / "tiny.xacro"
    got = self_check(world.robot, world.marker, world.secret / "secret.yaml", inside)
    assert got.pop("open inside") == "allowed"
    limits, environ = got.pop("limits"), got.pop("environ")
    assert got and all(v == "refused" for v in got.values()), got
    assert limits["RLIMIT_AS"][0] == MEMORY_MIB << 20 and limits["RLIMIT_FSIZE"] == [0, 0]
    assert 0 < limits["RLIMIT_CPU"][0] <= 10 and limits["RLIMIT_NOFILE"][0] <= 16
    assert "IKP_SECRET" not in environ and "HOME" not in environ and "PATH" not in environ, environ
    assert not world.marker.exists() and inside.exists()


# --- the evaluator alone --------------------------------------------------------------------------------------


@pytest.mark.parametrize("expr, value", [
    ("pi / 2", 1.5707963267948966), ("radians(90)", 1.5707963267948966), ("2 ** 10", 1024), ("2 ** -1", 0.5),
    ("min([3, 1, 2])", 1), ("'%s_%d' % ('a', 3)", "a_3"), ("[1, 2, 3][1:]", [2, 3]), ("1 if 2 > 1 else 0", 1),
    ("math.sqrt(16)", 4.0), ("python.len('abc')", 3), ("not (1 == 2) and 'a' in 'abc'", True),
])
def test_evaluator_admits(expr, value):
    from pipeline import safe_expr

    assert safe_expr.evaluate(expr, safe_expr.symbols().__getitem__) == value


def test_no_secret_anywhere(world):
    """After the corpus: the sentinels are in no file but their own, and the marker was never made."""
    assert not world.marker.exists()
    for p in world.root.rglob("*"):
        if p.is_file() and not p.is_symlink() and p.parent != world.secret and p.stat().st_size < (1 << 20):
            text = p.read_text(errors="replace")
            assert SENTINEL not in text and ENV_SENTINEL not in text, p
