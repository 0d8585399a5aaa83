"""A base kind: a metal given by its reflectivity and edge tint colours (Gulbrandsen 2014,
Section 3), mapped to the complex index in the shader, so a texture can drive the colours. Its
energies are the conductor's (``layers.conductor.response``)."""
from lamella.core import layers
from lamella.core.layers import conductor
from lamella.core.layers.params import rgb_param, roughness_params
from lamella.core.layers.schema import ANGLE, ANGLE_MAX, RGB, ROUGHNESS, Field, layer_kind
from lamella.core.metals import R_MAX
from lamella.core.models.rgb import RGB as RGBValue

FIELDS = (
    Field("reflectivity", RGB, [0.944, 0.776, 0.373], "colour at normal incidence", "", lo=0.0, hi=R_MAX,
          soft=(0.0, R_MAX), color=True),
    Field("edge_tint", RGB, [0.998, 0.981, 0.751], "colour toward grazing angles", "", lo=0.0, hi=1.0,
          soft=(0.0, 1.0), color=True),
    Field("roughness", ROUGHNESS, 0.0, "GGX alpha: a number or [alpha_x, alpha_y]", "GGX alpha", lo=0.0, hi=1.0,
          soft=(0.0, 1.0)),
    Field("rotation", ANGLE, 0.0, "turn of the anisotropy axes about the normal", "rad",
          lo=-ANGLE_MAX, hi=ANGLE_MAX, soft=(-3.141592653589793, 3.141592653589793)),
)


def complex_index(ops, r, g):
    """(eta, k) of reflectivity r and edge tint g (Gulbrandsen 2014, Eqs. 4 and 7 solved for k)."""
    sr = ops.sqrt(r)
    n = g * (1.0 - r) / (1.0 + r) + (1.0 - g) * (1.0 + sr) / (1.0 - sr)
    k2 = (r * (n + 1.0) * (n + 1.0) - (n - 1.0) * (n - 1.0)) / (1.0 - r)
    return n, ops.sqrt(ops.max(k2, 0.0))


def params(ops, slot, base) -> dict:
    r = rgb_param(ops, slot, "reflectivity", base.reflectivity)
    g = rgb_param(ops, slot, "edge_tint", base.edge_tint)
    pairs = [complex_index(ops, rc, gc) for rc, gc in zip(r, g)]
    return {"eta": RGBValue(*(n for n, _ in pairs)), "k": RGBValue(*(k for _, k in pairs)),
            **roughness_params(ops, slot, base.roughness, base.rotation)}


KIND = layer_kind("artist_metal", "base", "ArtistMetal", FIELDS, __doc__, params, conductor.response,
                  icon="SHADING_RENDERED")


def register():
    layers.register(KIND)


def unregister():
    layers.unregister(KIND)
