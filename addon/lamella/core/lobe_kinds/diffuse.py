"""Lambertian reflection: the light a diffuse base sends back up."""
from __future__ import annotations

import math

from .bsdf_node import BsdfNode
from .kind import LobeKind, osl_frame


def _lambert_closure_cos(ops, a, wi, wo):
    return ops.select(wo[2] > 0.0, wo[2] * (1.0 / math.pi), 0.0)


def _unit_scale(ops, a, wi):
    return 1.0


def _no_args(ops, lobe, wi):
    return {}


def _osl_diffuse(a: dict) -> str:
    return f"diffuse({osl_frame(a)[0]})"


def _bsdf_diffuse(ops, a, wi):
    return BsdfNode("ShaderNodeBsdfDiffuse", {}, {"Roughness": 0.0}, {"Normal": (0.0, 0.0, 1.0)})


KIND = LobeKind("diffuse", "reflected", _lambert_closure_cos, _unit_scale, _no_args,
                "Lambertian reflection (the light a diffuse base sends back up)", _osl_diffuse, _bsdf_diffuse,
                rough=False)
