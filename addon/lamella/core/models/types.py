"""The types every model shares: the lobes a model returns (``Lobe``), the error for a stack a
model cannot represent (``UnsupportedStack``), every layer's parameters as backend values
(``layer_params``, from the layer kinds' own ``params``) and the smallest cosine a path length
divides by (``COS_FLOOR``)."""
from __future__ import annotations

from dataclasses import dataclass

from ..param_id import layer_prefix, slots
from .rgb import RGB

COS_FLOOR = 1e-6  # smallest cosine used in a Beer-Lambert path length (keeps d / cos finite)


class UnsupportedStack(ValueError):
    """The model cannot represent this stack; the message says why."""


@dataclass
class Lobe:
    """A lobe of a model, in backend values: energy (RGB), roughness along its own axes, the
    angle of those axes from the shading tangent, its kind (a name of ``lamella.core.lobe_kinds``)
    and, for a transmission lobe, the index of the medium it enters relative to vacuum above.
    ``cover`` is the fraction of the surface the lobe is on (a part of a stack with partly
    covering coats, ``models.coverage``): the material reflects ``cover * weight``. ``normal``
    names the layer whose normal the lobe is about (``coat0``, ``base``: the interface it leaves,
    or the layer whose interior scatters it; ``param_id.layer_prefix``), where a material gives
    that layer a normal of its own; None: the shading normal."""

    weight: RGB
    alpha_x: object
    alpha_y: object
    rotation: object
    kind: str = "reflection"
    eta: object = 1.0
    cover: object = 1.0
    normal: str | None = None
    above: tuple | None = None  # the coats present above its layer (``layer_normals.coats_above``)


def layer_normal(stack, index: int) -> str:
    """The ``Lobe.normal`` of coat ``index`` of ``stack`` (its index in the whole stack, for a part
    of one: ``Stack.layer_index``), or of the base (``index`` past the coats)."""
    return layer_prefix(stack.layer_index(index) if index < len(stack.coats) else None)


def layer_params(ops, stack):
    """Every per-layer parameter as a backend value (a shader input when traced), by the layer
    kinds' own ``params``; for a view of a stack (``Stack.view``, ``models.sides``), that stack's
    parameters as the view arranges them."""
    if stack.view is not None:
        from .sides import view_params

        return view_params(ops, stack.view, *layer_params(ops, stack.view.original))
    coat_slots, base_slot = slots(stack)
    coats = [c.kind.params(ops, slot, c) for slot, c in zip(coat_slots, stack.coats)]
    return coats, stack.base.kind.params(ops, base_slot, stack.base)
