"""Coverage in Blender: a coat's Coverage input on the Lamella node takes a mask, and in Cycles with
OSL, Cycles without OSL and EEVEE the material renders as the mix, pixel by pixel, of the stack
with the coat and the stack without it, weighted by the mask (the definition of coverage,
``lamella.core.models.coverage``)."""
import numpy as np
import pytest

pytest.importorskip("bpy")
from lamella.blender import api, recompile  # noqa: E402
from lamella_dev.render import node_tree  # noqa: E402

from .addon_helpers import engine_scene, new_material, render  # noqa: E402

WOOD = {"type": "diffuse", "albedo": [0.5, 0.3, 0.15]}
VARNISH = {"ior": 1.5, "roughness": 0.01, "thickness": 0.4, "sigma_a": [0.1, 0.5, 1.5]}


def _mask(nt):
    """A mask varying across the sphere: 0 on its left half, rising to 1 at its right edge."""
    coords = nt.nodes.new("ShaderNodeTexCoord")
    ramp = nt.nodes.new("ShaderNodeTexGradient")
    nt.links.new(coords.outputs["Object"], ramp.inputs["Vector"])
    return ramp.outputs["Fac"]


def _render(engine, what):
    sc, sphere = engine_scene(engine, res=48, spp=32)
    mat = new_material(sphere, f"coverage_{engine}_{what}")
    nt = node_tree(mat)
    if what == "mask":  # the mask itself, as the renderer sees it at each pixel
        nt.nodes.clear()
        out, emit = nt.nodes.new("ShaderNodeOutputMaterial"), nt.nodes.new("ShaderNodeEmission")
        nt.links.new(_mask(nt), emit.inputs["Color"])
        nt.links.new(emit.outputs[0], out.inputs["Surface"])
    else:
        api.apply_stack(mat, {"layers": [] if what == "without" else [VARNISH], "base": WOOD})
        if what == "masked":
            nt.links.new(_mask(nt), api.input_socket(mat, 0, "coverage"))
            recompile.flush()
    px = render(sc)
    return px, mat


@pytest.mark.parametrize("engine", ["osl", "svm", "eevee"])
def test_a_mask_in_a_coats_coverage_renders_the_mix_of_the_stacks_with_and_without_the_coat(addon, engine):
    masked, mat = _render(engine, "masked")
    assert mat.lamella.status == "OK", mat.lamella.status_message
    assert "coat0_coverage" in mat.lamella.live_params
    with_, without, mask = (_render(engine, w)[0] for w in ("with", "without", "mask"))
    on = with_[..., 3] > 0.999  # the sphere, not its antialiased rim
    m = mask[..., :1]
    assert m[on].min() < 0.01 and m[on].max() > 0.9  # the mask spans bare wood to full varnish
    want = m * with_[..., :3] + (1 - m) * without[..., :3]
    err = np.abs(masked[..., :3] - want)[on].mean() / want[on].mean()
    control = np.abs(with_[..., :3] - without[..., :3])[on].mean() / want[on].mean()
    assert err < 0.04 and control > 0.3, (err, control)


def test_the_coverage_input_is_on_the_node_and_in_the_panel(addon):
    mat = addon.data.materials.new("coverage_inputs")
    api.apply_stack(mat, {"layers": [{**VARNISH, "coverage": 0.25}], "base": WOOD})
    sock = api.input_socket(mat, 0, "coverage")
    assert sock is not None and abs(sock.default_value - 0.25) < 1e-6 and "Coverage" in sock.name
    assert abs(mat.lamella.coats[0].coat.coverage - 0.25) < 1e-6
    assert api.read_stack(mat)["layers"][0]["coverage"] == pytest.approx(0.25)
    assert mat.lamella.status == "OK", mat.lamella.status_message
