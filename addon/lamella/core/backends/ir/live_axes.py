"""Table axes for linked parameters: how a node group reads a textured stack (docs/staging.md).

Staging bakes what depends on the view alone into the material table and keeps what a linked
parameter reaches traced. For a large stack that traced part is large (eight coats with media and
textures on two coat roughnesses and the base colour: some 16 000 plan nodes), and Cycles without OSL
(SVM) holds a shader's live values in a stack of 255 floats that such a part overflows: the
material renders black. With table axes, a value that depends on the view and on at most
``MAX_AXES`` linked parameters is baked too, on a table over (view, those parameters), and read
back by multilinear interpolation; only what depends on more linked parameters at once stays
traced.

An axis spans the field's slider range (``Field.soft``), widened to hold the stack's own value;
a texture value outside it is clamped to it. The nodes are evenly spaced in a coordinate that
crowds them where the model moves fastest: for a range the field's hard limits close at both
ends, (2 / pi) asin(sqrt(u)) of the position u in the range, quadratic toward both ends (a
diffuse albedo), and for a roughness the same of r = sqrt(u) (Blender's r = sqrt(alpha)):
quadratic in r toward both ends. Near alpha = 0 the lobes narrow as alpha and a coat's smooth and
rough Fresnel hand over (``fgd.ALPHA_BLEND``), and nodes evenly spaced in r (what the sine
warp of alpha is near 0) interpolated glossy coats across several lobe widths (the sweep over r
in `bench/linked_tables.md`; ``staging`` reads a lobe's own roughness from the tables as its
fourth root, the coordinate this axis is linear in near 0); near alpha = 1 the spreads a coat
adds to the layers below grow without bound. For other fields that cannot be negative (a
thickness, an absorption, an index) sqrt(u), crowding toward the low end where exponentials and
Fresnel terms move fastest; linear otherwise.
A field along which the model oscillates (a film's thickness: its interference colours cycle every
90-150 nm) has evenly spaced nodes at most its ``Field.axis_step`` apart, as many as its range needs
(151 over a film's 0-1500 nm): 17 nodes in the square-root warp interpolated across whole cycles, and
Cycles without OSL and EEVEE rendered the oil film preset's swirl 9.3 % off the OSL shader, which traces
the film. Such an axis keeps its nodes in tables over one or two parameters; in a table over three it
takes ``N_AXIS_WIDE`` times the others' fraction.
Angles get no axis (a linked rotation stays traced), and neither do the angles the model computes
(``staging``: they jump where they wrap).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...layers.schema import ANGLE
from ...param_id import ParamId, r_from_alpha
from ...stack import Stack

N_AXIS = 17  # nodes along a parameter axis (bench/linked_tables.md: the error and size they give)
N_AXIS_WIDE = 9  # along an axis other than a roughness's or an albedo's in a table over three parameters
MAX_AXES = 3  # linked parameters a tabulated value may depend on: tables over (view, p, q, s)


@dataclass(frozen=True)
class LiveAxis:
    """The table axis of parameter ``param`` (model units: GGX alpha, not r): ``n`` nodes over
    [``lo``, ``hi``], evenly spaced in the coordinate ``warp`` of u = (v - lo) / (hi - lo):
    "sqrt": sqrt(u); "sine": (2 / pi) asin(sqrt(u)), which crowds the nodes toward both ends
    (quadratically, like sqrt at the low end); "sine_r": "sine" of sqrt(u), for a roughness
    (quadratic in r = sqrt(alpha) toward both ends); "linear": u."""

    param: str
    lo: float
    hi: float
    n: int = N_AXIS
    warp: str = "sqrt"
    stepped: bool = False  # nodes as many as ``Field.axis_step`` asks (``axis_of``)

    def values(self) -> np.ndarray:
        """The parameter's value at each node (float64, (n,))."""
        x = np.linspace(0.0, 1.0, self.n)
        s2 = np.sin(0.5 * np.pi * x) ** 2
        u = {"sqrt": x * x, "sine": s2, "sine_r": s2 * s2, "linear": x}[self.warp]
        return self.lo + (self.hi - self.lo) * u

    def coord(self, ops, v):
        """The table coordinate in [0, 1] of parameter value ``v`` (backend values): clamped to
        the axis's range."""
        u = ops.clamp((v - self.lo) * (1.0 / (self.hi - self.lo)), 0.0, 1.0)
        if self.warp == "sine":
            return ops.atan2(ops.sqrt(u), ops.sqrt(1.0 - u)) * (2.0 / math.pi)
        if self.warp == "sine_r":  # the sine warp of r = sqrt(u)
            r = ops.sqrt(u)
            return ops.atan2(ops.sqrt(r), ops.sqrt(1.0 - r)) * (2.0 / math.pi)
        return ops.sqrt(u) if self.warp == "sqrt" else u


def axis_nodes(axis: LiveAxis, dims: int) -> int:
    """The nodes of ``axis`` in a table over ``dims`` parameters: ``N_AXIS``, but
    ``N_AXIS_WIDE`` along an index or a colour (eta, k: the model is smooth in them; not a
    roughness or an albedo, the "sine" warps) in a table over three (its size is the product); a
    stepped axis (``axis_of``: a film's thickness) its own nodes, over three parameters
    ``N_AXIS_WIDE / N_AXIS`` of them."""
    if axis.stepped:
        return axis.n if dims < 3 else max(N_AXIS_WIDE, axis.n * N_AXIS_WIDE // N_AXIS)
    return N_AXIS_WIDE if dims >= 3 and axis.warp not in ("sine", "sine_r") else N_AXIS


def field_of(stack: Stack, pid: ParamId):
    """The schema field (``layers.schema.Field``) that model parameter ``pid`` comes from."""
    layer = stack.base if pid.layer is None else stack.coats[pid.layer]
    return next(f for f in layer.kind.fields if f.name == pid.field)


def axis_of(stack: Stack, pid: ParamId, value: float, n: int | None = None) -> LiveAxis | None:
    """The axis of parameter ``pid`` for ``stack`` (its value ``value``), or None where the
    parameter gets none (an angle)."""
    f = field_of(stack, pid)
    if f.type == ANGLE:
        return None
    lo, hi = f.soft if f.soft is not None else (f.lo, f.hi)
    lo, hi = min(lo, value), max(hi, value)
    lo, hi = max(lo, f.lo), min(hi, f.hi)
    if not hi > lo or not math.isfinite(hi - lo):
        return None
    if f.axis_step is not None:  # the model oscillates along it: evenly spaced nodes
        return LiveAxis(pid.name, float(lo), float(hi), n or max(N_AXIS, math.ceil((hi - lo) / f.axis_step) + 1),
                        "linear", stepped=True)
    if (lo, hi) == (f.lo, f.hi):  # a range the model's limits close at both ends (a roughness, an albedo)
        warp = "sine_r" if pid.is_roughness else "sine"
    else:
        warp = "sqrt" if f.lo >= 0.0 else "linear"
    return LiveAxis(pid.name, float(lo), float(hi), n or N_AXIS, warp)


def socket_ranges(axis_tables, ids: dict) -> dict:
    """The range each linked socket's tables span, in the socket's units (a roughness as r,
    ``sockets``): socket name -> (lo, hi), over every axis of ``axis_tables`` that reads one of
    its parameters (``ids``: name -> ``ParamId``; a colour: the widest of its channels')."""
    out: dict = {}
    for tab in axis_tables:
        for a in tab.axes:
            pid = ids[a.param]
            lo, hi = (r_from_alpha(a.lo), r_from_alpha(a.hi)) if pid.is_roughness else (a.lo, a.hi)
            old = out.get(pid.socket, (lo, hi))
            out[pid.socket] = (min(old[0], lo), max(old[1], hi))
    return dict(sorted(out.items()))


def lookup_axes(data: np.ndarray, col: int, c, xs, dtype=np.float32):
    """Column ``col`` of an axis table ``data`` (n_mu, n_1, ..., n_k, columns) at view coordinate
    ``c`` and axis coordinates ``xs`` (k of them, each in [0, 1]): linear along every axis,
    clamped; exactly the arithmetic the emitters print (the view axis blended first, then the
    parameter axes from the last to the first)."""
    dtype = np.dtype(dtype).type
    sizes = data.shape[:-1]

    def cell(x, n):
        x = np.clip(np.asarray(x, dtype=dtype), 0.0, 1.0) * dtype(n - 1)
        i0 = np.minimum(np.floor(x), n - 2).astype(np.int64)
        return i0, (x - i0).astype(dtype)

    cells = [cell(c, sizes[0])] + [cell(x, n) for x, n in zip(xs, sizes[1:])]
    t = data[..., col].astype(dtype)

    # the view axis innermost (as the node group blends it): recurse over the parameter axes first
    def over_params(idx: tuple):
        k = len(idx)
        if k == len(sizes) - 1:
            i0, f = cells[0]
            a, b = t[(i0,) + idx], t[(i0 + 1,) + idx]
            return (a + (b - a) * f).astype(dtype)
        i0, f = cells[k + 1]
        a, b = over_params(idx + (i0,)), over_params(idx + (i0 + 1,))
        return (a + (b - a) * f).astype(dtype)

    return over_params(())


__all__ = ["LiveAxis", "axis_nodes", "field_of", "axis_of", "socket_ranges", "lookup_axes", "N_AXIS", "N_AXIS_WIDE", "MAX_AXES"]
