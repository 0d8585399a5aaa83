"""Cycles never renders NaN, Inf or negative pixels for any stack kind, including the
sphere's silhouette, where smooth-shaded normals face away from the viewer (N.I <= 0), and the
4-coat example, every case on its own sphere of one scene; and a passive stack never reflects
more than it receives (white furnace)."""
import math

import numpy as np
import pytest

from lamella_dev import suite

pytest.importorskip("bpy")
from lamella_dev.render import assign_material, build_scene, render_scene, render_stack  # noqa: E402

from .addon_helpers import grid_pixels, sphere_grid  # noqa: E402


EXAMPLES = ["four_coats", "coated_glass"]
# every stack kind: the suite, the media / diffuse / glass / ENDF-sized cases, and the examples
CASES = suite.names() + list(suite.pending_descriptions()) + EXAMPLES


def load(case):
    return suite.example(case) if case in EXAMPLES else suite.load(case)


def test_sphere_env_render_is_finite_and_non_negative():
    """Every case on its own sphere of one scene (Cycles with OSL), rendered once."""
    sc, sphere = build_scene("sphere-env", 24 * math.ceil(math.sqrt(len(CASES))), 4)
    spheres = sphere_grid(sc, sphere, len(CASES))
    for case, (ob, _, _) in zip(CASES, spheres):
        assign_material(ob, load(case), "cycles-osl")
    px, _ = render_scene(sc)
    assert np.isfinite(px).all(), f"{np.count_nonzero(~np.isfinite(px))} non-finite values"
    assert (px >= 0).all(), f"min {px.min()}"
    for case, (_, centre, radius) in zip(CASES, spheres):
        assert grid_pixels(px, centre, radius)[:, :3].mean() > 0.01, case


@pytest.mark.parametrize("case,spp", [("gold_coated", 16), ("four_coats", 16), ("varnished_wood", 16),
                                      ("rough_glass_plate", 16), ("coated_glass", 16),
                                      # media: a back-scatter closure's samples weigh e / GD(1, alpha), up to
                                      # 3.3 e for alpha = 1, so a pixel needs more samples for the same noise
                                      ("fog_g09_d1", 128), ("milky_coat_d2", 128)])
def test_white_furnace_reflects_at_most_what_it_receives(case, spp):
    px, _ = render_stack(load(case), "white-furnace", res=40, spp=spp)
    sphere = px[..., 3] > 0.999
    assert np.isfinite(px).all() and (px >= 0).all()
    # the lobes are normalised, so each pixel is the predicted albedo <= 1 (up to sampling noise
    # of the closures' importance sampling, well below 2 %)
    assert px[sphere, :3].mean(0).max() <= 1.0
    assert np.percentile(px[sphere, :3], 99) <= 1.02
