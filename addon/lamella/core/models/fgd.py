"""Pre-integrated interface terms read from the tables of ``lamella.core.luts``.

FGD (paper 001 Eq. 8) is the directional albedo of a rough interface with exact Fresnel; GD (paper
001 Eq. 38) the same with F = 1, the lobe normaliser. Both are written as "exact smooth value +
tabulated rough correction" so every smooth limit is exact to floating-point precision.
"""
from __future__ import annotations

from .. import luts
from .fresnel import f0_conductor, fresnel_conductor, fresnel_dielectric
from .rgb import RGB

F82_COS = 1.0 / 7.0  # Hoffman 2023: the F82 tint is matched at cos(theta) = 1/7 (~81.8 deg)


def _coords(ops, mu, alpha):
    return luts.mu_to_coord(ops, mu), luts.alpha_to_coord(ops, alpha)


def gd(ops, mu, alpha):
    """Directional albedo of a GGX lobe with F = 1 (paper 001 Eq. 38)."""
    cm, ca = _coords(ops, mu, alpha)
    return ops.lut("ggx_albedo_A", cm, ca)


def fgd_dielectric(ops, mu, alpha, eta):
    """FGD of a dielectric interface, light from the side of index n1 onto n2, eta = n2 / n1:
    F(mu, eta) + [FGD - F](mu, alpha, eta) from the 3D table; clamped to [0, 1]."""
    cm, ca = _coords(ops, mu, alpha)
    delta = ops.lut("fgd_dielectric_delta", cm, ca, luts.eta_to_coord(ops, eta))
    return ops.clamp(fresnel_dielectric(ops, mu, eta) + delta, 0.0, 1.0)


def fgd_conductor(ops, mu, alpha, eta: RGB, k: RGB) -> RGB:
    """FGD of a conductor of relative index eta + i k: the exact Fresnel at mu plus the rough
    correction of the F82 fit of that Fresnel curve (F0 from eta, k; tint a matched at cos = 1/7),
    whose albedo is linear in three tabulated integrals: F0 A + (1 - F0) B - a C."""
    cm, ca = _coords(ops, mu, alpha)
    A = ops.lut("ggx_albedo_A", cm, ca)
    B = ops.lut("ggx_albedo_B", cm, ca)
    C = ops.lut("ggx_albedo_C", cm, ca)
    one_m = 1.0 - mu
    one_m5 = one_m * one_m * one_m * one_m * one_m
    B0, C0 = one_m5, mu * one_m5 * one_m  # the alpha = 0 values of B and C
    cb = F82_COS
    schlick_w = (1.0 - cb) ** 5
    tint_w = cb * (1.0 - cb) ** 6
    out = []
    for e, kk in zip(eta, k):
        f0 = f0_conductor(e, kk)
        a = (f0 + (1.0 - f0) * schlick_w - fresnel_conductor(ops, cb, e, kk)) * (1.0 / tint_w)
        rough_minus_smooth = f0 * (A - 1.0) + (1.0 - f0) * (B - B0) - a * (C - C0)
        out.append(ops.clamp(fresnel_conductor(ops, mu, e, kk) + rough_minus_smooth, 0.0, 1.0))
    return RGB(*out)


def tir_fraction(ops, sx, sy, n_inside, alpha):
    """Belcour 2018's TIR term: the fraction of an upward lobe of roughness ``alpha`` in a medium
    of index ``n_inside``, whose mean direction has tangential part (sx, sy), that lies inside the
    escape cone toward vacuum (sin < 1 / n_inside). Exactly 1 for a smooth lobe refracted in from
    outside and for n_inside <= 1."""
    u = ops.min(ops.sqrt(sx * sx + sy * sy) * n_inside, 1.0)
    eta = 1.0 / n_inside
    return ops.lut("tir", u, luts.alpha_to_coord(ops, alpha), luts.tir_eta_to_coord(ops, eta))
