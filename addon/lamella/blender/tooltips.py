"""What a field says of itself where an artist points at it: the tooltip of a panel property and of
the Lamella node's input, from the layer-kind schema (``schema.Field``: description, unit, limits),
written once for both."""
from __future__ import annotations

from ..core.layers import BOOL, ROUGHNESS

# a schema unit in words, as a tooltip says it
UNIT_WORDS = {
    "rad": "radians",
    "nm": "nanometres",
    "length": "a length, in the unit Absorption and Scattering are per: only their product, the optical depth, "
              "matters",
    "1/length": "per unit of the coat's Thickness (coefficient x thickness is the optical depth)",
}


def roughness_tooltip(f, across: bool = False) -> str:
    """A roughness field's tooltip: Blender's r, along or across the tangent."""
    what = f.description.split(":")[0]
    where = "across the tangent" if across else "along the tangent when anisotropic"
    return (f"Blender roughness r (GGX alpha = r squared) {where}; {what}. Accepted: 0 to 1")


def field_tooltip(f) -> str:
    """The schema's description, its unit and its hard limits (what the parser accepts)."""
    if f.type == ROUGHNESS:
        return roughness_tooltip(f)
    if f.type == BOOL:
        return f"{f.description[:1].upper()}{f.description[1:]}"
    unit = f" [{UNIT_WORDS.get(f.unit, f.unit)}]" if f.unit else ""
    return f"{f.description[:1].upper()}{f.description[1:]}{unit}. Accepted: {f.limits_text()}"
