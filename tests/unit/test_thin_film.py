"""The thin-film reflectance (``lamella.core.models.thin_film``, Belcour and Barla 2017 in RGB):
its exact limits, its range over every angle, index and thickness in float32 and float64, the
traced graph against numpy, and its measured agreement with the spectral ground truth
(``lamella_dev.thin_film_spectral``).

The agreement table: ``python -m tests.unit.test_thin_film`` (from the repository root, with
``addon`` on the path) prints it."""
import math

import numpy as np
import pytest

from lamella.core.backends.ir.trace import Expr, Tracer
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.models import thin_film as tf
from lamella.core.models.fresnel import fresnel_conductor, fresnel_dielectric
from lamella.core.models.rgb import RGB
from lamella_dev import thin_film_spectral as spectral

GOLD = ((0.143, 0.374, 1.442), (3.983, 2.385, 1.603))
STEP_NM = 1  # the reference's wavelength step (5 gives the same table to four decimals)


def _stack(rgb, shape):
    return np.stack([np.broadcast_to(np.asarray(c), shape) for c in rgb], -1)


def model_rgb(cos_i, n_above, film_ior, d, n_below=None, conductor=None, dtype=np.float64):
    """The model on the numpy backend, inputs cast to ``dtype`` and broadcast; (..., 3)."""
    ops = NumpyOps(dtype)
    cos_i, n_above, film_ior, d = (np.asarray(x, dtype=dtype) for x in (cos_i, n_above, film_ior, d))
    shape = np.broadcast_shapes(cos_i.shape, n_above.shape, film_ior.shape, d.shape)
    if conductor is None:
        out = tf.film_reflectance_dielectric(ops, cos_i, n_above, film_ior, d, np.asarray(n_below, dtype=dtype))
    else:
        eta, k = (RGB(*(np.asarray(v, dtype=dtype) for v in x)) for x in conductor)
        out = tf.film_reflectance_conductor(ops, cos_i, n_above, film_ior, d, eta, k)
    return _stack(out, shape)


def bare_rgb(cos_i, n_above, n_below=None, conductor=None, dtype=np.float64):
    ops = NumpyOps(dtype)
    cos_i, n_above = np.asarray(cos_i, dtype=dtype), np.asarray(n_above, dtype=dtype)
    shape = np.broadcast_shapes(cos_i.shape, n_above.shape)
    if conductor is None:
        return _stack([fresnel_dielectric(ops, cos_i, np.asarray(n_below, dtype=dtype) / n_above)] * 3, shape)
    return _stack([fresnel_conductor(ops, cos_i, np.asarray(e, dtype=dtype) / n_above, np.asarray(k, dtype=dtype) / n_above)
                   for e, k in zip(*conductor)], shape)


COS_EDGES = np.concatenate([[0.0, 1e-7, 1e-3], np.cos(np.radians(np.linspace(0.0, 90.0, 31))), [1.0 - 1e-7, 1.0]])
DTYPES = [np.float64, np.float32]


# ------------------------------------------------------------------ exact limits
@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("n_above", [1.0, 1.5])
def test_zero_thickness_is_the_bare_interface_bit_for_bit(dtype, n_above):
    c = COS_EDGES[:, None]
    films = np.array([1.0, 1.2, 1.33, 1.5, 2.0, 2.4, 3.0])[None, :]
    for n_below in (1.0, 1.33, 1.5, 2.4):
        got = model_rgb(c, n_above, films, 0.0, n_below=n_below, dtype=dtype)
        np.testing.assert_array_equal(got, np.broadcast_to(bare_rgb(c, n_above, n_below, dtype=dtype), got.shape))
    got = model_rgb(c, n_above, films, 0.0, conductor=GOLD, dtype=dtype)
    np.testing.assert_array_equal(got, np.broadcast_to(bare_rgb(c, n_above, conductor=GOLD, dtype=dtype), got.shape))


@pytest.mark.parametrize("dtype", DTYPES)
def test_an_index_matched_film_is_the_bare_interface_at_every_thickness(dtype):
    """film_ior = n_below (a dielectric) and film_ior = n_above: no interference, the bare
    interface's Fresnel reflectance, to rounding, from 0 to 5000 nm (the fade in included)."""
    tol = 2e-6 if dtype == np.float32 else 1e-13
    c = COS_EDGES[:, None]
    d = np.array([0.0, 0.25, 0.5, 1.0, 3.0, 50.0, 300.0, 1000.0, 5000.0])[None, :]
    for n_above, n_below in [(1.0, 1.5), (1.0, 2.4), (1.5, 1.0), (1.33, 1.5), (1.0, 1.0)]:
        bare = bare_rgb(c, n_above, n_below, dtype=dtype)
        np.testing.assert_allclose(model_rgb(c, n_above, n_below, d, n_below=n_below, dtype=dtype),
                                   np.broadcast_to(bare, (len(COS_EDGES), d.shape[1], 3)), rtol=0, atol=tol)
        np.testing.assert_allclose(model_rgb(c, n_above, n_above, d, n_below=n_below, dtype=dtype),
                                   np.broadcast_to(bare, (len(COS_EDGES), d.shape[1], 3)), rtol=0, atol=tol)
    for n_above in (1.0, 1.5):
        bare = bare_rgb(c, n_above, conductor=GOLD, dtype=dtype)
        np.testing.assert_allclose(model_rgb(c, n_above, n_above, d, conductor=GOLD, dtype=dtype),
                                   np.broadcast_to(bare, (len(COS_EDGES), d.shape[1], 3)), rtol=0, atol=tol)


@pytest.mark.parametrize("dtype", DTYPES)
def test_total_internal_reflection_in_the_film_reflects_everything(dtype):
    """A film of lower index than the medium above, past the critical angle: R = 1 (as Cycles; the
    light a sub-wavelength film lets tunnel through is the spectral reference's only). And a
    dielectric's bottom interface past its critical angle: R = 1 (exact)."""
    theta_c = math.degrees(math.asin(1.33 / 1.5))
    c = np.cos(np.radians(np.linspace(theta_c + 0.5, 90.0, 20)))[:, None]
    d = np.array([1.0, 100.0, 700.0])[None, :]
    np.testing.assert_array_equal(model_rgb(c, 1.5, 1.33, d, n_below=1.5, dtype=dtype), 1.0)
    np.testing.assert_array_equal(model_rgb(c, 1.5, 1.33, d, conductor=GOLD, dtype=dtype), 1.0)
    c = np.cos(np.radians(np.linspace(math.degrees(math.asin(1.0 / 1.5)) + 0.5, 90.0, 20)))[:, None]
    np.testing.assert_array_equal(model_rgb(c, 1.5, 2.0, d, n_below=1.0, dtype=dtype), 1.0)


@pytest.mark.parametrize("dtype", DTYPES)
def test_finite_and_in_the_unit_interval_everywhere(dtype):
    """Every cosine in [0, 1] (both ends), film index 1..3, thickness 0..5000 nm (the fade's first
    nanometre included), media above and below from 0.25 to 4 (total internal reflection at either
    interface), conductors from k = 0 to 50."""
    c = COS_EDGES[:, None, None]
    films = np.concatenate([np.linspace(1.0, 3.0, 11), [1.0 + 1e-7, 1.33, 2.4]])[None, :, None]
    d = np.concatenate([[0.0, 1e-6, 0.3, 0.999], np.linspace(1.0, 5000.0, 41)])[None, None, :]
    for n_above in (1.0, 1.33, 1.5, 2.0, 4.0):
        for n_below in (0.25, 1.0, 1.33, 1.5, 2.4, 4.0):
            r = model_rgb(c, n_above, films, d, n_below=n_below, dtype=dtype)
            assert r.dtype == dtype and np.all(np.isfinite(r)) and r.min() >= 0.0 and r.max() <= 1.0, (n_above, n_below)
        for conductor in (GOLD, ((0.25, 1.0, 4.0), (0.0, 1e-6, 50.0)), ((4.0, 0.25, 1.5), (50.0, 0.0, 1.0))):
            r = model_rgb(c, n_above, films, d, conductor=conductor, dtype=dtype)
            assert r.dtype == dtype and np.all(np.isfinite(r)) and r.min() >= 0.0 and r.max() <= 1.0, (n_above, conductor)


def test_float32_follows_float64():
    c = np.cos(np.radians(np.arange(0.0, 90.1, 2.5)))[:, None, None]
    films = np.array([1.33, 1.5, 2.0, 2.4])[None, :, None]
    d = np.linspace(0.0, 5000.0, 101)[None, None, :]
    worst = 0.0
    for kw in (dict(n_below=1.0), dict(n_below=1.5), dict(conductor=GOLD)):
        a = model_rgb(c, 1.0, films, d, dtype=np.float64, **kw)
        b = model_rgb(c, 1.0, films, d, dtype=np.float32, **kw)
        worst = max(worst, float(np.abs(a - b).max()))
    assert worst < 2e-6, worst  # measured 1.55e-6


# ------------------------------------------------------------------ the conventions
def test_the_sensitivities_are_normalised_and_share_the_references_matrix():
    s = tf.sensitivity(NumpyOps(), np.zeros(1))
    for re, im in s:
        assert abs(float(re[0]) - 1.0) < 1e-14 and abs(float(im[0])) < 1e-14
    np.testing.assert_array_equal(np.array(tf.XYZ_TO_REC709), spectral.XYZ_TO_REC709)


def test_the_gaussian_fit_against_the_exact_transform_of_the_colour_matching_functions():
    """S_c(OPD) against sum_lambda rbar_c(lambda) exp(2 pi i OPD / lambda), the transform Cycles
    tabulates, over every OPD the model meets (0-90 um: three orders of 2 n d, n <= 3,
    d <= 5000 nm): equal at 0, within 0.003 near it, within 0.017 of the DC term everywhere (the
    paper's four lobes: 0.036 and 0.16), and past 30 um, where the transform has died out, within
    2e-4 (the lobes do not ring)."""
    lam, w = spectral.cmfs(1)
    opd = np.arange(0.0, 90001.0, 25.0)
    exact = np.exp(2j * np.pi * opd[:, None] / lam) @ w
    fit = np.stack([re + 1j * im for re, im in tf.sensitivity(NumpyOps(), opd)], -1)
    err = np.abs(fit - exact)
    assert err[opd <= 300].max() < 0.0031  # measured 0.00305
    np.testing.assert_allclose(err.max(0), [0.017, 0.014, 0.008], atol=5e-4)  # measured 0.01708 / 0.01408 / 0.00772
    assert err[opd >= 30000].max() < 2e-4  # measured 1.8e-4


def test_the_lobes_are_the_fitters_least_squares_optimum():
    """SENSITIVITY_LOBES is what ``python -m lamella_dev.thin_film_fit --lobes 3`` prints: the
    fitter evaluates the lobes as the model does, its cost at the constants is 1/98 of the
    paper's four lobes', and least squares started from them gains nothing beyond their rounding."""
    from scipy.optimize import least_squares

    from lamella_dev import thin_film_fit as fit

    opd = np.arange(0.0, fit.OPD_MAX_NM + 1.0, fit.OPD_STEP_NM)
    model = np.stack([re + 1j * im for re, im in tf.sensitivity(NumpyOps(), opd)], -1)
    np.testing.assert_allclose(fit.rgb_sensitivity(tf.SENSITIVITY_LOBES, opd), model, rtol=0, atol=1e-13)
    target = fit.exact_sensitivity(opd)

    def problem(lobes):
        axes, p = fit._from_lobes(lobes)
        res, jac = fit._problem(axes, opd, target)
        return res, jac, p

    res, jac, p = problem(tf.SENSITIVITY_LOBES)
    cost = 0.5 * float(np.sum(res(p) ** 2))
    paper_res, _, paper_p = problem(fit.PAPER_LOBES)
    assert 0.0315 < cost < 0.0316 and 3.08 < 0.5 * float(np.sum(paper_res(paper_p) ** 2)) < 3.09
    refined = least_squares(res, p, jac=jac, method="lm", max_nfev=30)
    assert refined.cost > (1.0 - 2e-5) * cost, (refined.cost, cost)  # measured 1e-5


def test_the_airy_series_of_the_reference_is_the_exact_sum():
    """The Belcour and Barla series (Eq. 10) with many orders, per wavelength, equals the exact Airy
    reflectance: the phases (both reflections, the conductor's included) are right."""
    c = np.cos(np.radians([0.0, 30.0, 60.0, 85.0]))[:, None]
    d = np.array([0.0, 100.0, 350.0, 1000.0])[None, :]
    for kw in (dict(n_below=1.0), dict(n_below=1.5), dict(n_below=3.0), dict(eta=GOLD[0], k=GOLD[1])):
        for film in (1.33, 2.4):
            exact = spectral.film_reflectance_rgb(c, 1.0, film, d, step_nm=5, **kw)
            series = spectral.series_reflectance_rgb(c, 1.0, film, d, orders=400, step_nm=5, **kw)
            np.testing.assert_allclose(series, exact, rtol=0, atol=1e-12)


def test_the_reference_maps_a_flat_spectrum_to_grey_and_a_bare_interface_to_fresnel():
    c = np.cos(np.radians(np.linspace(0.0, 89.0, 30)))
    for n_above, n_below in [(1.0, 1.5), (1.5, 1.0), (1.0, 2.4)]:
        want = bare_rgb(c, n_above, n_below)
        for film, d in [(n_below, 700.0), (1.8, 0.0)]:
            np.testing.assert_allclose(spectral.film_reflectance_rgb(c, n_above, film, d, n_below=n_below), want,
                                       rtol=0, atol=1e-13)
    lam = spectral.cmfs(1)[0]
    assert np.allclose(spectral._channel_wavelengths(), spectral.CHANNEL_WAVELENGTHS, atol=0.05)
    np.testing.assert_allclose(spectral.rgb_to_spectrum((1.0, 2.0, 3.0), np.array(spectral.CHANNEL_WAVELENGTHS)),
                               [1.0, 2.0, 3.0])
    assert spectral.rgb_to_spectrum((1.0, 2.0, 3.0), lam)[[0, -1]].tolist() == [3.0, 1.0]


# ------------------------------------------------------------------ traced == numpy
def _traced(conductor: bool):
    t = Tracer()
    names = ["cos_i", "n_above", "film_ior", "thickness"] + (
        ["eta_r", "eta_g", "eta_b", "k_r", "k_g", "k_b"] if conductor else ["n_below"])
    x = {n: t.input(n) for n in names}
    return t, names, _run(t, x, conductor)


def _run(ops, x, conductor):
    if conductor:
        eta = RGB(x["eta_r"], x["eta_g"], x["eta_b"])
        k = RGB(x["k_r"], x["k_g"], x["k_b"])
        return list(tf.film_reflectance_conductor(ops, x["cos_i"], x["n_above"], x["film_ior"], x["thickness"], eta, k))
    return list(tf.film_reflectance_dielectric(ops, x["cos_i"], x["n_above"], x["film_ior"], x["thickness"], x["n_below"]))


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("conductor", [False, True], ids=["dielectric", "conductor"])
def test_the_traced_graph_is_the_numpy_backend_bit_for_bit(conductor, dtype):
    t, names, outputs = _traced(conductor)
    assert all(isinstance(o, Expr) for o in outputs)
    assert len(t.live_nodes(outputs)) <= (1090 if conductor else 470)  # measured 1084 and 468
    rng = np.random.default_rng(7)
    n = 4000
    values = {"cos_i": np.concatenate([[0.0, 1.0], rng.uniform(0.0, 1.0, n - 2)]),
              "n_above": rng.choice([1.0, 1.33, 1.5], n), "film_ior": rng.uniform(1.0, 3.0, n),
              "thickness": np.concatenate([[0.0, 0.5], rng.uniform(0.0, 5000.0, n - 2)])}
    if conductor:
        values.update({f"eta_{c}": rng.uniform(0.05, 3.0, n) for c in "rgb"})
        values.update({f"k_{c}": rng.uniform(0.0, 8.0, n) for c in "rgb"})
    else:
        values["n_below"] = rng.choice([1.0, 1.33, 1.5, 2.4], n)
    ops = NumpyOps(dtype)
    got = t.evaluate(outputs, ops, values)
    want = _run(ops, {k: ops.input(k, v) for k, v in values.items()}, conductor)
    for a, b in zip(got, want):
        assert a.dtype == dtype
        np.testing.assert_array_equal(a, b)


def test_a_constant_thickness_of_zero_traces_to_the_bare_interface_only():
    """Structure folds: with d = 0 no film code is emitted (no exp, cos or sin); with d >= 1 nm
    the bare interface is not."""
    for conductor in (False, True):
        t = Tracer()
        x = {"cos_i": t.input("cos_i"), "n_above": 1.0, "film_ior": 1.33, "thickness": 0.0, "n_below": 1.5,
             "eta_r": 0.2, "eta_g": 0.4, "eta_b": 1.4, "k_r": 4.0, "k_g": 2.4, "k_b": 1.6}
        live = t.live_nodes(_run(t, x, conductor))
        assert not {n.op for n in live} & {"exp", "cos", "sin"}
    t = Tracer()
    x.update(cos_i=t.input("cos_i"), thickness=400.0)
    bare = fresnel_dielectric(t, x["cos_i"], 1.5)  # hash-consed: the film's bare term would be this node
    live = t.live_nodes(_run(t, x, False))
    assert {n.op for n in live} >= {"exp", "cos"} and "sin" not in {n.op for n in live}
    assert id(bare) not in {id(n) for n in live}


# ------------------------------------------------------------------ against the spectral ground truth
ANGLES = np.arange(0.0, 86.0, 5.0)
THICKNESS = np.arange(0.0, 1001.0, 10.0)
FILMS = (1.33, 1.5, 2.0, 2.4)
SUBSTRATES = {"air (n 1.0)": dict(n_below=1.0), "glass (n 1.5)": dict(n_below=1.5), "gold": dict(conductor=GOLD)}

# Measured (1 nm reference, the grid above, n_above = 1), the thresholds just above: max |dRGB|,
# mean |dRGB| (per point, the worst channel), mean CIEDE2000, and max |dRGB| over 0-60 degrees.
# The reference is clipped to [0, 1] as the model is (a Rec.709 channel of a saturated film can
# fall below 0 or pass 1). For the dielectrics what remains is about equally the fit of the
# sensitivities (test_the_gaussian_fit_against_the_exact_transform_of_the_colour_matching_functions)
# and the series' truncation after m = 3, which makes the max, at 75-85 degrees (r_123 is large
# there). With the paper's four lobes the mean |dRGB| was 0.0077, 0.0104, 0.0162, 0.0192 in air and
# 0.0015, 0, 0.0057, 0.0099 on glass, the mean CIEDE2000 1.6-2.6 and 1.0-1.9. For gold most of the
# error is the RGB index made spectral: the exact colour of the film on a constant index per channel
# (what the model assumes, ``GOLD_PER_CHANNEL`` below) is itself mean 0.031-0.034, dE00 2.05-2.27 and
# up to 0.051-0.084 over 0-60 degrees from this reference, which the model now sits at (with the
# paper's lobes its errors happened to offset part of that: 0.0309-0.0329, 2.06-2.12).
AGREEMENT = {
    ("air (n 1.0)", 1.33): (0.0985, 0.0019, 0.17, 0.00055),
    ("air (n 1.0)", 1.5): (0.1097, 0.0020, 0.18, 0.0013),
    ("air (n 1.0)", 2.0): (0.1082, 0.0023, 0.24, 0.0069),
    ("air (n 1.0)", 2.4): (0.0983, 0.0026, 0.28, 0.0154),
    ("glass (n 1.5)", 1.33): (0.0002, 0.00006, 0.03, 0.00012),
    ("glass (n 1.5)", 1.5): (1e-12, 1e-12, 1e-9, 1e-12),
    ("glass (n 1.5)", 2.0): (0.00075, 0.00023, 0.06, 0.00075),
    ("glass (n 1.5)", 2.4): (0.0023, 0.00055, 0.10, 0.0023),
    ("gold", 1.33): (0.0896, 0.0313, 2.09, 0.0510),
    ("gold", 1.5): (0.1332, 0.0313, 2.12, 0.0581),
    ("gold", 2.0): (0.1767, 0.0341, 2.27, 0.0758),
    ("gold", 2.4): (0.0940, 0.0343, 2.28, 0.0842),
}
# Gold against a reference whose index is each channel's constant, channel by channel (what the RGB
# model assumes): the film's own error, max (at grazing incidence: the truncation) and mean |dRGB|
# (the paper's lobes: 0.0045-0.0100); and the two references' difference at d = 0, no film (the RGB
# index made spectral: 0.0355).
GOLD_PER_CHANNEL = {1.33: (0.1026, 0.0012), 1.5: (0.1406, 0.0015), 2.0: (0.1765, 0.0022), 2.4: (0.1560, 0.0025)}


def _lab(rgb):
    import colour

    xyz = colour.RGB_to_XYZ(rgb, colour.RGB_COLOURSPACES["sRGB"], apply_cctf_decoding=False)
    return colour.XYZ_to_Lab(xyz, colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"])


def _delta_e(a, b):
    import colour

    return colour.delta_E(_lab(a), _lab(b), method="CIE 2000")


def _reference(c, film, d, kw):
    if "conductor" in kw:
        eta, k = kw["conductor"]
        return spectral.film_reflectance_rgb(c, 1.0, film, d, eta=eta, k=k, step_nm=STEP_NM)
    return spectral.film_reflectance_rgb(c, 1.0, film, d, n_below=kw["n_below"], step_nm=STEP_NM)


def _per_channel_reference(c, film, d):
    eta, k = GOLD
    return np.stack([spectral.film_reflectance_rgb(c, 1.0, film, d, eta=lambda lam, v=eta[i]: np.full_like(lam, v),
                                                   k=lambda lam, v=k[i]: np.full_like(lam, v), step_nm=STEP_NM)[..., i]
                     for i in range(3)], -1)


def agreement():
    """{(substrate, film_ior): (max, mean, mean dE00, max over 0-60 degrees, clip)} and for gold
    {film_ior: (max, mean)} against the per-channel reference, with the d = 0 floor."""
    c, d = np.meshgrid(np.cos(np.radians(ANGLES)), THICKNESS, indexing="ij")
    low = ANGLES <= 60.0
    table, gold, floor = {}, {}, 0.0
    for name, kw in SUBSTRATES.items():
        for film in FILMS:
            got = model_rgb(c, 1.0, film, d, **kw)
            ref = _reference(c, film, d, kw)
            clipped = np.clip(ref, 0.0, 1.0)
            err = np.abs(got - clipped).max(-1)
            table[name, film] = (float(err.max()), float(err.mean()), float(np.mean(_delta_e(got, clipped))),
                                 float(err[low].max()), float(np.abs(ref - clipped).max()))
            if "conductor" in kw:
                per = np.clip(_per_channel_reference(c, film, d), 0.0, 1.0)
                e = np.abs(got - per).max(-1)
                gold[film] = (float(e.max()), float(e.mean()))
                floor = max(floor, float(np.abs(per - clipped)[:, 0].max()))
    return table, gold, floor


@pytest.fixture(scope="module")
def measured():
    return agreement()


def test_agreement_with_the_spectral_reference(measured):
    table, gold, floor = measured
    for key, (mx, mean, de, low, _) in table.items():
        t_mx, t_mean, t_de, t_low = AGREEMENT[key]
        assert mx <= t_mx and mean <= t_mean and de <= t_de and low <= t_low, (key, mx, mean, de, low)
    for film, (mx, mean) in gold.items():
        t_mx, t_mean = GOLD_PER_CHANNEL[film]
        assert mx <= t_mx and mean <= t_mean, (film, mx, mean)
    assert 0.035 < floor < 0.036


def _hue(rgb):
    lab = _lab(rgb)
    return np.degrees(np.arctan2(lab[..., 2], lab[..., 1])) % 360.0, np.hypot(lab[..., 1], lab[..., 2])


def test_a_soap_film_shows_newtons_colours():
    """A soap film (n 1.33) in air, seen at 10 degrees: the reference's colours follow Newton's
    sequence with thickness (yellow, magenta, blue, green, yellow, magenta, green, magenta; by
    CIELAB hue), the model's hue classes agree, and wherever the colour is clearly chromatic
    (chroma > 15) the model's hue is within 0.3 degrees of the reference's clipped to [0, 1] as the
    model is (measured 0.29; the paper's lobes: 8.1). Clipping itself moves the reference's hue by
    up to 9 degrees here (a negative red at 450 nm)."""
    c = math.cos(math.radians(10.0))
    classes = {"yellow": (50, 100), "green": (120, 165), "blue": (230, 280), "magenta": (300, 360)}
    sequence = [(150, "yellow"), (200, "magenta"), (250, "blue"), (300, "green"), (350, "yellow"), (400, "magenta"),
                (500, "green"), (600, "magenta")]
    d = np.array([t for t, _ in sequence], dtype=np.float64)
    for rgb in (spectral.film_reflectance_rgb(c, 1.0, 1.33, d, n_below=1.0), model_rgb(c, 1.0, 1.33, d, n_below=1.0)):
        hue, _ = _hue(rgb)
        for (t, name), h in zip(sequence, hue):
            lo, hi = classes[name]
            assert lo <= h < hi, (t, name, h)
    d = np.arange(100.0, 1001.0, 10.0)
    h_ref, chroma = _hue(np.clip(spectral.film_reflectance_rgb(c, 1.0, 1.33, d, n_below=1.0), 0.0, 1.0))
    h_model, _ = _hue(model_rgb(c, 1.0, 1.33, d, n_below=1.0))
    diff = np.abs((h_model - h_ref + 180.0) % 360.0 - 180.0)[chroma > 15.0]
    assert diff.max() < 0.3, diff.max()


def main():
    table, gold, floor = agreement()
    print(f"RGB model against the spectral reference ({STEP_NM} nm), n_above 1, angles 0-85 deg (5), "
          "thickness 0-1000 nm (10); |dRGB| is the worst channel per point")
    print("| substrate | film ior | max abs | mean abs | mean dE00 | max abs 0-60 deg | reference clipped by |")
    print("|---|---|---|---|---|---|---|")
    for (name, film), (mx, mean, de, low, clip) in table.items():
        print(f"| {name} | {film} | {mx:.4f} | {mean:.4f} | {de:.2f} | {low:.4f} | {clip:.3f} |")
    print("gold against the per-channel reference (film_ior: max, mean):",
          {f: tuple(round(v, 4) for v in x) for f, x in gold.items()}, f"; the references differ by {floor:.4f} at d = 0")


if __name__ == "__main__":
    main()
