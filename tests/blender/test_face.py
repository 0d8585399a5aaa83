"""The Lamella node, the one node of a material an artist sees: a texture linked into it reaches
every engine, stays on its layer through other layers' edits, a linked value is bounded as the
panel's is, and the artist's own nodes around it are never touched."""
import numpy as np
import pytest

from lamella_dev import suite

pytest.importorskip("bpy")
from lamella.blender import api, material_nodes, recompile  # noqa: E402

from .addon_helpers import new_material, render, sphere_scene  # noqa: E402

# Cycles with OSL runs the Script node, Cycles without OSL the node group EEVEE runs too: EEVEE's
# first render of each material compiles its shader (tens of seconds here), so EEVEE renders these
# materials in the life test (test_material_life.py) and in test_addon_nodes.py.
ENGINES = (("cycles-osl", "CYCLES", True), ("cycles-nodes", "CYCLES", False))


def _render_in(sc, engine, osl):
    sc.render.engine = engine
    if engine == "CYCLES":
        sc.cycles.shading_system = osl
    else:  # EEVEE headless here (llvmpipe) takes half a minute a render with shadows on, as use_eevee says
        sc.eevee.use_shadows = False
    try:
        return render(sc)[..., :3]
    finally:
        sc.render.engine = "CYCLES"
        sc.cycles.shading_system = True


def _value_into(mat, socket, value):
    """A node of the artist's (a Value node standing for a texture) linked into ``socket``."""
    nt = mat.node_tree
    if socket.type == "RGBA":
        src = nt.nodes.new("ShaderNodeRGB")
        src.outputs[0].default_value = (*value, 1.0)
    else:
        src = nt.nodes.new("ShaderNodeValue")
        src.outputs[0].default_value = value
    nt.links.new(src.outputs[0], socket)
    return src


def _rel(a, b):
    return float(np.abs(a - b).mean() / b.mean())


def test_the_node_shows_the_panels_fields_in_its_order_units_and_labels(addon):
    mat = addon.data.materials.new("face_inputs")
    api.apply_stack(mat, {"layers": [{"ior": 1.5, "roughness": [0.09, 0.04]}, {"ior": 1.3}],
                          "base": {"type": "diffuse", "albedo": [0.5, 0.4, 0.3]}})
    mat.lamella.coats[0].name = "Lacquer"
    recompile.flush()
    names = [s.name for s in material_nodes.face_node(mat).inputs]
    assert names[:4] == ["Lacquer: IOR", "Lacquer: Roughness", "Lacquer: Roughness Y", "Lacquer: Rotation"]
    assert names[-4:] == ["Base: Color", "Base: Normal", "Normal", "Tangent"]  # each layer's own normal last
    assert names.count("Lacquer: Normal") == 1
    assert api.input_socket(mat, 0, "roughness").default_value == pytest.approx(0.3)  # Blender's r
    assert api.input_socket(mat, 0, "roughness_y").default_value == pytest.approx(0.2)
    assert tuple(api.input_socket(mat, "base", "albedo").default_value)[:3] == pytest.approx((0.5, 0.4, 0.3))
    for layer, field, says in ((5, "ior", "coat index"), ("top", "ior", "coat index"), (0, "albedo", "roughness")):
        with pytest.raises(KeyError, match=says):
            api.input_socket(mat, layer, field)


@pytest.mark.parametrize("engine,blender_engine,osl", ENGINES)
def test_a_texture_linked_once_reaches_every_engine(addon, engine, blender_engine, osl):
    """A linked coat roughness renders as the same roughness set in the panel, in each engine."""
    sc, sphere = sphere_scene(res=32, spp=16)
    stack = suite.load("gold_coated").to_dict()
    linked = new_material(sphere, "linked")
    api.apply_stack(linked, stack)
    _value_into(linked, api.input_socket(linked, 0, "roughness"), 0.6)
    got = _render_in(sc, blender_engine, osl)
    assert linked.lamella.live_params == "coat0_roughness"
    # Cycles with OSL runs the shader: the tables its live part reads are in its source, no file
    source = material_nodes.shader_source(linked)
    assert source is not None and "float LUT_" in source and "lut_dir" not in source
    stack["layers"][0]["roughness"] = 0.36
    panel = new_material(sphere, "panel")
    api.apply_stack(panel, stack)
    want = _render_in(sc, blender_engine, osl)
    stack["layers"][0]["roughness"] = 0.01
    api.apply_stack(panel, stack)
    unlinked = _render_in(sc, blender_engine, osl)
    assert _rel(got, want) < 0.01, engine
    assert _rel(unlinked, want) > 0.05, "the control: the texture's value must show"


def test_a_texture_stays_on_its_layer_through_edits_of_others(addon):
    mat = addon.data.materials.new("identity")
    api.apply_stack(mat, suite.load("three_coats"))
    s = mat.lamella
    _value_into(mat, api.input_socket(mat, 1, "roughness"), 0.4)
    recompile.compile_material(mat)
    assert s.live_params == "coat1_roughness"
    coat = s.coats[1].uid

    def where():
        return [k for k, c in enumerate(s.coats) if c.uid == coat][0]

    s.active_index = 0
    addon.ops.lamella.layer_add(material=mat.name, template="dust")  # a coat on top
    assert where() == 2 and api.input_socket(mat, 2, "roughness").is_linked
    assert s.live_params == "coat2_roughness"
    s.coats[0].show = False  # mute the new top coat
    recompile.flush()
    assert s.live_params == "coat1_roughness" and api.input_socket(mat, 2, "roughness").is_linked
    s.active_index = where()
    addon.ops.lamella.layer_move(material=mat.name, direction="DOWN")
    assert where() == 3 and s.live_params == "coat2_roughness"  # the muted coat 0 feeds nothing
    addon.ops.lamella.layer_duplicate(material=mat.name)  # the duplicate goes above, a layer of its own
    assert where() == 4 and api.input_socket(mat, 4, "roughness").is_linked
    assert not api.input_socket(mat, 3, "roughness").is_linked
    s.active_index = 1
    addon.ops.lamella.layer_remove(material=mat.name)
    assert where() == 3 and s.live_params == "coat2_roughness" and s.status == "OK"
    assert material_nodes.broken(mat) is None


def test_the_artists_nodes_around_it_are_kept(addon):
    """An Add Shader with an emission between the Lamella node and the output stays as the artist
    made it through edits, recompiles and renders, and renders."""
    sc, sphere = sphere_scene(res=32, spp=4)
    mat = new_material(sphere, "composed")
    api.apply_stack(mat, suite.load("gold_coated"))
    nt = mat.node_tree
    lamella = material_nodes.face_node(mat)
    out = nt.get_output_node("ALL")
    add, emission = nt.nodes.new("ShaderNodeAddShader"), nt.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 0.5
    nt.links.new(lamella.outputs["BSDF"], add.inputs[0])
    nt.links.new(emission.outputs[0], add.inputs[1])
    nt.links.new(add.outputs[0], out.inputs["Surface"])
    links = sorted((lk.from_node.name, lk.from_socket.identifier, lk.to_node.name, lk.to_socket.identifier)
                   for lk in nt.links)
    without = None
    for step in range(3):
        if step == 1:
            mat.lamella.coats[0].coat.roughness = 0.5
            recompile.flush()
        if step == 2:
            addon.ops.lamella.layer_add(material=mat.name, template="dust")
            addon.ops.lamella.recompile(material=mat.name)
        px = render(sc)
        assert sorted((lk.from_node.name, lk.from_socket.identifier, lk.to_node.name, lk.to_socket.identifier)
                      for lk in nt.links) == links
        assert material_nodes.broken(mat) is None and mat.lamella.status == "OK"
        assert len(nt.nodes) == len({n.name for n in nt.nodes})
    nt.links.new(lamella.outputs["BSDF"], out.inputs["Surface"])
    without = render(sc)
    assert px[..., :3].mean() > without[..., :3].mean() + 0.3, "the emission renders"


@pytest.mark.parametrize("engine,blender_engine,osl", ENGINES)
def test_a_linked_colour_is_bounded_as_the_panels(addon, engine, blender_engine, osl):
    """A diffuse base whose linked colour is 2 reflects what colour 1 does in a white furnace (it
    had rendered 7.5 million times brighter), and a linked colour inside the limits renders as
    that colour."""
    sc, sphere = sphere_scene(res=24, spp=16, scene="white-furnace")
    stack = {"layers": [{"ior": 1.5, "roughness": 0.04}], "base": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]}}
    renders = {}
    for name, linked, panel in (("over", (2.0, 2.0, 2.0), None), ("one", None, 1.0),
                                ("inside", (0.3, 0.6, 0.9), None), ("inside_panel", None, (0.3, 0.6, 0.9))):
        mat = new_material(sphere, f"bounded_{name}")
        base = dict(stack["base"], albedo=list(panel) if isinstance(panel, tuple) else [panel or 0.5] * 3)
        api.apply_stack(mat, {**stack, "base": base})
        if linked is not None:
            _value_into(mat, api.input_socket(mat, "base", "albedo"), linked)
        renders[name] = _render_in(sc, blender_engine, osl)
    assert np.isfinite(renders["over"]).all()
    assert _rel(renders["over"], renders["one"]) < 0.01, engine
    assert _rel(renders["inside"], renders["inside_panel"]) < 0.01, engine


@pytest.mark.parametrize("engine,blender_engine,osl", ENGINES)
def test_keyframes_on_an_input_render_on_every_frame(addon, engine, blender_engine, osl):
    """A keyframed input of the Lamella node (roughness r 0.2 on frame 1, 0.6 on frame 3) renders at
    its value on each frame, as the same value linked into it does (which renders as the panel's
    value: ``test_a_texture_linked_once_reaches_every_engine``): the renderer reads it, no add-on
    code runs per frame."""
    sc, sphere = sphere_scene(res=24, spp=16)
    stack = suite.load("gold_coated").to_dict()
    mat = new_material(sphere, "keyed")
    api.apply_stack(mat, stack)
    sock = api.input_socket(mat, 0, "roughness")
    for frame, r in ((1, 0.2), (3, 0.6)):
        sock.default_value = r
        sock.keyframe_insert("default_value", frame=frame)
    got = {}
    for frame in (1, 3):
        sc.frame_set(frame)
        got[frame] = _render_in(sc, blender_engine, osl)
    assert mat.lamella.live_params == "coat0_roughness"
    for frame, r in ((1, 0.2), (3, 0.6)):
        linked = new_material(sphere, f"linked_{frame}")
        api.apply_stack(linked, stack)
        _value_into(linked, api.input_socket(linked, 0, "roughness"), r)
        assert _rel(got[frame], _render_in(sc, blender_engine, osl)) < 1e-3, (engine, frame)
    assert _rel(got[1], got[3]) > 0.05


def test_keyframes_and_drivers_on_panel_values_render_and_travel(addon, tmp_path):
    """A coat's roughness keyframed in the panel (r 0.2 on frame 1, 0.6 on frame 3) and its IOR
    driven by the frame render at their values on each frame in every engine, also after a coat is
    added on top (the animation follows its coat), because the keys and the driver are copied onto
    the Lamella node's inputs, which the renderer reads."""
    sc, sphere = sphere_scene(res=24, spp=16)
    stack = suite.load("gold_coated").to_dict()
    mat = new_material(sphere, "panel_keyed")
    api.apply_stack(mat, stack)
    coat = mat.lamella.coats[0].coat
    for frame, r in ((1, 0.2), (3, 0.6)):
        coat.roughness = r
        mat.keyframe_insert("lamella.coats[0].coat.roughness", frame=frame)
    driver = mat.driver_add("lamella.coats[0].coat.ior").driver
    driver.expression = "1.3 + 0.1 * frame"
    addon.ops.lamella.layer_add(material=mat.name, template="dust")  # a coat on top: the animation stays on coat 1
    mat.lamella.coats[0].show = False  # muted: the stack renders as before, its coat 0 the animated one
    recompile.flush()
    got = {}
    for frame in (1, 3):
        sc.frame_set(frame)
        got[frame] = {e: _render_in(sc, b, o) for e, b, o in ENGINES}
    assert mat.lamella.live_params == "coat0_ior, coat0_roughness"
    linked = new_material(sphere, "panel_linked")  # the same values from the artist's nodes, frame by frame
    api.apply_stack(linked, stack)
    roughness = _value_into(linked, api.input_socket(linked, 0, "roughness"), 0.2)
    ior = _value_into(linked, api.input_socket(linked, 0, "ior"), 1.4)
    recompile.flush()
    for frame, r in ((1, 0.2), (3, 0.6)):
        roughness.outputs[0].default_value, ior.outputs[0].default_value = r, 1.3 + 0.1 * frame
        for e, b, o in ENGINES:
            assert _rel(got[frame][e], _render_in(sc, b, o)) < 1e-3, (e, frame)
    assert _rel(got[1]["cycles-osl"], got[3]["cycles-osl"]) > 0.05


@pytest.mark.parametrize("engine,blender_engine,osl", ENGINES)
def test_the_conductors_artist_colours_are_inputs_in_its_artist_mode(addon, engine, blender_engine, osl):
    """In the conductor's artist mode the Lamella node shows Reflectivity and Edge Tint (not eta
    and k), and a colour linked into Reflectivity renders as the same colour set in the panel
    (Gulbrandsen 2014's conversion, made in nodes inside the Lamella node)."""
    sc, sphere = sphere_scene(res=24, spp=16)
    stack = suite.load("gold_coated").to_dict()
    renders = {}
    for name in ("linked", "panel", "other"):
        mat = new_material(sphere, f"artist_{name}")
        api.apply_stack(mat, stack)
        base = mat.lamella.base.conductor
        base.mode = "ARTIST"
        base.reflectivity, base.edge_tint = (0.9, 0.6, 0.3) if name != "other" else (0.5, 0.5, 0.9), (0.9, 0.8, 0.5)
        recompile.flush()
        names = [s.name for s in material_nodes.face_node(mat).inputs]
        assert "Base: Reflectivity" in names and "Base: Edge Tint" in names and "Base: IOR (n)" not in names
        if name == "linked":
            base.reflectivity = (0.2, 0.2, 0.2)  # the panel's value, which the link overrides
            recompile.flush()
            _value_into(mat, api.input_socket(mat, "base", "reflectivity"), (0.9, 0.6, 0.3))
        renders[name] = _render_in(sc, blender_engine, osl)
        if name == "linked":
            assert mat.lamella.live_params == "base_eta, base_k"
    assert _rel(renders["linked"], renders["panel"]) < 0.01, engine
    assert _rel(renders["other"], renders["panel"]) > 0.05
