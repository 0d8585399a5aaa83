"""Roughness <-> variance mappings of the statistical layered models.

``belcour``: h(a) = a^1.1 / (1 - a^1.1) (Belcour 2018; restated in Yamaguchi et al. 2019 Eqs. 1-2), inverse
(v / (1 + v))^(1/1.1); ``BelcourMapping(p)`` the same form with another exponent (studies).
``weier``: f(a) = log(1 + b a^A / (1 - a^A)), inverse ((e^v - 1) / (e^v - 1 + b))^(1/A) with
A = 1.28809776, b = 1.31699416 (Weier & Belcour 2020, Section 3.3 and Listing 2).

Both forward maps clamp a^p below 1 - 1e-5 as Listing 2 does, so alpha = 1 gives a large finite
variance. The inverses are written so that no intermediate overflows for any variance >= 0:
the Weier inverse uses e^-v (in (0, 1]) instead of e^v.
"""
from __future__ import annotations

BELCOUR_P = 1.1
WEIER_A = 1.28809776
WEIER_B = 1.31699416
_POW_MAX = 0.99999


class Mapping:
    """``exponent``: the power of alpha the variance grows with at small roughness (a roughness
    scaled by j scales the variance by j ** exponent there)."""

    name = ""
    exponent = 1.0

    def to_variance(self, ops, a):
        raise NotImplementedError

    def to_roughness(self, ops, v):
        raise NotImplementedError


class BelcourMapping(Mapping):
    """h(a) = a^p / (1 - a^p); Belcour 2018's p = 1.1, other exponents for studies."""

    def __init__(self, p: float = BELCOUR_P):
        self.exponent = p
        self.name = "belcour" if p == BELCOUR_P else f"belcour p={p:g}"

    def to_variance(self, ops, a):
        ap = ops.min(ops.pow(ops.max(a, 0.0), self.exponent), _POW_MAX)
        return ap / (1.0 - ap)

    def to_roughness(self, ops, v):
        v = ops.max(v, 0.0)
        return ops.pow(v / (1.0 + v), 1.0 / self.exponent)


class WeierMapping(Mapping):
    name = "weier"
    exponent = WEIER_A

    def to_variance(self, ops, a):
        ap = ops.min(ops.pow(ops.max(a, 0.0), WEIER_A), _POW_MAX)
        return ops.log(1.0 + WEIER_B * ap / (1.0 - ap))

    def to_roughness(self, ops, v):
        e = ops.exp(-ops.max(v, 0.0))  # (e^v - 1) / (e^v - 1 + b) = (1 - e) / (1 - e + b e)
        num = 1.0 - e
        return ops.pow(num / (num + WEIER_B * e), 1.0 / WEIER_A)


MAPPINGS = {"belcour": BelcourMapping(), "weier": WeierMapping()}
