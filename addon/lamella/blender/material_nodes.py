"""The nodes Lamella owns in a material, and nothing else: the face (``face``) and what is inside it.

A Lamella material shows one group node, the face (``face.FACE``), whose group holds the OSL
shader (a Script node running the generated source, an INTERNAL text, its bytecode stored with the
node, so it travels with the .blend), the node group of the same model (``node_group``) and the
engine switch between them (``face``). The material renders through its active output for every
engine, as a Principled material does; nothing Lamella makes takes precedence over the artist's
nodes.

Everything a render reads is inside the .blend: the shader's tables are constants in its source
(its material table, and the model's look-up tables where a linked input's part of the model reads
them), the node group's material table is a packed image, and where a textured material's node
group reads the package's look-up tables those images are packed too.

Each material owns its face group, node group, shader text and table image: a material copied
or duplicated shares them until it is compiled, and then gets its own copies (a group or text with
more than one user is copied; a table image belongs to the node group whose name it records), so
the original is never changed by the copy's edits.
"""
from __future__ import annotations

import hashlib

import bpy

from ..core import luts
from ..core.backends.ir.live_axes import socket_ranges
from ..core.backends.ir.sockets import sockets
from ..core.backends.nodes.lower import emit_plan
from ..core.models import sides
from ..core.backends.nodes.svm import live_values
from . import animation, face, node_group
from .face import face_node, is_face_tree
from .osl_compile import assign_compiled, set_socket

STRUCTURE_KEY = "lamella_structure"  # custom property of a node group: the structure it was built for
TABLE_KEY = "lamella_table"  # custom property of a node group: the name of its material table image
NODES_KEY = "lamella_nodes"  # custom property of a table image: the name of the node group it belongs to
# the nodes earlier versions put into the material itself (migrated by ``migrate_layout``)
OLD_SCRIPT, OLD_OUTPUT, OLD_TANGENT, OLD_GROUP, OLD_EEVEE_OUTPUT = (
    "Lamella Shader", "Lamella Output", "Lamella Tangent", "Lamella Nodes", "Lamella EEVEE Output")
SCRIPT, GROUP = face.SCRIPT, face.GROUP


def inner_nodes(mat):
    """(face node, Script node, node group's node) of ``mat``, each None where absent."""
    node = face_node(mat)
    tree = node.node_tree if node is not None else None
    if tree is None:
        return node, None, None
    return node, tree.nodes.get(SCRIPT), tree.nodes.get(GROUP)


def shader_source(mat) -> str | None:
    """The OSL source ``mat``'s Script node runs, or None where it has none."""
    _, script, _ = inner_nodes(mat)
    return script.script.as_string() if script is not None and script.script is not None else None


def lamella_nodes(mat):
    """Every node Lamella made in ``mat``'s own tree (the face; an earlier version's nodes)."""
    nt = mat.node_tree
    if nt is None:
        return []
    old = (OLD_SCRIPT, OLD_OUTPUT, OLD_TANGENT, OLD_GROUP, OLD_EEVEE_OUTPUT)
    return [n for n in nt.nodes if n.name in old or (n.bl_idname == "ShaderNodeGroup" and is_face_tree(n.node_tree))]


def _shared(datablock) -> bool:
    """Whether a group Lamella made for one material is another's too (a copied material's) or
    linked from a library: it must be copied before it is changed."""
    return datablock.library is not None or datablock.users - int(datablock.use_fake_user) > 1


def _output(nt):
    """The output a new face is linked into: the active output for every engine, or a new one."""
    out = nt.get_output_node("ALL") if hasattr(nt, "get_output_node") else None
    if out is None:
        out = next((n for n in nt.nodes if n.bl_idname == "ShaderNodeOutputMaterial" and n.target == "ALL"), None)
    if out is None:
        out = nt.nodes.new("ShaderNodeOutputMaterial")
        out.target = "ALL"
        out.is_active_output = True
    return out


def ensure_face(mat, show: bool = False):
    """(face node, face group) of ``mat``, made where missing (linked into the material's output,
    in place of what it showed: the surface the artist asked Lamella for; a Lamella node the artist
    deleted is made again and linked only where the output shows nothing, unless ``show``) and
    made ``mat``'s own where it is shared with another material or linked from a library."""
    if mat.node_tree is None:
        mat.use_nodes = True
    nt = mat.node_tree
    if migrate_layout(mat):
        return face_node(mat), face_node(mat).node_tree
    node = face_node(mat)
    if node is None:
        empty = not nt.nodes
        out = _output(nt)
        node = nt.nodes.new("ShaderNodeGroup")
        node.name = node.label = face.FACE
        node.width = 260.0
        node.location = (out.location.x - 320.0, out.location.y)
        if empty:
            out.location = (320.0, 0.0)
            node.location = (0.0, 0.0)
        tree = bpy.data.node_groups.new(f"Lamella {mat.name}", "ShaderNodeTree")
        tree[face.FACE_KEY] = face.FACE_LAYOUT
        node.node_tree = tree
        face.sync_interface(tree, [])
        # the surface the artist asked Lamella for; a Lamella node deleted and made again is
        # linked only where the output shows nothing (what the artist linked there stays)
        if show or not mat.lamella.compiled_json or not out.inputs["Surface"].is_linked:
            nt.links.new(node.outputs["BSDF"], out.inputs["Surface"])
            link_thickness(nt, node)
    tree = node.node_tree
    if tree is None or not is_face_tree(tree):
        tree = bpy.data.node_groups.new(f"Lamella {mat.name}", "ShaderNodeTree")
        tree[face.FACE_KEY] = face.FACE_LAYOUT
        node.node_tree = tree
    elif _shared(tree):  # a copied or linked material's: its own from now on
        tree = tree.copy()
        tree.name = f"Lamella {mat.name}"
        node.node_tree = tree
    return node, tree


def link_thickness(nt, node) -> None:
    """Link the face's Thickness (EEVEE's, ``face.THICKNESS``) into every material output whose
    surface the face feeds directly and whose Thickness is free: the face's own pair of sockets."""
    for link in node.outputs["BSDF"].links:
        out = link.to_node
        if (out.bl_idname == "ShaderNodeOutputMaterial" and link.to_socket.name == "Surface"
                and not out.inputs[face.THICKNESS].is_linked):
            nt.links.new(node.outputs[face.THICKNESS], out.inputs[face.THICKNESS])


def eevee_settings(mat, stack, node=None) -> None:
    """The material settings EEVEE's glass needs: a base that transmits refracts by ray tracing
    where the scene traces rays (else EEVEE shows only the light probes through it, never the
    objects behind). The render method is left as it is: Dithered, the default, is the one that
    ray-traces refraction. Thickness (``face.THICKNESS``): EEVEE follows refracted light through the
    object's thickness, the material output's Thickness, or unlinked, one from the object's
    smallest dimension. So the face ``node``'s own Thickness (0: one interface) is unlinked from the
    outputs for a solid glass base, and linked into a free Thickness of an output its BSDF feeds
    for a thin-walled one (``models.sides``); an opaque base's is left as it is."""
    if not stack.base.kind.transmits:
        return
    if not mat.use_raytrace_refraction:
        mat.use_raytrace_refraction = True
    if node is None or face.THICKNESS not in node.outputs:
        return
    if sides.is_solid(stack):
        for link in list(node.outputs[face.THICKNESS].links):
            if link.to_node.bl_idname == "ShaderNodeOutputMaterial":
                mat.node_tree.links.remove(link)
    else:
        link_thickness(mat.node_tree, node)


TEXT_MARK = "lamella_shader"  # custom property of the Text datablocks Lamella writes shaders into


def shader_text(mat, script):
    """The Text datablock holding ``mat``'s shader source: the script's own unless another
    material's node shares it (a copied material), in which case a new one (copies stay
    independent). Blender gives a new text a fake user; Lamella's texts have none, so a text no
    Script node reads any more leaves the file with its material (``drop_unused_texts``)."""
    text = script.script
    if text is None or text.users - int(text.use_fake_user) > 1:
        text = bpy.data.texts.new(f"lamella_{mat.name}.osl")
    text.use_fake_user = False
    text[TEXT_MARK] = True
    return text


def drop_unused_texts() -> int:
    """Remove the shader texts Lamella wrote that no node reads (left by earlier versions, which
    made a text per edit, or by deleted Script nodes). Returns how many went."""
    def ours(t):
        return t.get(TEXT_MARK) or (t.name.startswith("lamella_") and t.lines
                                    and t.lines[0].body.startswith("// Generated by Lamella"))

    gone = [t for t in bpy.data.texts if t.library is None and t.users - int(t.use_fake_user) <= 0 and ours(t)]
    for t in gone:
        bpy.data.texts.remove(t)
    return len(gone)




def drop_unused_data() -> int:
    """Remove what Lamella made that nothing uses any more: shader texts (``drop_unused_texts``),
    node groups (a structure edit replaces nested groups; a deleted material leaves its group) and
    material-table images. Blender keeps data with no users in the saved file, so without this
    every structure edit would grow the .blend. Returns how many went."""
    own = (node_group.CHUNK_PREFIX, node_group.SECTION_PREFIX, ".lamella_nodes", "Lamella ")
    gone = 0
    while True:  # a group removed frees the nested groups it used
        groups = [g for g in bpy.data.node_groups if g.library is None and g.users == 0 and g.name.startswith(own)
                  and (not g.name.startswith("Lamella ") or STRUCTURE_KEY in g or face.FACE_KEY in g)]
        if not groups:
            break
        for g in groups:
            bpy.data.node_groups.remove(g)
        gone += len(groups)
    gone += drop_unused_texts()  # after the groups: a Lamella group removed frees its Script node's text
    images = [i for i in bpy.data.images if i.library is None and i.users == 0 and i.name.startswith(TABLE_IMAGE_PREFIX)]
    for i in images:
        bpy.data.images.remove(i)
    return gone + len(images)


def linked_sockets(mat) -> tuple:
    """The model sockets whose face inputs are linked in ``mat``, sorted: a staged shader reads
    their parameters live and bakes every other value."""
    node = face_node(mat)
    if node is None or node.node_tree is None:
        return ()
    return face.linked_models(node, face.face_inputs(mat.lamella), animation.animated_paths(node.id_data))


def sync_inputs(mat) -> None:
    """Bring an existing Lamella node's inputs to the panel's layers (their keyframes and drivers
    following their layers: ``animation.remap``) and mirror the panel's animation onto them, so
    that what is linked or animated is known before a compile."""
    node = face_node(mat)
    if node is None or node.node_tree is None or _shared(node.node_tree):
        return
    before = animation.input_order(node)
    face.sync_interface(node.node_tree, face.face_inputs(mat.lamella))
    animation.remap(node, before)
    animation.mirror_panel(mat)


def input_socket(mat, layer, field: str):
    """The face input of ``layer`` (a coat's index, 0 = top, or "base") and ``field`` (a stack
    field name, or ``<roughness field>_y`` for an anisotropic roughness across the tangent)."""
    settings = mat.lamella
    if layer == "base":
        uid = face.BASE_UID
    elif isinstance(layer, int) and not isinstance(layer, bool) and 0 <= layer < len(settings.coats):
        uid = settings.coats[layer].uid
    else:
        raise KeyError(f"layer {layer!r}: expected a coat index from 0 to {len(settings.coats) - 1} or 'base'")
    node = face_node(mat)
    sock = face.node_socket(node, f"{uid}/{field}") if node is not None else None
    if sock is None:
        known = sorted(i.key.split("/", 1)[1] for i in face.face_inputs(settings) if i.key.startswith(f"{uid}/"))
        raise KeyError(f"layer {layer!r} has no input {field!r} (it has: {', '.join(known)})")
    return sock


def input_for_model(mat, model_socket: str):
    """The Lamella node's input that feeds the model socket ``model_socket`` (``coat0_roughness``,
    ``base_eta``) now, or None."""
    node = face_node(mat)
    i = next((i for i in face.face_inputs(mat.lamella) if i.model == model_socket), None)
    return face.node_socket(node, i.key) if node is not None and i is not None else None


def not_an_input_message(mat, names) -> str:
    """What to do when the inputs ``names`` (model sockets: ``coat0_roughness``) of ``mat``'s
    Lamella node are linked or animated but the stack being compiled has no such input: the
    inputs named as the node shows them, with what feeds them."""
    shown = []
    for name in names:
        sock = input_for_model(mat, name)
        if sock is None:
            shown.append(name)
            continue
        fed = f" (linked from {sock.links[0].from_node.name!r})" if sock.is_linked and sock.links else " (animated)"
        shown.append(f"{sock.name!r}{fed}")
    many = len(shown) > 1
    return (f"the Lamella node's input{'s' if many else ''} {', '.join(shown)} {'feed' if many else 'feeds'} "
            f"a layer or field this stack does not have: unlink {'them' if many else 'it'} (or link into an input "
            "the stack has), then apply again; the material keeps its shader")


def install(mat, stack, model: str, shader, oso_path, build_group: bool = True) -> bool | None:
    """Put a compiled shader (``OslShader`` compiled to ``oso_path``) and the node group of the
    same staging into ``mat``'s face, and wire the face's inputs to both. With ``build_group``
    False a structure change leaves the node group as it is (``install_group``). Returns whether the
    node group was rebuilt, None when it was left out of date."""
    node, tree = ensure_face(mat)
    inputs = face.face_inputs(mat.lamella)
    before = animation.input_order(node)
    had_thickness = face.THICKNESS in node.outputs
    face.sync_interface(tree, inputs)
    if not had_thickness:  # a face of an earlier version: its Thickness goes where its surface goes
        link_thickness(mat.node_tree, node)
    eevee_settings(mat, stack, node)
    animation.remap(node, before)
    face.set_node_values(node, inputs)
    if shader.tables:
        raise ValueError(f"the shader of {mat.name!r} reads table files ({', '.join(shader.tables)}): a "
                         "material's shader carries its tables in its source (osl_shader's tables='inline')")
    script = tree.nodes.get(SCRIPT)
    if script is None:
        script = tree.nodes.new("ShaderNodeScript")
        script.name, script.label, script.width = SCRIPT, "Lamella (OSL)", 240.0
    text = shader_text(mat, script)
    assign_compiled(script, text, shader.source, oso_path, shader.socket_values)
    text[SOURCE_KEY] = source_digest(shader.source)
    group = tree.nodes.get(GROUP)
    if group is None:
        group = tree.nodes.new("ShaderNodeGroup")
        group.name, group.label, group.width = GROUP, "Lamella (nodes)", 240.0
    rebuilt = install_group(mat, group, stack, model, shader, build=build_group)
    face.wire(tree, inputs, script, group, face.live_keys(node, inputs, animation.animated_paths(mat.node_tree)))
    animation.mirror_panel(mat)
    return rebuilt


def build_group(mat, stack, model: str, live_budget) -> bool | None:
    """Build the node group a deferred compile left out of date (``install``'s ``build_group``
    False), from the stack and live parameters the material's shader shows, and wire it."""
    node, script, group = inner_nodes(mat)
    if node is None or group is None:
        return None
    rebuilt = install_group(mat, group, stack, model, live_budget)
    inputs = face.face_inputs(mat.lamella)
    face.wire(node.node_tree, inputs, script, group,
              face.live_keys(node, inputs, animation.animated_paths(mat.node_tree)))
    return rebuilt


def osl_usable(scene) -> bool:
    """Whether Cycles in ``scene`` can run the OSL shader: Open Shading Language on, and the CPU
    or an OptiX device (no other GPU backend runs OSL)."""
    cy = scene.cycles
    if not cy.shading_system:
        return False
    if cy.device == "CPU":
        return True
    prefs = bpy.context.preferences.addons.get("cycles")
    return prefs is not None and getattr(prefs.preferences, "compute_device_type", "") == "OPTIX"


def group_needed(scene) -> bool:
    """Whether ``scene`` renders Lamella materials through the node group now: EEVEE, or Cycles
    where it cannot run OSL."""
    engine = scene.render.engine
    return engine.startswith("BLENDER_EEVEE") or (engine == "CYCLES" and not osl_usable(scene))


TABLE_IMAGE_PREFIX = ".lamella_table "


def own_table_image(tree):
    """The material table image of node group ``tree``: the one it names, if that image names the
    group back (a copied or appended group, renamed, gets a new one)."""
    name = tree.get(TABLE_KEY)
    img = bpy.data.images.get(name) if name else None
    if img is None or img.library is not None or img.get(NODES_KEY) != tree.name:
        img = bpy.data.images.new(f"{TABLE_IMAGE_PREFIX}{tree.name.lstrip('.')}"[:60], 1, 1, alpha=True,
                                  float_buffer=True, is_data=True)
        img[NODES_KEY] = tree.name
        tree[TABLE_KEY] = img.name
    return img


def install_group(mat, node, stack, model: str, shader, build: bool = True) -> bool | None:
    """Give the face's node-group node ``node`` the node group of ``stack``, staged like ``shader``
    (an ``OslShader``, or the pair (live parameters, lobe budget)): rebuilt only when the
    structure changed (the staged graph's structure key, the table image's name included), and
    then only the nested groups whose content changed; a value edit only rewrites the material
    table's image and the sockets' values. A group another face shares (a copied material's) is
    copied first. With ``build`` False the group is left as it is (the caller builds it later).
    Returns whether the group was rebuilt, None when it was left out of date."""
    live, budget = (shader.live, mat.lamella.lobe_budget) if hasattr(shader, "live") else shader
    tree = node.node_tree
    if tree is not None and _shared(tree):  # shared with a copied material: its own
        tree = tree.copy()
        node.node_tree = tree
    if not build:  # staged, even a value edit changes the group's table: all of it waits
        return None
    if tree is None:
        tree = bpy.data.node_groups.new(f".lamella_nodes {mat.name}"[:60], "ShaderNodeTree")
    image = own_table_image(tree)
    staged = getattr(shader, "staged", None)  # the OSL shader's staging of this stack, when it has one
    plan = emit_plan(stack, model, live=live, budget=budget, image=image.name,
                     staged_ir=staged if staged is not None and staged.stack == stack else None)
    key = _layout_prefix() + (plan.staged.structure_key() if plan.staged is not None else "") + "|" + image.name
    rebuilt = node.node_tree is None or tree.get(STRUCTURE_KEY) != key
    if rebuilt:
        node_group.build_group(plan, tree.name, tree)
        tree[STRUCTURE_KEY] = key
        mat.lamella.node_live_values = live_values(plan)
        ranges = socket_ranges(plan.staged.axis_tables, plan.ids) if plan.staged is not None else {}
        mat.lamella.node_tables = ", ".join(f"{name} {lo:.3g} to {hi:.3g}" for name, (lo, hi) in ranges.items())
        node.node_tree = tree
    else:
        for name, pixels in plan.images.items():
            node_group.material_table_image(name, pixels)
    for sk in sockets(plan.ids, plan.params):
        sock = node.inputs.get(sk.name)
        if sock is not None:
            set_socket(sock, sk.value)
    return rebuilt


def old_layout(mat) -> bool:
    """Whether ``mat`` holds the nodes of an earlier version (``migrate_layout`` on its next
    compile)."""
    nt = mat.node_tree
    return nt is not None and any(nt.nodes.get(n) is not None for n in (OLD_SCRIPT, OLD_OUTPUT, OLD_EEVEE_OUTPUT))


def migrate_layout(mat) -> bool:
    """Bring a material compiled by an earlier version (a Script node, a node group, a tangent and
    two engine-specific outputs in the material itself) to the face: its nodes go, the links
    artists made into their parameter sockets move to the face's inputs (by the layer each fed),
    and the face is linked into the material's active output (the earlier version's outputs took
    precedence over it, so what rendered was Lamella's). Returns whether anything changed."""
    nt = mat.node_tree
    if nt is None:
        return False
    old = [nt.nodes.get(n) for n in (OLD_SCRIPT, OLD_OUTPUT, OLD_TANGENT, OLD_GROUP, OLD_EEVEE_OUTPUT)]
    old = [n for n in old if n is not None and not (n.bl_idname == "ShaderNodeGroup" and is_face_tree(n.node_tree))]
    if not old:
        return False
    links = []  # (from socket, model socket name) of links into the old parameter sockets
    for n in old:
        if n.name in (OLD_SCRIPT, OLD_GROUP):
            links += [(lk.from_socket, lk.to_socket.name) for s in n.inputs if s.is_linked for lk in s.links
                      if lk.from_node.name not in (OLD_TANGENT,) and s.name not in ("Normal", "Tangent", "lut_dir")]
    for n in old:
        nt.nodes.remove(n)
    # what the earlier version's Cycles and EEVEE outputs showed, the active output shows now
    node, tree = ensure_face(mat, show=True)
    inputs = face.face_inputs(mat.lamella)
    face.sync_interface(tree, inputs)
    by_model = {i.model: i.key for i in inputs if i.model}
    seen = set()
    for src, model in links:
        key = by_model.get(model)
        sock = face.node_socket(node, key) if key else None
        if sock is not None and key not in seen:
            nt.links.new(src, sock)
            seen.add(key)
    return True


def source_digest(source: str) -> str:
    return hashlib.sha256(source.encode()).hexdigest()[:16]


SOURCE_KEY = "lamella_source"  # custom property of a shader text: the digest of the source Lamella wrote


def reads_old_tables(source: str) -> bool:
    """Whether OSL ``source`` reads the look-up tables as a layout before ``luts.LAYOUT`` stored
    them (a shader saved by an older Lamella: it would read the wrong rows now)."""
    return "lamella_tex(" in source and luts.LAYOUT_MARK not in source


def _layout_prefix() -> str:
    """What a node group's structure key starts with: the look-up tables' layout its reads assume."""
    return f"luts{luts.LAYOUT}:"


def broken(mat, group_pending: bool = False) -> str | None:
    """What is wrong with the nodes of compiled material ``mat`` (the face or what is inside it
    deleted, the shader text edited, the node group or its table gone), or None if they render what
    Lamella built. ``group_pending``: the node group waits for a rebuild anyway (not checked).
    Where the face sits in the artist's tree, and what its output feeds, is the artist's."""
    nt = mat.node_tree
    if nt is None:
        return "the material has no nodes"
    node, script, group = inner_nodes(mat)
    if node is None:
        return f"the node '{face.FACE}' was deleted"
    live = bool(mat.lamella.live_params)
    if script is not None:
        text = script.script
        if text is None or not script.bytecode:
            return f"the node '{SCRIPT}' has no shader"
        if text.get(SOURCE_KEY) and source_digest(text.as_string()) != text[SOURCE_KEY]:
            return f"the shader text '{text.name}' was edited"
        if reads_old_tables(text.as_string()):
            return f"the shader text '{text.name}' reads the look-up tables of an older Lamella"
    elif not live:
        return f"the node '{SCRIPT}' was deleted"
    if group_pending and script is not None:
        return None
    if group is None or group.node_tree is None:
        return f"the node group '{GROUP}' was deleted"
    if not str(group.node_tree.get(STRUCTURE_KEY, "")).startswith(_layout_prefix()):
        return f"the node group '{group.node_tree.name}' was built for the look-up tables of an older Lamella"
    gone = node_group.missing_images(group.node_tree)
    if gone:
        return f"the node group's image '{gone[0]}' was deleted"
    return None


def prepare_repair(mat) -> None:
    """Make the next compile of ``mat`` rebuild its node group from scratch (what ``broken``
    finds wrong may sit inside it)."""
    _, _, group = inner_nodes(mat)
    if group is not None and group.node_tree is not None and STRUCTURE_KEY in group.node_tree:
        del group.node_tree[STRUCTURE_KEY]
