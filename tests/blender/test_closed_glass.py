"""Coated glass on a closed sphere, in every backend: the exactness tests use an open-backed
sphere and never see a back face, where Cycles' Refraction BSDF node inverts its index. In the
white furnace a lossless glass stack returns the light it receives."""
import numpy as np
import pytest

from lamella.core.stack import Stack

pytest.importorskip("bpy")
from lamella_dev.render import assign_material, build_scene, render_scene  # noqa: E402

GLASS = {
    "coated_glass": {"layers": [{"ior": 1.5, "roughness": 0.1}], "base": {"type": "dielectric", "ior": 1.5, "roughness": 0.1}},
    "rough_glass_plate": {"layers": [], "base": {"type": "dielectric", "ior": 1.5, "roughness": 0.3}},
}
# white furnace, 32 px, 16 spp: measured 1.000 (OSL and nodes in Cycles) and 0.95 (EEVEE, whose
# refraction is screen-space: a closed glass object renders a little dark)
FLOOR = {"cycles-osl": 0.98, "cycles-nodes": 0.98, "eevee": 0.9}


@pytest.mark.parametrize("engine", list(FLOOR))
@pytest.mark.parametrize("case", list(GLASS))
def test_closed_glass_is_transparent_in_the_white_furnace(addon, engine, case):
    sc, sphere = build_scene("white-furnace", 32, 16)
    assign_material(sphere, Stack.from_dict(GLASS[case]), engine)
    px = render_scene(sc)[0]
    on = px[..., 3] > 0.999
    mean = float(px[on, :3].mean())
    assert FLOOR[engine] <= mean <= 1.02, (engine, case, mean)
    assert np.isfinite(px).all() and (px >= 0).all()
