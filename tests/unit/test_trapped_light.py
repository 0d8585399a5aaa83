"""Light trapped under a rough coat over a smooth metal. What the coat reflects back down from
below has mostly been turned past the critical angle by facets reflecting totally; the mirror-like
base returns it along the same steep directions, and it comes up through the coat far less easily
than the first time. The adding equations count every round trip as the first, and a rough coat
over gold returned up to 12 % too much green light at 60 degrees against the energy-conserving walk
(``lamella_dev.reference``, interfaces="multiple"). The adding family now counts the later round
trips with the table ``dielectric_trapped_escape`` (``adding_doubling._adding_energies``)."""
import numpy as np
import pytest

from lamella.core import api
from lamella_dev import reference, suite
from lamella.core.stack import Stack

GOLD = {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603], "roughness": 0.01}
WALKERS = 40_000


@pytest.mark.parametrize("alpha", [0.1, 0.2, 0.3])
@pytest.mark.parametrize("model", ["yamaguchi2019", "weier2020"])
def test_rough_coat_over_smooth_gold_returns_what_the_walk_returns(alpha, model):
    stack = Stack.from_dict({"layers": [{"type": "coat", "ior": 1.5, "roughness": alpha}], "base": GOLD})
    # measured: 60 degrees, green: 0.123 / 0.114 / 0.051 too much with every round trip as the
    # first, 0.069 / 0.024 / -0.035 now; normal incidence within 0.025 either way
    for deg, tolerance in ((0.0, 0.02), (60.0, 0.08)):
        wi = suite.incident(deg)
        got = api.albedo(stack, wi, model)[0]
        want, err = reference.albedo(stack, wi, spp=WALKERS, seed=5, interfaces="multiple")
        np.testing.assert_array_less(np.abs(got / want[0] - 1.0), tolerance + 4.0 * err[0] / want[0],
                                     err_msg=f"alpha {alpha}, {model}, {deg} degrees: {got} against {want[0]}")


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_trapped_light_crosses_an_absorbing_coat_along_longer_paths(dtype):
    """``adding_doubling._trapped_round_trip``: what an absorbing interior lets through of the
    trapped light's way back down is 1 without absorption, at most the mean path's one-way
    transmittance (the trapped light travels outside the escape cone, the mean direction inside
    it), falling with thickness, finite in float32 down to grazing mean directions."""
    from lamella.core.backends.numpy_ops import NumpyOps
    from lamella.core.models.adding_doubling import _trapped_round_trip
    from lamella.core.models.rgb import RGB

    ops = NumpyOps(dtype)
    n = dtype(1.5)
    mu = np.array([1.0, 0.9, 0.7454, 0.746], dtype=dtype)  # the cone's edge at index 1.5: 0.7454
    for d in (0.0, 0.1, 1.0, 10.0, 1e4):
        path = dtype(d) / mu
        none = _trapped_round_trip(ops, RGB.splat(dtype(0.0)), dtype(d), n, path)
        for c in none:
            np.testing.assert_array_equal(c, 1.0)
        sig = RGB(dtype(0.05), dtype(0.8), dtype(3.0))
        got = _trapped_round_trip(ops, sig, dtype(d), n, path)
        for s, c in zip(sig, got):
            assert np.isfinite(c).all() and (c >= 0.0).all()
            assert (c <= np.exp(-s * path) * (1 + 1e-6) + 1e-30).all(), (d, s, c)
    thin, thick = (_trapped_round_trip(ops, RGB.splat(dtype(0.5)), dtype(d), n, dtype(d)).average()
                   for d in (0.2, 0.6))
    assert thick < thin


def test_an_absorbing_coat_over_rough_gold_is_as_dark_as_the_walk_at_normal_incidence():
    """The suite's absorbing rough coat over gold (``absorbing_rough_coat``): with the trapped light
    crossing the coat along the mean path, auto returned 0.715 / 0.291 / 0.110 at normal incidence
    against the energy-conserving walk's 0.632 / 0.261 / 0.104 (+13 % in red); along its own,
    longer paths 0.688 / 0.282 / 0.109."""
    from lamella_dev.bench.accuracy import load_reference
    from lamella_dev.bench.paths import REFERENCE_DIR_MULTIPLE

    ref = load_reference("absorbing_rough_coat", REFERENCE_DIR_MULTIPLE)
    i = list(ref["wi_degrees"]).index(0.0)
    got = api.albedo(suite.load("absorbing_rough_coat"), suite.incident(0.0))[0]
    assert np.all(got / np.asarray(ref[f"albedo_{i}"]) - 1.0 < 0.10), (got, ref[f"albedo_{i}"])


@pytest.mark.parametrize("coat_alpha, base_alpha, tolerance", [(0.3, 0.3, 0.04), (0.1, 0.3, 0.04), (0.3, 0.0, 0.07)])
def test_a_coat_over_a_rough_conductor_returns_what_the_walk_returns_at_every_view(coat_alpha, base_alpha,
                                                                                   tolerance):
    """A conductor's round trips under one coat from the tables of random walks
    (``adding_doubling._one_coat_round_trips``): the first way up depends on the view, the later
    ones do not. With the adding equations along the mean direction a coat of alpha 0.3 over a
    conductor of alpha 0.3 returned 0.83 / 0.76 / 0.76 of the walk's green light at 60 / 75 / 85
    degrees (0.81 / 0.81 at 75 / 85 with a coat of alpha 0.1, 0.85 / 0.83 over a mirror); with the
    tables 0.97-1.00 over the rough base in every channel and view, 0.94-0.99 over the mirror."""
    metal = {"type": "conductor", "eta": [0.05, 0.5, 1.0], "k": [3.0, 3.0, 3.0], "roughness": base_alpha}
    stack = Stack.from_dict({"layers": [{"type": "coat", "ior": 1.5, "roughness": coat_alpha}], "base": metal})
    for deg in (0.0, 45.0, 60.0, 75.0, 85.0):
        wi = suite.incident(deg)
        got = api.albedo(stack, wi)[0]
        want, err = reference.albedo(stack, wi, spp=WALKERS, seed=5, interfaces="multiple")
        np.testing.assert_array_less(np.abs(got / want[0] - 1.0), tolerance + 4.0 * err[0] / want[0],
                                     err_msg=f"coat {coat_alpha}, base {base_alpha}, {deg} degrees: "
                                             f"{got} against {want[0]}")
