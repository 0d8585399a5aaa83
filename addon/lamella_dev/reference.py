"""Stochastic ground truth of the exact layered BSDF (docs: the Python API contract).

Plain numpy, never traced: the yardstick every model is measured against. A random walk of energy
packets through planar layers of single-scattering GGX interfaces (Walter et al. 2007 reflection
and refraction, anisotropic, rotated), homogeneous media (Beer-Lambert, Henyey-Greenstein
scattering with spectral-MIS distance sampling) and a conductor / Lambertian / dielectric base, in
the spirit of Guo et al. 2018 ("Position-free Monte Carlo simulation for arbitrary layered BSDFs")
and pbrt-v4's ``LayeredBxDF``.

Conventions
-----------
* Rough interfaces (``interfaces``): "single" scatters once on the microsurface, pbrt-v4's
  convention, and loses the energy a real microsurface scatters again; "multiple" is the random
  walk on the microsurface of Heitz, Hanika, d'Eon and Dachsbacher 2016 (``microsurface.walk``:
  conductors with a Fresnel factor per bounce, dielectrics reflecting and refracting at every
  bounce, anisotropic), energy conserving. Its single-scattering part is the one below for
  reflection; for refraction its masking is the Beta form of uniform heights
  (``microsurface.g2_transmission``).
* Masking-shadowing (single): G2 = 1 / (1 + Lambda(i) + Lambda(o)) for reflection and transmission (the
  height-correlated form pbrt-v4 uses), Lambda anisotropic (Heitz 2014 Eq. 86); microfacet
  normals sampled from the visible-normal distribution (Heitz 2018, JCGT 7(4)). This is the
  convention of ``models/ggx.py`` and of the look-up tables.
* A packet carries *energy*: entering along -wi it leaves toward wo with a probability density
  (per unit solid angle of the exit medium) that equals f(wi, wo) |wo.z| by reciprocity. For a
  rough interface the density of a sampled event direction o is
  q_R = F D G2 / (4 |i.z|) and q_T = |i.h| |o.h| eta^2 (1 - F) D G2 / (|i.z| (i.h + eta o.h)^2)
  (Walter 2007 Eqs. 20-21 times |o.z|, eta = n_o / n_i), which is exactly pdf x weight of VNDF
  sampling with a Fresnel choice, so next-event estimation and sampling agree.

Next-event estimation (``eval_brdf_cos``)
-----------------------------------------
Every path is counted once, at its *last non-delta event* (a rough-interface reflection or
refraction, a rough or diffuse base, a medium scattering event). In a planar stack the exit
direction wo fixes the direction d_m of the path in every medium m (n sin(theta) is invariant), so
what follows the last non-delta event is a sum over delta-only paths (smooth interfaces,
unscattered media, in any order of bounces) that has a closed form: adding series in which every
non-delta element is a perfect absorber (its paths are counted at its own events). The connection
weight is q_event(d_m) x series x Jacobian (n_exit^2 cos_exit) / (n_m^2 cos_m) (radiance /
solid-angle change across the stack, Snell's n^2 cos dw invariance). The walk continues after each
event, so deeper paths are counted at their own last events. Smooth-only stacks have delta BRDFs:
``eval_brdf_cos`` returns 0 for them and ``albedo`` is the meaningful quantity.

``albedo`` counts escaping packets (no NEE): an independent check of ``eval_brdf_cos`` (its
hemispherical integral must equal the albedo; a test does this).

Thin films (a spectral walk)
----------------------------
A coat, a conductor base or a dielectric base may carry a thin film on its top interface
(``layers.film``: ``film_thickness`` nm, ``film_ior``), whose reflectance depends on the wavelength.
A stack with a film is walked spectrally: each packet carries one wavelength lambda, and at a
filmed interface every Fresnel factor of the walk is the film's exact Airy reflectance at lambda
(``microsurface.film_fresnel``, s and p averaged; Born and Wolf, *Principles of Optics*, Sections
1.5-1.6): the choice between reflection and refraction at smooth and rough interfaces (T = 1 - R:
the film absorbs nothing), a conductor's weight (R only), the densities of next-event estimation
(``_rough_q``), the delta-only exit series (``_Exit``, then built per packet) and every vertex of
the walk on the microsurface (``microsurface.walk``; Heitz et al. 2016), each from the side the light
arrives on (a lossless film reflects the same from both sides at Snell-related angles, which the
exit series uses; the walk computes each side's own). Everything else keeps its RGB value per
channel (absorption, scattering, a conductor's eta and k, an albedo), so channel c of a packet is
the walk with channel c's properties and the films at lambda, and its contribution is weighted by
W_c(lambda) / p(lambda): W_c is channel c's colour matching weight (CIE 1931 through linear
Rec.709, ``thin_film_spectral.cmfs``, unit sum per channel, so a spectrally flat reflectance is the
same in every channel and a film's colour is ``thin_film_spectral.spectrum_to_rgb`` of its
spectrum). The estimate of channel c is then sum_lambda W_c(lambda) x (that walk), which is what
the models' RGB film means (the film's reflectance projected per channel, the rest per channel).

Wavelengths are drawn independently per packet from the 1 nm grid of the colour matching functions
(360-830 nm, where W_c is defined: the estimate is unbiased for exactly the sum above, with no
quadrature of its own) with p proportional to sqrt(sum_c W_c^2), the density that minimises the
summed variance of the three channels for a flat spectrum (Cauchy-Schwarz): 2.9 times a flat
spectrum's squared value per channel against 6.9 for uniform sampling. (W_c has negative lobes, so
channel weights are signed.) Independent draws keep the packets independent, so the standard
errors stay the sample variance over packets, as for a stack without a film; stratifying the
wavelengths would lower the noise but make that error estimate an overestimate. A stack without a
film draws no wavelength and takes the RGB walk unchanged, number for number.
"""
from __future__ import annotations

import functools
import math

import numpy as np

from . import microsurface
from .microsurface import Film, _fresnel_conductor, _fresnel_dielectric, _ggx_d, sample_vndf, smith_lambda
from lamella.core.stack import Stack

ALPHA_MIN = 1e-4  # a rough interface with one zero axis is evaluated with this floor on that axis
MAX_EVENTS = 256
INTERFACES = ("single", "multiple")  # rough interfaces: pbrt-v4's single scattering, or Heitz et al. 2016's walk
CHUNK = 1 << 19
FILM_CHUNK = 1 << 16  # packets per batch when each carries its own exit series (a smooth filmed interface)


def _hg(cos_t, g):
    d = 1.0 + g * g - 2.0 * g * cos_t
    return (1.0 - g * g) / (4.0 * math.pi * d * np.sqrt(d))


def _sample_hg(w, g, u1, u2):
    """A new direction about w with HG cosine distribution (pbrt-v4 SampleHenyeyGreenstein)."""
    gg = np.where(np.abs(g) < 1e-3, 0.0, g)
    sq = (1.0 - gg * gg) / (1.0 + gg - 2.0 * gg * u1)
    cos_t = np.where(np.abs(g) < 1e-3, 1.0 - 2.0 * u1, (1.0 + gg * gg - sq * sq) / (2.0 * np.where(gg == 0, 1.0, gg)))
    cos_t = np.clip(cos_t, -1.0, 1.0)
    sin_t = np.sqrt(np.maximum(1.0 - cos_t * cos_t, 0.0))
    phi = 2.0 * math.pi * u2
    # orthonormal basis around w (Duff et al. 2017)
    sign = np.where(w[:, 2] >= 0, 1.0, -1.0)
    a = -1.0 / (sign + w[:, 2])
    b = w[:, 0] * w[:, 1] * a
    t = np.stack([1.0 + sign * w[:, 0] ** 2 * a, sign * b, -sign * w[:, 0]], -1)
    bb = np.stack([b, sign + w[:, 1] ** 2 * a, -w[:, 1]], -1)
    return (sin_t * np.cos(phi))[:, None] * t + (sin_t * np.sin(phi))[:, None] * bb + cos_t[:, None] * w


# ---------------------------------------------------------------- the stack as the walk sees it
KNOWN_KINDS = {False: ("coat",), True: ("conductor", "diffuse", "dielectric")}  # coats, bases


class _Layers:
    """Media 0..N (0 = vacuum above, m = interior of coat m-1) and interfaces 0..N (interface j
    between media j and j+1; interface N is the base)."""

    def __init__(self, stack: Stack, interfaces: str = "single"):
        if interfaces not in INTERFACES:
            raise ValueError(f"interfaces must be one of {', '.join(INTERFACES)}, got {interfaces!r}")
        # The walk knows each kind's physics itself, on purpose (it judges the models, so it does
        # not read the kinds' own responses): a kind it does not know has no reference yet.
        for where, layer in [*((f"coat {i}", c) for i, c in enumerate(stack.coats)), ("base", stack.base)]:
            if layer.type not in KNOWN_KINDS[where == "base"]:
                raise ValueError(f"{where}: the stochastic reference has no walk for {layer.type!r} layers "
                                 f"(it knows {', '.join(KNOWN_KINDS[where == 'base'])})")
        self.stack = stack
        self.multiple = interfaces == "multiple"
        coats = stack.coats
        self.N = len(coats)
        self.n = np.array([1.0] + [c.ior for c in coats])
        self.thick = np.array([0.0] + [c.thickness for c in coats])
        self.sig_a = np.array([[0.0] * 3] + [list(c.sigma_a) for c in coats])
        self.sig_s = np.array([[0.0] * 3] + [list(c.sigma_s) for c in coats])
        self.sig_s[self.thick == 0] = 0.0
        self.sig_a[self.thick == 0] = 0.0
        self.sig_t = self.sig_a + self.sig_s
        self.g = np.array([0.0] + [c.g for c in coats])
        self.scatters = (self.sig_s.max(1) > 0)
        rough = [c.roughness for c in coats]
        rot = [c.rotation for c in coats]
        b = stack.base
        if b.type == "diffuse":
            rough.append((0.0, 0.0))
            rot.append(0.0)
        else:
            rough.append(b.roughness)
            rot.append(b.rotation)
        self.alpha = np.array(rough, dtype=float)
        self.smooth = (self.alpha.max(1) == 0.0)
        self.alpha = np.maximum(self.alpha, ALPHA_MIN)
        self.cos_r = np.cos(rot)
        self.sin_r = np.sin(rot)
        self.base = b
        self.n_sub = b.ior if b.type == "dielectric" else None
        # thin films on the interfaces (``layers.film``): interface j carries coat j's, the base's
        # is interface N; a diffuse base has no interface to carry one
        if b.type == "diffuse" and getattr(b, "film_thickness", 0.0) > 0.0:
            raise ValueError("base: the stochastic reference has no thin film on a 'diffuse' base (it has no interface)")
        self.film_d = np.array([c.film_thickness for c in coats] + [getattr(b, "film_thickness", 0.0)], dtype=float)
        self.film_n = np.array([c.film_ior for c in coats] + [getattr(b, "film_ior", 1.0)], dtype=float)
        self.filmed = bool((self.film_d > 0.0).any())
        # a smooth filmed interface enters the delta-only exit series, which then depends on the
        # packet's wavelength
        self.film_in_exit = bool(((self.film_d > 0.0) & self.smooth).any())

    def to_local(self, j, w):
        c, s = self.cos_r[j], self.sin_r[j]
        return np.stack([w[:, 0] * c + w[:, 1] * s, -w[:, 0] * s + w[:, 1] * c, w[:, 2]], -1)

    def to_world(self, j, w):
        c, s = self.cos_r[j], self.sin_r[j]
        return np.stack([w[:, 0] * c - w[:, 1] * s, w[:, 0] * s + w[:, 1] * c, w[:, 2]], -1)

    def n_below(self, j):
        return self.n[j + 1] if j < self.N else self.n_sub

    def film(self, j, lam, flip):
        """The thin film on interface j for packets of wavelengths ``lam`` (nm) arriving from above,
        or from below where ``flip``, as the walk's frames see it (``microsurface.Film``); None
        without a film (or without wavelengths: a stack with no film)."""
        if lam is None or self.film_d[j] <= 0.0:
            return None
        n_above = self.n[j]
        if j == self.N and self.base.type == "conductor":
            return Film(self.film_n[j], self.film_d[j], lam, n_above,
                        conductor=(np.asarray(self.base.eta, dtype=float), np.asarray(self.base.k, dtype=float)))
        n_below = self.n_below(j)
        return Film(self.film_n[j], self.film_d[j], lam, np.where(flip, n_below, n_above),
                    n_in=np.where(flip, n_above, n_below))


# ---------------------------------------------------------------- interface events
def _rough_q(L: _Layers, j, i, o, eta_rel, conductor=None, film=None):
    """Density q(o) of a rough-interface event for a packet arriving along -i, in a frame where
    i.z > 0 (the side it arrives from is +z). Reflection if o.z > 0, transmission if o.z < 0.
    ``film``: the interface's thin film at each packet's wavelength (``microsurface.Film``), whose
    reflectance at the microfacet's cosine replaces the bare Fresnel factor."""
    ax, ay = L.alpha[j]
    il, ol = L.to_local(j, i), L.to_local(j, o)
    refl = ol[:, 2] > 0
    lam_i, lam_o = smith_lambda(il, ax, ay), smith_lambda(ol, ax, ay)
    g2 = 1.0 / (1.0 + lam_i + lam_o)
    # reflection
    hr = il + ol
    hr /= np.maximum(np.linalg.norm(hr, axis=1, keepdims=True), 1e-300)
    ci_r = np.sum(il * hr, 1)
    d_r = _ggx_d(hr, ax, ay)
    if conductor is not None:
        eta_c, k_c = conductor
        if film is not None:
            f = film.reflectance(ci_r)
        else:
            f = np.stack([_fresnel_conductor(ci_r, eta_c[c], k_c[c]) for c in range(3)], -1)
        return (f * (d_r * g2 / (4.0 * il[:, 2]))[:, None]) * refl[:, None]
    fres = (lambda c: _fresnel_dielectric(c, eta_rel)) if film is None else film.reflectance
    q_r = fres(ci_r) * d_r * g2 / (4.0 * il[:, 2])
    # transmission (Walter 2007): generalised half vector toward the side of i
    eta_rel = np.broadcast_to(np.asarray(eta_rel, dtype=float), il.shape[:1])
    ht = -(il + eta_rel[:, None] * ol)
    ht = ht * np.where(ht[:, 2] < 0, -1.0, 1.0)[:, None]
    ht /= np.maximum(np.linalg.norm(ht, axis=1, keepdims=True), 1e-300)
    ih, oh = np.sum(il * ht, 1), np.sum(ol * ht, 1)
    ok = (ih > 0) & (oh < 0)
    den = ih + eta_rel * oh
    q_t = np.where(ok, np.abs(ih * oh) * eta_rel ** 2 * (1.0 - fres(ih))
                   * _ggx_d(ht, ax, ay) * g2 / (il[:, 2] * np.maximum(den * den, 1e-300)), 0.0)
    return np.where(refl, q_r, q_t)[:, None] * np.ones(3)


def _flip(w, flip):
    return np.where(flip[:, None], w * np.array([1.0, 1.0, -1.0]), w)


# ---------------------------------------------------------------- delta-only exit series
class _Exit:
    """For each pair's exit direction: the Snell direction in every medium, the closed-form series
    of delta-only paths from each medium to the exit, and the solid-angle Jacobians. With ``lam``
    (one wavelength per row, nm), a smooth interface's thin film reflects at that wavelength (its
    reflectance from above: a lossless film reflects the same from below at the Snell-related
    angle, and totally where either side's direction is evanescent)."""

    def __init__(self, L: _Layers, wo: np.ndarray, lam: np.ndarray | None = None):
        self.up = wo[:, 2] > 0
        P = wo.shape[0]
        N = L.N
        n_exit = np.where(self.up, 1.0, L.n_sub if L.n_sub is not None else 1.0)
        s = wo[:, :2] * n_exit[:, None]  # invariant n sin(theta) times azimuth
        n_all = np.concatenate([L.n, [L.n_sub if L.n_sub is not None else 1.0]])  # media 0..N+1
        M = N + 2
        self.c = np.zeros((P, M))
        self.valid = np.zeros((P, M), bool)
        self.t = np.zeros((P, M, 2))
        for m in range(M):
            tm = s / n_all[m]
            c2 = 1.0 - np.sum(tm * tm, 1)
            self.valid[:, m] = c2 > 1e-14
            self.c[:, m] = np.sqrt(np.maximum(c2, 0.0))
            self.t[:, m] = tm
        self.valid[:, N + 1] &= L.n_sub is not None
        c_exit = np.abs(wo[:, 2])
        with np.errstate(divide="ignore", invalid="ignore"):
            self.jac = np.where(self.valid, (n_exit ** 2 * c_exit)[:, None]
                                / (n_all[None, :] ** 2 * np.maximum(self.c, 1e-300)), 0.0)
        # per-medium unscattered transmittance along the path (RGB)
        cc = np.maximum(self.c[:, :N + 1], 1e-300)
        self.tau = np.where(self.valid[:, :N + 1, None],
                            np.exp(-L.sig_t[None, :, :] * (L.thick[None, :, None] / cc[:, :, None])), 0.0)
        self.tau[:, 0] = 1.0
        # smooth-interface Fresnel (energy) at each interface j, for the path direction
        F = np.zeros((P, N + 1, 3))
        for j in range(N + 1):
            cj = self.c[:, j]
            if j < N or L.base.type == "dielectric":
                F[:, j] = _fresnel_dielectric(cj, n_all[j + 1] / n_all[j])[:, None]
            elif L.base.type == "conductor":
                F[:, j] = np.stack([_fresnel_conductor(cj, L.base.eta[c] / L.n[N], L.base.k[c] / L.n[N])
                                    for c in range(3)], -1)
            film = L.film(j, lam, np.zeros(P, bool)) if L.smooth[j] else None
            if film is not None:
                f = film.reflectance(cj)
                F[:, j] = f if f.ndim == 2 else f[:, None]
        self.F = F
        delta = L.smooth.copy()
        if L.base.type == "diffuse":
            delta[N] = False
        # looking down from medium m at interface m (and below), delta-only, non-delta absorbs
        Rb = np.zeros((P, N + 2, 3))
        for m in range(N, 0, -1):
            if not delta[m]:
                continue
            R = F[:, m]
            if m == N:
                Rb[:, m] = R
            else:
                inner = self.tau[:, m + 1] ** 2 * Rb[:, m + 1]
                Rb[:, m] = R + (1.0 - R) ** 2 * inner / np.maximum(1.0 - R * inner, 1e-300)
        # looking up from medium m at interface m-1 (and above)
        Ra = np.zeros((P, N + 2, 3))
        for m in range(1, N + 1):
            if not delta[m - 1]:
                continue
            R = F[:, m - 1]
            inner = self.tau[:, m - 1] ** 2 * Ra[:, m - 1] if m >= 2 else 0.0
            Ra[:, m] = R + (1.0 - R) ** 2 * inner / np.maximum(1.0 - R * inner, 1e-300)
        self.Rb, self.Ra = Rb, Ra
        ones = np.ones((P, 3))
        # reflection exits: X_top[m] from the top of medium m going up; UpB[m] = tau_m X_top[m]
        Xtop = np.zeros((P, N + 1, 3))
        UpB = np.zeros((P, N + 1, 3))
        UpB[:, 0] = ones
        for m in range(1, N + 1):
            if delta[m - 1]:
                R = F[:, m - 1]
                Xtop[:, m] = (1.0 - R) * UpB[:, m - 1] / np.maximum(1.0 - R * self.tau[:, m] ** 2 * Rb[:, m], 1e-300)
            UpB[:, m] = self.tau[:, m] * Xtop[:, m]
        # transmission exits: X_bot[m] from the bottom of medium m going down; DnT[m] = tau_m X_bot[m]
        Xbot = np.zeros((P, N + 2, 3))
        DnT = np.zeros((P, N + 2, 3))
        DnT[:, N + 1] = ones if L.n_sub is not None else 0.0
        for m in range(N, 0, -1):
            if delta[m] and (m < N or L.n_sub is not None):
                R = F[:, m]
                Xbot[:, m] = (1.0 - R) * DnT[:, m + 1] / np.maximum(1.0 - R * self.tau[:, m] ** 2 * Ra[:, m], 1e-300)
            DnT[:, m] = self.tau[:, m] * Xbot[:, m]
        self.Xtop, self.UpB, self.Xbot, self.DnT = Xtop, UpB, Xbot, DnT
        self.wo = wo

    def direction(self, m: int, up: bool, p: np.ndarray) -> np.ndarray:
        """The exit path's direction in medium m (world frame), going up or down, for the pairs p."""
        z = self.c[p, m] if up else -self.c[p, m]
        return np.concatenate([self.t[p, m], z[:, None]], 1)

    def after_interface(self, m: int, up: bool, p: np.ndarray) -> np.ndarray:
        """Delta-only weight from the boundary of medium m where a packet enters it (its bottom
        going up: reflection exits; its top going down: transmission exits), times the Jacobian,
        for the pairs p."""
        w = self.UpB[p, m] if up else self.DnT[p, m]
        return w * self.jac[p, m, None]


# ---------------------------------------------------------------- the walk
def _walk(L: _Layers, wi: np.ndarray, rng, exit_: _Exit | None, pair: np.ndarray, lam: np.ndarray | None = None,
          paths: dict | None = None):
    """Trace packets entering along -wi (one row per packet). Returns (reflected, transmitted,
    nee) per packet, RGB: escaped energy up / down and the NEE estimate toward each pair's wo.
    ``lam``: each packet's wavelength (nm) for a stack with thin films, which reflect at it (channel
    c of the result is then the walk with channel c's properties and the films at ``lam``).
    ``paths``: a dict that receives, per packet, the direction it left the top by (``"up"``, zero
    for a packet that did not) and how many times it met the base (``"base_meetings"``)."""
    K = wi.shape[0]
    N = L.N
    pos = np.zeros(K, dtype=np.int64)  # medium index (0 = outside above; N+1 = substrate)
    w = -wi.copy()
    beta = np.ones((K, 3))
    z = np.zeros(K)  # depth inside the current medium, from its top
    alive = np.ones(K, bool)
    # the packet starts at interface 0, arriving from medium 0
    at_iface = np.zeros(K, dtype=np.int64)
    pending = np.ones(K, bool)  # True: the packet sits on interface at_iface, about to interact
    refl = np.zeros((K, 3))
    trans = np.zeros((K, 3))
    nee = np.zeros((K, 3))
    scattered = np.zeros(K, bool)  # had a non-delta event (what eval_brdf_cos can see)
    up_dir = np.zeros((K, 3))
    base_meetings = np.zeros(K, dtype=np.int64)
    for depth in range(MAX_EVENTS):
        if not alive.any():
            break
        # --- interface interactions
        for j in range(N + 1):
            sel = np.nonzero(alive & pending & (at_iface == j))[0]
            if sel.size == 0:
                continue
            if not L.smooth[j] or (j == N and L.base.type == "diffuse"):
                scattered[sel] = True
            if j == N:
                base_meetings[sel] += 1
            _interface(L, j, sel, w, beta, pos, z, alive, pending, exit_, pair, nee, rng,
                       None if lam is None else lam[sel])
        # --- propagation inside media
        moving = np.nonzero(alive & ~pending)[0]
        if moving.size:
            _propagate(L, moving, w, beta, pos, z, alive, pending, at_iface, exit_, pair, nee, rng,
                       scattered)
        # --- escapes
        up_out = alive & ~pending & (pos == 0)
        refl[up_out] += beta[up_out]
        up_dir[up_out] = w[up_out]
        alive &= ~up_out
        down_out = alive & ~pending & (pos == N + 1)
        trans[down_out] += beta[down_out]
        alive &= ~down_out
        # --- Russian roulette after a few events, unbiased
        if depth >= 4:
            idx = np.nonzero(alive)[0]
            if idx.size:
                q = np.clip(beta[idx].max(1), 0.05, 1.0)
                survive = rng.random(idx.size) < q
                beta[idx] /= q[:, None]
                alive[idx[~survive]] = False
    if paths is not None:
        paths.update(up=up_dir, base_meetings=base_meetings)
    return refl, trans, nee, scattered


def _interface(L, j, sel, w, beta, pos, z, alive, pending, exit_, pair, nee, rng, lam=None):
    N = L.N
    wj = w[sel]
    n_above, n_below = L.n[j], L.n_below(j)
    is_base = j == N
    i = -wj
    flip = i[:, 2] < 0  # frame in which the packet arrives from +z
    i_f = _flip(i, flip)
    if is_base and L.base.type == "diffuse":
        # Lambertian: NEE then cosine sampling
        if exit_ is not None:
            up_pair = exit_.up[pair[sel]]
            d = exit_.direction(N, True, pair[sel])
            q = np.asarray(L.base.albedo)[None, :] * (d[:, 2] / math.pi)[:, None]
            nee[sel] += np.where(up_pair[:, None], beta[sel] * q * exit_.after_interface(N, True, pair[sel]), 0.0)
        u1, u2 = rng.random(sel.size), rng.random(sel.size)
        r, ph = np.sqrt(u1), 2 * math.pi * u2
        o = np.stack([r * np.cos(ph), r * np.sin(ph), np.sqrt(np.maximum(1 - u1, 0.0))], -1)
        beta[sel] *= np.asarray(L.base.albedo)[None, :]
        w[sel] = o
        pos[sel] = N
        z[sel] = L.thick[N]
        pending[sel] = False
        return
    conductor = None
    if is_base and L.base.type == "conductor":
        conductor = (np.asarray(L.base.eta) / n_above, np.asarray(L.base.k) / n_above)
        eta_rel = None
    else:
        eta_rel = np.where(flip, n_above / n_below, n_below / n_above)
    film = L.film(j, lam, flip)
    if L.smooth[j]:
        c = i_f[:, 2]
        if film is not None:
            f = film.reflectance(c)
        if conductor is not None:
            if film is None:
                f = np.stack([_fresnel_conductor(c, conductor[0][k], conductor[1][k]) for k in range(3)], -1)
            beta[sel] *= f
            o_f = i_f * np.array([-1.0, -1.0, 1.0])
            reflect = np.ones(sel.size, bool)
        else:
            F = _fresnel_dielectric(c, eta_rel) if film is None else f
            reflect = rng.random(sel.size) < F
            ct = np.sqrt(np.maximum(eta_rel ** 2 - 1.0 + c * c, 0.0) / eta_rel ** 2)
            o_t = np.concatenate([-i_f[:, :2] / eta_rel[:, None], -ct[:, None]], 1)
            o_f = np.where(reflect[:, None], i_f * np.array([-1.0, -1.0, 1.0]), o_t)
    else:
        # NEE toward the exit, then sample
        if exit_ is not None:
            _nee_interface(L, j, sel, i, i_f, flip, eta_rel, conductor, beta, exit_, pair, nee, rng, film)
        ax, ay = L.alpha[j]
        il = L.to_local(j, i_f)
        if L.multiple:  # the random walk on the microsurface decides where the packet leaves
            ol, weight, left = microsurface.walk(il, ax, ay, rng, eta=eta_rel, conductor=conductor, film=film)
            o_f = L.to_world(j, np.where(left[:, None], ol, np.array([0.0, 0.0, 1.0])))
            beta[sel] *= weight
            alive[sel[~left]] = False
            _leave_interface(L, j, sel, o_f, flip, w, pos, z, pending)
            return
        h = L.to_world(j, sample_vndf(il, ax, ay, rng.random(sel.size), rng.random(sel.size)))
        ci = np.sum(i_f * h, 1)
        o_r = 2.0 * ci[:, None] * h - i_f
        if conductor is not None:
            if film is not None:
                f = film.reflectance(ci)
            else:
                f = np.stack([_fresnel_conductor(ci, conductor[0][k], conductor[1][k]) for k in range(3)], -1)
            o_f = o_r
            reflect = np.ones(sel.size, bool)
            weight_rgb = f
        else:
            F = _fresnel_dielectric(ci, eta_rel) if film is None else film.reflectance(ci)
            reflect = rng.random(sel.size) < F
            ct = np.sqrt(np.maximum(eta_rel ** 2 - 1.0 + ci * ci, 0.0) / eta_rel ** 2)
            o_t = (-i_f + ci[:, None] * h) / eta_rel[:, None] - ct[:, None] * h
            o_f = np.where(reflect[:, None], o_r, o_t)
            weight_rgb = np.ones((sel.size, 3))
        ol = L.to_local(j, o_f)
        g = (1.0 + smith_lambda(il, ax, ay)) / (1.0 + smith_lambda(il, ax, ay) + smith_lambda(ol, ax, ay))
        wrong_side = np.where(reflect, o_f[:, 2] <= 0, o_f[:, 2] >= 0)
        beta[sel] *= weight_rgb * np.where(wrong_side, 0.0, g)[:, None]
        dead = wrong_side
        alive[sel[dead]] = False
    _leave_interface(L, j, sel, o_f, flip, w, pos, z, pending)


def _leave_interface(L, j, sel, o_f, flip, w, pos, z, pending):
    """Packets ``sel`` leave interface j along ``o_f`` (in the frame they arrived in from +z)."""
    o = _flip(o_f, flip)
    o /= np.linalg.norm(o, axis=1, keepdims=True)
    w[sel] = o
    # new medium: above interface j is medium j, below is j+1 (N+1 = substrate)
    new_pos = np.where(o[:, 2] > 0, j, j + 1)
    pos[sel] = new_pos
    z[sel] = np.where(o[:, 2] > 0, L.thick[np.minimum(new_pos, L.N)], 0.0)
    pending[sel] = False


def _nee_interface(L, j, sel, i, i_f, flip, eta_rel, conductor, beta, exit_, pair, nee, rng, film=None):
    """Connect a rough-interface event to the exit: reflection / transmission into the medium on
    either side, each followed by that side's delta-only series. With multiple-scattering
    interfaces the density toward the exit is the microsurface walk's own (stochastic) estimate."""
    N = L.N
    p = pair[sel]
    for up in (True, False):
        m = j if up else j + 1
        if m > N + 1 or (m == N + 1 and L.n_sub is None) or (not up and conductor is not None):
            continue
        d = exit_.direction(m, up, p)
        d_f = _flip(d, flip)
        if L.multiple:
            ax, ay = L.alpha[j]
            q = microsurface.walk(L.to_local(j, i_f), ax, ay, rng, eta=eta_rel, conductor=conductor,
                                  target=L.to_local(j, d_f), film=film)
        else:
            q = _rough_q(L, j, i_f, d_f, eta_rel if eta_rel is not None else 1.0, conductor, film)
        tail = exit_.after_interface(m, up, p)
        # going up, only exits through the top are delta-only (coming back down would cross this
        # rough interface again); going down, only exits through the base
        valid = exit_.valid[p, m] & (exit_.up[p] if up else ~exit_.up[p])
        nee[sel] += np.where(valid[:, None], beta[sel] * q * tail, 0.0)


def _propagate(L, idx, w, beta, pos, z, alive, pending, at_iface, exit_, pair, nee, rng, scattered):
    N = L.N
    m = pos[idx]
    wz = w[idx, 2]
    up = wz > 0
    th = L.thick[np.minimum(m, N)]
    dist = np.where(up, z[idx], th - z[idx]) / np.maximum(np.abs(wz), 1e-300)
    outside = (m == 0) | (m == N + 1)
    dist = np.where(outside, 0.0, dist)
    sig_t = L.sig_t[np.minimum(m, N)]
    sig_s = L.sig_s[np.minimum(m, N)]
    scat = L.scatters[np.minimum(m, N)] & ~outside
    # non-scattering media: Beer-Lambert to the boundary
    ns = ~scat
    beta[idx[ns]] *= np.exp(-sig_t[ns] * dist[ns, None])
    hit = ns.copy()
    if scat.any():
        k = np.nonzero(scat)[0]
        ch = rng.integers(0, 3, k.size)
        st = sig_t[k, ch]
        u = rng.random(k.size)
        t = np.where(st > 0, -np.log(1.0 - u) / np.maximum(st, 1e-300), np.inf)
        through = t >= dist[k]
        # boundary reached: Tr / P(pass), P(pass) = mean over channels of exp(-sig_t d)
        trb = np.exp(-sig_t[k] * dist[k, None])
        beta[idx[k[through]]] *= trb[through] / trb[through].mean(1, keepdims=True)
        hit[k[through]] = True
        s = ~through
        if s.any():
            ks = k[s]
            ts = t[s]
            tr = np.exp(-sig_t[ks] * ts[:, None])
            pdf = (sig_t[ks] * tr).mean(1, keepdims=True)
            beta[idx[ks]] *= sig_s[ks] * tr / pdf
            gi = idx[ks]
            mm = m[ks]
            scattered[gi] = True
            z[gi] = z[gi] - w[gi, 2] * ts
            g = L.g[mm]
            if exit_ is not None:
                _nee_medium(L, gi, mm, w, z, beta, exit_, pair, nee)
            w[gi] = _sample_hg(w[gi], g, rng.random(ks.size), rng.random(ks.size))
            w[gi] /= np.linalg.norm(w[gi], axis=1, keepdims=True)
    # packets that reached a boundary now sit on an interface (or have escaped)
    hit_idx = idx[hit & ~outside]
    mh = pos[hit_idx]
    goes_up = w[hit_idx, 2] > 0
    at_iface[hit_idx] = np.where(goes_up, mh - 1, mh)
    pending[hit_idx] = True


def _nee_medium(L, gi, mm, w, z, beta, exit_, pair, nee):
    p = pair[gi]
    for m in np.unique(mm):
        s = mm == m
        g_idx, pp = gi[s], p[s]
        th = L.thick[m]
        c = np.maximum(exit_.c[pp, m], 1e-300)
        valid = exit_.valid[pp, m]
        sig_t = L.sig_t[m]
        zz = z[g_idx]
        for up in (True, False):
            d = exit_.direction(m, up, pp)
            ph = _hg(np.sum(w[g_idx] * d, 1), L.g[m])
            # exit upward: straight up then X_top, or first down to the delta reflector below
            tr_first = np.exp(-sig_t[None, :] * ((zz if up else th - zz) / c)[:, None])
            refl_up = exit_.up[pp][:, None]
            # reflection exits
            if up:
                tail_r = tr_first * exit_.Xtop[pp, m]
                tail_t = tr_first * exit_.Ra[pp, m] * exit_.tau[pp, m] * exit_.Xbot[pp, m]
            else:
                tail_r = tr_first * exit_.Rb[pp, m] * exit_.tau[pp, m] * exit_.Xtop[pp, m]
                tail_t = tr_first * exit_.Xbot[pp, m]
            tail = np.where(refl_up, tail_r, tail_t) * exit_.jac[pp, m, None]
            nee[g_idx] += np.where(valid[:, None], beta[g_idx] * ph[:, None] * tail, 0.0)


# ---------------------------------------------------------------- wavelengths (thin films)
@functools.lru_cache(maxsize=None)
def _spectrum():
    """The wavelength grid (nm), its sampling CDF and each wavelength's channel weights W_c / p:
    W_c is channel c's colour matching weight of ``thin_film_spectral.cmfs(1)`` (CIE 1931 through
    Rec.709, unit sum per channel: a flat reflectance gives the same value in every channel), and
    p is proportional to sqrt(sum_c W_c^2)."""
    from .thin_film_spectral import cmfs

    lam, w = cmfs(1)
    p = np.sqrt((w * w).sum(1))
    p /= p.sum()
    cdf = np.cumsum(p)
    cdf /= cdf[-1]
    keep = p > 0.0
    ratio = np.zeros_like(w)
    ratio[keep] = w[keep] / p[keep, None]
    return lam, cdf, ratio


def _sample_wavelengths(rng, k: int):
    """(wavelengths (k,) in nm, channel weights (k, 3)) for k packets, drawn independently."""
    lam, cdf, ratio = _spectrum()
    idx = np.minimum(np.searchsorted(cdf, rng.random(k), side="right"), lam.size - 1)
    return lam[idx], ratio[idx]


# ---------------------------------------------------------------- public API
def _dirs(w):
    w = np.asarray(w, dtype=float)
    return w[None, :] if w.ndim == 1 else w


def covered_parts(stack) -> list[tuple[float, Stack]]:
    """(fraction of the surface, the stack there) for a stack with partly covering coats: each
    coat of coverage c is present on a fraction c, independently of the others, so each subset
    of them is present on the product of their coverages and the others' complements (lateral
    transport between the parts neglected). Subsets of zero area are left out; a stack whose coats
    all cover everything is one part of fraction 1."""
    stack = Stack.coerce(stack)
    partial = [i for i, c in enumerate(stack.coats) if c.coverage < 1.0]
    out = []
    for mask in range(2 ** len(partial)):
        here = {i for b, i in enumerate(partial) if mask >> b & 1}
        w = math.prod(stack.coats[i].coverage if i in here else 1.0 - stack.coats[i].coverage for i in partial)
        if w > 0.0:
            out.append((w, stack.part([i for i in range(len(stack.coats)) if i not in partial or i in here])))
    return out


def _mixed(parts, run):
    """The mix of ``run(stack) -> (mean, stderr)`` over ``covered_parts``: means weighted by the
    fractions, standard errors combined as independent estimates."""
    mean = err2 = 0.0
    for w, part in parts:
        m, e = run(part)
        mean = mean + w * m
        err2 = err2 + (w * e) ** 2
    return mean, np.sqrt(err2)


def eval_brdf_cos(stack, wi, wo, spp: int, seed: int = 0, interfaces: str = "single"):
    """Stochastic f(wi, wo) |wo.z| for each row of ``wo`` ((N, 3); ``wi`` (3,) or (N, 3)):
    returns (mean, stderr), each (N, 3). Lower-hemisphere ``wo`` is transmission into the
    dielectric base's substrate (density per solid angle there). ``interfaces``: "single" (rough
    interfaces scatter once, pbrt-v4's convention) or "multiple" (Heitz et al. 2016's walk on the
    microsurface, energy conserving: ``microsurface``). Partly covering coats: the mix of the
    walks of each part (``covered_parts``)."""
    parts = covered_parts(stack)
    if len(parts) > 1 or parts[0][0] != 1.0:
        return _mixed(parts, lambda part: eval_brdf_cos(part, wi, wo, spp, seed, interfaces))
    L = _Layers(parts[0][1], interfaces)
    wo = _dirs(wo)
    wi = np.broadcast_to(_dirs(wi), wo.shape)
    P = wo.shape[0]
    exit_ = _Exit(L, wo)
    rng = np.random.default_rng(seed)
    total = np.zeros((P, 3))
    total2 = np.zeros((P, 3))
    # a smooth filmed interface makes the exit series depend on each packet's wavelength: then
    # it is built per packet, in smaller batches
    per_chunk = max(1, (FILM_CHUNK if L.film_in_exit else CHUNK) // max(spp, 1))
    for start in range(0, P, per_chunk):
        stop = min(P, start + per_chunk)
        pair = np.repeat(np.arange(start, stop), spp)
        if L.filmed:
            lam, weight = _sample_wavelengths(rng, pair.size)
            if L.film_in_exit:
                _, _, nee, _ = _walk(L, wi[pair], rng, _Exit(L, wo[pair], lam), np.arange(pair.size), lam)
            else:
                _, _, nee, _ = _walk(L, wi[pair], rng, exit_, pair, lam)
            nee *= weight
        else:
            _, _, nee, _ = _walk(L, wi[pair], rng, exit_, pair)
        s = nee.reshape(stop - start, spp, 3)
        total[start:stop] = s.sum(1)
        total2[start:stop] = (s * s).sum(1)
    mean = total / spp
    var = np.maximum(total2 / spp - mean * mean, 0.0)
    return mean, np.sqrt(var / max(spp - 1, 1))


def albedo(stack, wi, spp: int, seed: int = 0, side: str = "reflected", exclude_delta: bool = False,
           interfaces: str = "single"):
    """Stochastic directional albedo: energy leaving the top (``side="reflected"``) or through
    the dielectric base (``"transmitted"``), by counting escaping packets. (mean, stderr), (N, 3).
    ``exclude_delta=True`` counts only packets that met at least one non-delta event: the part
    of the albedo that ``eval_brdf_cos`` integrates to (delta lobes have no density).
    ``interfaces``: as for ``eval_brdf_cos``."""
    if side not in ("reflected", "transmitted"):
        raise ValueError(f"side must be 'reflected' or 'transmitted', got {side!r}")
    parts = covered_parts(stack)
    if len(parts) > 1 or parts[0][0] != 1.0:
        return _mixed(parts, lambda part: albedo(part, wi, spp, seed, side, exclude_delta, interfaces))
    L = _Layers(parts[0][1], interfaces)
    wi = _dirs(wi)
    rng = np.random.default_rng(seed)
    means, errs = [], []
    for w in wi:
        tot = np.zeros(3)
        tot2 = np.zeros(3)
        left = spp
        while left > 0:
            k = min(left, CHUNK)
            if L.filmed:
                lam, weight = _sample_wavelengths(rng, k)
                r, t, _, scattered = _walk(L, np.broadcast_to(w, (k, 3)).copy(), rng, None, np.zeros(k, np.int64), lam)
                r, t = r * weight, t * weight
            else:
                r, t, _, scattered = _walk(L, np.broadcast_to(w, (k, 3)).copy(), rng, None, np.zeros(k, np.int64))
            v = r if side == "reflected" else t
            if exclude_delta:
                v = v * scattered[:, None]
            tot += v.sum(0)
            tot2 += (v * v).sum(0)
            left -= k
        m = tot / spp
        means.append(m)
        errs.append(np.sqrt(np.maximum(tot2 / spp - m * m, 0.0) / max(spp - 1, 1)))
    return np.array(means), np.array(errs)


def reflected_paths(stack, wi, spp: int, seed: int = 0, interfaces: str = "single"):
    """The light ``spp`` packets arriving along ``wi`` (3,) carry out of the top, packet by packet:
    (direction (M, 3), energy (M, 3), base meetings (M,)) for the M packets that left upward, the
    energy each carries (its share of the directional albedo is energy / spp) and how many times
    it met the base on its way: 0 for light the coats alone sent back. A stack with thin films or
    partly covering coats has no such split here."""
    parts = covered_parts(stack)
    if len(parts) > 1 or parts[0][0] != 1.0:
        raise ValueError("reflected_paths: a stack with partly covering coats is a mix of walks, not one")
    L = _Layers(parts[0][1], interfaces)
    if L.filmed:
        raise ValueError("reflected_paths: a stack with a thin film is walked per wavelength, not split here")
    rng = np.random.default_rng(seed)
    out = ([], [], [])
    left = spp
    while left > 0:
        k = min(left, CHUNK)
        paths: dict = {}
        r, _, _, _ = _walk(L, np.broadcast_to(_dirs(wi)[0], (k, 3)).copy(), rng, None, np.zeros(k, np.int64),
                           paths=paths)
        up = r.max(1) > 0.0
        for dst, v in zip(out, (paths["up"][up], r[up], paths["base_meetings"][up])):
            dst.append(v)
        left -= k
    return tuple(np.concatenate(v) for v in out)
