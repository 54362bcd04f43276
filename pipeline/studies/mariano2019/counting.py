"""Operation counting by instrumentation: a scalar type that counts every arithmetic operation.

The kinematics code of this study (:mod:`.algebra`, :mod:`.closed_form`) is written once, generic
over the scalar type; run on ``float`` it computes, run on :class:`Counted` it also counts.

Counting rules (the same for both algebras; written down in data/studies/mariano2019.yaml)
-----------------------------------------------------------------------------------------
* An operation is counted when at least one operand is a :class:`Counted` (a run-time value).
  Plain Python numbers are compile-time constants: ``float op float`` is folded, free.
* ``+`` and ``-`` -> ``add``; ``*`` -> ``mul``; ``/`` -> ``div``; ``sqrt`` -> ``sqrt``;
  ``sin``, ``cos``, ``atan2`` -> ``trig``; unary minus -> ``neg`` (a sign flip, no flop).
* Multiplication or division by a constant power of two (``0.5``, ``2``) -> ``scale`` (an exponent
  shift; kept apart from ``mul`` because eqs. 21-22 of 003_8b306f4736fa5051.txt do not count the
  halvings of eq. 16). Multiplication by the constants ``1`` / ``-1`` is free / a ``neg``;
  by ``0`` it folds to the constant ``0``; adding the constant ``0`` is free.
* :func:`var` turns a constant into a run-time value (zero cost): a general routine that does not
  know which entries of its inputs are 0 or 1 lifts them, so every product it executes is counted.
"""

from __future__ import annotations

import math
from contextlib import contextmanager
from dataclasses import asdict, dataclass

CATEGORIES = ("trig", "mul", "add", "div", "sqrt", "scale", "neg")
# Table I of 003_8b306f4736fa5051.txt: +,-,x 1 flop; / and sqrt 4 flop; trig 8 flop.
# `scale` is a multiplication by a constant (1 flop); `neg` is a sign flip (0 flop).
FLOP_WEIGHTS = {"trig": 8, "mul": 1, "add": 1, "div": 4, "sqrt": 4, "scale": 1, "neg": 0}
SNAP = 1e-15  # constant sin/cos within this of 0 or +-1 is snapped (cos(pi/2) = 6e-17 is a 0)


@dataclass
class OpCounts:
    """Counts of executed operations, one field per category."""

    trig: int = 0
    mul: int = 0
    add: int = 0
    div: int = 0
    sqrt: int = 0
    scale: int = 0
    neg: int = 0

    def flop(self) -> int:
        """Total with the Table I weights (see :data:`FLOP_WEIGHTS`)."""
        return sum(FLOP_WEIGHTS[k] * getattr(self, k) for k in CATEGORIES)

    def as_dict(self) -> dict:
        return {**asdict(self), "flop": self.flop()}

    def __sub__(self, other: "OpCounts") -> "OpCounts":
        return OpCounts(*(getattr(self, k) - getattr(other, k) for k in CATEGORIES))

    def copy(self) -> "OpCounts":
        return OpCounts(*(getattr(self, k) for k in CATEGORIES))


_COUNTS: list[OpCounts] = []


def _tick(kind: str) -> None:
    if _COUNTS:
        c = _COUNTS[-1]
        setattr(c, kind, getattr(c, kind) + 1)


@contextmanager
def counting():
    """Collect the operations executed inside the block into a fresh :class:`OpCounts`."""
    c = OpCounts()
    _COUNTS.append(c)
    try:
        yield c
    finally:
        _COUNTS.pop()


def snapshot() -> OpCounts:
    """The counts collected so far by the innermost :func:`counting` block."""
    return _COUNTS[-1].copy()


def _is_pow2(x: float) -> bool:
    if x == 0 or not math.isfinite(x):
        return False
    m, _ = math.frexp(abs(x))
    return m == 0.5


class Counted:
    """A float that counts the operations applied to it (see the module docstring)."""

    __slots__ = ("v",)

    def __init__(self, v: float):
        self.v = float(v)

    def __repr__(self) -> str:
        return f"Counted({self.v!r})"

    def __float__(self) -> float:
        return self.v

    # addition and subtraction
    def __add__(self, o):
        if isinstance(o, Counted):
            _tick("add")
            return Counted(self.v + o.v)
        if o == 0:
            return self
        _tick("add")
        return Counted(self.v + o)

    __radd__ = __add__

    def __sub__(self, o):
        if isinstance(o, Counted):
            _tick("add")
            return Counted(self.v - o.v)
        if o == 0:
            return self
        _tick("add")
        return Counted(self.v - o)

    def __rsub__(self, o):
        if o == 0:
            return -self
        _tick("add")
        return Counted(o - self.v)

    def __neg__(self):
        _tick("neg")
        return Counted(-self.v)

    def __pos__(self):
        return self

    def __abs__(self):  # a sign clear, like a comparison: not an arithmetic operation
        return Counted(abs(self.v))

    # comparisons are branches, not counted
    def __lt__(self, o):
        return self.v < value(o)

    def __le__(self, o):
        return self.v <= value(o)

    def __gt__(self, o):
        return self.v > value(o)

    def __ge__(self, o):
        return self.v >= value(o)

    # multiplication and division
    def __mul__(self, o):
        if isinstance(o, Counted):
            _tick("mul")
            return Counted(self.v * o.v)
        if o == 0:
            return 0.0
        if o == 1:
            return self
        if o == -1:
            return -self
        _tick("scale" if _is_pow2(o) else "mul")
        return Counted(self.v * o)

    __rmul__ = __mul__

    def __truediv__(self, o):
        if isinstance(o, Counted):
            _tick("div")
            return Counted(self.v / o.v)
        if o == 1:
            return self
        _tick("scale" if _is_pow2(o) else "div")
        return Counted(self.v / o)

    def __rtruediv__(self, o):
        _tick("div")
        return Counted(o / self.v)


def var(x):
    """A run-time value: lift a constant to :class:`Counted` (no cost); floats pass through."""
    if _COUNTS and not isinstance(x, Counted):
        return Counted(x)
    return x


def value(x) -> float:
    return x.v if isinstance(x, Counted) else float(x)


def _snap(y: float) -> float:
    if abs(y) < SNAP:
        return 0.0
    if abs(abs(y) - 1.0) < SNAP:
        return math.copysign(1.0, y)
    return y


def sin(x):
    if isinstance(x, Counted):
        _tick("trig")
        return Counted(math.sin(x.v))
    return _snap(math.sin(x))


def cos(x):
    if isinstance(x, Counted):
        _tick("trig")
        return Counted(math.cos(x.v))
    return _snap(math.cos(x))


def atan2(y, x):
    if isinstance(y, Counted) or isinstance(x, Counted):
        _tick("trig")
        return Counted(math.atan2(value(y), value(x)))
    return math.atan2(y, x)


def sqrt(x):
    if isinstance(x, Counted):
        _tick("sqrt")
        return Counted(math.sqrt(x.v))
    return math.sqrt(x)
