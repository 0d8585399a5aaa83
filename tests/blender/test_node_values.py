"""One value wherever the artist sets it: a value typed on the Lamella node renders in every engine
and is the panel's and ``read_stack``'s; a panel edit shows on the node; a keyframe on the node
animates the render. And the node's inputs say what they are: a label of their layer's own, which a
value edit never changes, a tooltip, a type and range that fit the value."""
import math

import numpy as np
import pytest

pytest.importorskip("bpy")
from lamella.blender import animation, api, material_nodes, recompile  # noqa: E402

from .addon_helpers import engine_scene, grid_pixels, render, sphere_grid  # noqa: E402

RED = {"layers": [], "base": {"type": "diffuse", "albedo": [0.8, 0.1, 0.1]}}
# a coat over a dark diffuse base, its roughness r 0.14 (GGX alpha 0.0196): r 0.84 changes the render
COATED = {"layers": [{"ior": 1.5, "roughness": 0.0196}], "base": {"type": "diffuse", "albedo": [0.05, 0.05, 0.05]}}
ROUGH = 0.84


def _stack(d, **change):
    import copy

    d = copy.deepcopy(d)
    for path, v in change.items():
        where, field = path.split("__")
        (d["base"] if where == "base" else d["layers"][int(where[4:])])[field] = v
    return d


def _typed_materials(addon, sc, sphere):
    """Three spheres: the red base typed blue on its node, the coat's roughness typed on its node,
    the coat's roughness keyed on its node (frame 1 r 0.14, frame 10 r 0.84); the scene at frame 10."""
    grid = sphere_grid(sc, sphere, 3)
    mats = []
    for (ob, _, _), (name, stack) in zip(grid, (("typed_colour", RED), ("typed_roughness", COATED),
                                               ("keyed_roughness", COATED))):
        mat = addon.data.materials.new(name)
        ob.data.materials.clear()
        ob.data.materials.append(mat)
        api.apply_stack(mat, stack)
        mats.append(mat)
    return grid, mats


def _type(mats):
    colour, rough, keyed = mats
    api.input_socket(colour, "base", "albedo").default_value = (0.1, 0.1, 0.8, 1.0)
    api.input_socket(rough, 0, "roughness").default_value = ROUGH
    sock = api.input_socket(keyed, 0, "roughness")
    sock.default_value = 0.14
    sock.keyframe_insert("default_value", frame=1)
    sock.default_value = ROUGH
    sock.keyframe_insert("default_value", frame=10)


def _discs(px, grid):
    return [grid_pixels(px, centre, radius, 0.8)[:, :3] for _, centre, radius in grid]


def _rel(a, b):
    return float(np.abs(a - b).mean() / b.mean())


@pytest.mark.parametrize("engine", ("osl", "svm", "eevee"))
def test_a_value_typed_or_keyed_on_the_node_renders_in_every_engine(addon, engine):
    """Each sphere renders as the stack with the value typed (or keyed, at frame 10) does, and
    differs from what it rendered before by what the value changes (the control)."""
    sc, sphere = engine_scene(engine, res=60, spp=16)
    grid, mats = _typed_materials(addon, sc, sphere)
    sc.frame_set(10)
    before = _discs(render(sc), grid)
    _type(mats)
    sc.frame_set(10)
    typed = _discs(render(sc), grid)
    mats[2].node_tree.animation_data_clear()  # the keyed one's frame 10, set in the stack instead
    for mat, stack in zip(mats, (_stack(RED, base__albedo=[0.1, 0.1, 0.8]),
                                 _stack(COATED, coat0__roughness=ROUGH ** 2),
                                 _stack(COATED, coat0__roughness=ROUGH ** 2))):
        api.apply_stack(mat, stack)  # the same values through the stack
    sc.frame_set(10)
    want = _discs(render(sc), grid)
    for k, name in enumerate(("colour", "roughness", "keyed roughness")):
        assert _rel(typed[k], want[k]) < 0.02, (engine, name, _rel(typed[k], want[k]))
        assert _rel(before[k], want[k]) > 0.04, (engine, name, "the control: the value must show",
                                                 _rel(before[k], want[k]))
    colour_mean = typed[0].mean(0)
    assert colour_mean[2] > 3 * colour_mean[0], "typed blue renders blue"


def test_a_value_typed_on_the_node_is_the_panels_and_the_stacks(addon):
    mat = addon.data.materials.new("typed_values")
    api.apply_stack(mat, {"layers": [{"ior": 1.5, "roughness": [0.04, 0.09], "rotation": 0.5}],
                          "base": {"type": "diffuse", "albedo": [0.8, 0.1, 0.1]}})
    s = mat.lamella
    api.input_socket(mat, "base", "albedo").default_value = (0.1, 0.2, 0.8, 1.0)
    api.input_socket(mat, 0, "roughness_y").default_value = 0.5
    api.input_socket(mat, 0, "ior").default_value = 1.7
    api.input_socket(mat, 0, "rotation").default_value = -1.0
    stack = api.read_stack(mat)
    assert stack["base"]["albedo"] == pytest.approx([0.1, 0.2, 0.8])
    assert stack["layers"][0]["roughness"] == pytest.approx([0.04, 0.25])
    assert stack["layers"][0]["ior"] == pytest.approx(1.7)
    assert stack["layers"][0]["rotation"] == pytest.approx(-1.0)
    assert tuple(s.base.diffuse.albedo) == pytest.approx((0.1, 0.2, 0.8))  # the panel shows it
    recompile.flush()
    assert s.status == "OK" and '"ior": 1.7' in s.compiled_json  # what compiled
    # the panel's edit shows on the node
    s.coats[0].coat.ior = 1.3
    recompile.flush()
    assert api.input_socket(mat, 0, "ior").default_value == pytest.approx(1.3)
    assert api.read_stack(mat)["layers"][0]["ior"] == pytest.approx(1.3)  # not the node's earlier 1.7
    # a linked input is the texture's: its value on the node is not the panel's
    value = mat.node_tree.nodes.new("ShaderNodeValue")
    value.outputs[0].default_value = 0.2
    sock = api.input_socket(mat, 0, "ior")
    mat.node_tree.links.new(value.outputs[0], sock)
    sock.default_value = 2.5
    assert api.read_stack(mat)["layers"][0]["ior"] == pytest.approx(1.3)


def test_a_value_typed_on_a_measured_metals_colour_makes_it_the_artists(addon):
    mat = addon.data.materials.new("typed_metal")
    api.apply_preset(mat, "lacquered_gold")
    pg = mat.lamella.base.conductor
    pg.mode = "MEASURED"
    recompile.flush()
    refl = api.input_socket(mat, "base", "reflectivity")  # a measured metal has its colours too
    assert api.input_socket(mat, "base", "edge_tint").type == "RGBA"
    with pytest.raises(KeyError, match="reflectivity"):
        api.input_socket(mat, "base", "eta")
    refl.default_value = (0.9, 0.9, 0.9, 1.0)
    base = api.read_stack(mat)["base"]
    assert pg.mode == "ARTIST" and tuple(pg.reflectivity) == pytest.approx((0.9, 0.9, 0.9))
    f0 = [((n - 1) ** 2 + k * k) / ((n + 1) ** 2 + k * k) for n, k in zip(base["eta"], base["k"])]
    assert f0 == pytest.approx([0.9] * 3, abs=1e-3), "the metal reflects the typed colour at normal incidence"


def test_every_input_says_what_it_is(addon):
    mat = addon.data.materials.new("car_paint_sockets")
    api.apply_preset(mat, "car_paint")
    node = material_nodes.face_node(mat)
    names = [s.name for s in node.inputs]
    assert len(names) == len(set(names)), "no two inputs share a name"
    assert names[0] == "Clear Coat: IOR" and "Red Paint: Absorption" in names
    items = {s.name: s for s in node.node_tree.interface.items_tree if s.item_type == "SOCKET" and s.in_out == "INPUT"}
    for name, item in items.items():
        assert item.description, f"{name} has no tooltip"
    assert "1/length" not in items["Red Paint: Absorption"].description  # the unit in words
    assert "per unit of the coat's Thickness" in items["Red Paint: Absorption"].description
    absorption = api.input_socket(mat, 1, "sigma_a")
    assert absorption.type == "VECTOR" and tuple(absorption.default_value) == pytest.approx((0.08, 2.5, 2.0))
    film = items["Clear Coat: Film Thickness"]
    assert film.subtype == "WAVELENGTH"  # nanometres
    rotation = items["Clear Coat: Rotation"]
    assert rotation.subtype == "ANGLE" and rotation.max_value == pytest.approx(2 * math.pi)
    assert items["Base: Reflectivity"].socket_type == "NodeSocketColor"  # the aluminium flakes' colours
    # two clear coats: two labels
    other = addon.data.materials.new("two_clear_coats")
    api.apply_stack(other, {"layers": [{"ior": 1.5}, {"ior": 1.5}], "base": {"type": "diffuse"}})
    assert [c.name for c in other.lamella.coats] == ["Clear Coat", "Clear Coat 2"]
    names = [s.name for s in material_nodes.face_node(other).inputs]
    assert len(names) == len(set(names))


def test_a_layers_label_stays_through_value_edits_and_follows_a_rename(addon):
    mat = addon.data.materials.new("labels")
    api.apply_stack(mat, COATED)
    s = mat.lamella
    assert s.coats[0].name == "Clear Coat"
    key = api.input_socket(mat, 0, "roughness")
    key.keyframe_insert("default_value", frame=1)
    api.apply_stack(mat, _stack(COATED, coat0__roughness=0.5))  # now rough: the label stays
    assert s.coats[0].name == "Clear Coat"
    assert material_nodes.face_node(mat).inputs[1].name == "Clear Coat: Roughness"
    s.coats[0].name = "Lacquer"  # the artist renames it: the inputs follow, keeping their keys
    recompile.flush()
    sock = api.input_socket(mat, 0, "roughness")
    assert sock.name == "Lacquer: Roughness"
    assert sock.path_from_id("default_value") in animation.animated_paths(mat.node_tree)  # its key followed it
    s.coats[0].name = "Base"  # the base's label is taken
    assert s.coats[0].name == "Base 2"


def test_a_preset_without_the_layer_a_texture_feeds_says_which_input_and_what_to_do(addon):
    mat = addon.data.materials.new("linked_then_coatless")
    api.apply_preset(mat, "lacquered_gold")
    noise = mat.node_tree.nodes.new("ShaderNodeTexNoise")
    mat.node_tree.links.new(noise.outputs["Fac"], api.input_socket(mat, 0, "roughness"))
    recompile.compile_material(mat)
    before = mat.lamella.compiled_json
    with pytest.raises(api.StackError) as e:
        api.apply_preset(mat, "anodised_titanium")  # no coat
    message = str(e.value)
    assert "'Lacquer: Roughness' (linked from 'Noise Texture')" in message and "unlink it" in message
    assert "coat0_roughness" not in message
    assert mat.lamella.compiled_json == before and api.input_socket(mat, 0, "roughness").is_linked  # kept
