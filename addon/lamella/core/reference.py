"""Stochastic ground truth of the exact layered BSDF (DESIGN.md, "Contract: the Python API").

Plain numpy, never traced, never imported by the models: the yardstick every analytic model is
measured against. Correctness and unbiasedness first, then variance, then speed.

The physical model (exact, no approximations beyond the ones named here)
------------------------------------------------------------------------
* Planar, infinitely wide layers. Media ``0..N+1``: 0 is the vacuum above (index 1), ``m`` (1..N)
  the interior of coat ``m-1``, ``N+1`` the glass half-space below a dielectric base. Interface
  ``j`` (0..N) separates media ``j`` and ``j+1``; interface ``N`` is the base.
* Every interface is a single-scattering anisotropic GGX microfacet interface: reflection and
  refraction of Walter et al. 2007 ("Microfacet models for refraction through rough surfaces",
  Eqs. 20-21 with the generalised half vector of Eq. 16 and the Jacobians of Eqs. 14 and 17), with
  the exact unpolarised dielectric Fresnel factor (total internal reflection included) or the exact
  complex conductor Fresnel factor for index ``(eta + i k) / n_above``. Anisotropic alpha
  ``(ax, ay)`` along axes turned by ``rotation`` about the normal.
* Masking-shadowing: the height-correlated Smith form G2 = 1 / (1 + Lambda(i) + Lambda(o)) for
  reflection *and* transmission (as pbrt-v4's ``TrowbridgeReitzDistribution::G``), with the
  anisotropic GGX Lambda of Heitz 2014 ("Understanding the masking-shadowing function", Eq. 86).
  Microfacet normals are sampled from the distribution of visible normals (Heitz 2018, "Sampling
  the GGX distribution of visible normals", JCGT 7(4), Listing 1), so a sampled event carries the
  weight G2 / G1(i) (times the conductor Fresnel factor).
* Roughness ``(0, 0)`` is a perfectly smooth interface: delta reflection / refraction with the exact
  Fresnel factor, handled as such (never as a tiny alpha). A dielectric interface between equal
  indices does not exist optically, whatever its roughness: it passes light straight through
  (as pbrt-v4's ``DielectricBxDF`` does for eta == 1). A rough interface with exactly one zero axis
  (a degenerate, one-dimensional GGX) is evaluated with that axis raised to ``ALPHA_MIN``.
* Coat interiors are homogeneous media of ``thickness`` with ``sigma_a``, ``sigma_s`` (RGB, per
  unit length) and a Henyey-Greenstein phase function of parameter ``g``; attenuation is
  Beer-Lambert along the actual path length. Distances are sampled with one-sample spectral MIS
  (a channel chosen uniformly, density = the mean of the three channels' densities), unbiased in
  every channel.
* Diffuse base: Lambertian ``albedo``. Dielectric base: a rough or smooth interface into a glass
  half-space of index ``ior``; what crosses it leaves the stack downward.

What is estimated
-----------------
Energy packets enter along ``-wi`` ("light from wi"). ``eval_brdf_cos(wi, wo)`` is the density,
per unit solid angle *of the exit medium*, of the energy leaving toward ``wo``: for a reflected
``wo`` (``wo.z > 0``) this is f(wi, wo) |wo.z| with the (reciprocal) BRDF f; for a transmitted
``wo`` (``wo.z < 0``, only with a dielectric base) it is Walter's f_t(wi, wo) |wo.z| with light
incident from ``wi`` and the eta^2 = (n_substrate / 1)^2 factor of Walter Eq. 21, i.e. *energy*
per solid angle in the substrate. Its integral over the lower hemisphere is therefore exactly
``albedo(side="transmitted")``. (The radiance BTDF for light arriving from the substrate along
``wo`` seen from ``wi`` differs by the factor 1 / n_substrate^2: f(wo -> wi) = f(wi -> wo) / n^2.)

Estimator of ``eval_brdf_cos`` (next-event estimation with MIS)
---------------------------------------------------------------
The walk follows packets with the sampling routines below (VNDF + Fresnel choice at interfaces,
spectral-MIS distance sampling and HG sampling in media, cosine sampling on a Lambertian base,
Russian roulette). A path is split at its events into *delta* events (smooth interfaces,
unscattered passage of a medium) and *non-delta* events (rough-interface reflection or
transmission, a rough or Lambertian base, a medium scattering event). Every path contributing to
f(wi, wo) has a *last* non-delta event ``e``; what follows it is a sequence of delta events, so
``e``'s outgoing direction is fixed by ``wo`` (in a planar stack ``n sin(theta)`` and the azimuth
are invariant: Snell), and the sum over all delta-only continuations (any number of smooth
reflections between smooth interfaces, Beer-Lambert in the unscattered media, non-delta elements
acting as absorbers because their paths are counted at their own events) is a closed-form adding
series computed once per ``wo`` (:class:`_Exit`). This handles pitfall "delta-only suffixes" exactly.

Each path is then counted once, by one or two strategies combined with the power heuristic,
in the spirit of pbrt-v4's ``LayeredBxDF::f`` generalised to any number of interfaces and of
Guo et al. 2018 ("Position-free Monte Carlo simulation for arbitrary layered BSDFs"):

* (B) *evaluation at the last event*: when the walker reaches a non-delta event ``e``, add
  beta x q_e(walker direction -> e's exit direction) x series. Always available.
* (A) *reverse sampling of the last event*: if ``e`` is a rough (or Lambertian) interface reached
  by a straight, unscattered segment from the previous non-delta event ``v`` (a rough interface,
  the base, or a scattering point in the medium between them), then at ``v`` the arrival
  direction at ``e`` is also sampled *from the exit side* (VNDF from e's exit direction, reflected
  or refracted, i.e. pbrt-v4's presampled ``wis``), and ``v``'s own density is evaluated toward
  it: beta x q_v(d) x Tr(d) x q_e(d -> exit) / p_A(d) x series. This is what keeps a glossy exit
  interface over a rougher layer (a clear coat over brushed metal) low-variance.

When both (A) and (B) can produce a path their weights are p^2 / (p_A^2 + p_B^2), with p_B the
walker's sampling density of the segment direction at ``v`` (including the Fresnel choice) and
p_A the reverse density at ``e`` (conditioned on the reflection / transmission it needs). When
only (B) can (``e`` is the first event, or delta events lie between ``v`` and ``e``), its weight
is 1. A scattering point as the last event is counted by evaluating the phase function toward the
exit direction (both up and down) times the series. Smooth-only stacks have delta BRDFs:
``eval_brdf_cos`` returns 0 for them and ``albedo`` is the meaningful quantity.

``albedo`` counts escaping packets (no NEE at all): an independent check of ``eval_brdf_cos``,
whose hemispherical integral must equal ``albedo(..., exclude_delta=True)``.

A packet's *density* q(i -> o) at a rough interface (arrival from the +z side, ``i`` pointing
away from the surface on that side, ``eta = n_o / n_i``) is
q_R = F D G2 / (4 i.z) and q_T = (1 - F) D G2 |i.h| |o.h| eta^2 / (i.z (i.h + eta o.h)^2),
i.e. Walter's f(i, o) |o.z|: its integral over o is the reflected / transmitted energy.
"""
from __future__ import annotations

import math

import numpy as np

from .stack import Conductor, Dielectric, Diffuse, Stack

ALPHA_MIN = 1e-4  # a rough interface with one zero axis is evaluated with this floor on that axis
MAX_EVENTS = 256  # interactions per walker (with Russian roulette the truncation bias is nil)
RR_START = 3  # Russian roulette from this many events on
CHUNK = 1 << 19  # walkers per batch (bounds memory: ~ 1 kB per walker at most)
_TINY = 1e-300


# ============================================================== microfacet primitives (numpy)
def _dot(a, b):
    return np.einsum("ij,ij->i", a, b)


def _normalize(v):
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), _TINY)


def _fresnel_dielectric(c, eta):
    """Unpolarised Fresnel reflectance for a cosine ``c`` >= 0 on the incident side and the
    relative index ``eta = n_transmitted / n_incident``; 1 under total internal reflection."""
    c = np.clip(c, 0.0, 1.0)
    eta2 = eta * eta
    num = eta2 - 1.0 + c * c
    ct = np.sqrt(np.maximum(num, 0.0) / eta2)
    rs = (c - eta * ct) / np.maximum(c + eta * ct, _TINY)
    rp = (eta * c - ct) / np.maximum(eta * c + ct, _TINY)
    return np.where(num <= 0.0, 1.0, np.minimum(0.5 * (rs * rs + rp * rp), 1.0))


def _fresnel_conductor(c, eta, k):
    """Unpolarised Fresnel reflectance of a conductor of relative complex index ``eta + i k``
    (scalars), exact, by complex arithmetic: r_s = (c - w) / (c + w), r_p = (n^2 c - w) / (n^2 c
    + w), w = sqrt(n^2 - sin^2) on the principal branch (Im w >= 0: the wave decays)."""
    c = np.clip(np.asarray(c, dtype=float), 0.0, 1.0)
    n2 = complex(eta, k) ** 2
    wt = np.sqrt(n2 - (1.0 - c * c) + 0j)
    rs = (c - wt) / (c + wt)
    rp = (n2 * c - wt) / (n2 * c + wt)
    return np.clip(0.5 * (np.abs(rs) ** 2 + np.abs(rp) ** 2), 0.0, 1.0)


def smith_lambda(w, ax, ay):
    """Smith Lambda of anisotropic GGX for a direction in the interface's (rotated) frame, Heitz
    2014 Eq. 86: (sqrt(1 + (ax^2 x^2 + ay^2 y^2) / z^2) - 1) / 2. |z| is used (either side)."""
    z2 = np.maximum(w[..., 2] ** 2, _TINY)
    t = (ax * ax * w[..., 0] ** 2 + ay * ay * w[..., 1] ** 2) / z2
    return 0.5 * (np.sqrt(1.0 + t) - 1.0)


def _ggx_d(h, ax, ay):
    """Anisotropic GGX NDF (Walter 2007 Eq. 33, Heitz 2014 Eq. 85) of a unit ``h`` with h.z >= 0."""
    t = h[..., 0] ** 2 / (ax * ax) + h[..., 1] ** 2 / (ay * ay) + h[..., 2] ** 2
    return np.where(t > 0, 1.0 / (math.pi * ax * ay * np.maximum(t, 1e-150) ** 2), 0.0)


def sample_vndf(i, ax, ay, u1, u2):
    """Heitz 2018 Listing 1: a visible normal of anisotropic GGX seen from ``i`` (rows, i.z > 0),
    density D_i(h) = G1(i) max(0, i.h) D(h) / i.z. ``ax``/``ay`` are scalars or per-row arrays.
    (Also used by ``luts`` to build its tables: keep it numerically stable.)"""
    vh = np.stack([ax * i[:, 0], ay * i[:, 1], i[:, 2]], -1)
    vh /= np.linalg.norm(vh, axis=1, keepdims=True)
    lensq = vh[:, 0] ** 2 + vh[:, 1] ** 2
    inv = np.where(lensq > 0, 1.0 / np.sqrt(np.maximum(lensq, 1e-300)), 0.0)
    t1 = np.where((lensq > 0)[:, None], np.stack([-vh[:, 1] * inv, vh[:, 0] * inv, 0 * inv], -1),
                  np.array([1.0, 0.0, 0.0]))
    t2 = np.cross(vh, t1)
    r = np.sqrt(u1)
    phi = 2.0 * math.pi * u2
    p1 = r * np.cos(phi)
    p2 = r * np.sin(phi)
    s = 0.5 * (1.0 + vh[:, 2])
    p2 = (1.0 - s) * np.sqrt(np.maximum(1.0 - p1 * p1, 0.0)) + s * p2
    p3 = np.sqrt(np.maximum(1.0 - p1 * p1 - p2 * p2, 0.0))
    nh = p1[:, None] * t1 + p2[:, None] * t2 + p3[:, None] * vh
    h = np.stack([ax * nh[:, 0], ay * nh[:, 1], np.maximum(nh[:, 2], 1e-12)], -1)
    return h / np.linalg.norm(h, axis=1, keepdims=True)


def _refract(v, h, eta):
    """Refraction of ``v`` (pointing away, v.h > 0) through the microfacet ``h`` into the other
    side, ``eta = n_other / n_v``. Returns (t, ok); ok is False under total internal reflection."""
    c = _dot(v, h)
    s2t = (1.0 - c * c) / (eta * eta)
    ok = s2t < 1.0
    ct = np.sqrt(np.maximum(1.0 - s2t, 0.0))
    t = -v / eta[:, None] + (c / eta - ct)[:, None] * h
    return t, ok


def hg_phase(cos_t, g):
    """Henyey-Greenstein phase function per steradian; ``cos_t`` between the travel directions
    before and after scattering (g > 0: forward scattering)."""
    d = 1.0 + g * g - 2.0 * g * cos_t
    return (1.0 - g * g) / (4.0 * math.pi * d * np.sqrt(d))


def sample_hg(w, g, u1, u2):
    """A travel direction after scattering a packet travelling along ``w``, distributed as the
    HG phase function (inverse CDF of cos_t; its density is exactly ``hg_phase``)."""
    if abs(g) < 1e-3:
        cos_t = 1.0 - 2.0 * u1
    else:
        sq = (1.0 - g * g) / (1.0 - g + 2.0 * g * u1)
        cos_t = (1.0 + g * g - sq * sq) / (2.0 * g)
    cos_t = np.clip(cos_t, -1.0, 1.0)
    sin_t = np.sqrt(np.maximum(1.0 - cos_t * cos_t, 0.0))
    phi = 2.0 * math.pi * u2
    # orthonormal basis around w (Duff et al. 2017, "Building an orthonormal basis, revisited")
    sign = np.where(w[:, 2] >= 0, 1.0, -1.0)
    a = -1.0 / (sign + w[:, 2])
    b = w[:, 0] * w[:, 1] * a
    t = np.stack([1.0 + sign * w[:, 0] ** 2 * a, sign * b, -sign * w[:, 0]], -1)
    bb = np.stack([b, sign + w[:, 1] ** 2 * a, -w[:, 1]], -1)
    o = (sin_t * np.cos(phi))[:, None] * t + (sin_t * np.sin(phi))[:, None] * bb + cos_t[:, None] * w
    return _normalize(o)


def _flip(w, flip):
    return np.where(flip[:, None], w * np.array([1.0, 1.0, -1.0]), w)


# ============================================================== interfaces
class _Iface:
    """Interface ``j`` between media ``j`` (index ``n_above``) and ``j + 1`` (``n_below``).

    ``kind`` is "dielectric", "conductor" or "diffuse"; ``delta`` means a smooth (specular)
    event. Directions handed to the methods are in the stack's frame; internally they are turned
    into the anisotropy frame and, for arrivals from below, mirrored so the arrival side is +z
    (GGX is symmetric under that mirror; the relative index is inverted)."""

    def __init__(self, j, kind, n_above, n_below, roughness=(0.0, 0.0), rotation=0.0,
                 eta=None, k=None, albedo=None):
        self.j, self.kind = j, kind
        self.n_above, self.n_below = float(n_above), float(n_below)
        smooth = roughness[0] == 0.0 and roughness[1] == 0.0
        self.matched = kind == "dielectric" and self.n_above == self.n_below
        self.delta = kind != "diffuse" and (smooth or self.matched)
        self.ax = max(float(roughness[0]), ALPHA_MIN)
        self.ay = max(float(roughness[1]), ALPHA_MIN)
        self.c, self.s = math.cos(rotation), math.sin(rotation)
        if kind == "conductor":
            self.eta = [e / self.n_above for e in eta]
            self.k = [x / self.n_above for x in k]
        self.albedo = None if albedo is None else np.asarray(albedo, dtype=float)

    # -- frames
    def local(self, w):
        return np.stack([w[:, 0] * self.c + w[:, 1] * self.s, -w[:, 0] * self.s + w[:, 1] * self.c, w[:, 2]], -1)

    def world(self, w):
        return np.stack([w[:, 0] * self.c - w[:, 1] * self.s, w[:, 0] * self.s + w[:, 1] * self.c, w[:, 2]], -1)

    def eta_from(self, above):
        """Relative index n_other / n_this for a direction on the side ``above`` (bool array)."""
        return np.where(above, self.n_below / self.n_above, self.n_above / self.n_below)

    def fresnel_rgb(self, c, eta):
        if self.kind == "conductor":
            return np.stack([_fresnel_conductor(c, self.eta[ch], self.k[ch]) for ch in range(3)], -1)
        return np.repeat(_fresnel_dielectric(c, eta)[:, None], 3, 1)

    # -- density and sampling pdf of a non-delta event
    def evaluate(self, i, o, need_q=True):
        """For a packet arriving on the side of ``i`` (``i`` points away from the interface on that
        side, i.e. minus the travel direction) and leaving along ``o``: returns
        (q, pdf_cond, choice): the energy density q(i -> o) per solid angle of ``o`` (RGB; zero
        if ``need_q`` is False), the density of the VNDF sampler producing ``o`` *given* the event
        kind (reflection if ``o`` is on ``i``'s side, else transmission), and the probability with
        which the walker picks that kind (F, 1 - F or 1). The walker's density is
        pdf_cond * choice; pdf_cond(o -> i) is the reverse density used by strategy (A)."""
        K = i.shape[0]
        if self.kind == "diffuse":
            ok = (i[:, 2] > 0) & (o[:, 2] > 0)
            cos_o = np.where(ok, o[:, 2], 0.0)
            q = self.albedo[None, :] * (cos_o / math.pi)[:, None] if need_q else None
            return q, cos_o / math.pi, np.ones(K)
        flip = i[:, 2] < 0
        eta = self.eta_from(~flip)
        il = self.local(_flip(i, flip))
        ol = self.local(_flip(o, flip))
        refl = ol[:, 2] > 0
        ax, ay = self.ax, self.ay
        h = np.where(refl[:, None], il + ol, il + eta[:, None] * ol)
        h = _normalize(h * np.where(h[:, 2] < 0, -1.0, 1.0)[:, None])
        ih, oh = _dot(il, h), _dot(ol, h)
        lam_i, lam_o = smith_lambda(il, ax, ay), smith_lambda(ol, ax, ay)
        d = _ggx_d(h, ax, ay)
        iz = np.maximum(il[:, 2], _TINY)
        g1 = 1.0 / (1.0 + lam_i)
        g2 = 1.0 / (1.0 + lam_i + lam_o)
        if self.kind == "conductor":
            ok = refl & (ih > 0)
            pdf = np.where(ok, g1 * d / (4.0 * iz), 0.0)
            q = self.fresnel_rgb(ih, None) * np.where(ok, d * g2 / (4.0 * iz), 0.0)[:, None] if need_q else None
            return q, pdf, np.ones(K)
        ok_r = refl & (ih > 0)
        ok_t = ~refl & (ih > 0) & (oh < 0)
        den = ih + eta * oh
        jac_t = np.where(ok_t, eta * eta * np.abs(oh) / np.maximum(den * den, _TINY), 0.0)  # Walter Eq. 17
        F = _fresnel_dielectric(np.maximum(ih, 0.0), eta)
        pdf = np.where(ok_r, g1 * d / (4.0 * iz), np.where(ok_t, g1 * d * ih / iz * jac_t, 0.0))
        choice = np.where(refl, F, 1.0 - F)
        q = None
        if need_q:
            qs = np.where(ok_r, F * d * g2 / (4.0 * iz), np.where(ok_t, (1.0 - F) * d * g2 * ih / iz * jac_t, 0.0))
            q = np.repeat(qs[:, None], 3, 1)
        return q, pdf, choice

    # -- the walker's sampling
    def sample(self, i, rng):
        """Sample the event for packets arriving on the side of ``i``. Returns (o, weight RGB,
        pdf) with weight = q / pdf (what the packet's throughput is multiplied by) and pdf the
        walker's solid-angle density of ``o`` (0 for a delta event). A zero weight kills."""
        K = i.shape[0]
        ones = np.ones((K, 3))
        if self.kind == "diffuse":
            u1, u2 = rng.random(K), rng.random(K)
            r, ph = np.sqrt(u1), 2.0 * math.pi * u2
            o = np.stack([r * np.cos(ph), r * np.sin(ph), np.sqrt(np.maximum(1.0 - u1, 0.0))], -1)
            return o, ones * self.albedo[None, :] * (i[:, 2] > 0)[:, None], o[:, 2] / math.pi
        flip = i[:, 2] < 0
        eta = self.eta_from(~flip)
        ifl = _flip(i, flip)
        if self.matched:
            return -i, ones, np.zeros(K)
        if self.delta:
            c = ifl[:, 2]
            o_r = ifl * np.array([-1.0, -1.0, 1.0])
            if self.kind == "conductor":
                return _flip(o_r, flip), self.fresnel_rgb(c, None), np.zeros(K)
            F = _fresnel_dielectric(c, eta)
            reflect = rng.random(K) < F
            ct = np.sqrt(np.maximum(1.0 - (1.0 - c * c) / (eta * eta), 0.0))
            o_t = np.concatenate([-ifl[:, :2] / eta[:, None], -ct[:, None]], 1)
            o = np.where(reflect[:, None], o_r, o_t)
            return _normalize(_flip(o, flip)), ones, np.zeros(K)
        ax, ay = self.ax, self.ay
        il = self.local(ifl)
        h = sample_vndf(il, ax, ay, rng.random(K), rng.random(K))
        ih = _dot(il, h)
        o_r = 2.0 * ih[:, None] * h - il
        lam_i = smith_lambda(il, ax, ay)
        d = _ggx_d(h, ax, ay)
        iz = np.maximum(il[:, 2], _TINY)
        g1 = 1.0 / (1.0 + lam_i)
        if self.kind == "conductor":
            o, refl = o_r, np.ones(K, bool)
            weight = self.fresnel_rgb(ih, None)
            pdf = g1 * d / (4.0 * iz)
        else:
            F = _fresnel_dielectric(ih, eta)
            refl = rng.random(K) < F
            o_t, _ = _refract(il, h, eta)  # F = 1 under TIR, so o_t is only used when it exists
            o = np.where(refl[:, None], o_r, o_t)
            oh = _dot(o, h)
            den = ih + eta * oh
            jac_t = eta * eta * np.abs(oh) / np.maximum(den * den, _TINY)
            pdf = np.where(refl, g1 * d / (4.0 * iz) * F, g1 * d * ih / iz * jac_t * (1.0 - F))
            weight = ones
        good = np.where(refl, o[:, 2] > 0, o[:, 2] < 0)
        g2_over_g1 = (1.0 + lam_i) / (1.0 + lam_i + smith_lambda(o, ax, ay))
        weight = weight * np.where(good, g2_over_g1, 0.0)[:, None]
        return _normalize(_flip(self.world(o), flip)), weight, np.where(good, pdf, 0.0)

    def sample_reverse(self, o, arrive_above, rng):
        """Strategy (A): given the exit direction ``o`` of this (last) event, sample the direction
        ``i`` the packet must have arrived from (pointing away on the arrival side ``arrive_above``)
        with the VNDF seen from ``o``: reflection if ``o`` is on the arrival side, refraction
        otherwise (Heitz 2018 sampling from the other end; its density is
        ``evaluate(o, i).pdf_cond``). Returns (i, ok)."""
        K = o.shape[0]
        if self.kind == "diffuse":
            u1, u2 = rng.random(K), rng.random(K)
            r, ph = np.sqrt(u1), 2.0 * math.pi * u2
            i = np.stack([r * np.cos(ph), r * np.sin(ph), np.sqrt(np.maximum(1.0 - u1, 0.0))], -1)
            return i, (o[:, 2] > 0) & arrive_above
        flip = o[:, 2] < 0
        o_above = ~flip
        ol = self.local(_flip(o, flip))
        h = sample_vndf(ol, self.ax, self.ay, rng.random(K), rng.random(K))
        oh = _dot(ol, h)
        refl = arrive_above == o_above
        i_r = 2.0 * oh[:, None] * h - ol
        if self.kind == "conductor":
            i_l, ok = i_r, refl & (i_r[:, 2] > 0)
        else:
            i_t, ok_t = _refract(ol, h, self.eta_from(o_above))
            i_l = np.where(refl[:, None], i_r, i_t)
            ok = np.where(refl, i_r[:, 2] > 0, ok_t & (i_t[:, 2] < 0))
        return _normalize(_flip(self.world(i_l), flip)), ok


# ============================================================== the stack as the walk sees it
class _Layers:
    """Media 0..N+1 (indices ``n``, thickness, coefficients) and interfaces 0..N, plus the static
    structure the estimator needs: which interfaces are non-delta, the delta *regions* they
    bound, and for each exit side the levels of the reverse chain."""

    def __init__(self, stack: Stack):
        coats = stack.coats
        self.N = N = len(coats)
        base = stack.base
        self.base = base
        self.transmissive = isinstance(base, Dielectric)
        n_sub = base.ior if self.transmissive else 1.0
        self.n = np.array([1.0] + [c.ior for c in coats] + [n_sub])  # media 0..N+1
        self.thick = np.array([0.0] + [c.thickness for c in coats] + [0.0])
        z3 = [0.0, 0.0, 0.0]
        self.sig_a = np.array([z3] + [list(c.sigma_a) if c.thickness > 0 else z3 for c in coats] + [z3])
        self.sig_s = np.array([z3] + [list(c.sigma_s) if c.thickness > 0 else z3 for c in coats] + [z3])
        self.sig_t = self.sig_a + self.sig_s
        self.g = np.array([0.0] + [c.g for c in coats] + [0.0])
        self.scatters = self.sig_s.max(1) > 0
        self.absorbs = self.sig_t.max(1) > 0
        ifaces = [_Iface(j, "dielectric", self.n[j], self.n[j + 1], c.roughness, c.rotation)
                  for j, c in enumerate(coats)]
        if isinstance(base, Conductor):
            ifaces.append(_Iface(N, "conductor", self.n[N], 1.0, base.roughness, base.rotation, eta=base.eta, k=base.k))
        elif isinstance(base, Diffuse):
            ifaces.append(_Iface(N, "diffuse", self.n[N], 1.0, albedo=base.albedo))
        else:
            ifaces.append(_Iface(N, "dielectric", self.n[N], n_sub, base.roughness, base.rotation))
        self.ifaces = ifaces
        nd = [not I.delta for I in ifaces]
        self.nd = nd
        # region bounds of medium m: nearest non-delta interface above (-1: none) / below (N+1: none)
        self.top_b = [max([j for j in range(0, m) if nd[j]], default=-1) for m in range(N + 2)]
        self.bot_b = [min([j for j in range(m, N + 1) if nd[j]], default=N + 1) for m in range(N + 2)]
        # reverse chains. side True: reflected wo (the chain climbs through the rough coats, each
        # crossed upward); side False: transmitted wo (it descends through the rough dielectric
        # interfaces, each crossed downward). levels[side]: interfaces in chain order (head first).
        # rhead[side]: the interface where the head event may instead be a reflection, or None.
        non_delta = [j for j in range(N + 1) if nd[j]]
        self.levels = {True: [j for j in non_delta if j < N], False: []}
        self.rhead = {True: non_delta[0] if non_delta else None, False: None}
        if self.transmissive and non_delta:
            self.levels[False] = sorted(non_delta, reverse=True)
            self.rhead[False] = non_delta[-1] if non_delta[-1] < N else None

    def target(self, side: bool, m: int):
        """Where a packet emitted into medium m (either direction) meets the reverse chain of
        ``side``: (interface, kind) with kind "T" (a chain level crossed toward the exit: arrival
        from below for reflection, from above for transmission) or "R" (the reflection head), or
        None if no non-delta event can follow delta-only (then only the exit series applies)."""
        if m <= 0 or m >= self.N + 1:
            return None
        if side:
            t = self.top_b[m]
            if t >= 0:
                return t, "T"
            b = self.bot_b[m]
            return (b, "R") if b == self.rhead[True] else None
        if not self.transmissive:
            return None
        b = self.bot_b[m]
        if b <= self.N:
            return b, "T"
        t = self.top_b[m]
        return (t, "R") if t >= 0 and t == self.rhead[False] else None


# ============================================================== delta-only series
class _Series:
    """Sums over delta-only paths for rows of tangential vectors ``s`` (n sin(theta) times the
    azimuth unit vector: invariant along a planar stack, so it fixes the direction in every
    medium). Non-delta interfaces end such paths: reaching one counts ``arr`` (1 when the path is
    being connected to a chain level there, 0 when it must leave the stack delta-only); escaping
    into the vacuum / the substrate counts ``esc_top`` / ``esc_bot`` (per row). With F_j the
    Fresnel reflectance of smooth interface j and tau_m the unscattered transmittance of medium m
    along the path (Beer-Lambert, thickness / cos):

    * Rb[m]: everything below medium m seen from m, by adding: R + T^2 r / (1 - R r),
      r = tau_{m+1}^2 Rb[m+1]; Ra[m]: everything above, seen from m (0 at non-delta interfaces);
    * Y[m]: from the top of medium m going up, the weight of reaching the region's top:
      ``arr`` at a non-delta interface, else (1 - F) tau_{m-1} Y[m-1] / (1 - F tau_m^2 Rb[m]),
      with tau_0 Y[0] = esc_top;  Z[m]: from the bottom of m going down, symmetric.

    Energy transmittance through a smooth interface is 1 - F in both directions (the n^2 radiance
    factor cancels against the solid-angle compression), so these are plain products."""

    def __init__(self, L: _Layers, s: np.ndarray, arr: float, esc_top, esc_bot):
        N = L.N
        K = s.shape[0]
        M = N + 2
        s2 = np.sum(s * s, 1)
        self.s = s
        c = np.zeros((M, K))
        valid = np.zeros((M, K), bool)
        for m in range(M):
            c2 = 1.0 - s2 / (L.n[m] ** 2)
            valid[m] = c2 > 1e-14
            c[m] = np.sqrt(np.maximum(c2, 0.0))
        self.c, self.valid = c, valid
        cc = np.maximum(c, _TINY)
        tau = np.ones((M, K, 3))
        for m in range(1, N + 1):
            if L.absorbs[m]:
                tau[m] = np.exp(-L.sig_t[m][None, :] * (L.thick[m] / cc[m])[:, None])
        tau = np.where(valid[:, :, None], tau, 0.0)
        self.tau = tau
        F = np.zeros((N + 1, K, 3))
        for j, I in enumerate(L.ifaces):
            if I.delta and not I.matched:
                F[j] = I.fresnel_rgb(c[j], np.full(K, I.n_below / I.n_above))
        nd = L.nd
        one = np.ones((K, 3))
        Rb = np.zeros((M, K, 3))
        for m in range(N, -1, -1):
            if not nd[m]:
                r = tau[m + 1] ** 2 * Rb[m + 1] if m < N else 0.0
                Rb[m] = F[m] + (1.0 - F[m]) ** 2 * r / np.maximum(1.0 - F[m] * r, _TINY)
        Ra = np.zeros((M, K, 3))
        for m in range(1, N + 2):
            if not nd[m - 1]:
                r = tau[m - 1] ** 2 * Ra[m - 1] if m >= 2 else 0.0
                Ra[m] = F[m - 1] + (1.0 - F[m - 1]) ** 2 * r / np.maximum(1.0 - F[m - 1] * r, _TINY)
        esc_top = np.broadcast_to(np.asarray(esc_top, dtype=float), (K,))
        esc_bot = np.broadcast_to(np.asarray(esc_bot, dtype=float), (K,))
        Y = np.zeros((M, K, 3))
        U_prev = one * (esc_top * valid[0])[:, None]  # tau_0 Y[0]: escaped into the vacuum
        for m in range(1, N + 1):
            if nd[m - 1]:
                Y[m] = arr * one
            else:
                R = F[m - 1]
                Y[m] = (1.0 - R) * U_prev / np.maximum(1.0 - R * tau[m] ** 2 * Rb[m], _TINY)
            U_prev = tau[m] * Y[m]
        Z = np.zeros((M, K, 3))
        sub = esc_bot * valid[N + 1] if L.transmissive else np.zeros(K)
        D_next = one * sub[:, None]  # tau_{N+1} Z[N+1]: escaped into the substrate
        for m in range(N, 0, -1):
            if nd[m]:
                Z[m] = arr * one
            else:
                R = F[m]
                Z[m] = (1.0 - R) * D_next / np.maximum(1.0 - R * tau[m] ** 2 * Ra[m], _TINY)
            D_next = tau[m] * Z[m]
        self.Rb, self.Ra, self.Y, self.Z = Rb, Ra, Y, Z
        self.Z0 = D_next  # from the bottom of the vacuum going down: tau_1 Z[1] (unused by the walk)

    def direction(self, L: _Layers, m: int, up) -> np.ndarray:
        """Unit direction of travel in medium m (``up`` bool or per-row array); a dummy
        (0, 0, +-1) where the direction does not exist there (the series are zero)."""
        v = self.valid[m]
        t = np.where(v[:, None], self.s / L.n[m], 0.0)
        c = np.where(v, self.c[m], 1.0)
        return np.concatenate([t, np.where(up, c, -c)[:, None]], 1)

    def from_point(self, L: _Layers, m: int, z, target_top: bool):
        """Delta-only weight from a point at depth ``z`` in medium m to the region's top (arrival
        from below) or bottom (arrival from above), leaving up first / down first:
        returns (up_first, down_first), RGB rows, without the Jacobian."""
        c = np.maximum(self.c[m], _TINY)
        th = L.thick[m]
        tr_up = _tr(L, m, z / c)
        tr_dn = _tr(L, m, (th - z) / c)
        tau = self.tau[m]
        if target_top:
            return tr_up * self.Y[m], tr_dn * self.Rb[m] * tau * self.Y[m]
        return tr_up * self.Ra[m] * tau * self.Z[m], tr_dn * self.Z[m]


def _tr(L, m, dist):
    """Beer-Lambert transmittance (RGB) of medium m (scalar) over path lengths ``dist``."""
    dist = np.asarray(dist, dtype=float)
    if not L.absorbs[m]:
        return np.ones(dist.shape + (3,))
    return np.exp(-L.sig_t[m] * dist[..., None])


class _Exit:
    """Everything that depends on ``wo`` only (one row per (wi, wo) pair): the exit path's
    direction in every medium (Snell), and the delta-only series from each possible last
    non-delta event to the exit (``_Series`` with ``arr = 0``), times the Jacobian
    jac[m] = n_exit^2 |wo.z| / (n_m^2 c_m) that turns a density per solid angle in medium m into
    one per solid angle of ``wo`` (n^2 cos dω is conserved by refraction).

    ``edge_dir[k]`` / ``edge_tail[k]``: for the last event at interface k, its exit direction and
    the series after it times jac: up in medium k for a reflected ``wo`` (tau_k Y[k]), down in
    medium k+1 for a transmitted one (tau_{k+1} Z[k+1]). ``med_up[m]`` / ``med_dn[m]``: from a
    scattering point in medium m leaving up first / down first (without the partial
    Beer-Lambert factor to the boundary)."""

    def __init__(self, L: _Layers, wo: np.ndarray):
        N = L.N
        P = wo.shape[0]
        self.up = up = wo[:, 2] > 0
        down_ok = (~up) & (wo[:, 2] < 0) & L.transmissive
        n_exit = np.where(up, 1.0, L.n[N + 1])
        s = wo[:, :2] * n_exit[:, None]
        ser = _Series(L, s, 0.0, up.astype(float), down_ok.astype(float))
        self.ser = ser
        cc = np.maximum(ser.c, _TINY)
        jac = np.where(ser.valid, (n_exit ** 2 * np.abs(wo[:, 2]))[None, :] / (L.n[:, None] ** 2 * cc), 0.0)
        upc = up[:, None]
        self.edge_dir, self.edge_tail = [], []
        for k in range(N + 1):
            self.edge_dir.append(np.where(upc, ser.direction(L, k, True), ser.direction(L, k + 1, False)))
            t_up = ser.tau[k] * ser.Y[k] * jac[k][:, None] if k >= 1 else upc * jac[0][:, None] * ser.valid[0][:, None]
            t_dn = ser.Z[k + 1] * ser.tau[k + 1] * jac[k + 1][:, None] if k + 1 <= N else \
                (down_ok * ser.valid[N + 1] * jac[N + 1])[:, None] * np.ones(3)
            self.edge_tail.append(np.where(upc, t_up, t_dn))
        M = N + 2
        self.med_up = np.zeros((M, P, 3))
        self.med_dn = np.zeros((M, P, 3))
        for m in range(1, N + 1):
            jm = jac[m][:, None]
            self.med_up[m] = (ser.Y[m] + ser.Ra[m] * ser.tau[m] * ser.Z[m]) * jm
            self.med_dn[m] = (ser.Rb[m] * ser.tau[m] * ser.Y[m] + ser.Z[m]) * jm

    def direction(self, L, m, up):
        return self.ser.direction(L, m, up)


# ============================================================== the reverse chain
class _Chain:
    """Per packet, a reverse chain sampled from the exit (pbrt-v4's presampled ``wis``, extended
    through every non-delta interface): at each level (interface j, crossed toward the exit), the
    tangential ``s`` of the arrival direction, its reverse density ``p`` per unit s (the
    measure n^2 |cos| dω, invariant through delta paths), the estimate ``C`` of (exit density
    for energy arriving there) / p, and the MIS suffix sum ``S`` over the strategies that sample
    more of the chain forward. Keyed by (side, j, kind) with kind "T" or "R" (reflection head).

    Level l below level l+1 (its neighbour toward the exit):
    C_l = qhat_l(s_l -> s_{l+1}) Route_l(s_{l+1}) C_{l+1} / p_l(s_l),
    S_l = (pf_l(s_{l+1} | s_l) / p_{l+1})^2 (1 + S_{l+1}), with qhat, pf per unit s of the
    outgoing direction and Route_l the delta-only series between the two levels."""

    def __init__(self, L: _Layers, ex: _Exit, pair: np.ndarray, rng):
        K = pair.shape[0]
        self.data = {}
        up = ex.up[pair]
        for side in (True, False):
            rows = np.nonzero(up if side else ~up)[0]
            if rows.size == 0:
                continue
            pr = pair[rows]
            levels = L.levels[side]
            prev = None
            for q, j in enumerate(levels):
                I = L.ifaces[j]
                n_arr = L.n[j + 1] if side else L.n[j]
                n_out = L.n[j] if side else L.n[j + 1]
                if q == 0:
                    o = ex.edge_dir[j][pr]
                    tail = ex.edge_tail[j][pr]
                    i, ok = I.sample_reverse(o, np.full(rows.size, not side), rng)
                    q_e, _, _ = I.evaluate(i, o)
                    _, p_rev, _ = I.evaluate(o, i, need_q=False)
                    ph = _per_s(p_rev, n_arr, i)
                    C = q_e * tail * _safe_inv(ph)[:, None]
                    S = np.zeros(rows.size)
                else:
                    s_up, C_up, p_up, S_up = prev
                    ser = _Series(L, s_up, 1.0, 0.0, 0.0)
                    m_out = j if side else j + 1
                    o = ser.direction(L, m_out, side)
                    route = ser.tau[m_out] * (ser.Y[m_out] if side else ser.Z[m_out])
                    i, ok = I.sample_reverse(o, np.full(rows.size, not side), rng)
                    q_e, pdf_f, choice = I.evaluate(i, o)
                    _, p_rev, _ = I.evaluate(o, i, need_q=False)
                    ph = _per_s(p_rev, n_arr, i)
                    qh = q_e * _safe_inv(n_out ** 2 * np.abs(o[:, 2]))[:, None]
                    pf_h = _per_s(pdf_f * choice, n_out, o)
                    C = qh * route * C_up * _safe_inv(ph)[:, None]
                    S = (pf_h * _safe_inv(p_up)) ** 2 * (1.0 + S_up)
                ok &= ph > 0
                s = n_arr * (-i[:, :2])
                C = np.where(ok[:, None], C, 0.0)
                ph = np.where(ok, ph, 0.0)
                prev = (s, C, ph, S)
                self._store(K, rows, (side, j, "T"), s, C, ph, S)
            j = L.rhead[side]
            if j is not None:
                I = L.ifaces[j]
                n_arr = L.n[j] if side else L.n[j + 1]
                o = ex.edge_dir[j][pr]
                tail = ex.edge_tail[j][pr]
                i, ok = I.sample_reverse(o, np.full(rows.size, side), rng)
                q_e, _, _ = I.evaluate(i, o)
                _, p_rev, _ = I.evaluate(o, i, need_q=False)
                ph = _per_s(p_rev, n_arr, i)
                ok &= ph > 0
                C = np.where(ok[:, None], q_e * tail * _safe_inv(ph)[:, None], 0.0)
                self._store(K, rows, (side, j, "R"), n_arr * (-i[:, :2]), C, np.where(ok, ph, 0.0),
                            np.zeros(rows.size))

    def _store(self, K, rows, key, s, C, p, S):
        if key not in self.data:
            self.data[key] = (np.zeros((K, 2)), np.zeros((K, 3)), np.zeros(K), np.zeros(K))
        d = self.data[key]
        d[0][rows], d[1][rows], d[2][rows], d[3][rows] = s, C, p, S


def _per_s(pdf, n, w):
    """A solid-angle density of direction ``w`` in a medium of index n, per unit tangential s
    (the measure n^2 |cos| dω)."""
    return pdf * _safe_inv(n * n * np.abs(w[:, 2]))


def _safe_inv(x):
    return np.where(x > 0, 1.0 / np.maximum(x, _TINY), 0.0)


# ============================================================== the walk
class _Walkers:
    """The live packets, as parallel arrays (compacted as packets die). ``pf`` is the density
    (per unit s) with which the previous non-delta event sampled the current delta-only stretch
    (0 if there was none); ``A`` the MIS history sum of that event if it was a chain event
    continued toward the exit (else 0)."""

    FIELDS = ("wid", "pair", "side", "m", "z", "w", "beta", "pf", "A")

    def __init__(self, wi, pair, side):
        K = wi.shape[0]
        self.wid = np.arange(K)
        self.pair = pair
        self.side = side
        self.m = np.zeros(K, dtype=np.int64)  # medium
        self.z = np.zeros(K)  # depth below the top of the medium
        self.w = -np.asarray(wi, dtype=float)  # travel direction
        self.beta = np.ones((K, 3))
        self.pf = np.zeros(K)
        self.A = np.zeros(K)

    def keep(self, mask):
        for f in self.FIELDS:
            setattr(self, f, getattr(self, f)[mask])

    def __len__(self):
        return self.wid.shape[0]


def _walk(L: _Layers, wi, pair, rng, ex: _Exit | None):
    """Trace packets entering along -wi (one row per packet; ``pair`` indexes ``ex``'s rows).
    Returns per packet (reflected, transmitted, nee, nondelta): the energy escaping up / down,
    the NEE estimate of f(wi, wo)|wo.z|, and whether it met a non-delta event."""
    K = wi.shape[0]
    N = L.N
    refl, trans, nee = np.zeros((K, 3)), np.zeros((K, 3)), np.zeros((K, 3))
    nondelta = np.zeros(K, bool)
    side = ex.up[pair] if ex is not None else np.ones(K, bool)
    chain = _Chain(L, ex, pair, rng) if ex is not None else None
    W = _Walkers(wi, pair, side)
    for depth in range(MAX_EVENTS):
        if len(W) == 0:
            break
        up = W.w[:, 2] > 0
        # ---- escapes
        esc_up = (W.m == 0) & up
        esc_dn = (W.m == N + 1) & ~up
        refl[W.wid[esc_up]] += W.beta[esc_up]
        trans[W.wid[esc_dn]] += W.beta[esc_dn]
        flat = np.abs(W.w[:, 2]) < 1e-12  # measure zero: a path along an interface never arrives
        W.keep(~(esc_up | esc_dn | flat))
        up = W.w[:, 2] > 0
        # ---- propagation to the next event in the current medium
        wz = np.abs(W.w[:, 2])
        th = L.thick[W.m]
        dist = np.where(up, W.z, th - W.z) / wz
        scat = np.zeros(len(W), bool)
        absorbing = L.absorbs[W.m] & ~L.scatters[W.m]
        if absorbing.any():
            W.beta[absorbing] *= np.exp(-L.sig_t[W.m[absorbing]] * dist[absorbing, None])
        sm = L.scatters[W.m]
        if sm.any():
            # one-sample spectral MIS: a channel chosen uniformly, density = mean over channels
            k = np.nonzero(sm)[0]
            sig_t = L.sig_t[W.m[k]]
            ch = rng.integers(0, 3, k.size)
            st = sig_t[np.arange(k.size), ch]
            t = np.where(st > 0, -np.log1p(-rng.random(k.size)) / np.maximum(st, _TINY), np.inf)
            through = t >= dist[k]
            tr_b = np.exp(-sig_t[through] * dist[k[through], None])  # P(pass) = mean_c tr_b
            W.beta[k[through]] *= tr_b / np.maximum(tr_b.mean(1, keepdims=True), _TINY)
            ks, ts = k[~through], t[~through]
            tr = np.exp(-sig_t[~through] * ts[:, None])
            pdf_t = (sig_t[~through] * tr).mean(1, keepdims=True)
            W.beta[ks] *= L.sig_s[W.m[ks]] * tr / np.maximum(pdf_t, _TINY)
            W.z[ks] += np.where(up[ks], -ts, ts) * wz[ks]
            W.z[ks] = np.clip(W.z[ks], 0.0, th[ks])
            scat[ks] = True
        # ---- scattering points
        if scat.any():
            s = np.nonzero(scat)[0]
            nondelta[W.wid[s]] = True
            for m in np.unique(W.m[s]):
                sel = s[W.m[s] == m]
                if ex is not None:
                    nee[W.wid[sel]] += _nee_medium(L, ex, chain, W, sel, m)
                g = L.g[m]
                w_new = sample_hg(W.w[sel], g, rng.random(sel.size), rng.random(sel.size))
                W.pf[sel] = _per_s(hg_phase(_dot(W.w[sel], w_new), g), L.n[m], w_new)
                W.A[sel] = 0.0
                W.w[sel] = w_new
        # ---- interface events
        arrive = np.nonzero(~scat)[0]
        j_of = np.where(up[arrive], W.m[arrive] - 1, W.m[arrive])
        for j in range(N + 1):
            sel = arrive[j_of == j]
            if sel.size == 0:
                continue
            I = L.ifaces[j]
            i = -W.w[sel]
            if I.delta:
                o, weight, _ = I.sample(i, rng)
            else:
                nondelta[W.wid[sel]] = True
                if ex is not None:
                    nee[W.wid[sel]] += _nee_interface(L, ex, chain, W, sel, j, i)
                o, weight, pdf = I.sample(i, rng)
                _update_mis(L, W, sel, j, i, o, pdf)
            W.beta[sel] *= weight
            W.w[sel] = o
            o_up = o[:, 2] > 0
            W.m[sel] = np.where(o_up, j, j + 1)
            W.z[sel] = np.where(o_up, L.thick[j], 0.0)
        # ---- Russian roulette (survival probability = largest throughput channel, pbrt style)
        if depth >= RR_START:
            bmax = W.beta.max(1)
            q = np.minimum(bmax, 1.0)
            live = (bmax > 0) & (rng.random(len(W)) < q)
            W.beta[live] /= q[live, None]
            W.keep(live)
        else:
            W.keep(W.beta.max(1) > 0)
    return refl, trans, nee, nondelta


def _chain_event(L, side, j, i, o):
    """Rows where the event at interface j (arrival ``i``, departure ``o``) is a chain level
    crossed toward the exit of ``side`` (per-row bool)."""
    lv_up = j in L.levels[True]
    lv_dn = j in L.levels[False]
    ok_up = lv_up & (i[:, 2] < 0) & (o[:, 2] > 0)
    ok_dn = lv_dn & (i[:, 2] > 0) & (o[:, 2] < 0)
    return np.where(side, ok_up, ok_dn)


def _update_mis(L, W, sel, j, i, o, pdf):
    """After the walker sampled ``o`` at non-delta interface j: its MIS state for what follows."""
    I = L.ifaces[j]
    n_out = np.where(o[:, 2] > 0, L.n[j], L.n[min(j + 1, L.N + 1)])
    cont = _chain_event(L, W.side[sel], j, i, o)
    A_new = np.zeros(sel.size)
    if cont.any():
        c = np.nonzero(cont)[0]
        _, p_rev, _ = I.evaluate(o[c], i[c], need_q=False)
        n_arr = np.where(i[c, 2] > 0, L.n[j], L.n[min(j + 1, L.N + 1)])
        pr_h = _per_s(p_rev, n_arr, i[c])
        pf_old = W.pf[sel[c]]
        A_new[c] = np.where(pf_old > 0, (pr_h * _safe_inv(pf_old)) ** 2 * (W.A[sel[c]] + 1.0), 0.0)
    W.A[sel] = A_new
    W.pf[sel] = _per_s(pdf, n_out, o)


def _connect(L, chain, W, sel, side_rows, m, key, z, dirs, vertex_fn, A_fn):
    """Connect the vertices ``sel`` (a subset of one exit side: ``side_rows`` bool per sel row)
    emitting into medium m to the chain entry ``key``: for each emission direction in ``dirs``
    (True: up first, False: down first), beta x qhat_v(d) x delta-only series x C, with the
    power-heuristic weight 1 / (1 + A + (pf_v / p)^2 (1 + S)).
    ``vertex_fn(rows, d, up) -> (q_v per solid angle, walker density per solid angle)``;
    ``A_fn(rows, d, up)`` -> the MIS history sum of the vertex (zeros for non-chain vertices)."""
    out = np.zeros((sel.size, 3))
    if key not in chain.data:
        return out
    rows = np.nonzero(side_rows)[0]
    if rows.size == 0:
        return out
    wid = W.wid[sel[rows]]
    s_c, C, p, S = (a[wid] for a in chain.data[key])
    live = p > 0
    if not live.any():
        return out
    rows, s_c, C, p, S = rows[live], s_c[live], C[live], p[live], S[live]
    ser = _Series(L, s_c, 1.0, 0.0, 0.0)
    # the region's top is the target for a reflected wo's "T" level and a transmitted wo's "R" head
    up_first, dn_first = ser.from_point(L, m, z[rows], (key[2] == "T") == key[0])
    n2 = L.n[m] ** 2
    for up in dirs:
        d = ser.direction(L, m, up)
        route = up_first if up else dn_first
        q_v, pf_v = vertex_fn(rows, d, up)
        inv = _safe_inv(n2 * np.abs(d[:, 2])) * ser.valid[m]
        qh, pfh = q_v * inv[:, None], pf_v * inv
        A = A_fn(rows, d, up)
        w = p * p / np.maximum(p * p * (1.0 + A) + pfh * pfh * (1.0 + S), _TINY)
        out[rows] += W.beta[sel[rows]] * qh * route * C * w[:, None]
    return out


def _nee_interface(L, ex, chain, W, sel, j, i):
    """NEE at a non-delta event at interface j for the walkers ``sel`` arriving from ``i``:
    (1) this event as the last one (if it is a head of the walker's chain), MIS-weighted against
    the earlier connections; (2) connections of this event to the chain, emitting into the
    medium above and below."""
    I = L.ifaces[j]
    N = L.N
    pair, beta, side = W.pair[sel], W.beta[sel], W.side[sel]
    total = np.zeros((sel.size, 3))
    from_above = i[:, 2] > 0
    n_arr = np.where(from_above, L.n[j], L.n[min(j + 1, N + 1)])
    # (1) last event
    head_T_up = L.levels[True][:1] == [j]
    head_T_dn = L.levels[False][:1] == [j]
    is_head = np.where(side, (L.rhead[True] == j) | head_T_up, (L.rhead[False] == j) | head_T_dn)
    if is_head.any():
        h = np.nonzero(is_head)[0]
        o_e = ex.edge_dir[j][pair[h]]
        tail = ex.edge_tail[j][pair[h]]
        q, _, _ = I.evaluate(i[h], o_e)
        _, p_rev, _ = I.evaluate(o_e, i[h], need_q=False)
        pr_h = _per_s(p_rev, n_arr[h], i[h])
        t_kind = np.where(side[h], ~from_above[h], from_above[h])  # crossed toward the exit
        pf = W.pf[sel[h]]
        A = np.where(pf > 0, (pr_h * _safe_inv(pf)) ** 2 * (np.where(t_kind, W.A[sel[h]], 0.0) + 1.0), 0.0)
        total[h] += beta[h] * q * tail / (1.0 + A)[:, None]

    # (2) connections, emitting up into medium j and down into medium j+1
    def vertex(rows, d, up):
        q_v, pdf, choice = I.evaluate(i[rows], d)
        return q_v, pdf * choice

    for m, up in ((j, True), (j + 1, False)):
        if m < 1 or m > N:
            continue
        for sd in (True, False):
            tg = L.target(sd, m)
            if tg is None:
                continue
            key = (sd, tg[0], tg[1])
            chain_cont = tg[1] == "T" and (up == sd) and j in L.levels[sd]

            def A_fn(rows, d, up_, chain_cont=chain_cont, sd=sd):
                if not chain_cont:
                    return np.zeros(rows.size)
                # the vertex is itself a chain level crossed toward the exit (if it was reached
                # from the far side): its history sum, as in _update_mis
                far = ~from_above[rows] if sd else from_above[rows]
                _, p_rev, _ = I.evaluate(d, i[rows], need_q=False)
                pr_h = _per_s(p_rev, n_arr[rows], i[rows])
                pf = W.pf[sel[rows]]
                A = np.where(pf > 0, (pr_h * _safe_inv(pf)) ** 2 * (W.A[sel[rows]] + 1.0), 0.0)
                return np.where(far, A, 0.0)

            z = np.full(sel.size, L.thick[m] if up else 0.0)
            total += _connect(L, chain, W, sel, side == sd, m, key, z, (up,), vertex, A_fn)
    return total


def _nee_medium(L, ex, chain, W, sel, m):
    """NEE at scattering points in medium m: the point as the last event (phase function toward
    the exit direction, up and down, times the delta series; weight 1), and its connections to
    the chain (leaving up first and down first)."""
    pair, beta, w, z = W.pair[sel], W.beta[sel], W.w[sel], W.z[sel]
    side = W.side[sel]
    g, th = L.g[m], L.thick[m]
    c = np.maximum(ex.ser.c[m][pair], _TINY)
    total = np.zeros((sel.size, 3))
    for up in (True, False):
        d = ex.direction(L, m, up)[pair]
        ph = hg_phase(_dot(w, d), g)
        tr = _tr(L, m, (z if up else th - z) / c)
        series = (ex.med_up if up else ex.med_dn)[m][pair]
        total += beta * (ph[:, None] * tr) * series

    def vertex(rows, d, up):
        p = hg_phase(_dot(w[rows], d), g)
        return p[:, None] * np.ones(3), p

    def A_fn(rows, d, up):
        return np.zeros(rows.size)

    for sd in (True, False):
        tg = L.target(sd, m)
        if tg is None:
            continue
        total += _connect(L, chain, W, sel, side == sd, m, (sd, tg[0], tg[1]), z, (True, False), vertex, A_fn)
    return total


# ============================================================== public API
def _dirs(w, name):
    w = np.asarray(w, dtype=float)
    if w.ndim == 1:
        w = w[None, :]
    if w.ndim != 2 or w.shape[1] != 3 or not np.isfinite(w).all():
        raise ValueError(f"{name} must be a finite direction (3,) or an array of directions (N, 3)")
    norm = np.linalg.norm(w, axis=1, keepdims=True)
    if (norm == 0).any():
        raise ValueError(f"{name} contains a zero vector")
    return w / norm


def _stats(total, total2, n):
    mean = total / n
    var = np.maximum(total2 / n - mean * mean, 0.0)
    return mean, np.sqrt(var / max(n - 1, 1))


def eval_brdf_cos(stack, wi, wo, spp: int, seed: int = 0):
    """Stochastic f(wi, wo) |wo.z| for each row of ``wo`` ((N, 3); ``wi`` (3,) or (N, 3),
    broadcast): returns (mean, stderr), each (N, 3). ``spp`` walkers per (wi, wo) pair,
    deterministic for a given ``seed``. Lower-hemisphere ``wo`` is transmission into the
    dielectric base's substrate: energy per solid angle there (see the module docstring), zero
    for opaque bases. Delta lobes (smooth interfaces) have no density and are not included."""
    L = _Layers(Stack.coerce(stack))
    wo = _dirs(wo, "wo")
    wi = _dirs(wi, "wi")
    wi, wo = np.broadcast_arrays(wi, wo)
    if (wi[:, 2] <= 0).any():
        raise ValueError("wi must lie in the upper hemisphere (wi.z > 0)")
    if spp < 1:
        raise ValueError("spp must be >= 1")
    P = wo.shape[0]
    ex = _Exit(L, np.ascontiguousarray(wo))
    rng = np.random.default_rng(seed)
    total, total2 = np.zeros((P, 3)), np.zeros((P, 3))
    n_walk = P * spp
    for start in range(0, n_walk, CHUNK):
        idx = np.arange(start, min(n_walk, start + CHUNK))
        pair = idx // spp
        _, _, v, _ = _walk(L, wi[pair], pair, rng, ex)
        for ch in range(3):
            total[:, ch] += np.bincount(pair, v[:, ch], minlength=P)
            total2[:, ch] += np.bincount(pair, v[:, ch] ** 2, minlength=P)
    return _stats(total, total2, spp)


def albedo(stack, wi, spp: int, seed: int = 0, side: str = "reflected", exclude_delta: bool = False):
    """Stochastic directional albedo by counting escaping packets (no NEE): the energy leaving the
    top (``side="reflected"``) or through the dielectric base (``"transmitted"``; zeros for
    opaque bases). ``wi`` (3,) or (N, 3); returns (mean, stderr), each (N, 3).
    ``exclude_delta=True`` counts only packets that met at least one non-delta event: the part of
    the albedo that ``eval_brdf_cos`` integrates to (delta lobes have no density)."""
    if side not in ("reflected", "transmitted"):
        raise ValueError(f"side must be 'reflected' or 'transmitted', got {side!r}")
    L = _Layers(Stack.coerce(stack))
    wi = _dirs(wi, "wi")
    if (wi[:, 2] <= 0).any():
        raise ValueError("wi must lie in the upper hemisphere (wi.z > 0)")
    if spp < 1:
        raise ValueError("spp must be >= 1")
    P = wi.shape[0]
    rng = np.random.default_rng(seed)
    total, total2 = np.zeros((P, 3)), np.zeros((P, 3))
    n_walk = P * spp
    for start in range(0, n_walk, CHUNK):
        idx = np.arange(start, min(n_walk, start + CHUNK))
        pair = idx // spp
        r, t, _, nd = _walk(L, wi[pair], pair, rng, None)
        v = r if side == "reflected" else t
        if exclude_delta:
            v = v * nd[:, None]
        for ch in range(3):
            total[:, ch] += np.bincount(pair, v[:, ch], minlength=P)
            total2[:, ch] += np.bincount(pair, v[:, ch] ** 2, minlength=P)
    return _stats(total, total2, spp)
