"""The transfer-matrix model's forward-scattered family, round in angle about its direction in the
medium that scattered it (``transfer_matrix``, ``TransferMatrix.round_forward``): along the plane
of incidence its lobe keeps the family's roughness, across it the roughness as wide, projected,
at the cosine of the mean direction in that medium; its axes turn with the view; normal incidence, the energies and
stacks with an anisotropic interface are as before; finite toward grazing in float32."""
import numpy as np
import pytest

import lamella.core as lc
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.models.ggx import alpha_of_projected_width
from lamella.core.models.transfer_matrix import FORWARD_SATURATION, TransferMatrix

from .stacks import coat, gold, stack


def medium(ior, roughness, thickness, sigma_s, g, sigma_a=(0.0, 0.0, 0.0)):
    return dict(coat(ior, roughness, thickness=thickness, sigma_a=sigma_a), sigma_s=list(sigma_s), g=g)


ROUND = TransferMatrix("tm6", six_flux=True)
PLAIN = TransferMatrix("tm6", six_flux=True, round_forward=False)
FOG = stack(medium(1.0, 0.0, 1.0, (0.5, 0.5, 0.5), 0.9), base=gold(0.02))
MILKY = stack(medium(1.5, 0.05, 0.4, (2.0, 1.5, 1.0), 0.7, sigma_a=(0.1, 0.2, 0.4)), base=gold(0.1))


def directions(thetas_deg, phi=0.0):
    t = np.radians(np.asarray(thetas_deg, dtype=float))
    return np.stack([np.sin(t) * np.cos(phi), np.sin(t) * np.sin(phi), np.cos(t)], -1)


def _changed(a, b):
    """Indices of the lobes whose across roughness ``a`` changed against ``b``."""
    return np.flatnonzero(np.any(np.abs(a.alpha_y - b.alpha_y) > 1e-12, axis=0))


def test_tm6_is_the_round_forward_model():
    from lamella.core import models

    assert models.get("tm6").round_forward


@pytest.mark.parametrize("d", [FOG, MILKY])
def test_normal_incidence_and_energies_are_unchanged(d):
    wi = directions([0.0, 30.0, 60.0, 80.0], phi=0.7)
    a, b = lc.lobes(d, wi, ROUND), lc.lobes(d, wi, PLAIN)
    np.testing.assert_array_equal(a.weight, b.weight)
    np.testing.assert_array_equal(a.alpha_x, b.alpha_x)  # along the plane: the family's roughness
    np.testing.assert_allclose(a.alpha_y[0], b.alpha_y[0], rtol=1e-12)  # at normal incidence: round


@pytest.mark.parametrize("d,ior", [(FOG, 1.0), (MILKY, 1.5)])
@pytest.mark.parametrize("theta", [30.0, 60.0, 75.0])
def test_across_the_plane_the_roughness_over_the_mediums_cosine(d, ior, theta):
    """The forward families' lobes change (the once-scattered one's too, where the coat draws it
    apart: in a fog, not in a coat of index 1.5), nothing else: across the plane of incidence
    the roughness whose projected width at cos(theta_t) is the lobe's at normal incidence (theta_t
    the mean direction's angle in the coat; alpha / cos(theta_t) to first order, narrower as the
    horizon nears), its axis the view's azimuth."""
    phi = 0.4
    wi = directions([theta], phi=phi)
    a, b = lc.lobes(d, wi, ROUND), lc.lobes(d, wi, PLAIN)
    changed = _changed(a, b)
    assert len(changed) == (2 if ior == 1.0 else 1)
    c = np.sqrt(1.0 - (np.sin(np.radians(theta)) / ior) ** 2)
    k = FORWARD_SATURATION
    for j in changed:
        alpha, across = b.alpha_x[0, j], a.alpha_y[0, j]
        assert across ** 2 * (c * c + k * across ** 2) == pytest.approx(alpha ** 2 * (1.0 + k * alpha ** 2), rel=1e-9)
        assert alpha < across <= alpha / c
        assert a.rotation[0, j] == pytest.approx(phi, abs=1e-12)


def test_the_cosine_is_the_scattering_coats_for_light_reflected_below_it():
    """A scattering coat (index 1.5) over a clear coat of index 2: the forward light the clear
    coat's interface and the base send back was scattered in the upper coat, and its lobe is
    round in angle there, at the cosine of that coat, not of the clear coat it is reflected in."""
    d = stack(medium(1.5, 0.05, 0.4, (2.0, 1.5, 1.0), 0.7), coat(2.0, 0.05), base=gold(0.1))
    theta = 60.0
    wi = directions([theta], phi=0.2)
    a, b = lc.lobes(d, wi, ROUND), lc.lobes(d, wi, PLAIN)
    changed = _changed(a, b)
    assert len(changed) >= 2  # the coat's own forward light and what the layers below send back
    c = np.sqrt(1.0 - (np.sin(np.radians(theta)) / 1.5) ** 2)
    k = FORWARD_SATURATION
    for j in changed:
        alpha, across = b.alpha_x[0, j], a.alpha_y[0, j]
        assert across ** 2 * (c * c + k * across ** 2) == pytest.approx(alpha ** 2 * (1.0 + k * alpha ** 2), rel=1e-9), j


def test_first_order_for_a_narrow_family():
    """A narrow forward lobe (a thin, strongly forward-scattering fog) is alpha / cos across."""
    ops = NumpyOps(np.float64)
    for c in (1.0, 0.8, 0.5, 0.3):
        a = 1e-4
        b = a * a * (1.0 + FORWARD_SATURATION * a * a)
        assert alpha_of_projected_width(ops, b, c, FORWARD_SATURATION) == pytest.approx(a / c, rel=1e-4)


def test_the_lobe_turns_with_the_view():
    """An isotropic stack: the view turned about the normal turns the lobe's axes with it and
    changes nothing else."""
    wi = directions([60.0, 60.0, 60.0], phi=np.array([0.0, 1.0, 2.5]))
    lb = lc.lobes(FOG, wi, ROUND)
    for name in ("weight", "alpha_x", "alpha_y"):
        np.testing.assert_allclose(getattr(lb, name)[1:], np.broadcast_to(getattr(lb, name)[:1], getattr(lb, name)[1:].shape),
                                   rtol=1e-12)
    for k in _changed(lb, lc.lobes(FOG, wi, PLAIN)):  # the forward and the once-scattered family
        np.testing.assert_allclose(lb.rotation[:, k], [0.0, 1.0, 2.5], atol=1e-12)


def test_stacks_with_an_anisotropic_interface_keep_round_lobes():
    """There the lobes' axes would turn with the view against the interfaces' (staged tables would
    need the azimuth): the forward family stays round."""
    d = stack(medium(1.5, [0.1, 0.02], 0.5, (1.0, 1.0, 1.0), 0.8), base=gold(0.1))
    wi = directions([0.0, 45.0, 70.0], phi=0.3)
    a, b = lc.lobes(d, wi, ROUND), lc.lobes(d, wi, PLAIN)
    for name in ("weight", "alpha_x", "alpha_y", "rotation"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_finite_and_bounded_from_normal_incidence_to_the_horizon(dtype):
    """At normal incidence the view's azimuth is atan2(0, 0) = 0 and the lobe round; toward the
    horizon the across roughness is capped: finite, non-negative values in both precisions."""
    wi = directions([0.0, 80.0, 89.0, 89.9, 90.0], phi=1.1)
    for d in (FOG, MILKY):
        lb = lc.lobes(d, wi, ROUND, dtype=dtype)
        for name in ("weight", "alpha_x", "alpha_y", "rotation"):
            assert np.isfinite(getattr(lb, name)).all(), name
        assert (lb.alpha_y <= 1.0).all() and (lb.alpha_y >= 0.0).all()
        np.testing.assert_allclose(lb.alpha_y[0], lb.alpha_x[0], rtol=1e-6)
        wo = directions([30.0, 85.0, 60.0, 30.0, 0.0], phi=1.1 + np.pi)
        f = lc.evaluate(d, wi, wo, ROUND, dtype=dtype)
        assert np.isfinite(f).all() and (f >= 0).all()


def _without_the_once_scattered_family(monkeypatch):
    from lamella.core.models import transfer_matrix

    monkeypatch.setattr(transfer_matrix, "once_forward", lambda ops, sa, ss, g, h: 0.0 * h)


@pytest.mark.parametrize("d", [FOG, stack(medium(1.0, 0.0, 0.5, (0.5, 0.5, 0.5), 0.9),
                                          medium(1.0, 0.0, 0.7, (0.3, 0.6, 0.9), 0.5, sigma_a=(0.2, 0.1, 0.0)),
                                          base=gold(0.1))])
def test_the_once_scattered_family_splits_the_forward_light_and_keeps_its_energy(d, monkeypatch):
    """The forward light a medium scattered once is a family of its own (``F1``), with a narrower
    lobe than the rest of the forward light; the energies are the single family's, split: the
    albedo is the same with the family drawn apart or not, through two media too."""
    wi = directions([0.0, 30.0, 60.0, 80.0], phi=0.3)
    split = lc.lobes(d, wi, "tm6")
    albedo = lc.albedo(d, wi, "tm6")
    _without_the_once_scattered_family(monkeypatch)
    whole = lc.lobes(d, wi, "tm6")
    np.testing.assert_allclose(lc.albedo(d, wi, "tm6"), albedo, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(split.weight.sum(1), whole.weight.sum(1), rtol=1e-9, atol=1e-12)
    at_zero = split.weight[0].sum(-1) > 1e-6  # normal incidence: lobes that carry light
    narrow = split.alpha_x[0][at_zero].min()
    assert narrow < whole.alpha_x[0][at_zero & (whole.alpha_x[0] > 0.05)].min()  # a narrower lobe appears


def test_a_coat_that_refracts_keeps_one_forward_family(monkeypatch):
    """Over a coat of index 1.5 the once-scattered light is not drawn apart (``ONCE_INDEX_RAMP``):
    the lobes are the same as without the family."""
    wi = directions([0.0, 45.0, 75.0], phi=0.3)
    split = lc.lobes(MILKY, wi, "tm6")
    _without_the_once_scattered_family(monkeypatch)
    whole = lc.lobes(MILKY, wi, "tm6")
    np.testing.assert_allclose(split.weight, whole.weight, rtol=1e-12, atol=1e-15)
    on = split.weight.sum(-1) > 0
    np.testing.assert_allclose(split.alpha_x[on], whole.alpha_x[on], rtol=1e-12)
