"""A lobe kind: Lambertian transmission, light leaving on the far side of the surface with a
cosine distribution (a sheet of paper, a leaf). Its closure is Cycles' ``translucent`` in OSL and
the Translucent BSDF node elsewhere: f cos = |wo.z| / pi for wo below the surface, and its
directional albedo is 1 at weight 1."""
import math

from lamella.core import lobe_kinds


def _closure_cos(ops, a, wi, wo):
    return ops.select(wo[2] < 0.0, wo[2] * (-1.0 / math.pi), 0.0)


def _osl(a: dict) -> str:
    return "translucent(Normal)"


def _node(ops, a, wi) -> lobe_kinds.BsdfNode:
    return lobe_kinds.BsdfNode("ShaderNodeBsdfTranslucent", {}, {}, {"Normal": (0.0, 0.0, 1.0)})


KIND = lobe_kinds.LobeKind("translucent", "transmitted", _closure_cos, lambda ops, a, wi: 1.0,
                           lambda ops, lobe, wi: {}, "Lambertian transmission (light through a thin diffuser)",
                           _osl, _node, rough=False)


def register():
    lobe_kinds.register(KIND)


def unregister():
    lobe_kinds.unregister(KIND)
