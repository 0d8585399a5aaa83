"""The dielectric base: a transmissive substrate of absolute index ``ior`` under a rough
interface; light crossing it leaves the stack downward. The substrate is solid (glass, water,
a gem): on a closed mesh, light that entered meets the far side from inside the substrate, which
shows it the layers in the reverse order and total internal reflection (``models.sides``).
``thin_walled``: the substrate is a thin sheet instead (a pane, a bubble, a film on glass; OpenPBR's
``geometry_thin_walled``): its back face has the same roughness, light crossing it leaves in the
direction it came, and both faces of a mesh show the stack as drawn. With ``ior`` 1 under a glass
coat, a plate with air on both sides."""
from __future__ import annotations

from . import film
from .params import BaseResponse, field_param, roughness_params
from .schema import ANGLE, ANGLE_MAX, BOOL, FLOAT, IOR_MAX, IOR_MIN, ROUGHNESS, Field, layer_kind
from ..models.rgb import RGB as RGBValue

FIELDS = (
    Field("ior", FLOAT, 1.5, "index of refraction of the substrate (absolute)", "", lo=IOR_MIN, hi=IOR_MAX,
          soft=(1.0, 3.0), label="IOR"),
    Field("roughness", ROUGHNESS, 0.0, "GGX alpha of the interface: a number or [alpha_x, alpha_y]", "GGX alpha",
          lo=0.0, hi=1.0, soft=(0.0, 1.0)),
    Field("rotation", ANGLE, 0.0, "turn of the anisotropy axes about the normal", "rad",
          lo=-ANGLE_MAX, hi=ANGLE_MAX, soft=(-3.141592653589793, 3.141592653589793)),
    *film.FIELDS,
    Field("thin_walled", BOOL, False, "a thin sheet of the substrate (a pane, a bubble) instead of a solid: light "
          "crossing it keeps its direction, and both faces show the stack as drawn", "", lo=0.0, hi=1.0,
          label="Thin Walled"),
)


def params(ops, slot, base) -> dict:
    return {"ior": field_param(ops, slot, "ior", base.ior), **roughness_params(ops, slot, base.roughness, base.rotation),
            **film.params(ops, slot, base)}


def response(ops, p, mu, alpha, n_above) -> BaseResponse:
    """FGD of the rough dielectric interface (total internal reflection included when the
    substrate is optically thinner), under its thin film the film's (``models.film``), the rest
    transmitted (T = 1 - R, as for the coats)."""
    from ..models import film as film_model
    from ..models.fgd import fgd_dielectric

    eta = p["ior"] / n_above
    if film_model.has_film(p):
        r = film_model.fgd(ops, mu, alpha, film_model.dielectric_curve(ops, p, n_above, p["ior"]))
    else:
        r = RGBValue.splat(fgd_dielectric(ops, mu, alpha, eta))
    return BaseResponse(reflectance=r, transmittance=1.0 - r, eta=eta)


KIND = layer_kind("dielectric", "base", "Dielectric", FIELDS, __doc__, params, response, transmits=True,
                  icon="MOD_FLUIDSIM")
Dielectric = KIND.cls
