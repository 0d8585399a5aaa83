"""Diffuse light between a base that sends light up diffusely and the coats above it: a Lambertian
base, and what a rough conductor's microsurface scatters more than once (not in the layered-model
papers; the classical adding of reflectances, e.g. van de Hulst 1980, with a scattering coat's
internal diffuse reflectance as in Kubelka-Munk-type layer models).

Light a diffuse base sends up is cosine-distributed over the hemisphere of the medium above it.
``DiffuseUp`` sums the stack above for that light direction by direction (each direction keeps
n sin(theta) through smooth interfaces, so it has its own exact Fresnel factors, total internal
reflection included, and its own path lengths d / cos in every absorbing interior): the
transmittance ``up`` of the whole stack above and its reflectance ``back`` (light going up that the
stack returns, by reflections and total internal reflection). The interface roughness is neglected
(it redistributes diffuse light but hardly changes its averages). A scattering interior is taken as
diffuse both ways: the Kubelka-Munk slab of the six-flux model (``homogeneous_medium``) over twice
the thickness, the mean path of cosine-distributed light, the same for every direction. The base
then sends out ``e A up / (1 - A back)`` (all orders of base-coat bounces) for the energy e that
reached it.
"""
from __future__ import annotations

from .fresnel import fresnel_dielectric
from .rgb import RGB

# Gauss-Legendre on [0, 1] by number of points (nodes, weights)
_GL_X = (0.1834346424956498, 0.5255324099163290, 0.7966664774136267, 0.9602898564975363)
_GL_W = (0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763)
GAUSS_01 = {
    2: ((0.2113248654051871, 0.7886751345948129), (0.5, 0.5)),
    4: ((0.0694318442029737, 0.3300094782075719, 0.6699905217924281, 0.9305681557970263),
        (0.1739274225687269, 0.3260725774312731, 0.3260725774312731, 0.1739274225687269)),
    8: (tuple(0.5 * (1.0 + s * x) for x in _GL_X for s in (-1.0, 1.0)),
        tuple(0.5 * w for w in _GL_W for _ in (-1.0, 1.0))),
}
# The directions of ``DiffuseUp``: cosine-weighted light is uniform in u = sin^2 of its angle in the
# base's medium; the nodes are used on the escape cone and on the rest of the hemisphere separately
# (the kink at the critical angle would otherwise fall between nodes). What a rough conductor
# scatters more than once is a small part of its light: two directions on each side of the
# critical angle keep its escape through up to eight absorbing coats within 5 % of eight (within
# 0.3 % of the stack's albedo) at a quarter of the shader's nodes for it.
SCATTERED_POINTS = 2


def scattering_interior(ops, p) -> tuple[RGB, RGB]:
    """Diffuse transmittance and reflectance of a scattering coat's interior, from its backend
    parameters ``p`` (``thickness``, ``sigma_a``, ``sigma_s``, ``g``)."""
    from .homogeneous_medium import slab

    sig_a = p.get("sigma_a", RGB.splat(0.0))
    kd = [slab(ops, sa, ss, p["g"], 2.0 * p["thickness"]) for sa, ss in zip(sig_a, p["sigma_s"])]
    return RGB(*(x[2] for x in kd)), RGB(*(x[1] for x in kd))


class DiffuseUp:
    """The stack above a diffuse base, for the light it sends up: ``up`` (the share that leaves
    through the top) and ``back`` (the share the stack returns to the base, by Fresnel reflection,
    total internal reflection and, for scattering interiors, back-scattering), per channel.

    Coats are recorded from the top down and summed at the base (``base_energy``) direction by
    direction: light leaving the base at a given angle keeps n sin(theta) through smooth
    interfaces, so each direction has its own Fresnel factors and path lengths in every absorbing
    interior, and the stack's response to it is the adding of its interfaces and interiors along
    it (all orders of reflection between them). The Lambertian base spreads what comes back over
    the hemisphere again, so only the cosine-weighted averages of ``up`` and ``back`` over the
    directions matter. Light inside the escape cone leaves along short paths and light beyond it,
    returned by total internal reflection, crossed the interiors along long ones; averaging the
    transmittance of each over the hemisphere first (2 E3 of the optical depth) makes the escaping
    light too dark under an absorbing coat (a coat of optical depth 0.56-1.1 over a diffuse base:
    0.100 against the walk's 0.123 in green). Interface roughness is neglected (it redistributes
    diffuse light but hardly changes its averages), and a scattering interior is taken as diffuse
    both ways (the Kubelka-Munk slab of ``interior``), the same for every direction."""

    def __init__(self):
        self._steps: list[tuple] = []
        self._n = 1.0  # index of the medium below the coats added so far

    def add_interface(self, ops, eta):
        """An interface below the part added so far: n_below / n_above = eta."""
        self._steps.append(("interface", self._n, self._n * eta))
        self._n = self._n * eta

    def add_medium(self, ops, p):
        """The interior of the coat just added, from its backend parameters ``p``."""
        if "sigma_s" in p:
            self._steps.append(("scattering", *scattering_interior(ops, p)))
        else:
            tau = p.get("sigma_a", RGB.splat(0.0)).map(lambda s: s * p["thickness"])
            self._steps.append(("absorbing", self._n, tau))

    def _along(self, ops, s2):
        """(up, back) of the stack for light going up with n^2 sin^2 = s2 (RGB)."""
        up, back = RGB.splat(1.0), RGB.splat(0.0)
        for step in self._steps:
            if step[0] == "interface":
                _, n_above, n_below = step
                c = ops.sqrt(ops.max(1.0 - s2 / (n_below * n_below), 0.0))  # cosine below
                r = fresnel_dielectric(ops, c, n_above / n_below)  # 1 past the critical angle
                denom = (1.0 - r * back).map(lambda d: ops.max(d, 1e-7))
                up = (1.0 - r) * up / denom
                back = r + (1.0 - r) * (1.0 - r) * back / denom
            elif step[0] == "absorbing":
                _, n, tau = step
                c = ops.max(ops.sqrt(ops.max(1.0 - s2 / (n * n), 0.0)), 1e-6)
                a = tau.map(lambda x: ops.exp(-x / c))
                up, back = a * up, a * a * back
            else:
                _, t, r = step
                denom = (1.0 - r * back).map(lambda d: ops.max(d, 1e-7))
                up, back = t * up / denom, r + t * t * back / denom
        return up, back

    def averages(self, ops, points: int = 8):
        """(up, back) averaged over cosine-weighted directions in the base's medium, ``points``
        directions (``GAUSS_01``) inside the escape cone and as many beyond it."""
        n_b = self._n
        u_c = ops.min(1.0 / (n_b * n_b), 1.0)  # the escape cone: n_b^2 u < 1
        up, back = RGB.splat(0.0), RGB.splat(0.0)
        nodes, weights = GAUSS_01[points]
        for lo, width in ((0.0, u_c), (u_c, 1.0 - u_c)):
            for x, w in zip(nodes, weights):
                u_up, u_back = self._along(ops, n_b * n_b * (lo + width * x))
                up, back = up + u_up * (w * width), back + u_back * (w * width)
        return up, back

    def base_energy(self, ops, e_in: RGB, albedo: RGB) -> RGB:
        """Energy a Lambertian base of ``albedo`` sends out of the top, all orders of bounces
        between the base and the stack above, for energy ``e_in`` reaching it."""
        return self.emitted(ops, e_in * albedo, albedo)

    def emitted(self, ops, e_up: RGB, albedo: RGB, points: int = 8) -> RGB:
        """Energy out of the top for diffuse light ``e_up`` a base sends up, all orders of bounces
        between the base, which reflects what the stack returns with ``albedo``, and the stack
        (``points``: of ``averages``)."""
        up, back = self.averages(ops, points)
        return e_up * up / (1.0 - albedo * back).map(lambda d: ops.max(d, 1e-7))
