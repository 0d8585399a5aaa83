"""The brute-force image reference (stack as nested interface spheres, lamella_dev.reference_scene)
is judged by the BRDF-space stochastic reference (lamella_dev.reference): under a white furnace
every sphere pixel is the stack's directional albedo for that pixel's view, so rings of pixels at a
given view angle must match ``reference.albedo`` at that angle.

Tolerance 2 %: a band of pixels at 256 spp has a noise of about 0.3 % and ``reference.albedo``
(2^14 walkers per 2-degree bin, evaluated at the band's own pixel angles) about 0.3 %; the shells
(0.004 thick) and the faceted mesh add a few 0.1 %. Measured: within 0.3 % in every band and
channel except tinted_varnish's blue at 55-65 deg (1.3 %, its smallest albedo, 0.14).
A wrong relative IOR, a missed back-face inversion or a volume density off by the shell
thickness moves these by 5-50 %.

The same yardstick judges the scattering media (a fog over gold) and the diffuse core (varnish
over a Lambertian base); white-furnace renders of lossless stacks (media over a mirror, a white
diffuse core, a smooth glass core) must stay at 1, and stacks that nested volumes cannot express
are refused with the layer named.
"""

import numpy as np
import pytest

from lamella.core import Stack
from lamella_dev import reference, suite

pytest.importorskip("bpy")
from lamella_dev.reference_scene import absorption_densities, interface_radii  # noqa: E402
from lamella_dev.render import render_stack  # noqa: E402

RES = 64


def view_angles(res):
    """The view zenith angle (degrees) of every pixel of the canonical orthographic camera."""
    c = (np.arange(res) + 0.5) / res * 2.2 - 1.1
    X, Z = np.meshgrid(c, -c)
    return np.degrees(np.arcsin(np.clip(np.hypot(X, Z), 0.0, 1.0)))


def assert_bands_match_the_albedo(stack, interfaces="single", tolerance=0.02):
    """The white-furnace render of ``stack`` as nested spheres against ``reference.albedo`` (both
    with ``interfaces``) in three bands of view angle: each band's mean within ``tolerance``."""
    px, _ = render_stack(stack, "white-furnace", res=RES, spp=256, engine="reference", interfaces=interfaces)
    assert np.isfinite(px).all() and (px >= 0).all()
    theta = view_angles(RES)
    for lo, hi in ((0.0, 20.0), (25.0, 35.0), (55.0, 65.0)):
        m = (theta >= lo) & (theta < hi) & (px[..., 3] > 0.999)
        got = px[m, :3].mean(0)
        # the reference at each pixel's own angle (2-degree bins), averaged like the pixels
        edges = np.arange(lo, hi + 1e-9, 2.0)
        counts, _ = np.histogram(theta[m], edges)
        centres = 0.5 * (edges[1:] + edges[:-1])
        wi = np.stack([suite.incident(t) for t in centres])
        want, _ = reference.albedo(stack, wi, spp=1 << 14, seed=7, interfaces=interfaces)
        want = (np.asarray(want).reshape(-1, 3) * counts[:, None]).sum(0) / counts.sum()
        rel = np.abs(got - want) / want
        print(stack.name, interfaces, (lo, hi), got, want, rel)
        assert rel.max() < tolerance, ((lo, hi), got, want)


@pytest.mark.parametrize("case", ["gold_coated", "tinted_varnish"])
def test_nested_spheres_reproduce_the_stochastic_albedo(case):
    assert_bands_match_the_albedo(suite.load(case))


def test_energy_conserving_interfaces_keep_a_lossless_stack_white():
    """``interfaces="multiple"`` (Cycles' multiscatter GGX in every interface): a rough coat over a
    perfect mirror, both alpha 0.3, loses nothing, so the white furnace renders about 1; with
    single-scattering interfaces the microsurfaces' masking loses a quarter of the light.
    Measured at 32 px, 64 spp: mean 0.985 against 0.716."""
    from lamella.core.stack import Stack

    d = {"name": "mirror_under_rough_coat", "layers": [{"type": "coat", "ior": 1.5, "roughness": 0.3}],
         "base": {"type": "conductor", "eta": [0.001] * 3, "k": [1000.0] * 3, "roughness": 0.3}}
    means = {}
    for interfaces in ("single", "multiple"):
        px, _ = render_stack(Stack.from_dict(d), "white-furnace", res=32, spp=64, engine="reference",
                             interfaces=interfaces)
        assert np.isfinite(px).all() and (px >= 0).all()
        means[interfaces] = float(px[px[..., 3] > 0.999, :3].mean())
    assert means["multiple"] > 0.97 and means["single"] < 0.8, means


def test_energy_conserving_nested_spheres_reproduce_the_energy_conserving_albedo():
    """gold_coated with Cycles' multiscatter GGX interfaces against ``reference.albedo`` with
    Heitz et al. 2016's random walk (``interfaces="multiple"``), bands as above: within 2 %
    (measured 0.2-1.0 %). The two keep a microsurface's energy differently: Cycles scales the
    single-scattering lobe by 1 / E (its shape unchanged) where the walk spreads it, so under a
    rougher coat they part: rough_coat_over_mirror (coat alpha 0.3) is 4-7 % apart in green and
    blue (not asserted)."""
    assert_bands_match_the_albedo(suite.load("gold_coated"), interfaces="multiple")


def test_shell_geometry():
    stack = suite.load("three_coats")
    assert interface_radii(stack, 0.004) == pytest.approx([1.0, 0.996, 0.992, 0.988])
    with pytest.raises(ValueError, match="half the sphere"):
        interface_radii(stack, 0.2)


def test_absorption_is_split_over_nested_volumes():
    d = suite.load("tinted_varnish").to_dict()
    dens = absorption_densities(suite.load("tinted_varnish"), 0.004)
    c = d["layers"][0]
    assert dens[0] == pytest.approx(tuple(s * c["thickness"] / 0.004 for s in c["sigma_a"]))
    # a coat absorbing less than the one above it cannot be built from additive nested volumes
    d["layers"] = [dict(c), dict(c, sigma_a=[0.0, 0.0, 0.0], thickness=0.0)]
    from lamella.core import Stack

    with pytest.raises(ValueError, match="coat 1"):
        absorption_densities(Stack.from_dict(d), 0.004)


def test_bare_conductor_pins_tangent_rotation_and_axes():
    """With no coat the model's GGX lobe is exact, so the reference's conductor sphere and the
    generated shader render nearly the same image; this pins the reference's tangent, rotation
    sense and alpha axes to the shader's. Nearly: what the microsurface scatters more than once the
    models send out as a diffuse lobe, Cycles' energy-conserving sphere (``multi_ggx``) inside the
    lobe's shape (the walk on the microsurface agrees with neither exactly; against it the diffuse
    form measures better on isotropic metals, `docs/models.md`). Measured at 64 px, 64 spp:
    8x8-tile RMSE 0.025 (2.3 % of the light scattered more than once, mean bias +0.041 in this
    environment; 0.0024 while the models left that light out, against the single-scattering
    sphere); with the rotation mirrored 0.152, with the axes swapped 0.227 (at 256 spp 0.025,
    0.148 and 0.223: the tile means are the model's difference, not noise)."""
    from lamella.core import Stack
    from lamella_dev.image_metrics import block_rmse

    d = {"layers": [], "base": {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603],
                                "roughness": [0.02, 0.2], "rotation": 0.5}}
    ref, _ = render_stack(Stack.from_dict(d), "sphere-env", res=64, spp=64, engine="reference",
                          interfaces="multiple")
    ours, _ = render_stack(Stack.from_dict(d), "sphere-env", res=64, spp=64, engine="cycles-osl")
    d["base"]["rotation"] = -0.5
    mirrored, _ = render_stack(Stack.from_dict(d), "sphere-env", res=64, spp=64, engine="cycles-osl")
    d["base"]["rotation"], d["base"]["roughness"] = 0.5, [0.2, 0.02]
    swapped, _ = render_stack(Stack.from_dict(d), "sphere-env", res=64, spp=64, engine="cycles-osl")
    m = ref[..., 3] > 0.999
    right = block_rmse(ours, ref, m, 8)
    assert right < 0.04
    assert block_rmse(mirrored, ref, m, 8) > 3.0 * right and block_rmse(swapped, ref, m, 8) > 3.0 * right


# ----------------------------------------------------------------- media, diffuse and glass cores
GOLD = {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603], "roughness": 0.02}
# |eta + i k| huge: normal Fresnel reflectance about 1 - 4 eta / k^2 = 1 - 4e-12, a lossless mirror
MIRROR = {"type": "conductor", "eta": [1e-4] * 3, "k": [1e4] * 3, "roughness": 0.0}
FOG = {"ior": 1.0, "roughness": 0.0, "thickness": 1.0, "sigma_s": [0.755] * 3, "g": 0.3}  # a pure medium


def _stack(layers, base):
    from lamella.core import Stack

    return Stack.from_dict({"layers": layers, "base": base})


def _render_scene(sc):
    """Render a scene built by hand (render_stack's EXR round trip): RGBA, top row first."""
    import tempfile
    from pathlib import Path

    import bpy

    from lamella.core.exr import read_rgba

    with tempfile.TemporaryDirectory() as tmp:
        sc.render.image_settings.file_format = "OPEN_EXR"
        sc.render.image_settings.color_depth = "32"
        sc.render.filepath = str(Path(tmp) / "render.exr")
        bpy.ops.render.render(write_still=True)
        return read_rgba(Path(tmp) / "render.exr")


def _band_means(px, bands=((0.0, 20.0), (25.0, 35.0), (55.0, 65.0), (70.0, 80.0))):
    theta = view_angles(px.shape[0])
    return np.array([px[(theta >= lo) & (theta < hi), :3].mean(0) for lo, hi in bands])


def _relative_to_stochastic_albedo(stack, px, bands=((0.0, 20.0), (25.0, 35.0), (55.0, 65.0))):
    """|band mean - reference.albedo| / reference.albedo per band and channel, the reference taken
    at the band's own pixel angles (2-degree bins) and averaged like the pixels."""
    from lamella_dev import reference

    theta = view_angles(px.shape[0])
    out = []
    for lo, hi in bands:
        m = (theta >= lo) & (theta < hi)
        got = px[m, :3].mean(0)
        edges = np.arange(lo, hi + 1e-9, 2.0)
        counts, _ = np.histogram(theta[m], edges)
        wi = np.stack([suite.incident(t) for t in 0.5 * (edges[1:] + edges[:-1])])
        want, _ = reference.albedo(stack, wi, spp=1 << 14, seed=7)
        want = (np.asarray(want).reshape(-1, 3) * counts[:, None]).sum(0) / counts.sum()
        out.append(np.abs(got - want) / want)
        print((lo, hi), got, want, out[-1])
    return np.array(out)


def test_fog_over_gold_reproduces_the_stochastic_albedo():
    """A scattering medium (sigma_s 0.755, g 0.3, depth 1, behind an index-matched boundary) over
    gold, judged like the coats above. Measured at 64 px, 256 spp: relative differences at most
    0.1 % in red and green and 0.4 / 0.8 / 0.95 % in blue (the 0-20 / 25-35 / 55-65 degree bands);
    without the medium, blue is 24-31 % lower, and a medium whose density ignored the shell
    thickness would be 250 times too dense."""
    stack = _stack([FOG], GOLD)
    px, _ = render_stack(stack, "white-furnace", res=RES, spp=256, engine="reference")
    assert np.isfinite(px).all() and (px >= 0).all()
    assert _relative_to_stochastic_albedo(stack, px).max() < 0.02


def test_shell_volumes_split_scattering_over_nested_spheres():
    from lamella_dev.reference_scene import shell_volumes

    d = 0.004
    (v,) = shell_volumes(_stack([dict(FOG, sigma_a=[0.1, 0.2, 0.3])], GOLD), d)
    assert v.sigma_s == pytest.approx((0.755 / d,) * 3) and v.g == 0.3
    assert v.sigma_a == pytest.approx((0.1 / d, 0.2 / d, 0.3 / d))
    # identical media below a scattering coat: the inner sphere adds nothing
    lacquer_fog = dict(FOG, ior=1.5, roughness=0.05)
    v0, v1 = shell_volumes(_stack([FOG, lacquer_fog], GOLD), d)
    assert v0.sigma_s == pytest.approx((0.755 / d,) * 3) and v1.empty
    # more scattering with the same g below: the inner sphere adds the difference, same g
    v0, v1 = shell_volumes(_stack([FOG, dict(lacquer_fog, thickness=3.0)], GOLD), d)
    assert v1.sigma_s == pytest.approx((2 * 0.755 / d,) * 3) and v1.g == 0.3


@pytest.mark.parametrize("below", [
    {"ior": 1.5, "roughness": 0.05},  # a clear coat: the fog would fill its shell
    dict(FOG, g=0.5),  # another phase function: not a sum of Henyey-Greenstein volumes of one g
    dict(FOG, thickness=0.5),  # thinner: a scattering density cannot be subtracted
])
def test_scattering_that_would_leak_into_lower_coats_is_refused(below):
    from lamella_dev.reference_scene import shell_volumes

    with pytest.raises(ValueError, match="coat 0: its scattering .* coat 1 below it"):
        shell_volumes(_stack([FOG, below], GOLD))


def test_glass_under_a_medium_is_refused():
    from lamella_dev.reference_scene import shell_volumes

    glass = {"type": "dielectric", "ior": 1.5, "roughness": 0.1}
    with pytest.raises(ValueError, match="coat 0: the dielectric base"):
        shell_volumes(_stack([{"ior": 1.5, "thickness": 0.5, "sigma_a": [0.1, 0.2, 0.3]}], glass))
    assert all(v.empty for v in shell_volumes(_stack([{"ior": 1.5, "roughness": 0.05}], glass)))


def test_scattering_coat_builds_and_renders():
    """An absorbing, scattering dielectric coat: a finite, non-negative image, the volume of the
    shell built with the coat's coefficients times thickness / d, HG phase, and the bounce limits
    raised for the volume's random walk."""
    import bpy

    from lamella_dev.reference_scene import MEDIUM_BOUNCES, SHELL_THICKNESS

    coat = {"ior": 1.5, "roughness": 0.05, "thickness": 0.5, "sigma_a": [1.0, 0.2, 1.0], "sigma_s": [0.7] * 3,
            "g": 0.6}
    px, _ = render_stack(_stack([coat], GOLD), "sphere-env", res=32, spp=32, engine="reference")
    assert np.isfinite(px).all() and (px >= 0).all()
    assert px[view_angles(32) < 80, :3].mean() > 0.01
    nodes = bpy.data.materials["interface_0"].node_tree.nodes
    vol = next(n for n in nodes if n.bl_idname == "ShaderNodeVolumeCoefficients")
    k = 0.5 / SHELL_THICKNESS
    assert tuple(vol.inputs["Scatter Coefficients"].default_value) == pytest.approx((0.7 * k,) * 3, rel=1e-6)
    assert tuple(vol.inputs["Absorption Coefficients"].default_value) == pytest.approx((k, 0.2 * k, k), rel=1e-6)
    assert vol.inputs["Anisotropy"].default_value == pytest.approx(0.6)
    assert vol.phase == "HENYEY_GREENSTEIN"
    c = bpy.context.scene.cycles
    assert c.volume_bounces == c.max_bounces == MEDIUM_BOUNCES


@pytest.mark.parametrize("layers", [
    [FOG],  # a pure medium behind an invisible boundary
    [dict(FOG, ior=1.5)],  # the same medium inside a smooth dielectric coat (light trapped by TIR)
    [dict(FOG, sigma_s=[4.0] * 3, g=0.7)],  # optical depth 4: needs more than 64 bounces
])
def test_lossless_medium_over_a_mirror_is_white_in_the_furnace(layers):
    """Nothing absorbs: every sphere pixel must show the furnace's radiance 1. Measured at 48 px,
    64 spp: band means 0.996-0.999 (pure fog), 1.0000 (in a smooth coat), 0.999-1.000 (depth 4;
    0.981-0.988 with 64 bounces)."""
    px, _ = render_stack(_stack(layers, MIRROR), "white-furnace", res=48, spp=64, engine="reference")
    assert np.isfinite(px).all() and (px >= 0).all()
    means = _band_means(px)
    print(means)
    assert np.abs(means - 1.0).max() < 0.015


def test_diffuse_core_with_albedo_one_is_white_in_the_furnace():
    px, _ = render_stack(_stack([], {"type": "diffuse", "albedo": [1.0, 1.0, 1.0]}), "white-furnace", res=32,
                         spp=64, engine="reference")
    means = _band_means(px)
    print(means)
    assert np.abs(means - 1.0).max() < 0.005


def test_diffuse_core_under_varnish_reproduces_the_stochastic_albedo():
    """Varnished wood (absorbing coat ior 1.5 over a Lambertian albedo (0.5, 0.3, 0.15)): measured
    at 64 px, 256 spp within 1 % of reference.albedo in every band and channel."""
    layers = [{"ior": 1.5, "roughness": 0.05, "thickness": 0.5, "sigma_a": [0.1, 0.3, 0.6]}]
    stack = _stack(layers, {"type": "diffuse", "albedo": [0.5, 0.3, 0.15]})
    px, _ = render_stack(stack, "white-furnace", res=RES, spp=256, engine="reference")
    assert _relative_to_stochastic_albedo(stack, px).max() < 0.02


def test_glass_core_renders():
    """A rough glass ball under a rotated anisotropic coat renders finite and non-negative; a
    smooth one (lossless delta interfaces, light leaving through the ball's back) is white in the
    furnace."""
    glass = {"type": "dielectric", "ior": 1.5, "roughness": [0.1, 0.3], "rotation": 0.4}
    coat = {"ior": 1.3, "roughness": [0.05, 0.1], "rotation": 0.3}
    px, _ = render_stack(_stack([coat], glass), "sphere-env", res=32, spp=32, engine="reference")
    assert np.isfinite(px).all() and (px >= 0).all()
    assert px[view_angles(32) < 80, :3].mean() > 0.01
    smooth = {"type": "dielectric", "ior": 1.5}
    px, _ = render_stack(_stack([{"ior": 1.3}], smooth), "white-furnace", res=32, spp=32, engine="reference")
    assert np.abs(_band_means(px) - 1.0).max() < 0.005


def test_pure_medium_boundary_is_invisible():
    """An index-matched smooth boundary (ior 1 under air, roughness 0) is a Transparent BSDF: over
    smooth gold (so that pixels do not depend on random numbers, which the extra transparent
    bounce shifts) the image is the same as without that sphere. Measured at 64 px: max difference
    2.4e-4, mean 1.6e-7 (float noise). Cycles' own smooth dielectric at eta = 1 is not invisible:
    mean -0.4 % and outliers up to 10 under the forest HDRI, and over rough gold it blocks the
    sun's light entirely (a delta light behind a delta interface)."""
    import bpy

    from lamella_dev.reference_scene import build_reference
    from lamella_dev.render import build_scene

    stack = _stack([{"ior": 1.0, "roughness": 0.0}], dict(GOLD, roughness=0.0))
    images = []
    for keep_boundary in (True, False):
        sc, sphere = build_scene("sphere-env", 32, 16)
        build_reference(sc, sphere, stack)
        if not keep_boundary:
            bpy.data.objects.remove(bpy.data.objects["interface_0"])
        images.append(_render_scene(sc))
    assert bpy.data.materials["interface_0"].node_tree.nodes.get("Transparent BSDF") is not None
    assert np.abs(images[0] - images[1]).max() < 1e-3
    assert abs(float(np.mean(images[0][..., :3] - images[1][..., :3]))) < 1e-5


def test_media_are_sampled_as_homogeneous():
    """Constant volume coefficients take Cycles' homogeneous path (analytic transmittance and
    distance sampling): even the biased ray marcher, held to 2 steps of 1/100 of its step size,
    renders the same image as with its defaults."""
    import bpy

    from lamella_dev.reference_scene import build_reference
    from lamella_dev.render import build_scene

    images = []
    for rate, steps in ((1.0, 1024), (0.01, 2)):
        sc, sphere = build_scene("white-furnace", 32, 16)
        build_reference(sc, sphere, _stack([dict(FOG, sigma_s=[4.0] * 3)], GOLD))
        sc.cycles.volume_biased = True
        sc.cycles.volume_step_rate = rate
        sc.cycles.volume_max_steps = steps
        images.append(_render_scene(sc))
        assert all(m.cycles.volume_sampling == "DISTANCE" for m in bpy.data.materials if m.name.startswith("interface"))
    assert np.abs(images[0] - images[1]).max() < 1e-5


def test_a_partly_covering_coat_is_the_mix_of_its_parts_spheres():
    """Coverage 0.4: the render mixes the nested spheres with and without the coat (0.4 and 0.6),
    and the mix reproduces the stochastic albedo, which mixes its walks the same way."""
    d = suite.load("tinted_varnish").to_dict()
    d["layers"][0]["coverage"] = 0.4
    stack = Stack.from_dict(d)
    assert [w for w, _ in reference.covered_parts(stack)] == pytest.approx([0.6, 0.4])
    assert_bands_match_the_albedo(stack)
