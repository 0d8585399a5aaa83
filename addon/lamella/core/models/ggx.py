"""Anisotropic GGX reflection lobe over the abstract ops.

Conventions (shared with the stochastic reference and the look-up tables): the GGX normal
distribution of Walter et al. 2007 Eq. (33) in its anisotropic form (Heitz 2014, "Understanding
the masking-shadowing function", Eq. 85), Smith's Lambda (Heitz 2014, Eq. 86) and the
height-correlated masking-shadowing G2 = 1 / (1 + Lambda(wi) + Lambda(wo)) (Heitz 2014, Eq. 99).
Directions are in the local frame (z = normal, x = shading tangent); a lobe's axes are that frame
turned by ``rotation`` about z.
"""
from __future__ import annotations

import math

# A delta (alpha = 0) lobe cannot be evaluated pointwise; evaluation uses this floor instead, which
# keeps the lobe's energy (the GD normalisation divides it out) and every intermediate finite in
# float32: (1 / ALPHA_EVAL_MIN**2)**2 = 1e16 < 3.4e38.
ALPHA_EVAL_MIN = 1e-4


def rotate_to_lobe(ops, x, y, cos_r, sin_r):
    """Components of a tangent-plane vector along a lobe's axes (frame turned by angle r)."""
    return x * cos_r + y * sin_r, -x * sin_r + y * cos_r


def projected_alpha2(ax, ay, x, y):
    """Squared roughness seen along the tangent-plane direction (x, y) (not normalised):
    returns ax^2 x^2 + ay^2 y^2 (Heitz 2014, Eq. 80, times sin^2)."""
    return ax * ax * x * x + ay * ay * y * y


def ggx_d(ops, hx, hy, hz, ax, ay):
    """Anisotropic GGX NDF D(h) for a half vector in the lobe frame (Heitz 2014, Eq. 85)."""
    t = hx * hx / (ax * ax) + hy * hy / (ay * ay) + hz * hz
    return 1.0 / (math.pi * ax * ay * t * t)


def smith_s(ops, z, a2s):
    """sqrt(z^2 + alpha_proj^2 sin^2): the stable building block of Lambda. With
    s = smith_s(...), Lambda = (s - |z|) / (2 |z|) and G1 = 2 |z| / (|z| + s)."""
    return ops.sqrt(z * z + a2s)


def ggx_lobe_cos(ops, wi, wo, ax, ay, cos_r, sin_r):
    """rho(wi, wo) * wo.z for a GGX reflection lobe without Fresnel:
    D(h) G2(wi, wo) / (4 wi.z wo.z) * wo.z, rewritten without any division by wi.z or wo.z:
    G2 / (4 wi.z) = wo.z / (2 (wo.z s_i + wi.z s_o)). Zero for wo below the horizon."""
    ix, iy, iz = wi
    ox, oy, oz = wo
    ax = ops.max(ax, ALPHA_EVAL_MIN)
    ay = ops.max(ay, ALPHA_EVAL_MIN)
    iz = ops.max(iz, 0.0)
    ozp = ops.max(oz, 0.0)
    hx, hy, hz = ix + ox, iy + oy, iz + ozp
    hlen = ops.sqrt(ops.max(hx * hx + hy * hy + hz * hz, 1e-30))
    hx, hy, hz = hx / hlen, hy / hlen, hz / hlen
    lhx, lhy = rotate_to_lobe(ops, hx, hy, cos_r, sin_r)
    d = ggx_d(ops, lhx, lhy, hz, ax, ay)
    lix, liy = rotate_to_lobe(ops, ix, iy, cos_r, sin_r)
    lox, loy = rotate_to_lobe(ops, ox, oy, cos_r, sin_r)
    s_i = smith_s(ops, iz, projected_alpha2(ax, ay, lix, liy))
    s_o = smith_s(ops, ozp, projected_alpha2(ax, ay, lox, loy))
    den = ops.max(2.0 * (ozp * s_i + iz * s_o), 1e-30)
    return ops.select(oz > 0.0, d * ozp / den, 0.0)


def alpha_of_projected_width(ops, b, c, k):
    """The roughness alpha of the GGX reflection lobe whose width projected on the surface at view
    cosine ``c`` is 2 sqrt(b), with the projected width modelled as 2 alpha sqrt(c^2 + k alpha^2)
    (first order 2 alpha c; ``k`` > 0 narrows broad lobes toward grazing, where the horizon cuts
    them): alpha^2 = 2 b / (sqrt(c^4 + 4 k b) + c^2), the root of alpha^2 (c^2 + k alpha^2) = b in
    the form that does not cancel."""
    c2 = c * c
    return ops.sqrt(2.0 * b / ops.max(ops.sqrt(c2 * c2 + 4.0 * k * b) + c2, 1e-30))


def alpha_across_of_round(ops, a, c, k):
    """The roughness across the plane of incidence of the GGX lobe that, seen at view cosine ``c``,
    is as wide across as a lobe of roughness ``a`` is at normal incidence (its directions round in
    angle about the mirror): the projected width of ``alpha_of_projected_width`` at normal
    incidence, 2 a sqrt(1 + k a^2), matched at ``c``; a / c to first order, at most 1."""
    b = a * a * (1.0 + k * a * a)
    return ops.min(alpha_of_projected_width(ops, b, c, k), 1.0)
