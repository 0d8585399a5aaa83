"""The reflectance of an interface under a thin film (soap, oil, an oxide), in RGB, written once over
the abstract ops: L. Belcour and P. Barla 2017, *A Practical Extension to Microfacet Theory for the
Modeling of Varying Iridescence*, ACM TOG 36(4).

A film of index ``film_ior`` and thickness d (nm) lies between the medium above (index ``n_above``)
and a substrate: a dielectric of index ``n_below`` or a conductor of complex index eta + i k per
RGB channel (all indices absolute). Per polarisation the film's multiple reflections sum to the Airy
reflectance, which Belcour and Barla write as a Fourier series in the round trip's phase
Phi = 2 pi OPD / lambda + phi_21 + phi_23 (Eq. 10, the sum over path-order differences m):

    R(lambda) = C_0 + 2 sum_m C_m cos(m Phi),   C_0 = R_12 + R_s,   C_m = (R_s - T_121) r_123^m,
    R_s = T_121^2 R_23 / (1 - R_12 R_23),   T_121 = 1 - R_12,   r_123 = sqrt(R_12 R_23),

with OPD = 2 film_ior d cos(theta_film). Their spectral antialiasing integrates each term against a
colour matching function analytically: cos(m Phi) becomes the Fourier transform of the sensitivity
(as a function of wavenumber) at m OPD, phase-shifted by m (phi_21 + phi_23). Written with the
complex round-trip amplitude rho = r_21 r_23 (|rho| = r_123, arg rho = phi_21 + phi_23), each
channel c is

    R_c = C_0 + 2 (R_s - T_121) sum_{m=1..3} Re(rho^m S_c(m OPD)),

for s and p separately, then averaged. S_c is the Fourier transform, over the wavenumber, of
channel c's colour matching function, as the Gaussian lobes of Belcour and Barla's supplemental
code (the transforms of Gaussians over the wavenumber), three per CIE 1931 XYZ function fitted by
least squares to the exact transform (``lamella_dev.thin_film_fit``), mapped to linear Rec.709 and
normalised to S_c(0) = 1.

Conventions, matched to Blender's Cycles (its Principled BSDF thin film, in
intern/cycles/kernel/closure/bsdf_util.h: ``fresnel_iridescence``,
``iridescence_airy_summation``, ``iridescence_lookup_sensitivity``, ``fresnel_conductor_polarized``;
the table in intern/cycles/scene/shader.cpp, ``ShaderManager::compute_thin_film_table``), so that
our colours compare with Principled's:

- orders m = 1..3 (Cycles truncates there; the next term is of relative size r_123^4);
- RGB: XYZ through Cycles' XYZ (D65) -> Rec.709 matrix (``XYZ_TO_REC709``), then each RGB channel
  divided by its value at OPD = 0 (Cycles normalises its table's DC term to 1), so a spectrally
  flat reflectance R gives (R, R, R) and light of equal energy per wavelength is white. (Cycles
  tabulates the Fourier transform of the measured CMFs; we evaluate an analytic fit of it, which
  traces to an exp, a cos and, for a conductor, a sin per lobe: nine lobes, within 0.017 of the
  exact transform, where the paper's four, which Blender 4.2 used, are within 0.16. Blender 4.2
  also adapted the white by scaling XYZ by D65's white before the matrix.)
- the film's top interface reflecting totally (a film of lower index than the medium above, past
  the critical angle): R = 1, as Cycles; so is the bottom interface of a dielectric reflecting
  totally (exact: with |r_23| = 1 the Airy sum is 1). The light a film thinner than a wavelength
  lets tunnel through in the first case is not modelled (``lamella_dev.thin_film_spectral`` has
  it).
- conductor substrate: its reflectance and phase per polarisation from the exact complex-index
  amplitudes (Born and Wolf, Principles of Optics, 7th ed., Section 14.4.1, as Cycles'
  ``fresnel_conductor_polarized``), per RGB channel with that channel's sensitivity; the phase
  enters through rho as a complex number.
- d -> 0: the film fades out over its first nanometre, weight smoothstep(0, 1, d), as in Cycles,
  which is where the truncated series is furthest from the exact sum (at d = 0 all orders are in
  phase; near grazing incidence r_123 is not small). Cycles fades the film's index to the medium
  above's; we fade the reflectance to the bare interface's (``fresnel_dielectric`` /
  ``fresnel_conductor``): the same at both ends and identical from 1 nm on, and an index-matched
  film stays exactly the bare interface at every thickness. At d <= 0 the result is the bare
  interface's, bit for bit.

Limits that hold: d = 0 gives the bare interface exactly; an index-matched film (film_ior = n_below
for a dielectric, or film_ior = n_above) reflects as the bare interface at every thickness, to
rounding (r_23, or r_12, is exactly 0 and the series collapses to C_0); R is in [0, 1] and finite
at every cosine in [0, 1], in float32 as in float64.

Accuracy against the exact spectral colour (``lamella_dev.thin_film_spectral``; the table in
tests/unit/test_thin_film.py, 0-85 degrees, 0-1000 nm, film index 1.33-2.4): mean |dRGB| 0.0001 to
0.0026 and mean CIEDE2000 0.03 to 0.27 for dielectric substrates (with the paper's four lobes
0.0015 to 0.019 and 1 to 2.6). What remains is about equally the fit of the sensitivities (up to
0.017 of S_c(0)) and the truncation after m = 3, which dominates from 60 degrees on, where r_123
grows (up to 0.1 at 85 degrees). A conductor given in RGB adds the ambiguity of its spectrum (mean
|dRGB| 0.03 for gold against a spectrum interpolated through its RGB index, 0.001 to 0.0024 against
a constant index per channel).
"""
from __future__ import annotations

import math

from .fresnel import fresnel_conductor, fresnel_dielectric
from .rgb import RGB

ORDERS = 3
FADE_NM = 1.0  # over its first FADE_NM nanometres the film fades in from the bare interface
_TINY = 1e-30  # guards denominators that vanish only where their numerators do

# Cycles' XYZ (D65) -> linear Rec.709 matrix (ShaderManager::init_xyz_transforms).
XYZ_TO_REC709 = ((3.2404542, -1.5371385, -0.4985314),
                 (-0.9692660, 1.8760108, 0.0415560),
                 (0.0556434, -0.2040259, 1.0572252))

# The XYZ sensitivities' Fourier transform as Gaussian lobes, the form of Belcour and Barla 2017's
# supplemental code: val * sqrt(2 pi var) * exp(-var phi^2) * exp(i pos phi) at phi = 2 pi OPD (OPD
# in metres, pos in 1/m, var in m^2), each lobe the transform of a Gaussian over the wavenumber.
# (XYZ axis, val, pos, var) per lobe, three per XYZ function: a least-squares fit of the RGB
# sensitivities this module uses (after XYZ_TO_REC709 and the normalisation to S_c(0) = 1, real
# and imaginary parts) to the exact transform of the 1 nm CIE 1931 2-degree table, OPD 0-90 um,
# made by ``PYTHONPATH=addon python -m lamella_dev.thin_film_fit --lobes 3`` (which prints these
# digits). Max |S_c - exact| 0.017 (R), 0.014 (G), 0.008 (B), against the paper's four lobes' 0.16,
# 0.14, 0.07; the paper's constants are ``lamella_dev.thin_film_fit.PAPER_LOBES``.
SENSITIVITY_LOBES = ((0, 4.86190e-13, 1.65304e+06, 2.93250e+09),
                     (0, 1.56384e-13, 1.79220e+06, 2.79993e+09),
                     (0, 9.79291e-14, 2.23484e+06, 5.12136e+09),
                     (1, 2.66598e-13, 1.69939e+06, 4.14297e+09),
                     (1, 3.40740e-13, 1.84938e+06, 4.85649e+09),
                     (1, 2.33734e-14, 2.07282e+06, 5.46185e+09),
                     (2, 2.46084e-13, 2.17584e+06, 2.19402e+09),
                     (2, 2.13118e-13, 2.18165e+06, 9.26933e+09),
                     (2, 2.29463e-13, 2.29822e+06, 1.73221e+09))


def _lobes_nm():
    """Per lobe (decay, frequency) for OPD in nm: exp(-decay OPD^2) and cos(frequency OPD); and per
    RGB channel the lobes' weights, normalised to sum 1 (S_c(0) = 1)."""
    to_phi = 2.0 * math.pi * 1e-9
    shape = tuple((var * to_phi * to_phi, pos * to_phi) for _, _, pos, var in SENSITIVITY_LOBES)
    amp = [val * math.sqrt(2.0 * math.pi * var) for _, val, _, var in SENSITIVITY_LOBES]
    weights = []
    for row in XYZ_TO_REC709:
        w = [row[axis] * a for (axis, *_), a in zip(SENSITIVITY_LOBES, amp)]
        dc = sum(w)
        weights.append(tuple(x / dc for x in w))
    return shape, tuple(weights)


_SHAPE, _WEIGHTS = _lobes_nm()


def sensitivity(ops, opd, imaginary: bool = True):
    """S_c(OPD) for c = R, G, B, OPD in nm: a list of three (real, imaginary) pairs, the
    imaginary part None when ``imaginary`` is False (a real rho needs only the real part)."""
    lobes = []
    for decay, freq in _SHAPE:
        g = ops.exp(-decay * (opd * opd))
        arg = freq * opd
        lobes.append((g * ops.cos(arg), g * ops.sin(arg) if imaginary else None))
    out = []
    for w in _WEIGHTS:
        re = sum(wj * lobe[0] for wj, lobe in zip(w, lobes))
        im = sum(wj * lobe[1] for wj, lobe in zip(w, lobes)) if imaginary else None
        out.append((re, im))
    return out


def _smoothstep01(ops, x):
    t = ops.clamp(x, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _film_top(ops, cos_i, n_above, film_ior, thickness_nm):
    """What the top interface and the film's depth give: with q_j = n_j cos(theta_j) from Snell's
    law in every layer, q_j^2 = n_j^2 - n_above^2 + q1^2 (q1 = n_above cos_i): n_above^2, q1^2,
    q2, whether the top interface reflects totally, the s and p amplitudes r_12 and the OPD
    (nm)."""
    c1 = ops.clamp(cos_i, 0.0, 1.0)
    q1 = n_above * c1
    q1sq = q1 * q1
    nn1 = n_above * n_above
    nn2 = film_ior * film_ior
    q2sq = (nn2 - nn1) + q1sq
    tir = q2sq < 0.0
    q2 = ops.sqrt(ops.max(q2sq, 0.0))
    r12s = (q1 - q2) / ops.max(q1 + q2, _TINY)
    r12p = (nn2 * q1 - nn1 * q2) / ops.max(nn2 * q1 + nn1 * q2, _TINY)
    opd = 2.0 * thickness_nm * q2
    return nn1, q1sq, q2, tir, (r12s, r12p), opd


def _fade_in(ops, thickness_nm, bare, film):
    """The bare interface's reflectance at d <= 0, the film's from FADE_NM on, smoothstep between
    (both ends exact: weights 0 and 1)."""
    s = _smoothstep01(ops, thickness_nm * (1.0 / FADE_NM))
    return (1.0 - s) * bare + s * film


def _airy(ops, r12, r23_re, r23_im, big_r23, sens):
    """One polarisation, three channels' sensitivities: C_0 + 2 (R_s - T_121) sum_m Re(rho^m S(m OPD))
    with rho = -r12 r23 (r23 complex; ``r23_im`` None for a real amplitude) and R_23 = |r23|^2."""
    big_r12 = r12 * r12
    t121 = 1.0 - big_r12
    rs = t121 * t121 * big_r23 / ops.max(1.0 - big_r12 * big_r23, _TINY)
    c0 = big_r12 + rs
    k2 = 2.0 * (rs - t121)
    rho_re = -r12 * r23_re
    rho_im = None if r23_im is None else -r12 * r23_im
    total = 0.0
    pm_re, pm_im = rho_re, rho_im
    for m in range(ORDERS):
        s_re, s_im = sens[m]
        if pm_im is None:
            total = total + pm_re * s_re
        else:
            total = total + (pm_re * s_re - pm_im * s_im)
        if m + 1 < ORDERS:
            if pm_im is None:
                pm_re = pm_re * rho_re
            else:
                pm_re, pm_im = pm_re * rho_re - pm_im * rho_im, pm_re * rho_im + pm_im * rho_re
    return c0 + k2 * total


def film_reflectance_dielectric(ops, cos_i, n_above, film_ior, thickness_nm, n_below) -> RGB:
    """Reflectance (RGB, linear Rec.709) of the interface from a medium of index ``n_above`` onto a
    dielectric of index ``n_below`` under a film of index ``film_ior`` and thickness
    ``thickness_nm``, light arriving at cosine ``cos_i`` in the medium above (Belcour and Barla
    2017, Eq. 10 with their spectral antialiasing; conventions of Cycles, see the module). The
    transmittance is 1 - R per channel (no absorption in a dielectric film)."""
    nn1, q1sq, q2, tir_top, (r12s, r12p), opd = _film_top(ops, cos_i, n_above, film_ior, thickness_nm)
    nn2 = film_ior * film_ior
    nn3 = n_below * n_below
    q3sq = (nn3 - nn1) + q1sq
    tir_bottom = q3sq < 0.0
    q3 = ops.sqrt(ops.max(q3sq, 0.0))
    r23s = (q2 - q3) / ops.max(q2 + q3, _TINY)
    r23p = (nn3 * q2 - nn2 * q3) / ops.max(nn3 * q2 + nn2 * q3, _TINY)
    sens_m = [sensitivity(ops, (m + 1) * opd, imaginary=False) for m in range(ORDERS)]
    bare = fresnel_dielectric(ops, cos_i, n_below / n_above)
    out = []
    for c in range(3):
        sens = [s[c] for s in sens_m]
        r = 0.5 * (_airy(ops, r12s, r23s, None, r23s * r23s, sens) + _airy(ops, r12p, r23p, None, r23p * r23p, sens))
        r = ops.select(tir_top, 1.0, ops.select(tir_bottom, 1.0, ops.clamp(r, 0.0, 1.0)))
        out.append(_fade_in(ops, thickness_nm, bare, r))
    return RGB(*out)


def _conductor_amplitudes(ops, q2, nn2, nn1, q1sq, eta, k):
    """The complex amplitudes r_23 (s, p) from the film (q2 = n2 cos(theta_2), nn2 = n2^2) onto a
    conductor eta + i k (one channel), each as (real, imaginary, |r|^2) (Born and Wolf, Section
    14.4.1), with q3 = (eta + i k) cos(theta_3) = u + i v written without cancellation: the larger
    of u, v from their squares' sum, the smaller from u v = eta k."""
    ek = eta * k
    t1 = (eta * eta - k * k - nn1) + q1sq  # u^2 - v^2
    t2 = ops.sqrt(t1 * t1 + 4.0 * ek * ek)  # u^2 + v^2
    big = ops.sqrt(ops.max(0.5 * (t2 + ops.abs(t1)), 0.0))
    small = ek / ops.max(big, _TINY)
    u = ops.select(t1 >= 0.0, big, small)
    v = ops.select(t1 >= 0.0, small, big)
    # s: (q2 - q3) / (q2 + q3)
    den_s = ops.max((q2 + u) * (q2 + u) + v * v, _TINY)
    rs_re = (q2 * q2 - t2) / den_s
    rs_im = -2.0 * q2 * v / den_s
    big_rs = ((q2 - u) * (q2 - u) + v * v) / den_s
    # p: (N^2 q2 - n2^2 q3) / (N^2 q2 + n2^2 q3), N^2 = eta^2 - k^2 + 2 i eta k
    p_re = (eta * eta - k * k) * q2
    p_im = 2.0 * ek * q2
    h_re = nn2 * u
    h_im = nn2 * v
    den_p = ops.max((p_re + h_re) * (p_re + h_re) + (p_im + h_im) * (p_im + h_im), _TINY)
    rp_re = (p_re * p_re + p_im * p_im - h_re * h_re - h_im * h_im) / den_p
    rp_im = 2.0 * (p_im * h_re - p_re * h_im) / den_p
    big_rp = ((p_re - h_re) * (p_re - h_re) + (p_im - h_im) * (p_im - h_im)) / den_p
    return (rs_re, rs_im, big_rs), (rp_re, rp_im, big_rp)


def film_reflectance_conductor(ops, cos_i, n_above, film_ior, thickness_nm, eta: RGB, k: RGB) -> RGB:
    """Reflectance (RGB, linear Rec.709) of a conductor of absolute complex index ``eta + i k`` (per
    channel) under a film of index ``film_ior`` and thickness ``thickness_nm``, seen from a medium
    of index ``n_above`` at cosine ``cos_i`` (Belcour and Barla 2017, Eq. 10, with the conductor's
    phase on reflection; conventions of Cycles, see the module)."""
    nn1, q1sq, q2, tir_top, (r12s, r12p), opd = _film_top(ops, cos_i, n_above, film_ior, thickness_nm)
    nn2 = film_ior * film_ior
    sens_m = [sensitivity(ops, (m + 1) * opd, imaginary=True) for m in range(ORDERS)]
    out = []
    for c, (e, kk) in enumerate(zip(eta, k)):
        (rs_re, rs_im, big_rs), (rp_re, rp_im, big_rp) = _conductor_amplitudes(ops, q2, nn2, nn1, q1sq, e, kk)
        sens = [s[c] for s in sens_m]
        r = 0.5 * (_airy(ops, r12s, rs_re, rs_im, big_rs, sens) + _airy(ops, r12p, rp_re, rp_im, big_rp, sens))
        r = ops.select(tir_top, 1.0, ops.clamp(r, 0.0, 1.0))
        bare = fresnel_conductor(ops, cos_i, e / n_above, kk / n_above)
        out.append(_fade_in(ops, thickness_nm, bare, r))
    return RGB(*out)


__all__ = ["film_reflectance_dielectric", "film_reflectance_conductor", "sensitivity", "XYZ_TO_REC709",
           "SENSITIVITY_LOBES", "ORDERS", "FADE_NM"]
