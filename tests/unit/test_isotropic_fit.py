"""The isotropic stand-ins of anisotropic GGX lobes (``lamella.core.lobe_kinds.isotropic_fit``): an
isotropic lobe stands for itself, the stand-ins keep the lobe's energy, and they draw a strongly
anisotropic lobe closer than today's single lobe of alpha sqrt(ax ay) (``bench/eevee_anisotropy_fit.md``)."""
import math

import numpy as np
import pytest

from lamella.core.lobe_kinds import isotropic_fit as F


def _view(theta_deg, phi_deg=0.0):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def _hemisphere(ax, ay, wi):
    h, dh = F.h_grid(ax, ay, 48, 96)
    return F.wo_of_h(wi, h, dh)


def _stand_ins_cos(ax, ay, wi, wo, k, shift=True):
    st = F.fit(np.array([ax]), np.array([ay]), wi[None, :], k=k, shift=shift)
    return F.fit_cos(st, 0, wi, wo), st


def _geometric_mean_cos(ax, ay, wi, wo):
    a = math.sqrt(ax * ay)
    g = float(F.gd(F._OPS, np.array(wi[2]), np.array(a)))
    return F.tilted_cos(wi, wo, a, np.array([0.0, 0.0, 1.0])) / g


def _l1(f, target, dwo):
    return float((np.abs(f - target) * dwo).sum() / (target * dwo).sum())


@pytest.mark.parametrize("k", [1, 2, 3])
def test_an_isotropic_lobe_stands_for_itself(k):
    alpha = 0.3
    for wi in (_view(0.0), _view(50.0, 30.0), _view(75.0, 200.0)):
        st = F.fit(np.array([alpha]), np.array([alpha]), wi[None, :], k=k)
        assert np.all(st.tilt == 0.0) and np.allclose(st.alpha, alpha)
        assert np.allclose(st.normal, [0.0, 0.0, 1.0])
        assert st.fraction.sum() == pytest.approx(1.0)
        wo, dwo = _hemisphere(alpha, alpha, wi)
        f, _ = _stand_ins_cos(alpha, alpha, wi, wo, k)
        np.testing.assert_allclose(f, F.anisotropic_cos(wi, wo, alpha, alpha), rtol=1e-9, atol=1e-12)


def test_a_mirror_stands_for_itself():
    st = F.fit(np.zeros(2), np.zeros(2), np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]]), k=3)
    assert np.all(st.tilt == 0.0) and np.allclose(st.alpha, F.ALPHA_MIN)


def test_the_fit_of_an_isotropic_lobe_is_that_lobe():
    shape = F.fit_shape(0.2, 0.2, 3, n_r=24, n_psi=48, rounds=2)
    assert shape.error < 1e-9
    assert np.all(shape.tilt == 0.0) and np.allclose(shape.alpha, 0.2)


@pytest.mark.parametrize("ax, ay", [(0.1, 0.01), (0.16, 0.04), (0.4, 0.1), (0.05, 0.3)])
def test_the_stand_ins_keep_the_lobes_energy(ax, ay):
    """Each stand-in is GD-normalised about its own normal, so their energies sum to the lobe's
    exactly (the fractions); over the hemisphere above the surface they reflect what the lobe does
    within 6 % up to 60 degrees (measured: 0.951 to 1.016; the rest is the tilted lobes' light
    below the surface, which no renderer draws)."""
    for wi in (_view(0.0), _view(30.0, 0.0), _view(60.0, 0.0), _view(60.0, 90.0), _view(45.0, 135.0)):
        wo, dwo = _hemisphere(ax, ay, wi)
        target = F.anisotropic_cos(wi, wo, ax, ay)
        for k in (2, 3):
            f, st = _stand_ins_cos(ax, ay, wi, wo, k)
            assert st.fraction.sum() == pytest.approx(1.0, abs=1e-12)
            g = F.gd(F._OPS, np.clip((st.normal[0] * wi).sum(-1), 0.0, 1.0), st.alpha[0])
            assert float((st.scale[0] * g).sum()) == pytest.approx(1.0, abs=1e-9)
            ratio = float((f * dwo).sum() / (target * dwo).sum())
            assert 0.94 < ratio < 1.03, (ax, ay, wi, k, ratio)


def test_the_fit_beats_the_geometric_mean_on_a_brushed_lobe():
    """A 4:1 lobe (alpha 0.16 x 0.04, and 0.4 x 0.1): the K = 3 stand-ins' relative L1 of f cos is
    at least 0.25 below today's stand-in's (measured 0.81 -> 0.51 at 0 degrees, 0.79 -> 0.45 at 45
    degrees along the long axis, 0.81 -> 0.50 at 60 degrees) and K = 2's at least 0.12 below (0.58
    to 0.64)."""
    for ax, ay, wi in ((0.16, 0.04, _view(0.0)), (0.4, 0.1, _view(45.0, 0.0)), (0.04, 0.16, _view(45.0, 90.0)),
                       (0.16, 0.04, _view(60.0, 45.0))):
        wo, dwo = _hemisphere(ax, ay, wi)
        target = F.anisotropic_cos(wi, wo, ax, ay)
        geo = _l1(_geometric_mean_cos(ax, ay, wi, wo), target, dwo)
        k2 = _l1(_stand_ins_cos(ax, ay, wi, wo, 2)[0], target, dwo)
        k3 = _l1(_stand_ins_cos(ax, ay, wi, wo, 3)[0], target, dwo)
        assert k3 < geo - 0.25 and k2 < geo - 0.12, (ax, ay, wi, geo, k2, k3)


def test_the_tilts_follow_the_long_axis_and_the_view():
    """The stand-ins tilt along the larger alpha's axis; a view toward grazing along that axis shifts
    them toward it, mirrored for the opposite view; a view across it shifts nothing."""
    wi = _view(70.0, 0.0)
    along = F.fit(np.array([0.4]), np.array([0.1]), wi[None, :], k=3)
    across = F.fit(np.array([0.1]), np.array([0.4]), wi[None, :], k=3)
    assert np.allclose(along.normal[0, :, 1], 0.0) and np.allclose(across.normal[0, :, 0], 0.0)
    assert np.allclose(along.long_axis, [1.0, 0.0]) and np.allclose(across.long_axis, [0.0, 1.0])
    assert along.tilt[0].mean() > math.radians(3.0)  # toward the view
    assert abs(across.tilt[0].mean()) < 1e-6  # the view is across the long axis: no shift
    back = F.fit(np.array([0.4]), np.array([0.1]), (wi * [-1.0, 1.0, 1.0])[None, :], k=3)
    np.testing.assert_allclose(np.sort(back.tilt[0]), np.sort(-along.tilt[0]), atol=1e-12)


def test_the_table_holds_the_fit():
    """At a table node the interpolated shape is the one ``fit_shape`` finds (its L1 within 0.01)."""
    ax, ay = 0.3, 0.3 * 0.2
    wi = np.array([0.0, 0.0, 1.0])
    h, dh = F.h_grid(ax, ay, 40, 96)
    wo, dwo = F.wo_of_h(wi, h, dh)
    target = F.anisotropic_cos(wi, wo, ax, ay)
    tabulated = _l1(F.stand_ins_cos(F.shape_of(ax, ay, 2), ax, ay, wi, wo), target, dwo)
    fitted = F.fit_shape(ax, ay, 2, rounds=3)
    assert tabulated == pytest.approx(fitted.error, abs=0.01)


def test_the_fit_is_fast_at_staging():
    rng = np.random.default_rng(1)
    n = 64 * 16 * 5
    ax, ay = rng.uniform(0.01, 1.0, n), rng.uniform(0.01, 1.0, n)
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    F.load_table()
    import time

    t = time.perf_counter()
    st = F.fit(ax, ay, v, k=3)
    assert time.perf_counter() - t < 1.0
    assert np.all(np.isfinite(st.scale)) and np.all(st.scale >= 0.0)
    assert np.allclose(np.linalg.norm(st.normal, axis=-1), 1.0)
