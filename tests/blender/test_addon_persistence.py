"""A Lamella material survives what Blender does to data: save and reload (same image), undo and
redo, append and link into another file, and registering the extension again."""
import numpy as np
import pytest

from lamella_dev import suite

pytest.importorskip("bpy")
from lamella.blender import api, material_nodes  # noqa: E402

from . import addon_helpers  # noqa: E402
from .addon_helpers import new_material, render, sphere_scene  # noqa: E402


def _same_image(a, b):
    """The same material rendered in two scenes: the same image up to Cycles' scene-to-scene noise
    (a fresh sphere's corner normals hash differently; measured: up to 1.2e-4 at 7 of 9216
    pixels, 2.5e-5 elsewhere, for the very same material in one process)."""
    d = np.abs(a - b)
    assert np.percentile(d, 99.5) < 3e-5 and d.max() < 1e-3, (np.percentile(d, 99.5), d.max())


def test_register_and_unregister_twice(addon):
    """The session registered the extension; take it down and up twice, then check it works."""
    for _ in range(2):
        addon_helpers.unregister()
        try:
            assert not hasattr(addon.types.Material, "lamella")
            assert not hasattr(addon.types, "LAMELLA_PT_material")
            with pytest.raises((AttributeError, KeyError, RuntimeError)):
                addon.ops.lamella.layer_add.get_rna_type()
        finally:
            addon_helpers.register()
        assert hasattr(addon.types, "LAMELLA_PT_material") and addon.ops.lamella.layer_add.get_rna_type()
    m = addon.data.materials.new("reregistered")
    api.apply_stack(m, suite.load("gold_coated"))
    assert m.lamella.status == "OK"


def test_save_reload_render_gives_the_same_image(addon, tmp_path):
    sc, sphere = sphere_scene()
    mat = new_material(sphere, "saved")
    api.apply_stack(mat, suite.load("tinted_varnish"))
    before = render(sc)
    path = tmp_path / "saved.blend"
    addon.ops.wm.save_as_mainfile(filepath=str(path))
    addon.ops.wm.open_mainfile(filepath=str(path))
    mat = addon.data.materials["saved"]
    assert api.read_stack(mat) == _normalised("tinted_varnish")
    after = render(addon.context.scene)
    _same_image(after, before)


def _normalised(case):
    from lamella.core import Stack

    return Stack.from_dict(suite.load(case).to_dict()).to_dict()


def test_undo_restores_the_previous_stack_and_redo_the_new_one(addon):
    mat = addon.data.materials.new("undo")
    api.apply_stack(mat, suite.load("gold_coated"))
    addon.ops.ed.undo_push(message="gold")
    old_src = mat.node_tree.nodes[material_nodes.SCRIPT].script.as_string()
    addon.ops.lamella.preset_apply(material="undo", preset="varnished_wood")
    addon.ops.ed.undo_push(message="wood")
    addon.ops.ed.undo()
    mat = addon.data.materials["undo"]
    assert api.read_stack(mat)["base"]["type"] == "conductor"
    assert mat.node_tree.nodes[material_nodes.SCRIPT].script.as_string() == old_src
    addon.ops.ed.redo()
    mat = addon.data.materials["undo"]
    assert api.read_stack(mat)["base"]["type"] == "diffuse"


@pytest.mark.parametrize("link", [False, True])
def test_append_and_link_keep_the_stack_and_the_image(addon, tmp_path, link):
    sc, sphere = sphere_scene()
    mat = new_material(sphere, "library_mat")
    api.apply_stack(mat, suite.load("gold_coated"))
    before = render(sc)
    stack = api.read_stack(mat)
    lib = tmp_path / "library.blend"
    addon.data.libraries.write(str(lib), {mat}, fake_user=True)

    sc, sphere = sphere_scene()
    assert "library_mat" not in addon.data.materials
    with addon.data.libraries.load(str(lib), link=link) as (src, dst):
        dst.materials = ["library_mat"]
    got = dst.materials[0]
    assert (got.library is not None) == link
    assert api.read_stack(got) == stack
    sphere.data.materials.clear()
    sphere.data.materials.append(got)
    _same_image(render(sc), before)
    if link:
        from lamella.core import StackError

        with pytest.raises(StackError, match="linked"):
            api.apply_stack(got, suite.load("varnished_wood"))
