"""The exact colour of a thin film on an interface: the ground truth that
``lamella.core.models.thin_film`` (Belcour and Barla 2017) is measured against.

Plain numpy, never traced, and it shares no model code: per wavelength the exact Airy reflectance
of the three-media stack (medium above, film, substrate) from complex amplitudes, s and p
polarisations averaged, integrated against the CIE 1931 2-degree colour matching functions
(``colour-science``'s table, 360-830 nm).

Amplitudes (Born and Wolf, Principles of Optics, Sections 1.5 and 1.6; time factor exp(-i w t),
complex index N = n + i k with k >= 0 absorbing): with q_j = N_j cos(theta_j) =
sqrt(N_j^2 - n_1^2 sin^2(theta_1)) (the root with Im >= 0: evanescent or absorbed downward)

    r_s(i, j) = (q_i - q_j) / (q_i + q_j),   r_p(i, j) = (N_j^2 q_i - N_i^2 q_j) / (N_j^2 q_i + N_i^2 q_j),
    r = (r_12 + r_23 e^{i delta}) / (1 + r_12 r_23 e^{i delta}),   delta = 4 pi d q_2 / lambda,

R = (|r_s|^2 + |r_p|^2) / 2. This is exact for every case the RGB model simplifies: total internal
reflection at either interface, including the light a film thinner than a wavelength lets tunnel
through where the top interface alone would reflect totally (frustrated total internal reflection),
and a conductor's complex phase on reflection. A zero thickness gives the bare interface between
the medium above and the substrate exactly.

Colour: RGB is linear Rec.709 (Blender's scene-linear) with Cycles' normalisation of its thin film
(Blender's ``ShaderManager::compute_thin_film_table``): the RGB colour matching functions are the
XYZ ones through Cycles' XYZ (D65) -> Rec.709 matrix, each normalised to unit area, so channel c is

    RGB_c = sum_lambda R(lambda) rbar_c(lambda) / sum_lambda rbar_c(lambda),

and a spectrally flat reflectance R gives (R, R, R) exactly. (Light of equal energy per wavelength
is white; this is the paper's illuminant E, adapted to Rec.709's white by scaling each RGB channel.)

A conductor given by RGB ``eta``, ``k`` (as the stack gives them) is made spectral by
``rgb_to_spectrum``: piecewise-linear in wavelength through the channel values placed at each
channel's representative wavelength (``CHANNEL_WAVELENGTHS``, the centroid of its colour matching
function: a reflectance linear in wavelength has exactly its value there as its channel value),
constant beyond the outer two. A callable ``f(wavelength_nm) -> array`` gives a spectrum directly.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

# Cycles' XYZ (D65) -> linear Rec.709 matrix (ShaderManager::init_xyz_transforms); the RGB model
# holds the same numbers (a test keeps the two equal).
XYZ_TO_REC709 = np.array([[3.2404542, -1.5371385, -0.4985314],
                          [-0.9692660, 1.8760108, 0.0415560],
                          [0.0556434, -0.2040259, 1.0572252]])


@lru_cache(maxsize=None)
def cmfs(step_nm: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """(wavelengths in nm, (L, 3) RGB colour matching functions normalised to unit sum per channel)
    on 360-830 nm every ``step_nm`` nanometres (1 or 5)."""
    import colour

    table = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    lam = np.asarray(table.wavelengths, dtype=np.float64)
    xyz = np.asarray(table.values, dtype=np.float64)
    keep = (lam >= 360.0) & (lam <= 830.0) & (np.round(lam) % step_nm == 0)
    rgb = xyz[keep] @ XYZ_TO_REC709.T
    return lam[keep], rgb / rgb.sum(0)


def _channel_wavelengths() -> tuple[float, float, float]:
    lam, w = cmfs(1)
    return tuple(float(c) for c in lam @ w)  # the first moment of each unit-area channel


CHANNEL_WAVELENGTHS = (635.2, 543.7, 437.5)  # R, G, B: _channel_wavelengths() rounded (a test checks)


def rgb_to_spectrum(values, lam: np.ndarray) -> np.ndarray:
    """An RGB triple (e.g. a conductor's eta or k) as a spectrum over ``lam`` (nm): piecewise
    linear through (CHANNEL_WAVELENGTHS[c], values[c]), constant beyond the outer two. A callable is
    evaluated at ``lam`` instead."""
    if callable(values):
        return np.broadcast_to(np.asarray(values(lam), dtype=np.float64), lam.shape)
    r, g, b = (float(v) for v in values)
    xs = CHANNEL_WAVELENGTHS[::-1]  # increasing: blue, green, red
    return np.interp(lam, xs, (b, g, r))


def _q(nn, n1: float, sin2: np.ndarray) -> np.ndarray:
    """N_j cos(theta_j) from Snell's law (nn = N_j^2), the root with Im >= 0."""
    q = np.sqrt(nn - (n1 * n1) * sin2 + 0j)
    return np.where(q.imag < 0.0, -q, q)


def _ratio(num, den):
    """num / den, 0 where both vanish (an index-matched interface at grazing incidence)."""
    ok = den != 0
    return np.where(ok, num / np.where(ok, den, 1.0), 0.0)


def _stack(cos_i, n_above, film_ior, thickness_nm, n_below, eta, k, step_nm):
    """The wavelengths, the thicknesses (..., 1), q_2 (..., 1) and the s and p amplitudes
    (r_12, r_23) of the stack, each (..., L)."""
    if (n_below is None) == (eta is None or k is None):
        raise ValueError("give either n_below (a dielectric substrate) or eta and k (a conductor)")
    lam, _ = cmfs(step_nm)
    cos_i, thickness_nm = np.broadcast_arrays(np.asarray(cos_i, dtype=np.float64),
                                              np.asarray(thickness_nm, dtype=np.float64))
    c1 = cos_i[..., None]
    if np.any(c1 <= 0.0) or np.any(c1 > 1.0):
        raise ValueError("cos_i must be in (0, 1]: grazing incidence is the limit R = 1")
    sin2 = 1.0 - c1 * c1
    n1 = float(n_above)
    nn1, nn2 = n1 * n1, float(film_ior) ** 2
    if n_below is not None:
        nn3 = np.full(lam.shape, float(n_below) ** 2, dtype=np.complex128)
    else:
        nn3 = (rgb_to_spectrum(eta, lam) + 1j * rgb_to_spectrum(k, lam)) ** 2
    q1 = n1 * c1 + 0j
    q2 = _q(nn2, n1, sin2)
    q3 = _q(nn3, n1, sin2)
    s = (_ratio(q1 - q2, q1 + q2), _ratio(q2 - q3, q2 + q3))
    p = (_ratio(nn2 * q1 - nn1 * q2, nn2 * q1 + nn1 * q2), _ratio(nn3 * q2 - nn2 * q3, nn3 * q2 + nn2 * q3))
    return lam, thickness_nm[..., None], q2, (s, p)


def film_spectrum(cos_i, n_above: float, film_ior: float, thickness_nm, n_below=None,
                  eta=None, k=None, step_nm: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """(wavelengths (L,), reflectance (..., L)): the exact Airy reflectance per wavelength at the
    incidence cosines ``cos_i`` (in (0, 1]) in the medium above and thicknesses ``thickness_nm``
    (broadcast together to the shape (...)), unpolarised. The substrate is a dielectric of index
    ``n_below`` or a conductor ``eta + i k`` (RGB triples or callables of the wavelength in nm,
    absolute indices)."""
    lam, d, q2, amplitudes = _stack(cos_i, n_above, film_ior, thickness_nm, n_below, eta, k, step_nm)
    phase = np.exp(1j * (4.0 * np.pi * d / lam) * q2)
    out = 0.0
    for r12, r23 in amplitudes:
        b = r23 * phase
        out = out + 0.5 * np.abs(_ratio(r12 + b, 1.0 + r12 * b)) ** 2
    return lam, np.clip(out, 0.0, 1.0)


def spectrum_to_rgb(reflectance: np.ndarray, step_nm: int = 1) -> np.ndarray:
    """(..., L) reflectance on ``cmfs(step_nm)``'s wavelengths -> (..., 3) linear Rec.709."""
    return reflectance @ cmfs(step_nm)[1]


def film_reflectance_rgb(cos_i, n_above: float, film_ior: float, thickness_nm, n_below=None,
                         eta=None, k=None, step_nm: int = 1) -> np.ndarray:
    """The exact colour of the filmed interface, (..., 3) linear Rec.709 for ``cos_i`` and
    ``thickness_nm`` broadcast to the shape (...): ``film_spectrum`` integrated by
    ``spectrum_to_rgb``. Saturated colours can leave the Rec.709 gamut (a channel below 0 or above
    1); the RGB model clamps to [0, 1], as Cycles does."""
    _, r = film_spectrum(cos_i, n_above, film_ior, thickness_nm, n_below, eta, k, step_nm)
    return spectrum_to_rgb(r, step_nm)


def series_reflectance_rgb(cos_i, n_above: float, film_ior: float, thickness_nm, n_below=None,
                           eta=None, k=None, orders: int = 3, step_nm: int = 1) -> np.ndarray:
    """The Airy reflectance as Belcour and Barla 2017 write it (Eq. 10 per wavelength: C_0 plus
    2 C_m cos(m Phi) over path-order differences m = 1..``orders``, Phi the round trip's phase,
    propagation and both reflections), integrated exactly against the colour matching functions.

    A diagnostic that splits the RGB model's error: ``orders`` large gives ``film_reflectance_rgb``
    (where the top interface does not reflect totally); ``orders=3`` is the model's truncation with
    exact spectral integration, so what remains between it and the model is the Gaussian fit of the
    sensitivities (and the RGB conductor's index held per channel)."""
    lam, d, q2, amplitudes = _stack(cos_i, n_above, film_ior, thickness_nm, n_below, eta, k, step_nm)
    if np.any(np.abs(q2.imag) > 0):
        raise ValueError("the series needs a film the light enters (no total reflection at the top)")
    path = np.exp(2j * np.pi * (2.0 * d * q2.real) / lam)  # exp(2 pi i OPD / lambda)
    out = 0.0
    for r12, r23 in amplitudes:
        r12 = r12.real
        big_r12, big_r23 = r12 * r12, np.abs(r23) ** 2
        t121 = 1.0 - big_r12
        rs = t121 * t121 * big_r23 / np.maximum(1.0 - big_r12 * big_r23, 1e-300)
        rho = -r12 * r23 * path  # the round trip: r_21 r_23 and the path
        series = np.broadcast_to(big_r12 + rs, rho.shape)
        rho_m = np.ones_like(rho)
        for _ in range(orders):
            rho_m = rho_m * rho
            series = series + 2.0 * (rs - t121) * rho_m.real
        out = out + 0.5 * series
    return out @ cmfs(step_nm)[1]


__all__ = ["XYZ_TO_REC709", "CHANNEL_WAVELENGTHS", "cmfs", "rgb_to_spectrum", "film_spectrum", "spectrum_to_rgb",
           "film_reflectance_rgb", "series_reflectance_rgb"]
