"""The three representations of lobe spread used by the adding-doubling variants.

All three are linear spaces (sum, scale by a scalar), which is all the adding equations need:

``ScalarVariance``      Belcour 2018: one variance; anisotropic roughness averaged.
``AxisVariance``        Weier & Belcour 2020, Section 3.1: one variance per axis of
                        a frame shared by all layers (the shading frame).
``CovarianceVariance``  Yamaguchi et al. 2019, Section 3.1: a 2x2 covariance
                        Sigma = R^T diag(h(ax), h(ay)) R per interface, R the interface's rotation;
                        the final lobe is its eigen-decomposition.

Each ``Spread`` class knows how to build an interface's spread from its roughness and rotation
(``from_interface``), how to fetch an isotropic table for an anisotropic interface
(``fgd_fetch``), and how to turn a spread back into a GGX lobe (``to_lobe``).
"""
from __future__ import annotations

# Past this variance every mapping's roughness is 1 to within 1e-6 (the variance of alpha = 1 is
# about 1e5 under Belcour's mapping, 12 under Weier's), so a larger spread is the same lobe. The
# adding equations scale spreads by refraction Jacobians that grow without bound toward grazing
# (1 / cos^2 of a cosine clamped at 1e-6), so an unbounded spread overflowed float32 where it is
# squared (the covariance's eigen-decomposition) below the horizon. ``bounded`` caps its size.
VARIANCE_MAX = 1e6



class ScalarVariance:
    __slots__ = ("v",)

    def __init__(self, v):
        self.v = v

    @staticmethod
    def zero():
        return ScalarVariance(0.0)

    @staticmethod
    def isotropic(v):
        return ScalarVariance(v)

    def __add__(self, o):
        return ScalarVariance(self.v + o.v)

    def scale(self, s):
        return ScalarVariance(self.v * s)

    def divide_safe(self, ops, e):
        return ScalarVariance(ops.select(e > 0.0, self.v / ops.max(e, 1e-30), 0.0))

    def mean(self):
        return self.v

    def plus_along(self, ops, ux, uy, v):
        """This spread plus variance ``v`` along the unit direction (ux, uy), averaged here."""
        return ScalarVariance(self.v + 0.5 * v)

    def bounded(self, ops):
        return ScalarVariance(ops.min(self.v, VARIANCE_MAX))

    @staticmethod
    def from_interface(ops, mapping, ax, ay, cos_r, sin_r, scale=1.0):
        return ScalarVariance(mapping.to_variance(ops, 0.5 * (ax + ay) * scale))

    @staticmethod
    def fgd_fetch(ops, sx, sy, cz, ax, ay, cos_r, sin_r):
        """(cos, alpha) at which to read isotropic FGD tables: the averaged roughness."""
        return cz, 0.5 * (ax + ay)

    def to_lobe(self, ops, mapping):
        a = mapping.to_roughness(ops, self.v)
        return a, a, 0.0


def rms_alpha(ops, ax, ay):
    if ax is ay:  # an isotropic layer (one roughness input): nothing to average
        return ax
    return ops.sqrt(0.5 * (ax * ax + ay * ay))


def _stretch_fetch(ops, lx, ly, cz, ax, ay):
    """Weier & Belcour 2020 Listing 1: stretch the incident direction by the excess roughness of each axis
    and read the isotropic table at the smaller roughness."""
    amin = ops.min(ax, ay)
    dx = ax - amin
    dy = ay - amin
    lx = lx / (1.0 + dx * dx)
    ly = ly / (1.0 + dy * dy)
    return ops.sqrt(ops.max(1.0 - lx * lx - ly * ly, 0.0)), amin


class AxisVariance:
    __slots__ = ("x", "y")

    def __init__(self, x, y):
        self.x, self.y = x, y

    @staticmethod
    def zero():
        return AxisVariance(0.0, 0.0)

    @staticmethod
    def isotropic(v):
        return AxisVariance(v, v)

    def __add__(self, o):
        return AxisVariance(self.x + o.x, self.y + o.y)

    def scale(self, s):
        return AxisVariance(self.x * s, self.y * s)

    def divide_safe(self, ops, e):
        inv = ops.select(e > 0.0, 1.0 / ops.max(e, 1e-30), 0.0)
        return AxisVariance(self.x * inv, self.y * inv)

    def mean(self):
        return 0.5 * (self.x + self.y)

    def plus_along(self, ops, ux, uy, v):
        """This spread plus variance ``v`` along the unit direction (ux, uy), on the shared axes."""
        return AxisVariance(self.x + v * ux * ux, self.y + v * uy * uy)

    def bounded(self, ops):
        return AxisVariance(ops.min(self.x, VARIANCE_MAX), ops.min(self.y, VARIANCE_MAX))

    @staticmethod
    def shared_axes(ops, ax, ay, cos_r, sin_r):
        """A rotated interface seen along the shared axes: the projected roughness
        sqrt(ax^2 cos^2 + ay^2 sin^2) along x and its counterpart along y (Heitz 2014 Eq. 80).
        Exact for unrotated interfaces; the shared-axes model cannot represent more."""
        c2, s2 = cos_r * cos_r, sin_r * sin_r
        return (ops.sqrt(ax * ax * c2 + ay * ay * s2), ops.sqrt(ax * ax * s2 + ay * ay * c2))

    @staticmethod
    def from_interface(ops, mapping, ax, ay, cos_r, sin_r, scale=1.0):
        px, py = AxisVariance.shared_axes(ops, ax, ay, cos_r, sin_r)
        return AxisVariance(mapping.to_variance(ops, px * scale), mapping.to_variance(ops, py * scale))

    @staticmethod
    def fgd_fetch(ops, sx, sy, cz, ax, ay, cos_r, sin_r):
        px, py = AxisVariance.shared_axes(ops, ax, ay, cos_r, sin_r)
        return _stretch_fetch(ops, sx, sy, cz, px, py)

    def to_lobe(self, ops, mapping):
        return mapping.to_roughness(ops, self.x), mapping.to_roughness(ops, self.y), 0.0


class CovarianceVariance:
    __slots__ = ("xx", "xy", "yy")

    def __init__(self, xx, xy, yy):
        self.xx, self.xy, self.yy = xx, xy, yy

    @staticmethod
    def zero():
        return CovarianceVariance(0.0, 0.0, 0.0)

    @staticmethod
    def isotropic(v):
        return CovarianceVariance(v, 0.0, v)

    def __add__(self, o):
        return CovarianceVariance(self.xx + o.xx, self.xy + o.xy, self.yy + o.yy)

    def scale(self, s):
        return CovarianceVariance(self.xx * s, self.xy * s, self.yy * s)

    def divide_safe(self, ops, e):
        inv = ops.select(e > 0.0, 1.0 / ops.max(e, 1e-30), 0.0)
        return CovarianceVariance(self.xx * inv, self.xy * inv, self.yy * inv)

    def mean(self):
        return 0.5 * (self.xx + self.yy)

    def plus_along(self, ops, ux, uy, v):
        """This spread plus variance ``v`` along the unit direction (ux, uy): Sigma + v u u^T."""
        return CovarianceVariance(self.xx + v * ux * ux, self.xy + v * ux * uy, self.yy + v * uy * uy)

    def bounded(self, ops):
        """The covariance scaled down (its shape kept) so that its larger diagonal entry, which
        bounds every entry of a positive semi-definite 2x2 matrix, is at most VARIANCE_MAX."""
        k = VARIANCE_MAX / ops.max(ops.max(self.xx, self.yy), VARIANCE_MAX)
        return self.scale(k)

    @staticmethod
    def from_interface(ops, mapping, ax, ay, cos_r, sin_r, scale=1.0):
        """Sigma = R^T diag(h(ax), h(ay)) R with the interface axes x' = (cos r, sin r)
        (Yamaguchi et al. 2019, Section 3.1)."""
        vx = mapping.to_variance(ops, ax * scale)
        vy = mapping.to_variance(ops, ay * scale)
        c2, s2, cs = cos_r * cos_r, sin_r * sin_r, cos_r * sin_r
        return CovarianceVariance(vx * c2 + vy * s2, (vx - vy) * cs, vx * s2 + vy * c2)

    @staticmethod
    def fgd_fetch(ops, sx, sy, cz, ax, ay, cos_r, sin_r):
        """Isotropic tables read at the RMS roughness sqrt((ax^2 + ay^2) / 2). Yamaguchi et al. 2019 used
        Unity's F*G approximation here; we measured (``tests/unit/test_models.py``,
        ``test_anisotropic_energy``) that the RMS roughness tracks the directional albedo of
        anisotropic GGX far better than the stretch of Weier & Belcour 2020 Listing 1 when one axis is
        much rougher (e.g. (0.3, 0.05) at normal incidence: 0.938 vs exact 0.934; Listing 1 gives
        the smooth value 0.997). Rotation-invariant, so rotated interfaces need nothing more."""
        return cz, rms_alpha(ops, ax, ay)

    def to_lobe(self, ops, mapping):
        """Eigen-decomposition of the symmetric 2x2 covariance: major variance along the angle
        0.5 * atan2(2 xy, xx - yy), minor across it."""
        half_tr = 0.5 * (self.xx + self.yy)
        half_diff = 0.5 * (self.xx - self.yy)
        r = ops.sqrt(half_diff * half_diff + self.xy * self.xy)
        if isinstance(r, float) and r == 0.0:  # isotropic by structure (traced): no eigen-split
            a = mapping.to_roughness(ops, ops.max(half_tr, 0.0))
            return a, a, 0.0
        major = half_tr + r
        minor = ops.max(half_tr - r, 0.0)
        angle = 0.5 * ops.atan2(self.xy, half_diff)
        return mapping.to_roughness(ops, major), mapping.to_roughness(ops, minor), angle


SPREADS = {"scalar": ScalarVariance, "axis": AxisVariance, "covariance": CovarianceVariance}
