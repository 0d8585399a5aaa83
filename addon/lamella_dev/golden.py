"""Goldens that hold on any processor: a generated output split into its *structure* (compared
exactly) and its *computed numbers* (compared with a stated tolerance).

The same code computes the last bits of a float differently on another x86-64 processor: numpy's
SIMD kernels of exp, log, sin, arctan, power (AVX2 and AVX-512 paths differ by a few ulps), the
BLAS kernel picked for the processor (the order a dot product sums in), libm's FMA variants. A
golden that hashes float bytes or compares printed floats character for character then fails on
a machine other than the one that made it, while nothing changed. So a golden here is:

* ``structure``: everything that is not a computed number (node types, links, names, table
  shapes, the shader's text with each float literal replaced by ``#``), hashed exactly: a changed
  layout, a node more, an operation swapped is a change;
* ``numbers``: the computed numbers in order, compared with ``TOLERANCE``: a number off by more
  than ``atol + rtol * |stored|`` is a change, float noise (up to thousands of ulps of float32) is
  not.

Integers (indices, counts, sizes) are structure: they do not carry float noise. A float literal is
a token with a decimal point or an exponent (``0.5``, ``1e-06``, ``-3.0``); the emitters print
every float that way (``backends.osl.emit._literal``), so an integer-looking token is an integer.
"""
from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import json
import numbers
import re

import numpy as np


@dataclasses.dataclass(frozen=True)
class Tolerance:
    """Two numbers agree when ``|fresh - stored| <= atol + rtol * |stored|``."""

    rtol: float
    atol: float

    def __str__(self) -> str:
        return f"{self.atol:g} + {self.rtol:g} |x|"


# Float32 has 24 bits of mantissa (6e-8 relative): 1e-5 is about 170 of its ulps, far above the
# few ulps processors differ by, and far below what a render shows (a preset's value changed by
# 0.1 % moves its tables by about 1e-3).
TOLERANCE = Tolerance(rtol=1e-5, atol=1e-6)

# A number in printed text: not part of an identifier (``table_8``, ``mt0_a``), a sign only when
# nothing but an operator or bracket precedes it.
_NUMBER = re.compile(r"(?<![\w.])(?:(?<=[\s(\[{,=:*/+])-)?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?(?![\w.])")
PLACEHOLDER = "#"


def _is_float_token(token: str) -> bool:
    return "." in token or "e" in token or "E" in token


def split_text(text: str) -> tuple[str, np.ndarray]:
    """(``text`` with each float literal replaced by ``#``, those literals' values in order)."""
    values: list[float] = []

    def take(m: re.Match) -> str:
        token = m.group(0)
        if not _is_float_token(token):
            return token
        values.append(float(token))
        return PLACEHOLDER

    return _NUMBER.sub(take, text), np.array(values, dtype=np.float64)


def split_values(obj) -> tuple[object, list[float]]:
    """(``obj`` as plain JSON values with every float replaced by ``#``, those floats in order).
    Dataclasses, dicts (by sorted key), lists, tuples and numpy scalars are walked; ints, bools,
    strings and None are structure."""
    values: list[float] = []

    def walk(o):
        if dataclasses.is_dataclass(o) and not isinstance(o, type):
            return [type(o).__name__, walk(dataclasses.asdict(o))]
        if isinstance(o, dict):
            return [[str(k), walk(v)] for k, v in sorted(o.items(), key=lambda kv: str(kv[0]))]
        if isinstance(o, (list, tuple)):
            return [walk(v) for v in o]
        if isinstance(o, (bool, str)) or o is None:
            return o
        if isinstance(o, numbers.Integral):
            return int(o)
        if isinstance(o, numbers.Real):
            values.append(float(o))
            return PLACEHOLDER
        raise TypeError(f"cannot split {type(o).__name__}")

    return walk(obj), values


def digest(*parts) -> str:
    """sha256 (16 hex digits) of structure parts: strings as they are, anything else as JSON."""
    h = hashlib.sha256()
    for p in parts:
        h.update((p if isinstance(p, str) else json.dumps(p, sort_keys=True)).encode())
        h.update(b"\0")
    return h.hexdigest()[:16]


def number_changes(stored, fresh, tolerance: Tolerance = TOLERANCE) -> str | None:
    """None when ``fresh`` agrees with ``stored`` number for number within ``tolerance``; else one
    line: how many differ, and the largest difference and where."""
    stored = np.asarray(stored, dtype=np.float64).reshape(-1)
    fresh = np.asarray(fresh, dtype=np.float64).reshape(-1)
    if stored.shape != fresh.shape:
        return f"{fresh.size} numbers where {stored.size} were stored"
    off = np.abs(fresh - stored) - (tolerance.atol + tolerance.rtol * np.abs(stored))
    bad = ~(off <= 0.0)  # a NaN on either side is a change
    if not bad.any():
        return None
    gap = np.abs(fresh - stored)
    gap = np.where(np.isnan(gap), np.inf, gap)  # a NaN is the worst
    i = int(np.argmax(np.where(bad, gap, -1.0)))
    return (f"{int(bad.sum())} of {stored.size} numbers differ by more than {tolerance} (largest at #{i}: "
            f"{fresh[i]:.9g} where {stored[i]:.9g} was stored)")


# ---------------------------------------------------------------- for tests: float noise, made on purpose
def nudge(values, ulps: int, rng: np.random.Generator, dtype=np.float32) -> np.ndarray:
    """``values`` each moved by a random whole number of ``dtype`` ulps in [-ulps, ulps]: what
    another processor may compute (float32's ulps are the coarser, so they cover float64's)."""
    v = np.asarray(values, dtype=dtype).copy()
    steps = rng.integers(-ulps, ulps + 1, size=v.shape)
    for k in range(1, ulps + 1):
        v = np.where(steps >= k, np.nextafter(v, dtype(np.inf)), v)
        v = np.where(steps <= -k, np.nextafter(v, dtype(-np.inf)), v)
    return v


def nudge_text(text: str, ulps: int, rng: np.random.Generator) -> str:
    """``text`` with every float literal moved by up to ``ulps`` float32 ulps and printed again
    (as the emitters print: the shortest repr)."""
    _, values = split_text(text)
    moved = iter(nudge(values, ulps, rng).astype(np.float64).tolist())

    def put(m: re.Match) -> str:
        return repr(next(moved)) if _is_float_token(m.group(0)) else m.group(0)

    return _NUMBER.sub(put, text)


def processor_noise(values, ulps: int):
    """``values`` as another processor's kernel might return them: each moved by a whole number of
    ulps in [-ulps, ulps] that is a function of the value itself (the same input gives the same
    output on any one machine, so values computed alike stay equal), whole numbers (0, 1, 8 ...)
    left as they are (every implementation returns an exact result exactly: exp(0), cos(0),
    power(2, 3)). Float64 or float32 arrays and scalars."""
    v = np.asarray(values)
    if not np.issubdtype(v.dtype, np.floating) or v.dtype.itemsize not in (4, 8):
        return values
    uint = np.uint64 if v.dtype.itemsize == 8 else np.uint32
    bits = np.ascontiguousarray(v).view(uint).astype(np.uint64).reshape(v.shape)
    steps = ((bits * np.uint64(0x9E3779B97F4A7C15)) >> np.uint64(40)) % np.uint64(2 * ulps + 1)
    steps = steps.astype(np.int64) - ulps
    out = v.copy()
    for k in range(1, ulps + 1):
        out = np.where(steps >= k, np.nextafter(out, v.dtype.type(np.inf)), out)
        out = np.where(steps <= -k, np.nextafter(out, v.dtype.type(-np.inf)), out)
    out = np.where(np.isfinite(v) & (v == np.round(v)), v, out)
    return out if isinstance(values, np.ndarray) else v.dtype.type(out[()])


# numpy's functions whose last bits depend on the processor (SIMD kernels, BLAS, reductions over
# SIMD lanes); sqrt and the four operations are correctly rounded everywhere
PROCESSOR_DEPENDENT = ("exp", "expm1", "log", "log1p", "log2", "log10", "sin", "cos", "tan", "arcsin", "arccos",
                       "arctan", "arctan2", "sinh", "cosh", "tanh", "power", "hypot", "cbrt", "dot", "matmul",
                       "einsum", "sum", "mean")


@contextlib.contextmanager
def numpy_of_another_processor(ulps: int = 4):
    """Within the block, numpy's ``PROCESSOR_DEPENDENT`` functions (called as ``np.<name>``) return
    their results moved by ``processor_noise``: code run inside computes as it might on another
    processor. numpy's own attributes are restored on leaving."""
    def noisy(f):
        @functools.wraps(f)
        def g(*args, **kwargs):
            out = f(*args, **kwargs)
            return processor_noise(out, ulps) if isinstance(out, (np.ndarray, np.floating)) else out
        return g

    saved = {name: getattr(np, name) for name in PROCESSOR_DEPENDENT}
    try:
        for name, f in saved.items():
            setattr(np, name, noisy(f))
        yield
    finally:
        for name, f in saved.items():
            setattr(np, name, f)
