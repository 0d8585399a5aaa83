"""The pre-integrated tables: stored files match their generator, and the error between nodes
stays within the figures quoted in bench/luts.md."""
import math

import numpy as np
import pytest

from lamella_dev.bench.luts_error import METALS, _integrate
from lamella.core import luts
from lamella_dev import luts_build
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.models.fgd import fgd_conductor, fgd_dielectric, gd
from lamella.core.models.fresnel import fresnel_conductor, fresnel_dielectric
from lamella.core.models.rgb import RGB


@pytest.mark.parametrize("name", list(luts.SPECS))
def test_stored_tables_have_their_shape_and_range(name):
    t = luts.table(name)
    assert t.shape == luts.SPECS[name].shape and t.dtype == np.float32
    assert np.isfinite(t).all()
    if name in ("ggx_albedo", "tir", "ggx_refract_albedo", "dielectric_rough_reflect", "dielectric_trapped_escape",
                "coat_first_escape", "coat_trapped_equilibrium", "hg_backward_escape", "hg_backward_cosine"):
        assert (t >= 0).all() and (t <= 1).all()


def test_stored_tables_match_the_generator():
    """Regenerating (about 10 s) reproduces the committed EXR files: they are not stale."""
    fresh = luts_build.generate_ggx_albedo()
    for name, arr in fresh.items():
        np.testing.assert_allclose(luts.table(name), arr, atol=2e-6)


@pytest.mark.parametrize("cell", [(3, 5, 2), (20, 9, 4), (24, 12, 3), (31, 15, 0), (40, 7, 1)])
def test_stored_rough_dielectric_table_matches_the_generator(cell):
    """Cells of ``dielectric_rough_reflect`` recomputed by its generator's own walk (the whole table
    takes minutes): the same random numbers, the same value."""
    i, j, k = cell
    alpha, eta = float(luts._alpha_nodes(luts.N_MS_ALPHA)[j]), float(luts._ms_eta_nodes(luts.N_MS_ETA)[k])
    s = luts.ms_sine(i / (luts.N_MS_X - 1.0), eta)
    assert luts.table("dielectric_rough_reflect")[i, j, k] == pytest.approx(
        luts_build.dielectric_rough_reflect_cell(s, alpha, eta), abs=1e-6)


@pytest.mark.parametrize("cell", [(3, 5, 2), (20, 9, 4), (24, 12, 3), (31, 15, 0), (40, 7, 1)])
def test_stored_trapped_escape_table_matches_the_generator(cell):
    """Cells of ``dielectric_trapped_escape`` recomputed by its generator's own two walks."""
    i, j, k = cell
    alpha, eta = float(luts._alpha_nodes(luts.N_MS_ALPHA)[j]), float(luts._ms_eta_nodes(luts.N_MS_ETA)[k])
    s = luts.ms_sine(i / (luts.N_MS_X - 1.0), eta)
    assert luts.table("dielectric_trapped_escape")[i, j, k] == pytest.approx(
        luts_build.dielectric_trapped_escape_cell(s, alpha, eta), abs=1e-6)


@pytest.mark.parametrize("cell", [(0, 3, 2, 7), (5, 6, 9, 7), (15, 4, 4, 3), (9, 9, 0, 10), (2, 0, 5, 5)])
def test_stored_first_escape_table_matches_the_generator(cell):
    """Cells of ``coat_first_escape`` (view, coat alpha, base alpha, eta) recomputed by its
    generator's walks: the same random numbers, the same value, where the folded axis puts them."""
    i, j, b, k = cell
    alphas, etas = luts._alpha_nodes(luts.N_FE_ALPHA), luts._tir_eta_nodes(luts.N_FE_ETA)
    mu = i / (luts.N_FE_MU - 1.0)
    assert luts.table("coat_first_escape")[i, j, k * luts.N_FE_ALPHA + b] == pytest.approx(
        luts_build.coat_first_escape_cell(mu, float(alphas[j]), float(alphas[b]), float(etas[k])), abs=1e-6)


@pytest.mark.parametrize("cell", [(3, 0, 7), (6, 6, 7), (9, 2, 3), (0, 0, 10)])
def test_stored_trapped_equilibrium_table_matches_the_generator(cell):
    j, b, k = cell
    alphas, etas = luts._alpha_nodes(luts.N_FE_ALPHA), luts._tir_eta_nodes(luts.N_FE_ETA)
    assert luts.table("coat_trapped_equilibrium")[j, b, k] == pytest.approx(
        luts_build.coat_trapped_equilibrium_cell(float(alphas[j]), float(alphas[b]), float(etas[k])), abs=1e-6)


def test_stored_half_lobe_tables_match_the_generator():
    """``hg_backward_escape`` and ``hg_backward_cosine`` regenerated (a second): not stale."""
    fresh = luts_build.generate_backward_half()
    for name, arr in fresh.items():
        np.testing.assert_allclose(luts.table(name), arr, atol=2e-6)


@pytest.mark.parametrize("g, deg, n", [(0.9, 0.0, 1.5), (0.9, 60.0, 1.5), (0.3, 75.0, 1.5), (0.6, 45.0, 2.0),
                                       (-0.5, 30.0, 1.3), (0.95, 80.0, 1.0)])
def test_half_lobe_moments_match_sampled_scattering(g, deg, n):
    """The quadrature of ``backward_half_moments`` against directions sampled from the backward
    half of the HG phase function (its inverse CDF) about a primary refracted in at ``deg`` through index ``n``: the share
    of the backward half in the escape cone and its mean |v_z|, within the sampling noise."""
    rng = np.random.default_rng(7)
    m = 200_000  # the share's standard error at most 0.0011, the mean's 0.0007
    # the inverse CDF's u maps to the scattering cosine increasingly, -1 at u = 0 and 0 at u0
    u0 = ((1.0 - g * g) / math.sqrt(1.0 + g * g) - (1.0 - g)) / (2.0 * g)
    s_ = (1.0 - g * g) / (1.0 - g + 2.0 * g * u0 * rng.random(m))
    ct = np.minimum((1.0 + g * g - s_ * s_) / (2.0 * g), 0.0)
    st = np.sqrt(np.maximum(1.0 - ct * ct, 0.0))
    ph = 2.0 * np.pi * rng.random(ct.size)
    sine = np.sin(np.radians(deg)) / n
    c = np.sqrt(1.0 - sine * sine)
    # the primary d = (sine, 0, -c); e1 = (c, 0, sine) completes it in the plane of incidence
    vz = -c * ct + sine * st * np.cos(ph)
    cos_cone = math.sqrt(max(1.0 - 1.0 / (n * n), 0.0))
    share, mean_abs = luts_build.backward_half_moments(g, sine, cos_cone)
    assert share == pytest.approx(float(np.mean(vz > cos_cone)), abs=0.005)
    assert mean_abs == pytest.approx(float(np.mean(np.abs(vz))), abs=0.003)


@pytest.mark.parametrize("g", [-0.8, -0.4, 0.0, 0.4, 0.8])
def test_half_lobe_tables_at_normal_incidence_are_the_closed_forms(g):
    """Untilted, the half-lobe's share in a cone is ``forward_cone_fraction(-g)`` and its mean
    |cosine| ``backward_mean_cosine(g)``: the tables read on their g nodes give both."""
    from lamella.core.models.hg import (backward_abs_cosine, backward_escape, backward_mean_cosine,
                                        forward_cone_fraction)

    ops = NumpyOps()
    for cos_cone in (0.0, 0.5, 0.75, 0.875):
        assert float(backward_escape(ops, g, 0.0, cos_cone)) == pytest.approx(
            float(forward_cone_fraction(ops, -g, cos_cone)), abs=1e-4)
    assert float(backward_abs_cosine(ops, g, 0.0)) == pytest.approx(float(backward_mean_cosine(ops, g)), abs=1e-4)


def test_first_escape_reads_its_folded_table_between_the_index_nodes():
    """The model's look-up of the folded 4D table: on a node the stored value, between two index
    nodes the blend of the two eta blocks, and within the generator's own value there (index 1.6
    between the nodes 1.5 and 1.667: the table's interpolation error, a few hundredths)."""
    from lamella.core.models.fgd import coat_first_escape

    ops = NumpyOps()
    alphas, etas = luts._alpha_nodes(luts.N_FE_ALPHA), luts._tir_eta_nodes(luts.N_FE_ETA)
    t = luts.table("coat_first_escape")
    i, j, b, k = 6, 5, 4, 7
    mu, ac, ab = i / (luts.N_FE_MU - 1.0), float(alphas[j]), float(alphas[b])
    assert float(coat_first_escape(ops, mu, ac, ab, 1.0 / float(etas[k]))) == pytest.approx(
        float(t[i, j, k * luts.N_FE_ALPHA + b]), abs=1e-6)
    n = 1.6
    w = (1.0 / n - etas[k - 1]) / (etas[k] - etas[k - 1])
    blend = (1.0 - w) * t[i, j, (k - 1) * luts.N_FE_ALPHA + b] + w * t[i, j, k * luts.N_FE_ALPHA + b]
    got = float(coat_first_escape(ops, mu, ac, ab, n))
    assert got == pytest.approx(float(blend), abs=1e-5)
    assert got == pytest.approx(luts_build.coat_first_escape_cell(mu, ac, ab, 1.0 / n), abs=0.03)


def test_trapped_escape_is_exact_in_its_limits_and_traps_from_the_denser_side():
    """A smooth interface sends what it reflects back along the way it came: the trapped light
    crosses as easily as the first time (the table at alpha 0 and the model's look-up near it); an
    index-matched interface lets everything through. From the denser side, past alpha 0.05, what
    a rough interface reflected crosses on its next arrival less easily than light arriving for
    the first time."""
    from lamella_dev.microsurface import _fresnel_dielectric
    from lamella.core.models.fgd import trapped_escape

    t = luts.table("dielectric_trapped_escape")
    r = luts.table("dielectric_rough_reflect")
    etas = luts._ms_eta_nodes(luts.N_MS_ETA)
    s = np.array([[luts.ms_sine(i / (luts.N_MS_X - 1.0), e) for e in etas] for i in range(luts.N_MS_X)])
    f = _fresnel_dielectric(np.maximum(np.sqrt(1.0 - s * s), luts_build.MU_FLOOR), np.broadcast_to(etas, s.shape))
    np.testing.assert_allclose(t[:, 0, :], 1.0 - f, atol=1e-6)
    assert (t[:, 1:, luts.N_MS_ETA // 2] == 1.0).all()
    ops = NumpyOps()
    mu = np.linspace(0.01, 1.0, 97)
    for e in (1 / 1.7, 1 / 1.5, 1.5):
        np.testing.assert_allclose(trapped_escape(ops, mu, np.zeros_like(mu), e), 1.0 - fresnel_dielectric(ops, mu, e),
                                   atol=1e-6)
    inside = slice(0, int(luts.MS_KNEE * (luts.N_MS_X - 1)))  # up to the critical angle
    denser = etas < 0.9
    assert (t[inside, 4:, :][..., denser] < 1.0 - r[inside, 4:, :][..., denser]).all()


def test_rough_dielectric_table_is_exact_in_its_limits():
    """A smooth interface reflects its Fresnel factor, an index-matched one nothing, in the table
    and through the model's look-up (which hands over to the exact Fresnel factor near alpha 0)."""
    from lamella_dev.microsurface import _fresnel_dielectric
    from lamella.core.models.fresnel import fresnel_dielectric

    t = luts.table("dielectric_rough_reflect")
    etas = luts._ms_eta_nodes(luts.N_MS_ETA)
    s = np.array([[luts.ms_sine(i / (luts.N_MS_X - 1.0), e) for e in etas] for i in range(luts.N_MS_X)])
    f = _fresnel_dielectric(np.maximum(np.sqrt(1.0 - s * s), luts_build.MU_FLOOR), np.broadcast_to(etas, s.shape))
    np.testing.assert_allclose(t[:, 0, :], f, atol=1e-6)
    assert (t[:, :, luts.N_MS_ETA // 2] == 0.0).all()
    ops = NumpyOps()
    mu = np.linspace(0.01, 1.0, 97)
    for e in (1 / 1.7, 1 / 1.5, 1 / 1.33, 1.33, 1.5):
        np.testing.assert_allclose(fgd_dielectric(ops, mu, np.zeros_like(mu), e, multiple=True),
                                   fresnel_dielectric(ops, mu, e), atol=1e-6)


@pytest.mark.parametrize("mu,alpha,eta", [(0.8, 0.3, 1 / 1.5), (0.55, 0.2, 1 / 1.5), (0.3, 0.12, 1.5),
                                          (0.5, 0.25, 1 / 1.33), (0.95, 0.6, 1 / 1.7), (0.2, 0.3, 2.2),
                                          (0.62, 0.1, 1 / 1.3), (0.74, 0.05, 1 / 1.5), (0.66, 0.2, 1 / 1.3),
                                          (0.9, 0.05, 1 / 1.5)])
def test_dielectric_reflectance_matches_the_microsurface_walk(mu, alpha, eta):
    """FGD plus the multiple-scattering table is the whole reflectance of the energy-conserving
    interface (Heitz et al. 2016), between the tables' nodes, from either side, at and near the
    critical angle of the denser side: an independent walk with other random numbers, 100,000
    walks (standard error at most 0.0016). Without the table, from the denser side, the
    single-scattering FGD misses up to 0.3 of it."""
    from lamella_dev import microsurface

    k = 100_000
    wi = np.broadcast_to([np.sqrt(1.0 - mu * mu), 0.0, mu], (k, 3))
    o, _, left = microsurface.walk(wi, alpha, alpha, np.random.default_rng(2024), eta=np.full(k, eta))
    walk = np.mean(left & (o[:, 2] > 0))
    got = float(fgd_dielectric(NumpyOps(), np.array(mu), np.array(alpha), eta, multiple=True))
    assert got == pytest.approx(walk, abs=0.015)


def test_stored_refraction_table_matches_the_generator():
    np.testing.assert_allclose(luts.table("ggx_refract_albedo"), luts_build.generate_refract_albedo(), atol=2e-6)


@pytest.mark.parametrize("eta,alpha,degrees", [(1.0, 0.05, 0.0), (1.0, 0.2, 0.0), (1.0, 0.45, 0.0),
                                               (1.5, 0.03, 45.0), (1.33, 0.03, 70.0)])
def test_transmission_lobe_carries_its_weight(eta, alpha, degrees):
    """The sampled transmittance in ``ggx_refract_albedo`` normalises the transmission lobe kind's
    closure as integrated by quadrature of its pointwise value (a different estimator): the lobe
    transmits its weight, up to what falls above the horizon (nothing for these lobes), also with
    the closure normal tilted away from the view (mu' < 1)."""
    from lamella.core import lobe_kinds
    from lamella.core.models.types import Lobe

    ops = NumpyOps()
    kind = lobe_kinds.kind("transmission")
    th = np.radians(degrees)
    wi = (np.sin(th), 0.0, np.cos(th))
    lobe = Lobe(None, alpha, alpha, 0.0, "transmission", eta)
    nt, nphi = 1200, 480
    t, p = np.meshgrid((np.arange(nt) + 0.5) / nt * np.pi / 2 + np.pi / 2, (np.arange(nphi) + 0.5) / nphi * 2 * np.pi,
                       indexing="ij")
    wo = (np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t))
    energy = (kind.closure_cos(ops, lobe, wi, wo) * np.sin(t)).sum() * (np.pi / 2 / nt) * (2 * np.pi / nphi)
    assert abs(energy * kind.scale(ops, lobe, wi) - 1.0) < 3e-3


def test_tir_column_at_eta_one_is_exactly_one():
    assert (luts.table("tir")[:, :, -1] == 1.0).all()
    assert (luts.table("tir")[:, 0, :] == 1.0).all()


POINTS = [(0.63, 0.07), (0.21, 0.33), (0.9, 0.52), (0.05, 0.12)]


@pytest.mark.parametrize("mu,alpha", POINTS)
def test_off_node_error(mu, alpha):
    ops = NumpyOps()
    assert abs(float(gd(ops, mu, alpha)) - _integrate(mu, alpha, lambda c, o: 1.0)) < 2e-3
    for eta, k in METALS.values():
        got = list(fgd_conductor(ops, mu, alpha, RGB(*eta), RGB(*k)))
        for ch in range(3):
            exact = _integrate(mu, alpha, lambda c, o: fresnel_conductor(ops, c, eta[ch], k[ch]))
            assert abs(float(got[ch]) - exact) < 5e-3
    for eta in (1.5, 0.7, 1.02):
        exact = _integrate(mu, alpha, lambda c, o: fresnel_dielectric(ops, c, eta))
        assert abs(float(fgd_dielectric(ops, mu, alpha, eta)) - exact) < 2e-2


def test_packed_atlas_holds_the_same_values_as_the_table():
    """The RGBA-packed copy the OSL shaders read four slices at a time from (luts.PACKED) is the
    same float32 data as the one-channel table numpy reads."""
    import OpenEXR

    for name, fname in luts.PACKED.items():
        t = luts.table(name)
        with OpenEXR.File(str(luts.DATA_DIR / fname)) as f:
            px = np.asarray(f.channels()["RGBA"].pixels)
        n0, n1, n2 = t.shape
        assert px.shape == (2 * (n2 // 4) * n0, n1, 4)  # the atlas above its mirror image
        px = luts.from_file(px, fname)
        for k in range(n2):
            g, c = divmod(k, 4)
            np.testing.assert_array_equal(px[g * n0:(g + 1) * n0, :, c], t[:, :, k])


@pytest.mark.parametrize("name", sorted(luts.SPECS))
def test_numpy_archive_holds_the_exr_tables(name):
    """The numpy backend reads tables.npz (inside Blender there is no OpenEXR package); the OSL
    shaders read the EXR files: both must hold the same float32 values."""
    np.testing.assert_array_equal(luts.table(name), luts.read_exr_table(name))


def test_every_file_holds_its_atlas_above_its_mirror_image():
    """OSL's texture() counts t from a file's first row (OpenImageIO, Blender up to 5.0) or from its
    last (Cycles from Blender 5.1): each file is symmetric top to bottom, so both read the same
    value (``luts.to_file``), and the header the shaders inline reads it at half its t."""
    import OpenEXR

    from lamella.core.backends.osl.emit import LUT_HEADER, OSL_DIR

    files = {s.file: s.channel for s in luts.SPECS.values()} | {f: "RGBA" for f in luts.PACKED.values()}
    for fname, channel in files.items():
        with OpenEXR.File(str(luts.DATA_DIR / fname)) as f:
            px = np.asarray(f.channels()[channel].pixels)
            assert f.header()["lamella_layout"] == str(luts.LAYOUT)
        np.testing.assert_array_equal(px, px[::-1])
    header = (OSL_DIR / LUT_HEADER).read_text()
    assert luts.LAYOUT_MARK in header and header.count("/ (2 * rows)") == 2
    with pytest.raises(ValueError, match="layout"):
        luts.from_file(np.arange(6.0).reshape(3, 2))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("shape", [(17, 9), (17, 13, 5)])
def test_a_one_point_look_up_is_a_lane_of_a_batched_one(dtype, shape):
    """A one-direction model run reads its tables one point at a time (``numpy_ops``'s scalar
    path): the same bits as that point among others, clamping outside [0, 1] and the top node
    included, in float32 and float64."""
    from lamella.core.backends.numpy_ops import _multilinear

    rng = np.random.default_rng(3)
    table = rng.uniform(-1.0, 2.0, shape).astype(dtype)
    edges = np.array([-0.3, 0.0, 1.0, 1.4, 0.5], dtype=dtype)
    points = np.concatenate([rng.uniform(-0.2, 1.2, (400, len(shape))),
                             np.stack(np.meshgrid(*[edges] * len(shape)), -1).reshape(-1, len(shape))]).astype(dtype)
    batched = _multilinear(table, [points[:, k] for k in range(len(shape))], dtype)
    for p, want in zip(points, batched):
        got = _multilinear(table, [np.array([x], dtype=dtype) for x in p], dtype)
        assert got.dtype == dtype and got.shape == (1,)
        assert got[0] == want, (p, got[0], want)
