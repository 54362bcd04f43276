"""The child side of the xacro sandbox (:mod:`pipeline.xacro_sandbox`): the limits, and the :class:`Sandbox`
that replaces the evaluator, resolver, file access and parser of the ``xacro`` module and refuses, in an
audit hook, what the expansion must not do.

Standard library only: besides its import by :mod:`pipeline.xacro_sandbox` (for the limits and
:func:`one_line`), the sandbox child (``pipeline/xacro_child.py``) loads this file by path.
"""

from __future__ import annotations

import os

MAX_FILE_BYTES = 16 << 20              # one xacro / YAML file read by the expansion
MAX_READ_BYTES = 64 << 20              # all files read by one expansion
MAX_OUTPUT_BYTES = 64 << 20            # the expanded URDF
MAX_ELEMENTS = 20_000                  # elements expanded, macro bodies counted each time (a UR5e: 280)
MAX_INCLUDES = 1_000                   # files included (the same one counted each time)
MAX_YAML_VALUES = 4_000_000            # items and characters of one YAML file, aliases counted in full
MAX_OPEN_FILES = 16
RECURSION_LIMIT = 3_000
ROS_HINT = ("run `xacro {name} > robot.urdf` in a ROS environment (with that package) and import robot.urdf; "
            "or name the package's folder with --xacro-path and include it by a relative path")


def one_line(text: str, limit: int = 800) -> str:
    """``text`` on one printable line of at most ``limit`` characters (white space folded, ``...`` when cut)."""
    text = "".join(c if c.isprintable() else " " for c in text.replace("\r", " ").replace("\n", " "))
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def memory_message(memory_mib: int) -> str:
    """The one-line error of an expansion that passed the memory limit ``memory_mib`` [MiB]."""
    return (f"xacro expansion passed the {memory_mib} MiB memory limit (a file whose expansion needs more "
            "memory is refused: a macro expansion or a value too large?)")


class Refused(Exception):
    """Refused by the sandbox (not by the evaluator): ``kind`` is file, env, ros, limit, op or syntax."""

    def __init__(self, kind: str, why: str, token: str | None = None):
        super().__init__(why)
        self.kind, self.why, self.token = kind, why, token


_WRITE_FLAGS = os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_TRUNC | os.O_APPEND
# events the hook lets through without looking (all others are refused, some after a look at their path)
_HARMLESS_EVENTS = frozenset({"compile", "builtins.id", "object.__setattr__", "object.__delattr__", "time.sleep",
                              "sys._getframe"})
_PATH_EVENTS = frozenset({"open", "os.listdir", "os.scandir", "glob.glob", "glob.glob/2"})
_EVENT_NAMES = {"os.system": "running a shell command", "subprocess.Popen": "starting a process",
                "os.posix_spawn": "starting a process", "os.fork": "starting a process",
                "os.forkpty": "starting a process", "os.exec": "starting a program", "os.spawn": "starting a process",
                "os.putenv": "changing the environment", "os.unsetenv": "changing the environment",
                "import": "importing a module", "exec": "running Python code", "socket.connect": "network access",
                "socket.bind": "network access", "socket.__new__": "network access",
                "socket.getaddrinfo": "network access", "ctypes.dlopen": "loading native code",
                "ctypes.dlsym": "loading native code", "os.kill": "sending a signal", "os.remove": "removing a file",
                "os.rename": "renaming a file", "os.mkdir": "making a folder"}


class Sandbox:
    def __init__(self, req: dict, xacro, yaml, safe):
        self.xacro, self.yaml, self.safe = xacro, yaml, safe
        self.input = req["file"]
        self.input_dir = os.path.dirname(self.input)
        self.dirs = []
        for d in req["dirs"]:
            real = os.path.realpath(d)
            if real not in self.dirs:
                self.dirs.append(real)
        self.files = {os.path.realpath(self.input)}
        self.user_args = dict(req["args"])
        self.memory_mib = req["memory_mib"]
        self.read: list[tuple[str, bytes]] = []  # (absolute path as opened, bytes) of every file read
        self.bytes_read = 0
        self.stack: list[str] = []  # the texts being evaluated, outermost first
        self.elements = 0
        self.includes = 0
        self.hook_refusal: Refused | None = None
        self.in_hook = False

    # -- files -------------------------------------------------------------------------------------------------

    def shown(self, p: str) -> str:
        """A path as a message shows it: relative to the input's folder when inside it."""
        ap = os.path.abspath(p)
        if ap.startswith(self.input_dir + os.sep):
            return os.path.relpath(ap, self.input_dir)
        return ap

    def allowed(self, real: str) -> bool:
        return real in self.files or any(real == d or real.startswith(d.rstrip(os.sep) + os.sep) for d in self.dirs)

    def _outside(self, p: str) -> Refused:
        folders = ", ".join(self.dirs)
        return Refused("file", f"{self.shown(p)} is outside the folders this xacro file may read ({folders}); "
                        "name its folder with --xacro-path DIR", p)

    def check_read(self, p: str) -> str:
        """The real path of ``p`` if it may be read (allowed folder, a regular file), else Refused."""
        import stat

        real = os.path.realpath(p)
        if not self.allowed(real):
            raise self._outside(p)
        try:
            mode = os.stat(real).st_mode
        except OSError:
            return real  # the open reports it
        if not stat.S_ISREG(mode):
            kind = ("a FIFO" if stat.S_ISFIFO(mode) else "a character device" if stat.S_ISCHR(mode) else
                    "a block device" if stat.S_ISBLK(mode) else "a socket" if stat.S_ISSOCK(mode) else
                    "a folder" if stat.S_ISDIR(mode) else "not a file")
            raise Refused("file", f"{self.shown(p)} is not a regular file ({kind})", p)
        return real

    def read_bytes(self, file) -> bytes:
        import stat

        if not isinstance(file, (str, bytes, os.PathLike)):
            raise Refused("file", f"opening {type(file).__name__} {file!r} is not allowed")
        p = os.path.abspath(os.fsdecode(file))
        real = self.check_read(p)
        try:
            size = os.stat(real).st_size
        except OSError as exc:
            raise FileNotFoundError(exc.errno, exc.strerror, p) from None
        if size > MAX_FILE_BYTES:
            raise Refused("limit", f"{self.shown(p)} is larger than {MAX_FILE_BYTES >> 20} MiB", p)
        fd = os.open(real, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC | getattr(os, "O_NOFOLLOW", 0))
        try:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                raise Refused("file", f"{self.shown(p)} is not a regular file", p)
            chunks, n = [], 0
            while n <= MAX_FILE_BYTES:
                chunk = os.read(fd, 1 << 20)
                if not chunk:
                    break
                chunks.append(chunk)
                n += len(chunk)
        finally:
            os.close(fd)
        data = b"".join(chunks)
        if len(data) > MAX_FILE_BYTES:
            raise Refused("limit", f"{self.shown(p)} is larger than {MAX_FILE_BYTES >> 20} MiB", p)
        self.bytes_read += len(data)
        if self.bytes_read > MAX_READ_BYTES:
            raise Refused("limit", f"the files read pass {MAX_READ_BYTES >> 20} MiB in all", p)
        self.read.append((p, data))
        return data

    def open(self, file, mode="r", *args, **kwargs):
        """xacro's ``open``: reading an allowed regular file (its bytes, in memory); nothing else."""
        import io

        if any(c in str(mode) for c in "wax+"):
            raise Refused("file", "writing files is not allowed", str(file))
        return io.BytesIO(self.read_bytes(file))

    def parse(self, inp, filename=None):
        """xacro's ``parse``: the file read through :meth:`open`, refused if it declares XML entities."""
        import xml.dom.minidom
        import xml.parsers.expat

        xacro = self.xacro
        if inp is None:
            self.includes += 1
            if self.includes > MAX_INCLUDES:
                raise Refused("limit", f"more than {MAX_INCLUDES} files included (an include loop?)")
            try:
                data = self.read_bytes(os.path.join(xacro.root_dir, filename))
            except OSError as e:
                xacro.filestack.pop()
                raise xacro.XacroException(f"{e.strerror or 'cannot read'}: {self.shown(filename)}", exc=e) \
                    from None
            where = os.path.abspath(filename)
            check = xml.parsers.expat.ParserCreate()  # a first pass (any encoding): no entity declarations

            def entity(*args):
                exc = Refused("syntax", "XML entity declarations (<!ENTITY>) are not allowed in xacro files")
                exc._ikp_where = (where, check.CurrentLineNumber)
                raise exc

            check.EntityDeclHandler = entity
            try:
                check.Parse(data, True)
                return xml.dom.minidom.parseString(data)
            except xml.parsers.expat.ExpatError as e:
                e._ikp_where = (where, e.lineno)
                raise
        return xml.dom.minidom.parseString(inp) if isinstance(inp, (str, bytes)) else inp

    def glob(self, pattern: str, recursive: bool = False):
        import glob as _glob

        magic = min((i for i, c in enumerate(pattern) if c in "*?["), default=len(pattern))
        base = os.path.dirname(pattern[:magic]) or "."
        if not self.allowed(os.path.realpath(base)):
            raise self._outside(pattern)
        if "**" in pattern:
            raise Refused("file", "recursive include patterns (**) are not allowed", pattern)
        return sorted(p for p in _glob.glob(pattern) if self.allowed(os.path.realpath(p)))

    # -- expressions -------------------------------------------------------------------------------------------

    def _mark(self, exc: BaseException) -> None:
        if getattr(exc, "_ikp_stack", None) is None:
            try:
                exc._ikp_stack = (list(self.stack), list(self.xacro.filestack or []))
            except Exception:  # noqa: BLE001
                pass

    def safe_eval(self, expr, globals, locals=None):
        text = expr if isinstance(expr, str) else str(expr)
        self.stack.append(text)
        try:
            return self.safe.evaluate(text, globals.__getitem__)
        except BaseException as exc:
            self._mark(exc)
            raise
        finally:
            self.stack.pop()

    def wrap_eval_text(self, orig):
        def eval_text(text, symbols):
            self.stack.append(text if isinstance(text, str) else "")
            try:
                return orig(text, symbols)
            except BaseException as exc:
                self._mark(exc)
                raise
            finally:
                self.stack.pop()
        return eval_text

    def wrap_eval_all(self, orig):
        def eval_all(node, macros, symbols):
            self.elements += 1
            if self.elements > MAX_ELEMENTS:
                raise Refused("limit", f"more than {MAX_ELEMENTS:,} elements expanded; a macro expansion this "
                               "large is refused")
            return orig(node, macros, symbols)
        return eval_all

    def wrap_process_include(self, orig):
        def process_include(elt, macros, symbols, func):
            self.stack.append(elt.getAttribute("filename"))
            try:
                return orig(elt, macros, symbols, func)
            except BaseException as exc:
                self._mark(exc)
                raise
            finally:
                self.stack.pop()
        return process_include

    def load_yaml(self, filename):
        """``xacro.load_yaml``: an allowed YAML file, size-checked (aliases counted in full)."""
        xacro, yaml = self.xacro, self.yaml
        if not isinstance(filename, str):
            raise TypeError("load_yaml() takes a file name")
        path = xacro.abs_filename_spec(filename)
        data = self.read_bytes(path)
        xacro.filestack.append(path)
        try:
            value = yaml.load(data, Loader=yaml.SafeLoader)
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            what = getattr(exc, "problem", None) or type(exc).__name__
            at = f"line {mark.line + 1}: " if mark is not None else ""
            raise xacro.XacroException(f"{self.shown(path)}: not valid YAML ({at}{one_line(str(what), 200)})") \
                from None
        finally:
            xacro.filestack.pop()
        try:
            self.safe._size(value, limit=MAX_YAML_VALUES)
        except self.safe.ExpressionLimit:
            raise Refused("limit", f"{self.shown(path)} expands to more than {MAX_YAML_VALUES:,} values and "
                           "characters (YAML aliases counted in full)", filename) from None
        return xacro.YamlListWrapper.wrap(value)

    def arg(self, name):
        ctx = self.xacro.substitution_args_context.get("arg", {})
        if not isinstance(name, str) or name not in ctx:
            raise NameError(f"undefined xacro argument {name!r}")
        return ctx[name]

    def env(self, name, *default, text=None):
        name = str(name)
        if name in self.user_args:
            return self.user_args[name]
        raise Refused("env", text or f"env({name!r})", name)

    def find(self, *args):
        raise Refused("ros", f"$(find {' '.join(map(str, args))})", "find")

    def tokenize(self, s, sep=",; ", skip_empty=True):
        import re

        if not isinstance(s, str) or not isinstance(sep, str):
            raise TypeError("tokenize() takes strings")
        parts = re.split("[" + "".join(re.escape(c) for c in sep) + "]", s) if sep else [s]
        return [p for p in parts if p] if skip_empty else parts

    def dotify(self, d):
        if not isinstance(d, dict):
            raise TypeError("dotify() takes a dict")
        return self.xacro.YamlDictWrapper(d)

    def fatal(self, *args):
        raise self.xacro.XacroException(" ".join(map(str, args)))

    def global_symbols(self) -> dict:
        safe = self.safe

        def quiet(*args):
            return ""

        def abs_filename(name):
            return self.xacro.abs_filename_spec(str(name))

        # bound methods: one object each (a new one per attribute access would not be the registered one)
        load_yaml, dotify = self.load_yaml, self.dotify
        xns = safe.Namespace(load_yaml=load_yaml, abs_filename=abs_filename, dotify=dotify, arg=self.arg,
                             tokenize=self.tokenize, fatal=self.fatal, message=quiet, warning=quiet, error=quiet,
                             print_location=quiet)
        for fn in xns.values():
            safe.register(fn)
        out = safe.symbols()
        out.update(xacro=xns, load_yaml=load_yaml, abs_filename=abs_filename, dotify=dotify)
        return out

    def eval_extension(self, s):
        """``$(...)``: ``arg``, ``dirname``, ``eval`` (the safe evaluator), ``env``/``optenv`` from
        ``--xacro-arg`` only; ``find`` and other ROS substitutions refused."""
        xacro = self.xacro
        self.stack.append(s)
        try:
            inner = s[2:-1].strip()
            if inner.startswith("eval ") or inner == "eval":
                return str(self.safe.evaluate(inner[4:], self._eval_lookup))
            parts = inner.split()
            cmd, rest = (parts[0], parts[1:]) if parts else ("", [])
            if cmd == "arg" and len(rest) == 1:
                ctx = xacro.substitution_args_context.get("arg", {})
                if rest[0] not in ctx:
                    raise xacro.XacroException(f"undefined substitution argument {rest[0]} (give it with "
                                               f"--xacro-arg {rest[0]}:=VALUE)")
                return ctx[rest[0]]
            if cmd == "dirname" and not rest:
                return os.path.dirname(os.path.abspath(xacro.filestack[-1] if xacro.filestack else self.input))
            if cmd in ("env", "optenv") and rest:
                return self.env(rest[0], text=f"$({inner})")
            if cmd in ("find", "anon", "exec", "package", "param"):
                raise Refused("ros", f"$({inner})", s)
            if cmd == "cwd":
                raise Refused("syntax", "$(cwd) is not supported (it depends on where the import runs); use "
                               "$(dirname)", s)
            raise xacro.XacroException(f"unknown substitution $({inner}) (supported: arg, dirname, eval; "
                                       "env and optenv with --xacro-arg)")
        except BaseException as exc:
            self._mark(exc)
            raise
        finally:
            self.stack.pop()

    def _eval_lookup(self, name):
        funcs = self._eval_funcs
        if name in funcs:
            return funcs[name]
        ctx = self.xacro.substitution_args_context.get("arg", {})
        if name in ctx:
            return self.xacro.substitution_args.convert_value(ctx[name], "auto")
        raise KeyError(name)

    # -- audit hook --------------------------------------------------------------------------------------------

    def audit(self, event: str, args) -> None:
        if event in _HARMLESS_EVENTS or self.in_hook:
            return
        self.in_hook = True
        try:
            why = self._audit_why(event, args)
        finally:
            self.in_hook = False
        if why is not None:
            exc = why if isinstance(why, Refused) else Refused("op", why)
            if self.hook_refusal is None:
                self.hook_refusal = exc
            raise exc

    def _audit_why(self, event: str, args):
        if event in _PATH_EVENTS:
            target = args[0] if args else None
            if event == "open":
                flags = args[2] if len(args) > 2 and isinstance(args[2], int) else 0
                mode = args[1] if len(args) > 1 and isinstance(args[1], str) else ""
                if flags & _WRITE_FLAGS or any(c in mode for c in "wax+"):
                    return "writing files is not allowed"
                if not isinstance(target, (str, bytes)):
                    return f"opening {target!r} is not allowed"
                try:
                    self.check_read(os.path.abspath(os.fsdecode(target)))
                except Refused as r:
                    return r
                return None
            if event.startswith("glob.glob"):
                target = os.path.dirname(str(target)) or "."
            if target is None or isinstance(target, int):
                target = "."
            p = os.path.abspath(os.fsdecode(target))
            if not self.allowed(os.path.realpath(p)):
                return self._outside(p)
            return None
        name = next((v for k, v in _EVENT_NAMES.items() if event == k or event.startswith(k + ".")), None)
        return f"{name} ({event}) is not allowed" if name else f"the operation {event} is not allowed"

    # -- messages ----------------------------------------------------------------------------------------------

    def locate(self, exc) -> str:
        """``line N`` (the input file) or ``FILE, line N`` (an included one) where ``exc`` arose, or ''."""
        where = None
        for e in _chain(exc):
            if getattr(e, "_ikp_where", None):
                where = e._ikp_where
                break
        if where is None:
            stack, filestack = next((e._ikp_stack for e in _chain(exc) if getattr(e, "_ikp_stack", None)), ([], []))
            token = next((e.token for e in _chain(exc) if getattr(e, "token", None)), None)
            where = self._find(stack, filestack, token)
        if where is None:
            return ""
        f, line = where
        if os.path.abspath(f) == self.input:
            return f"line {line}"
        return f"{self.shown(f)}, line {line}"

    def _find(self, stack, filestack, token):
        from xml.sax.saxutils import escape

        order = []
        for f in reversed([f for f in filestack if f]):
            order += [(p, d) for p, d in self.read if p == os.path.abspath(f)][:1]
        order += [(p, d) for p, d in reversed(self.read) if (p, d) not in order]
        if not order:
            try:
                order = [(self.input, self.read_bytes(self.input))]
            except Exception:  # noqa: BLE001
                return None
        order = [(p, d.decode("utf-8", "replace")) for p, d in order]
        texts = [t for t in reversed(stack) if isinstance(t, str) and t.strip()]
        if token:
            texts.append(token)
        for text in texts:
            variants = []
            for t in (text, text.strip().splitlines()[0] if text.strip() else text):
                for v in (t, escape(t), escape(t, {'"': "&quot;"}), escape(t, {"'": "&apos;"}),
                          escape(t, {'"': "&quot;", "'": "&apos;"})):
                    if v and v not in variants:
                        variants.append(v)
            for p, text_ in order:
                for v in variants:
                    i = text_.find(v)
                    if i >= 0:
                        if token and token in v:
                            i += v.index(token)
                        return p, text_.count("\n", 0, i) + 1
        return None

    def describe(self, exc: BaseException) -> str:
        safe = self.safe
        root = next((e for e in _chain(exc) if isinstance(e, (Refused, safe.ExpressionRefused))), None)
        if self.hook_refusal is not None and root is None:
            root = self.hook_refusal
        loc = self.locate(exc)
        at = f"{loc}: " if loc else ""
        if isinstance(root, safe.ExpressionLimit):
            return f"{at}xacro expression refused ({root.why}; expressions are bounded so that a file cannot " \
                   "exhaust the machine)"
        if isinstance(root, safe.ExpressionRefused):
            return f"{at}xacro expression refused ({safe.describe(root)})"
        if isinstance(root, Refused):
            if root.kind == "file":
                return f"{at}xacro file access refused ({root.why})"
            if root.kind == "env":
                name = root.token
                return (f"{at}{root.why} refused (xacro files may not read environment variables; pass the "
                        f"value with --xacro-arg {name}:=VALUE)")
            if root.kind == "ros":
                return (f"xacro cannot expand the file ({at}{root.why} needs ROS (a ROS package path), which this "
                        f"tool does not use; {ROS_HINT.format(name=os.path.basename(self.input))})")
            if root.kind == "limit":
                return f"{at}xacro expansion refused ({root.why})"
            if root.kind == "syntax":
                return f"{at}xacro expansion refused ({root.why})"
            return f"{at}xacro expansion refused ({root.why}; a xacro file may only describe a robot)"
        if any(isinstance(e, RecursionError) for e in _chain(exc)):
            return (f"xacro cannot expand the file ({at}nested too deeply: macros, includes or elements nested "
                    "beyond what the expansion allows (a macro or include that calls itself?))")
        import xml.parsers.expat

        if isinstance(exc, xml.parsers.expat.ExpatError):
            return f"xacro cannot expand the file ({at}not valid XML: {xml.parsers.expat.ErrorString(exc.code)})"
        msg = one_line(str(exc) or type(exc).__name__, 400)
        first = msg.find(" when evaluating expression")
        if first >= 0 and msg.find(" when evaluating expression", first + 1) > 0:  # nested: the innermost only
            msg = msg[: msg.find(" when evaluating expression", first + 1)]
        if isinstance(exc, (NameError, TypeError, ValueError, KeyError, IndexError, ZeroDivisionError,
                            AttributeError, SyntaxError, OSError)):
            msg = f"{type(exc).__name__}: {msg}"
        return f"xacro cannot expand the file ({at}{msg})"

    # -- run ---------------------------------------------------------------------------------------------------

    def patch(self) -> None:
        import re

        xacro = self.xacro
        refuse = _refuse_eval
        xacro.safe_eval = self.safe_eval
        xacro.eval = refuse  # any remaining eval in the module (shadows the builtin)
        xacro.substitution_args.eval = refuse
        xacro.substitution_args.resolve_args = _refuse_resolve
        xacro.open = self.open
        xacro.parse = self.parse
        xacro.load_yaml = self.load_yaml
        xacro.glob = _Glob(self.glob)
        xacro.eval_extension = self.eval_extension
        xacro.eval_text = self.wrap_eval_text(xacro.eval_text)
        xacro.eval_all = self.wrap_eval_all(xacro.eval_all)
        xacro.process_include = self.wrap_process_include(xacro.process_include)
        # the macro-parameter regex with a possessive run (same matches, no exponential backtracking on
        # a parameter such as  a:=xxxxxxxxxxxxxxxxxxxxxxxxxxxxxx' )
        xacro.re_macro_arg = re.compile(xacro.re_macro_arg.pattern.replace(r"[^\s'\"]+)+", r"[^\s'\"]++)+"))
        xacro._global_symbols = self.global_symbols()
        self._eval_funcs = {"arg": self.safe.register(lambda name: self.xacro.substitution_args.convert_value(
                                self.arg(name), "auto")),
                            "dirname": self.safe.register(lambda: self.eval_extension("$(dirname)")),
                            "env": self.safe.register(self.env), "optenv": self.safe.register(self.env),
                            "find": self.safe.register(self.find),
                            "true": True, "false": False, "True": True, "False": False}
        self._eval_funcs.update(self.safe.MATH)
        for unit in xacro.ConstructUnits:
            self.yaml.SafeLoader.add_constructor(unit.value.tag, unit.constructor)

    def run(self) -> tuple[bool, str]:
        xacro = self.xacro
        failure = memory = None
        try:
            doc = xacro.process_file(self.input, mappings=dict(self.user_args))
            if self.hook_refusal is not None:
                raise self.hook_refusal
            self.elements = 0
            xml = doc.toprettyxml(indent="  ")
            del doc
            if len(xml) > MAX_OUTPUT_BYTES:
                raise Refused("limit", f"the expanded URDF passes {MAX_OUTPUT_BYTES >> 20} MiB")
            return True, xml
        except MemoryError:
            memory = True
        except BaseException as exc:  # noqa: BLE001  every failure is one line
            if any(isinstance(e, MemoryError) for e in _chain(exc)):
                memory = True
            else:
                try:
                    failure = self.describe(exc)
                except MemoryError:
                    memory = True
                except BaseException as exc2:  # noqa: BLE001
                    failure = f"xacro cannot expand the file ({type(exc).__name__}; {type(exc2).__name__})"
        if memory:
            return False, memory_message(self.memory_mib)
        return False, failure


def _chain(exc):
    """``exc`` and the exceptions it wraps (xacro's ``.exc``, ``__cause__``, ``__context__``), inner last."""
    seen, out, todo = set(), [], [exc]
    while todo:
        e = todo.pop(0)
        if e is None or id(e) in seen or not isinstance(e, BaseException):
            continue
        seen.add(id(e))
        out.append(e)
        todo += [getattr(e, "exc", None), e.__cause__, None if e.__suppress_context__ else e.__context__]
    return out[::-1]  # innermost first


class _Glob:
    def __init__(self, fn):
        self.glob = fn


def _refuse_eval(*args, **kwargs):
    raise Refused("op", "Python's eval is not allowed")


def _refuse_resolve(*args, **kwargs):
    raise Refused("op", "xacro's own substitution resolver is not allowed")
