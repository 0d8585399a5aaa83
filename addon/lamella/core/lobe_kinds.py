"""The lobe kinds: one table that says, for every kind of lobe a model emits, how it is evaluated,
how its weight is normalised, which side of the surface it lights and which Cycles closure
renders it (DESIGN.md "Where a new kind goes"). ``lamella.core.api.evaluate`` (numpy), the OSL
emitter and, later, the node-graph emitter all read this table and nothing else about lobes.

A lobe of weight ``e`` (RGB energy) contributes ``e * scale(wi) * closure_cos(wi, wo)`` to
f(wi, wo) |wo.z|, where ``closure_cos`` is exactly what the renderer's closure evaluates (f cos
of a closure of weight 1) and ``scale`` the normaliser that makes the lobe carry its weight in
energy (Randrianandrasana et al. 2021 Section 6.6, Eqs. 37-38: 1 / GD for GGX). The shader gives its closure the
weight ``e * scale``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

from .models.fgd import gd
from .models.ggx import ggx_lobe_cos
from .models.variance import rms_alpha

GD_FLOOR = 1e-6  # GD is >= 0.2 for every alpha <= 1 at wi.z >= 0; the floor only guards wi.z < 0


@dataclass(frozen=True)
class LobeKind:
    """``closure_cos(ops, lobe, wi, wo)``: f cos of the closure of weight 1 (backend values);
    ``scale(ops, lobe, wi)``: the normaliser; ``side``: ``"reflected"`` or ``"transmitted"``;
    ``osl(ax, ay, cos_r, sin_r)``: the Cycles OSL closure call, given printed expressions of the
    lobe's roughness and of its axes' rotation; ``description``: one line for docs and tables."""

    name: str
    side: str
    closure_cos: Callable
    scale: Callable
    osl: Callable
    description: str


def _ggx_closure_cos(ops, lobe, wi, wo):
    c, s = ops.cos(lobe.rotation), ops.sin(lobe.rotation)
    return ggx_lobe_cos(ops, wi, wo, lobe.alpha_x, lobe.alpha_y, c, s)


def _gd_scale(ops, lobe, wi):
    """1 / GD at the lobe's RMS roughness: exact for isotropic lobes, and within a few percent of
    the numerically integrated albedo of anisotropic GGX up to 70 degrees (the projected roughness
    along wi is much worse; measured in tests/unit/test_models.py)."""
    return 1.0 / ops.max(gd(ops, wi[2], rms_alpha(ops, lobe.alpha_x, lobe.alpha_y)), GD_FLOOR)


def _osl_tangent(c: str, s: str) -> str:
    return "Tn" if (c, s) == ("1.0", "0.0") else f"normalize({c} * Tn + {s} * Bn)"


def _osl_ggx_reflection(ax: str, ay: str, c: str, s: str) -> str:
    """Cycles' single-scattering GGX reflection without Fresnel (refract = 0) on the lobe's axes:
    the shading tangent turned by the lobe rotation about the normal."""
    return f'microfacet("ggx", Normal, {_osl_tangent(c, s)}, {ax}, {ay}, 1.0, 0)'


def _backscatter_closure_cos(ops, lobe, wi, wo):
    """An isotropic GGX reflection whose normal is the incident direction: its mirror direction
    is wi itself (back-scattered light returns toward the viewer). Evaluated in that lobe's frame
    (z' = wi): only c = wo . wi matters; zero below the surface."""
    c = wi[0] * wo[0] + wi[1] * wo[1] + wi[2] * wo[2]
    sin_c = ops.sqrt(ops.max(1.0 - c * c, 0.0))
    value = ggx_lobe_cos(ops, (0.0, 0.0, 1.0), (sin_c, 0.0, c), lobe.alpha_x, lobe.alpha_y, 1.0, 0.0)
    return ops.select(wo[2] > 0.0, value, 0.0)


def _backscatter_scale(ops, lobe, wi):
    """1 / GD at normal incidence in the lobe's own frame (its mean is its normal)."""
    return 1.0 / ops.max(gd(ops, 1.0, lobe.alpha_x), GD_FLOOR)


def _osl_backscatter(ax: str, ay: str, c: str, s: str) -> str:
    """Cycles' GGX reflection about the view direction V (Cycles' I points toward the viewer)."""
    return f'microfacet("ggx", V, {ax}, 1.0, 0)'


def _refracted_mirror(ops, lobe, wi):
    """The incident direction whose mirror image is the refracted mean direction's reflection
    through the surface: (wi_x / eta, wi_y / eta, cos_t), eta the substrate's index over vacuum
    (a stack of parallel interfaces refracts as one interface); cos_t = 0 beyond total internal
    reflection (the lobe then carries no energy)."""
    inv = 1.0 / lobe.eta
    tx, ty = wi[0] * inv, wi[1] * inv
    return tx, ty, ops.sqrt(ops.max(1.0 - tx * tx - ty * ty, 0.0))


def _transmission_closure_cos(ops, lobe, wi, wo):
    """Belcour 2018's rough refraction as a mirrored rough reflection (restated in
    Randrianandrasana et al. 2021, Section 3.2): a GGX lobe about the refracted mean direction,
    the reflection lobe of ``_refracted_mirror(wi)`` mirrored through the surface; zero above it.
    Exact in energy by construction (GD-normalised at cos_t), symmetric about the refracted
    direction, and well defined for a plate (eta = 1: straight through)."""
    c, s = ops.cos(lobe.rotation), ops.sin(lobe.rotation)
    wm = (wo[0], wo[1], -wo[2])
    value = ggx_lobe_cos(ops, _refracted_mirror(ops, lobe, wi), wm, lobe.alpha_x, lobe.alpha_y, c, s)
    return ops.select(wo[2] < 0.0, value, 0.0)


def _transmission_scale(ops, lobe, wi):
    return 1.0 / ops.max(gd(ops, _refracted_mirror(ops, lobe, wi)[2], rms_alpha(ops, lobe.alpha_x, lobe.alpha_y)),
                         GD_FLOOR)


def _osl_transmission_unavailable(*args) -> str:
    raise NotImplementedError("the transmission lobe of a dielectric base has no Cycles closure yet: Cycles' "
                              "refracting microfacet closure is a Walter BTDF, which does not reproduce the "
                              "mirrored-reflection lobe (and degenerates for a plate, eta = 1)")


def _lambert_closure_cos(ops, lobe, wi, wo):
    return ops.select(wo[2] > 0.0, wo[2] * (1.0 / math.pi), 0.0)


def _unit_scale(ops, lobe, wi):
    return 1.0


def _osl_diffuse(ax: str, ay: str, c: str, s: str) -> str:
    return "diffuse(Normal)"


KINDS: dict[str, LobeKind] = {k.name: k for k in (
    LobeKind("reflection", "reflected", _ggx_closure_cos, _gd_scale, _osl_ggx_reflection,
             "GGX reflection about the mirror direction, GD-normalised"),
    LobeKind("diffuse", "reflected", _lambert_closure_cos, _unit_scale, _osl_diffuse,
             "Lambertian reflection (the light a diffuse base sends back up)"),
    LobeKind("backscatter", "reflected", _backscatter_closure_cos, _backscatter_scale, _osl_backscatter,
             "GGX reflection about the incident direction (light back-scattered by a medium)"),
    LobeKind("transmission", "transmitted", _transmission_closure_cos, _transmission_scale,
             _osl_transmission_unavailable, "GGX lobe about the refracted direction, below a dielectric base"),
)}


def kind(name: str) -> LobeKind:
    if name not in KINDS:
        raise NotImplementedError(f"lobe kind {name!r} is not in the lobe-kind table (have: {', '.join(KINDS)})")
    return KINDS[name]


def eval_lobes_cos(ops, lobes, wi, wo):
    """f(wi, wo) |wo.z| of a list of lobes: sum_k e_k scale_k(wi) closure_cos_k(wi, wo)."""
    from .models.rgb import RGB

    total = RGB.splat(0.0)
    for lobe in lobes:
        k = kind(lobe.kind)
        total = total + lobe.weight * (k.closure_cos(ops, lobe, wi, wo) * k.scale(ops, lobe, wi))
    return total
