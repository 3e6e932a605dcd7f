"""Count the floating-point operations the kernels really execute, by running them as Python.

With TWBR_JIT=off the kernels are plain Python functions (twbr_common.jit). Run them on `Counted` numbers
and every +, -, *, / (and ** 2), comparison and math call is tallied by kind as it executes: branches,
loops and rates are counted as they happen, not estimated from the source. The kernels' own allocations
(np.empty, np.zeros, ...) and `math` are swapped for counting versions in every twbr module while
`counting()` is active, so intermediate arrays keep counted numbers too.

A flop here is one add, subtract, multiply or divide (an FMA the compiler contracts counts as two, as
rooflines do). Comparisons (min, max, clamps, tests) and math calls (sin, cos, sqrt, ...) are reported
apart: they occupy the floating-point units too, at different costs.
"""

from __future__ import annotations

import contextlib
import math
import sys
from collections import Counter
from collections.abc import Iterator

import numpy as np

if "numba" in sys.modules:  # pragma: no cover - a misuse, said clearly
    raise RuntimeError("flop_count needs the interpreted kernels: import it with TWBR_JIT=off, before twbr")

TALLY: Counter = Counter()
ARITHMETIC = ("add", "sub", "mul", "div")


def _v(x) -> float:
    return x.v if isinstance(x, Counted) else x


class Counted:
    """A float that tallies the operations done with it."""

    __slots__ = ("v",)

    def __init__(self, v) -> None:
        self.v = float(v)

    def _op(self, kind: str, value: float) -> Counted:
        TALLY[kind] += 1
        return Counted(value)

    def __add__(self, o): return self._op("add", self.v + _v(o))
    def __radd__(self, o): return self._op("add", _v(o) + self.v)
    def __sub__(self, o): return self._op("sub", self.v - _v(o))
    def __rsub__(self, o): return self._op("sub", _v(o) - self.v)
    def __mul__(self, o): return self._op("mul", self.v * _v(o))
    def __rmul__(self, o): return self._op("mul", _v(o) * self.v)
    def __truediv__(self, o): return self._op("div", self.v / _v(o))
    def __rtruediv__(self, o): return self._op("div", _v(o) / self.v)

    def __pow__(self, o):
        if _v(o) != 2:
            TALLY["pow"] += 1
            return Counted(self.v ** _v(o))
        return self._op("mul", self.v * self.v)

    def __neg__(self): return Counted(-self.v)  # a sign flip, not a flop
    def __pos__(self): return self
    def __abs__(self): return Counted(abs(self.v))

    def _cmp(self, result: bool) -> bool:
        TALLY["compare"] += 1
        return result

    def __lt__(self, o): return self._cmp(self.v < _v(o))
    def __le__(self, o): return self._cmp(self.v <= _v(o))
    def __gt__(self, o): return self._cmp(self.v > _v(o))
    def __ge__(self, o): return self._cmp(self.v >= _v(o))
    def __eq__(self, o): return self._cmp(self.v == _v(o))
    def __ne__(self, o): return self._cmp(self.v != _v(o))
    def __hash__(self): return hash(self.v)
    def __float__(self): return self.v
    def __int__(self): return int(self.v)
    def __index__(self): return int(self.v)
    def __bool__(self): return self.v != 0.0
    def __round__(self, n=None): return round(self.v, n)
    def __repr__(self): return f"Counted({self.v!r})"


class _CountingMath:
    """`math` for the kernels: each function call is tallied under its name."""

    def __getattr__(self, name: str):
        real = getattr(math, name)
        if not callable(real):
            return real
        if name in ("isnan", "isinf", "isfinite", "floor", "ceil", "copysign"):
            return lambda *a: real(*(_v(x) for x in a))  # bit tests and rounding: not counted

        def counted(*args):
            TALLY[name] += 1
            return Counted(real(*(_v(x) for x in args)))

        return counted


def counted_array(a: np.ndarray) -> np.ndarray:
    """An object array of Counted holding a float array's values (other arrays pass as they are)."""
    if not (isinstance(a, np.ndarray) and a.dtype == np.float64):
        return a
    out = np.empty(a.shape, dtype=object)
    out.ravel()[:] = [Counted(v) for v in a.ravel()]
    return out


class _CountingNumpy:
    """`np` for the kernels: float arrays they allocate hold Counted numbers."""

    def __getattr__(self, name: str):
        real = getattr(np, name)
        if not isinstance(real, np.ufunc):
            return real

        def counted(*args):  # a ufunc on counted numbers: tallied under its name per element
            plain = [np.vectorize(_v, otypes=[float])(a) if isinstance(a, np.ndarray) and a.dtype == object
                     else _v(a) for a in args]
            out = real(*plain)
            TALLY[name] += int(np.size(out))
            return counted_array(out) if isinstance(out, np.ndarray) else Counted(out)

        return counted

    @staticmethod
    def _float(dtype) -> bool:
        return dtype is None or dtype is float or np.dtype(dtype) == np.float64

    def _filled(self, shape, value, dtype=None):
        if not self._float(dtype):
            return np.full(shape, value, dtype=dtype)
        return counted_array(np.full(shape, value, dtype=float))

    def empty(self, shape, dtype=None):
        return self._filled(shape, 0.0, dtype)

    def zeros(self, shape, dtype=None):
        return self._filled(shape, 0.0, dtype)

    def full(self, shape, value, dtype=None):
        return self._filled(shape, _v(value), dtype)

    def empty_like(self, a, dtype=None):
        return self._filled(np.shape(a), 0.0, dtype if dtype is not None else (None if a.dtype == object else a.dtype))

    def zeros_like(self, a, dtype=None):
        return self.empty_like(a, dtype)


@contextlib.contextmanager
def counting() -> Iterator[Counter]:
    """Swap `math` and `np` of every loaded twbr module for counting ones; yields the tally (reset)."""
    swapped = []
    for name, module in list(sys.modules.items()):
        if not name.startswith("twbr_") or module is None:
            continue
        for attr, replacement in (("math", _CountingMath()), ("np", _CountingNumpy())):
            if getattr(module, attr, None) in (math, np):
                swapped.append((module, attr, getattr(module, attr)))
                setattr(module, attr, replacement)
    TALLY.clear()
    try:
        yield TALLY
    finally:
        for module, attr, original in swapped:
            setattr(module, attr, original)


def flops(tally: Counter) -> int:
    return sum(tally[k] for k in ARITHMETIC)
