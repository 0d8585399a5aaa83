"""Exact unpolarised Fresnel reflectance, written once over the abstract ops.

Dielectric: Guo et al. 2015 Eq. (9) / Walter et al. 2007 Eq. (22) in the s/p form, with total internal
reflection. Conductor: the exact complex-index form (e.g. Born & Wolf; the formula used by pbrt-v4
``FrComplex`` expanded into real arithmetic), unpolarised average of s and p.
"""
from __future__ import annotations

from .rgb import RGB


def fresnel_dielectric(ops, cos_i, eta):
    """Reflectance of light arriving at cosine ``cos_i`` (>= 0) from a medium of index n1 onto one
    of index n2, ``eta = n2 / n1`` (> 0). Returns 1 under total internal reflection."""
    cos_i = ops.clamp(cos_i, 0.0, 1.0)
    # cos_t^2 = 1 - (1 - cos_i^2) / eta^2, written as (eta^2 - 1 + cos_i^2) / eta^2 so that an
    # index-matched interface gives cos_t = cos_i exactly instead of a cancellation at grazing.
    eta2 = eta * eta
    cos2_t_num = (eta2 - 1.0) + cos_i * cos_i
    cos_t = ops.sqrt(ops.max(cos2_t_num, 0.0) / eta2)
    rs_den = cos_i + eta * cos_t
    rp_den = eta * cos_i + cos_t
    # Both denominators vanish only at cos_i = cos_t = 0, i.e. grazing incidence on an
    # index-matched interface (eta = 1), whose reflectance is 0 (both numerators vanish too).
    # TIR is strictly cos_t^2 < 0: at cos_t = 0 the formulas below are exact (1 at the critical
    # angle for eta < 1, 0 for eta = 1 at grazing).
    rs = (cos_i - eta * cos_t) / ops.max(rs_den, 1e-30)
    rp = (eta * cos_i - cos_t) / ops.max(rp_den, 1e-30)
    f = 0.5 * (rs * rs + rp * rp)
    return ops.select(cos2_t_num < 0.0, 1.0, ops.min(f, 1.0))


def fresnel_conductor(ops, cos_i, eta, k):
    """Reflectance of a conductor of relative complex index ``eta + i k`` (scalar channel) at
    incidence cosine ``cos_i``. Exact for the unpolarised average of s and p."""
    c = ops.clamp(cos_i, 0.0, 1.0)
    c2 = c * c
    s2 = 1.0 - c2
    eta2 = eta * eta
    k2 = k * k
    t0 = eta2 - k2 - s2
    a2pb2 = ops.sqrt(ops.max(t0 * t0 + 4.0 * eta2 * k2, 0.0))
    a = ops.sqrt(ops.max(0.5 * (a2pb2 + t0), 0.0))
    t1 = a2pb2 + c2
    t2 = 2.0 * a * c
    rs = (t1 - t2) / ops.max(t1 + t2, 1e-30)
    t3 = c2 * a2pb2 + s2 * s2
    t4 = t2 * s2
    rp = rs * (t3 - t4) / ops.max(t3 + t4, 1e-30)
    return ops.clamp(0.5 * (rp + rs), 0.0, 1.0)


def fresnel_conductor_rgb(ops, cos_i, eta: RGB, k: RGB) -> RGB:
    return RGB(*(fresnel_conductor(ops, cos_i, e, kk) for e, kk in zip(eta, k)))

