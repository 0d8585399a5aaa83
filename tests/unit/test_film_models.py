"""A thin film in the models (``models.film``): a smooth filmed interface reflects exactly the film's
RGB reflectance (``models.thin_film``) and that is within the fit's error of the exact spectral
colour; an index-matched film is the bare interface; a lossless filmed stack keeps its energy;
every model runs a film on every kind of interface; the staged shader follows a linked thickness."""
import numpy as np
import pytest

from lamella.core import Stack, api
from lamella.core.backends.evaluate import evaluate_staged
from lamella.core.backends.ir import staging
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.models.thin_film import film_reflectance_conductor, film_reflectance_dielectric
from lamella_dev import suite

GOLD = {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603]}
ANGLES = (0.0, 30.0, 60.0)


def _wi(deg):
    return suite.incident(deg)


@pytest.mark.parametrize("model", ["yamaguchi2019", "belcour2018", "weier2020", "tm2", "tm6", "endf"])
def test_a_smooth_filmed_coat_reflects_the_films_reflectance_at_its_top(model):
    """A smooth coat over a black base: the reflected energy is the filmed top interface's."""
    d = {"layers": [{"ior": 1.5, "film_thickness": 320.0, "film_ior": 1.33}],
         "base": {"type": "diffuse", "albedo": [0.0, 0.0, 0.0]}}
    ops = NumpyOps()
    for deg in ANGLES:
        try:
            got = api.albedo(d, _wi(deg), model)[0]
        except api.UnsupportedStack:
            pytest.skip(f"{model} does not run a coat over a Lambertian base")
        want = np.array(list(film_reflectance_dielectric(ops, np.cos(np.radians(deg)), 1.0, 1.33, 320.0, 1.5)),
                        dtype=float)
        np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-9, err_msg=f"{deg} deg")


def test_a_smooth_filmed_metal_reflects_the_films_reflectance():
    d = {"layers": [], "base": {**GOLD, "film_thickness": 250.0, "film_ior": 1.5}}
    ops = NumpyOps()
    for deg in ANGLES:
        got = api.albedo(d, _wi(deg))[0]
        want = np.array(list(film_reflectance_conductor(ops, np.cos(np.radians(deg)), 1.0, 1.5, 250.0,
                                                        GOLD["eta"], GOLD["k"])), dtype=float)
        np.testing.assert_allclose(got, want, rtol=1e-6, err_msg=f"{deg} deg")


def test_the_models_film_is_within_the_fits_error_of_the_exact_spectral_colour():
    """Against the exact Airy reflectance integrated over the CIE 1931 curves (``thin_film_spectral``):
    a smooth filmed interface, 0-60 degrees, 100-900 nm; the fit's error measured in
    tests/unit/test_thin_film.py is about 0.002 mean |dRGB| for a soap film on glass."""
    from lamella_dev.thin_film_spectral import film_reflectance_rgb

    errs = []
    for t in (100.0, 300.0, 500.0, 900.0):
        d = {"layers": [], "base": {"type": "dielectric", "ior": 1.5, "film_thickness": t, "film_ior": 1.33}}
        for deg in ANGLES:
            got = api.albedo(d, _wi(deg))[0]
            want = np.asarray(film_reflectance_rgb(np.cos(np.radians(deg)), 1.0, 1.33, t, n_below=1.5)).ravel()
            errs.append(np.abs(got - want).max())
    assert max(errs) < 0.003, errs


@pytest.mark.parametrize("model", ["yamaguchi2019", "tm6"])
def test_an_index_matched_film_is_the_bare_interface(model):
    bare = {"layers": [{"ior": 1.5, "roughness": 0.1}], "base": {**GOLD, "roughness": 0.2}}
    filmed = {"layers": [{"ior": 1.5, "roughness": 0.1, "film_thickness": 400.0, "film_ior": 1.5}],
              "base": {**GOLD, "roughness": 0.2}}
    wi = _wi(40.0)
    wo, _ = suite.wo_grid(wi)
    np.testing.assert_allclose(api.evaluate(filmed, wi, wo, model), api.evaluate(bare, wi, wo, model), rtol=1e-9)


@pytest.mark.parametrize("model", ["yamaguchi2019", "tm6", "endf"])
def test_a_filmed_plate_keeps_the_energy_the_bare_plate_keeps(model):
    """A rough glass coat with a film over an air base (a plate): the film moves light between the
    reflected and the transmitted side and loses none (the bare plate's own balance, reflected +
    transmitted, is the model's: 1 for tm6, 0.9966 at 60 degrees for the adding family)."""
    coat = {"ior": 1.5, "roughness": 0.1}
    plate = {"type": "dielectric", "ior": 1.0, "roughness": 0.0}
    filmed = {"layers": [{**coat, "film_thickness": 380.0, "film_ior": 1.33}], "base": plate}
    bare = {"layers": [coat], "base": plate}
    for deg in ANGLES:
        total = [api.albedo(d, _wi(deg), model)[0] + api.albedo(d, _wi(deg), model, "transmitted")[0]
                 for d in (filmed, bare)]
        np.testing.assert_allclose(total[0], total[1], atol=2e-4, err_msg=f"{deg} deg")
        assert not np.allclose(api.albedo(filmed, _wi(deg), model), api.albedo(bare, _wi(deg), model), atol=1e-3)


def test_a_linked_film_thickness_stays_live_and_the_staged_shader_follows_it():
    d = {"layers": [{"ior": 1.33, "roughness": 0.02, "film_thickness": 300.0, "film_ior": 1.47}],
         "base": {"type": "diffuse", "albedo": [0.05, 0.05, 0.05]}}
    st = staging.stage(Stack.from_dict(d), live=["coat0_film_thickness"])
    assert "coat0_film_thickness" in st.live
    wi = _wi(35.0)
    wo, _ = suite.wo_grid(wi)
    for t in (150.0, 450.0):
        want = api.evaluate({**d, "layers": [{**d["layers"][0], "film_thickness": t}]}, wi, wo)
        got = evaluate_staged(st, wi, wo, np.float64, values={"coat0_film_thickness": t})
        assert np.abs(got - want).sum() / want.sum() < 0.01, t
