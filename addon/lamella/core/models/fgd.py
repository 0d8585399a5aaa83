"""Pre-integrated interface terms read from the tables of ``lamella.core.luts``.

FGD (Randrianandrasana et al. 2021 Eq. 8) is the directional albedo of a rough interface with exact
Fresnel, single scattering; GD (Eq. 38) the same with F = 1, the lobe normaliser. Smooth limits are
exact to floating-point precision: the tables hold rough-minus-smooth differences, and the
multiple-scattering tables vanish for a smooth interface.
"""
from __future__ import annotations

from .. import luts
from .fresnel import fresnel_conductor, fresnel_dielectric
from .rgb import RGB


def _coords(ops, mu, alpha):
    return luts.mu_to_coord(ops, mu), luts.alpha_to_coord(ops, alpha)


def gd(ops, mu, alpha):
    """Directional albedo of a GGX lobe with F = 1 (Randrianandrasana et al. 2021 Eq. 38)."""
    cm, ca = _coords(ops, mu, alpha)
    return ops.lut("ggx_albedo", cm, ca)


# Below this roughness scale the lobe is narrow enough that the exact Fresnel at its mean beats
# the piecewise-linear quadrature; the blend exp(-(alpha / ALPHA_BLEND)^2) hands over between
# them (0.02 measured best of 0.01/0.02/0.04/0.08 in bench/luts.md's dielectric error).
ALPHA_BLEND = 0.02


def smooth_weight(ops, alpha):
    """exp(-(alpha / ALPHA_BLEND)^2): the weight of the smooth interface's exact value."""
    a = alpha * (1.0 / ALPHA_BLEND)
    return ops.exp(-(a * a))


def _hat(ops, mu, j):
    left, right = luts.hat(mu, j)
    if left is None:
        return ops.clamp(right, 0.0, 1.0)
    if right is None:
        return ops.clamp(left, 0.0, 1.0)
    return ops.clamp(ops.min(left, right), 0.0, 1.0)


def fgd_quadrature(ops, mu, alpha, fresnel):
    """FGD of a GGX interface whose Fresnel reflectance is ``fresnel(cos)`` (any backend function):
    sum_j F(c_j) (D_j + h_j(mu)) from the ``fresnel_hat_delta`` table, where the pointwise
    interpolation error F(mu) - sum_j F(c_j) h_j(mu) is added back for narrow lobes, so a smooth
    interface gets exactly F(mu)."""
    cm, ca = _coords(ops, mu, alpha)
    n = len(luts.FRESNEL_NODES)
    rough = 0.0
    interp = 0.0
    for j, c in enumerate(luts.FRESNEL_NODES):
        f = fresnel(c)
        h = _hat(ops, mu, j)
        rough = rough + f * (ops.lut("fresnel_hat_delta", cm, ca, j / (n - 1.0)) + h)
        interp = interp + f * h
    return ops.clamp(rough + (fresnel(mu) - interp) * smooth_weight(ops, alpha), 0.0, 1.0)


def fgd_dielectric(ops, mu, alpha, eta, multiple: bool = False, smooth=None):
    """FGD of a dielectric interface, light from the side of index n1 onto n2, eta = n2 / n1
    (total internal reflection included through the exact Fresnel curve).

    ``multiple=True``: the whole reflectance of the energy-conserving interface instead (Heitz,
    Hanika, d'Eon and Dachsbacher 2016; the ``dielectric_rough_reflect`` table), handing over to the
    exact Fresnel factor as alpha goes to 0 (the blend of ``fgd_quadrature``); one minus it is the
    interface's transmittance. From the denser side it is well above FGD
    (alpha 0.3, eta 1 / 1.5, 37 degrees: 0.43 against 0.27), because light one facet sends on meets
    others past their own critical angle, and FGD's quadrature rounds the Fresnel curve's kink at the
    critical angle off. From the lighter side the two agree within 0.01 (alpha up to 0.6), and the
    part single scattering misses leaves broader than the GGX lobe FGD weights, so the models use
    this from below only (``adding_doubling``).

    ``smooth``: the smooth interface's reflectance to hand over to (``multiple=True``), where the
    caller has it more exactly than the Fresnel factor at ``mu``: from below along the refracted
    mean direction it is the reflectance from above at the incidence (Stokes' relations), which in
    float32 does not cancel where the refracted ray runs near grazing under an index-matched
    interface (index 1.0000001 at 1e-7 from grazing: cos_t^2 from below rounds negative, a false
    total internal reflection that trapped the light)."""
    if multiple:
        rough = ops.lut("dielectric_rough_reflect", luts.ms_x_to_coord(ops, mu, eta),
                        luts.alpha_to_coord(ops, alpha), luts.ms_eta_to_coord(ops, eta))
        exact = fresnel_dielectric(ops, mu, eta) if smooth is None else smooth
        return ops.clamp(rough + (exact - rough) * smooth_weight(ops, alpha), 0.0, 1.0)
    return fgd_quadrature(ops, mu, alpha, lambda c: fresnel_dielectric(ops, c, eta))


def trapped_escape(ops, mu, alpha, eta):
    """Of the light a rough dielectric interface reflects back to the side it came from (index n1,
    eta = n2 / n1, arriving along cosine ``mu``), the share that crosses the interface when a mirror
    sends it back (the ``dielectric_trapped_escape`` table, from the energy-conserving interface of
    Heitz, Hanika, d'Eon and Dachsbacher 2016), handing over to the smooth interface's
    transmittance, where the reflected light comes back along the way it came, as alpha goes to 0
    (the blend of ``fgd_quadrature``). From the denser side it is far below the transmittance of
    the first arrival: the reflected light has mostly been turned past the critical angle."""
    rough = ops.lut("dielectric_trapped_escape", luts.ms_x_to_coord(ops, mu, eta),
                    luts.alpha_to_coord(ops, alpha), luts.ms_eta_to_coord(ops, eta))
    smooth = 1.0 - fresnel_dielectric(ops, mu, eta)
    return ops.clamp(rough + (smooth - rough) * smooth_weight(ops, alpha), 0.0, 1.0)


def coat_first_escape(ops, mu, alpha_coat, alpha_base, n):
    """Of the light one rough coat (index ``n``, roughness ``alpha_coat``) refracts in from the view
    of cosine ``mu`` and a base of roughness ``alpha_base`` reflects, the share that crosses the
    coat on its first way up (the ``coat_first_escape`` table: random walks on both microsurfaces,
    the base reflecting everything). A 4D table stored folded: the two eta blocks around
    1 / ``n``, blended."""
    x = luts.tir_eta_to_coord(ops, 1.0 / n) * (luts.N_FE_ETA - 1)
    j = ops.min(ops.floor(x), luts.N_FE_ETA - 2)
    f = x - j
    b = luts.alpha_to_coord(ops, alpha_base) * (luts.N_FE_ALPHA - 1)
    last = 1.0 / (luts.N_FE_ALPHA * luts.N_FE_ETA - 1)
    c0, c1 = ops.clamp(mu, 0.0, 1.0), luts.alpha_to_coord(ops, alpha_coat)
    lo = ops.lut("coat_first_escape", c0, c1, (j * luts.N_FE_ALPHA + b) * last)
    hi = ops.lut("coat_first_escape", c0, c1, ((j + 1.0) * luts.N_FE_ALPHA + b) * last)
    return ops.clamp(lo + (hi - lo) * f, 0.0, 1.0)


def coat_trapped_equilibrium(ops, alpha_coat, alpha_base, n):
    """Of the light trapped between one rough coat (index ``n``) and its base after a few round
    trips, the share that crosses the coat per round trip (the ``coat_trapped_equilibrium``
    table): the same for every view."""
    return ops.clamp(ops.lut("coat_trapped_equilibrium", luts.alpha_to_coord(ops, alpha_coat),
                             luts.alpha_to_coord(ops, alpha_base), luts.tir_eta_to_coord(ops, 1.0 / n)), 0.0, 1.0)


def fgd_conductor(ops, mu, alpha, eta: RGB, k: RGB) -> RGB:
    """FGD of a conductor of relative complex index eta + i k, per channel."""
    return RGB(*(fgd_quadrature(ops, mu, alpha, lambda c, e=e, kk=kk: fresnel_conductor(ops, c, e, kk))
                 for e, kk in zip(eta, k)))


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


def fresnel_average(ops, fresnel):
    """The hemispherical average 2 integral of F(mu) mu d mu of a Fresnel curve ``fresnel(cos)``,
    exact for its piecewise-linear interpolant over the nodes of the FGD quadrature (so the
    samples are those ``fgd_quadrature`` takes, shared in a traced shader)."""
    total = 0.0
    for c, w in zip(luts.FRESNEL_NODES, HEMI_WEIGHTS):
        total = total + w * fresnel(c)
    return ops.clamp(total, 0.0, 1.0)


def conductor_scattered(ops, mu, alpha, eta: RGB, k: RGB, single: RGB, f_avg: RGB | None = None) -> RGB:
    """What a rough conductor reflects after scattering more than once on its microsurface, per
    channel, from its single-scattering FGD ``single``: single F_avg (1 - E) / E, E = GD the albedo
    with F = 1 and F_avg the hemispherical average of the Fresnel factor (Turquin 2019's
    compensation, Eq. 13 integrated over the outgoing directions, with Kulla and Conty 2017's
    F_avg for his F0: the light scattered again meets facets at every angle). A perfect mirror
    then reflects everything at any roughness. Single scattering loses 12 % at alpha 0.3 and 32 %
    at alpha 0.5 at normal incidence; against the random walk on the microsurface (Heitz et al.
    2016) gold of alpha 0.3 at 60 degrees is then within 0.3 % in red and green and 2.2 % short in
    blue (with F0, 3.1 %). The light leaves broad, and under a coat the models send it up as a Lambertian
    base's (``diffuse_transport.DiffuseUp``). ``f_avg``: F_avg per channel where the Fresnel curve is
    not the bare conductor's (under a thin film, ``models.film``)."""
    e = gd(ops, mu, alpha)
    lost = ops.max(1.0 - e, 0.0) / ops.max(e, 1e-4)  # GD <= 1; its table may exceed 1 in the last digit
    # With single = F E (F <= 1 a mean Fresnel factor) the total is F E + F F_avg (1 - E) <= 1; but
    # FGD and GD come from two tables, and for a mirror-like metal (F = 1) FGD may exceed GD in
    # their last digits: never more than what single scattering leaves
    if f_avg is None:
        f_avg = RGB(*(fresnel_average(ops, lambda c, ee=ee, kk=kk: fresnel_conductor(ops, c, ee, kk))
                      for ee, kk in zip(eta, k)))
    return RGB(*(ops.min(s * fa * lost, ops.max(1.0 - s, 0.0)) for s, fa in zip(single, f_avg)))


def tir_fraction(ops, sx, sy, n_inside, alpha):
    """Belcour 2018's TIR term: the fraction of an upward lobe of roughness ``alpha`` in a medium
    of index ``n_inside``, whose mean direction has tangential part (sx, sy), that lies inside the
    escape cone toward vacuum (sin < 1 / n_inside). Exactly 1 for a smooth lobe refracted in from
    outside and for n_inside <= 1."""
    u = ops.min(ops.sqrt(sx * sx + sy * sy) * n_inside, 1.0)
    eta = 1.0 / n_inside
    return ops.lut("tir", u, luts.alpha_to_coord(ops, alpha), luts.tir_eta_to_coord(ops, eta))
