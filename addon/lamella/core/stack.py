"""The layer stack: validation, defaults, normalisation (docs/design.md, "Contract: the stack description").

A stack is JSON-compatible data: coats listed top to bottom, then a base, and the version of the
format it is written in (``stack_format``: older formats are migrated on reading). Each layer is parsed by
its kind's schema (``lamella.core.layers``), which turns it into an immutable dataclass and
rejects bad input with a :class:`StackError` whose message names the layer and the field, so every
entry point (UI, JSON, Python API, CLI) can show it as is.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, replace
from typing import Any, Mapping

from . import stack_format
from .layers import BASE_KINDS, COAT_KINDS, Coat, Conductor, Dielectric, Diffuse, StackError

MAX_COATS = 8
MAX_NAME = 256  # characters in a stack's name (free text: shaders derive safe identifiers from it)
MAX_JSON = 1_000_000  # characters of stack JSON: a stack of eight coats takes about 2,000

Base = Conductor | Diffuse | Dielectric


@dataclass(frozen=True)
class Stack:
    """Coats top to bottom, then the base. Build with :meth:`from_dict` / :meth:`from_json`."""

    coats: tuple[Coat, ...]
    base: Base
    name: str = ""
    # a part of a stack (``part``): the index each coat has in the stack it was taken from, so its
    # parameters keep their names (``coat2_ior`` stays coat 2's); empty: the coats' own positions
    origin: tuple[int, ...] = ()
    # a view of a stack (``models.sides``: the far side of a solid dielectric base, a thin sheet
    # written out): how it was made and from what; its parameters are that stack's. None: as drawn
    view: object = None

    # ----------------------------------------------------------------- construction
    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "Stack":
        if not isinstance(d, Mapping):
            raise StackError("stack", None, f"expected an object, got {type(d).__name__}")
        d = stack_format.upgrade(d)  # older formats migrated, newer ones refused
        for k in d:
            if k not in ("format", "name", "layers", "base"):
                raise StackError("stack", str(k)[:60], "unknown key (allowed: base, format, layers, name)")
        name = d.get("name", "")
        if not isinstance(name, str):
            raise StackError("stack", "name", f"expected a string, got {type(name).__name__}")
        if len(name) > MAX_NAME:
            raise StackError("stack", "name", f"{len(name)} characters; at most {MAX_NAME}")
        layers = d.get("layers", [])
        if not isinstance(layers, (list, tuple)):
            raise StackError("stack", "layers", f"expected a list of coats, got {type(layers).__name__}")
        if len(layers) > MAX_COATS:
            raise StackError("stack", "layers", f"{len(layers)} coats; at most {MAX_COATS} are supported")
        coats = tuple(_parse_layer(f"coat {i}", c, COAT_KINDS, "coat") for i, c in enumerate(layers))
        if "base" not in d or d["base"] is None or d["base"] == {}:
            raise StackError("base", None, f"missing: a stack needs a base ({', '.join(BASE_KINDS)})")
        return cls(coats=coats, base=_parse_layer("base", d["base"], BASE_KINDS, None), name=name)

    @classmethod
    def from_json(cls, text: str) -> "Stack":
        if not isinstance(text, (str, bytes, bytearray)):
            raise StackError("stack", None, f"expected JSON text, got {type(text).__name__}")
        if len(text) > MAX_JSON:
            raise StackError("stack", None, f"{len(text)} characters of JSON; a stack takes at most {MAX_JSON}")
        try:
            d = json.loads(text)
        except json.JSONDecodeError as e:
            raise StackError("stack", None, f"not valid JSON ({e})") from None
        except RecursionError:
            raise StackError("stack", None, "not a stack: JSON nested too deeply") from None
        except (UnicodeDecodeError, ValueError) as e:
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
        return {"format": stack_format.FORMAT, "name": self.name, "layers": [c.kind.to_dict(c) for c in self.coats],
                "base": self.base.kind.to_dict(self.base)}

    def to_json(self, indent: int | None = 2) -> str:
        return json.dumps(self.to_dict(), indent=indent)

    def part(self, kept) -> "Stack":
        """The stack where only the coats whose indices are in ``kept`` are present, over the same
        base (``models.coverage``): those coats, each covering the whole of it. Its parameters are
        named by the coats' indices here (``origin``)."""
        kept = tuple(sorted(kept))
        coats = tuple(replace(self.coats[i], coverage=1.0) if self.coats[i].coverage != 1.0 else self.coats[i]
                      for i in kept)
        return Stack(coats=coats, base=self.base, name=self.name, origin=tuple(self.layer_index(i) for i in kept))

    def layer_index(self, i: int) -> int:
        """The index coat ``i`` of this stack has in the stack it was taken from (``part``)."""
        return self.origin[i] if self.origin else i

    # ----------------------------------------------------------------- structure queries
    @property
    def has_media(self) -> bool:
        return any(c.has_absorption or c.has_scattering for c in self.coats)

    @property
    def has_scattering(self) -> bool:
        return any(c.has_scattering for c in self.coats)

    @property
    def isotropic(self) -> bool:
        """Every interface isotropic: the stack's response is symmetric about the normal."""
        return all(r[0] == r[1] for r in (getattr(layer, "roughness", (0.0, 0.0)) for layer in (*self.coats, self.base)))

    def interface_iors(self) -> list[float]:
        """Absolute index of every medium from the top: [1.0 (vacuum), coat 0, ..., coat n-1]."""
        return [1.0] + [c.ior for c in self.coats]


def _parse_layer(layer: str, d: Any, kinds, default_type: str | None):
    if not isinstance(d, Mapping):
        raise StackError(layer, None, f"expected an object, got {type(d).__name__}")
    t = d.get("type", default_type)
    if not isinstance(t, str) or t not in kinds:
        role = "layers must be" if default_type else "expected one of"
        shown = repr(t) if len(repr(t)) <= 60 else repr(t)[:57] + "..."
        raise StackError(layer, "type", f"{role} {', '.join(repr(k) for k in kinds)}, got {shown}")
    return kinds[t].parse(layer, d)


__all__ = ["Stack", "StackError", "Coat", "Conductor", "Diffuse", "Dielectric", "MAX_COATS", "Base"]
