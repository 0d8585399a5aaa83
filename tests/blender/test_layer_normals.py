"""A normal per layer in Blender: a bump linked into a coat's or the base's Normal input on the
Lamella node is read by that layer's closures alone, the same in Cycles with OSL (the Script
node's ``coat0_normal``) and without (the node group's frame per BSDF), and reaches EEVEE."""
import numpy as np
import pytest

pytest.importorskip("bpy")
from lamella.blender import api  # noqa: E402
from lamella_dev.render import node_tree  # noqa: E402

from .addon_helpers import engine_scene, new_material, render  # noqa: E402

STACK = {"layers": [{"ior": 1.5, "roughness": 0.001}],
         "base": {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603], "roughness": 0.04}}


def _render(engine, layer):
    sc, sphere = engine_scene(engine, res=48, spp=32)
    mat = new_material(sphere, f"normals_{engine}_{layer}")
    api.apply_stack(mat, STACK)
    if layer is not None:
        nt = node_tree(mat)
        noise = nt.nodes.new("ShaderNodeTexNoise")
        noise.inputs["Scale"].default_value = 6.0
        bump = nt.nodes.new("ShaderNodeBump")
        bump.inputs["Strength"].default_value = 1.0
        nt.links.new(noise.outputs["Fac"], bump.inputs["Height"])
        nt.links.new(bump.outputs["Normal"], api.input_socket(mat, layer, "normal"))
    px = render(sc)
    return px, mat


def test_a_bumped_layer_renders_alike_in_cycles_with_and_without_osl_and_differs_from_the_flat_one(addon):
    flat, _ = _render("osl", None)
    on = flat[..., 3] > 0.999
    for layer, live in ((0, "coat0_normal"), ("base", "base_normal")):
        osl, mat = _render("osl", layer)
        assert mat.lamella.status == "OK" and live in mat.lamella.live_params.split(", ")
        svm, _ = _render("svm", layer)
        same = np.abs(osl - svm)[on, :3].mean() / osl[on, :3].mean()
        moved = np.abs(osl - flat)[on, :3].mean() / flat[on, :3].mean()
        assert np.isfinite(osl).all() and np.isfinite(svm).all()
        assert same < 0.03 and moved > 3 * same, (layer, same, moved)


def test_a_bumped_layer_renders_in_eevee(addon):
    px, mat = _render("eevee", 0)
    assert mat.lamella.status == "OK" and np.isfinite(px).all() and (px >= 0).all()
    assert px[px[..., 3] > 0.999, :3].mean() > 0.01


def test_the_normal_input_is_every_layers_and_unlinked_is_the_shading_normal(addon):
    mat = addon.data.materials.new("normal_inputs")
    api.apply_stack(mat, STACK)
    for layer in (0, "base"):
        sock = api.input_socket(mat, layer, "normal")
        assert sock.type == "VECTOR" and not sock.is_linked and "Normal" in sock.name
    assert mat.lamella.live_params == ""
