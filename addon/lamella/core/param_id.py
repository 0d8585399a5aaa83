"""What a model parameter is, as data: its layer, field, channel and unit.

A layer kind declares its parameters through the slot it is given (``LayerSlot``: which layer it
is, and the kind's fields; ``layers.params`` has the helpers), so each parameter the models read carries a ``ParamId`` from the
moment it is made: the coat (0 = top) or the base it belongs to, the schema field it comes from,
the channel ("r", "g", "b" of a colour field; "x", "y" of an anisotropic roughness) and the unit
the model reads it in. Every consumer (the sockets a shader shows, the table axes of linked
inputs, the OSL bundle's README, the Blender node) reads these attributes; none rebuilds them
from the parameter's name, which is only the shader identifier made from them here.

Roughness is the one field whose model unit differs from the unit artists see: the models read
GGX alpha, Blender's sliders and sockets Blender's roughness r, alpha = r * r
(``alpha_from_r``, ``r_from_alpha``: the one conversion between them).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

ALPHA = "GGX alpha"  # the model unit of a roughness field (schema ``Field.unit``)
COLOUR_CHANNELS = ("r", "g", "b")
AXES = ("x", "y")  # the two roughnesses of an anisotropic interface


def alpha_from_r(r):
    """GGX alpha of Blender's roughness ``r`` (a number or a backend value)."""
    return r * r


def r_from_alpha(alpha: float) -> float:
    """Blender's roughness r of GGX ``alpha`` (negative alphas, which no valid stack has, read as 0)."""
    return math.sqrt(max(float(alpha), 0.0))


def layer_prefix(layer: int | None) -> str:
    """The identifier prefix of a layer: ``coat<i>`` (0 = top), or ``base`` (``layer`` None)."""
    return "base" if layer is None else f"coat{layer}"


def layer_label(layer: int | None) -> str:
    """How messages name a layer: "coat 0", "base"."""
    return "base" if layer is None else f"coat {layer}"


def socket_name(layer: int | None, field: str, axis: str = "") -> str:
    """The shader input (socket) of a layer's field in the units artists use: ``coat0_roughness``,
    ``coat1_roughness_x``, ``base_eta`` (a colour's three channels are one socket), ``coat0_ior``."""
    return f"{layer_prefix(layer)}_{field}" + (f"_{axis}" if axis else "")


NORMAL = "normal"  # a layer's own normal: a shader input of its own (``normal_socket``), not a model parameter


def normal_socket(layer_name: str) -> str:
    """The shader input of a layer's own normal, by the layer's prefix: ``coat0_normal``,
    ``base_normal``."""
    return f"{layer_name}_{NORMAL}"


def split_normals(live) -> tuple[tuple, tuple]:
    """``live`` (socket or parameter names) without the layers' normals, and the layers (prefixes,
    sorted) whose normal is among them."""
    normals = tuple(sorted(n[: -len(NORMAL) - 1] for n in live if n.endswith(f"_{NORMAL}")))
    return tuple(n for n in live if not n.endswith(f"_{NORMAL}")), normals


@dataclass(frozen=True)
class ParamId:
    """One model parameter: ``layer`` (coat index from the top, None for the base), ``field`` (the
    layer kind's schema field), ``channel`` ("r", "g", "b" of a colour; "x", "y" of an anisotropic
    roughness; "" otherwise) and ``unit`` (the unit the model reads: ``ALPHA`` for a roughness,
    the field's own otherwise)."""

    layer: int | None
    field: str
    channel: str = ""
    unit: str = ""

    @property
    def is_roughness(self) -> bool:
        return self.unit == ALPHA

    @property
    def is_colour(self) -> bool:
        return self.channel in COLOUR_CHANNELS

    @property
    def name(self) -> str:
        """The shader identifier: ``coat0_alpha``, ``coat1_alpha_x``, ``base_eta_g``, ``coat0_ior``."""
        stem = "alpha" if self.is_roughness else self.field
        return f"{layer_prefix(self.layer)}_{stem}" + (f"_{self.channel}" if self.channel else "")

    @property
    def socket(self) -> str:
        """The socket that feeds it (``socket_name``)."""
        return socket_name(self.layer, self.field, "" if self.is_colour else self.channel)

    @property
    def where(self) -> str:
        """The layer and field, as messages name them: "coat 1, field 'roughness'"."""
        return f"{layer_label(self.layer)}, field '{self.field}'"


@dataclass(frozen=True)
class LayerSlot:
    """The layer a kind's ``params`` declares parameters for: ``layer`` (coat index from the top,
    None for the base) and the kind's ``fields`` (schema ``Field``s, whose ``param_unit`` is each
    parameter's unit). ``str(slot)`` is the layer's identifier prefix (``coat0``, ``base``)."""

    layer: int | None
    fields: tuple

    def __str__(self) -> str:
        return layer_prefix(self.layer)

    def id(self, field: str, channel: str = "") -> ParamId:
        """The ``ParamId`` of this layer's ``field`` (one of the kind's fields) and ``channel``."""
        f = next((f for f in self.fields if f.name == field), None)
        if f is None:
            raise ValueError(f"{layer_label(self.layer)}: a parameter comes from one of the kind's fields "
                             f"({', '.join(f.name for f in self.fields)}), not {field!r}")
        return ParamId(self.layer, field, channel, f.param_unit)


def slots(stack) -> tuple[list[LayerSlot], LayerSlot]:
    """The slots of ``stack``'s coats (top first) and of its base. A part of a stack
    (``Stack.part``) names its coats by their indices in the whole stack."""
    return ([LayerSlot(stack.layer_index(i), c.kind.fields) for i, c in enumerate(stack.coats)],
            LayerSlot(None, stack.base.kind.fields))


__all__ = ["LayerSlot", "slots", "NORMAL", "normal_socket", "split_normals", "ALPHA", "COLOUR_CHANNELS", "AXES", "ParamId", "alpha_from_r", "r_from_alpha",
           "layer_prefix", "layer_label", "socket_name"]
