"""The numpy backend of the one model (docs/design.md, "One model, three backends").

Model code never imports numpy: it receives an *ops* object and uses only its operations,
Python arithmetic and comparisons on the values it is handed. ``NumpyOps`` maps those operations
to numpy ufuncs in a fixed precision (float64 or float32), so the same model code is the
reference implementation, the benchmark subject, and (through the tracing backends) the shader.
"""
from __future__ import annotations

import numpy as np

from .. import luts as _luts
from .ir.traced_ops import Ops, TracedOp


class NumpyOps(Ops):
    """Operations over numpy arrays of one dtype.

    ``dtype`` is ``np.float64`` (default) or ``np.float32``; every constant and input is cast so
    that no operation silently promotes a float32 evaluation to float64.
    """

    name = "numpy"

    def __init__(self, dtype=np.float64):
        self.dtype = np.dtype(dtype)

    def set_scope(self, name: str) -> None:
        """Labels only matter to the tracer (readable generated code); nothing to do here."""

    # ------------------------------------------------------------------ values
    def const(self, x):
        """A literal of the model (or a structural constant)."""
        return self.dtype.type(x)

    def param(self, pid, value):
        """A layer's parameter (``core.param_id.ParamId``). For numpy it is just the (cast) value;
        tracers make an input."""
        return np.asarray(value, dtype=self.dtype) if np.ndim(value) else self.dtype.type(value)

    def input(self, name: str, value):
        """A per-shading-point input (a direction component)."""
        return np.asarray(value, dtype=self.dtype)

    # ------------------------------------------------------------------ math
    def apply(self, op: TracedOp, *xs):
        """sqrt, exp, log, pow, abs, min, max, cos, sin, atan2, floor and any registered function
        (``ir.traced_ops``), in this backend's precision."""
        return op.numpy(self, *xs)

    def clamp(self, x, lo, hi):
        return np.minimum(np.maximum(x, lo), hi)

    def select(self, cond, a, b):
        return np.where(cond, a, b).astype(self.dtype, copy=False)

    # ------------------------------------------------------------------ tables
    def lut(self, name: str, *coords):
        """Multilinear look-up in the named table (see ``lamella.core.luts``); coordinates are
        normalised to [0, 1] per axis and clamped."""
        return _multilinear(_typed_table(name, self.dtype), [np.asarray(c, dtype=self.dtype) for c in coords],
                            self.dtype)


_TYPED: dict = {}  # (table name, dtype) -> the table in that precision


def _typed_table(name: str, dtype) -> np.ndarray:
    key = (name, np.dtype(dtype))
    t = _TYPED.get(key)
    if t is None or t.shape != _luts.table(name).shape:
        t = _TYPED[key] = np.ascontiguousarray(_luts.table(name), dtype=dtype)
    return t


def _multilinear(table: np.ndarray, coords, dtype) -> np.ndarray:
    """Clamp-to-edge multilinear interpolation of ``table`` (axes in the order of ``coords``) at
    coordinates in [0, 1] (node i of an axis with n nodes sits at i / (n - 1)). The 2^d corners
    are gathered at once, the first axis the fastest-varying bit of a corner's number; their
    weights are products over the axes in axis order, summed in corner order."""
    coords = np.broadcast_arrays(*coords)
    shape = coords[0].shape
    table = np.ascontiguousarray(table)
    if coords[0].size == 1:  # one point (a model run for one direction): the same sums on scalars
        return np.asarray(_multilinear_point(table, [c.reshape(()) for c in coords], dtype), dtype=dtype).reshape(shape)
    strides = [s // table.itemsize for s in table.strides]
    base = np.zeros(shape, dtype=np.int64)
    w = np.ones((1,) + shape, dtype=dtype)
    offsets = np.zeros(1, dtype=np.int64)
    for c, n, stride in zip(coords, table.shape, strides):
        x = np.clip(c, 0.0, 1.0) * (n - 1)
        i = np.minimum(np.floor(x).astype(np.int64), n - 2)
        base = base + i * stride
        f = (x - i).astype(dtype)
        w = np.concatenate([w * (1 - f), w * f])
        offsets = np.concatenate([offsets, offsets + stride])
    corners = table.reshape(-1).take(base[None] + offsets.reshape((-1,) + (1,) * len(shape)))
    return (w * corners).sum(0, dtype=dtype)


def _multilinear_point(table: np.ndarray, coords, dtype):
    """``_multilinear`` at one point, in scalars of ``dtype``, without the arrays' overhead (a
    look-up is most of a one-direction model run): the same operations in the same order as one
    lane of a batched call, so a direction gets the same bits alone as among others. (Arrays of
    one point summed their corners pairwise, which could differ in the last bit.)"""
    scalar = np.dtype(dtype).type
    one = scalar(1)
    flat = table.reshape(-1)
    base = 0
    ws = [one]
    offsets = [0]
    for c, n, stride in zip(coords, table.shape, (s // table.itemsize for s in table.strides)):
        x = scalar(min(max(c[()], 0.0), 1.0)) * (n - 1)
        i = min(int(np.floor(x)), n - 2)
        base += i * stride
        f = (x - i).astype(dtype)
        ws = [w * (one - f) for w in ws] + [w * f for w in ws]
        offsets = offsets + [o + stride for o in offsets]
    total = scalar(0)
    for w, o in zip(ws, offsets):
        total = total + w * flat[base + o]
    return total
