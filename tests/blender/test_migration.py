"""A file saved before the Lamella node (tests/references/lamella_0_1_0_layout.blend, made by
Lamella 0.1.0) opens, and its materials become Lamella nodes at their next compile: the old nodes
go, the artist's texture moves to the input of the coat it fed, and each renders as a material made
now from the same stack with the same texture does."""
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("bpy")
from lamella.blender import api, material_nodes, recompile  # noqa: E402

from .addon_helpers import new_material, render  # noqa: E402

OLD = Path(__file__).resolve().parents[1] / "references" / "lamella_0_1_0_layout.blend"


def _scene_in_the_open_file(bpy):
    """A sphere before the forest HDRI, made in the file as it was opened (the canonical scenes
    start from factory settings, which would drop the file's materials)."""
    from lamella_dev.render import node_tree

    sc = bpy.context.scene
    sc.render.engine, sc.cycles.device, sc.cycles.shading_system = "CYCLES", "CPU", True
    sc.cycles.samples, sc.cycles.use_denoising, sc.cycles.use_adaptive_sampling = 16, False, False
    sc.render.resolution_x = sc.render.resolution_y = 32
    sc.view_settings.view_transform = "Standard"
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32)
    bpy.ops.object.shade_smooth()
    sphere = bpy.context.object
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    sc.collection.objects.link(cam)
    sc.camera = cam
    cam.data.type, cam.data.ortho_scale = "ORTHO", 2.2
    cam.location, cam.rotation_euler = (0.0, -10.0, 0.0), (1.5707963, 0.0, 0.0)
    sc.world = bpy.data.worlds.new("world")
    nodes = node_tree(sc.world).nodes
    env = nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(str(Path(bpy.utils.system_resource("DATAFILES", path="studiolights/world"))
                                         / "forest.exr"))
    sc.world.node_tree.links.new(env.outputs["Color"], nodes["Background"].inputs["Color"])
    return sc, sphere


def test_a_file_from_before_the_lamella_node_migrates_and_renders_the_same(addon):
    import bpy

    if bpy.app.version < (5, 2, 0):
        pytest.skip("the file is saved by Blender 5.2")
    addon.ops.wm.open_mainfile(filepath=str(OLD))
    old = {n: addon.data.materials[n] for n in ("old_plain", "old_textured")}
    assert all(material_nodes.old_layout(m) for m in old.values())
    stacks = {n: api.read_stack(m) for n, m in old.items()}
    sc, sphere = _scene_in_the_open_file(addon)
    got = {}
    for name, m in old.items():
        sphere.data.materials.clear()
        sphere.data.materials.append(m)
        got[name] = render(sc)[..., :3]  # render_pre compiles what load_post scheduled: the migration
        assert m.lamella.status == "OK" and not material_nodes.old_layout(m)
        recompile.flush_groups()  # what waits until something renders the node group
        assert material_nodes.broken(m) is None
        names = {n.name for n in m.node_tree.nodes}
        assert not names & {"Lamella Shader", "Lamella Output", "Lamella EEVEE Output", "Lamella Nodes",
                            "Lamella Tangent"}
        assert m.node_tree.get_output_node("ALL").inputs["Surface"].links[0].from_node == material_nodes.face_node(m)
    textured = old["old_textured"]
    sock = api.input_socket(textured, 1, "roughness")
    assert sock.is_linked and sock.links[0].from_node.name == "artist noise"
    assert textured.lamella.live_params == "coat1_roughness"
    for name, stack in stacks.items():
        fresh = new_material(sphere, f"fresh_{name}")
        api.apply_stack(fresh, stack)
        if name == "old_textured":
            noise = fresh.node_tree.nodes.new("ShaderNodeTexNoise")
            fresh.node_tree.links.new(noise.outputs["Fac"], api.input_socket(fresh, 1, "roughness"))
            recompile.compile_material(fresh)
        want = render(sc)[..., :3]
        assert np.abs(got[name] - want).mean() / want.mean() < 1e-3, name
