"""Adding-doubling of lobe statistics (energy, mean, spread) through a stack of rough interfaces.

The loop is Belcour 2018's ``computeAddingDoubling`` as published in Weier & Belcour 2020 Listing 3 (which
restates it with per-axis variances) and reviewed in Randrianandrasana et al. 2021 Eqs. (7)-(12); the spread type
(scalar, per-axis, 2x2 covariance) selects Belcour 2018, Weier & Belcour 2020 or Yamaguchi et al.
2019 (see ``variance.py``). Written once over the abstract ops: Python control flow depends only
on the stack's structure (number of coats, which ones absorb, the base kind).

Per interface, with cti the cosine of the mean direction above it and n12 = n_below / n_above:

* energies: R12 = FGD(cti, alpha, n12) (exact Fresnel + a pre-integrated rough correction, see
  ``fgd.py``), T12 = 1 - R12. From below, along the refracted mean direction, R21 is the
  interface's whole reflectance seen from that side (the energy-conserving interface of Heitz et
  al. 2016, tabulated: ``fgd_dielectric(..., multiple=True)``), T21 = 1 - R21: from the denser
  side facets tilted past the critical angle reflect totally and send light on to other facets, so a rough coat traps
  more light than Belcour 2018's symmetric R21 = R12 lets it (alpha 0.2 at 60 degrees: 0.67 of the
  light going up escapes by the microsurface walk, 0.92 by R21 = R12). The symmetric energies
  still weight the spreads (``adding_doubling``). The TIR correction of Belcour 2018
  (Randrianandrasana et al. 2021 after Eq. 10) moves the part of an upward lobe that falls outside
  the escape cone into the upward reflectance; the lobe's spread there is the accumulated
  transmitted spread with each refraction's deviation taken at its own incidence (a facet tilt d
  moves the refracted direction's tangential part by d |ctt - cti / n12|, Walter et al. 2007
  Eq. 40 differentiated; Belcour's fake-refraction scale is its value at normal incidence);
* spreads: s_r = f(alpha) for reflection, s_t12 = f(alpha |n12 - 1| / (2 n12)) and
  s_t21 = f(alpha |n12 - 1| / 2) for transmission (Belcour 2018's fake-refraction scale at normal
  incidence: a facet tilt d deviates a refracted ray by d |1 - n1/n2|, a reflected one by 2d),
  Jacobians j12 = n12 ctt / cti (Listing 3, lines 29-37);
* the adding equations of Listing 3 lines 46-76 (energies: Randrianandrasana et al. 2021 Eqs. 1-2 and 10; spreads:
  Randrianandrasana et al. 2021 Eq. 11), one output lobe per interface with energy m_R0i (the light that reached the
  interface and came back out, all orders), in which the round trips after the first count the light
  the stack above reflected back as trapped: it comes up again less easily than the first time
  (``_adding_energies``, the table ``dielectric_trapped_escape``). For a conductor under coats
  the round trips come from tables of random walks instead: the share of the base's light that
  crosses the coats on its first way up, for the view, and the share per later round trip, which
  no longer depends on it (``_round_trips``);
* a coat interior, Belcour 2018's medium operator along the refracted mean direction (path
  h = d / cos): T = (1 + sigma_s h) exp(-(sigma_a + sigma_s) h), the unscattered light plus the
  light scattered once, all of it forward; R = 0; the scattered light widens the transmitted
  spreads by Belcour 2018 Eq. 21's variance of the HG asymmetry g (``hg.belcour_variance_of_g``).
  With sigma_s = 0 this is Beer-Lambert. In the adding equations a component with R = 0 reduces to
  T0i *= T, Ti0 *= T, Ri0 *= T^2, s_t0i += s_g, s_ti0 += s_g, s_ri0 += 2 s_g. Light scattered more
  than once, and back-scattered light, is lost (the energy loss of Belcour's model in thick media,
  Randrianandrasana et al. 2021 Fig. 2; tm6 keeps it).
* the base by its kind's response (``lamella.core.layers``): a GGX reflection lobe for a
  conductor or a dielectric substrate, and for a conductor a diffuse lobe with what its
  microsurface scatters more than once, sent up through the coats as a Lambertian base's light
  (``fgd.conductor_scattered``, ``diffuse_transport``); the energy crossing a dielectric base leaves as one GGX
  transmission lobe with the accumulated transmitted statistics (Belcour 2018's T paths; energy as
  Randrianandrasana et al. 2021 Eq. 25); a Lambertian base adds one diffuse lobe whose energy comes from the adding of
  hemispherical energies (``diffuse_transport.py``).
"""
from __future__ import annotations

from dataclasses import dataclass

from . import film
from .diffuse_transport import GAUSS_01, SCATTERED_POINTS, DiffuseUp
from .fgd import (coat_first_escape, coat_trapped_equilibrium, fgd_dielectric, smooth_weight, tir_fraction,
                  trapped_escape)
from .ggx import alpha_of_projected_width
from .hg import belcour_variance_of_g
from .rgb import RGB
from .roughness import MAPPINGS, BelcourMapping
from .types import COS_FLOOR, Lobe, layer_normal, layer_params
from .variance import AxisVariance, CovarianceVariance, ScalarVariance, rms_alpha


JACOBIANS = ("variance", "roughness")
REFRACTION_SPREADS = ("normal", "direction down", "across down")


@dataclass(frozen=True)
class Variant:
    """One variant of the statistical model (a registered model family), or a study of one
    (``models.variant``). The published variants keep the defaults of the refinements below;
    ``yamaguchi_refined`` (what ``auto`` runs on stacks of interfaces) sets them all, each one
    measured necessary in ``bench/interface_variants.md``:

    ``jacobians``: "variance" scales a spread by each refraction's Jacobian j = n2 ct / (n1 ci)
    as Belcour 2018 does (Listing 3); "roughness" scales the roughness by j, the variance by
    j ** ``mapping.exponent`` (to first order a refraction scales a lobe's angular width, and so
    the roughness of the GGX lobe of that width, by j).
    ``refraction_spread``: "normal" gives a facet tilt's deviation of the ray refracted down its
    value at normal incidence (Belcour 2018's fake refraction, |1 - n1/n2| against reflection's
    2); "direction down" its value at the mean direction, d |ct - ci n1/n2| / ct in units of a GGX
    lobe of the lower medium (Walter et al. 2007 Eq. 40 differentiated; the same at normal
    incidence); "across down" that value across the plane of incidence only, the normal-incidence
    value along it: the lobe widens across the plane and not along it, where the interfaces'
    transmission and the horizon cut it (the lobe-floor fits: their across / along roughness
    ratio is 2-3 at 60-75 degrees), over isotropic stacks; over stacks with an anisotropic
    interface "normal" (there the lobes' axes would turn with the view's azimuth against the
    interfaces', and a staged shader's table would need the azimuth; measured in
    ``bench/interface_variants.md``). The light going up keeps Belcour's value.
    ``saturation``: k > 0 takes a lobe below the top interface out of the stack by its projected
    width, 2 alpha sqrt(c^2 + k alpha^2) for a GGX lobe at view cosine c instead of the first
    order's 2 alpha c (``_saturated``): a broad lobe leaves narrower toward grazing than the
    Jacobian's 1 / c makes it."""

    name: str
    spread: type  # a class of variance.py
    mapping: object  # a roughness.Mapping
    tir: bool = True
    jacobians: str = "variance"
    refraction_spread: str = "normal"
    saturation: float = 0.0

    def __post_init__(self):
        if self.jacobians not in JACOBIANS:
            raise ValueError(f"jacobians is one of {JACOBIANS}, got {self.jacobians!r}")
        if self.refraction_spread not in REFRACTION_SPREADS:
            raise ValueError(f"refraction_spread is one of {REFRACTION_SPREADS}, got {self.refraction_spread!r}")
        if not self.saturation >= 0.0:
            raise ValueError(f"saturation is >= 0, got {self.saturation!r}")

    def run(self, ops, stack, wi) -> list[Lobe]:
        return adding_doubling(ops, stack, wi, self)


# The published variants (the model registry holds them by these names)
BELCOUR2018 = Variant("belcour2018", ScalarVariance, MAPPINGS["belcour"])
WEIER2020 = Variant("weier2020", AxisVariance, MAPPINGS["weier"])
YAMAGUCHI2019 = Variant("yamaguchi2019", CovarianceVariance, MAPPINGS["belcour"])
# Yamaguchi et al. 2019 with the refinements, the mapping's exponent 1.18 (spreads add closer to
# their root sum of squares than with Belcour's 1.1): measured on the suite and the hold-out
# stacks (``bench/interface_variants.md``), every (case, angle) within 0.02 of yamaguchi2019's
# error or below it; at 1.16 the suite's mean is higher, at 1.20 one pair rises by more
YAMAGUCHI_REFINED = Variant("yamaguchi_refined", CovarianceVariance, BelcourMapping(1.18), jacobians="roughness",
                            refraction_spread="across down", saturation=0.5)


@dataclass(frozen=True)
class _Added:
    """Energies of the part of the stack already added, RGB (Weier & Belcour 2020 Listing 3, lines
    10-13): reflected from above and below, transmitted downward and upward; and K, how easily
    the light this part reflects back down comes up through it again, relative to Ti0 (see
    ``_adding_energies``)."""

    R0i: RGB
    T0i: RGB
    Ri0: RGB
    Ti0: RGB
    K: RGB

    def through(self, t: RGB) -> "_Added":
        """After a non-scattering-back interior of one-way transmittance ``t`` below."""
        return _Added(self.R0i, self.T0i * t, self.Ri0 * t * t, self.Ti0 * t, self.K)


def adding_doubling(ops, stack, wi, variant: Variant, unscattered: bool = False) -> list[Lobe]:
    """Lobes (one per reflecting interface, top to bottom, then a transmission or diffuse lobe if
    the base has one) for the incident direction ``wi = (x, y, z)`` (backend values, unit vector
    in the upper hemisphere).

    ``unscattered``: the light no medium has scattered only, each scattering interior taken as
    extinction (sigma_a + sigma_s along the mean path and along the trapped light's paths), what
    ``transfer_matrix`` leaves to this model when it carries the scattered light itself. (A
    Lambertian base's light goes up diffusely either way, scattered by the media on its way.)

    Two sets of energies are added: the interfaces' own (reflectance from below as seen from below,
    ``_dielectric_interface``), which give every lobe's weight, and Belcour 2018's symmetric ones
    (R21 = R12), which weight the spreads. Weighting the spreads by the first counts every extra
    round trip that total internal reflection on the microfacets adds as a full bounce of spread,
    and the lobes come out too broad (measured against the energy-conserving references:
    rough_coat_over_mirror at normal incidence 0.30 relative L1 against 0.14)."""
    Spread, mapping = variant.spread, variant.mapping
    coats, base = layer_params(ops, stack)
    base_kind = stack.base.kind
    # the coats above the base for light it sends up diffusely (a Lambertian base; what a rough
    # conductor scatters more than once); nothing is computed unless the base uses it
    diffuse_up = DiffuseUp()

    wx, wy, wz = wi
    cti = ops.clamp(wz, 0.0, 1.0)
    c0 = cti  # the view's cosine above the stack
    sx, sy = wx, wy  # tangential part of the mean direction in the current medium
    n_above = 1.0

    # Statistics of the part of the stack already added (Weier & Belcour 2020 Listing 3, lines 10-13)
    empty = _Added(RGB.splat(0.0), RGB.splat(1.0), RGB.splat(0.0), RGB.splat(1.0), RGB.splat(1.0))
    added, weights = empty, empty
    # s_r0i, s_t0i, s_ri0, s_ti0, and the transmitted spread that decides escape (``_add_interface``)
    spreads = (Spread.zero(),) * 5
    j0i, ji0 = 1.0, 1.0
    # what the absorbing interiors above let through of the light trapped under them, on its way
    # back down (``_trapped_round_trip``); along the mean path for scattering interiors
    A0i = RGB.splat(1.0)

    # for the base's round trips (``_round_trips``): each interface's slope variance and refraction,
    # and what the interiors let through along the mean path, one way
    refractions = []
    interiors = RGB.splat(1.0)

    lobes: list[Lobe] = []
    for index, p in enumerate(coats):
        ops.set_scope(f"coat{index}")
        n12 = p["ior"] / n_above
        refractions.append((rms_alpha(ops, p["ax"], p["ay"]), n12))
        energies, kappa, ctt, tsx, tsy, j12, j21, s_r12, s_t12, s_t21, s_e12 = _dielectric_interface(
            ops, variant, p, sx, sy, cti, n_above, n12, stack.isotropic)
        added, weights, spreads, lobe = _add_interface(
            ops, variant, mapping, index, sx, sy, n_above, energies, kappa, j12, s_r12, s_t12, s_t21, s_e12,
            added, weights, spreads, j0i, ji0, A0i, c0=c0, c_in=cti)
        lobe.normal = layer_normal(stack, index)
        lobes.append(lobe)
        j0i, ji0 = j0i * j12, ji0 * j21
        cti, sx, sy = ctt, tsx, tsy
        n_above = p["ior"]
        diffuse_up.add_interface(ops, n12)
        # The coat's interior (Belcour 2018's medium operator) along the refracted mean direction
        if "thickness" in p:
            path = p["thickness"] / ops.max(cti, COS_FLOOR)
            sig_a = p.get("sigma_a", RGB.splat(0.0))
            scatters = "sigma_s" in p and not unscattered
            if "sigma_s" in p and unscattered:
                sig_a = sig_a + p["sigma_s"]
            if scatters:
                sig_t = sig_a + p["sigma_s"]
                t = RGB(*((1.0 + ss * path) * ops.exp(-st * path) for st, ss in zip(sig_t, p["sigma_s"])))
                s_g = Spread.isotropic(belcour_variance_of_g(ops, p["g"]))
                s_r0i, s_t0i, s_ri0, s_ti0, s_e0i = spreads
                spreads = (s_r0i, s_t0i + s_g, s_ri0 + s_g.scale(2.0), s_ti0 + s_g, s_e0i + s_g)
            else:
                t = sig_a.map(lambda s: ops.exp(-s * path))
            added, weights = added.through(t), weights.through(t)
            interiors = interiors * t
            if scatters:
                A0i = A0i * t
            else:  # the light trapped under the coats crosses it along its own, longer paths
                A0i = A0i * _trapped_round_trip(ops, sig_a, p["thickness"], p["ior"], path)
            diffuse_up.add_medium(ops, p)

    ops.set_scope("base")
    index = len(coats)
    if not base_kind.interface:
        # A Lambertian base: everything that reaches it becomes diffuse light going up
        albedo = base_kind.response(ops, base, cti, 0.0, n_above).albedo
        lobes.append(Lobe(diffuse_up.base_energy(ops, added.T0i, albedo), 0.0, 0.0, 0.0, "diffuse", normal="base"))
        ops.set_scope("lobes")
        return lobes

    cos_r, sin_r = ops.cos(base["rotation"]), ops.sin(base["rotation"])
    fetch_mu, fetch_alpha = Spread.fgd_fetch(ops, sx, sy, cti, base["ax"], base["ay"], cos_r, sin_r)
    resp = base_kind.response(ops, base, fetch_mu, fetch_alpha, n_above)
    s_r12 = Spread.from_interface(ops, mapping, base["ax"], base["ay"], cos_r, sin_r)
    if resp.transmittance is None:
        interface = (resp.reflectance, RGB.splat(0.0), resp.reflectance, RGB.splat(0.0))
        kappa = 1.0
        j12 = 1.0
        s_t12 = s_t21 = s_e12 = Spread.zero()
    else:
        # a transmissive substrate: the same interface statistics as a coat's top interface
        interface, kappa, ctt, tsx, tsy, j12, j21, s_r12, s_t12, s_t21, s_e12 = _dielectric_interface(
            ops, variant, base, sx, sy, cti, n_above, resp.eta, stack.isotropic)
    reach = added.T0i
    # under coats, the round trips of a conductor's light have tables of their own
    trips = _round_trips(ops, refractions, n_above, base, c0, cti, added, interiors, A0i) \
        if resp.transmittance is None and coats else None
    added, weights, spreads, lobe = _add_interface(
        ops, variant, mapping, index, sx, sy, n_above, interface, kappa, j12, s_r12, s_t12, s_t21, s_e12,
        added, weights, spreads, j0i, ji0, A0i, None if resp.scattered is None else resp.reflectance + resp.scattered,
        c0=c0, c_in=cti, trips=trips)
    lobe.normal = "base"
    lobes.append(lobe)
    if resp.scattered is not None:
        # what the base's microsurface scatters more than once leaves it broad: up through the
        # coats as a Lambertian base's light, what they return reflected again
        lobes.append(Lobe(diffuse_up.emitted(ops, reach * resp.scattered, resp.reflectance + resp.scattered,
                                            SCATTERED_POINTS),
                          0.0, 0.0, 0.0, "diffuse", normal="base"))
    if resp.transmittance is not None:
        # What crossed every interface leaves downward: one GGX transmission lobe with the
        # accumulated transmitted spread, refracting as a single interface from vacuum into the
        # substrate (parallel interfaces: n sin(theta) is conserved through the stack).
        tax, tay, trot = spreads[1].to_lobe(ops, mapping)
        lobes.append(Lobe(added.T0i, tax, tay, trot, "transmission", base["ior"], normal="base"))
    ops.set_scope("lobes")
    return lobes


def _dielectric_interface(ops, variant: Variant, p, sx, sy, cti, n_above, n12, isotropic: bool):
    """Energies (R12, T12 from above; R21, T21 from below; RGB: a thin film on the interface colours
    them, ``film.dielectric_energies``), the relative ease kappa with which the
    light the interface reflects from below comes through it again (``_adding_energies``),
    refracted mean direction, Jacobians and spreads (reflected; transmitted down and up;
    transmitted down as it decides escape) of a rough dielectric interface from index n_above onto
    n_above * n12 (Weier & Belcour 2020 Listing 3, lines 20-37), with ``variant``'s refinements
    (``isotropic``: the stack's interfaces all are: ``ax`` equals ``ay``)."""
    Spread, mapping = variant.spread, variant.mapping
    cos_r, sin_r = ops.cos(p["rotation"]), ops.sin(p["rotation"])
    ax, ay = p["ax"], p["ay"]
    fetch_mu, fetch_alpha = Spread.fgd_fetch(ops, sx, sy, cti, ax, ay, cos_r, sin_r)
    s_r12 = Spread.from_interface(ops, mapping, ax, ay, cos_r, sin_r)
    # Snell on the tangential component; beyond total internal reflection nothing is transmitted
    # and the mean direction is only carried along (finite) for the lanes whose energy is already
    # zero. ctt^2 = (n12^2 - 1 + cti^2) / n12^2: exact for index-matched interfaces at grazing
    # (the form 1 - |s_t|^2 cancels catastrophically there; see fresnel_dielectric)
    tsx, tsy = sx / n12, sy / n12
    cos2_num = n12 * n12 - 1.0 + cti * cti
    transmits = cos2_num > 0.0
    ctt = ops.sqrt(ops.max(cos2_num, 0.0) / (n12 * n12))
    R12s = ops.select(transmits, fgd_dielectric(ops, fetch_mu, fetch_alpha, n12), 1.0)
    # Seen from below along the refracted mean direction the same microsurface reflects more:
    # facets tilted past the critical angle reflect totally (n12 > 1), and light one facet sends
    # on meets others (Heitz et al. 2016). Belcour 2018 takes R21 = R12.
    in_mu, in_alpha = Spread.fgd_fetch(ops, tsx, tsy, ctt, ax, ay, cos_r, sin_r)
    R21s = ops.select(transmits, fgd_dielectric(ops, in_mu, in_alpha, 1.0 / n12, multiple=True), 1.0)
    # What it reflects from below has mostly been turned past the critical angle and comes through
    # again less easily than on its first arrival (1 under TIR of the mean: nothing comes up).
    kappa = ops.select(transmits, ops.clamp(trapped_escape(ops, in_mu, in_alpha, 1.0 / n12)
                                            / ops.max(1.0 - R21s, 1e-6), 0.0, 1.0), 1.0)
    up = 0.5 * ops.abs(n12 - 1.0)
    along = up / n12
    if variant.refraction_spread == "normal" or (variant.refraction_spread == "across down" and not isotropic):
        s_t12 = Spread.from_interface(ops, mapping, ax, ay, cos_r, sin_r, scale=along)
    else:
        at_mean = 0.5 * ops.abs(ctt - cti / n12) / ops.max(ctt, COS_FLOOR)
        if variant.refraction_spread == "direction down":
            s_t12 = Spread.from_interface(ops, mapping, ax, ay, cos_r, sin_r, scale=at_mean)
        else:
            s_t12 = _across(ops, Spread, mapping, ax, sx, sy, along, at_mean)
    s_t21 = Spread.from_interface(ops, mapping, ax, ay, cos_r, sin_r, scale=up)
    # the spread that decides escape through the interfaces above: a facet tilt d deviates the
    # refracted direction's tangential part by d |ctt - cti / n12| (Walter et al. 2007 Eq. 40
    # differentiated at the mean normal; d |1 - 1 / n12| at normal incidence, as s_t12)
    s_esc = Spread.from_interface(ops, mapping, ax, ay, cos_r, sin_r, scale=0.5 * ops.abs(ctt - cti / n12))
    # Under TIR of the mean direction nothing reaches the layers below, so their spreads are
    # irrelevant: zero Jacobians restart the telescoping product n_i ct_i / ct_0 there (with 1 it
    # would gain a factor up to n / COS_FLOOR per TIR and overflow float32).
    j12 = n12 * ctt / ops.max(cti, COS_FLOOR)
    j21 = ops.max(cti, COS_FLOOR) / (n12 * ops.max(ctt, COS_FLOOR))
    if variant.jacobians == "roughness":
        j12, j21 = ops.pow(j12, mapping.exponent), ops.pow(j21, mapping.exponent)
    j12 = ops.select(transmits, j12, 0.0)
    j21 = ops.select(transmits, j21, 0.0)
    R12, R21 = film.dielectric_energies(ops, p, fetch_mu, fetch_alpha, n_above, p["ior"], R12s, R21s, transmits)
    return (R12, 1.0 - R12, R21, 1.0 - R21), kappa, ctt, tsx, tsy, j12, j21, s_r12, s_t12, s_t21, s_esc


def _across(ops, Spread, mapping, a, sx, sy, along, across):
    """The spread of an isotropic interface's (roughness ``a``) transmission with deviation scale
    ``along`` in the plane of incidence (the mean direction's tangential part (sx, sy)) and the
    larger ``across`` across it: the spread at ``along`` plus, along the unit vector across the
    plane, the variance the roughness gains from ``along`` to ``across``. At normal incidence,
    where the plane is undefined, the two scales are equal and nothing is added."""
    s2 = sx * sx + sy * sy
    inv = 1.0 / ops.sqrt(ops.max(s2, 1e-24))
    extra = ops.max(mapping.to_variance(ops, a * across) - mapping.to_variance(ops, a * along), 0.0)
    base = Spread.from_interface(ops, mapping, a, a, 1.0, 0.0, scale=along)
    return base.plus_along(ops, (0.0 - sy) * inv, sx * inv, ops.select(s2 > 1e-12, extra, 0.0))


def _add_interface(ops, variant, mapping, index, sx, sy, n_above, interface, kappa, j12, s_r12, s_t12, s_t21,
                   s_e12, added: _Added, weights: _Added, spreads, j0i, ji0, A0i, again: RGB | None = None,
                   c0=1.0, c_in=1.0, trips: "_RoundTrips | None" = None):
    """Add one interface (energies R12, T12 from above, R21, T21 from below, ``kappa`` of
    ``_dielectric_interface``) below the stack added so far: the energies ``added`` with the
    interface's own, the spread weights ``weights`` with Belcour 2018's symmetric R21 = R12,
    T21 = T12 and every round trip alike. ``again``: what the interface reflects of the light that
    comes back to it, where that is more than what goes into its lobe (``_adding_energies``).
    ``c0``, ``c_in``: the cosines of the view above the stack and of the mean direction above the
    interface (``Variant.saturation``). ``trips``: the round trips of the interface's light under
    the stack above, where they are known better than the adding equations' (``_RoundTrips``; the
    lobe's energy only). Returns both, the new spreads and the interface's lobe."""
    R12, T12 = interface[0], interface[1]
    s_r0i, s_t0i, s_ri0, s_ti0, s_e0i = spreads
    s_r21 = s_r12
    # Belcour 2018's TIR correction (Randrianandrasana et al. 2021, after Eq. 10): of the light this interface
    # sends up, the part outside the escape cone is reflected back down by the stack above.
    tir = None
    if variant.tir and index > 0:
        tir = tir_fraction(ops, sx, sy, n_above, mapping.to_roughness(ops, (s_e0i + s_r12).mean()))
    e, m_R0i, _, _ = _adding_energies(ops, interface, added, tir, A0i, RGB.splat(kappa), again, trips)
    w, w_R0i, w_Ri0, w_Rr = _adding_energies(ops, (R12, T12, R12, T12), weights, tir, A0i, RGB.splat(1.0))

    # Scalar forms (lines 59-66)
    r0i, e_r0i, e_ri0 = weights.R0i.average(), w.R0i.average(), w.Ri0.average()
    m_r0i, m_ri0, m_rr, r21 = w_R0i.average(), w_Ri0.average(), w_Rr.average(), R12.average()

    # Adding on spreads (lines 68-76)
    bounce = (s_r12 + s_ri0).scale(m_rr)
    inner = s_t0i + s_r12 + bounce
    lobe_spread = s_ti0 + inner.scale(j0i)
    new_s_r0i = (s_r0i.scale(r0i) + lobe_spread.scale(m_r0i)).divide_safe(ops, e_r0i)
    new_s_t0i = s_t0i.scale(j12) + s_t12 + (s_r12 + s_ri0).scale(j12 * m_rr)
    new_s_ri0 = (s_r21.scale(r21)
                 + (s_t12 + (s_t21 + s_ri0 + bounce).scale(j12)).scale(m_ri0)).divide_safe(ops, e_ri0)
    new_s_ti0 = s_ti0 + s_t21.scale(ji0) + (s_r12 + s_ri0).scale(ji0 * m_rr)
    new_s_e0i = s_e0i.scale(j12) + s_e12 + (s_r12 + s_ri0).scale(j12 * m_rr)
    new_spreads = tuple(x.bounded(ops) for x in (new_s_r0i, new_s_t0i, new_s_ri0, new_s_ti0, new_s_e0i))
    lax, lay, lrot = lobe_spread.bounded(ops).to_lobe(ops, mapping)
    if variant.saturation > 0.0 and index > 0:
        lax, lay = (_saturated(ops, a, c0, c_in, n_above, variant.saturation) for a in (lax, lay))
    return e, w, new_spreads, Lobe(m_R0i, lax, lay, lrot)


def _trapped_round_trip(ops, sig_a, d, n, path):
    """What an absorbing interior (index ``n``, thickness ``d``, absorption ``sig_a``) lets through
    of the light trapped under the coats, for the way back down, given that the upward
    transmittance already holds one crossing along the mean path ``path``.

    Light the stack above turns back (the part of a lobe outside the escape cone, Belcour 2018's
    TIR correction, and what the stack above reflects again) travels outside the escape cone,
    n sin(theta) > 1, both up and down: longer paths than the mean direction's, which lies inside
    it. Its round trip, cosine-weighted over those directions (uniform in u = sin^2 theta on
    (1 / n^2, 1), two Gauss nodes as ``diffuse_transport``), is sum w exp(-sig_a 2 d / mu); over the
    mean path's crossing that is sum w exp(-sig_a (2 d / mu - path)), every factor at most 1 (with
    sig_a = 0 exactly 1). Beer-Lambert along the mean path both ways let the trapped light out too
    easily under absorbing coats over rough bases: measured by the keep rule, suite mean 0.1850 ->
    0.1846, hold-out 0.2349 -> 0.2344, absorbing_rough_coat at normal incidence 0.103 -> 0.077
    (its albedo too bright, ``bench/accuracy.md``), tinted_varnish 0.062 -> 0.056, holdout_11 0.121
    -> 0.113; four nodes instead of two changed the suite mean by 1e-5."""
    u_c = ops.min(1.0 / (n * n), 1.0)
    nodes, weights = GAUSS_01[2]
    out = RGB.splat(0.0)
    for x, w in zip(nodes, weights):
        mu = ops.max(ops.sqrt(ops.max(1.0 - (u_c + (1.0 - u_c) * x), 0.0)), COS_FLOOR)
        k = ops.max(2.0 * d / mu - path, 0.0)
        out = out + sig_a.map(lambda s: ops.exp(-s * k)) * w
    return out


def _saturated(ops, a, c, c_in, n, k):
    """The roughness of the GGX lobe as wide, projected on the surface, as the model's lobe
    leaving at view cosine ``c`` from a medium of index ``n`` where its mean direction's cosine is
    ``c_in``, of roughness ``a``. The model's roughness is first order: the lobe inside, of
    roughness a_in = a c / (n c_in), scaled by the refraction's Jacobian n c_in / c. A GGX lobe's
    projected width is 2 alpha sqrt(c^2 + k alpha^2) (2 alpha c to first order), and the refraction
    scales the inner lobe's by n: alpha^2 (c^2 + k alpha^2) = b, b = n^2 a_in^2 (c_in^2 + k a_in^2),
    alpha^2 = 2 b / (sqrt(c^4 + 4 k b) + c^2) (``ggx.alpha_of_projected_width``). Never wider than
    ``a`` (for n >= 1; the minimum holds it under rounding), narrower toward grazing, the same for
    a narrow lobe at normal incidence.
    (Where the model's roughness is capped at 1, within a few degrees of the horizon, a_in
    underestimates the inner lobe and the lobe narrows again; its weight vanishes there.)"""
    a_in = a * c / ops.max(n * c_in, COS_FLOOR)
    b = n * n * a_in * a_in * (c_in * c_in + k * a_in * a_in)
    return ops.min(alpha_of_projected_width(ops, b, c, k), a)


def _at_least(ops, d: RGB, bound: RGB) -> RGB:
    """The denominator ``d`` of an adding equation, never below its physical lower ``bound`` (nor
    below 1e-7)."""
    return RGB(*(ops.max(ops.max(x, b), 1e-7) for x, b in zip(d, bound)))


@dataclass(frozen=True)
class _RoundTrips:
    """What becomes of the light an interface sends up under the stack above, per unit it sends:
    the part that leaves the top on its first way up (``first``) and the part that comes back down
    to the interface (``back``); then on every later round trip, per unit that came back, the part
    that leaves (``later``) and the part that comes back again (``returns``). ``weight``: how much
    of them replaces the adding equations' own, along the mean direction (``_adding_energies``)."""

    first: RGB
    back: RGB
    later: RGB
    returns: RGB
    weight: object


def _round_trips(ops, refractions, n, base, c0, c_in, added: _Added, interiors: RGB, A0i) -> _RoundTrips:
    """The round trips of the light a conductor base (parameters ``base``) reflects under the
    coats, from the view of cosine ``c0``, from two tables of random walks through one rough coat
    over a rough base (``fgd.coat_first_escape``, ``fgd.coat_trapped_equilibrium``).

    The first way up crosses the coat at a share F that depends on the view; after a few round
    trips the trapped light has forgotten the view and crosses at a share E of its own (coat
    alpha 0.3, index 1.5, over a mirror: F 0.85 at normal incidence and 0.28 at 75 degrees, E 0.28
    at every view). The adding equations along the mean direction (Belcour 2018's escape cone,
    ``kappa``) kept too much of it trapped at grazing views over rough bases, whose lobe sends
    much of the light toward the normal: a coat of alpha 0.3 over a conductor of alpha 0.3
    returned 0.76 of the walk's green light at 75 degrees.

    The coats are one coat of the index ``n`` above the base (the escape cone is the same:
    n sin(theta) is kept through parallel interfaces) and of the slope variance of every interface
    in proportion to how much it refracts, alpha^2 = sum alpha_i^2 min(((n_i - 1) / (n - 1))^2, 1)
    (n_i the interface's index ratio; an index-matched interface adds nothing, one coat is itself).
    An anisotropic interface counts by the isotropic roughness of its slope variance
    (``variance.rms_alpha``; the mean or geometric mean of the axes made the trapped light of stacks
    with one nearly smooth axis too dark at grazing views: rotated_90 at 75 degrees 0.336 -> 0.358
    and 0.378 relative L1, against 0.336 with it).
    What the stack transmits at the mean direction beyond that coat's transmittance there (other
    interfaces, a film) scales the shares: up = Ti0 / T(c_in); of the light the interiors let through
    along the mean path (``interiors``, a), what does not leave comes back down along the trapped
    light's own paths (``A0i``, ``_trapped_round_trip``): first = F up, back = (a - F up) A0i,
    later = E up, returns = (a - E up) A0i. up is at most a: the stack transmits no more than its
    interiors let through (the coat's own transmittance comes from an anisotropic fetch in ``Ti0``
    and from the isotropic roughness here, which may differ by a little). Where both the coats and the base are smooth, nothing is trapped past
    the escape cone and the adding equations are exact: the tables hand over to them as the
    roughness goes to 0 (``fgd.smooth_weight``)."""
    variance = 0.0
    for a, n12 in refractions:
        share = ops.min((n12 - 1.0) * (n12 - 1.0) / ops.max((n - 1.0) * (n - 1.0), 1e-12), 1.0)
        variance = variance + a * a * share
    a_coat, a_base = ops.sqrt(variance), rms_alpha(ops, base["ax"], base["ay"])
    first = coat_first_escape(ops, c0, a_coat, a_base, n)
    later = coat_trapped_equilibrium(ops, a_coat, a_base, n)
    bare = 1.0 - fgd_dielectric(ops, c_in, a_coat, 1.0 / n, multiple=True)
    up = RGB(*(ops.min(t / ops.max(bare, 1e-6), i) for t, i in zip(added.Ti0, interiors)))
    weight = 1.0 - smooth_weight(ops, ops.sqrt(variance + a_base * a_base))
    return _RoundTrips(up * first, (interiors - up * first) * A0i, up * later, (interiors - up * later) * A0i, weight)


def _adding_energies(ops, interface, added: _Added, tir, A0i, kappa: RGB, again: RGB | None = None,
                     trips: _RoundTrips | None = None):
    """The adding equations on energies (Listing 3 lines 46-57; Randrianandrasana et al. 2021
    Eqs. 1-2 and 10) for an interface (R12, T12, R21, T21) below ``added``: the new statistics, the
    interface's lobe energy m_R0i, and m_Ri0, m_Rr. ``tir``: the fraction of the light the
    interface sends up that lies inside the escape cone (None: all of it). ``A0i``: what the
    absorbing interiors above let through of the light trapped under them on its way back down
    (``_trapped_round_trip``). ``kappa``: how easily
    what this interface reflects from below comes up through it again, relative to T21.
    ``again``: what the interface reflects of the light that comes back down to it (default R12;
    a rough conductor's lobe holds its single scattering, but every time the trapped light meets it
    again it also reflects what it scatters more than once: with R12 there, a coat of alpha 0.2
    over gold of alpha 0.2 at 60 degrees returned 12 % too little red light, 3 % with the whole).

    The lobe energy counts the first round trip apart from the later ones. The adding equations
    take every round trip between the interface and the stack above as the first (the geometric
    series T0i R12 Ti0 sum (Ri0 R12)^k). But what a rough stack above reflects back down has mostly
    been turned past its critical angle by facets reflecting totally: it comes up through the stack
    again K times as easily as the first time (K = ``added.K``, from the table
    ``dielectric_trapped_escape``), and is reflected again by the rest, Rt = Ri0 + Ti0 A0i (1 - K).
    So m_R0i = T0i R12 (Ti0 + Ri0 Ra K Ti0 / (1 - Rt Ra)), Ra = ``again``; K = 1 is the adding
    equation. For a coat of alpha 0.1 over smooth gold at 60 degrees a random walk through the two
    (light bouncing between them with the directions the microsurfaces give it) returns 0.645 of
    the green light; with every round trip's direction redrawn from the first one's 0.713, the
    adding equation 0.721, this form 0.687 (``tests/unit/test_trapped_light.py``).
    ``trips``: the round trips known otherwise (``_RoundTrips``), by their weight in place of those
    along the mean direction: m_R0i = T0i R12 (first + back Ra later / (1 - returns Ra))."""
    R12, T12, R21, T21 = interface
    R0i, T0i, Ri0, Ti0 = added.R0i, added.T0i, added.Ri0, added.Ti0

    # The TIR correction changes the stack-above statistics seen by *this* interface's lobe only;
    # the persisted statistics stay uncorrected so that the correction is not compounded at every
    # deeper interface (with compounding, inserting an index-matched coat changed the result).
    Ri0_seen, Ti0_seen, K = Ri0, Ti0, added.K
    if tir is not None:
        # the trapped light crosses the absorbing interiors above once more on its way back down
        # (Ti0 holds the way up along the mean path, A0i the rest of its round trip along its own,
        # longer paths: ``_trapped_round_trip``); the TIR reflection itself loses nothing
        turned = Ti0 * A0i * (1.0 - tir)
        Ri0_seen = Ri0 + turned
        Ti0_seen = Ti0 * tir
        # What the correction turns back is the part of the lobe's own spread outside the escape
        # cone, not light a microsurface has turned past the critical angle: it comes up again as
        # easily as the first time (a rough base below spreads it anew; under a smooth one the
        # lobe is narrow and little is turned back). With K for it as well, a coat of alpha 0.3
        # over gold of alpha 0.3 at 60 degrees returned 30 % too little green light, 22 % without.
        K = (Ri0 * K + turned + 1e-7) / (Ri0_seen + 1e-7)
    # 1 - Rt R12 >= (1 - R12) + R12 Tt, as Rt + Tt <= 1: rounding can break the bound when
    # the stack above reflects almost everything back down (from below at the critical angle) and
    # the lobe then carried more than the light that reached the interface (float32: 1.00001 of it).
    # (Bounding ``denom`` below as well put a kink into the energies that the node group's tables
    # over linked parameters could not follow.)
    Tt = Ti0_seen * K
    Rt = Ri0_seen + Ti0_seen * A0i * (1.0 - K)
    if trips is not None:
        w = trips.weight
        Ti0_seen = Ti0_seen + (trips.first - Ti0_seen) * w
        Ri0_seen = Ri0_seen + (trips.back - Ri0_seen) * w
        Tt = Tt + (trips.later - Tt) * w
        Rt = Rt + (trips.returns - Rt) * w
    Ra = R12 if again is None else again
    m_R0i = T0i * R12 * (Ti0_seen + Ri0_seen * Ra * Tt / _at_least(ops, 1.0 - Rt * Ra, (1.0 - Ra) + Ra * Tt))

    # Multiple scattering forms (Listing 3, lines 46-51)
    denom = (1.0 - Ri0 * R12).map(lambda d: ops.max(d, 1e-7))
    m_Ri0 = T21 * Ri0 * T12 / denom
    m_Rr = Ri0 * R12 / denom

    # Adding on energies (lines 53-57)
    # what the new stack reflects from below: the interface's own reflection and the light the
    # stack above sent back through it, each with its own ease of coming up again
    reflected = R21 + m_Ri0
    K_new = (R21 * kappa + m_Ri0 * added.K + 1e-7) / (reflected + 1e-7)
    new = _Added(R0i + m_R0i, T0i * T12 / denom, reflected, T21 * Ti0 / denom, K_new)
    return new, m_R0i, m_Ri0, m_Rr
