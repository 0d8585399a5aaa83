"""Coated glass on a closed sphere, in every backend: the exactness tests use an open-backed
sphere and never see a back face, where Cycles' Refraction BSDF node inverts its index. A solid
lossless glass ball in the white furnace returns the light it receives once the light totally
reflected inside it may bounce until it leaves (bounce limits raised to 64: Principled glass of
index 1.5 renders 0.9985 at roughness 0.32 and 0.9996 at 0.3 there, 0.943 and 0.945 at Cycles'
default 12)."""
import numpy as np
import pytest

from lamella.core.stack import Stack

pytest.importorskip("bpy")
from lamella_dev.render import assign_material, build_scene, render_scene  # noqa: E402

GLASS = {
    "coated_glass": {"layers": [{"ior": 1.5, "roughness": 0.1}], "base": {"type": "dielectric", "ior": 1.5, "roughness": 0.1}},
    "rough_glass_plate": {"layers": [], "base": {"type": "dielectric", "ior": 1.5, "roughness": 0.3}},
}
# white furnace, 32 px, 16 spp, 64 bounces: measured 0.987 for the rough glass ball (OSL and nodes
# in Cycles) and 0.95 (EEVEE, whose refraction is screen-space: a closed glass object renders a
# little dark)
FLOOR = {"cycles-osl": 0.98, "cycles-nodes": 0.98, "eevee": 0.9}
# Measured 1.038 in Cycles: inside the coated ball the light totally reflected at grazing
# incidence leaves as an anisotropic lobe (alpha 0.042 x 0.15 at 80 degrees, from an isotropic
# stack), and the reflection lobe's normaliser, 1 / GD at its RMS roughness, overshoots that lobe's
# albedo by 7 % there (0.889 against 0.951, integrated); each trapped bounce adds it.
GAINS = {("coated_glass", "cycles-osl"), ("coated_glass", "cycles-nodes")}


@pytest.mark.parametrize("engine", list(FLOOR))
@pytest.mark.parametrize("case", list(GLASS))
def test_closed_glass_is_transparent_in_the_white_furnace(addon, engine, case, request):
    if (case, engine) in GAINS:
        request.applymarker(pytest.mark.xfail(strict=True, reason="anisotropic lobes' 1 / GD normaliser at "
                                                                  "grazing incidence (module comment)"))
    sc, sphere = build_scene("white-furnace", 32, 16)
    c = sc.cycles
    c.max_bounces = c.glossy_bounces = c.transmission_bounces = 64
    assign_material(sphere, Stack.from_dict(GLASS[case]), engine)
    px = render_scene(sc)[0]
    on = px[..., 3] > 0.999
    mean = float(px[on, :3].mean())
    assert np.isfinite(px).all() and (px >= 0).all()
    assert FLOOR[engine] <= mean <= 1.02, (engine, case, mean)
