"""What the models read from a layer, as backend values (shader inputs when traced).

Layer kinds build their parameters with these helpers, so every kind names its shader inputs the
same way (``coat0_ior``, ``base_alpha``, ``base_eta_r``) and an isotropic layer carries no
anisotropy code.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..models.rgb import RGB


def rgb_param(ops, name: str, values) -> RGB:
    return RGB(*(ops.param(f"{name}_{ch}", v) for ch, v in zip("rgb", values)))


def roughness_params(ops, prefix: str, roughness, rotation) -> dict:
    """An isotropic layer is one input ``<prefix>_alpha`` with no rotation (rotation has no effect
    on it): the traced shader then carries no anisotropy or rotation code for it. An anisotropic
    layer has ``_alpha_x``, ``_alpha_y`` and ``_rotation`` inputs. Which of the two a layer is,
    is part of the stack's structure (a different shader), like the number of coats."""
    ax, ay = roughness
    if ax == ay:
        a = ops.param(f"{prefix}_alpha", ax)
        return {"ax": a, "ay": a, "rotation": 0.0}
    return {"ax": ops.param(f"{prefix}_alpha_x", ax), "ay": ops.param(f"{prefix}_alpha_y", ay),
            "rotation": ops.param(f"{prefix}_rotation", rotation)}


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
