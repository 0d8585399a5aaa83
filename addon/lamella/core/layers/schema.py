"""The field schema of a layer kind: one declaration per field that the stack parser, ``to_dict``
and the Blender properties all read (DESIGN.md "Where a new kind goes").

A :class:`Field` says what a value is (a number, an RGB triple, a GGX roughness that may be
anisotropic), its default, its hard limits (rejected outside) and soft limits (the range a UI
slider offers), its unit and a one-line description. :func:`layer_kind` turns a tuple of fields
into an immutable dataclass with a parser and a serialiser, so a kind's field list is written
once.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, make_dataclass
from typing import Any, Callable, Mapping


class StackError(ValueError):
    """Invalid stack description. ``layer`` and ``field`` say where (``layer`` is ``"base"``,
    ``"stack"`` or ``"coat N"``)."""

    def __init__(self, layer: str, field_name: str | None, message: str):
        self.layer = layer
        self.field = field_name
        where = layer if field_name is None else f"{layer}, field '{field_name}'"
        super().__init__(f"{where}: {message}")


# Value types a field can hold (what the parser accepts and what to_dict writes)
FLOAT = "float"  # a finite number
RGB = "rgb"  # three finite numbers (a single number is splatted)
ROUGHNESS = "roughness"  # GGX alpha: a number (isotropic) or [alpha_x, alpha_y]; stored as a pair
ANGLE = "angle"  # radians, any finite value


@dataclass(frozen=True)
class Field:
    """One field of a layer kind.

    ``lo``/``hi`` are hard limits (``None``: unbounded); ``lo_open``/``hi_open`` make them strict.
    ``soft`` is the (lo, hi) range a UI slider offers. ``unit`` is shown next to the value.
    ``label`` is the name a user interface shows (default: the field name in title case),
    ``color`` marks an RGB field that is a reflectance (a colour picker makes sense), and
    ``group`` names the collapsible part of a panel the field belongs to ("" : the main part)."""

    name: str
    type: str
    default: Any
    description: str
    unit: str = ""
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    soft: tuple[float, float] | None = None
    label: str = ""
    color: bool = False
    group: str = ""

    @property
    def ui_label(self) -> str:
        return self.label or self.name.replace("_", " ").title()

    def limits_text(self) -> str:
        lo = "-inf" if self.lo is None else f"{self.lo:g}"
        hi = "inf" if self.hi is None else f"{self.hi:g}"
        return f"{'(' if self.lo_open or self.lo is None else '['}{lo}, {hi}{')' if self.hi_open or self.hi is None else ']'}"

    def check_bounds(self, layer: str, x: float, shown) -> None:
        bad_lo = self.lo is not None and (x <= self.lo if self.lo_open else x < self.lo)
        bad_hi = self.hi is not None and (x >= self.hi if self.hi_open else x > self.hi)
        if bad_lo or bad_hi:
            raise StackError(layer, self.name, f"must lie in {self.limits_text()}{' ' + self.unit if self.unit else ''}, "
                                               f"got {shown}")

    # ----------------------------------------------------------------- parse / serialise
    def parse(self, layer: str, v: Any):
        if self.type == FLOAT or self.type == ANGLE:
            x = _number(layer, self.name, v)
            self.check_bounds(layer, x, x)
            return x
        if self.type == RGB:
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                v = [v, v, v]
            if not isinstance(v, (list, tuple)) or len(v) != 3:
                raise StackError(layer, self.name, f"expected an RGB triple (3 numbers), got {v!r}")
            out = tuple(_number(layer, self.name, x) for x in v)
            for x in out:
                self.check_bounds(layer, x, list(out))
            return out
        if self.type == ROUGHNESS:
            if isinstance(v, (list, tuple)):
                if len(v) != 2:
                    raise StackError(layer, self.name, f"expected a number or [alpha_x, alpha_y], got {v!r}")
                pair = tuple(_number(layer, self.name, x) for x in v)
            else:
                x = _number(layer, self.name, v)
                pair = (x, x)
            for x in pair:
                self.check_bounds(layer, x, x)
            return pair
        raise TypeError(f"unknown field type {self.type!r}")

    def to_json(self, value):
        return list(value) if self.type in (RGB, ROUGHNESS) else value


def _number(layer: str, name: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise StackError(layer, name, f"expected a number, got {type(v).__name__} {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise StackError(layer, name, f"must be finite, got {x}")
    return x


@dataclass(frozen=True)
class LayerKind:
    """A kind of layer: its ``type`` string, its role (``"coat"`` or ``"base"``), its fields, the
    immutable dataclass holding a parsed layer, and what the models need from it:

    ``params(ops, prefix, layer)``: the layer's parameters as backend values (shader inputs when
    traced), a dict the kind's own ``response`` and the models read;
    ``response(ops, p, mu, alpha, n_above)`` (bases only): a :class:`BaseResponse`, the base's
    energies for light arriving at cosine ``mu`` from a medium of index ``n_above``."""

    type: str
    role: str
    fields: tuple[Field, ...]
    cls: type
    description: str
    params: Callable
    response: Callable | None = None

    def field(self, name: str) -> Field:
        return next(f for f in self.fields if f.name == name)

    def parse(self, layer: str, d: Any):
        if not isinstance(d, Mapping):
            raise StackError(layer, None, f"expected an object, got {type(d).__name__}")
        allowed = {"type"} | {f.name for f in self.fields}
        for k in d:
            if k not in allowed:
                raise StackError(layer, str(k), f"unknown key (allowed: {', '.join(sorted(allowed))})")
        return self.cls(**{f.name: f.parse(layer, d.get(f.name, f.default)) for f in self.fields})

    def to_dict(self, layer) -> dict[str, Any]:
        return {"type": self.type, **{f.name: f.to_json(getattr(layer, f.name)) for f in self.fields}}


def layer_kind(type_name: str, role: str, class_name: str, fields_: tuple[Field, ...], description: str,
               params: Callable, response: Callable | None = None, namespace: dict | None = None) -> LayerKind:
    """Build a layer kind and its frozen dataclass (fields in schema order, defaults from the
    schema, a read-only ``type`` attribute, and ``kind``: the LayerKind itself)."""
    specs = [(f.name, Any, field(default=_frozen_default(f))) for f in fields_]
    specs.append(("type", str, field(default=type_name, init=False)))
    cls = make_dataclass(class_name, specs, frozen=True, namespace=dict(namespace or {}))
    cls.__doc__ = description
    kind = LayerKind(type_name, role, tuple(fields_), cls, description, params, response)
    cls.kind = kind  # a class attribute, not a field: equality and to_dict ignore it
    return kind


def _frozen_default(f: Field):
    """Defaults as the parser would store them (tuples, pairs), so ``Kind()`` equals parsing {}."""
    if f.type == ROUGHNESS and not isinstance(f.default, (list, tuple)):
        return (float(f.default), float(f.default))
    if isinstance(f.default, list):
        return tuple(f.default)
    return f.default


__all__ = ["StackError", "Field", "LayerKind", "layer_kind", "FLOAT", "RGB", "ROUGHNESS", "ANGLE"]
