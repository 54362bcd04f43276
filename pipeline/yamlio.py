"""The one YAML loader of every input file (robot files, study settings, run configs, schemas).

:func:`load_yaml` reads a file, :func:`parse_yaml` a string; both refuse, in one line naming the
file (and the field where there is one), what PyYAML's ``safe_load`` would accept or choke on:

- content that is not UTF-8 text: UTF-16/32 (byte-order marks, NUL bytes), invalid UTF-8
  sequences, control characters (binary junk);
- files larger than :data:`MAX_BYTES`, more than :data:`MAX_NODES` YAML nodes, nesting deeper
  than :data:`MAX_DEPTH`, and aliases whose expansion would exceed :data:`MAX_EXPANDED` nodes
  ("billion laughs": nine levels of nine-fold aliases expand to ~4e8 nodes);
- duplicate keys in one mapping (PyYAML keeps the last silently);
- any tag (``!!python/object``, ``!!str``, ``!custom``): the inputs are plain data;
- YAML 1.1 surprises in plain scalars: base-60 numbers (``12:30`` is 750), ``yes``/``no``/
  ``on``/``off`` booleans, leading-zero octals (``0755``), binary ``0b101``, underscores in
  numbers (``1_000``) and unquoted dates (``2019-01-01`` becomes a date object).

The checks run over PyYAML's event stream (libyaml's parser when available, which is iterative:
20 000 nested ``[`` cannot overflow the stack) before anything is constructed, so the time and
memory spent on any input are bounded by :data:`MAX_BYTES` and :data:`MAX_NODES`. What passes is
then constructed by ``SafeLoader`` (aliases and ``<<`` merge keys work as before; the depth is
already bounded, so its recursion cannot overflow).
"""

from __future__ import annotations

import re
from pathlib import Path

import yaml

from pipeline.errors import not_regular

# Limits, each far above the project's real inputs (largest file 23 kB, ~1 700 nodes, depth 9, the
# largest alias expansion a few hundred nodes) and far below what costs a second or 100 MB to load.
MAX_BYTES = 1 << 20  # 1 MiB per YAML file
MAX_NODES = 20_000  # scalars + collections + aliases, as written (12x the largest real file; PyYAML's pure-Python
#                    loader, which a study verb may still use after this check, needs ~2 s for 20 000 nodes)
MAX_EXPANDED = 50_000  # nodes after expanding every alias (billion-laughs bound: what walks the parsed tree,
#                        schema validation and hashing, sees every alias expanded)
MAX_DEPTH = 32  # nested collections

_Loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)

_RESOLVER = yaml.resolver.Resolver()
_TAG = "tag:yaml.org,2002:"
_BOOL_WORDS = {"yes", "no", "on", "off"}


def _surprise(value: str) -> str | None:
    """Why PyYAML (YAML 1.1) would read the plain scalar ``value`` surprisingly, or None.

    YAML 1.2, and most readers of a file, read all of these as the string written.
    """
    tag = _RESOLVER.resolve(yaml.ScalarNode, value, (True, False))
    if tag in (_TAG + "int", _TAG + "float"):
        if ":" in value:
            return (f"base-60 number {value!r} (YAML 1.1 reads it as {_sexagesimal(value)}); write the number "
                    f"in decimal, or quote it")
        if "_" in value:
            return f"number {value!r} with underscores (YAML 1.1 only); write the digits without them, or quote it"
        if re.match(r"^[-+]?0b", value):
            return f"binary number {value!r} (YAML 1.1 only); write it in decimal, or quote it"
        if re.match(r"^[-+]?0[0-7]+$", value):
            return (f"{value!r} is a YAML 1.1 octal number ({int(value.lstrip('+-'), 8)}); write it without the "
                    f"leading 0, or quote it")
    elif tag == _TAG + "bool" and value.lower() in _BOOL_WORDS:
        return f"{value!r} is a YAML 1.1 boolean; write true or false, or quote it"
    elif tag == _TAG + "timestamp":
        return f"{value!r} would be read as a date; quote it"
    return None


# characters YAML does not allow in a stream (as PyYAML's reader), i.e. binary content
_NON_PRINTABLE = re.compile("[^\x09\x0A\x0D\x20-\x7E\x85\xA0-\uD7FF\uE000-\uFFFD\U00010000-\U0010ffff]")
_BOMS = ((b"\x00\x00\xfe\xff", "UTF-32"), (b"\xff\xfe\x00\x00", "UTF-32"), (b"\xfe\xff", "UTF-16"),
         (b"\xff\xfe", "UTF-16"))


class YAMLInputError(ValueError):
    """A YAML input refused by :func:`load_yaml`; the message is one line naming the file."""


def _sexagesimal(v: str) -> str:
    sign = -1 if v.startswith("-") else 1
    x = 0.0 if "." in v else 0
    for part in v.lstrip("+-").replace("_", "").split(":"):
        x = x * 60 + (float(part) if "." in part else int(part))
    return repr(sign * x)


def _field(path: list) -> str:
    return "/".join(str(p) for p in path)


def _where(source: str, path: list, mark) -> str:
    line = f"line {mark.line + 1}" if mark is not None else ""
    field = f"field '{_field(path)}'" if path else ""
    return f"{source}: " + ", ".join(x for x in (field, line) if x)


def decode_text(data: bytes, source: str) -> str:
    """UTF-8 bytes -> text, refusing UTF-16/32, invalid UTF-8 and control characters (one line).

    Parameters
    ----------
    data : bytes
    source : str
        Names the input in messages (a file path, or e.g. ``--set scale``).

    Returns
    -------
    str
        The text, without a UTF-8 byte-order mark.
    """
    for bom, enc in _BOMS:
        if data.startswith(bom):
            raise YAMLInputError(f"{source}: not UTF-8 text ({enc} byte-order mark); save the file as UTF-8")
    if b"\x00" in data:
        line = data[:data.index(b"\x00")].count(b"\n") + 1
        raise YAMLInputError(f"{source}: line {line}: not UTF-8 text (NUL bytes: binary content or UTF-16)")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise YAMLInputError(f"{source}: line {line}: not UTF-8 text (byte 0x{data[exc.start]:02x} at offset "
                             f"{exc.start} is not valid UTF-8)") from None
    text = text[1:] if text.startswith("\ufeff") else text
    bad = _NON_PRINTABLE.search(text)
    if bad:
        line = text.count("\n", 0, bad.start()) + 1
        raise YAMLInputError(f"{source}: line {line}: control character U+{ord(bad.group()):04X} "
                             f"(binary content, not YAML text)")
    return text


def _key_of(event) -> object:
    """Identity of a scalar mapping key for the duplicate check (``a``, ``'a'`` and ``"a"`` are one key)."""
    if event.implicit[0]:
        tag = _RESOLVER.resolve(yaml.ScalarNode, event.value, (True, False))
        if tag != "tag:yaml.org,2002:str":
            return (tag, event.value)
    return event.value


class _EventWalk:
    """The state of :func:`check_events`: one frame per open collection, the anchors' expanded sizes and
    the counts of nodes and documents; :meth:`take` checks one event."""

    def __init__(self, source: str):
        self.source = source
        # one frame per open collection: [kind, path, expanded size, anchor, keys seen, expecting key, key]
        self.stack: list[list] = []
        self.sizes: dict[str, int] = {}  # anchor -> expanded size of its node
        self.nodes = 0
        self.docs = 0

    def path_of(self) -> list:
        out = []
        for fr in self.stack:
            if fr[0] == "map" and fr[6] is not None:
                out.append(fr[6])
            elif fr[0] == "seq":
                out.append(fr[4])
        return out

    def fail(self, mark, text: str, path: list | None = None):
        raise YAMLInputError(f"{_where(self.source, self.path_of() if path is None else path, mark)}: {text}")

    def add(self, size: int, mark) -> None:
        """A child node of ``size`` expanded nodes completed in the innermost collection."""
        if not self.stack:
            return
        fr = self.stack[-1]
        fr[2] += size
        if fr[2] > MAX_EXPANDED:
            self.fail(mark, f"aliases expand to more than {MAX_EXPANDED} nodes (an alias bomb?)")
        if fr[0] == "seq":
            fr[4] += 1
        else:  # a mapping's value (keys are scalars, counted where they are read)
            fr[5], fr[6] = True, None

    def take(self, ev) -> None:
        """Check one event; refuse (one line) anything :func:`parse_yaml` refuses."""
        if isinstance(ev, (yaml.StreamStartEvent, yaml.StreamEndEvent, yaml.DocumentEndEvent)):
            return
        if isinstance(ev, yaml.DocumentStartEvent):
            self.docs += 1
            if self.docs > 1:
                raise YAMLInputError(f"{self.source}: line {ev.start_mark.line + 1}: more than one YAML document "
                                     f"in the file")
            return
        self.nodes += not isinstance(ev, (yaml.SequenceEndEvent, yaml.MappingEndEvent))
        if self.nodes > MAX_NODES:
            self.fail(ev.start_mark, f"more than {MAX_NODES} YAML nodes (no input of this project comes near; a "
                                     f"generated or hostile file?)")
        in_key = bool(self.stack) and self.stack[-1][0] == "map" and self.stack[-1][5]
        tag = getattr(ev, "tag", None)
        if tag is not None:  # written in the file: '!!python/object', '!!str', '!foo', '!'
            self.fail(ev.start_mark, f"YAML tag {tag!r} not allowed (inputs are plain data: numbers, strings, "
                                     f"lists, mappings)")
        if isinstance(ev, yaml.AliasEvent):
            if in_key:
                self.fail(ev.start_mark, "an alias as a mapping key is not allowed")
            if ev.anchor not in self.sizes:
                self.fail(ev.start_mark, f"alias *{ev.anchor} names no anchor defined before it")
            self.add(self.sizes[ev.anchor], ev.start_mark)
        elif isinstance(ev, yaml.ScalarEvent):
            self._scalar(ev, in_key)
        elif isinstance(ev, (yaml.SequenceStartEvent, yaml.MappingStartEvent)):
            if in_key:
                self.fail(ev.start_mark, "a list or mapping as a mapping key is not allowed")
            if len(self.stack) >= MAX_DEPTH:
                self.fail(ev.start_mark, f"nested deeper than {MAX_DEPTH} levels (no input of this project comes "
                                         f"near)", path=[])
            if isinstance(ev, yaml.SequenceStartEvent):
                self.stack.append(["seq", None, 1, ev.anchor, 0, False, None])
            else:
                self.stack.append(["map", None, 1, ev.anchor, set(), True, None])
        elif isinstance(ev, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
            fr = self.stack.pop()
            if fr[3]:
                self.sizes[fr[3]] = fr[2]
            self.add(fr[2], ev.start_mark)

    def _scalar(self, ev, in_key: bool) -> None:
        why = _surprise(ev.value) if ev.implicit[0] and not ev.style else None
        if why:
            self.fail(ev.start_mark, why)
        if in_key:
            fr = self.stack[-1]
            key = _key_of(ev)
            if key in fr[4]:
                self.fail(ev.start_mark, f"duplicate key {ev.value!r} in one mapping (YAML would keep only the last)")
            fr[4].add(key)
            fr[6] = ev.value
            fr[5] = False  # the value comes next
            fr[2] += 1
            return
        if ev.anchor:
            self.sizes[ev.anchor] = 1
        self.add(1, ev.start_mark)


def check_events(text: str, source: str) -> None:
    """Walk the YAML event stream of ``text`` and refuse (one line) anything :func:`parse_yaml` refuses.

    Linear in the size of the text; nothing is constructed and no alias is expanded.

    Raises
    ------
    YAMLInputError
        One line naming ``source``, the line and the field.
    """
    walk = _EventWalk(source)
    try:
        for ev in yaml.parse(text, Loader=_Loader):
            walk.take(ev)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"{source}: line {mark.line + 1}" if mark is not None else source
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise YAMLInputError(f"{where}: not valid YAML ({problem})") from None


def parse_yaml(text: str, source: str):
    """Parse YAML text with the checks of :func:`check_events`; returns plain Python data.

    Parameters
    ----------
    text : str
    source : str
        Names the input in messages (a file path, or e.g. ``--set studies``).

    Raises
    ------
    YAMLInputError
        One line naming ``source`` (and the field and line where there is one).
    """
    if len(text) > MAX_BYTES:
        raise YAMLInputError(f"{source}: larger than {MAX_BYTES} bytes (no input of this project comes near)")
    check_events(text, source)
    try:
        return yaml.load(text, Loader=_Loader)  # noqa: S506  (a SafeLoader)
    except yaml.YAMLError as exc:  # e.g. a merge key ('<<') whose value is not a mapping
        mark = getattr(exc, "problem_mark", None)
        where = f"{source}: line {mark.line + 1}" if mark is not None else source
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise YAMLInputError(f"{where}: not valid YAML ({problem})") from None
    except RecursionError:  # unreachable with MAX_DEPTH, kept so that no input gives a traceback
        raise YAMLInputError(f"{source}: nested too deeply") from None


def load_yaml(path: str | Path, what: str = "file"):
    """Read and parse one YAML file (see the module docstring for what is refused).

    Parameters
    ----------
    path : str or Path
    what : str
        Noun for an unreadable file: ``"{path}: cannot read {what} (No such file or directory)"``.

    Raises
    ------
    YAMLInputError
        One line naming the file.
    """
    path = Path(path)
    why = not_regular(path)
    if why:  # reading a FIFO would block until someone writes to it
        raise YAMLInputError(f"{path}: {why}")
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_BYTES + 1)
    except OSError as exc:
        raise YAMLInputError(f"{path}: cannot read {what} ({exc.strerror or exc})") from None
    if len(data) > MAX_BYTES:
        raise YAMLInputError(f"{path}: larger than {MAX_BYTES} bytes (no {what} of this project comes near; "
                             f"a generated or hostile file?)")
    return parse_yaml(decode_text(data, str(path)), str(path))
