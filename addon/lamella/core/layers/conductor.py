"""The conductor base: an opaque metal of absolute complex index ``eta + i k`` (RGB, as published
measurements give it); under a coat of index n its interface sees ``(eta + i k) / n``."""
from __future__ import annotations

from . import film
from .params import BaseResponse, rgb_param, roughness_params
from .schema import ANGLE, ANGLE_MAX, RGB, ROUGHNESS, Field, layer_kind

ETA_MIN, ETA_MAX = 1e-4, 1e3  # measured metals: eta 0.03 to 10
K_MAX = 1e6  # a huge extinction is a mirror (Fresnel's limit k -> inf): 1 - R ~ 4 eta / k^2

FIELDS = (
    Field("eta", RGB, [0.143, 0.374, 1.442], "real part of the complex index of refraction (absolute)", "",
          lo=ETA_MIN, hi=ETA_MAX, soft=(0.01, 5.0), label="IOR (n)"),
    Field("k", RGB, [3.983, 2.385, 1.603], "extinction coefficient: imaginary part of the index", "",
          lo=0.0, hi=K_MAX, soft=(0.0, 10.0), label="Extinction (k)"),
    Field("roughness", ROUGHNESS, 0.0, "GGX alpha: a number or [alpha_x, alpha_y]", "GGX alpha",
          lo=0.0, hi=1.0, soft=(0.0, 1.0)),
    Field("rotation", ANGLE, 0.0, "turn of the anisotropy axes about the normal", "rad",
          lo=-ANGLE_MAX, hi=ANGLE_MAX, soft=(-3.141592653589793, 3.141592653589793)),
    *film.FIELDS,
)


def params(ops, slot, base) -> dict:
    return {"eta": rgb_param(ops, slot, "eta", base.eta), "k": rgb_param(ops, slot, "k", base.k),
            **roughness_params(ops, slot, base.roughness, base.rotation), **film.params(ops, slot, base)}


def response(ops, p, mu, alpha, n_above) -> BaseResponse:
    """FGD of the rough conductor with exact complex Fresnel (Randrianandrasana et al. 2021 Eq. 8),
    or under its thin film the film's reflectance (``models.film``): its GGX lobe; and what its
    microsurface scatters more than once (``fgd.conductor_scattered``)."""
    from ..models import film as film_model
    from ..models.fgd import conductor_scattered, fgd_conductor

    eta, k = p["eta"] / n_above, p["k"] / n_above
    if film_model.has_film(p):
        curve = film_model.conductor_curve(ops, p, n_above)
        single = film_model.fgd(ops, mu, alpha, curve)
        f_avg = film_model.average(ops, curve)
    else:
        single, f_avg = fgd_conductor(ops, mu, alpha, eta, k), None
    return BaseResponse(reflectance=single, scattered=conductor_scattered(ops, mu, alpha, eta, k, single, f_avg))


KIND = layer_kind("conductor", "base", "Conductor", FIELDS, __doc__, params, response, icon="METAL")
Conductor = KIND.cls
