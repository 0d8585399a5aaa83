"""The stochastic reference with thin films (``lamella_dev.reference``: a spectral walk, one
wavelength per packet, weighted per channel by the colour matching functions) against exact
results: the film's Airy reflectance per wavelength (``lamella_dev.thin_film_spectral``), closed-form
smooth stacks per wavelength, energy conservation of lossless filmed stacks (smooth, and rough with
Heitz et al. 2016's walk on the microsurface), Walter et al. 2007's single rough interface with the
film's reflectance, the consistency of the next-event estimate with the albedo, reciprocity (in
reflection, and in transmission from either side of a rough film); and a stack without a film
taking the code path it took before films (its numbers within float noise of the stored ones)."""
import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from lamella_dev import golden
from lamella_dev import microsurface as M
from lamella_dev import reference as R
from lamella_dev import suite
from lamella_dev import thin_film_spectral as T

from .stacks import GOLD
from .test_reference import upper, walter

MIRROR = {"type": "conductor", "eta": [1.0, 1.0, 1.0], "k": [1e6, 1e6, 1e6]}
SOAP = {"film_thickness": 400.0, "film_ior": 1.33}


def incidences(*degrees):
    return np.stack([suite.incident(d) for d in degrees])


def coat(ior=1.5, roughness=0.0, **kw):
    return {"type": "coat", "ior": ior, "roughness": roughness, **kw}


def within(mean, want, err, k=4.5, slack=0.0):
    return bool(np.all(np.abs(mean - want) <= k * err + slack))


def per_channel(values, fn):
    """Channel c of ``fn(v_c)`` for an RGB ``values``: the reference holds everything that is not a
    film per channel (a conductor's eta and k), so channel c is the film spectrum over the
    conductor of channel c's index, weighted by channel c."""
    return np.array([fn(v)[..., c] for c, v in enumerate(values)]).T


# ---------------------------------------------------------------- 1. no film: the path of before films
def _no_film_runs():
    wo = np.array([[0.3, 0.1, 0.9], [-0.5, 0.2, 0.7], [0.1, -0.6, 0.5], [0.2, 0.1, -0.9]])
    wo = wo / np.linalg.norm(wo, axis=1, keepdims=True)
    for name, interfaces in [("gold_coated", "single"), ("rough_glass_plate", "multiple"), ("milky_coat_d01", "single"),
                             ("varnished_wood", "single"), ("three_coats", "multiple")]:
        s = suite.load(name)
        yield name, "eval", R.eval_brdf_cos(s, suite.incident(30.0), wo, spp=64, seed=1, interfaces=interfaces)
        yield name, "albedo", R.albedo(s, incidences(0.0, 60.0), spp=3000, seed=2, interfaces=interfaces,
                                       side="transmitted" if name == "rough_glass_plate" else "reflected")


# (mean, stderr) of each run as the reference of before films computed them (it knew nothing of
# them); another processor computes other last bits (numpy's kernels), a different path moves them
# by the estimate's own noise (about 1e-3 relative at these walker counts), so they compare within
# 1e-9 relative
NO_FILM_RUNS = Path(__file__).parents[1] / "references" / "no_film_walks.json"
SAME_PATH = golden.Tolerance(rtol=1e-9, atol=1e-12)


def _no_film_changes(runs) -> list[str]:
    stored = json.loads(NO_FILM_RUNS.read_text())["runs"]
    changes = []
    for name, kind, (mean, err) in runs:
        want = stored[f"{name} {kind}"]
        for what, got in (("mean", mean), ("stderr", err)):
            change = golden.number_changes(want[what], got, SAME_PATH)
            if change is not None:
                changes.append(f"{name} {kind} {what}: {change}")
    return changes


def test_a_stack_without_a_film_takes_the_path_it_took_before_films():
    """Same seed, same numbers as before films, within ``SAME_PATH``; and the check is one a
    different path fails: one walker more per direction moves them far beyond it."""
    runs = list(_no_film_runs())
    assert _no_film_changes(runs) == []
    name, kind, (mean, err) = runs[0]
    s = suite.load(name)
    wo = np.array([[0.3, 0.1, 0.9], [-0.5, 0.2, 0.7], [0.1, -0.6, 0.5], [0.2, 0.1, -0.9]])
    other = R.eval_brdf_cos(s, suite.incident(30.0), wo / np.linalg.norm(wo, axis=1, keepdims=True), spp=65, seed=1)
    assert len(_no_film_changes([(name, kind, other)])) == 2


def test_the_path_check_holds_on_another_processor():
    """The walks run with numpy's processor-dependent kernels returning other last bits
    (``golden.numpy_of_another_processor``, up to 4 ulps): still the path of before films, no
    walker's random decision flipped; and the noise did reach them (not bit-equal)."""
    with golden.numpy_of_another_processor():
        runs = list(_no_film_runs())
    assert _no_film_changes(runs) == []
    stored = json.loads(NO_FILM_RUNS.read_text())["runs"]
    assert any(not np.array_equal(np.asarray(stored[f"{n} {k}"]["mean"]), mean) for n, k, (mean, _) in runs)


def test_a_zero_thickness_film_is_no_film():
    d = {"layers": [coat(1.5, 0.2, film_thickness=0.0, film_ior=2.0)], "base": dict(GOLD, roughness=0.3)}
    bare = {"layers": [coat(1.5, 0.2)], "base": dict(GOLD, roughness=0.3)}
    wi = suite.incident(40.0)
    wo = upper(4)[0]
    for a, b in zip(R.eval_brdf_cos(d, wi, wo, spp=32, seed=3), R.eval_brdf_cos(bare, wi, wo, spp=32, seed=3)):
        np.testing.assert_array_equal(a, b)
    assert not R._Layers(R.Stack.coerce(d)).filmed


# ---------------------------------------------------------------- the film's reflectance per wavelength
@pytest.mark.parametrize("n_i,film,n_t", [
    (1.0, 1.33, 1.5),        # soap on glass
    (1.5, 1.33, 1.0),        # from inside the glass: total internal reflection past 41.8 degrees
    (1.5, 1.0, 1.5),         # an air gap: frustrated total internal reflection (the film's wave evanescent)
    (1.33, 2.3, 1.0),
    (1.0, 2.3, (2.74, 3.8)),  # an oxide on titanium (red channel)
    (1.5, 1.0, (0.143, 3.983)),  # an evanescent film over gold
])
def test_the_film_reflectance_is_the_airy_sum(n_i, film, n_t):
    """``microsurface.film_fresnel`` (one wavelength per element, real arithmetic where the film's
    wave propagates) against ``thin_film_spectral.film_spectrum`` (complex amplitudes on the whole
    spectrum), at every wavelength, from normal to grazing incidence."""
    lam = T.cmfs(1)[0]
    for cos in (1.0, 0.8, 0.5, 0.2, 0.02):
        for d in (30.0, 400.0, 2000.0):
            if isinstance(n_t, tuple):
                _, want = T.film_spectrum(cos, n_i, film, d, eta=(n_t[0],) * 3, k=(n_t[1],) * 3)
                got = M.film_fresnel(np.full(lam.shape, cos), n_i, film, d, complex(*n_t), lam)
            else:
                _, want = T.film_spectrum(cos, n_i, film, d, n_below=n_t)
                got = M.film_fresnel(np.full(lam.shape, cos), n_i, film, d, n_t, lam)
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert M.film_fresnel(np.array([0.0]), n_i, film, 100.0, 1.5, np.array([500.0]))[0] == 1.0  # grazing


def test_a_lossless_film_reflects_alike_from_both_sides():
    """Stokes: a lossless stratified medium transmits, hence reflects, the same from both sides at
    Snell-related angles: what the exit series takes for granted from above."""
    c1 = np.linspace(0.05, 1.0, 9)[:, None]
    lam = np.array([380.0, 450.0, 550.0, 700.0])[None, :]
    c3 = np.sqrt(1.0 - (1.0 / 1.5) ** 2 * (1.0 - c1 * c1))
    np.testing.assert_allclose(M.film_fresnel(c1, 1.0, 1.33, 400.0, 1.5, lam),
                               M.film_fresnel(c3, 1.5, 1.33, 400.0, 1.0, lam), atol=1e-13)


def test_the_wavelength_weights_average_to_one():
    """sum_lambda p(lambda) W_c / p = 1 per channel: a spectrally flat reflectance gives the same
    value in every channel (``thin_film_spectral.spectrum_to_rgb``'s normalisation)."""
    lam, cdf, ratio = R._spectrum()
    p = np.diff(np.concatenate([[0.0], cdf]))
    np.testing.assert_allclose((p[:, None] * ratio).sum(0), 1.0, atol=1e-12)
    np.testing.assert_allclose(p[:, None] * ratio, T.cmfs(1)[1], atol=1e-15)


# ---------------------------------------------------------------- 2. one smooth filmed interface
def test_a_smooth_filmed_dielectric_reflects_the_film_colour():
    d = {"layers": [], "base": {"type": "dielectric", "ior": 1.5, **SOAP}}
    wi = incidences(0.0, 40.0, 75.0)
    r, er = R.albedo(d, wi, spp=200_000, seed=21)
    t, et = R.albedo(d, wi, spp=200_000, seed=21, side="transmitted")
    want = T.film_reflectance_rgb(wi[:, 2], 1.0, 1.33, 400.0, n_below=1.5)
    assert within(r, want, er), (r, want, er)
    assert within(t, 1.0 - want, et), (t, 1.0 - want, et)
    assert (er < 0.003).all()


def test_a_smooth_filmed_conductor_reflects_the_film_colour_per_channel():
    eta, k = [2.74, 2.54, 2.2], [3.8, 3.43, 3.0]
    d = {"layers": [], "base": {"type": "conductor", "eta": eta, "k": k, "film_thickness": 250.0, "film_ior": 2.3}}
    wi = incidences(0.0, 40.0, 75.0)
    r, er = R.albedo(d, wi, spp=100_000, seed=22)
    want = per_channel(list(zip(eta, k)), lambda ek: T.film_reflectance_rgb(wi[:, 2], 1.0, 2.3, 250.0, eta=(ek[0],) * 3,
                                                                           k=(ek[1],) * 3))
    assert within(r, want, er), (r, want, er)
    # the film changes the colour: far from the bare metal's
    bare, _ = R.albedo({"layers": [], "base": {"type": "conductor", "eta": eta, "k": k}}, wi, spp=1000, seed=22)
    assert np.abs(want - bare).max() > 0.1


# ---------------------------------------------------------------- 3. smooth filmed stacks in closed form
def _plate(cos0, top=None, bottom=None):
    """R and T per wavelength of a glass plate (ior 1.5, air on both sides), each interface bare
    or under a film ((ior, nm)): the film's interference is coherent, the plate's reflections
    add as energies. The top reflects the same from inside (a lossless film)."""
    lam = T.cmfs(1)[0]
    cos1 = np.sqrt(1.0 - (1.0 - cos0 ** 2) / 1.5 ** 2)
    r1 = (T.film_spectrum(cos0, 1.0, top[0], top[1], n_below=1.5)[1] if top
          else T.film_spectrum(cos0, 1.0, 1.0, 0.0, n_below=1.5)[1])
    r2 = (T.film_spectrum(cos1, 1.5, bottom[0], bottom[1], n_below=1.0)[1] if bottom
          else np.broadcast_to(T.film_spectrum(cos1, 1.5, 1.0, 0.0, n_below=1.0)[1], (len(cos0), lam.size)))
    den = 1.0 - r1 * r2
    return T.spectrum_to_rgb(r1 + (1.0 - r1) ** 2 * r2 / den), T.spectrum_to_rgb((1.0 - r1) * (1.0 - r2) / den)


@pytest.mark.parametrize("top,bottom", [(SOAP, None), (None, {"film_thickness": 150.0, "film_ior": 2.0}),
                                        (SOAP, {"film_thickness": 150.0, "film_ior": 2.0})])
def test_a_filmed_glass_plate_is_its_closed_form(top, bottom):
    """Light reflected inside the plate meets the top film from below: a walk that took the bare
    interface there, or the film's reflectance at the wrong side's angle, misses this."""
    d = {"layers": [coat(1.5, **(top or {}))], "base": {"type": "dielectric", "ior": 1.0, **(bottom or {})}}
    wi = incidences(0.0, 45.0, 80.0)
    r, er = R.albedo(d, wi, spp=100_000, seed=31)
    t, et = R.albedo(d, wi, spp=100_000, seed=31, side="transmitted")
    want_r, want_t = _plate(wi[:, 2], top and (top["film_ior"], top["film_thickness"]),
                            bottom and (bottom["film_ior"], bottom["film_thickness"]))
    assert within(r, want_r, er), (r, want_r, er)
    assert within(t, want_t, et), (t, want_t, et)


def test_lossless_smooth_filmed_stacks_conserve_energy():
    """A filmed coat over a perfect mirror reflects everything, in every channel; smooth filmed
    coats over a filmed glass substrate reflect and transmit everything between them."""
    wi = incidences(0.0, 50.0, 85.0)
    mirror = {"layers": [coat(1.5, **SOAP)], "base": dict(MIRROR, film_thickness=200.0, film_ior=2.0)}
    r, er = R.albedo(mirror, wi, spp=50_000, seed=32)
    assert within(r, 1.0, er, slack=1e-9), (r, er)
    glass = {"layers": [coat(1.4, film_thickness=300.0, film_ior=2.2), coat(1.7, film_thickness=120.0, film_ior=1.3)],
             "base": {"type": "dielectric", "ior": 1.5, "film_thickness": 500.0, "film_ior": 1.33}}
    r, er = R.albedo(glass, wi, spp=50_000, seed=33)
    t, et = R.albedo(glass, wi, spp=50_000, seed=33, side="transmitted")
    assert within(r + t, 1.0, er + et), (r + t, er + et)
    assert (r > 0.02).all() and (t > 0.02).all()


# ---------------------------------------------------------------- 4. rough filmed interfaces
def test_rough_filmed_interfaces_conserve_energy_with_the_microsurface_walk():
    """Heitz et al. 2016's walk with a film on every facet: lossless rough filmed stacks lose nothing
    (R + T = 1, and R = 1 over a mirror), in every channel."""
    wi = incidences(0.0, 60.0, 85.0)
    glass = {"layers": [coat(1.4, 0.4, **SOAP)], "base": {"type": "dielectric", "ior": 1.5, "roughness": [0.6, 0.3],
                                                           "rotation": 0.5, "film_thickness": 250.0, "film_ior": 2.1}}
    r, er = R.albedo(glass, wi, spp=30_000, seed=41, interfaces="multiple")
    t, et = R.albedo(glass, wi, spp=30_000, seed=41, side="transmitted", interfaces="multiple")
    assert within(r + t, 1.0, er + et, slack=1e-3), (r + t, er + et)
    mirror = {"layers": [coat(1.5, 0.5, **SOAP)], "base": dict(MIRROR, roughness=0.7, film_thickness=300.0, film_ior=2.3)}
    r, er = R.albedo(mirror, wi, spp=20_000, seed=42, interfaces="multiple")
    assert within(r, 1.0, er, slack=1e-3), (r, er)


def _film_rgb_at(cos, spectrum):
    """spectrum_to_rgb of ``spectrum(cos_array) -> (..., L)`` at each cosine, safe at 0."""
    return T.spectrum_to_rgb(spectrum(np.clip(cos, 1e-9, 1.0)))


def test_a_single_rough_filmed_interface_is_walter_2007_with_the_film():
    """One event, counted exactly by next-event estimation for its wavelength: the estimate is
    Walter et al. 2007 with the film's reflectance at the microfacet's cosine in place of Fresnel's,
    averaged over the wavelengths (reflection F D G2 / (4 |i.z|); transmission (1 - F) times the
    rest)."""
    wi = suite.incident(35.0)
    wo = np.concatenate([upper(3)[0], upper(3)[0] * [1, 1, -1]])
    ax, ay, rot = 0.3, 0.15, 0.4
    d = {"layers": [], "base": {"type": "dielectric", "ior": 1.5, "roughness": [ax, ay], "rotation": rot, **SOAP}}
    mean, err = R.eval_brdf_cos(d, wi, wo, spp=4000, seed=43)
    wib = np.broadcast_to(wi, wo.shape)
    bare = walter(wib, wo, ax, ay, rot, 1.5)  # its Fresnel factor divided out below
    i = wib
    refl = wo[:, 2] > 0
    h = np.where(refl[:, None], i + wo, -(i + 1.5 * wo))
    h = h / np.linalg.norm(h, axis=1, keepdims=True) * np.sign(h[:, 2:3])
    ih = np.sum(i * h, 1)
    f_bare = M._fresnel_dielectric(ih, 1.5)
    f_film = _film_rgb_at(ih, lambda c: T.film_spectrum(c, 1.0, 1.33, 400.0, n_below=1.5)[1])
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(refl[:, None], f_film / f_bare[:, None], (1.0 - f_film) / (1.0 - f_bare[:, None]))
        want = np.where(bare[:, None] > 0.0, bare[:, None] * scale, 0.0)
    assert want.max() > 0.05
    assert within(mean, want, err, slack=1e-12), (mean, want, err)


CONSISTENCY = {
    "smooth filmed coat over rough gold": {"layers": [coat(1.5, film_thickness=350.0, film_ior=1.33)],
                                           "base": dict(GOLD, roughness=0.3)},
    "rough filmed coat over rough filmed gold": {"layers": [coat(1.5, 0.3, **SOAP)],
                                                 "base": dict(GOLD, roughness=0.3, film_thickness=250.0, film_ior=2.3)},
    "smooth filmed absorbing coat over diffuse": {"layers": [coat(1.33, film_thickness=300.0, film_ior=1.5, thickness=0.3,
                                                                  sigma_a=[0.1, 0.3, 0.6])],
                                                  "base": {"type": "diffuse", "albedo": [0.5, 0.3, 0.2]}},
}


@pytest.mark.parametrize("interfaces", R.INTERFACES)
@pytest.mark.parametrize("name", list(CONSISTENCY))
def test_eval_integrates_to_the_albedo_with_films(name, interfaces):
    """The next-event estimate (the exit series with its films at each packet's wavelength, the
    rough interfaces' densities with the film's reflectance) integrates over the hemisphere to the
    albedo that counts escaping packets."""
    if interfaces == "multiple" and name.endswith("diffuse"):
        pytest.skip("no rough interface: the same numbers as single")
    d = CONSISTENCY[name]
    wo, dw = upper(16)
    wi = suite.incident(35.0)
    mean, err = R.eval_brdf_cos(d, wi, wo, spp=64, seed=44, interfaces=interfaces)
    integral, ierr = (mean * dw).sum(0), np.sqrt(((err * dw) ** 2).sum(0))
    alb, aerr = R.albedo(d, wi, spp=60_000, seed=45, exclude_delta=True, interfaces=interfaces)
    tol = 4.5 * np.sqrt(ierr ** 2 + aerr[0] ** 2) + 0.006  # + the grid's quadrature of lobes alpha >= 0.3
    assert (np.abs(integral - alb[0]) <= tol).all(), (integral, alb[0], tol)


def test_a_film_on_a_diffuse_base_is_refused_naming_the_base():
    """A diffuse base has no interface to carry a film (its schema has none); were it given one,
    the reference would say so rather than ignore it."""
    stack = SimpleNamespace(coats=[], base=SimpleNamespace(type="diffuse", film_thickness=100.0))
    with pytest.raises(ValueError, match="base: .*film"):
        R._Layers(stack)


@pytest.mark.parametrize("interfaces", R.INTERFACES)
def test_reciprocity_with_films(interfaces):
    """f(a, b) = f(b, a) through rough filmed interfaces, which light crosses both ways: the film
    seen from below (in the walk on the microsurface too, where a refracted path meets the facets
    again from inside) must be the film's own reflectance from that side."""
    d = {"layers": [coat(1.5, 0.5, film_thickness=300.0, film_ior=2.0)],
         "base": dict(GOLD, roughness=0.4, film_thickness=250.0, film_ior=2.3)}
    a = np.array([[0.3, 0.2, 0.93], [0.7, -0.4, 0.59]])
    b = np.array([[-0.5, 0.1, 0.86], [0.1, 0.8, 0.59]])
    a, b = a / np.linalg.norm(a, axis=1, keepdims=True), b / np.linalg.norm(b, axis=1, keepdims=True)
    m1, e1 = R.eval_brdf_cos(d, a, b, spp=30_000, seed=46, interfaces=interfaces)
    m2, e2 = R.eval_brdf_cos(d, b, a, spp=30_000, seed=47, interfaces=interfaces)
    f1, f2 = m1 / b[:, 2:3], m2 / a[:, 2:3]
    s = np.sqrt((e1 / b[:, 2:3]) ** 2 + (e2 / a[:, 2:3]) ** 2)
    assert (np.abs(f1 - f2) <= 4.5 * s).all(), (f1, f2, s)


@pytest.mark.parametrize("interfaces", R.INTERFACES)
def test_transmission_reciprocity_through_a_rough_film(interfaces):
    """f(i -> o) / n_o^2 = f(o -> i) / n_i^2 across a rough filmed interface. Light goes from glass
    to air in the stack scaled by 1 / 1.5 (air above, index 1 / 1.5 below, the film's index scaled
    and its thickness stretched alike keep every phase): there the walk on the microsurface meets
    the facets from the glass side first, so a film taken from the wrong side anywhere in it (the
    walk's refracted paths meet the facets again from inside) breaks the equality."""
    a = {"layers": [], "base": {"type": "dielectric", "ior": 1.5, "roughness": 0.6, "film_thickness": 300.0,
                                "film_ior": 2.25}}
    b = {"layers": [], "base": {"type": "dielectric", "ior": 1.0 / 1.5, "roughness": 0.6, "film_thickness": 450.0,
                                "film_ior": 1.5}}
    i = np.array([[0.3, 0.2, 0.93], [0.7, -0.4, 0.59], [0.0, 0.6, 0.8]])
    o = np.array([[-0.5, 0.1, -0.86], [0.1, 0.8, -0.59], [0.2, -0.3, -0.93]])
    i, o = i / np.linalg.norm(i, axis=1, keepdims=True), o / np.linalg.norm(o, axis=1, keepdims=True)
    flip = np.array([1.0, 1.0, -1.0])
    ma, ea = R.eval_brdf_cos(a, i, o, spp=30_000, seed=48, interfaces=interfaces)
    mb, eb = R.eval_brdf_cos(b, o * flip, i * flip, spp=30_000, seed=49, interfaces=interfaces)
    fa, fb = ma / -o[:, 2:3], 1.5 ** 2 * mb / i[:, 2:3]
    s = np.sqrt((ea / -o[:, 2:3]) ** 2 + (1.5 ** 2 * eb / i[:, 2:3]) ** 2)
    assert fa.max() > 0.4
    assert (np.abs(fa - fb) <= 4.5 * s + 1e-12).all(), (fa, fb, s)
