"""The lobe kinds: one table that says, for every kind of lobe a model emits, how it is evaluated,
how its weight is normalised and which side of the surface it lights: the physics of the closure
that renders it (docs/design.md "Where a new kind goes"). ``lamella.core.api.evaluate`` (numpy)
reads this table and nothing else about lobes; each backend keeps its own table of how a kind is
printed or built, keyed by the kind's name: ``backends/osl_closures.py`` (the Cycles OSL closure
call) and ``backends/bsdf_nodes.py`` (the Blender BSDF node, for Cycles without OSL and EEVEE).

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

from . import luts
from .luts import REFRACT_ETA
from .models.fgd import gd
from .models.ggx import ALPHA_EVAL_MIN, ggx_lobe_cos, smith_s
from .models.variance import rms_alpha

GD_FLOOR = 1e-6  # GD is >= 0.2 for every alpha <= 1 at wi.z >= 0; the floor only guards wi.z < 0


@dataclass(frozen=True)
class LobeKind:
    """A closure is a function of its arguments, the named values ``args(ops, lobe, wi)`` turns a
    lobe into (roughness, axes, normal) and a backend prints or wires:
    ``cos_of_args(ops, a, wi, wo)``: f cos of the closure of weight 1 (exactly what the renderer's
    closure evaluates); ``scale_of_args(ops, a, wi)``: the normaliser that makes the closure carry
    its lobe's energy; ``side``: ``"reflected"`` or ``"transmitted"``; ``description``: one line
    for docs and tables; ``rough``: the lobe is a microfacet lobe, a delta at zero roughness.
    ``closure_cos`` and ``scale`` are the same of a lobe."""

    name: str
    side: str
    cos_of_args: Callable
    scale_of_args: Callable
    args: Callable
    description: str
    rough: bool = True

    def closure_cos(self, ops, lobe, wi, wo):
        return self.cos_of_args(ops, self.args(ops, lobe, wi), wi, wo)

    def scale(self, ops, lobe, wi):
        return self.scale_of_args(ops, self.args(ops, lobe, wi), wi)


def _ggx_closure_cos(ops, a, wi, wo):
    return ggx_lobe_cos(ops, wi, wo, a["ax"], a["ay"], a["cos"], a["sin"])


def _gd_scale(ops, a, wi):
    """1 / GD at the lobe's RMS roughness: exact for isotropic lobes, and within a few percent of
    the numerically integrated albedo of anisotropic GGX up to 70 degrees (the projected roughness
    along wi is much worse; measured in tests/unit/test_models.py)."""
    return 1.0 / ops.max(gd(ops, wi[2], rms_alpha(ops, a["ax"], a["ay"])), GD_FLOOR)


def _ggx_args(ops, lobe, wi):
    return {"ax": lobe.alpha_x, "ay": lobe.alpha_y, "cos": ops.cos(lobe.rotation), "sin": ops.sin(lobe.rotation)}


def _backscatter_closure_cos(ops, a, wi, wo):
    """An isotropic GGX reflection whose normal is the incident direction: its mirror direction
    is wi itself (back-scattered light returns toward the viewer). Evaluated in that lobe's frame
    (z' = wi): only c = wo . wi matters; zero below the surface."""
    c = wi[0] * wo[0] + wi[1] * wo[1] + wi[2] * wo[2]
    sin_c = ops.sqrt(ops.max(1.0 - c * c, 0.0))
    value = ggx_lobe_cos(ops, (0.0, 0.0, 1.0), (sin_c, 0.0, c), a["alpha"], a["alpha"], 1.0, 0.0)
    return ops.select(wo[2] > 0.0, value, 0.0)


def _backscatter_scale(ops, a, wi):
    """1 / GD at normal incidence in the lobe's own frame (its mean is its normal)."""
    return 1.0 / ops.max(gd(ops, 1.0, a["alpha"]), GD_FLOOR)


def _backscatter_args(ops, lobe, wi):
    return {"alpha": lobe.alpha_x}


def _refracted_mirror(ops, lobe, wi):
    """The incident direction whose mirror image is the refracted mean direction's reflection
    through the surface: (wi_x / eta, wi_y / eta, cos_t), eta the substrate's index over vacuum
    (a stack of parallel interfaces refracts as one interface); cos_t = 0 beyond total internal
    reflection (the lobe then carries no energy)."""
    inv = 1.0 / lobe.eta
    # cos_t^2 = (eta^2 - 1 + cos_i^2) / eta^2: exact for a plate (eta = 1) at grazing, where the
    # form 1 - |t_xy|^2 cancels
    cos2 = (lobe.eta * lobe.eta - 1.0 + wi[2] * wi[2]) * (inv * inv)
    return wi[0] * inv, wi[1] * inv, ops.sqrt(ops.max(cos2, 0.0))


def _transmission_alpha(ops, lobe):
    """The closure roughness whose refraction lobe spreads like a GGX reflection lobe of the
    model's (reflection-equivalent) roughness: alpha_w = 2 eta alpha / (eta - 1), Belcour 2018's
    fake-refraction scale at normal incidence solved for the Walter roughness, at eta = REFRACT_ETA.
    Cycles' refracting closure is isotropic (it ignores alpha_y) and clamps alpha to 1, so the lobe
    takes the RMS roughness and is too narrow beyond a reflection-equivalent alpha of 0.495."""
    k = 2.0 * REFRACT_ETA / (REFRACT_ETA - 1.0)
    return ops.clamp(k * rms_alpha(ops, lobe.alpha_x, lobe.alpha_y), ALPHA_EVAL_MIN, 1.0)


def transmission_alpha_of_spread(ops, closure_alpha):
    """The (reflection-equivalent) lobe roughness whose closure roughness is ``closure_alpha``:
    the inverse of ``_transmission_alpha``, for models that know the transmitted spread itself."""
    return closure_alpha * ((REFRACT_ETA - 1.0) / (2.0 * REFRACT_ETA))


def _transmission_normal(ops, lobe, wi):
    """The closure normal n that refracts wi, at index REFRACT_ETA, exactly into the transmitted
    mean direction t = -r (r = ``_refracted_mirror``): Walter et al. 2007 Eq. 16's generalised half
    vector, n = -(wi + eta t) / |wi + eta t| = (eta r - wi) / |eta r - wi|. n = wi for a plate
    (eta = 1); n . wi > 0 always, since r . wi > 0."""
    rx, ry, rz = _refracted_mirror(ops, lobe, wi)
    nx, ny, nz = REFRACT_ETA * rx - wi[0], REFRACT_ETA * ry - wi[1], REFRACT_ETA * rz - wi[2]
    inv = 1.0 / ops.sqrt(ops.max(nx * nx + ny * ny + nz * nz, 1e-30))
    return nx * inv, ny * inv, nz * inv


def _transmission_closure_cos(ops, args, wi, wo):
    """Cycles' refracting GGX closure ``microfacet("ggx", n, alpha_w, REFRACT_ETA, 1)`` (isotropic
    Walter et al. 2007 BTDF, Eqs. 16, 21 and 33, with Fresnel replaced by 1 and the height-correlated
    Smith G2; ``bsdf_microfacet_eval`` of Cycles 5.0), evaluated as Cycles does: with h = -(eta wo
    + wi) / |eta wo + wi|, c_x = n . x,
        f cos = D(h) eta^2 |h.wi| |h.wo| / |eta wo + wi|^2 * G2 / c_i,
    G2 / c_i = 2 |c_o| / (|c_o| s_i + c_i s_o), s = sqrt(c^2 + alpha^2 (1 - c^2)) (no division by a
    cosine). Nonzero only for c_i > 0, c_o < 0, and wo below the shading normal (Cycles'
    bump-shadowing test when the closure normal is not the shading normal). At a large index the
    refraction hardly bends, so this is a GGX lobe about -n: the transmitted direction, tilted by
    the closure normal ``_transmission_normal`` (Belcour 2018's rough refraction as a lobe about the
    refracted mean)."""
    n = (args["nx"], args["ny"], args["nz"])
    a = args["alpha"]
    a2 = a * a
    eta = REFRACT_ETA
    hx, hy, hz = -(eta * wo[0] + wi[0]), -(eta * wo[1] + wi[1]), -(eta * wo[2] + wi[2])
    l2 = hx * hx + hy * hy + hz * hz  # >= (eta - 1)^2 for unit vectors
    h_i = hx * wi[0] + hy * wi[1] + hz * wi[2]
    h_o = hx * wo[0] + hy * wo[1] + hz * wo[2]
    h_n = hx * n[0] + hy * n[1] + hz * n[2]
    c2 = ops.min(h_n * h_n / l2, 1.0)
    t = 1.0 - c2 * (1.0 - a2)
    d = a2 / (math.pi * t * t)
    c_i = wi[0] * n[0] + wi[1] * n[1] + wi[2] * n[2]
    c_o = wo[0] * n[0] + wo[1] * n[1] + wo[2] * n[2]
    abs_o = ops.abs(c_o)
    s_i = smith_s(ops, c_i, a2 * (1.0 - c_i * c_i))
    s_o = smith_s(ops, c_o, a2 * (1.0 - c_o * c_o))
    g2_over_ci = 2.0 * abs_o / ops.max(abs_o * s_i + c_i * s_o, 1e-30)
    value = d * (eta * eta) * ops.abs(h_i * h_o) / (l2 * l2) * g2_over_ci
    return ops.select(wo[2] < 0.0, ops.select(c_o < 0.0, value, 0.0), 0.0)


def _transmission_scale(ops, args, wi):
    """1 / the closure's directional transmittance at weight 1 (``ggx_refract_albedo``)."""
    n = (args["nx"], args["ny"], args["nz"])
    mu = wi[0] * n[0] + wi[1] * n[1] + wi[2] * n[2]
    a = args["alpha"]
    t = ops.lut("ggx_refract_albedo", luts.mu_to_coord(ops, mu), luts.alpha_to_coord(ops, a))
    return 1.0 / ops.max(t, GD_FLOOR)


def _transmission_args(ops, lobe, wi):
    n = _transmission_normal(ops, lobe, wi)
    return {"alpha": _transmission_alpha(ops, lobe), "nx": n[0], "ny": n[1], "nz": n[2]}


def _lambert_closure_cos(ops, a, wi, wo):
    return ops.select(wo[2] > 0.0, wo[2] * (1.0 / math.pi), 0.0)


def _unit_scale(ops, a, wi):
    return 1.0


def _no_args(ops, lobe, wi):
    return {}


KINDS: dict[str, LobeKind] = {k.name: k for k in (
    LobeKind("reflection", "reflected", _ggx_closure_cos, _gd_scale, _ggx_args,
             "GGX reflection about the mirror direction, GD-normalised"),
    LobeKind("diffuse", "reflected", _lambert_closure_cos, _unit_scale, _no_args,
             "Lambertian reflection (the light a diffuse base sends back up)", rough=False),
    LobeKind("backscatter", "reflected", _backscatter_closure_cos, _backscatter_scale, _backscatter_args,
             "GGX reflection about the incident direction (light back-scattered by a medium)"),
    LobeKind("transmission", "transmitted", _transmission_closure_cos, _transmission_scale, _transmission_args,
             "GGX refraction lobe about the transmitted direction, below a dielectric base"),
)}


def register(kind_: LobeKind, osl_closure: Callable, bsdf_node: Callable) -> LobeKind:
    """Add a lobe kind with its printer for the OSL backend (``backends.osl_closures``) and its
    builder for the node-graph backend (``backends.bsdf_nodes``): the three tables every lobe is
    evaluated, printed and built from. Lobes of a new kind are never merged with others
    (``backends.lobe_budget.MERGEABLE``)."""
    from .backends import bsdf_nodes, osl_closures

    if kind_.name in KINDS:
        raise ValueError(f"a lobe kind named {kind_.name!r} is registered already")
    if kind_.side not in ("reflected", "transmitted"):
        raise ValueError(f"lobe kind {kind_.name!r}: side is 'reflected' or 'transmitted', got {kind_.side!r}")
    KINDS[kind_.name] = kind_
    osl_closures.CLOSURES[kind_.name] = osl_closure
    bsdf_nodes.BSDF_NODES[kind_.name] = bsdf_node
    return kind_


def unregister(name: str) -> None:
    """Remove a lobe kind registered by :func:`register` from the three tables."""
    from .backends import bsdf_nodes, osl_closures

    for table in (KINDS, osl_closures.CLOSURES, bsdf_nodes.BSDF_NODES):
        table.pop(name, None)


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
