"""GGX refraction about the transmitted mean direction: the light a dielectric base (glass) sends
down into its substrate, rendered by a refracting closure at one fixed index (``REFRACT_ETA``)
whose normal is tilted so that its refraction is the model's transmitted direction."""
from __future__ import annotations

import math

from .. import luts
from ..luts import REFRACT_ETA
from ..models.ggx import ALPHA_EVAL_MIN, smith_s
from ..models.variance import rms_alpha
from .bsdf_node import BsdfNode
from .kind import GD_FLOOR, LobeKind, osl_frame


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


def _closure_albedo(ops, alpha, n, wi):
    """The closure's directional transmittance at weight 1 (``ggx_refract_albedo``) for the view
    ``wi`` about its normal ``n``."""
    mu = wi[0] * n[0] + wi[1] * n[1] + wi[2] * n[2]
    return ops.lut("ggx_refract_albedo", luts.mu_to_coord(ops, mu), luts.alpha_to_coord(ops, alpha))


def _transmission_scale(ops, args, wi):
    """1 / the closure's directional transmittance at weight 1 (its ``albedo`` argument)."""
    return 1.0 / ops.max(args["albedo"], GD_FLOOR)


def _transmission_args(ops, lobe, wi):
    """The closure's roughness and normal, the lobe's index (EEVEE's refraction reads it) and the
    closure's albedo (its normaliser, and what EEVEE's weight undoes it by: ``_eevee_transmission``)."""
    n = _transmission_normal(ops, lobe, wi)
    alpha = _transmission_alpha(ops, lobe)
    return {"alpha": alpha, "nx": n[0], "ny": n[1], "nz": n[2], "eta": lobe.eta,
            "albedo": _closure_albedo(ops, alpha, n, wi)}


def _osl_transmission(a: dict) -> str:
    """Cycles' refracting GGX closure (refract = 1) at index REFRACT_ETA about the closure normal
    given in the local frame."""
    nn, t, b = osl_frame(a)
    n = f'normalize({a["nx"]} * {t} + {a["ny"]} * {b} + {a["nz"]} * {nn})'
    return f'microfacet("ggx", {n}, {a["alpha"]}, {REFRACT_ETA!r}, 1)'


def _bsdf_transmission(ops, a, wi):
    """Refraction BSDF (GGX) at index REFRACT_ETA about the closure normal."""
    return BsdfNode("ShaderNodeBsdfRefraction", {"distribution": "GGX"},
                    {"Roughness": ops.sqrt(a["alpha"]), "IOR": REFRACT_ETA},
                    {"Normal": (a["nx"], a["ny"], a["nz"])})


def _eevee_transmission(ops, a, wi):
    """EEVEE's refraction: a Refraction BSDF at the lobe's own index about the shading normal, so
    that EEVEE, which follows refracted light through an object's thickness (the material output's
    Thickness; unlinked, the object's), bends it at the far side as the glass does, with the
    Walter roughness whose refraction spreads as the lobe (``_transmission_alpha`` at the lobe's
    index, not REFRACT_ETA), and the weight of the lobe's energy: the closure's weight times the
    closure's albedo (its normaliser undone, ``_transmission_scale``; an argument, so the shaders
    read it from the material table)."""
    eta = ops.max(ops.abs(a["eta"] - 1.0), 1e-3)
    lobe_alpha = a["alpha"] * ((REFRACT_ETA - 1.0) / (2.0 * REFRACT_ETA))
    alpha = ops.clamp(2.0 * a["eta"] * lobe_alpha / eta, ALPHA_EVAL_MIN, 1.0)
    node = BsdfNode("ShaderNodeBsdfRefraction", {"distribution": "GGX"},
                    {"Roughness": ops.sqrt(alpha), "IOR": a["eta"]}, {"Normal": (0.0, 0.0, 1.0)})
    return node, a["albedo"]


KIND = LobeKind("transmission", "transmitted", _transmission_closure_cos, _transmission_scale, _transmission_args,
                "GGX refraction lobe about the transmitted direction, below a dielectric base", _osl_transmission,
                _bsdf_transmission, eevee=_eevee_transmission)
