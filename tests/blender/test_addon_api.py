"""The batch API (docs/design.md "Contract: the Blender-side batch API"): apply_stack / read_stack,
the material's nodes, and bad input that leaves the material as it was."""
import json

import numpy as np
import pytest

from lamella.core import Stack, StackError
from lamella_dev import suite
from lamella.core.models import UnsupportedStack

pytest.importorskip("bpy")
from lamella.blender import api, material_nodes, recompile  # noqa: E402

from .addon_helpers import new_material, render  # noqa: E402

STRUCTURES = ["gold_coated", "rotated_60", "three_coats", "tinted_varnish", "fog_g09_d1", "milky_coat_d2",
              "varnished_wood", "rough_glass_plate"]


def _same_stack(a: dict, b: dict):
    sa, sb = Stack.from_dict(a), Stack.from_dict(b)
    assert sa.base.type == sb.base.type and len(sa.coats) == len(sb.coats)
    for x, y in [*zip(sa.coats, sb.coats), (sa.base, sb.base)]:
        for f in x.kind.fields:
            np.testing.assert_allclose(np.ravel(getattr(x, f.name)), np.ravel(getattr(y, f.name)), rtol=1e-6,
                                       atol=1e-9, err_msg=f"{f.name}")


@pytest.mark.parametrize("case", STRUCTURES)
def test_apply_then_read_gives_the_stack_back(addon, case):
    mat = addon.data.materials.new(case)
    stack = suite.load(case)
    api.apply_stack(mat, stack)
    _same_stack(api.read_stack(mat), stack.to_dict())
    s = mat.lamella
    assert s.enabled and s.status == "OK", s.status_message
    face, script, group = material_nodes.inner_nodes(mat)
    output = mat.node_tree.get_output_node("ALL")
    assert output.target == "ALL" and output.inputs["Surface"].links[0].from_node == face, "one output, every engine"
    assert [n.bl_idname for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"] == [
        "ShaderNodeOutputMaterial"]
    assert "BSDF" in script.outputs and len(script.inputs) > 3
    assert {s.name for s in script.inputs} <= {s.name for s in group.inputs}, "same parameter sockets"
    assert all(s.is_linked for s in group.inputs), "every input of the group is fed by the Lamella node"
    assert json.loads(s.compiled_json)["base"]["type"] == stack.base.type


def test_apply_accepts_dict_and_json(addon):
    mat = addon.data.materials.new("json")
    d = suite.load("gold_coated").to_dict()
    api.apply_stack(mat, json.dumps(d))
    api.apply_stack(mat, d)
    assert api.read_stack(mat)["base"]["type"] == "conductor"


def test_read_stack_of_a_plain_material_is_none(addon):
    assert api.read_stack(addon.data.materials.new("plain")) is None


@pytest.mark.parametrize("bad,where", [
    ({"layers": [{"ior": -1.0}], "base": {"type": "conductor"}}, "coat 0, field 'ior'"),
    ({"layers": [{"roughness": 2.0}], "base": {"type": "conductor"}}, "coat 0, field 'roughness'"),
    ({"layers": [{"thickness": float("nan")}], "base": {"type": "conductor"}}, "coat 0, field 'thickness'"),
    ({"layers": [{"colour": 1}], "base": {"type": "conductor"}}, "coat 0, field 'colour'"),
    ({"layers": [], "base": {"type": "diffuse", "albedo": [1, 2]}}, "base, field 'albedo'"),
    ({"layers": []}, "base"),
    ("{not json", "not valid JSON"),
])
def test_bad_input_raises_and_leaves_the_material_intact(addon, bad, where):
    mat = addon.data.materials.new("intact")
    api.apply_stack(mat, suite.load("tinted_varnish"))
    before_stack, before_src = api.read_stack(mat), material_nodes.shader_source(mat)
    with pytest.raises(StackError, match=where):
        api.apply_stack(mat, bad)
    assert api.read_stack(mat) == before_stack
    assert material_nodes.shader_source(mat) == before_src
    assert mat.lamella.status == "OK"


def test_forced_model_that_cannot_run_the_stack_leaves_the_material_intact(addon):
    mat = addon.data.materials.new("unsupported")
    api.apply_stack(mat, suite.load("gold_coated"))
    before = api.read_stack(mat)
    with pytest.raises(UnsupportedStack):
        api.apply_stack(mat, suite.load("fog_g09_d1"), model="endf")
    assert api.read_stack(mat) == before and mat.lamella.model == "auto"


def test_user_nodes_stay_and_linked_textures_survive_recompiles(addon):
    from lamella_dev.render import node_tree

    mat = addon.data.materials.new("user_nodes")
    nt = node_tree(mat)
    user = {n.name for n in nt.nodes}  # the default Principled BSDF and its output
    api.apply_stack(mat, suite.load("gold_coated"))
    tex = nt.nodes.new("ShaderNodeTexNoise")
    nt.links.new(tex.outputs["Fac"], api.input_socket(mat, 0, "roughness"))
    mat.lamella.coats[0].coat.ior = 1.7  # a value edit
    recompile.flush()
    mat.lamella.base.conductor.roughness = 0.5  # and another
    recompile.flush()
    assert user <= {n.name for n in nt.nodes}
    rough = api.input_socket(mat, 0, "roughness")
    assert rough.is_linked and rough.links[0].from_node == tex
    assert abs(api.input_socket(mat, 0, "ior").default_value - 1.7) < 1e-6
    assert abs(api.input_socket(mat, "base", "roughness").default_value - 0.5) < 1e-6  # the panel's r


def test_edits_schedule_and_the_render_flushes_them(addon, scene):
    sc, sphere = scene
    mat = new_material(sphere)
    api.apply_stack(mat, suite.load("gold_coated"))
    dark = render(sc)
    mat.lamella.base.conductor.roughness = 0.9
    assert mat.lamella.status == "PENDING" and mat.name_full in recompile.pending()
    rough = render(sc)  # render_pre compiles the pending edit first
    assert mat.lamella.status == "OK" and not recompile.pending()
    assert abs(api.input_socket(mat, "base", "roughness").default_value - 0.9) < 1e-5
    assert np.abs(rough - dark).mean() > 1e-3


def test_muted_layer_is_left_out_of_the_shader(addon):
    mat = addon.data.materials.new("muted")
    api.apply_stack(mat, suite.load("three_coats"))
    mat.lamella.coats[1].show = False
    recompile.flush()
    assert len(json.loads(mat.lamella.compiled_json)["layers"]) == 2
    assert len(api.read_stack(mat)["layers"]) == 2
    assert len(mat.lamella.coats) == 3


def test_duplicated_material_is_independent(addon):
    a = addon.data.materials.new("original")
    api.apply_stack(a, suite.load("gold_coated"))
    b = a.copy()
    b.lamella.coats[0].coat.ior = 1.9
    recompile.flush()
    sa, sb = (material_nodes.inner_nodes(m)[1] for m in (a, b))
    assert sa.script != sb.script
    assert abs(api.input_socket(a, 0, "ior").default_value - 1.5) < 1e-6
    assert abs(api.input_socket(b, 0, "ior").default_value - 1.9) < 1e-6
    assert material_nodes.face_node(a).node_tree != material_nodes.face_node(b).node_tree
    assert api.read_stack(a)["layers"][0]["ior"] == 1.5


def test_an_invalid_edit_keeps_the_last_working_shader(addon):
    """Values outside what the models accept cannot come from the panel (the properties carry
    the schema's limits); a forced model that cannot run an edited stack can."""
    mat = addon.data.materials.new("forced")
    api.apply_stack(mat, suite.load("gold_coated"), model="endf")
    src = material_nodes.shader_source(mat)
    c = mat.lamella.coats[0].coat
    c.thickness, c.sigma_s = 1.0, (1.0, 1.0, 1.0)  # endf has no scattering media
    recompile.flush()
    assert mat.lamella.status == "ERROR" and "endf" in mat.lamella.status_message
    assert material_nodes.shader_source(mat) == src
