"""A thin film on a rough interface, as the models take it: the interface's energies with the
film's reflectance (``thin_film``: Belcour and Barla 2017, Airy summation with their spectral
antialiasing, in RGB) in place of the bare Fresnel factor.

A layer whose ``film_thickness`` is above 0 declares ``film_thickness`` (nm) and ``film_ior``
(``layers.film``); the film lies on its top interface. Then:

- from above, R12 is the FGD of the interface with the film's reflectance as its Fresnel curve
  (``fgd.fgd_quadrature`` sampled per colour channel): the facets of a rough interface see the film
  at their own angles, which mixes its colours as Belcour and Barla 2017 (Section 5) integrate
  them over the microfacet distribution; T12 = 1 - R12 (the film absorbs nothing);
- from below, where the interface's reflectance holds the light its facets reflect totally
  (``fgd.fgd_dielectric(multiple=True)``), which a film of real index cannot change, the film
  scales what crosses: T21 = T21_bare (1 - R12) / (1 - R12_bare), the film's transmittance
  relative to the bare interface's at the mean direction (exact for a smooth interface, whose
  transmittance is the same from both sides: a lossless stack of layers transmits alike both
  ways, Stokes relations);
- a conductor base under a film reflects the FGD of the filmed conductor curve, and what its
  microsurface scatters more than once takes the film's hemispherical average (``fgd``'s Kulla
  and Conty 2017 F_avg).

The diffuse light a Lambertian base sends up through the coats crosses their interfaces bare
(``diffuse_transport``): its hemispherical average of a film's colours is nearly grey.
"""
from __future__ import annotations

from .fgd import fgd_quadrature, fresnel_average
from .rgb import RGB
from .thin_film import film_reflectance_conductor, film_reflectance_dielectric

TINY = 1e-6  # a transmittance below this scales nothing (the interface reflects all of it)


def has_film(p) -> bool:
    """Whether the layer's params declare a film (``layers.film``: its thickness is above 0)."""
    return "film_thickness" in p


def _memo(curve):
    """``curve`` evaluated once per cosine (the quadrature asks each channel in turn)."""
    seen: dict = {}

    def at(c):
        key = c if isinstance(c, float) else id(c)
        if key not in seen:
            seen[key] = (c, tuple(curve(c)))
        return seen[key][1]

    return at


def dielectric_curve(ops, p, n_above, n_below):
    """Reflectance (RGB, as a tuple) of the filmed dielectric interface at cosine c, from absolute
    index ``n_above`` onto ``n_below``."""
    return _memo(lambda c: film_reflectance_dielectric(ops, c, n_above, p["film_ior"], p["film_thickness"], n_below))


def conductor_curve(ops, p, n_above):
    """Reflectance (RGB, as a tuple) of the filmed conductor of ``p`` (absolute eta, k) at cosine c
    under a medium of absolute index ``n_above``."""
    return _memo(lambda c: film_reflectance_conductor(ops, c, n_above, p["film_ior"], p["film_thickness"],
                                                      p["eta"], p["k"]))


def fgd(ops, mu, alpha, curve) -> RGB:
    """FGD per channel of an interface whose Fresnel curve is ``curve`` (an RGB per cosine)."""
    return RGB(*(fgd_quadrature(ops, mu, alpha, lambda c, ch=ch: curve(c)[ch]) for ch in range(3)))


def average(ops, curve) -> RGB:
    """The hemispherical average of ``curve`` per channel (``fgd.fresnel_average``)."""
    return RGB(*(fresnel_average(ops, lambda c, ch=ch: curve(c)[ch]) for ch in range(3)))


def dielectric_energies(ops, p, mu, alpha, n_above, n_below, r12_bare, r21_bare, transmits):
    """(R12, R21) of a rough dielectric interface, RGB: with the film of ``p`` when it has one
    (module docstring), else the bare ones splatted. ``mu``, ``alpha``: where the FGD is read;
    ``r12_bare``, ``r21_bare``: the bare interface's (already 1 under total internal reflection of
    the mean direction, ``transmits`` False)."""
    if not has_film(p):
        return RGB.splat(r12_bare), RGB.splat(r21_bare)
    r12 = fgd(ops, mu, alpha, dielectric_curve(ops, p, n_above, n_below))
    r12 = r12.map(lambda r: ops.select(transmits, r, 1.0))
    t_bare = 1.0 - r12_bare
    scale = r12.map(lambda r: ops.select(t_bare > TINY, (1.0 - r) / ops.max(t_bare, TINY), 1.0))
    r21 = scale.map(lambda s: ops.clamp(1.0 - (1.0 - r21_bare) * s, 0.0, 1.0))
    return r12, r21


__all__ = ["has_film", "dielectric_curve", "conductor_curve", "fgd", "average", "dielectric_energies"]
