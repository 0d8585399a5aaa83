"""The GGX microsurface in numpy, for the stochastic reference and the table generator.

Primitives: Fresnel factors (unpolarised, dielectric and conductor), Smith's Lambda and the GGX
distribution, anisotropic (Heitz 2014, "Understanding the masking-shadowing function", Eqs. 72 and
86), and visible-normal sampling (Heitz 2018, JCGT 7(4), Listing 1, for views above the horizon;
Dupuy and Benyoub 2023, "Sampling visible GGX normals with spherical caps", Listing 3, for any
view).

The multiple-scattering interface (``walk``) is the random walk on the microsurface of Heitz,
Hanika, d'Eon and Dachsbacher 2016, "Multiple-scattering microfacet BSDFs with the Smith model":
the microsurface is a random medium of uniformly distributed heights in [-1, 1] (their Sec. 4.2)
and GGX slopes; a ray from height h in direction w leaves it without a hit with probability
G1(w, h) = C1(h)^Lambda(w) (Eq. 11), else hits at the height drawn by inverting that (Sec. 5.1,
``sample_height``); there it scatters on a visible normal drawn from D_wi (Eq. 2): a conductor
reflects and weighs the packet by its Fresnel factor (Sec. 6.1), a dielectric reflects with
probability F and otherwise refracts to the other side of the microsurface, whose medium is the
same walk mirrored (heights and directions negated, the index inverted; Sec. 6.2). An evaluation
of the BSDF toward a given direction is the walk's next-event estimate: at every vertex the phase
function toward that direction times the probability of leaving toward it from that height
(Sec. 5.2); it is unbiased and, like everything the reference computes, stochastic.

Its single-scattering part is the height-correlated Smith BSDF: G2 = 1 / (1 + Lambda_i + Lambda_o)
for reflection, and for transmission the Beta form G2 = B(1 + Lambda_i, 1 + Lambda_o) that
uniform heights imply (``g2_transmission``), where pbrt-v4's single-scattering interfaces (this
reference's ``interfaces="single"``) use 1 / (1 + Lambda_i + Lambda_o) for both.

A thin film on the interface (``film_fresnel``, ``Film``: the exact Airy reflectance at one
wavelength per packet) replaces the Fresnel factor on every facet, each from the side the walk
meets it on; the reference's spectral walk (``reference``, "Thin films") gives each packet its
wavelength.
"""
from __future__ import annotations

import math

import numpy as np

MAX_ORDER = 256  # scattering events on one microsurface; a walk still inside after this is dropped


def _fresnel_dielectric(c, eta):
    c = np.clip(c, 0.0, 1.0)
    eta2 = eta * eta
    num = eta2 - 1.0 + c * c
    ct = np.sqrt(np.maximum(num, 0.0) / eta2)
    rs = (c - eta * ct) / np.maximum(c + eta * ct, 1e-300)
    rp = (eta * c - ct) / np.maximum(eta * c + ct, 1e-300)
    return np.where(num < 0.0, 1.0, np.minimum(0.5 * (rs * rs + rp * rp), 1.0))


def _fresnel_conductor(c, eta, k):
    c = np.clip(c, 0.0, 1.0)
    c2 = c * c
    s2 = 1.0 - c2
    t0 = eta * eta - k * k - s2
    a2pb2 = np.sqrt(t0 * t0 + 4.0 * eta * eta * k * k)
    a = np.sqrt(np.maximum(0.5 * (a2pb2 + t0), 0.0))
    t1 = a2pb2 + c2
    t2 = 2.0 * a * c
    rs = (t1 - t2) / np.maximum(t1 + t2, 1e-300)
    t3 = c2 * a2pb2 + s2 * s2
    t4 = t2 * s2
    rp = rs * (t3 - t4) / np.maximum(t3 + t4, 1e-300)
    return np.clip(0.5 * (rp + rs), 0.0, 1.0)


def _abs2(z):
    return (z * z.conj()).real


def _airy(r12, x, y, cos_d, sin_d):
    """|r|^2 of r = (r12 + z) / (1 + r12 z), z = (x + i y) e^{i delta}, for a real r12."""
    z2 = x * x + y * y
    rz = 2.0 * r12 * (x * cos_d - y * sin_d)
    r2 = r12 * r12
    return (r2 + z2 + rz) / (1.0 + r2 * z2 + rz)


def _film_fresnel_evanescent(c, n_i, nn2, thickness_nm, nn3, lam_nm):
    """``film_fresnel`` where the wave in the film is evanescent (q_2 imaginary: light tunnelling
    through a film of lower index past its critical angle), in complex arithmetic, without
    complex division: with r_12 = a / b and r_23 = u / v, |r|^2 = |a v + u b E|^2 / |b v + a u E|^2,
    E = e^{i delta}."""
    nn1 = n_i * n_i
    s2 = nn1 * (1.0 - c * c)
    q1 = n_i * c
    q2 = np.sqrt((nn2 - s2) + 0j)
    q3 = np.sqrt((nn3 - s2) + 0j)  # principal roots: Im >= 0 since Im(N^2) = 2 eta k >= 0
    e = np.exp((1j * 4.0 * math.pi * thickness_nm) * q2 / lam_nm)
    out = 0.0
    for a, b, u, v in ((q1 - q2, q1 + q2, q2 - q3, q2 + q3),
                       (nn2 * q1 - nn1 * q2, nn2 * q1 + nn1 * q2, nn3 * q2 - nn2 * q3, nn3 * q2 + nn2 * q3)):
        ue = u * e
        out = out + 0.5 * _abs2(a * v + ue * b) / _abs2(b * v + ue * a)
    return out


def film_fresnel(c, n_i, n_film, thickness_nm, n_t, lam_nm):
    """Unpolarised reflectance of a thin film between two half-spaces, at one wavelength per
    element: light arriving at cosine ``c`` from the medium of real index ``n_i`` onto a film of
    index ``n_film`` and thickness ``thickness_nm`` over a medium of index ``n_t`` (real, or
    complex eta + i k for a conductor), all absolute, wavelength ``lam_nm`` (nm); the arguments
    broadcast together.

    The exact Airy sum (Born and Wolf, *Principles of Optics*, Sections 1.5-1.6): with
    q_j = N_j cos(theta_j) = sqrt(N_j^2 - n_i^2 sin^2(theta_i)) (Im >= 0),
    r_s(a, b) = (q_a - q_b) / (q_a + q_b), r_p(a, b) = (N_b^2 q_a - N_a^2 q_b) / (N_b^2 q_a + N_a^2 q_b),
    r = (r_12 + r_23 e^{i delta}) / (1 + r_12 r_23 e^{i delta}), delta = 4 pi d q_2 / lambda, and
    R = (|r_s|^2 + |r_p|^2) / 2: total internal reflection at either interface, the light a film
    thinner than a wavelength lets tunnel through, and a conductor's phase on reflection included.
    The film absorbs nothing: a dielectric stack transmits 1 - R (the same from both sides, at
    Snell-related angles, as for any lossless stratified medium). At grazing incidence (c = 0) R = 1.

    Where the film's wave propagates (q_2 real, the common case) r_12 is real and
    |r|^2 = (r12^2 + |r23|^2 + 2 r12 Re z) / (1 + r12^2 |r23|^2 + 2 r12 Re z), z = r23 e^{i delta},
    in real arithmetic (r_23 = x + i y written out, q_3 = u + i v); elsewhere in complex arithmetic
    (``_film_fresnel_evanescent``)."""
    conductor = np.iscomplexobj(n_t)
    c, n_i, n_t, lam_nm = np.clip(c, 0.0, 1.0), np.asarray(n_i, dtype=float), np.asarray(n_t), np.asarray(lam_nm, dtype=float)
    shape = np.broadcast_shapes(c.shape, n_i.shape, n_t.shape, lam_nm.shape)
    nn1 = n_i * n_i
    nn2 = float(n_film) ** 2
    s2 = nn1 * (1.0 - c * c)
    q1 = n_i * c
    q2sq = nn2 - s2
    q2 = np.sqrt(np.maximum(q2sq, 0.0))
    nn3 = n_t * n_t
    if conductor:
        q3 = np.sqrt(nn3 - s2)  # the principal root: Im >= 0 since Im(N^2) = 2 eta k >= 0
        u, v, e_re, e_im = q3.real, q3.imag, nn3.real, nn3.imag
    else:
        t = nn3 - s2
        u, v = np.sqrt(np.maximum(t, 0.0)), np.sqrt(np.maximum(-t, 0.0))
        e_re, e_im = nn3, 0.0
    delta = (4.0 * math.pi * float(thickness_nm)) * q2 / lam_nm
    cos_d, sin_d = np.cos(delta), np.sin(delta)
    with np.errstate(invalid="ignore", divide="ignore"):
        # s: r_23 = (q2 - q3) / (q2 + q3)
        den = (q2 + u) ** 2 + v * v
        r_s = _airy((q1 - q2) / (q1 + q2), (q2 * q2 - u * u - v * v) / den, -2.0 * v * q2 / den, cos_d, sin_d)
        # p: r_23 = (P - H) / (P + H), P = N3^2 q2, H = n2^2 q3
        p_re, p_im, h_re, h_im = e_re * q2, e_im * q2, nn2 * u, nn2 * v
        den = (p_re + h_re) ** 2 + (p_im + h_im) ** 2
        r_p = _airy((nn2 * q1 - nn1 * q2) / (nn2 * q1 + nn1 * q2), (p_re * p_re + p_im * p_im - h_re * h_re - h_im * h_im) / den,
                    2.0 * (p_im * h_re - p_re * h_im) / den, cos_d, sin_d)
        out = np.array(np.broadcast_to(0.5 * (r_s + r_p), shape))
        ev = np.broadcast_to(q2sq < 0.0, shape)
        if ev.any():
            c_, n_i_, n_t_, lam_ = (np.broadcast_to(x, shape)[ev] for x in (c, n_i, n_t, lam_nm))
            out[ev] = _film_fresnel_evanescent(c_, n_i_, nn2, float(thickness_nm), n_t_ * n_t_, lam_)
    # the denominators vanish only at grazing incidence (c = 0) or on sets of measure zero
    return np.where((c > 0.0) & np.isfinite(out), np.clip(out, 0.0, 1.0), 1.0)


class Film:
    """A thin film on an interface, for a batch of packets each at its own wavelength: the Fresnel
    factor the walk uses in place of the bare interface's (``film_fresnel``).

    ``n_out`` (K,): the absolute index of the side the packets arrive from (the walk's +z side);
    a dielectric interface has ``n_in`` (K,), the other side's, and a conductor ``conductor`` =
    (eta (3,), k (3,)), absolute, one per RGB channel (the film is spectral, the rest per channel)."""

    def __init__(self, ior, thickness_nm, lam_nm, n_out, n_in=None, conductor=None):
        self.ior, self.thickness = float(ior), float(thickness_nm)
        self.lam = np.asarray(lam_nm, dtype=float)
        self.n_out = np.broadcast_to(np.asarray(n_out, dtype=float), self.lam.shape)
        self.n_in = None if n_in is None else np.broadcast_to(np.asarray(n_in, dtype=float), self.lam.shape)
        self.conductor = conductor

    def take(self, idx):
        """The film for the packets ``idx``."""
        return Film(self.ior, self.thickness, self.lam[idx], self.n_out[idx],
                    None if self.n_in is None else self.n_in[idx], self.conductor)

    def reflectance(self, c, inside=None):
        """R at microfacet (or interface) cosine ``c``: (K,) for a dielectric, from the arrival
        side, or from the other side where ``inside``; (K, 3) for a conductor."""
        if self.conductor is not None:
            n_t = np.asarray(self.conductor[0], dtype=float) + 1j * np.asarray(self.conductor[1], dtype=float)
            return film_fresnel(np.asarray(c)[:, None], self.n_out[:, None], self.ior, self.thickness, n_t[None, :],
                                self.lam[:, None])
        n_i, n_t = self.n_out, self.n_in
        if inside is not None:
            n_i, n_t = np.where(inside, self.n_in, self.n_out), np.where(inside, self.n_out, self.n_in)
        return film_fresnel(c, n_i, self.ior, self.thickness, n_t, self.lam)


def smith_lambda(w, ax, ay):
    """Smith Lambda of a direction in the interface frame (z may be negative: |z| is used)."""
    z2 = np.maximum(w[..., 2] ** 2, 1e-300)
    t = (ax * ax * w[..., 0] ** 2 + ay * ay * w[..., 1] ** 2) / z2
    return 0.5 * (np.sqrt(1.0 + t) - 1.0)


def _ggx_d(h, ax, ay):
    t = h[..., 0] ** 2 / (ax * ax) + h[..., 1] ** 2 / (ay * ay) + h[..., 2] ** 2
    # t = 0 only for a degenerate (zero) half vector, e.g. wo = -wi: no microfacet maps one to the other
    return np.where(t > 0, 1.0 / (math.pi * ax * ay * np.maximum(t, 1e-150) ** 2), 0.0)


def sample_vndf(i, ax, ay, u1, u2):
    """Heitz 2018 Listing 1: a visible normal for direction i (i.z > 0) of anisotropic GGX."""
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


def sample_vndf_sphere(i, ax, ay, u1, u2):
    """A visible normal for direction ``i`` of any elevation (the distribution D_i(m) proportional to
    max(0, i.m) D(m)): Dupuy and Benyoub 2023, Listing 3 (a point on the spherical cap of the
    stretched view)."""
    v = np.stack([ax * i[:, 0], ay * i[:, 1], i[:, 2]], -1)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    phi = 2.0 * math.pi * u1
    z = (1.0 - u2) * (1.0 + v[:, 2]) - v[:, 2]
    s = np.sqrt(np.clip(1.0 - z * z, 0.0, 1.0))
    h = np.stack([s * np.cos(phi), s * np.sin(phi), z], -1) + v
    m = np.stack([ax * h[:, 0], ay * h[:, 1], h[:, 2]], -1)
    return m / np.maximum(np.linalg.norm(m, axis=1, keepdims=True), 1e-300)


def signed_lambda(w, ax, ay):
    """Smith's Lambda of a direction of travel: Lambda(w) upward, -1 - Lambda(-w) downward (Heitz
    et al. 2016, Sec. 5.1), so that (1 + Lambda(w)) w.z is the microsurface's projected area."""
    lam = smith_lambda(w, ax, ay)
    return np.where(w[:, 2] >= 0.0, lam, -1.0 - lam)


def _c1(h):
    return np.clip(0.5 * (h + 1.0), 0.0, 1.0)  # uniform heights in [-1, 1]


def _inv_c1(u):
    return np.clip(2.0 * u - 1.0, -1.0, 1.0)


def escape_probability(w, h, ax, ay):
    """G1(w, h): the probability that a ray leaving height ``h`` along ``w`` meets the
    microsurface no more (0 for rays going down)."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        g = np.power(_c1(h), smith_lambda(w, ax, ay))
    return np.where(w[:, 2] > 0.0, np.where(w[:, 2] > 0.9999, 1.0, g), 0.0)


def sample_height(w, h, ax, ay, u):
    """The height of the next hit of a ray from height ``h`` along ``w``, or +inf if it leaves the
    microsurface (Heitz et al. 2016, Sec. 5.1: C1(h') = C1(h) / (1 - u)^(1 / Lambda(w)))."""
    lam = signed_lambda(w, ax, ay)
    wz = w[:, 2]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore", under="ignore"):
        leave = (wz > 0.0) & ((wz > 0.9999) | (u > 1.0 - escape_probability(w, h, ax, ay)))
        hit = _inv_c1(_c1(h) / np.power(1.0 - u, 1.0 / lam))
    hit = np.where(wz < -0.9999, _inv_c1(u * _c1(h)), hit)
    hit = np.where(np.abs(wz) < 1e-4, h, hit)
    return np.where(leave, np.inf, hit)


def visible_ndf(i, m, ax, ay):
    """D_i(m) = max(0, i.m) D(m) / ((1 + Lambda(i)) i.z), the density of visible normals."""
    area = (1.0 + signed_lambda(i, ax, ay)) * i[:, 2]
    return np.maximum(np.sum(i * m, 1), 0.0) * _ggx_d(m, ax, ay) / np.maximum(area, 1e-300)


def phase(i, o, ax, ay, eta=None, conductor=None, fresnel=None):
    """The microsurface's phase function in the frame of the side a ray travels in (microfacet
    normals up): the density of leaving along ``o`` after a hit by a ray arriving along -``i``,
    (K, 3). Reflection where o.z > 0 (times the Fresnel factor, RGB for a conductor),
    refraction into the other side (index ratio ``eta`` = n_other / n_this) where o.z < 0.
    ``fresnel``: the Fresnel factor as a function of the microfacet cosine (a filmed facet,
    ``Film.reflectance``: (K,) for a dielectric, (K, 3) for a conductor) in place of the bare one."""
    hr = i + o
    hr = hr / np.maximum(np.linalg.norm(hr, axis=1, keepdims=True), 1e-300)
    hr = hr * np.where(hr[:, 2] < 0.0, -1.0, 1.0)[:, None]
    ci = np.sum(i * hr, 1)
    base = visible_ndf(i, hr, ax, ay) / np.maximum(4.0 * ci, 1e-300) * (ci > 0)
    if conductor is not None:
        if fresnel is not None:
            f = fresnel(ci)
        else:
            f = np.stack([_fresnel_conductor(ci, conductor[0][c], conductor[1][c]) for c in range(3)], -1)
        return np.where((o[:, 2] > 0.0)[:, None], f * base[:, None], 0.0)
    fres = (lambda c: _fresnel_dielectric(c, eta)) if fresnel is None else fresnel
    refl = fres(ci) * base
    ht = -(i + eta[:, None] * o)
    ht = ht * np.where(ht[:, 2] < 0.0, -1.0, 1.0)[:, None]
    ht = ht / np.maximum(np.linalg.norm(ht, axis=1, keepdims=True), 1e-300)
    ih, oh = np.sum(i * ht, 1), np.sum(o * ht, 1)
    den = ih + eta * oh
    trans = np.where((ih > 0) & (oh < 0), eta * eta * (1.0 - fres(ih)) * visible_ndf(i, ht, ax, ay)
                     * np.abs(oh) / np.maximum(den * den, 1e-300), 0.0)
    return np.where(o[:, 2] > 0.0, refl, trans)[:, None] * np.ones(3)


def g2_transmission(lam_i, lam_o):
    """The height-correlated masking-shadowing of a refraction through uniform heights, Beta(1 +
    Lambda_i, 1 + Lambda_o): what the walk's single scattering integrates to (its reflection
    counterpart is 1 / (1 + Lambda_i + Lambda_o))."""
    lg = np.frompyfunc(math.lgamma, 1, 1)
    a, b = 1.0 + np.asarray(lam_i, float), 1.0 + np.asarray(lam_o, float)
    return np.exp((lg(a) + lg(b) - lg(a + b)).astype(float))


def walk(i, ax, ay, rng, eta=None, conductor=None, target=None, max_order: int = MAX_ORDER, orders=None,
         events: bool = False, film: Film | None = None):
    """Random walks on the microsurface for rays arriving along -``i`` (K, 3) from the side
    +z (the interface's frame, i.z > 0). ``eta``: n_below / n_above (K,) for a dielectric, or
    ``conductor`` = (eta (3,), k (3,)) relative to the medium above.

    Without ``target``: (o, weight, left): the direction each walk leaves along (o.z > 0 reflected,
    o.z < 0 transmitted), its energy weight (K, 3: the product of the conductor's Fresnel factors;
    1 for a dielectric) and whether it left within ``max_order`` events (a walk still inside carries
    nothing). With ``target`` (K, 3): the stochastic estimate of f(i, target) |target.z| (K, 3)
    by next-event estimation at every vertex. ``orders``: count only these scattering orders
    (1 = single scattering), for the validation. ``events=True`` (without ``target``) also returns
    how many times each walk scattered before it left (K,). ``film``: a thin film on every microfacet
    (``Film``, one wavelength per walk, arrival side +z), whose reflectance replaces the bare
    Fresnel factor at every vertex, from the side the walk is on there, in the choice between
    reflection and refraction, the conductor's weight and the next-event estimate alike."""
    K = i.shape[0]
    w = -np.asarray(i, dtype=float)  # the ray's direction in the frame of its side (normals up)
    h = np.full(K, 2.0)  # above the highest microfacet
    outside = np.ones(K, bool)
    energy = np.ones((K, 3))
    active = np.ones(K, bool)
    out = np.zeros((K, 3))
    left = np.zeros(K, bool)
    q = np.zeros((K, 3))
    scattered = np.zeros(K, np.int64)
    eta_out = None if conductor is not None else np.broadcast_to(np.asarray(eta, dtype=float), (K,))
    for order in range(1, max_order + 1):
        idx = np.nonzero(active)[0]
        if idx.size == 0:
            break
        hh = sample_height(w[idx], h[idx], ax, ay, rng.random(idx.size))
        gone = ~np.isfinite(hh)
        g = idx[gone]
        out[g] = np.where(outside[g, None], w[g], -w[g])
        left[g] = True
        scattered[g] = order - 1
        active[g] = False
        idx, hh = idx[~gone], hh[~gone]
        if idx.size == 0:
            break
        h[idx] = hh
        ins = ~outside[idx]
        wi = -w[idx]
        eta_s = None if eta_out is None else np.where(ins, 1.0 / eta_out[idx], eta_out[idx])
        fres = None
        if film is not None:
            f_idx = film.take(idx)
            fres = (lambda cc, f_idx=f_idx, ins=ins: f_idx.reflectance(cc, None if conductor is not None else ins))
        if target is not None and (orders is None or order in orders):
            t = np.where(ins[:, None], -target[idx], target[idx])  # the target in this side's frame
            esc = np.where(t[:, 2] > 0.0, escape_probability(t, hh, ax, ay), escape_probability(-t, -hh, ax, ay))
            q[idx] += energy[idx] * phase(wi, t, ax, ay, eta_s, conductor, fres) * esc[:, None]
        m = sample_vndf_sphere(wi, ax, ay, rng.random(idx.size), rng.random(idx.size))
        c = np.sum(wi * m, 1)
        o = 2.0 * c[:, None] * m - wi
        if conductor is not None:
            if fres is not None:
                energy[idx] *= fres(c)
            else:
                energy[idx] *= np.stack([_fresnel_conductor(c, conductor[0][k], conductor[1][k]) for k in range(3)], -1)
            w[idx] = o
        else:
            refract = rng.random(idx.size) >= (_fresnel_dielectric(c, eta_s) if fres is None else fres(c))
            ct = np.sqrt(np.maximum(1.0 - (1.0 - c * c) / (eta_s * eta_s), 0.0))
            o_t = -wi / eta_s[:, None] + (c / eta_s - ct)[:, None] * m
            # refracted: the walk goes on in the other side's frame, mirrored (Sec. 6.2)
            w[idx] = np.where(refract[:, None], -o_t, o)
            h[idx] = np.where(refract, -hh, hh)
            outside[idx] ^= refract
        w[idx] /= np.linalg.norm(w[idx], axis=1, keepdims=True)
    if target is not None:
        return q
    if events:
        return out, np.where(left[:, None], energy, 0.0), left, scattered
    return out, np.where(left[:, None], energy, 0.0), left
