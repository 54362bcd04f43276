"""The import graph of the package: no module imports a layer above its own, and no cycle anywhere.

Every ``import`` statement counts, at module level or inside a function (a lazy import is still a
dependency). Layers, bottom to top (see pipeline/jobs/__init__.py):
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

PKG = Path(__file__).resolve().parent.parent / "pipeline"

# (layer, module-name prefixes); the longest matching prefix decides
LAYERS = [
    (0, ["pipeline", "pipeline.provenance", "pipeline.yamlio", "pipeline.errors", "pipeline.names", "pipeline.catalogue",
         "pipeline.kinematics"]),
    (1, ["pipeline.robots", "pipeline.urdf", "pipeline.mjcf", "pipeline.problems"]),
    (2, ["pipeline.io"]),
    (3, ["pipeline.solvers", "pipeline.settings", "pipeline.runner"]),
    (4, ["pipeline.studies", "pipeline.report"]),
    (5, ["pipeline.jobs"]),
    (6, ["pipeline.cli", "pipeline.__main__"]),
]
NAMES = {0: "base (provenance, yamlio, kinematics)", 1: "robots and problems", 2: "file formats (io)",
         3: "solvers and settings", 4: "studies and report", 5: "jobs", 6: "cli"}


def layer_of(module: str) -> int:
    if module.startswith("pipeline.studies.") and module.endswith(".cli"):
        return 6  # a study's own verbs: command-line layer
    best, layer = -1, None
    for lay, prefixes in LAYERS:
        for p in prefixes:
            if (module == p or module.startswith(p + ".")) and len(p) > best:
                best, layer = len(p), lay
    assert layer is not None, module
    return layer


def modules() -> dict[str, Path]:
    out = {}
    for f in PKG.rglob("*.py"):
        parts = list(f.relative_to(PKG.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = f
    return out


def import_graph() -> dict[str, set[str]]:
    mods = modules()

    def resolve(name: str) -> str | None:
        while name and name not in mods:
            name = name.rpartition(".")[0]
        return name or None

    graph: dict[str, set[str]] = {m: set() for m in mods}
    for m, f in mods.items():
        pkg = m if f.name == "__init__.py" else m.rpartition(".")[0]
        tree = ast.parse(f.read_text(), str(f))
        graph[m] |= {d for d in dynamic_imports(m, tree, mods) if d != m}
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    parts = pkg.split(".")[: len(pkg.split(".")) - node.level + 1]
                    base = ".".join(parts + ([base] if base else []))
                # `from pkg import sub` imports the submodule when there is one, else a name of pkg
                names = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base for a in node.names]
            for n in names:
                if n == "pipeline" or n.startswith("pipeline."):
                    r = resolve(n)
                    if r and r != m:
                        graph[m].add(r)
    return graph


# calls that import a module named by a string
DYNAMIC = {"import_module", "find_spec", "spec_from_file_location", "__import__"}
MODULE_STRING = re.compile(r"^(pipeline(?:\.\w+)+)(?::\w+)?$")


def dynamic_imports(module: str, tree: ast.AST, mods) -> set[str]:
    """The modules ``module`` imports by a string (``importlib.import_module``, ``find_spec``,
    ``spec_from_file_location``, ``__import__``).

    A literal names its module; an f-string names every module matching its literal parts
    (``{__name__}`` is the module's own name); any other argument (a variable) counts as every module
    named by a string constant anywhere in the module (a registry of import strings, say), so no
    import hides behind a name."""
    calls = [n for n in ast.walk(tree) if isinstance(n, ast.Call) and n.args
             and (getattr(n.func, "attr", None) or getattr(n.func, "id", None)) in DYNAMIC]
    out: set[str] = set()
    for call in calls:
        arg = call.args[0]
        strings = [arg] if isinstance(arg, (ast.Constant, ast.JoinedStr)) else \
            [n for n in ast.walk(tree) if isinstance(n, ast.JoinedStr)
             or isinstance(n, ast.Constant) and isinstance(n.value, str)]
        for node in strings:
            out |= _named_modules(module, node, mods)
    return out


def _named_modules(module: str, node: ast.AST, mods) -> set[str]:
    """The package modules a string constant or an f-string names."""
    if isinstance(node, ast.Constant):
        hit = MODULE_STRING.match(node.value) if isinstance(node.value, str) else None
        return {hit.group(1)} & set(mods) if hit else set()
    parts = [re.escape(v.value) if isinstance(v, ast.Constant)
             else re.escape(module) if getattr(v.value, "id", None) == "__name__" else r"\w+"
             for v in node.values]
    if not "".join(parts).startswith("pipeline"):
        return set()
    pattern = re.compile("^" + "".join(parts) + "(?::\\w+)?$")
    return {m for m in mods if pattern.match(m)}


def test_the_walk_follows_import_strings():
    """A module that imports by a string is held to the layers like any other: a planted
    ``importlib.import_module("pipeline.cli")`` in the kinematics is an edge the layer test sees, and
    so are an f-string's modules and a registry of import strings."""
    mods = modules()
    planted = ast.parse('import importlib\nimportlib.import_module("pipeline.cli")\n')
    assert dynamic_imports("pipeline.kinematics.planted", planted, mods) == {"pipeline.cli"}
    fstring = ast.parse('import importlib\nimportlib.import_module(f"pipeline.studies.{x}.cli")\n')
    assert "pipeline.studies.erthal1992.cli" in dynamic_imports("m", fstring, mods)
    registry = ast.parse('import importlib\nREG = ("pipeline.jobs.solve:run",)\n'
                         'def load(ref):\n    return importlib.import_module(ref.partition(":")[0])\n')
    assert dynamic_imports("pipeline.problems", registry, mods) == {"pipeline.jobs.solve"}
    assert layer_of("pipeline.jobs.solve") > layer_of("pipeline.problems")  # so the layer test would fail


def test_no_module_imports_a_layer_above_its_own():
    bad = [f"{m} ({NAMES[layer_of(m)]}) imports {d} ({NAMES[layer_of(d)]})"
           for m, deps in sorted(import_graph().items()) for d in sorted(deps) if layer_of(d) > layer_of(m)]
    assert not bad, "\n".join(bad)


def test_no_import_cycle():
    graph = import_graph()
    index, low, stack, on, cycles = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    assert not cycles, "import cycles: " + "; ".join(" <-> ".join(c) for c in cycles)


def test_the_file_format_layer_imports_nothing_above_robots():
    graph = import_graph()
    for m, deps in graph.items():
        if m.startswith("pipeline.io"):
            assert all(layer_of(d) <= 2 for d in deps), (m, deps)


# ---- inside pipeline.solvers: kernels < core < the method folders, which never import each other ----
SOLVER_LAYERS = {"pipeline.solvers.kernels": 0, "pipeline.solvers.core": 1, "pipeline.solvers.iterative": 2,
                 "pipeline.solvers.closed_form": 2, "pipeline.solvers.peers": 2, "pipeline.solvers": 3}
METHOD_FOLDERS = ("pipeline.solvers.iterative", "pipeline.solvers.closed_form", "pipeline.solvers.peers")


def solver_folder(module: str) -> str | None:
    """The sub-package of ``pipeline.solvers`` a module belongs to (the package itself for its
    ``__init__``), None outside ``pipeline.solvers``."""
    best = None
    for p in SOLVER_LAYERS:
        if (module == p or module.startswith(p + ".")) and (best is None or len(p) > len(best)):
            best = p
    return best


def solver_violations(graph: dict[str, set[str]]) -> list[str]:
    """Imports inside ``pipeline.solvers`` that go up a sub-package layer or sideways between two
    method folders."""
    bad = []
    for m, deps in sorted(graph.items()):
        fm = solver_folder(m)
        if fm is None:
            continue
        for d in sorted(deps):
            fd = solver_folder(d)
            if fd is None or fd == fm:
                continue
            if SOLVER_LAYERS[fd] > SOLVER_LAYERS[fm] or (fm in METHOD_FOLDERS and fd in METHOD_FOLDERS):
                bad.append(f"{m} ({fm}) imports {d} ({fd})")
    return bad


def test_solver_sub_packages_import_down_only_and_never_sideways():
    assert not solver_violations(import_graph()), "\n".join(solver_violations(import_graph()))


def test_a_planted_sideways_import_is_caught():
    """The check fails on a method folder importing another (here: a closed form taking an
    iterative method's helper), and on a kernel importing the core."""
    graph = {k: set(v) for k, v in import_graph().items()}
    graph["pipeline.solvers.closed_form.analytic"].add("pipeline.solvers.iterative.optimizers")
    graph["pipeline.solvers.kernels.kin"].add("pipeline.solvers.core.rule")
    bad = solver_violations(graph)
    assert bad == ["pipeline.solvers.closed_form.analytic (pipeline.solvers.closed_form) imports "
                   "pipeline.solvers.iterative.optimizers (pipeline.solvers.iterative)",
                   "pipeline.solvers.kernels.kin (pipeline.solvers.kernels) imports "
                   "pipeline.solvers.core.rule (pipeline.solvers.core)"], bad


def private_imports(files: dict[str, Path]) -> list[str]:
    """``from X import _name`` (or ``import X._mod``) of another module's private name, anywhere in
    the package: a private name is for its own module (a shared helper gets a public name)."""
    bad = []
    for m, f in sorted(files.items()):
        for node in ast.walk(ast.parse(f.read_text(), str(f))):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("pipeline"):
                for a in node.names:
                    if a.name.startswith("_") and not a.name.startswith("__"):
                        bad.append(f"{m}: from {node.module} import {a.name}")
            elif isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.startswith("pipeline.") and any(p.startswith("_") for p in a.name.split(".")[1:]):
                        bad.append(f"{m}: import {a.name}")
    return bad


# private modules the package imports by name on purpose (kept for a reason each)
PRIVATE_ALLOWED = {
    "pipeline._numba_cache",  # the package's own compile-cache set-up, imported by name (pipeline/__init__.py)
}


def test_no_module_imports_another_modules_private_name():
    bad = [b for b in private_imports(modules()) if not any(part in b for part in PRIVATE_ALLOWED)]
    assert not bad, "\n".join(bad)


def test_a_planted_private_import_is_caught(tmp_path):
    f = tmp_path / "planted.py"
    f.write_text("from pipeline.solvers.closed_form.lines import _helper\nimport pipeline.solvers._old\n")
    assert private_imports({"pipeline.planted": f}) == [
        "pipeline.planted: from pipeline.solvers.closed_form.lines import _helper",
        "pipeline.planted: import pipeline.solvers._old"]


def test_the_walk_sees_lazy_imports():
    """A function-level import counts: the CLI's verbs import the jobs inside their functions."""
    assert "pipeline.jobs.solve" in import_graph()["pipeline.cli"]
