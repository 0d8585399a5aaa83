"""The math functions model code may call on its ops, and how every backend computes each: one
table (docs/design.md "One model, three backends").

Besides Python arithmetic and comparisons (which the tracer records as ``add`` ... ``ge``), the
ops ``select``, ``clamp`` and ``lut``, model code calls ``ops.<name>(...)`` for the functions
below. A :class:`TracedOp` says, for one function: its numpy form (in the ops' precision), its
value on plain numbers (the tracer folds constant arithmetic), the OSL expression that prints it,
and the Blender Math nodes that build it. :func:`register` installs it on the numpy backend and
the tracer; the OSL printer and the node-graph lowering read this table. A new function is one
module that calls :func:`register`, and a test holds every backend to the numpy form.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np


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


OPS: dict[str, TracedOp] = {}


def register(op: TracedOp) -> TracedOp:
    """Add ``op`` to the table and to the numpy backend and the tracer as ``ops.<name>``."""
    from . import numpy_ops, trace

    if op.name in OPS or hasattr(numpy_ops.NumpyOps, op.name) or hasattr(trace.Tracer, op.name):
        raise ValueError(f"a traced operation or ops method named {op.name!r} exists already")
    OPS[op.name] = op
    numpy_ops.install(op)
    trace.install(op)
    return op


def unregister(name: str) -> None:
    """Remove a registered operation (an extension's) from the table and both backends."""
    from . import numpy_ops, trace

    if OPS.pop(name, None) is not None:
        delattr(numpy_ops.NumpyOps, name)
        delattr(trace.Tracer, name)
        trace._FOLD.pop(name, None)


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
):
    OPS[_op.name] = _op

__all__ = ["TracedOp", "OPS", "register", "unregister"]
