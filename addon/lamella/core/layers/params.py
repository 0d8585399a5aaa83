"""What the models read from a layer, as backend values (shader inputs when traced).

A kind's ``params(ops, slot, layer)`` declares each parameter through ``slot`` (``LayerSlot``:
which layer it is) with these helpers, so every parameter carries its identity
(``core.param_id.ParamId``: layer, field, channel, unit) and every kind names its shader inputs
the same way (``coat0_ior``, ``base_alpha``, ``base_eta_r``); an isotropic layer carries no
anisotropy code.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..models.rgb import RGB
from ..param_id import AXES, COLOUR_CHANNELS, LayerSlot


def field_param(ops, slot: LayerSlot, field: str, value):
    """The parameter of a number field."""
    return ops.param(slot.id(field), value)


def rgb_param(ops, slot: LayerSlot, field: str, values) -> RGB:
    """The three parameters of a colour field (one per channel)."""
    return RGB(*(ops.param(slot.id(field, ch), v) for ch, v in zip(COLOUR_CHANNELS, values)))


def roughness_params(ops, slot: LayerSlot, roughness, rotation, field: str = "roughness",
                     rotation_field: str = "rotation") -> dict:
    """An isotropic layer is one input ``<layer>_alpha`` with no rotation (rotation has no effect
    on it): the traced shader then carries no anisotropy or rotation code for it. An anisotropic
    layer has ``_alpha_x``, ``_alpha_y`` and ``_rotation`` inputs. Which of the two a layer is,
    is part of the stack's structure (a different shader), like the number of coats."""
    ax, ay = roughness
    if ax == ay:
        a = ops.param(slot.id(field), ax)
        return {"ax": a, "ay": a, "rotation": 0.0}
    x, y = AXES
    return {"ax": ops.param(slot.id(field, x), ax), "ay": ops.param(slot.id(field, y), ay),
            "rotation": ops.param(slot.id(rotation_field), rotation)}


@dataclass
class BaseResponse:
    """A base's energies for light arriving from the medium above (backend values; ``None`` where
    the kind has no such part, which is structure: the models emit no code for it).

    ``reflectance``: RGB energy of its GGX reflection lobe (the interface's FGD);
    ``transmittance``: RGB energy crossing into the substrate (a transmissive base);
    ``albedo``: RGB Lambertian reflectance of what reaches it (a diffuse base);
    ``scattered``: RGB energy its microsurface reflects after scattering more than once, which
    leaves nearly as a Lambertian surface's light does (a rough conductor; Kulla and Conty 2017);
    ``eta``: substrate index over the index above (a transmissive base), for the refracted
    direction and the transmitted spread."""

    reflectance: RGB | None = None
    transmittance: RGB | None = None
    albedo: RGB | None = None
    scattered: RGB | None = None
    eta: object = None
