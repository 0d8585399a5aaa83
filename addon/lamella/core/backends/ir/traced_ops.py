"""The math functions model code may call on its ops, and how every backend computes each: one
table (docs/design.md "One model, three backends").

Besides Python arithmetic and comparisons (which the tracer records as ``add`` ... ``ge``), the
ops ``select``, ``clamp`` and ``lut``, model code calls ``ops.<name>(...)`` for the functions
below. A :class:`TracedOp` says, for one function: its numpy form (in the ops' precision), its
value on plain numbers (the tracer folds constant arithmetic), the OSL expression that prints it,
and the Blender Math nodes that build it. Every backend's ops class derives from :class:`Ops`,
which resolves ``ops.<name>`` through this table to the backend's ``apply``; the OSL printer and
the node-graph lowering read the table too. A new function is one module that calls
:func:`register`, and a test holds every backend to the numpy form.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ...registry import Registry, require_callables


@dataclass(frozen=True)
class TracedOp:
    """``numpy(ops, *xs)``: the value over numpy arrays (``ops.dtype`` is the precision; nothing may
    promote a float32 evaluation); ``fold(*floats)``: the value on Python floats, or None where
    it is not finite (the tracer then keeps the node); ``osl``: an OSL function name, or a format
    string over the printed arguments (``"{0} * {0}"``); ``nodes(math, *xs)``: the node-graph
    form, ``math(OPERATION, *xs)`` building one Blender Math node of that operation and returning
    its output (arguments are node outputs or floats)."""

    name: str
    arity: int
    numpy: Callable
    fold: Callable
    osl: str
    nodes: Callable
    description: str

    def osl_expression(self, args: list[str]) -> str:
        if "{" in self.osl:
            return "(" + self.osl.format(*args) + ")"
        return f"{self.osl}({', '.join(args)})"


def _subclasses(cls) -> list[type]:
    out = []
    for sub in cls.__subclasses__():
        out += [sub, *_subclasses(sub)]
    return out


def _complete(op: TracedOp) -> None:
    if not isinstance(op, TracedOp):
        raise TypeError(f"a traced operation is a TracedOp, got {type(op).__name__}")
    if not op.name.isidentifier() or op.name.startswith("_"):
        raise ValueError(f"traced operation {op.name!r}: the name is what model code calls, ops.<name>")
    taken = [cls.__name__ for cls in (Ops, *_subclasses(Ops)) if op.name in vars(cls)]
    if taken:
        raise ValueError(f"traced operation {op.name!r}: {', '.join(taken)} has a method of that name already")
    if not isinstance(op.arity, int) or op.arity < 1:
        raise ValueError(f"traced operation {op.name!r}: arity is a whole number from 1, got {op.arity!r}")
    if not isinstance(op.osl, str) or not op.osl:
        raise ValueError(f"traced operation {op.name!r}: osl is a function name or a format string")
    require_callables("traced operation", op, "numpy", "fold", "nodes")


OPS: Registry[TracedOp] = Registry("traced operation", _complete)


class Ops:
    """What every backend's ops object is (the numpy backend, the tracer): besides its own
    methods (``const``, ``param``, ``input``, ``select``, ``clamp``, ``lut``, ``set_scope``),
    ``ops.<name>`` of a registered traced operation calls ``self.apply(op, *xs)``."""

    name = "ops"

    def apply(self, op: TracedOp, *xs):
        raise NotImplementedError

    def __getattr__(self, name: str):
        op = OPS.get(name)
        if op is None:
            raise AttributeError(f"{type(self).__name__} has no operation {name!r} (traced operations: "
                                 f"{', '.join(OPS)})")
        return lambda *xs: self.apply(op, *xs)


def register(op: TracedOp) -> TracedOp:
    """Add ``op``: every backend then has it as ``ops.<name>``."""
    return OPS.register(op)


def unregister(op_or_name) -> None:
    """Remove a registered operation (an extension's)."""
    OPS.unregister(op_or_name)


def _math_node(operation: str) -> Callable:
    return lambda math_, *xs: math_(operation, *xs)


def _pow_numpy(ops, x, y):
    return np.power(x, ops.dtype.type(y) if isinstance(y, float) else y)


def _fold(fn):
    """``fn`` on floats, None where Python raises (log(0), sqrt(-1), overflow): the node stays."""
    def folded(*xs):
        try:
            return fn(*xs)
        except (ValueError, OverflowError, ZeroDivisionError):
            return None
    return folded


for _op in (
    TracedOp("sqrt", 1, lambda ops, x: np.sqrt(x), _fold(math.sqrt), "sqrt", _math_node("SQRT"), "square root"),
    TracedOp("exp", 1, lambda ops, x: np.exp(x), _fold(math.exp), "exp", _math_node("EXPONENT"), "e to the x"),
    TracedOp("log", 1, lambda ops, x: np.log(x), _fold(math.log), "log",
             lambda math_, x: math_("LOGARITHM", x, math.e), "natural logarithm"),
    TracedOp("pow", 2, _pow_numpy, _fold(math.pow), "pow", _math_node("POWER"), "x to the y"),
    TracedOp("abs", 1, lambda ops, x: np.abs(x), abs, "fabs", _math_node("ABSOLUTE"), "absolute value"),
    TracedOp("min", 2, lambda ops, a, b: np.minimum(a, b), min, "min", _math_node("MINIMUM"), "smaller of two"),
    TracedOp("max", 2, lambda ops, a, b: np.maximum(a, b), max, "max", _math_node("MAXIMUM"), "larger of two"),
    TracedOp("cos", 1, lambda ops, x: np.cos(x), _fold(math.cos), "cos", _math_node("COSINE"), "cosine"),
    TracedOp("sin", 1, lambda ops, x: np.sin(x), _fold(math.sin), "sin", _math_node("SINE"), "sine"),
    TracedOp("atan2", 2, lambda ops, y, x: np.arctan2(y, x), math.atan2, "atan2", _math_node("ARCTAN2"),
             "angle of (x, y)"),
    TracedOp("floor", 1, lambda ops, x: np.floor(x), _fold(lambda x: float(math.floor(x))), "floor",
             _math_node("FLOOR"), "largest whole number not above"),
):
    register(_op)

__all__ = ["TracedOp", "Ops", "OPS", "register", "unregister"]
