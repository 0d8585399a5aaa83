"""Pre-integrated interface terms read from the tables of ``lamella.core.luts``.

FGD (paper 001 Eq. 8) is the directional albedo of a rough interface with exact Fresnel; GD (paper
001 Eq. 38) the same with F = 1, the lobe normaliser. Both are written as "exact smooth value +
tabulated rough correction" so every smooth limit is exact to floating-point precision.
"""
from __future__ import annotations

from .. import luts
from .fresnel import fresnel_conductor, fresnel_dielectric
from .rgb import RGB

def _coords(ops, mu, alpha):
    return luts.mu_to_coord(ops, mu), luts.alpha_to_coord(ops, alpha)


def gd(ops, mu, alpha):
    """Directional albedo of a GGX lobe with F = 1 (paper 001 Eq. 38)."""
    cm, ca = _coords(ops, mu, alpha)
    return ops.lut("ggx_albedo", cm, ca)


def fgd_dielectric(ops, mu, alpha, eta):
    """FGD of a dielectric interface, light from the side of index n1 onto n2, eta = n2 / n1:
    F(mu, eta) + [FGD - F](mu, alpha, eta) from the 3D table; clamped to [0, 1]."""
    cm, ca = _coords(ops, mu, alpha)
    delta = ops.lut("fgd_dielectric_delta", cm, ca, luts.eta_to_coord(ops, eta))
    return ops.clamp(fresnel_dielectric(ops, mu, eta) + delta, 0.0, 1.0)


def fgd_conductor(ops, mu, alpha, eta: RGB, k: RGB) -> RGB:
    """FGD of a conductor of relative index eta + i k, as the exact Fresnel at mu plus a
    quadrature of the Fresnel curve at the fixed cosines ``luts.FRESNEL_NODES`` against the
    tabulated rough-minus-smooth weights (see ``luts``, table ``fresnel_hat_delta``)."""
    cm, ca = _coords(ops, mu, alpha)
    nodes = luts.FRESNEL_NODES
    weights = [ops.lut("fresnel_hat_delta", cm, ca, j / (len(nodes) - 1.0)) for j in range(len(nodes))]
    out = []
    for e, kk in zip(eta, k):
        f = fresnel_conductor(ops, mu, e, kk)
        for j, c in enumerate(nodes):
            f = f + fresnel_conductor(ops, c, e, kk) * weights[j]
        out.append(ops.clamp(f, 0.0, 1.0))
    return RGB(*out)


def tir_fraction(ops, sx, sy, n_inside, alpha):
    """Belcour 2018's TIR term: the fraction of an upward lobe of roughness ``alpha`` in a medium
    of index ``n_inside``, whose mean direction has tangential part (sx, sy), that lies inside the
    escape cone toward vacuum (sin < 1 / n_inside). Exactly 1 for a smooth lobe refracted in from
    outside and for n_inside <= 1."""
    u = ops.min(ops.sqrt(sx * sx + sy * sy) * n_inside, 1.0)
    eta = 1.0 / n_inside
    return ops.lut("tir", u, luts.alpha_to_coord(ops, alpha), luts.tir_eta_to_coord(ops, eta))
