"""Expand a xacro file in a separate, limited process that cannot run code, read the environment, read
outside the folders it is given, write files or hang.

The parent side is :func:`expand` (used by :func:`pipeline.urdf.expand_xacro`): it runs the child's file
by path (``python -I -B .../xacro_child.py``; not ``-m``, which would import the package and its numba
cache set-up) with an empty environment, sends the request (file, ``--xacro-arg`` values,
allowed folders, limits) as JSON on stdin, kills the child after the wall-time limit and reads at most
:data:`MAX_OUTPUT_BYTES` back. It returns the URDF text or raises :class:`SandboxError` with one line.

The child (``pipeline/xacro_child.py``, with the limits and the :class:`~pipeline.xacro_box.Sandbox` of
``pipeline/xacro_box.py``), standard library + xacro + yaml + :mod:`pipeline.safe_expr` only, all three
files loaded by path:

1. sets ``resource`` limits: address space (:data:`MEMORY_MIB`), CPU time, no file writes
   (``RLIMIT_FSIZE`` 0), few open files, no core dumps, no new processes;
2. imports everything it will need, then replaces, in the ``xacro`` module, the expression evaluator
   (``safe_eval`` and ``eval``: :func:`pipeline.safe_expr.evaluate`), the global symbols (the math
   names, a few builtins, ``xacro.load_yaml`` ...), the ``$(...)`` resolver (``eval_extension``:
   ``arg``, ``dirname`` and ``eval`` only; ``env``/``optenv`` only with a ``--xacro-arg`` of that
   name; ``find`` and the other ROS substitutions refused), ``open`` (allowed folders, regular files,
   :data:`MAX_FILE_BYTES`), ``glob``, ``parse`` (no ``<!ENTITY``) and counts elements and includes;
3. installs an audit hook (``sys.addaudithook``) that refuses processes, sockets, ctypes, environment
   changes, imports, ``exec``/``eval`` of code, and opening or listing anything outside the allowed
   folders or not a regular file: a second wall should the first leak;
4. expands the file and writes ``OK\\n<urdf>`` or ``ERR\\n<one line>`` to stdout, then ``os._exit``.
"""

from __future__ import annotations

import os
import sys

from pipeline.xacro_box import (MAX_ELEMENTS, MAX_FILE_BYTES, MAX_INCLUDES, MAX_OPEN_FILES,  # noqa: F401
                                MAX_OUTPUT_BYTES, MAX_READ_BYTES, MAX_YAML_VALUES, RECURSION_LIMIT, ROS_HINT,
                                memory_message, one_line)

TIME_LIMIT_S = 8.0                     # wall time of one expansion (the CPU limit is one second more)
MEMORY_MIB = 768                       # address space of the expanding process


class SandboxError(Exception):
    """The expansion failed or was refused; ``str(exc)`` is one line (without the file name in front)."""


# ---------------------------------------------------------------------------------------------------------------
# parent side

# ---------------------------------------------------------------------------------------------------------------
# parent side


def _fmt_s(x: float) -> str:
    return f"{x:g}"


def expand(path, args: dict | None = None, paths=(), *, time_limit: float = TIME_LIMIT_S,
           memory_mib: int = MEMORY_MIB) -> str:
    """The URDF text of the xacro file ``path``, expanded in a limited child process.

    ``args``: the ``--xacro-arg`` values (also the only values ``$(env X)``/``$(optenv X)`` may take);
    ``paths``: folders, besides the file's own, that the file may include or load YAML from."""
    import signal

    path = os.path.abspath(os.fspath(path))
    request = {
        "file": path,
        "args": {str(k): str(v) for k, v in (args or {}).items()},
        "dirs": [os.path.dirname(path)] + [os.path.abspath(os.fspath(p)) for p in paths],
        "time_limit": float(time_limit),
        "memory_mib": int(memory_mib),
    }
    rc, out, err, timed_out, too_much = _run_child(request, time_limit)
    if timed_out or rc == -signal.SIGXCPU:
        raise SandboxError(f"xacro expansion stopped after {_fmt_s(time_limit)} s (time limit; a file that takes "
                           "longer to expand is refused: a macro or include loop, or a very large expansion?)")
    if too_much:
        raise SandboxError(f"xacro expansion produced more than {MAX_OUTPUT_BYTES >> 20} MiB of URDF "
                           "(output limit)")
    if out.startswith(b"OK\n") and rc == 0:
        try:
            return out[3:].decode("utf-8")
        except UnicodeDecodeError:
            raise SandboxError("xacro expansion produced text that is not UTF-8") from None
    if out.startswith(b"ERR\n"):
        raise SandboxError(one_line(out[4:].decode("utf-8", "replace")))
    if b"MemoryError" in err or b"Cannot allocate memory" in err or b"memory" in err.lower():
        raise SandboxError(memory_message(memory_mib))
    raise SandboxError(f"xacro expansion failed (the expanding process ended with exit status {rc})")


def self_check(folder, marker, outside, inside) -> dict:
    """What the child's audit hook does to forbidden operations (os.system, fork, imports, writes, reads
    outside ``folder`` ...) and the limits and environment it runs with; for the tests."""
    import json

    folder = os.path.abspath(os.fspath(folder))
    request = {"file": os.path.join(folder, "self-check.xacro"), "args": {}, "dirs": [folder],
               "time_limit": TIME_LIMIT_S, "memory_mib": MEMORY_MIB,
               "self_check": {"marker": os.fspath(marker), "outside": os.fspath(outside), "inside": os.fspath(inside)}}
    rc, out, err, timed_out, too_much = _run_child(request, TIME_LIMIT_S)
    if rc != 0 or not out.startswith(b"OK\n"):
        raise SandboxError(f"self-check failed (exit status {rc}): {one_line(out.decode('utf-8', 'replace'))}")
    return json.loads(out[3:])


def _run_child(request: dict, time_limit: float) -> tuple[int, bytes, bytes, bool, bool]:
    """Run this file as the child with ``request`` on stdin: (exit status, stdout, stderr, timed out, output
    past the cap). Empty environment, isolated interpreter, its own session (killed as a group)."""
    import json
    import selectors
    import signal
    import subprocess
    import time

    script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "xacro_child.py")
    start = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-I", "-B", script], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env={}, cwd="/", close_fds=True, start_new_session=True)
    out, err, too_much, timed_out = bytearray(), bytearray(), False, False
    try:
        try:
            proc.stdin.write(json.dumps(request).encode())
            proc.stdin.close()
        except BrokenPipeError:
            pass
        sel = selectors.DefaultSelector()
        sel.register(proc.stdout, selectors.EVENT_READ, out)
        sel.register(proc.stderr, selectors.EVENT_READ, err)
        deadline = start + time_limit
        while sel.get_map():
            left = deadline - time.monotonic()
            if left <= 0:
                timed_out = True
                break
            for key, _ in sel.select(timeout=left):
                chunk = os.read(key.fd, 1 << 16)
                if not chunk:
                    sel.unregister(key.fileobj)
                    continue
                buf = key.data
                if len(buf) < (MAX_OUTPUT_BYTES + 64 if buf is out else 1 << 16):
                    buf += chunk
                if buf is out and len(out) > MAX_OUTPUT_BYTES + 16:
                    too_much = True
            if too_much:
                break
        sel.close()
        if not (timed_out or too_much):
            try:
                proc.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                timed_out = True
    finally:
        if proc.poll() is None:
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                proc.kill()
        proc.wait()
        proc.stdout.close()
        proc.stderr.close()
    return proc.returncode, bytes(out), bytes(err), timed_out, too_much
