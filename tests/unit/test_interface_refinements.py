"""The refinements of the interface model (``adding_doubling.Variant``, ``yamaguchi_refined``):
exact limits (smooth stacks, normal incidence, the first-order width), the view-aligned axes they
give isotropic stacks, finite values toward grazing in float32, and the keep rule they were
measured by (``lamella_dev.keep_rule``)."""
from dataclasses import replace

import numpy as np
import pytest

import lamella.core as lc
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.models import choose_auto, variant
from lamella.core.models.adding_doubling import YAMAGUCHI2019, YAMAGUCHI_REFINED, _saturated
from lamella_dev import keep_rule

from .stacks import coat, gold, stack


def directions(thetas_deg, phi=0.0):
    t = np.radians(np.asarray(thetas_deg, dtype=float))
    return np.stack([np.sin(t) * np.cos(phi), np.sin(t) * np.sin(phi), np.cos(t)], -1)


ROUGH = [
    stack(coat(1.5, 0.1), base=gold(0.01)),
    stack(coat(1.4, 0.1), coat(1.0, 0.01), coat(1.4, 0.1), base=gold(0.0)),
    stack(coat(1.49, [0.1, 0.01]), base=gold([0.01, 0.05], 0.5)),
    stack(coat(1.5, 0.447, thickness=0.5, sigma_a=(0.8, 0.8, 0.2)), base=gold(0.0014)),
]


def test_auto_runs_the_refined_model_on_interfaces():
    assert choose_auto(lc.Stack.from_dict(stack(coat(1.5, 0.1), base=gold(0.1)))) == "yamaguchi_refined"
    assert "yamaguchi_refined" in lc.MODELS and "yamaguchi2019" in lc.MODELS


def test_smooth_stacks_are_the_published_model():
    """Every refinement acts on spreads: with smooth interfaces (and a smooth base) the lobes are
    yamaguchi2019's, energies and all."""
    d = stack(coat(1.5, 0.0, thickness=0.3, sigma_a=(0.2, 0.5, 0.9)), coat(1.3, 0.0), base=gold(0.0))
    wi = directions([0.0, 30.0, 60.0, 80.0], phi=0.4)
    a, b = lc.lobes(d, wi, "yamaguchi2019"), lc.lobes(d, wi, "yamaguchi_refined")
    np.testing.assert_allclose(b.weight, a.weight, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(b.alpha_x, 0.0, atol=1e-12)
    np.testing.assert_allclose(b.alpha_y, 0.0, atol=1e-12)


@pytest.mark.parametrize("d", ROUGH)
def test_refraction_spreads_agree_at_normal_incidence(d):
    """At normal incidence the deviation at the mean direction is Belcour's fake refraction, on
    both axes: the three refraction spreads give the same lobes."""
    wi = directions([0.0])
    lobes = [lc.lobes(d, wi, replace(YAMAGUCHI_REFINED, refraction_spread=s))
             for s in ("normal", "direction down", "across down")]
    for lb in lobes[1:]:
        np.testing.assert_allclose(lb.weight, lobes[0].weight, rtol=1e-12)
        np.testing.assert_allclose(lb.alpha_x, lobes[0].alpha_x, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(lb.alpha_y, lobes[0].alpha_y, rtol=1e-9, atol=1e-12)


def test_saturation_has_the_first_order_limit():
    """A narrow lobe keeps the model's (first-order) roughness; a broad one toward grazing leaves
    narrower; finite and non-negative from normal incidence to the horizon, in float32 too."""
    ops = NumpyOps(np.float64)
    for c in (1.0, 0.5, 0.2):
        c_in = np.sqrt(1.0 - (1.0 - c * c) / 1.5 ** 2)
        np.testing.assert_allclose(_saturated(ops, 1e-3, c, c_in, 1.5, 0.5), 1e-3, rtol=1e-5)
    c, c_in = 0.25, np.sqrt(1.0 - (1.0 - 0.0625) / 2.25)
    assert _saturated(ops, 0.4, c, c_in, 1.5, 0.5) < 0.8 * 0.4
    c = np.array([1.0, 0.5, 1e-3, 1e-7, 0.0], dtype=np.float32)
    c_in = np.sqrt(1.0 - (1.0 - c * c) / np.float32(2.25))
    out = _saturated(NumpyOps(np.float32), np.float32(0.3), c, c_in, np.float32(1.5), 0.5)
    assert np.all(np.isfinite(out)) and np.all(out >= 0.0) and np.all(out <= 0.3 + 1e-6)


def test_isotropic_stacks_get_lobes_across_the_plane_of_incidence():
    """Over an isotropic stack the lobe through the coat is rougher across the plane of incidence
    than along it at oblique views, and its axes turn with the view's azimuth."""
    d = stack(coat(1.5, 0.1), base=gold(0.01))
    for phi in (0.0, 0.7, 2.0):
        lb = lc.lobes(d, directions([60.0], phi), "yamaguchi_refined")
        k = 1  # the base's lobe, below the coat's own reflection
        assert lb.alpha_x[0, k] > 1.1 * lb.alpha_y[0, k]
        # the major axis across the plane of incidence: at phi + pi / 2 (mod pi)
        np.testing.assert_allclose(np.mod(lb.rotation[0, k] - phi - np.pi / 2 + np.pi / 2, np.pi), np.pi / 2, atol=1e-9)
    ref = lc.lobes(d, directions([60.0], 0.0), "yamaguchi_refined")
    turned = lc.lobes(d, directions([60.0], 1.3), "yamaguchi_refined")
    np.testing.assert_allclose(turned.alpha_x, ref.alpha_x, rtol=1e-9)
    np.testing.assert_allclose(turned.weight, ref.weight, rtol=1e-9)


def test_turning_the_layers_and_the_view_turns_the_lobe():
    d = stack(coat(1.49, [0.1, 0.01]), base=gold([0.01, 0.05], 0.0))
    turned = stack(coat(1.49, [0.1, 0.01], rotation=0.7), base=gold([0.01, 0.05], 0.7))
    lb0 = lc.lobes(d, directions([50.0], 0.2), "yamaguchi_refined")
    lb1 = lc.lobes(turned, directions([50.0], 0.9), "yamaguchi_refined")
    np.testing.assert_allclose(lb1.weight, lb0.weight, rtol=1e-9)
    np.testing.assert_allclose(lb1.alpha_x, lb0.alpha_x, rtol=1e-9)
    np.testing.assert_allclose(lb1.alpha_y, lb0.alpha_y, rtol=1e-9)
    rough = [k for k, name in enumerate(lb0.kinds) if name != "diffuse"]
    np.testing.assert_allclose(np.mod(lb1.rotation[:, rough] - lb0.rotation[:, rough] + 0.1, np.pi), 0.8, atol=1e-9)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("d", ROUGH)
def test_finite_toward_grazing(d, dtype):
    """No NaN, Inf or negative value from normal incidence to the horizon, float32 as float64."""
    cz = np.array([1.0, 0.5, 0.1, 1e-3, 1e-6, 0.0])
    sz = np.sqrt(1.0 - cz * cz)
    wi = np.stack([sz * np.cos(0.3), sz * np.sin(0.3), cz], -1)
    lb = lc.lobes(d, wi, "yamaguchi_refined", dtype=dtype)
    for x in (lb.weight, lb.alpha_x, lb.alpha_y, lb.rotation):
        assert np.all(np.isfinite(x))
    assert np.all(lb.weight >= 0.0) and np.all(lb.alpha_x >= 0.0) and np.all(lb.alpha_y >= 0.0)
    assert np.all(lb.alpha_x <= 1.0 + 1e-6)


def test_variant_rejects_unknown_refinements():
    with pytest.raises(ValueError, match="refraction_spread"):
        variant("yamaguchi2019", refraction_spread="sideways")
    with pytest.raises(ValueError, match="jacobians"):
        replace(YAMAGUCHI2019, jacobians="angles")
    with pytest.raises(ValueError, match="saturation"):
        replace(YAMAGUCHI2019, saturation=-1.0)


def test_keep_rule():
    before = {("a", 0.0): 0.2, ("a", 60.0): 0.3, ("holdout_00", 0.0): 0.4}
    better = {("a", 0.0): 0.15, ("a", 60.0): 0.31, ("holdout_00", 0.0): 0.41}
    v = keep_rule.judge(before, better)
    assert v.kept and not v.rises
    assert v.suite == pytest.approx((0.25, 0.23)) and v.holdout == pytest.approx((0.4, 0.41))
    assert v.per_angle[0.0] == pytest.approx((-0.05 + 0.01) / 2)
    worse = {**better, ("holdout_00", 0.0): 0.43}
    v = keep_rule.judge(before, worse)
    assert not v.kept and v.rises == [("holdout_00", 0.0, 0.4, 0.43)]
    assert not keep_rule.judge(before, before).kept  # the mean must fall
    with pytest.raises(ValueError):
        keep_rule.judge(before, {("b", 0.0): 0.1})


def test_auto_with_swaps_a_model():
    d = lc.Stack.from_dict(stack(coat(1.5, 0.1), base=gold(0.1)))
    wi = directions([45.0])
    swapped = keep_rule.AutoWith({"yamaguchi_refined": YAMAGUCHI2019})
    np.testing.assert_array_equal(lc.lobes(d, wi, swapped).alpha_x, lc.lobes(d, wi, "yamaguchi2019").alpha_x)
