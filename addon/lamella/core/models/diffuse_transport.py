"""Diffuse light between a Lambertian base and the coats above it (not in the layered-model
papers; the classical adding of hemispherical reflectances, e.g. van de Hulst 1980, with the
coats' internal diffuse reflectance as in Kubelka-Munk-type layer models).

Light a diffuse base sends up is cosine-distributed over the hemisphere of the medium above it.
Each coat is summarised for such light by hemispherical averages of its energies:

* an interface from index n1 onto n2: R_d(n2 / n1) = integral of F(mu) 2 mu d mu (exact Fresnel,
  total internal reflection included from the dense side), T_d = 1 - R_d on each side; computed as
  the Fresnel quadrature of ``fgd.py`` integrated over the hemisphere (weights of the cosine
  nodes' hat functions, exact for the piecewise-linear Fresnel curve); the interface roughness is
  neglected (it redistributes diffuse light but hardly changes its hemispherical average);
* an absorbing interior of optical depth tau (normal incidence): T_d(tau) = 2 E3(tau) =
  integral of exp(-tau / mu) 2 mu d mu, by 8-point Gauss-Legendre quadrature;
* a scattering interior: the Kubelka-Munk slab of the six-flux model (``homogeneous_medium``) over
  twice the thickness, the mean path of cosine-distributed light.

``DiffuseUp`` adds these from the top coat down, keeping what the base needs: the transmittance
``up`` of the whole stack above for diffuse light going up, and its reflectance ``back`` (light
going up that the stack returns, by reflections and total internal reflection). The base then
sends out ``e_in A up / (1 - A back)`` (all orders of base-coat bounces), e_in the energy that
reached it.
"""
from __future__ import annotations

from .. import luts
from .fresnel import fresnel_dielectric
from .rgb import RGB


def _hat_hemispherical_weights(nodes) -> tuple[float, ...]:
    """w_j = integral over [0, 1] of h_j(mu) 2 mu d mu for the hat functions over ``nodes``."""
    out = []
    for j in range(len(nodes)):
        w = 0.0
        if j > 0:  # rising part on [a, b]: (mu - a) / (b - a)
            a, b = nodes[j - 1], nodes[j]
            w += 2.0 / (b - a) * ((b ** 3 - a ** 3) / 3.0 - a * (b * b - a * a) / 2.0)
        if j + 1 < len(nodes):  # falling part: (b - mu) / (b - a)
            a, b = nodes[j], nodes[j + 1]
            w += 2.0 / (b - a) * (b * (b * b - a * a) / 2.0 - (b ** 3 - a ** 3) / 3.0)
        out.append(w)
    return tuple(out)


HEMI_WEIGHTS = _hat_hemispherical_weights(luts.FRESNEL_NODES)

# 8-point Gauss-Legendre on [0, 1] (nodes, weights)
_GL_X = (0.1834346424956498, 0.5255324099163290, 0.7966664774136267, 0.9602898564975363)
_GL_W = (0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763)
GAUSS_MU = tuple(0.5 * (1.0 + s * x) for x in _GL_X for s in (-1.0, 1.0))
GAUSS_W = tuple(0.5 * w for w in _GL_W for _ in (-1.0, 1.0))


def diffuse_fresnel(ops, eta):
    """Hemispherical (cosine-weighted) average of the exact Fresnel reflectance, light from index
    n1 onto n2, eta = n2 / n1."""
    total = 0.0
    for c, w in zip(luts.FRESNEL_NODES, HEMI_WEIGHTS):
        total = total + w * fresnel_dielectric(ops, c, eta)
    return ops.clamp(total, 0.0, 1.0)


def diffuse_transmittance(ops, tau):
    """2 E3(tau): the fraction of cosine-distributed light crossing a slab of normal optical depth
    tau (>= 0) unabsorbed. Each term decays, so any tau is finite (0 for tau -> inf)."""
    total = 0.0
    for mu, w in zip(GAUSS_MU, GAUSS_W):
        total = total + (w * 2.0 * mu) * ops.exp(-tau * (1.0 / mu))
    return total


def interior(ops, p) -> tuple[RGB, RGB | None]:
    """Diffuse transmittance and (if it scatters) reflectance of a coat's interior, from its
    backend parameters ``p`` (``thickness``, ``sigma_a``, ``sigma_s``, ``g``)."""
    from .homogeneous_medium import slab

    sig_a = p.get("sigma_a", RGB.splat(0.0))
    if "sigma_s" not in p:
        return sig_a.map(lambda s: diffuse_transmittance(ops, s * p["thickness"])), None
    kd = [slab(ops, sa, ss, p["g"], 2.0 * p["thickness"]) for sa, ss in zip(sig_a, p["sigma_s"])]
    return RGB(*(x[2] for x in kd)), RGB(*(x[1] for x in kd))


class DiffuseUp:
    """The stack above a diffuse base, for diffuse light going up: ``up`` (transmitted to the top)
    and ``back`` (returned downward), per channel, built coat by coat from the top."""

    def __init__(self):
        self.up = RGB.splat(1.0)
        self.back = RGB.splat(0.0)

    def add_interface(self, ops, eta):
        """An interface below the part added so far: n_below / n_above = eta."""
        r_above = diffuse_fresnel(ops, eta)  # light coming down onto it
        r_below = diffuse_fresnel(ops, 1.0 / eta)  # light coming up onto it (TIR included)
        denom = (1.0 - r_above * self.back).map(lambda d: ops.max(d, 1e-7))
        self.up = (1.0 - r_below) * self.up / denom
        self.back = r_below + (1.0 - r_below) * self.back * (1.0 - r_above) / denom

    def add_medium(self, ops, t: RGB, r: RGB | None = None):
        """A medium below the part added so far: diffuse transmittance ``t`` each way and (a
        scattering medium) diffuse reflectance ``r`` on each side."""
        if r is None:
            self.up = t * self.up
            self.back = t * t * self.back
            return
        denom = (1.0 - r * self.back).map(lambda d: ops.max(d, 1e-7))
        self.up = t * self.up / denom
        self.back = r + t * t * self.back / denom

    def base_energy(self, ops, e_in: RGB, albedo: RGB) -> RGB:
        """Energy a Lambertian base of ``albedo`` sends out of the top, all orders of bounces
        between the base and the stack above, for energy ``e_in`` reaching it."""
        return e_in * albedo * self.up / (1.0 - albedo * self.back).map(lambda d: ops.max(d, 1e-7))
