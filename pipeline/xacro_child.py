"""The xacro sandbox's child process (:mod:`pipeline.xacro_sandbox` runs this file by path:
``python -I -B .../xacro_child.py``, request as JSON on stdin).

Standard library + xacro + yaml only; :mod:`pipeline.xacro_box` (the limits and the :class:`Sandbox`) and
:mod:`pipeline.safe_expr` are loaded by path, the package is never imported. Steps: see
:mod:`pipeline.xacro_sandbox`.
"""

from __future__ import annotations

import os
import sys


class _Sink:
    """A stderr that drops what is written."""

    def write(self, s):
        return len(s)

    def flush(self):
        pass

    def isatty(self):
        return False


def _limits(req: dict, open_files: int) -> None:
    """Set the child's resource limits: address space, CPU time, no file writes, ``open_files``, no core
    dumps, no new processes."""
    import math
    import resource
    import signal

    def setlim(which, soft, hard=None):
        hard = soft if hard is None else hard
        try:
            _, cur_hard = resource.getrlimit(which)
            if cur_hard != resource.RLIM_INFINITY:
                soft, hard = min(soft, cur_hard), min(hard, cur_hard)
            resource.setrlimit(which, (soft, hard))
        except (ValueError, OSError):
            pass

    mem = int(req["memory_mib"]) << 20
    setlim(resource.RLIMIT_AS, mem)
    cpu = int(math.ceil(float(req["time_limit"]))) + 1
    setlim(resource.RLIMIT_CPU, cpu, cpu + 1)
    setlim(resource.RLIMIT_FSIZE, 0)
    setlim(resource.RLIMIT_CORE, 0)
    setlim(resource.RLIMIT_NOFILE, open_files)
    if hasattr(resource, "RLIMIT_NPROC"):
        setlim(resource.RLIMIT_NPROC, 0)
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past RLIMIT_FSIZE fails instead of killing


def _self_check(refused: type, paths: dict) -> dict:
    """What the audit hook and the limits do to a few forbidden operations, run after the hook is in place
    (for the tests: ``{"self_check": {"marker": ..., "outside": ..., "inside": ...}}``)."""
    import resource

    def attempt(fn):
        try:
            fn()
        except refused:
            return "refused"
        except BaseException as exc:  # noqa: BLE001
            return f"failed: {type(exc).__name__}"
        return "allowed"

    def fork():
        if os.fork() == 0:
            os._exit(0)

    marker = paths["marker"]
    tries = {
        "os.system": lambda: os.system(f"touch {marker}"),
        "os.posix_spawn": lambda: os.posix_spawn("/bin/touch", ["touch", marker], {}),
        "os.fork": fork,
        "os.execv": lambda: os.execv("/bin/touch", ["touch", marker]),
        "import subprocess": lambda: __import__("subprocess"),
        "socket": lambda: __import__("socket").socket(),
        "import ctypes": lambda: __import__("ctypes"),
        "exec": lambda: exec("1"),
        "os.putenv": lambda: os.putenv("IKP_X", "1"),
        "os.unsetenv": lambda: os.unsetenv("PATH"),
        "open outside": lambda: open(paths["outside"]).close(),
        "open inside for writing": lambda: open(paths["inside"], "a").close(),
        "os.open write": lambda: os.close(os.open(marker, os.O_WRONLY | os.O_CREAT)),
        "os.listdir /": lambda: os.listdir("/"),
        "os.scandir outside": lambda: list(os.scandir(os.path.dirname(paths["outside"]))),
        "os.remove": lambda: os.remove(paths["inside"]),
        "open inside": lambda: open(paths["inside"], "rb").close(),
    }
    result = {name: attempt(fn) for name, fn in tries.items()}
    result["limits"] = {name: resource.getrlimit(getattr(resource, name))
                        for name in ("RLIMIT_AS", "RLIMIT_CPU", "RLIMIT_FSIZE", "RLIMIT_NOFILE")}
    result["environ"] = sorted(os.environ)
    return result


def _write(status: bytes, payload: str) -> None:
    data = status + payload.encode("utf-8", "replace")
    view = memoryview(data)
    while view:
        n = os.write(1, view)
        view = view[n:]


def _load(name: str, filename: str):
    """A sibling file of this one, loaded by path as module ``name`` (the package is never imported)."""
    import importlib.util

    here = os.path.dirname(os.path.abspath(__file__))
    spec = importlib.util.spec_from_file_location(name, os.path.join(here, filename))
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


def _child_main() -> None:
    kit = None
    try:
        import json

        kit = _load("ikp_xacro_box", "xacro_box.py")
        req = json.loads(sys.stdin.buffer.read(1 << 20))
        _limits(req, kit.MAX_OPEN_FILES)
        sys.setrecursionlimit(kit.RECURSION_LIMIT)
        import glob  # noqa: F401  everything the expansion uses, imported before the audit hook refuses imports
        import io  # noqa: F401
        import re  # noqa: F401
        import stat  # noqa: F401
        import xml.dom.expatbuilder  # noqa: F401
        import xml.dom.minidom  # noqa: F401
        import xml.parsers.expat  # noqa: F401
        import xml.sax.saxutils  # noqa: F401

        import yaml
        import xacro
        import xacro.substitution_args

        safe = _load("ikp_safe_expr", "safe_expr.py")
        sys.stderr = _Sink()  # xacro's warnings: not shown (the user gets one line)
        box = kit.Sandbox(req, xacro, yaml, safe)
        box.patch()
    except BaseException as exc:  # noqa: BLE001
        why = kit.one_line(str(exc), 200) if kit else " ".join(str(exc).split())[:200]
        _write(b"ERR\n", f"xacro expansion could not start ({type(exc).__name__}: {why})")
        os._exit(2)
    sys.addaudithook(box.audit)
    if req.get("self_check"):
        ok, payload = True, json.dumps(_self_check(kit.Refused, req["self_check"]))
    else:
        ok, payload = box.run()
    try:
        _write(b"OK\n" if ok else b"ERR\n", payload)
    except MemoryError:
        os._exit(3)
    os._exit(0 if ok else 2)


if __name__ == "__main__":
    _child_main()
