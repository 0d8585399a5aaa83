"""A coat kind: a lacquer given by the colour white light has after one pass through it along the
normal, as artists pick it, rather than by an absorption coefficient. It is a coat of thickness 1
whose absorption is the colour's absorbance (``absorbance``, Beer-Lambert), so every model
renders it as that coat."""
from lamella.core import layers
from lamella.core.layers.params import field_param, rgb_param, roughness_params
from lamella.core.layers.schema import ANGLE, ANGLE_MAX, FLOAT, IOR_MAX, IOR_MIN, RGB, ROUGHNESS, Field, layer_kind

COLOR_MIN = 1e-4  # an absorbance of 9.2 along the normal: black for any render

FIELDS = (
    Field("ior", FLOAT, 1.5, "index of refraction of the lacquer (absolute)", "", lo=IOR_MIN, hi=IOR_MAX,
          soft=(1.0, 3.0), label="IOR"),
    Field("roughness", ROUGHNESS, 0.0, "GGX alpha of the top interface: a number or [alpha_x, alpha_y]",
          "GGX alpha", lo=0.0, hi=1.0, soft=(0.0, 1.0)),
    Field("rotation", ANGLE, 0.0, "turn of the interface's anisotropy axes about the normal", "rad",
          lo=-ANGLE_MAX, hi=ANGLE_MAX, soft=(-3.141592653589793, 3.141592653589793)),
    Field("color", RGB, [0.9, 0.6, 0.3], "colour of white light after one pass through the lacquer along the normal",
          "", lo=COLOR_MIN, hi=1.0, soft=(0.01, 1.0), label="Color", color=True),
)


def _has_absorption(self) -> bool:
    return any(c < 1.0 for c in self.color)


def params(ops, slot, layer) -> dict:
    p = {"ior": field_param(ops, slot, "ior", layer.ior), **roughness_params(ops, slot, layer.roughness, layer.rotation)}
    if layer.has_absorption:
        p["thickness"] = 1.0
        p["sigma_a"] = rgb_param(ops, slot, "color", layer.color).map(ops.absorbance)
    return p


KIND = layer_kind("tinted_lacquer", "coat", "TintedLacquer", FIELDS, __doc__, params, icon="COLOR",
                  namespace={"has_absorption": property(_has_absorption), "has_scattering": property(lambda self: False)})


def register():
    layers.register(KIND)


def unregister():
    layers.unregister(KIND)
