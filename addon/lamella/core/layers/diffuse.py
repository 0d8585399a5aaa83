"""The diffuse base: an opaque Lambertian surface of reflectance ``albedo`` (RGB). Not in the
layered-model papers; every artist expects it (varnished wood, coated plastic)."""
from __future__ import annotations

from .params import BaseResponse, rgb_param
from .schema import RGB, Field, layer_kind

FIELDS = (
    Field("albedo", RGB, [0.8, 0.8, 0.8], "Lambertian reflectance", "", lo=0.0, hi=1.0, soft=(0.0, 1.0), label="Color",
          color=True),
)


def params(ops, slot, base) -> dict:
    return {"albedo": rgb_param(ops, slot, "albedo", base.albedo)}


def response(ops, p, mu, alpha, n_above) -> BaseResponse:
    return BaseResponse(albedo=p["albedo"])


KIND = layer_kind("diffuse", "base", "Diffuse", FIELDS, __doc__, params, response, interface=False,
                  icon="MATSPHERE")
Diffuse = KIND.cls
