"""The Blender BSDF node a lobe kind builds (``LobeKind.node``), as data: the node-graph backend
wires it, ``lamella.blender.node_group`` creates it. Pure data, no bpy."""
from __future__ import annotations

from dataclasses import dataclass


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
    lo, hi = ops.min(ax, ay), ops.max(ax, ay)
    q = ops.sqrt((lo + 1e-12) / (hi + 1e-12))  # 1 for isotropic, even at 0
    # 1 - q = (1 - q^2) / (1 + q) = (hi - lo) / ((hi + 1e-12) (1 + q)): no cancellation for nearly
    # equal axes (hi - lo is exact there), where 1 - q is a multiple of float32's 2^-24
    a = (hi - lo) / ((hi + 1e-12) * (1.0 + q))
    return ops.sqrt(ops.sqrt(ax * ay)), ops.select(ax <= ay, a, 0.0 - a)
