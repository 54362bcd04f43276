"""numba's on-disk cache, each kernel keyed on the source it can reach.

numba checks a cached function against its own source file only (modification time and size). A kernel
that inlines a function of another module (the solvers inline the FK check of
:mod:`pipeline.kinematics.fkcheck`, for example) would keep its old machine code after that other module
changed: a checkout or an edit could then run stale code and give other numbers without any error.

So, for the package's own modules, the "source stamp" numba stores beside each cached kernel (and
compares on every load) is a digest of the kernel's module **and every package module it imports**,
directly or through others, at module level or inside a function (:func:`closure_digest`; the import
statements are read with :mod:`ast`, nothing is executed). A changed module recompiles exactly the
kernels that can reach it: editing ``pipeline/studies/``, ``pipeline/report/``, ``pipeline/jobs/`` or the
README recompiles no solver kernel.

The cache lives in ``pipeline/__pycache__/numba/`` (or the user's cache directory where the package is
not writable). A ``NUMBA_CACHE_DIR`` the user set is used as the directory; the stamps are ours either way.
The stamp is installed as a numba cache locator the moment numba is imported (a one-shot import hook),
so that ``import pipeline`` itself does not import numba.
"""

from __future__ import annotations

import ast
import hashlib
import importlib.abc
import importlib.util
import os
import shutil
import sys
from functools import lru_cache
from pathlib import Path

_OURS = "PIPELINE_NUMBA_CACHE_DIR"  # the directory we chose (a NUMBA_CACHE_DIR equal to it is ours, not the user's)
PKG = Path(__file__).resolve().parent
LAYOUT = "v2"  # the cache layout (v1: one directory per digest of the whole package)


def _module_file(name: str) -> Path | None:
    """The source file of package module ``name`` (``pipeline.x.y``), or None."""
    parts = name.split(".")[1:]
    base = PKG.joinpath(*parts) if parts else PKG
    for f in (base.with_suffix(".py"), base / "__init__.py"):
        if f.is_file():
            return f
    return None


@lru_cache(maxsize=None)
def _imports(path: Path) -> tuple[Path, ...]:
    """Package source files ``path`` imports (every ``import`` statement, at any depth of the module)."""
    try:
        tree = ast.parse(path.read_bytes(), str(path))
    except (OSError, SyntaxError, ValueError):
        return ()
    pkg = path.relative_to(PKG.parent).with_suffix("").parts[:-1]  # the package the module sits in
    out = set()
    for node in ast.walk(tree):
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = list(pkg[: len(pkg) - node.level + 1])
                base = ".".join(up + ([base] if base else []))
            names = [base] + [f"{base}.{a.name}" for a in node.names]
        for n in names:
            if n == "pipeline" or n.startswith("pipeline."):
                parts = n.split(".")
                for k in range(len(parts), 0, -1):  # the module itself and each package above it
                    f = _module_file(".".join(parts[:k]))
                    if f is not None:
                        out.add(f)
    out.discard(path)
    return tuple(sorted(out))


def closure(path: Path) -> list[Path]:
    """``path`` and every package source file it can reach through imports, sorted."""
    seen, todo = set(), [Path(path).resolve()]
    while todo:
        f = todo.pop()
        if f in seen:
            continue
        seen.add(f)
        todo.extend(_imports(f))
    return sorted(seen)


@lru_cache(maxsize=None)
def closure_digest(path: Path) -> str:
    """16 hex digits of SHA-1 over the files of :func:`closure` (relative path and bytes); once per file
    and process (numba asks for it at every cached function's decoration)."""
    h = hashlib.sha1()
    for f in closure(path):
        h.update(f.relative_to(PKG).as_posix().encode())
        h.update(b"\0")
        h.update(f.read_bytes())
    return h.hexdigest()[:16]


def _install_locator() -> None:
    """Put the closure-stamped locator first among numba's cache locators (once)."""
    from numba.core import caching

    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl  # the name of numba >= 0.58 / before
    user = getattr(caching, "UserProvidedCacheLocator", None) or caching._UserProvidedCacheLocator
    if any(getattr(c, "_pipeline_closure", False) for c in impl._locator_classes):
        return

    class ClosureStampedLocator(user):
        """numba's locator for a user-given cache directory, with the closure digest as source stamp."""

        _pipeline_closure = True

        def get_source_stamp(self):
            return ("pipeline-closure", closure_digest(Path(self._py_file)))

        @classmethod
        def from_function(cls, py_func, py_file):
            try:
                inside = Path(py_file).resolve().is_relative_to(PKG)
            except (OSError, ValueError):
                inside = False
            return super().from_function(py_func, py_file) if inside else None

    impl._locator_classes.insert(0, ClosureStampedLocator)
    _install_notice()
    _install_compile_clock()
    _find_tbb()


NOTICE_ENV = "PIPELINE_COMPILE_NOTICE"  # "0": no line when a kernel compiles (the test suite sets it)


def _install_notice() -> None:
    """One line on stderr the first time this process compiles a package kernel (a cache miss): what it
    compiles and roughly how long that takes. Nothing when every kernel loads from the cache."""
    from numba.core import event

    class FirstCompile(event.Listener):
        done = False

        def on_start(self, ev):
            if FirstCompile.done or os.environ.get(NOTICE_ENV, "1") == "0":
                return
            fn = getattr(ev.data.get("dispatcher"), "py_func", None)
            module = getattr(fn, "__module__", "") or ""
            if not module.startswith("pipeline."):
                return
            FirstCompile.done = True
            sys.stderr.write(f"ik-pipeline: compiling {module}.{fn.__qualname__} and the kernels it calls (first use "
                             "since an install or a change of their source; about 10-30 s of CPU for one method's "
                             "single call, about a minute more for its batch lanes; then loaded from the cache in "
                             f"{os.environ.get('NUMBA_CACHE_DIR', '?')} in under a second)\n")
            sys.stderr.flush()

        def on_end(self, ev):
            pass

    event.register("numba:compile", FirstCompile())


def _find_tbb() -> None:
    """Let numba find the TBB library of the ``tbb`` wheel (a dependency on x86-64 Linux), so that its default
    threading layer choice (TBB first, then OpenMP, then its own work queue) takes TBB.

    Why TBB: a batch kernel on 2 threads is one parallel region per call. Under OpenMP the region ends at a
    barrier every thread must reach, so on a busy machine a call waits for a descheduled thread: 500
    closed-form goals (1.2 ms of work) took 13 ms at load 3.6 on 2 cores. TBB's region ends when its work
    is done, whoever did it: the same batch took 1.2 ms, as on 1 thread. The wheel puts the library in
    the environment's ``lib`` folder, which the loader does not search, so it is loaded here by its path
    (numba then finds it by name). Nothing happens where it is not installed or where the user chose a
    layer (``NUMBA_THREADING_LAYER``)."""
    if os.environ.get("NUMBA_THREADING_LAYER") or not sys.platform.startswith("linux"):
        return
    import ctypes
    import site

    for base in dict.fromkeys((sys.prefix, sys.base_prefix, site.USER_BASE or "")):
        lib = Path(base) / "lib" / "libtbb.so.12"
        if base and lib.is_file():
            try:
                ctypes.CDLL(str(lib), mode=ctypes.RTLD_GLOBAL)
            except OSError:
                continue
            return


# [ns spent so far in numba's compiler (compiling kernels or loading them from the cache), nesting depth,
# start of the outermost entry]: read by the solvers (:func:`compile_ns`) to leave that time out of a call's times
COMPILE_CLOCK = [0, 0, 0]


def compile_ns() -> int:
    """Nanoseconds this process has spent so far in numba's compiler, compiling kernels or loading them
    from the cache (0 until numba is imported). A call that changed it compiled or loaded something, so
    its measured times are not its own (:meth:`pipeline.solvers.core.driver.Bound.solve`)."""
    return COMPILE_CLOCK[0]


def _install_compile_clock() -> None:
    """Count the time spent holding numba's compiler lock (every compile and every cache load takes it)."""
    from numba.core import event
    import time

    clock = COMPILE_CLOCK

    class CompileClock(event.Listener):
        def on_start(self, ev):
            if clock[1] == 0:
                clock[2] = time.perf_counter_ns()
            clock[1] += 1

        def on_end(self, ev):
            clock[1] -= 1
            if clock[1] == 0:
                clock[0] += time.perf_counter_ns() - clock[2]

    event.register("numba:compiler_lock", CompileClock())


class _AfterNumba(importlib.abc.MetaPathFinder):
    """Runs :func:`_install_locator` right after ``numba`` is first imported, whoever imports it."""

    def find_spec(self, name, path=None, target=None):
        if name != "numba":
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec("numba")
        if spec is None or spec.loader is None:
            return spec
        run = spec.loader.exec_module

        def exec_module(module):
            run(module)
            _install_locator()

        spec.loader.exec_module = exec_module
        return spec


def use_source_keyed_cache() -> None:
    """Point numba's cache at the package's cache directory and stamp its kernels by their closure
    (see the module docstring)."""
    given = os.environ.get("NUMBA_CACHE_DIR")
    if not given or given == os.environ.get(_OURS):
        base = PKG / "__pycache__" / "numba"
        if not os.access(PKG, os.W_OK):
            base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "ik-pipeline" / "numba"
        here = base / LAYOUT
        os.environ["NUMBA_CACHE_DIR"] = os.environ[_OURS] = str(here)
        if base.is_dir():  # caches of an earlier layout (one directory per digest of the whole package)
            for old in base.iterdir():
                if old.name != LAYOUT and old.is_dir():
                    shutil.rmtree(old, ignore_errors=True)
    if "numba" in sys.modules:  # imported before us: its configuration is read already
        sys.modules["numba"].config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]
        _install_locator()
    elif not any(isinstance(f, _AfterNumba) for f in sys.meta_path):
        sys.meta_path.insert(0, _AfterNumba())
