"""Every built-in preset applies through the operator and renders finite, and every measured
metal of the picker writes its published eta/k."""
import math

import numpy as np
import pytest

from lamella.core import metals, presets

pytest.importorskip("bpy")
from lamella.blender import api  # noqa: E402

from .addon_helpers import engine_scene, grid_pixels, new_material, render, sphere_grid, sphere_scene  # noqa: E402


def test_every_preset_applies_and_renders_finite(addon):
    """Each built-in preset through the operator onto its own sphere of one scene, rendered once
    (Cycles with OSL): finite, non-negative everywhere, and every sphere lit."""
    ids = [p.id for p in presets.builtin()]
    sc, sphere = sphere_scene(res=24 * math.ceil(math.sqrt(len(ids))), spp=4)
    spheres = sphere_grid(sc, sphere, len(ids))
    for preset, (ob, _, _) in zip(ids, spheres):
        mat = new_material(ob, preset)
        addon.ops.lamella.preset_apply(material=mat.name, preset=preset)
        assert mat.lamella.status == "OK", (preset, mat.lamella.status_message)
    px = render(sc)
    assert np.isfinite(px).all() and (px >= 0).all()
    for preset, (_, centre, radius) in zip(ids, spheres):
        inside = grid_pixels(px, centre, radius)
        assert len(inside) >= 4, preset
        assert inside[:, :3].mean() > 0.005, preset


MASKED = [p.id for p in presets.builtin() if p.inputs]


@pytest.mark.parametrize("engine", ["osl", "svm", "eevee"])
def test_a_preset_with_procedural_inputs_links_them_and_renders_in_every_engine(addon, engine):
    """Worn Lacquer on Wood links a wear mask into the lacquer's coverage, Dust on Upward Faces the
    world normal's z into the dust's, the films a thickness, Car Paint orange peel and flakes into
    normals: each is linked and live in every engine, renders in Cycles with and without OSL (a
    textured film's OSL render is ``test_every_preset_applies_and_renders_finite``'s) and in
    EEVEE, and (in Cycles without OSL) differs from its stack without them (the panel's values).
    Each preset on its own sphere of one scene."""
    from lamella.blender import input_recipes
    assert {"worn_lacquer_on_wood", "dust_on_upward_faces"} <= set(MASKED)
    ids = [pid for pid in MASKED
           if engine != "osl" or not any(field.endswith("film_thickness") for field, _ in presets.find(pid).inputs)]
    sc, sphere = engine_scene(engine, res=24 * math.ceil(math.sqrt(len(ids))), spp=4)
    spheres = sphere_grid(sc, sphere, len(ids))
    mats = []
    for pid, (ob, _, _) in zip(ids, spheres):
        preset = presets.find(pid)
        mat = new_material(ob, f"{pid}_{engine}")
        addon.ops.lamella.preset_apply(material=mat.name, preset=pid)
        assert mat.lamella.status == "OK", (pid, mat.lamella.status_message)
        for socket, recipe in preset.inputs:
            assert socket in mat.lamella.live_params.split(", ")
            layer, _, field = socket.partition("_")
            sock = api.input_socket(mat, int(layer[4:]) if layer != "base" else "base", field)
            assert sock.is_linked and sock.links[0].from_node.get(input_recipes.RECIPE_KEY) == recipe
        mats.append(mat)
    masked = render(sc)
    assert np.isfinite(masked).all() and (masked >= 0).all()
    if engine != "svm":  # the inputs' effect is measured once, in Cycles without OSL (the node group)
        return
    for pid, mat in zip(ids, mats):
        preset = presets.find(pid)
        api.apply_stack(mat, preset.load())  # the same stack, the mask's nodes left unlinked
        for socket, _ in preset.inputs:
            layer, _, field = socket.partition("_")
            sock = api.input_socket(mat, int(layer[4:]) if layer != "base" else "base", field)
            mat.node_tree.links.remove(sock.links[0])
    plain = render(sc)
    for pid, (_, centre, radius) in zip(ids, spheres):
        m, p = grid_pixels(masked, centre, radius, part=0.95), grid_pixels(plain, centre, radius, part=0.95)
        assert np.abs(m - p)[:, :3].mean() > 0.01 * p[:, :3].mean(), pid


def test_the_next_preset_removes_the_nodes_a_preset_built_and_keeps_the_artists(addon):
    from lamella.blender import input_recipes
    from lamella_dev.render import node_tree

    mat = addon.data.materials.new("recipes_replaced")
    addon.ops.lamella.preset_apply(material=mat.name, preset="worn_lacquer_on_wood")
    nt = node_tree(mat)
    mine = nt.nodes.new("ShaderNodeTexNoise")
    made = [n for n in nt.nodes if input_recipes.RECIPE_KEY in n]
    assert len(made) >= 3 and any(n.type == "FRAME" for n in made)
    addon.ops.lamella.preset_apply(material=mat.name, preset="lacquered_gold")
    assert not [n for n in nt.nodes if input_recipes.RECIPE_KEY in n]
    assert mine.name in nt.nodes and mat.lamella.status == "OK" and mat.lamella.live_params == ""


@pytest.mark.parametrize("metal", list(metals.measured()))
def test_measured_metal_picker_writes_the_published_values(addon, metal):
    mat = addon.data.materials.new(f"metal_{metal}")
    api.apply_stack(mat, {"layers": [], "base": {"type": "conductor"}})
    c = mat.lamella.base.conductor
    c.mode = "MEASURED"
    c.metal = metal
    m = metals.measured()[metal]
    np.testing.assert_allclose(c.eta, m["eta"], rtol=1e-6)
    np.testing.assert_allclose(c.k, m["k"], rtol=1e-6)
    addon.ops.lamella.recompile(material=mat.name)
    np.testing.assert_allclose(api.read_stack(mat)["base"]["eta"], m["eta"], rtol=1e-6)


def test_artist_mode_stores_eta_k_with_the_asked_reflectivity(addon):
    mat = addon.data.materials.new("artist")
    api.apply_stack(mat, {"layers": [], "base": {"type": "conductor"}})
    c = mat.lamella.base.conductor
    c.mode = "ARTIST"
    c.reflectivity = (0.9, 0.5, 0.2)
    c.edge_tint = (0.3, 0.6, 0.9)
    f0 = [metals.normal_reflectance(n, k) for n, k in zip(c.eta, c.k)]
    np.testing.assert_allclose(f0, (0.9, 0.5, 0.2), atol=1e-5)
    r, g = metals.complex_to_artistic(c.eta, c.k)
    np.testing.assert_allclose(g, (0.3, 0.6, 0.9), atol=1e-4)


def test_malformed_user_preset_files_are_skipped_and_reported(addon):
    from lamella.blender import operators, paths, ui

    from .addon_helpers import RecordingLayout

    folder = paths.user_presets_dir()
    bad = {"deep.json": "[" * 5000 + "]" * 5000, "latin1.json": "{\"name\": \"caf\xe9\"}".encode("latin-1"),
           "list.json": "[1, 2]", "huge_k.json": '{"layers": [], "base": {"type": "conductor", "k": 1e300}}',
           "empty.json": ""}
    try:
        for name, text in bad.items():
            (folder / name).write_bytes(text if isinstance(text, bytes) else text.encode())
        items = operators.preset_items()
        assert not any(i[0].startswith("user:") and i[0][5:] + ".json" in bad for i in items)
        assert [p.name for p, _ in presets.scan_user(folder)[1]] == sorted(bad)
        m = addon.data.materials.new("after_bad_presets")
        addon.ops.lamella.preset_apply(material=m.name, preset=presets.builtin()[0].id)
        assert m.lamella.status == "OK"
        layout = RecordingLayout()
        menu = type("M", (), {"layout": layout})()
        ui.LAMELLA_MT_presets.draw(menu, addon.context)
        assert sum(t.startswith("Skipped ") for t in layout.labels) == len(bad)
    finally:
        for name in bad:
            (folder / name).unlink(missing_ok=True)
