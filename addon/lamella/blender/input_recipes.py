"""Procedural inputs a preset links into a material's Lamella node: node set-ups an artist would
build by hand (a wear mask, dust on the faces that look up, an oil film's swirling thickness, a
soap film draining, a clear coat's orange peel, metal flakes), named so that a preset can ask for
them (``core.presets.Preset.inputs``: socket name -> recipe name).

A recipe builds its nodes into any shader node tree (a material's, or the node-group library's
groups, ``lamella_dev.preset_exports``) and returns the socket that feeds the input. Its nodes
sit in one frame labelled with the recipe, and carry ``RECIPE_KEY`` (the recipe's name), so the
next preset applied removes them and never an artist's own nodes. A recipe's output node also
carries ``INPUT_KEY``, the socket it feeds, until it is linked: a material whose Lamella node
does not exist yet (an asset appended from the library, compiled where it is first used) links it
when its node is built (``link_pending``, before the compile reads what is linked).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from ..core.registry import Registry, require_callables
from . import face
from .material_nodes import ensure_face

RECIPE_KEY = "lamella_recipe"  # node custom property: the recipe that made it
INPUT_KEY = "lamella_input"  # output node custom property: the Lamella node socket it feeds, until linked


@dataclass(frozen=True)
class InputRecipe:
    """``name``; ``label`` (the frame's); ``description``; ``build(tree, add)`` makes the nodes with
    ``add(type)`` (so each is marked) and returns the output socket."""

    name: str
    label: str
    description: str
    build: Callable


RECIPES: Registry = Registry("input recipe", lambda r: require_callables("input recipe", r, "build"))


def register(recipe: InputRecipe) -> InputRecipe:
    return RECIPES.register(recipe)


def _worn(tree, add):
    """Lacquer rubbed off in patches: a noise in object space, its upper part (sharpened) where the
    coat remains (coverage 1), about a third of the surface worn to the wood."""
    coords = add("ShaderNodeTexCoord")
    noise = add("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 3.0
    noise.inputs["Detail"].default_value = 6.0
    noise.inputs["Roughness"].default_value = 0.6
    ramp = add("ShaderNodeMapRange")
    ramp.inputs["From Min"].default_value = 0.40
    ramp.inputs["From Max"].default_value = 0.50
    ramp.clamp = True
    tree.links.new(coords.outputs["Object"], noise.inputs["Vector"])
    tree.links.new(noise.outputs["Fac"], ramp.inputs["Value"])
    return ramp, ramp.outputs["Result"]


def _upward(tree, add):
    """Dust where a face looks up: the world normal's z, none below 0.2 (walls and overhangs),
    all of it above 0.7 (tops)."""
    geometry = add("ShaderNodeNewGeometry")
    split = add("ShaderNodeSeparateXYZ")
    ramp = add("ShaderNodeMapRange")
    ramp.inputs["From Min"].default_value = 0.2
    ramp.inputs["From Max"].default_value = 0.7
    ramp.clamp = True
    tree.links.new(geometry.outputs["Normal"], split.inputs["Vector"])
    tree.links.new(split.outputs["Z"], ramp.inputs["Value"])
    return ramp, ramp.outputs["Result"]


def _oil_swirl(tree, add):
    """An oil film's thickness swirling across the surface: a distorted noise in object space mapped
    to 150-650 nm (the first orders' vivid colours)."""
    coords = add("ShaderNodeTexCoord")
    noise = add("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 1.5
    noise.inputs["Detail"].default_value = 3.0
    noise.inputs["Distortion"].default_value = 2.0
    ramp = add("ShaderNodeMapRange")
    ramp.inputs["From Min"].default_value = 0.3
    ramp.inputs["From Max"].default_value = 0.7
    ramp.inputs["To Min"].default_value = 150.0
    ramp.inputs["To Max"].default_value = 650.0
    ramp.clamp = True
    tree.links.new(coords.outputs["Object"], noise.inputs["Vector"])
    tree.links.new(noise.outputs["Fac"], ramp.inputs["Value"])
    return ramp, ramp.outputs["Result"]


def _drainage(tree, add):
    """A soap film draining under gravity: thin at the top (150 nm) and thick at the bottom
    (900 nm), along the object's z."""
    coords = add("ShaderNodeTexCoord")
    split = add("ShaderNodeSeparateXYZ")
    ramp = add("ShaderNodeMapRange")
    ramp.inputs["From Min"].default_value = 1.0
    ramp.inputs["From Max"].default_value = -1.0
    ramp.inputs["To Min"].default_value = 150.0
    ramp.inputs["To Max"].default_value = 900.0
    ramp.clamp = True
    tree.links.new(coords.outputs["Object"], split.inputs["Vector"])
    tree.links.new(split.outputs["Z"], ramp.inputs["Value"])
    return ramp, ramp.outputs["Result"]


def _orange_peel(tree, add):
    """The orange peel of a sprayed clear coat: a fine noise bump (object space) on its normal."""
    coords = add("ShaderNodeTexCoord")
    noise = add("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 40.0
    noise.inputs["Detail"].default_value = 2.0
    bump = add("ShaderNodeBump")
    bump.inputs["Strength"].default_value = 0.08
    tree.links.new(coords.outputs["Object"], noise.inputs["Vector"])
    tree.links.new(noise.outputs["Fac"], bump.inputs["Height"])
    return bump, bump.outputs["Normal"]


def _flakes(tree, add):
    """Metal flakes in a paint: Voronoi cells in object space, each tilting the normal its own way
    (the cell's random colour about 0.5, by up to about 25 degrees)."""
    coords = add("ShaderNodeTexCoord")
    cells = add("ShaderNodeTexVoronoi")
    cells.inputs["Scale"].default_value = 250.0
    centred = add("ShaderNodeVectorMath")
    centred.operation = "SUBTRACT"
    centred.inputs[1].default_value = (0.5, 0.5, 0.5)
    tilt = add("ShaderNodeVectorMath")
    tilt.operation = "SCALE"
    tilt.inputs["Scale"].default_value = 0.9
    geometry = add("ShaderNodeNewGeometry")
    tilted = add("ShaderNodeVectorMath")
    tilted.operation = "ADD"
    unit = add("ShaderNodeVectorMath")
    unit.operation = "NORMALIZE"
    tree.links.new(coords.outputs["Object"], cells.inputs["Vector"])
    tree.links.new(cells.outputs["Color"], centred.inputs[0])
    tree.links.new(centred.outputs["Vector"], tilt.inputs[0])
    tree.links.new(geometry.outputs["Normal"], tilted.inputs[0])
    tree.links.new(tilt.outputs["Vector"], tilted.inputs[1])
    tree.links.new(tilted.outputs["Vector"], unit.inputs[0])
    return unit, unit.outputs["Vector"]


WORN = register(InputRecipe("worn", "Wear mask", "patches where a coat is rubbed off (a noise in object space)", _worn))
UPWARD = register(InputRecipe("upward", "Faces looking up", "where a face looks up (the world normal's z)", _upward))
OIL_SWIRL = register(InputRecipe("oil_swirl", "Oil film swirl", "an oil film's thickness swirling (150-650 nm)",
                                 _oil_swirl))
ORANGE_PEEL = register(InputRecipe("orange_peel", "Orange peel", "a sprayed clear coat's orange peel (a fine bump)",
                                   _orange_peel))
FLAKES = register(InputRecipe("flakes", "Metal flakes", "metal flakes: Voronoi cells each tilting the normal",
                              _flakes))
DRAINAGE = register(InputRecipe("drainage", "Soap film drainage", "a soap film thin at the top, thick at the bottom "
                                "(150-900 nm)", _drainage))


def build(tree, name: str, socket_name: str = "", location=(0.0, 0.0)):
    """Build recipe ``name`` into ``tree`` in a frame of its own, each node marked with the recipe;
    returns (output node, output socket). ``socket_name``: the Lamella node socket it is for (the
    frame says so)."""
    recipe = RECIPES.require(name)
    frame = tree.nodes.new("NodeFrame")
    frame.label = f"Lamella preset: {recipe.label}" + (f" -> {socket_name}" if socket_name else "")
    frame[RECIPE_KEY] = name
    made = []

    def add(node_type):
        node = tree.nodes.new(node_type)
        node[RECIPE_KEY] = name
        node.parent = frame
        made.append(node)
        return node

    out_node, out = recipe.build(tree, add)
    for k, node in enumerate(made):
        node.location = (location[0] - 200.0 * (len(made) - 1 - k), location[1])
    return out_node, out


def remove(mat) -> int:
    """Remove the nodes recipes made in ``mat`` (a preset's inputs); returns how many went."""
    nt = mat.node_tree
    if nt is None:
        return 0
    made = [n for n in nt.nodes if RECIPE_KEY in n]
    for n in made:
        nt.nodes.remove(n)
    return len(made)


def add(mat, inputs) -> list:
    """Build the recipes ``inputs`` ((socket name, recipe name), ...) into ``mat``'s node tree, each
    output marked with the socket it feeds; they are linked by ``link_pending``. Returns the output
    nodes."""
    nt = mat.node_tree
    node = nt.nodes.get(face.FACE)
    x, y = (node.location[0] - 300.0, node.location[1]) if node is not None else (-600.0, 0.0)
    outs = []
    for k, (socket, name) in enumerate(inputs):
        out_node, _ = build(nt, name, socket, (x, y - 250.0 * k))
        out_node[INPUT_KEY] = socket
        outs.append(out_node)
    return outs


def face_key(settings, socket: str) -> str | None:
    """The Lamella node input key of model socket ``socket`` (``coat0_coverage``: the first coat
    of the panel's list; ``base_albedo``), or None for a layer the material does not have."""
    layer, _, field = socket.partition("_")
    if layer == "base":
        uid = face.BASE_UID
    elif layer.startswith("coat") and layer[4:].isdigit() and int(layer[4:]) < len(settings.coats):
        uid = settings.coats[int(layer[4:])].uid
    else:
        return None
    return f"{uid}/{field}"


def link_pending(mat) -> bool:
    """Link every recipe output of ``mat`` still marked with the socket it feeds to that input of
    the Lamella node (made, with its inputs, if it does not exist yet), unless something else is
    linked there. Returns whether anything was linked."""
    nt = mat.node_tree
    if nt is None or not mat.lamella.enabled:
        return False
    pending = [n for n in nt.nodes if INPUT_KEY in n]
    if not pending:
        return False
    node, tree = ensure_face(mat)
    face.sync_interface(tree, face.face_inputs(mat.lamella))
    linked = False
    for out_node in pending:
        key = face_key(mat.lamella, str(out_node[INPUT_KEY]))
        target = face.node_socket(node, key) if key is not None else None
        del out_node[INPUT_KEY]
        if target is not None and not target.is_linked:
            nt.links.new(out_node.outputs[0], target)
            linked = True
    return linked


__all__ = ["InputRecipe", "RECIPES", "register", "build", "add", "remove", "link_pending", "face_key",
           "RECIPE_KEY", "INPUT_KEY"]
