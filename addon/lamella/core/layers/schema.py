"""The field schema of a layer kind: one declaration per field that the stack parser, ``to_dict``
and the Blender properties all read (docs/design.md "Where a new kind goes").

A :class:`Field` says what a value is (a number, an RGB triple, a GGX roughness that may be
anisotropic), its default, its hard limits (rejected outside) and soft limits (the range a UI
slider offers), its unit and a one-line description. :func:`layer_kind` turns a tuple of fields
into an immutable dataclass with a parser and a serialiser, so a kind's field list is written
once.
"""
from __future__ import annotations

import math
import numbers
import struct
from dataclasses import dataclass, field, make_dataclass
from typing import Any, Callable, Mapping

from ..param_id import ALPHA


class StackError(ValueError):
    """Invalid stack description. ``layer`` and ``field`` say where (``layer`` is ``"base"``,
    ``"stack"`` or ``"coat N"``)."""

    def __init__(self, layer: str, field_name: str | None, message: str):
        self.layer = layer
        self.field = field_name
        where = layer if field_name is None else f"{layer}, field '{field_name}'"
        super().__init__(f"{where}: {message}")


FLOAT32_MAX = 3.4028234663852886e38  # the largest finite float32: shaders compute in float32

# Hard limits shared by kinds (closed; ``Field``): wide enough for any physical material, narrow
# enough that every model stays finite on them in float32 (tests/unit/test_stability.py)
# A dielectric's index (coat interior, glass base). Transparent materials span about 1 to 3 (rutile
# 2.9); indices below 1 only stand for a lower index than the medium above. Beyond the range the
# light trapped between layers bounces so often that float32 rounding, amplified by the
# inter-reflection sums, shows in the energy: at ior 100 the transfer-matrix models' albedo
# exceeded 1 by 1.5 % in float32 (`lamella stress`); within it by at most about 1e-4.
IOR_MIN, IOR_MAX = 0.25, 4.0
ANGLE_MAX = 1000.0  # radians either way: a rotation is meaningful modulo 2 pi
THICKNESS_MAX = 1e4  # length units
SIGMA_MAX = 1e6  # 1 / length units: optical depths up to 1e10
G_MAX = 0.999999  # |g| < 1: Henyey-Greenstein's forward/backward limit is a delta

# Value types a field can hold (what the parser accepts and what to_dict writes)
FLOAT = "float"  # a finite number
RGB = "rgb"  # three finite numbers (a single number is splatted)
ROUGHNESS = "roughness"  # GGX alpha: a number (isotropic) or [alpha_x, alpha_y]; stored as a pair
ANGLE = "angle"  # radians, any finite value
BOOL = "bool"  # true or false: a choice of the layer's structure (never a shader input)


@dataclass(frozen=True)
class Field:
    """One field of a layer kind.

    ``lo``/``hi`` are the hard limits, closed, both required: a value outside is rejected, never
    clamped, and the Blender property holding the field has the same min and max, so whatever the
    parser accepts is stored as given (to float32 precision: bounds are compared in float32, the
    precision Blender stores). Every limit lies well inside float32's range, the precision the
    shaders compute in. ``soft`` is the (lo, hi) range a UI slider offers. ``unit`` is shown next to the value.
    ``label`` is the name a user interface shows (default: the field name in title case),
    ``color`` marks an RGB field that is a reflectance (a colour picker makes sense), and
    ``group`` names the collapsible part of a panel the field belongs to ("" : the main part).
    ``axis_step``: where the model oscillates in the field (a film's interference colours cycle with
    its thickness), the widest spacing of the nodes of a table over it (``live_axes``: evenly spaced
    nodes, as many as the range needs); None: the table's usual nodes."""

    name: str
    type: str
    default: Any
    description: str
    unit: str = ""
    lo: float | None = None
    hi: float | None = None
    soft: tuple[float, float] | None = None
    label: str = ""
    color: bool = False
    group: str = ""
    axis_step: float | None = None

    @property
    def param_unit(self) -> str:
        """The unit the models read this field in (a roughness: GGX alpha, whatever ``unit`` shows)."""
        return ALPHA if self.type == ROUGHNESS else self.unit

    @property
    def ui_label(self) -> str:
        return self.label or self.name.replace("_", " ").title()

    def limits_text(self) -> str:
        return "true or false" if self.type == BOOL else f"[{self.lo:g}, {self.hi:g}]"

    def check_bounds(self, layer: str, x: float, shown) -> None:
        x32 = _f32(x)
        if not (_f32(self.lo) <= x32 <= _f32(self.hi)):
            raise StackError(layer, self.name, f"must lie in {self.limits_text()}{' ' + self.unit if self.unit else ''}, "
                                               f"got {shown}")

    # ----------------------------------------------------------------- parse / serialise
    def parse(self, layer: str, v: Any):
        if self.type == BOOL:
            if isinstance(v, bool) or type(v).__name__ == "bool_":
                return bool(v)
            raise StackError(layer, self.name, f"expected true or false, got {type(v).__name__} {_short(v, 40)}")
        if self.type == FLOAT or self.type == ANGLE:
            x = _number(layer, self.name, v)
            self.check_bounds(layer, x, x)
            return x
        if self.type == RGB:
            if isinstance(v, numbers.Real) and not isinstance(v, bool):
                v = [v, v, v]
            v = _sequence(v)
            if v is None or len(v) != 3:
                raise StackError(layer, self.name, f"expected an RGB triple (3 numbers), got {_short(v)}")
            out = tuple(_number(layer, self.name, x) for x in v)
            for x in out:
                self.check_bounds(layer, x, list(out))
            return out
        if self.type == ROUGHNESS:
            seq = _sequence(v)
            if seq is not None:
                v = seq
                if len(v) != 2:
                    raise StackError(layer, self.name, f"expected a number or [alpha_x, alpha_y], got {_short(v)}")
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


def _sequence(v):
    """A list, tuple or one-dimensional numpy array as a list (None for anything else)."""
    if isinstance(v, (list, tuple)):
        return list(v)
    if type(v).__name__ == "ndarray" and getattr(v, "ndim", 0) == 1:
        return list(v)
    return None


def _short(v, n: int = 60) -> str:
    """``repr(v)`` cut to ``n`` characters for a message."""
    r = repr(v)
    return r if len(r) <= n else r[: n - 3] + "..."


def _f32(x: float) -> float:
    """``x`` rounded to float32 (what a Blender property stores), as a Python float."""
    return struct.unpack("f", struct.pack("f", x))[0]


def _number(layer: str, name: str, v: Any) -> float:
    """A finite number from JSON, Python or numpy (``numbers.Real``: float32 and int64 scalars
    from a pipeline's arrays are welcome; booleans are not numbers here)."""
    if isinstance(v, bool) or type(v).__name__ == "bool_" or not isinstance(v, numbers.Real):
        raise StackError(layer, name, f"expected a number, got {type(v).__name__} {_short(v, 40)}")
    try:
        x = float(v)
    except OverflowError:
        raise StackError(layer, name, f"must be finite in float32 (at most {FLOAT32_MAX:.4g} in size), "
                                      f"got an integer of {len(str(abs(int(v))))} digits") from None
    if not math.isfinite(x):
        raise StackError(layer, name, f"must be finite, got {x}")
    if abs(x) > FLOAT32_MAX:
        raise StackError(layer, name, f"must be finite in float32 (at most {FLOAT32_MAX:.4g} in size), got {x:g}")
    return x


@dataclass(frozen=True)
class LayerKind:
    """A kind of layer: its ``type`` string, its role (``"coat"`` or ``"base"``), its fields, the
    immutable dataclass holding a parsed layer, and what the models need from it:

    ``params(ops, slot, layer)``: the layer's parameters as backend values (shader inputs when
    traced), a dict the kind's own ``response`` and the models read; each is declared through
    ``slot`` (``params.LayerSlot``) with ``params.field_param``, ``rgb_param`` or
    ``roughness_params``, which give it its identity (``core.param_id.ParamId``);
    ``response(ops, p, mu, alpha, n_above)`` (bases only): a :class:`BaseResponse`, the base's
    energies for light arriving at cosine ``mu`` from a medium of index ``n_above``.

    What the layer can do, which is all the models and backends route on (never its name):
    ``interface``: it has a rough GGX interface on top: its params hold ``ax``, ``ay`` and
    ``rotation`` (``params.roughness_params``) and, for a base, its response's ``reflectance`` is
    that interface's energy (every coat has one; a Lambertian base has none, and its response is
    its ``albedo``); ``transmits`` (bases): light crossing the interface enters a substrate below
    and leaves the stack downward: its params hold the substrate's absolute ``ior`` and its response
    ``transmittance`` and ``eta``. ``icon``: the Blender icon name a panel shows for the kind."""

    type: str
    role: str
    fields: tuple[Field, ...]
    cls: type
    description: str
    params: Callable
    response: Callable | None = None
    interface: bool = True
    transmits: bool = False
    icon: str = "DOT"

    def field(self, name: str) -> Field:
        return next(f for f in self.fields if f.name == name)

    def parse(self, layer: str, d: Any):
        if not isinstance(d, Mapping):
            raise StackError(layer, None, f"expected an object, got {type(d).__name__}")
        allowed = {"type"} | {f.name for f in self.fields}
        for k in d:
            if k not in allowed:
                raise StackError(layer, str(k)[:60], f"unknown key (allowed: {', '.join(sorted(allowed))})")
        return self.cls(**{f.name: f.parse(layer, d.get(f.name, f.default)) for f in self.fields})

    def to_dict(self, layer) -> dict[str, Any]:
        return {"type": self.type, **{f.name: f.to_json(getattr(layer, f.name)) for f in self.fields}}


# What the models read from a coat besides its params (``Stack`` and ``choose_auto`` read them to
# decide a stack's structure): a coat kind's fields or ``namespace`` properties must provide these.
# A coat kind without a ``coverage`` field covers the whole surface (``coverage`` 1).
COAT_ATTRIBUTES = ("ior", "roughness", "has_absorption", "has_scattering", "is_smooth", "coverage")


def _is_smooth(layer) -> bool:
    return layer.roughness[0] == 0.0 and layer.roughness[1] == 0.0


def layer_kind(type_name: str, role: str, class_name: str, fields_: tuple[Field, ...], description: str,
               params: Callable, response: Callable | None = None, namespace: dict | None = None, *,
               interface: bool = True, transmits: bool = False, icon: str = "DOT") -> LayerKind:
    """Build a layer kind and its frozen dataclass (fields in schema order, defaults from the
    schema, a read-only ``type`` attribute, and ``kind``: the LayerKind itself).

    What the models need of a kind's role is checked here, so a kind that lacks it fails when it
    is declared, not in a shader: a base has a ``response``; a layer with an ``interface`` has
    ``roughness`` and ``rotation`` fields; a coat has an interface and the ``COAT_ATTRIBUTES``
    (``is_smooth`` comes from the roughness unless the kind defines it); a transmitting base has an
    interface and an ``ior`` field."""
    names = {f.name for f in fields_}
    namespace = dict(namespace or {})
    for f in fields_:
        if f.lo is None or f.hi is None or not (-FLOAT32_MAX < f.lo <= f.hi < FLOAT32_MAX):
            raise ValueError(f"{type_name}.{f.name}: every field needs finite float32 hard limits lo <= hi")
    if role not in ("coat", "base"):
        raise ValueError(f"{type_name}: role must be 'coat' or 'base', got {role!r}")
    if role == "base" and response is None:
        raise ValueError(f"{type_name}: a base kind needs a response (its energies)")
    if interface and not {"roughness", "rotation"} <= names:
        raise ValueError(f"{type_name}: a layer with an interface needs 'roughness' and 'rotation' fields")
    if role == "coat":
        namespace.setdefault("is_smooth", property(_is_smooth))
        if "coverage" not in names:
            namespace.setdefault("coverage", 1.0)
        missing = [a for a in COAT_ATTRIBUTES if a not in names and a not in namespace]
        if not interface or missing:
            raise ValueError(f"{type_name}: a coat has an interface and provides {', '.join(COAT_ATTRIBUTES)} "
                             f"(missing: {', '.join(missing) or 'the interface'})")
    if transmits and (role != "base" or not interface or "ior" not in names):
        raise ValueError(f"{type_name}: a transmitting kind is a base with an interface and an 'ior' field")
    specs = [(f.name, Any, field(default=_frozen_default(f))) for f in fields_]
    specs.append(("type", str, field(default=type_name, init=False)))
    cls = make_dataclass(class_name, specs, frozen=True, namespace=namespace)
    cls.__doc__ = description
    kind = LayerKind(type_name, role, tuple(fields_), cls, description, params, response, interface, transmits, icon)
    cls.kind = kind  # a class attribute, not a field: equality and to_dict ignore it
    return kind


def _frozen_default(f: Field):
    """Defaults as the parser would store them (tuples, pairs), so ``Kind()`` equals parsing {}."""
    if f.type == ROUGHNESS and not isinstance(f.default, (list, tuple)):
        return (float(f.default), float(f.default))
    if isinstance(f.default, list):
        return tuple(f.default)
    return f.default


__all__ = ["StackError", "COAT_ATTRIBUTES", "FLOAT32_MAX", "IOR_MIN", "IOR_MAX", "ANGLE_MAX", "THICKNESS_MAX", "SIGMA_MAX", "G_MAX", "Field", "LayerKind", "layer_kind", "FLOAT", "RGB", "ROUGHNESS", "ANGLE", "BOOL"]
