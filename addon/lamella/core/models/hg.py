"""Henyey-Greenstein statistics of the transfer-matrix models (Randrianandrasana et al. 2021,
Section 4-6): the GGX alpha <-> HG asymmetry fit, the transmitted-asymmetry operator, the
back-scattered fraction of a HG phase function and where its backward half goes."""
from __future__ import annotations

from .. import luts

G_ALPHA_MAX = -0.085 + 1.085 / (1.0 + 2.0 ** 1.3)  # g(alpha = 1): rougher lobes clamp to alpha 1


def g_of_alpha(ops, alpha):
    """Asymmetry of the HG lobe equivalent to a GGX reflection of roughness alpha at normal
    incidence (Randrianandrasana et al. 2021, Eq. 15): g = -0.085 + 1.085 / (1 + (alpha/0.5)^1.3)."""
    return -0.085 + 1.085 / (1.0 + ops.pow(ops.max(alpha, 0.0) * 2.0, 1.3))


def alpha_of_g(ops, g):
    """Inverse of Eq. 15: alpha = 0.5 (1.085 / (g + 0.085) - 1)^(1/1.3), clamped to [0, 1] (a lobe
    broader than alpha 1, g below G_ALPHA_MAX, is drawn at alpha 1)."""
    gc = ops.clamp(g, G_ALPHA_MAX, 1.0)
    return ops.clamp(0.5 * ops.pow(ops.max(1.085 / (gc + 0.085) - 1.0, 0.0), 1.0 / 1.3), 0.0, 1.0)


def transmitted_g(ops, g, eta_ratio):
    """Asymmetry of an HG lobe after a smooth interface from index n_i onto n_t,
    eta_ratio = n_i / n_t (Eq. 17): h(g) = sqrt(1 - clamp((1 - g^2) eta_ratio^(3/4), 0, 1))."""
    t = (1.0 - g * g) * ops.pow(ops.max(eta_ratio, 0.0), 0.75)
    return ops.sqrt(1.0 - ops.clamp(t, 0.0, 1.0))


def backscatter_fraction(ops, g):
    """p-(g): the fraction of a HG phase function scattered into the backward hemisphere
    (Eqs. 30-31): Q(|g|) for g >= 0, 1 - Q(|g|) otherwise, Q(u) = 0.5039 - 0.8254 u + 0.3226 u^2."""
    u = ops.abs(g)
    q = 0.5039 - 0.8254 * u + 0.3226 * u * u
    return ops.select(g >= 0.0, q, 1.0 - q)


def belcour_variance_of_g(ops, g):
    """The spread a HG medium adds to the light it scatters forward, in the variance space of
    Belcour 2018's roughness mapping (Belcour 2018, Eq. 21): ((1 - g) / g)^0.8 / (1 + g), g clamped
    to [1e-5, 1] (isotropic and back-scattering media spread as far as the mapping goes)."""
    gc = ops.clamp(g, 1e-5, 1.0)
    return ops.pow((1.0 - gc) / gc, 0.8) / (1.0 + gc)


def backward_mean_cosine(ops, g):
    """Mean cosine, about the backward direction, of the backward half of a HG phase function:
    -int_{-1}^0 mu p(mu) dmu / int_{-1}^0 p(mu) dmu in closed form, with a = sqrt(1 + g^2):
    -(1/g) (a - (1 + g + g^2) / (1 + g)) / (1/a - 1/(1 + g)); 1/2 - g/4 + g^2/4 below |g| = 0.01,
    where the closed form cancels, 0.414 at g = 0.9, 0.93 at g = -0.9."""
    a = ops.sqrt(1.0 + g * g)
    small = ops.abs(g) < 0.01
    gs = ops.select(small, 0.5, g)  # keeps the unused branch finite
    one = 1.0 + gs
    closed = -(a - (1.0 + gs + gs * gs) / one) / (gs * (1.0 / a - 1.0 / one))
    return ops.select(small, 0.5 - 0.25 * g * (1.0 - g), closed)


def forward_cone_fraction(ops, g, cos_cone):
    """The fraction of the forward half of a HG phase function that lies within the cone of cosine
    ``cos_cone`` about its forward direction: with the HG cumulative over the scattering cosine x,
    F(x) = (1 - g^2) / (2 g) ((1 + g^2 - 2 g x)^-1/2 - 1 / (1 + g)), (F(1) - F(c)) / (F(1) - F(0)) =
    (1 / (1 - g) - (1 + g^2 - 2 g c)^-1/2) / (1 / (1 - g) - (1 + g^2)^-1/2); (1 - c)(1 + 3 g c / 2)
    below |g| = 0.01, where the closed form cancels. The backward half about the backward
    direction is the forward half of -g. 1 for c = 0; for the escape cone of index 1.5 (c = 0.745)
    0.92 at g = 0.9, 0.17 at g = -0.9, 0.255 for isotropic scattering."""
    small = ops.abs(g) < 0.01
    gs = ops.select(small, 0.5, g)  # keeps the unused branch finite
    inv = 1.0 / (1.0 - gs)
    closed = (inv - 1.0 / ops.sqrt(1.0 + gs * gs - 2.0 * gs * cos_cone)) / (inv - 1.0 / ops.sqrt(1.0 + gs * gs))
    return ops.select(small, (1.0 - cos_cone) * (1.0 + 1.5 * g * cos_cone), closed)


def backward_escape(ops, g, sine, cos_cone):
    """Of the backward half of a HG phase function about a primary going down at ``sine`` to the
    normal (the light a medium back-scatters once), the share inside the escape cone of cosine
    ``cos_cone`` about the normal (the ``hg_backward_escape`` table). At normal incidence it is
    ``forward_cone_fraction(-g, cos_cone)``; a tilted primary tilts the half-lobe's edge with it
    and sends more of it up steeply (g = 0.9, index 1.5: 0.171 at normal incidence, 0.200 at 60
    degrees outside), and part of it down (25 %)."""
    return ops.clamp(ops.lut("hg_backward_escape", luts.g_to_coord(ops, g), ops.clamp(sine, 0.0, 1.0),
                             ops.clamp(cos_cone, 0.0, 1.0)), 0.0, 1.0)


def backward_abs_cosine(ops, g, sine):
    """The mean |cosine to the normal| of that backward half-lobe (the ``hg_backward_cosine``
    table): ``backward_mean_cosine(g)`` at normal incidence (0.414 at g = 0.9), more as the
    primary tilts (0.464 at 60 degrees outside a coat of index 1.5)."""
    return ops.clamp(ops.lut("hg_backward_cosine", luts.g_to_coord(ops, g), ops.clamp(sine, 0.0, 1.0)), 0.05, 1.0)
