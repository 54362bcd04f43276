"""A small expression evaluator for xacro's ``${...}`` and ``$(eval ...)``: arithmetic, never code.

xacro evaluates its expressions with Python's ``eval`` (builtins removed, names with ``__`` refused),
which an attribute walk such as ``''.__class__.__mro__[1].__subclasses__()`` still escapes. This module
evaluates the parsed expression itself, node by node, and admits only:

* number, string, ``True``/``False``/``None``, list, tuple and dict literals;
* arithmetic (``+ - * / // % **``, unary ``+ - ~``, ``& | ^ << >>`` on integers), comparisons (``in`` and
  ``is`` included), ``and``/``or``/``not`` and ``a if c else b``;
* names, looked up with the caller's ``lookup`` (xacro's properties and its global symbols);
* subscripts and slices of strings, lists, tuples and dicts (the lists and dicts ``load_yaml`` returns);
* ``ns.key`` on a dict-like namespace (``math.pi``, ``xacro.load_yaml``, ``config.kinematics.x`` of a
  YAML dict) -- a key lookup, never a Python attribute;
* calls of the functions in :data:`FUNCTIONS` (the math module's, ``abs min max round int float str len
  bool list tuple dict sum sorted range any all``) and of those a caller adds with :func:`register`.

Everything else (attribute access, lambda, comprehensions, f-strings, ``:=``, ``*``-unpacking, keyword
arguments, calling anything not registered) raises :class:`ExpressionRefused` before anything runs.
The work is bounded: text at most :data:`MAX_TEXT` characters and :data:`MAX_DEPTH` levels deep, integers
within +-2**64, ``**`` with an integer exponent at most :data:`MAX_POW_EXP` and a float result within
1e308, strings, lists, tuples and dicts at most :data:`MAX_ITEMS` items, and any value (nested
containers counted in full) at most :data:`MAX_TOTAL` items and characters; past a bound
:class:`ExpressionLimit` (a subclass) is raised.

Standard library only: the xacro sandbox (:mod:`pipeline.xacro_sandbox`) loads this file by path.
"""

from __future__ import annotations

import ast
import math
import operator
import re

MAX_TEXT = 10_000        # characters of one expression
MAX_DEPTH = 200          # nesting levels of one expression's syntax tree
MAX_INT = 2 ** 64        # |integer| bound
MAX_POW_EXP = 1000       # integer exponent bound of **
MAX_ITEMS = 100_000      # length of a string, list, tuple or dict
MAX_TOTAL = 1_000_000    # items and characters of a value, nested containers counted in full
MAX_WORK = 5_000_000     # items touched by one evaluation (copies, walks)
MAX_FORMAT_WIDTH = 1000  # width / precision in '%' formatting

HINT = "xacro expressions may use arithmetic, property names and the math functions"


class ExpressionRefused(Exception):
    """An expression uses something this evaluator does not admit; ``str(exc)`` says what (one line)."""

    def __init__(self, why: str, token: str | None = None):
        super().__init__(why)
        self.why = why
        self.token = token  # a piece of the expression's text to find it in the file


class ExpressionLimit(ExpressionRefused):
    """An expression passed one of the work bounds."""


class Namespace(dict):
    """A named group of symbols (``math``, ``xacro``, ``python``): ``ns.name`` looks ``name`` up."""


_NODE_NAMES = {
    "Lambda": "lambda is", "ListComp": "comprehensions are", "SetComp": "comprehensions are",
    "DictComp": "comprehensions are", "GeneratorExp": "comprehensions are", "JoinedStr": "f-strings are",
    "FormattedValue": "f-strings are", "NamedExpr": "assignment expressions (:=) are", "Starred": "unpacking (*) is",
    "Set": "set literals are", "Await": "await is", "Yield": "yield is", "YieldFrom": "yield is",
    "MatMult": "the @ operator is",
}

# Python builtins not offered to expressions: named in the refusal when a file uses one
_PYTHON_BUILTINS = frozenset(dir(__builtins__) if not isinstance(__builtins__, dict) else __builtins__)

_ALLOWED_NODES = (
    ast.Expression, ast.BinOp, ast.UnaryOp, ast.BoolOp, ast.Compare, ast.IfExp, ast.Constant, ast.List,
    ast.Tuple, ast.Dict, ast.Name, ast.Load, ast.Subscript, ast.Slice, ast.Call, ast.Attribute,
    ast.Add, ast.Sub, ast.Mult, ast.Div, ast.FloorDiv, ast.Mod, ast.Pow, ast.BitAnd, ast.BitOr, ast.BitXor,
    ast.LShift, ast.RShift, ast.UAdd, ast.USub, ast.Not, ast.Invert, ast.And, ast.Or, ast.Eq, ast.NotEq,
    ast.Lt, ast.LtE, ast.Gt, ast.GtE, ast.In, ast.NotIn, ast.Is, ast.IsNot,
)


# ---------------------------------------------------------------------------------------------------------------
# bounds


class _Budget:
    __slots__ = ("left",)

    def __init__(self, n: int = MAX_WORK):
        self.left = n

    def spend(self, n: int) -> None:
        self.left -= n
        if self.left < 0:
            raise ExpressionLimit(f"the expression does too much work (more than {MAX_WORK:,} items touched)")


def _check_int(v):
    if isinstance(v, int) and not isinstance(v, bool) and (v > MAX_INT or v < -MAX_INT):
        raise ExpressionLimit("integer beyond 2**64")
    return v


def _size(v, budget: _Budget | None = None, limit: int = MAX_TOTAL) -> int:
    """Items and characters of ``v``, nested containers counted in full (shared ones each time they
    appear); :class:`ExpressionLimit` past ``limit``."""
    total = 0
    stack = [v]
    while stack:
        x = stack.pop()
        if isinstance(x, str):
            total += len(x)
        elif isinstance(x, (list, tuple)):
            total += 1 + len(x)
            stack.extend(x)
        elif isinstance(x, dict):
            total += 1 + 2 * len(x)
            stack.extend(dict.keys(x))
            stack.extend(dict.values(x))
        else:
            total += 1
        if total > limit:
            raise ExpressionLimit(f"a value larger than {limit:,} items and characters")
    if budget is not None:
        budget.spend(total)
    return total


def _check(v, budget: _Budget | None = None):
    """A result: admitted type, integer bound, length bound."""
    if isinstance(v, bool) or v is None or isinstance(v, float):
        return v
    if isinstance(v, int):
        return _check_int(v)
    if isinstance(v, (str, list, tuple, dict)):
        if len(v) > MAX_ITEMS:
            raise ExpressionLimit(f"a {_kind(v)} longer than {MAX_ITEMS:,} items")
        if budget is not None:
            budget.spend(len(v))
        return v
    if callable(v) and _is_function(v):
        return v
    raise ExpressionRefused(f"a value of type {type(v).__name__!r} is not allowed")


def _kind(v) -> str:
    return ("string" if isinstance(v, str) else "list" if isinstance(v, list) else "tuple"
            if isinstance(v, tuple) else "dict" if isinstance(v, dict) else type(v).__name__)


def _num(v, op: str):
    if isinstance(v, (int, float)):
        return v
    raise TypeError(f"unsupported operand type for {op}: {_kind(v)!r}")


# ---------------------------------------------------------------------------------------------------------------
# operators


def _add(a, b, budget):
    if isinstance(a, (str, list, tuple)) and isinstance(b, (str, list, tuple)):
        if len(a) + len(b) > MAX_ITEMS:
            raise ExpressionLimit(f"a {_kind(a)} longer than {MAX_ITEMS:,} items")
        budget.spend(len(a) + len(b))
        return a + b  # a TypeError for a string plus a list
    return _num(a, "+") + _num(b, "+")


def _mul(a, b, budget):
    if isinstance(b, (str, list, tuple)) and isinstance(a, int):
        a, b = b, a
    if isinstance(a, (str, list, tuple)):
        if not isinstance(b, int):
            raise TypeError(f"can't multiply a {_kind(a)} by {_kind(b)!r}")
        n = max(int(b), 0) * len(a)
        if n > MAX_ITEMS:
            raise ExpressionLimit(f"a {_kind(a)} longer than {MAX_ITEMS:,} items")
        budget.spend(n)
        return a * b
    return _num(a, "*") * _num(b, "*")


def _pow(a, b, budget):
    _num(a, "**"), _num(b, "**")
    if isinstance(a, int) and isinstance(b, int) and b >= 0:
        if abs(a) > 1 and b > MAX_POW_EXP:
            raise ExpressionLimit(f"** with an exponent above {MAX_POW_EXP}")
        if abs(a) > 1 and (abs(a).bit_length() - 1) * b > 64:
            raise ExpressionLimit("integer beyond 2**64")
    try:
        r = a ** b
    except OverflowError:
        raise ExpressionLimit("a number beyond 1e308") from None
    if isinstance(r, complex):
        raise ExpressionRefused("complex numbers are not allowed")
    return r


_FMT = re.compile(r"%[#0\- +]*(\*|\d+)?(?:\.(\*|\d+))?")


def _mod(a, b, budget):
    if isinstance(a, str):
        for m in _FMT.finditer(a):
            for g in m.groups():
                if g == "*" or (g and int(g) > MAX_FORMAT_WIDTH):
                    raise ExpressionLimit(f"'%' formatting with a width or precision above {MAX_FORMAT_WIDTH}")
        if isinstance(b, (tuple, dict, list)):
            _size(b, budget)
        r = a % b
        if len(r) > MAX_ITEMS:
            raise ExpressionLimit(f"a string longer than {MAX_ITEMS:,} items")
        return r
    return _num(a, "%") % _num(b, "%")


def _shift(op):
    def f(a, b, budget):
        if not isinstance(a, int) or not isinstance(b, int):
            raise TypeError("shifts take integers")
        if b > 64:
            raise ExpressionLimit("integer beyond 2**64")
        return op(a, b)
    return f


def _intop(op, sym):
    def f(a, b, budget):
        if not isinstance(a, int) or not isinstance(b, int):
            raise TypeError(f"{sym} takes integers or booleans")
        return op(a, b)
    return f


def _arith(op, sym):
    def f(a, b, budget):
        return op(_num(a, sym), _num(b, sym))
    return f


_BINOPS = {
    ast.Add: _add, ast.Sub: _arith(operator.sub, "-"), ast.Mult: _mul, ast.Div: _arith(operator.truediv, "/"),
    ast.FloorDiv: _arith(operator.floordiv, "//"), ast.Mod: _mod, ast.Pow: _pow,
    ast.LShift: _shift(operator.lshift), ast.RShift: _shift(operator.rshift),
    ast.BitAnd: _intop(operator.and_, "&"), ast.BitOr: _intop(operator.or_, "|"),
    ast.BitXor: _intop(operator.xor, "^"),
}

_CMPOPS = {
    ast.Eq: operator.eq, ast.NotEq: operator.ne, ast.Lt: operator.lt, ast.LtE: operator.le, ast.Gt: operator.gt,
    ast.GtE: operator.ge, ast.In: lambda a, b: a in b, ast.NotIn: lambda a, b: a not in b,
    ast.Is: operator.is_, ast.IsNot: operator.is_not,
}


# ---------------------------------------------------------------------------------------------------------------
# functions


def _bounded_iterable(x, what: str):
    if isinstance(x, (str, list, tuple, dict)):
        return x
    raise TypeError(f"{what}() takes a string, list, tuple or dict, not {_kind(x)!r}")


def _int(x=0, base=None):
    if base is None:
        if isinstance(x, str) and len(x) > 100:
            raise ExpressionLimit("int() of a string longer than 100 characters")
        return int(x)
    if not isinstance(x, str) or len(x) > 100:
        raise TypeError("int() with a base takes a string of at most 100 characters")
    return int(x, base)


def _float(x=0.0):
    if isinstance(x, str) and len(x) > 1000:
        raise ExpressionLimit("float() of a string longer than 1000 characters")
    return float(x)


def _str(x=""):
    _size(x)
    return str(x)


def _len(x):
    return len(_bounded_iterable(x, "len"))


def _bool(x=False):
    return bool(x)


def _abs(x):
    return abs(_num(x, "abs"))


def _minmax(fn, name):
    def f(*args):
        items = args[0] if len(args) == 1 else args
        _bounded_iterable(items, name)
        _size(items)
        return fn(items)
    f.__name__ = name
    return f


def _round(x, ndigits=None):
    _num(x, "round")
    if ndigits is None:
        return round(x)
    if not isinstance(ndigits, int) or abs(ndigits) > 400:
        raise ExpressionLimit("round() with more than 400 digits")
    return round(x, ndigits)


def _list(x=()):
    return list(_bounded_iterable(x, "list"))


def _tuple(x=()):
    return tuple(_bounded_iterable(x, "tuple"))


def _dict(x=()):
    _bounded_iterable(x, "dict")
    _size(x)
    return dict(x)


def _sum(x, start=0):
    _bounded_iterable(x, "sum")
    total = _num(start, "sum")
    for v in x:
        total = _check_int(total + _num(v, "sum"))
    return total


def _sorted(x):
    _bounded_iterable(x, "sorted")
    _size(x)
    return sorted(x)


def _range(*args):
    for a in args:
        if not isinstance(a, int):
            raise TypeError("range() takes integers")
    r = range(*args)
    if len(r) > MAX_ITEMS:
        raise ExpressionLimit(f"range() of more than {MAX_ITEMS:,} items")
    return list(r)


def _any(x):
    _size(_bounded_iterable(x, "any"))
    return any(x)


def _all(x):
    _size(_bounded_iterable(x, "all"))
    return all(x)


def _factorial(n):
    if not isinstance(n, int) or n > 20:
        raise ExpressionLimit("factorial() of more than 20 (integer beyond 2**64)")
    return math.factorial(n)


def _combperm(fn):
    def f(n, k=None):
        if not isinstance(n, int) or n > 1000:
            raise ExpressionLimit(f"{fn.__name__}() of more than 1000")
        return _check_int(fn(n) if k is None else fn(n, k))
    f.__name__ = fn.__name__
    return f


def _prod(x, start=1):
    _bounded_iterable(x, "prod")
    total = _num(start, "prod")
    for v in x:
        total = _check_int(total * _num(v, "prod"))
    return total


def _lcm(*args):
    r = 1
    for a in args:
        r = _check_int(math.lcm(r, a))
    return r


def _ldexp(x, i):
    if not isinstance(i, int) or abs(i) > 100_000:
        raise ExpressionLimit("ldexp() exponent beyond 100000")
    try:
        return math.ldexp(x, i)
    except OverflowError:
        raise ExpressionLimit("a number beyond 1e308") from None


def _mathfn(fn):
    def f(*args):
        for a in args:
            if isinstance(a, (list, tuple, dict)):
                _size(a)
            elif isinstance(a, str):
                raise TypeError(f"{fn.__name__}() takes numbers, not a string")
        try:
            return fn(*args)
        except OverflowError:
            raise ExpressionLimit("a number beyond 1e308") from None
    f.__name__ = fn.__name__
    return f


_MATH_WRAPPED = {"factorial": _factorial, "comb": _combperm(math.comb), "perm": _combperm(math.perm),
                 "prod": _prod, "lcm": _lcm, "ldexp": _ldexp}

#: the math module's public names (xacro exposes all of them, directly and as ``math.<name>``)
MATH = Namespace()
for _name in sorted(dir(math)):
    if _name.startswith("_"):
        continue
    _v = getattr(math, _name)
    MATH[_name] = _v if isinstance(_v, float) else _MATH_WRAPPED.get(_name) or _mathfn(_v)

#: the builtins xacro files use
BUILTINS = {
    "abs": _abs, "min": _minmax(min, "min"), "max": _minmax(max, "max"), "round": _round, "int": _int,
    "float": _float, "str": _str, "len": _len, "bool": _bool, "list": _list, "tuple": _tuple, "dict": _dict,
    "sum": _sum, "sorted": _sorted, "range": _range, "any": _any, "all": _all,
}
for _name, _fn in BUILTINS.items():
    _fn.__name__ = _name

_FUNCTIONS: dict[int, object] = {}


def register(fn):
    """Admit ``fn`` as a function expressions may call (it must bound its own work)."""
    _FUNCTIONS[id(fn)] = fn
    return fn


def _is_function(v) -> bool:
    return _FUNCTIONS.get(id(v)) is v


for _fn in list(BUILTINS.values()) + [v for v in MATH.values() if callable(v)]:
    register(_fn)


def symbols() -> dict:
    """The global symbols of an expression: the builtins, the math names (also as ``math.<name>``) and
    ``python.<builtin>``, ``True``, ``False``, ``None``."""
    out = {}
    out.update(MATH)
    out.update(BUILTINS)
    out["math"] = Namespace(MATH)
    out["python"] = Namespace(BUILTINS)
    out["True"], out["False"], out["None"] = True, False, None
    return out


# ---------------------------------------------------------------------------------------------------------------
# evaluation


def _static_check(tree, text: str) -> None:
    """Refuse disallowed syntax anywhere in the tree before evaluating any of it (the leftmost first)."""
    found = []
    stack = [(tree, 0)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise ExpressionLimit(f"the expression is nested more than {MAX_DEPTH} levels deep")
        why = _refusal(node, text)
        if why is not None:  # its children are not looked at: "lambda", not its "arguments"
            where = (getattr(node, "end_lineno", 0) or 0, getattr(node, "end_col_offset", 0) or 0) \
                if isinstance(node, ast.Attribute) else (getattr(node, "lineno", 0), getattr(node, "col_offset", 0))
            found.append((where, why))
            if not isinstance(node, ast.Attribute):
                continue
        stack.extend((c, depth + 1) for c in ast.iter_child_nodes(node))
    if found:
        raise min(found, key=lambda f: f[0])[1]


def _refusal(node, text: str) -> ExpressionRefused | None:
    name = type(node).__name__
    if name in _NODE_NAMES:
        return ExpressionRefused(f"{_NODE_NAMES[name]} not allowed", _token(node, text))
    if not isinstance(node, _ALLOWED_NODES):
        return ExpressionRefused(f"{name} is not allowed", _token(node, text))
    if isinstance(node, ast.Attribute) and node.attr.startswith("_"):
        return ExpressionRefused(f"attribute access {node.attr!r} is not allowed", node.attr)
    if isinstance(node, ast.Name) and node.id.startswith("__"):
        return ExpressionRefused(f"the name {node.id!r} is not allowed", node.id)
    if isinstance(node, ast.Call) and node.keywords:
        return ExpressionRefused("keyword arguments are not allowed", _token(node, text))
    if isinstance(node, ast.Dict) and any(k is None for k in node.keys):
        return ExpressionRefused("unpacking (**) is not allowed", "**")
    if isinstance(node, ast.Constant) and not isinstance(node.value, (int, float, str, bool, type(None))):
        return ExpressionRefused(f"{type(node.value).__name__} literals are not allowed", _token(node, text))
    return None


def _token(node, text: str) -> str | None:
    try:
        return ast.get_source_segment(text, node)
    except Exception:  # noqa: BLE001
        return None


def parse(text: str):
    """The checked syntax tree of ``text`` (SyntaxError for bad syntax, ExpressionRefused for the rest)."""
    if not isinstance(text, str):
        text = str(text)
    if len(text) > MAX_TEXT:
        raise ExpressionLimit(f"an expression longer than {MAX_TEXT:,} characters")
    text = text.strip()
    if "\x00" in text:
        raise SyntaxError("a NUL character in the expression")
    try:
        tree = ast.parse(text, mode="eval")
    except (RecursionError, MemoryError):
        raise ExpressionLimit(f"the expression is nested more than {MAX_DEPTH} levels deep") from None
    except SyntaxError as exc:
        if "too many nested" in str(exc) or "too complex" in str(exc):
            raise ExpressionLimit(f"the expression is nested more than {MAX_DEPTH} levels deep") from None
        raise SyntaxError(f"invalid expression syntax ({exc.msg})") from None
    _static_check(tree, text)
    return tree, text


def evaluate(text, lookup, *, check_result: bool = True):
    """The value of the expression ``text``; ``lookup(name)`` gives a name's value (KeyError: undefined).

    Raises ExpressionRefused / ExpressionLimit (not admitted, past a bound), SyntaxError, NameError, and
    TypeError / ValueError / ZeroDivisionError / KeyError / IndexError of the arithmetic itself."""
    tree, text = parse(text)
    budget = _Budget()
    ev = _Evaluator(lookup, budget, text)
    value = ev.eval(tree.body)
    if check_result:
        _size(value, budget)
    return value


class _Evaluator:
    def __init__(self, lookup, budget: _Budget, text: str):
        self.lookup = lookup
        self.budget = budget
        self.text = text

    def eval(self, node):
        m = getattr(self, "_" + type(node).__name__)
        return _check(m(node), self.budget)

    def _Constant(self, node):
        return node.value

    def _Name(self, node):
        try:
            value = self.lookup(node.id)
        except KeyError:
            if node.id in _PYTHON_BUILTINS:
                raise ExpressionRefused(f"the Python builtin {node.id!r} is not allowed", node.id) from None
            raise NameError(f"name {node.id!r} is not defined") from None
        return _check(value)

    def _List(self, node):
        return [self.eval(e) for e in node.elts]

    def _Tuple(self, node):
        return tuple(self.eval(e) for e in node.elts)

    def _Dict(self, node):
        out = {}
        for k, v in zip(node.keys, node.values):
            out[self.eval(k)] = self.eval(v)
        return out

    def _BinOp(self, node):
        a, b = self.eval(node.left), self.eval(node.right)
        return _BINOPS[type(node.op)](a, b, self.budget)

    def _UnaryOp(self, node):
        v = self.eval(node.operand)
        if isinstance(node.op, ast.Not):
            return not v
        if isinstance(node.op, ast.Invert):
            if not isinstance(v, int):
                raise TypeError("~ takes an integer")
            return ~v
        v = _num(v, "unary " + ("-" if isinstance(node.op, ast.USub) else "+"))
        return -v if isinstance(node.op, ast.USub) else +v

    def _BoolOp(self, node):
        is_and = isinstance(node.op, ast.And)
        value = None
        for e in node.values:
            value = self.eval(e)
            if bool(value) != is_and:
                return value
        return value

    def _Compare(self, node):
        left = self.eval(node.left)
        for op, right_node in zip(node.ops, node.comparators):
            right = self.eval(right_node)
            if isinstance(left, (list, tuple, dict)) or isinstance(right, (list, tuple, dict)):
                _size(left, self.budget)
                _size(right, self.budget)
            if isinstance(op, (ast.In, ast.NotIn)) and not isinstance(right, (str, list, tuple, dict)):
                raise TypeError(f"'in' needs a string, list, tuple or dict on its right, not {_kind(right)!r}")
            if not _CMPOPS[type(op)](left, right):
                return False
            left = right
        return True

    def _IfExp(self, node):
        return self.eval(node.body) if self.eval(node.test) else self.eval(node.orelse)

    def _Subscript(self, node):
        value = self.eval(node.value)
        if not isinstance(value, (str, list, tuple, dict)):
            raise TypeError(f"a {_kind(value)} cannot be subscripted")
        if isinstance(node.slice, ast.Slice):
            s = node.slice
            parts = [None if p is None else self.eval(p) for p in (s.lower, s.upper, s.step)]
            if any(p is not None and not isinstance(p, int) for p in parts):
                raise TypeError("slice indices must be integers")
            if isinstance(value, dict):
                raise TypeError("a dict cannot be sliced")
            result = value[slice(*parts)]
            self.budget.spend(len(result))
            return result
        index = self.eval(node.slice)
        return value[index]

    def _Attribute(self, node):
        value = self.eval(node.value)
        if isinstance(value, dict):  # a namespace, a YAML dict, a xacro include namespace: a key lookup
            try:
                return value[node.attr]
            except (KeyError, AttributeError):
                if isinstance(value, Namespace) and node.attr in _PYTHON_BUILTINS:
                    raise ExpressionRefused(f"the Python builtin {node.attr!r} is not allowed", node.attr) from None
                raise NameError(f"{node.attr!r} is not defined in {_token(node.value, self.text) or 'it'}") \
                    from None
        raise ExpressionRefused(f"attribute access {node.attr!r} is not allowed", node.attr)

    def _Call(self, node):
        fn = self.eval(node.func)
        if not (callable(fn) and _is_function(fn)):
            raise ExpressionRefused(f"calling a value of type {_kind(fn)!r} is not allowed (only the math "
                                    "functions and a few builtins may be called)", _token(node.func, self.text))
        args = [self.eval(a) for a in node.args]
        if len(args) > 1000:
            raise ExpressionLimit("a call with more than 1000 arguments")
        return fn(*args)


def describe(exc: ExpressionRefused) -> str:
    """The one-line reason of a refusal, with the hint of what expressions may use."""
    return f"{exc.why}; {HINT}"
