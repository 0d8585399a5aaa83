"""The coat: a slab whose top interface separates the medium above from its interior of index
``ior``, a homogeneous medium of ``thickness`` with absorption ``sigma_a``, scattering ``sigma_s``
(per unit length, RGB) and Henyey-Greenstein asymmetry ``g`` (docs/design.md, "Contract: the stack
description"). A coat whose ior equals the medium above and whose roughness is 0 is a pure
medium (dust, fog)."""
from __future__ import annotations

from . import film
from .params import field_param, rgb_param, roughness_params
from .schema import (ANGLE, ANGLE_MAX, FLOAT, G_MAX, IOR_MAX, IOR_MIN, RGB, ROUGHNESS, SIGMA_MAX, THICKNESS_MAX, Field,
                     layer_kind)

FIELDS = (
    Field("ior", FLOAT, 1.5, "index of refraction of the coat's interior (absolute)", "",
          lo=IOR_MIN, hi=IOR_MAX, soft=(1.0, 3.0), label="IOR"),
    Field("roughness", ROUGHNESS, 0.0, "GGX alpha of the top interface: a number or [alpha_x, alpha_y]",
          "GGX alpha", lo=0.0, hi=1.0, soft=(0.0, 1.0)),
    Field("rotation", ANGLE, 0.0, "turn of the interface's anisotropy axes about the normal", "rad",
          lo=-ANGLE_MAX, hi=ANGLE_MAX, soft=(-3.141592653589793, 3.141592653589793)),
    Field("coverage", FLOAT, 1.0, "fraction of the surface the coat covers: where it is absent the layers below "
          "show (a mask linked here paints it)", "", lo=0.0, hi=1.0, soft=(0.0, 1.0)),
    Field("thickness", FLOAT, 0.0, "thickness of the interior medium", "length", lo=0.0, hi=THICKNESS_MAX,
          soft=(0.0, 10.0),
          group="Medium"),
    Field("sigma_a", RGB, [0.0, 0.0, 0.0], "absorption coefficient of the interior", "1/length",
          lo=0.0, hi=SIGMA_MAX, soft=(0.0, 10.0), label="Absorption", group="Medium"),
    Field("sigma_s", RGB, [0.0, 0.0, 0.0], "scattering coefficient of the interior", "1/length",
          lo=0.0, hi=SIGMA_MAX, soft=(0.0, 10.0), label="Scattering", group="Medium"),
    Field("g", FLOAT, 0.0, "Henyey-Greenstein asymmetry of the interior's scattering", "",
          lo=-G_MAX, hi=G_MAX, soft=(-0.99, 0.99), label="Phase Asymmetry g",
          group="Medium"),
    *film.FIELDS,
)


def _has_absorption(self) -> bool:
    return self.thickness > 0.0 and any(s > 0.0 for s in self.sigma_a)


def _has_scattering(self) -> bool:
    return self.thickness > 0.0 and any(s > 0.0 for s in self.sigma_s)


def params(ops, slot, coat) -> dict:
    """ior and roughness always; thickness and sigma_a only for an absorbing interior, sigma_s and
    g only for a scattering one (a clear coat traces to no medium code)."""
    p = {"ior": field_param(ops, slot, "ior", coat.ior), **roughness_params(ops, slot, coat.roughness, coat.rotation),
         **film.params(ops, slot, coat)}
    if coat.has_absorption or coat.has_scattering:
        p["thickness"] = field_param(ops, slot, "thickness", coat.thickness)
    if coat.has_absorption:
        p["sigma_a"] = rgb_param(ops, slot, "sigma_a", coat.sigma_a)
    if coat.has_scattering:
        p["sigma_s"] = rgb_param(ops, slot, "sigma_s", coat.sigma_s)
        p["g"] = field_param(ops, slot, "g", coat.g)
    return p


KIND = layer_kind("coat", "coat", "Coat", FIELDS, __doc__, params, icon="MOD_THICKNESS", namespace={
    "has_absorption": property(_has_absorption),
    "has_scattering": property(_has_scattering),
})
Coat = KIND.cls
