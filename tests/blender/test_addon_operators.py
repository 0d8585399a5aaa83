"""Every ``bpy.ops.lamella.*`` operator invoked in background mode (the way batch scripts use
them), with a named material since there is no context material there; failures come back as
reports (RuntimeError from a script) and leave the material as it was."""
import json

import pytest

from lamella.core import StackError, presets
from lamella_dev import suite

pytest.importorskip("bpy")
from lamella.blender import api, material_nodes, operators  # noqa: E402


@pytest.fixture
def mat(addon):
    m = addon.data.materials.new("ops")
    api.apply_stack(m, suite.load("three_coats"))
    return m


def _names(m):
    return [c.name for c in m.lamella.coats]


def test_every_operator_is_registered_with_a_description(addon):
    for cls in operators.classes:
        op = getattr(addon.ops.lamella, cls.bl_idname.split(".")[1])
        assert op.get_rna_type().description, cls.bl_idname
        assert "UNDO" in cls.bl_options or cls.bl_idname in (
            "lamella.preset_save", "lamella.preset_remove", "lamella.stack_export", "lamella.export_osl"), \
            f"{cls.bl_idname} changes the material and must be undoable"


def test_material_new_enable_and_disable(addon):
    addon.ops.lamella.material_new(name="fresh", preset="car_paint")
    m = addon.data.materials["fresh"]
    assert m.lamella.enabled and len(m.lamella.coats) == 2 and m.lamella.status == "OK"
    plain = addon.data.materials.new("plain_op")
    addon.ops.lamella.enable(material=plain.name)
    assert plain.lamella.enabled and api.read_stack(plain)["base"]["type"] == "conductor"
    addon.ops.lamella.disable(material=plain.name)
    assert not plain.lamella.enabled and material_nodes.lamella_nodes(plain) == []


def test_layer_add_remove_move_duplicate(addon, mat):
    s = mat.lamella
    s.active_index = 1
    addon.ops.lamella.layer_add(material=mat.name, template="dust")
    assert len(s.coats) == 4 and s.active_index == 1 and s.coats[1].name == "Dust"
    assert s.status == "OK" and s.picked_model == "tm6_refined"
    addon.ops.lamella.layer_move(material=mat.name, direction="UP")
    assert s.active_index == 0 and s.coats[0].name == "Dust"
    addon.ops.lamella.layer_duplicate(material=mat.name)
    # the duplicate, above, is a layer of its own with a label of its own
    assert len(s.coats) == 5 and (s.coats[0].name, s.coats[1].name) == ("Dust 2", "Dust")
    s.coats[1].coat.g = 0.8  # the copy is independent
    assert s.coats[0].coat.g == pytest.approx(0.3)
    addon.ops.lamella.layer_remove(material=mat.name)
    addon.ops.lamella.layer_remove(material=mat.name)
    assert len(s.coats) == 3 and not {"Dust", "Dust 2"} & set(_names(mat))
    assert len(json.loads(s.compiled_json)["layers"]) == 3


def test_every_layer_template_adds(addon, mat):
    for t in presets.layer_templates():
        m = addon.data.materials.new(f"tmpl_{t['id']}")
        api.apply_stack(m, suite.load("gold_coated"))
        addon.ops.lamella.layer_add(material=m.name, template=t["id"])
        assert m.lamella.status == "OK", (t["id"], m.lamella.status_message)
        assert len(json.loads(m.lamella.compiled_json)["layers"]) == 2


def test_recompile_and_fix_render_settings(addon, mat):
    addon.ops.lamella.recompile(material=mat.name)
    sc = addon.context.scene
    sc.render.engine = "BLENDER_WORKBENCH"
    addon.ops.lamella.fix_render_settings()
    assert sc.render.engine == "CYCLES" and sc.cycles.shading_system and sc.cycles.device == "CPU"


def test_presets_save_apply_remove(addon, mat):
    addon.ops.lamella.preset_save(material=mat.name, name="My Three Coats")
    items = [i[0] for i in operators.preset_items()]
    assert "user:my_three_coats" in items
    other = addon.data.materials.new("other")
    addon.ops.lamella.preset_apply(material=other.name, preset="user:my_three_coats")
    assert api.read_stack(other)["layers"] == api.read_stack(mat)["layers"]
    addon.ops.lamella.preset_remove(preset="user:my_three_coats")
    assert "user:my_three_coats" not in [i[0] for i in operators.preset_items()]
    with pytest.raises(RuntimeError, match="built-in"):
        addon.ops.lamella.preset_remove(preset="car_paint")


def test_import_export_round_trip(addon, mat, tmp_path):
    out = tmp_path / "stack.json"
    addon.ops.lamella.stack_export(material=mat.name, filepath=str(out))
    other = addon.data.materials.new("imported")
    addon.ops.lamella.stack_import(material=other.name, filepath=str(out))
    assert api.read_stack(other) == api.read_stack(mat)


@pytest.mark.parametrize("content,message", [
    ("{broken", "not valid JSON"),
    ('{"layers": [{"ior": 0}], "base": {"type": "conductor"}}', "coat 0, field 'ior'"),
    ('{"layers": [], "base": {"type": "conductor", "k": [1, 2]}}', "base, field 'k'"),
])
def test_invalid_json_import_leaves_the_material_intact(addon, mat, tmp_path, content, message):
    bad = tmp_path / "bad.json"
    bad.write_text(content)
    before, src = api.read_stack(mat), material_nodes.shader_source(mat)
    with pytest.raises(RuntimeError, match=message):
        addon.ops.lamella.stack_import(material=mat.name, filepath=str(bad))
    assert api.read_stack(mat) == before
    assert material_nodes.shader_source(mat) == src


def test_missing_material_is_reported(addon):
    with pytest.raises(RuntimeError, match="no material named"):
        addon.ops.lamella.layer_add(material="does not exist", template="clear_coat")


def test_export_osl_writes_a_bundle(addon, mat, tmp_path):
    addon.ops.lamella.export_osl(material=mat.name, filepath=str(tmp_path / "three.osl"), target_convention="osl-spec")
    assert (tmp_path / "three.osl").exists() and (tmp_path / "README.md").exists()
    assert "-normalize(I)" in (tmp_path / "three.osl").read_text()


def test_stack_error_is_the_api_error(addon):
    assert issubclass(StackError, ValueError)


def test_remove_and_move_refuse_what_they_cannot_do_and_say_why(addon, mat):
    s = mat.lamella
    before = _names(mat)
    s.active_index = len(s.coats)  # past the coats (the base row)
    with pytest.raises(RuntimeError, match="select a coat to remove"):
        addon.ops.lamella.layer_remove(material=mat.name)
    assert _names(mat) == before
    s.active_index = len(s.coats) - 1
    with pytest.raises(RuntimeError, match="already the lowest coat"):
        addon.ops.lamella.layer_move(material=mat.name, direction="DOWN")
    s.active_index = 0
    with pytest.raises(RuntimeError, match="already the top coat"):
        addon.ops.lamella.layer_move(material=mat.name, direction="UP")
    assert _names(mat) == before


def test_a_named_material_is_edited_whatever_the_context_shows(addon, mat):
    """A script names its material with material=: the operator acts on it even where the active
    object's material has no coat (a glass base alone), and refuses a material without coats in
    words."""
    bare = addon.data.materials.new("bare glass")
    api.apply_stack(bare, {"layers": [], "base": {"type": "dielectric", "ior": 1.5}})
    ob = addon.data.objects.new("context object", addon.data.meshes.new("context mesh"))
    addon.context.scene.collection.objects.link(ob)
    ob.data.materials.append(bare)
    addon.context.view_layer.objects.active = ob
    n = len(mat.lamella.coats)
    mat.lamella.active_index = 0
    addon.ops.lamella.layer_remove(material=mat.name)
    assert len(mat.lamella.coats) == n - 1
    with pytest.raises(RuntimeError, match="no coat to remove"):
        addon.ops.lamella.layer_remove(material=bare.name)
    addon.data.objects.remove(ob)


def test_list_buttons_are_greyed_out_where_they_cannot_act(addon, mat):
    from lamella.blender import ui

    from .addon_helpers import RecordingLayout

    s = mat.lamella
    for index, want in ((0, {"lamella.layer_remove": True, "up": False, "down": True}),
                        (len(s.coats) - 1, {"up": True, "down": False}),
                        (len(s.coats), {"lamella.layer_remove": False, "up": False, "down": False})):
        s.active_index = index
        layout = RecordingLayout()
        ui.draw_layers(layout, mat)
        got = {("up" if d == "UP" else "down") if op == "lamella.layer_move" else op: on
               for op, d, on in layout.root.enabled_operators}
        assert {k: got[k] for k in want} == want, index
