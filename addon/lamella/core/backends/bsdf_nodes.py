"""How the node-graph backend builds each lobe kind (``lamella.core.lobe_kinds``): the Blender BSDF
node that makes the kind's closure in Cycles without OSL, and in EEVEE what EEVEE makes of that
node, with its sockets as backend values of the kind's arguments. A new lobe kind adds its builder
here (``BSDF_NODES``; a test checks every kind has one)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from ..luts import REFRACT_ETA


@dataclass(frozen=True)
class BsdfNode:
    """The Blender BSDF node that renders a lobe (the node-graph backend): its type and
    properties, its float sockets as backend values, and its vector sockets as local-frame
    triples (x along the shading tangent, y the bitangent, z the normal) of backend values, or
    None to leave the socket unlinked. The ``Color`` socket takes the lobe's weight."""

    bl_idname: str
    props: dict
    floats: dict
    vectors: dict

def blender_anisotropy(ops, ax, ay):
    """Blender's (Roughness, Anisotropy) of a GGX lobe with roughness ax along its tangent and ay
    across it: the Glossy BSDF sets alpha = r^2 and, for anisotropy a >= 0, alpha_x = alpha (1 - a),
    alpha_y = alpha / (1 - a), for a < 0 alpha_x = alpha / (1 + a), alpha_y = alpha (1 + a)
    (Cycles 5.0, ``svm_node_closure_bsdf``). So alpha = sqrt(ax ay) and |a| = 1 - sqrt(min / max);
    Cycles clamps |a| to 0.99, an axis ratio of 10^4. One traced value for both axes (an
    isotropic lobe) gives r = sqrt(alpha) and no anisotropy, without the nodes that would find it."""
    if ax is ay and not isinstance(ax, (int, float)) and getattr(ops, "name", "") == "trace":
        return ops.sqrt(ax), 0.0
    q = ops.sqrt((ops.min(ax, ay) + 1e-12) / (ops.max(ax, ay) + 1e-12))  # 1 for isotropic, even at 0
    return ops.sqrt(ops.sqrt(ax * ay)), ops.select(ax <= ay, 1.0 - q, q - 1.0)

def _bsdf_ggx_reflection(ops, a, wi):
    """Glossy BSDF (GGX) on the lobe's axes. EEVEE ignores the anisotropy and renders the
    Roughness socket alone, alpha = sqrt(ax ay): of the isotropic stand-ins measured (arithmetic,
    geometric and RMS mean, the larger axis, the roughness projected on the view's azimuth) the
    geometric mean is the closest to the anisotropic lobes (``bench/eevee_anisotropy.md``), so one
    node group serves Cycles and EEVEE."""
    r, aniso = blender_anisotropy(ops, a["ax"], a["ay"])
    return BsdfNode("ShaderNodeBsdfAnisotropic", {"distribution": "GGX"}, {"Roughness": r, "Anisotropy": aniso},
                    {"Normal": (0.0, 0.0, 1.0), "Tangent": (a["cos"], a["sin"], 0.0)})

def _bsdf_backscatter(ops, a, wi):
    """Glossy BSDF (GGX, isotropic) about the view direction."""
    return BsdfNode("ShaderNodeBsdfAnisotropic", {"distribution": "GGX"},
                    {"Roughness": ops.sqrt(a["alpha"]), "Anisotropy": 0.0},
                    {"Normal": tuple(wi), "Tangent": None})

def _bsdf_transmission(ops, a, wi):
    """Refraction BSDF (GGX) at index REFRACT_ETA about the closure normal."""
    return BsdfNode("ShaderNodeBsdfRefraction", {"distribution": "GGX"},
                    {"Roughness": ops.sqrt(a["alpha"]), "IOR": REFRACT_ETA},
                    {"Normal": (a["nx"], a["ny"], a["nz"])})

def _bsdf_diffuse(ops, a, wi):
    return BsdfNode("ShaderNodeBsdfDiffuse", {}, {"Roughness": 0.0}, {"Normal": (0.0, 0.0, 1.0)})


BSDF_NODES: dict[str, Callable] = {
    "reflection": _bsdf_ggx_reflection,
    "diffuse": _bsdf_diffuse,
    "backscatter": _bsdf_backscatter,
    "transmission": _bsdf_transmission,
}
