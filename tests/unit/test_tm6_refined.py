"""tm6_refined (``models.TM6_REFINED``, what ``auto`` runs on scattering stacks): the light no
medium has scattered through the interfaces by yamaguchi_refined, the scattered light by the
six-flux transfer matrices (``transfer_matrix``, ``primary``)."""
import itertools

import numpy as np
import pytest

import lamella.core as lc
from lamella.core.models import TM6_REFINED
from lamella.core.stack import Stack
from lamella_dev import suite

WIS = np.array([suite.incident(d) for d in (0.0, 30.0, 60.0, 80.0, 89.0)])


def _coat(ior, rough, d=None, sigma_a=None, sigma_s=None, g=0.0):
    c = {"type": "coat", "ior": ior, "roughness": rough}
    if d is not None:
        c.update(thickness=d, sigma_a=sigma_a or [0.0] * 3, sigma_s=sigma_s or [0.0] * 3, g=g)
    return c


GOLD = {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603], "roughness": 0.2}


@pytest.mark.parametrize("name", ["frosted_metal", "rotated_60", "three_coats", "tinted_varnish", "varnished_wood"])
def test_without_scattering_it_is_yamaguchi_refined(name):
    """Nothing scatters: every flux is the primary, and the model is yamaguchi_refined exactly."""
    st = suite.load(name)
    a, b = lc.lobes(st, WIS, TM6_REFINED), lc.lobes(st, WIS, "yamaguchi_refined")
    assert a.kinds == b.kinds
    np.testing.assert_array_equal(a.weight, b.weight)
    np.testing.assert_array_equal(a.alpha_x, b.alpha_x)


def test_a_vanishing_medium_hands_over_to_yamaguchi_refined():
    """sigma_s -> 0: the scattered families vanish and the primary's extinction is the absorption
    alone, so the albedo tends to the clear coat's under yamaguchi_refined. (Over a smooth base: a
    rough conductor's multiply scattered light goes up through ``diffuse_transport``, which takes a
    scattering interior as diffuse both ways and an absorbing one direction by direction, in every
    model alike.)"""
    smooth_gold = dict(GOLD, roughness=0.0)
    clear = {"layers": [_coat(1.5, 0.2, 1.0, sigma_a=[0.3, 0.1, 0.05])], "base": smooth_gold}
    faint = {"layers": [_coat(1.5, 0.2, 1.0, sigma_a=[0.3, 0.1, 0.05], sigma_s=[1e-7] * 3, g=0.5)],
             "base": smooth_gold}
    assert lc.Stack.from_dict(faint).has_scattering
    np.testing.assert_allclose(lc.albedo(faint, WIS, TM6_REFINED), lc.albedo(clear, WIS, "yamaguchi_refined"),
                               atol=1e-6)


def test_the_primary_lobes_are_yamaguchi_refineds_with_the_media_as_extinction():
    """The model's first lobes are yamaguchi_refined's on the stack whose media only extinguish
    (sigma_a + sigma_s, nothing scattered): the primary model's lobes, unchanged, but for the rough
    base's multiply scattered light, which leaves diffusely and is scattered by the media on its
    way up (more of it comes out than through a medium that only extinguishes)."""
    st = suite.load("milky_coat_d01")
    d = st.to_dict()
    for layer in d["layers"]:
        layer["sigma_a"] = [a + s for a, s in zip(layer.get("sigma_a", [0.0] * 3), layer["sigma_s"])]
        layer["sigma_s"] = [0.0] * 3
    primary = lc.lobes(Stack.from_dict(d), WIS, "yamaguchi_refined")
    got = lc.lobes(st, WIS, TM6_REFINED)
    k = len(primary.kinds)
    assert got.kinds[:k] == primary.kinds and len(got.kinds) > k
    glossy = [j for j in range(k) if primary.kinds[j] != "diffuse"]
    diffuse = [j for j in range(k) if primary.kinds[j] == "diffuse"]
    assert glossy and diffuse
    np.testing.assert_allclose(got.weight[:, glossy], primary.weight[:, glossy], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(got.alpha_x[:, glossy], primary.alpha_x[:, glossy], rtol=1e-12, atol=1e-15)
    assert (got.weight[:, diffuse] >= primary.weight[:, diffuse]).all()


LOSSLESS_BASES = [{"type": "conductor", "eta": [0.01] * 3, "k": [900.0] * 3},
                  {"type": "diffuse", "albedo": [1.0] * 3},
                  {"type": "dielectric", "ior": 1.0}]


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("base", LOSSLESS_BASES, ids=lambda b: b["type"])
def test_a_lossless_stack_returns_at_most_what_came_in(base, dtype):
    """Nothing absorbs: reflected plus transmitted light is at most 1 at any view, in float64 and
    float32. The scattered families are scaled to what the primary model's lobes leave (without
    the scale a coat of index 2.5, alpha 0.8 over a mirror returned 1.09 at 89 degrees)."""
    worst = 0.0
    # thickness and scattering coefficient: with nothing absorbed a medium is its optical depth
    # sigma_s d alone, so one pair per depth (0.025, 0.25, 0.5, 5, 50)
    depths = ((0.05, 0.5), (0.05, 5.0), (1.0, 0.5), (1.0, 5.0), (10.0, 5.0))
    for ior, rough, (d, ss), g, brough in itertools.product((1.0, 1.5, 2.5), (0.0, 0.3, 0.8), depths,
                                                           (-0.5, 0.0, 0.9), (0.0, 0.5)):
        b = dict(base)
        if b["type"] == "diffuse" and brough:
            continue  # a Lambertian base has no roughness: the same stack as with brough 0
        if b["type"] != "diffuse":
            b["roughness"] = brough
        st = {"layers": [_coat(ior, rough, d, sigma_s=[ss] * 3, g=g)], "base": b}
        total = lc.lobes(st, WIS, TM6_REFINED, dtype=dtype).weight.sum(1)  # reflected and transmitted
        assert np.isfinite(total).all()
        worst = max(worst, float(total.max()))
    assert worst <= 1.0 + (1e-6 if dtype == np.float32 else 1e-12), worst
    assert worst > 0.99  # the check sees stacks that return nearly everything


def test_a_float32_stack_that_once_returned_more_than_it_received():
    """Found by the random stacks (``lamella_dev.bench.stress``): three coats, the middle one
    scattering blue 1600 per unit, over a mirror-like conductor; in float32 the scale of the
    scattered light (1 - A) / (1 - A_tm) divided two small differences and returned 1.005."""
    d = {"layers": [{"type": "coat", "roughness": [1.0, 1.0]},
                    {"type": "coat", "ior": 1.128748220104118, "thickness": 0.0007840850556950552,
                     "sigma_s": [0.0001202652204621719, 0.2883755651833978, 1633.2239004487342],
                     "g": 0.3078925159093675},
                    {"type": "coat", "ior": 0.31199996395457663}],
         "base": {"type": "conductor"}}
    wi = np.array([[0.4394662127085659, 0.045531060610444235, 0.8971044367336936],
                   [-0.95364427132682, -0.10222865589139495, 0.28304046650642967],
                   [0.6773563124876212, -0.7356550998485378, 1e-07],
                   [-0.2880521208987666, -0.9576147323666822, 1e-07]])
    total = lc.lobes(d, wi, TM6_REFINED, dtype=np.float32).weight.sum(1)
    assert (total <= 1.0 + 1e-6).all(), total
