"""The layer stack: validation, defaults, normalisation (DESIGN.md, "Contract: the stack description").

A stack is JSON-compatible data: coats listed top to bottom, then a base. This module turns that
data into immutable dataclasses and rejects bad input with a :class:`StackError` whose message
names the layer and the field, so every entry point (UI, JSON, Python API, CLI) can show it as is.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any, Mapping

MAX_COATS = 8


class StackError(ValueError):
    """Invalid stack description. ``layer`` and ``field`` say where (``layer`` is ``"base"``,
    ``"stack"`` or ``"coat N"``)."""

    def __init__(self, layer: str, field_name: str | None, message: str):
        self.layer = layer
        self.field = field_name
        where = layer if field_name is None else f"{layer}, field '{field_name}'"
        super().__init__(f"{where}: {message}")


Pair = tuple[float, float]
RGB = tuple[float, float, float]


@dataclass(frozen=True)
class Coat:
    """A slab: top interface (medium above -> index ``ior``) and a homogeneous interior."""

    ior: float = 1.5
    roughness: Pair = (0.0, 0.0)  # GGX alpha along the (rotated) x and y axes
    rotation: float = 0.0  # radians, anisotropy axes about the normal, relative to the tangent
    thickness: float = 0.0
    sigma_a: RGB = (0.0, 0.0, 0.0)
    sigma_s: RGB = (0.0, 0.0, 0.0)
    g: float = 0.0
    type: str = field(default="coat", init=False)

    @property
    def is_smooth(self) -> bool:
        return self.roughness[0] == 0.0 and self.roughness[1] == 0.0

    @property
    def has_absorption(self) -> bool:
        return self.thickness > 0.0 and any(s > 0.0 for s in self.sigma_a)

    @property
    def has_scattering(self) -> bool:
        return self.thickness > 0.0 and any(s > 0.0 for s in self.sigma_s)


@dataclass(frozen=True)
class Conductor:
    """Opaque metal base with absolute complex index ``eta + i k`` (RGB)."""

    eta: RGB = (0.143, 0.374, 1.442)
    k: RGB = (3.983, 2.385, 1.603)
    roughness: Pair = (0.0, 0.0)
    rotation: float = 0.0
    type: str = field(default="conductor", init=False)


@dataclass(frozen=True)
class Diffuse:
    """Opaque Lambertian base."""

    albedo: RGB = (0.8, 0.8, 0.8)
    type: str = field(default="diffuse", init=False)


@dataclass(frozen=True)
class Dielectric:
    """Transmissive substrate (a glass half-space): light crossing it leaves the stack downward."""

    ior: float = 1.5
    roughness: Pair = (0.0, 0.0)
    rotation: float = 0.0
    type: str = field(default="dielectric", init=False)


Base = Conductor | Diffuse | Dielectric
_BASE_TYPES: dict[str, type] = {"conductor": Conductor, "diffuse": Diffuse, "dielectric": Dielectric}


@dataclass(frozen=True)
class Stack:
    """Coats top to bottom, then the base. Build with :meth:`from_dict` / :meth:`from_json`."""

    coats: tuple[Coat, ...]
    base: Base
    name: str = ""

    # ----------------------------------------------------------------- construction
    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "Stack":
        if not isinstance(d, Mapping):
            raise StackError("stack", None, f"expected an object, got {type(d).__name__}")
        _check_keys("stack", d, {"name", "layers", "base"})
        name = d.get("name", "")
        if not isinstance(name, str):
            raise StackError("stack", "name", f"expected a string, got {type(name).__name__}")
        layers = d.get("layers", [])
        if not isinstance(layers, (list, tuple)):
            raise StackError("stack", "layers", f"expected a list of coats, got {type(layers).__name__}")
        if len(layers) > MAX_COATS:
            raise StackError("stack", "layers", f"{len(layers)} coats; at most {MAX_COATS} are supported")
        coats = tuple(_parse_coat(i, c) for i, c in enumerate(layers))
        if "base" not in d or d["base"] is None or d["base"] == {}:
            raise StackError("base", None, "missing: a stack needs a base (conductor, diffuse or dielectric)")
        return cls(coats=coats, base=_parse_base(d["base"]), name=name)

    @classmethod
    def from_json(cls, text: str) -> "Stack":
        try:
            d = json.loads(text)
        except json.JSONDecodeError as e:
            raise StackError("stack", None, f"not valid JSON ({e})") from None
        return cls.from_dict(d)

    @classmethod
    def coerce(cls, s: "Stack | Mapping[str, Any] | str") -> "Stack":
        """Accept a Stack, a dict or JSON text."""
        if isinstance(s, Stack):
            return s
        if isinstance(s, str):
            return cls.from_json(s)
        return cls.from_dict(s)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"name": self.name, "layers": [], "base": None}
        for c in self.coats:
            out["layers"].append({
                "type": "coat", "ior": c.ior, "roughness": list(c.roughness), "rotation": c.rotation,
                "thickness": c.thickness, "sigma_a": list(c.sigma_a), "sigma_s": list(c.sigma_s),
                "g": c.g,
            })
        b = self.base
        if isinstance(b, Conductor):
            out["base"] = {"type": "conductor", "eta": list(b.eta), "k": list(b.k),
                           "roughness": list(b.roughness), "rotation": b.rotation}
        elif isinstance(b, Diffuse):
            out["base"] = {"type": "diffuse", "albedo": list(b.albedo)}
        else:
            out["base"] = {"type": "dielectric", "ior": b.ior, "roughness": list(b.roughness),
                           "rotation": b.rotation}
        return out

    def to_json(self, indent: int | None = 2) -> str:
        return json.dumps(self.to_dict(), indent=indent)

    # ----------------------------------------------------------------- structure queries
    @property
    def has_media(self) -> bool:
        return any(c.has_absorption or c.has_scattering for c in self.coats)

    @property
    def has_scattering(self) -> bool:
        return any(c.has_scattering for c in self.coats)

    def interface_iors(self) -> list[float]:
        """Absolute index of every medium from the top: [1.0 (vacuum), coat 0, ..., coat n-1]."""
        return [1.0] + [c.ior for c in self.coats]


# --------------------------------------------------------------------- parsing helpers
def _check_keys(layer: str, d: Mapping[str, Any], allowed: set[str]) -> None:
    for k in d:
        if k not in allowed:
            raise StackError(layer, str(k), f"unknown key (allowed: {', '.join(sorted(allowed))})")


def _number(layer: str, name: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise StackError(layer, name, f"expected a number, got {type(v).__name__} {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise StackError(layer, name, f"must be finite, got {x}")
    return x


def _rgb(layer: str, name: str, v: Any, *, nonneg: bool = True, upper: float | None = None) -> RGB:
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        v = [v, v, v]
    if not isinstance(v, (list, tuple)) or len(v) != 3:
        raise StackError(layer, name, f"expected an RGB triple (3 numbers), got {v!r}")
    out = tuple(_number(layer, name, x) for x in v)
    if nonneg and any(x < 0 for x in out):
        raise StackError(layer, name, f"must be >= 0, got {list(out)}")
    if upper is not None and any(x > upper for x in out):
        raise StackError(layer, name, f"must be <= {upper}, got {list(out)}")
    return out  # type: ignore[return-value]


def _roughness(layer: str, v: Any) -> Pair:
    if isinstance(v, (list, tuple)):
        if len(v) != 2:
            raise StackError(layer, "roughness", f"expected a number or [alpha_x, alpha_y], got {v!r}")
        ax, ay = (_number(layer, "roughness", x) for x in v)
    else:
        ax = ay = _number(layer, "roughness", v)
    for a in (ax, ay):
        if not 0.0 <= a <= 1.0:
            raise StackError(layer, "roughness", f"GGX alpha must lie in [0, 1], got {a}")
    return (ax, ay)


def _ior(layer: str, v: Any) -> float:
    x = _number(layer, "ior", v)
    if x <= 0.0:
        raise StackError(layer, "ior", f"must be > 0, got {x}")
    return x


def _parse_coat(i: int, c: Any) -> Coat:
    layer = f"coat {i}"
    if not isinstance(c, Mapping):
        raise StackError(layer, None, f"expected an object, got {type(c).__name__}")
    _check_keys(layer, c, {"type", "ior", "roughness", "rotation", "thickness", "sigma_a", "sigma_s", "g"})
    if c.get("type", "coat") != "coat":
        raise StackError(layer, "type", f"layers must be coats (type 'coat'), got {c.get('type')!r}")
    thickness = _number(layer, "thickness", c.get("thickness", 0.0))
    if thickness < 0:
        raise StackError(layer, "thickness", f"must be >= 0, got {thickness}")
    g = _number(layer, "g", c.get("g", 0.0))
    if abs(g) >= 1.0:
        raise StackError(layer, "g", f"Henyey-Greenstein g must satisfy |g| < 1, got {g}")
    return Coat(
        ior=_ior(layer, c.get("ior", 1.5)),
        roughness=_roughness(layer, c.get("roughness", 0.0)),
        rotation=_number(layer, "rotation", c.get("rotation", 0.0)),
        thickness=thickness,
        sigma_a=_rgb(layer, "sigma_a", c.get("sigma_a", [0.0, 0.0, 0.0])),
        sigma_s=_rgb(layer, "sigma_s", c.get("sigma_s", [0.0, 0.0, 0.0])),
        g=g,
    )


def _parse_base(b: Any) -> Base:
    layer = "base"
    if not isinstance(b, Mapping):
        raise StackError(layer, None, f"expected an object, got {type(b).__name__}")
    t = b.get("type")
    if t not in _BASE_TYPES:
        raise StackError(layer, "type", f"expected one of {sorted(_BASE_TYPES)}, got {t!r}")
    if t == "conductor":
        _check_keys(layer, b, {"type", "eta", "k", "roughness", "rotation"})
        eta = _rgb(layer, "eta", b.get("eta", list(Conductor.eta)))
        if any(x <= 0 for x in eta):
            raise StackError(layer, "eta", f"must be > 0, got {list(eta)}")
        return Conductor(eta=eta, k=_rgb(layer, "k", b.get("k", list(Conductor.k))),
                         roughness=_roughness(layer, b.get("roughness", 0.0)),
                         rotation=_number(layer, "rotation", b.get("rotation", 0.0)))
    if t == "diffuse":
        _check_keys(layer, b, {"type", "albedo"})
        return Diffuse(albedo=_rgb(layer, "albedo", b.get("albedo", list(Diffuse.albedo)), upper=1.0))
    _check_keys(layer, b, {"type", "ior", "roughness", "rotation"})
    return Dielectric(ior=_ior(layer, b.get("ior", 1.5)),
                      roughness=_roughness(layer, b.get("roughness", 0.0)),
                      rotation=_number(layer, "rotation", b.get("rotation", 0.0)))
