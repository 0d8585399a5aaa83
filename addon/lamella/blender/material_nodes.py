"""The nodes Lamella owns in a material, and nothing else.

A Lamella material has a Script node running the generated OSL shader (INTERNAL text, so the
shader travels with the .blend), the node group of the same model (``node_group``) and a Tangent
node (radial about the object's z, switchable to a UV map by the user) feeding both. A Material
Output whose target is Cycles shows the Script node where Cycles can run OSL (Open Shading
Language on, CPU device or OptiX) and the node group otherwise (``wire_cycles``); a Material
Output whose target is EEVEE shows the node group. Blender renders with the output whose target
matches the engine in preference to an "All" output, so the user's own nodes, and their output,
stay in the material untouched.

The nodes are found by name; a recompile reuses them, so textures linked into the Script node's
parameter sockets stay linked (a socket is kept while its parameter keeps its name and type).
"""
from __future__ import annotations

import hashlib

SCRIPT = "Lamella Shader"
OUTPUT = "Lamella Output"
TANGENT = "Lamella Tangent"
GROUP = "Lamella Nodes"
EEVEE_OUTPUT = "Lamella EEVEE Output"
OWNED = (SCRIPT, OUTPUT, TANGENT, GROUP, EEVEE_OUTPUT)
STRUCTURE_KEY = "lamella_structure"  # custom property of a group: the structure it was built for


def _place(nt):
    """A spot right of the material's existing nodes."""
    xs = [n.location.x + n.width for n in nt.nodes if n.name not in OWNED]
    ys = [n.location.y for n in nt.nodes if n.name not in OWNED]
    return (max(xs) + 200.0 if xs else 0.0), (min(ys) - 400.0 if ys else 0.0)


def _new_owned(nt, bl_idname: str, name: str, label: str, location, **props):
    """A node Lamella owns: found again by ``name``."""
    node = nt.nodes.new(bl_idname)
    node.name, node.label, node.location = name, label, location
    for key, value in props.items():
        setattr(node, key, value)
    return node


def lamella_nodes(mat):
    """(script, output, tangent) nodes of ``mat``, each None where absent."""
    nt = mat.node_tree
    if nt is None:
        return None, None, None
    return nt.nodes.get(SCRIPT), nt.nodes.get(OUTPUT), nt.nodes.get(TANGENT)


def ensure_nodes(mat):
    """The Script, output and tangent nodes, created (and linked) where missing."""
    if mat.node_tree is None:
        mat.use_nodes = True
    nt = mat.node_tree
    script, output, tangent = lamella_nodes(mat)
    if script is None or output is None or tangent is None:
        x, y = _place(nt)
    if tangent is None:
        tangent = _new_owned(nt, "ShaderNodeTangent", TANGENT, TANGENT, (x, y), direction_type="RADIAL", axis="Z")
    if script is None:
        script = _new_owned(nt, "ShaderNodeScript", SCRIPT, "Lamella", (x + 200.0, y), width=240.0)
    if output is None:
        output = _new_owned(nt, "ShaderNodeOutputMaterial", OUTPUT, OUTPUT, (x + 520.0, y), target="CYCLES")
    return script, output, tangent


def shader_text(mat, script):
    """The Text datablock holding ``mat``'s shader source: the script's own unless another
    material's node shares it (a copied material), in which case a new one (copies stay
    independent)."""
    import bpy

    text = script.script
    if text is None or text.users > 1:
        text = bpy.data.texts.new(f"lamella_{mat.name}.osl")
    return text


NOT_PARAMS = ("Normal", "Tangent", "lut_dir")  # sockets of the Script node and group that are no model parameter


def linked_sockets(mat) -> tuple:
    """The sockets linked in ``mat`` (on the Script node or the node group), sorted: a staged
    shader reads their parameters live and bakes every other value."""
    nt = mat.node_tree
    if nt is None:
        return ()
    linked = set()
    for name in (SCRIPT, GROUP):
        node = nt.nodes.get(name)
        if node is not None:
            linked |= {s.name for s in node.inputs if s.is_linked and s.name not in NOT_PARAMS}
    return tuple(sorted(linked))


def install_shader(mat, shader, oso_path, lut_dir: str) -> None:
    """Put the compiled shader (``OslShader``) into ``mat``: the Script node runs it, its parameter
    sockets take the shader's values (the stack's values: existing sockets keep their links but
    get the new value), its output and tangent are linked."""
    from .osl_compile import assign_compiled

    script, output, tangent = ensure_nodes(mat)
    text = shader_text(mat, script)
    assign_compiled(script, text, shader.source, oso_path, shader.socket_values)
    if "lut_dir" in script.inputs:  # internal (the installation's tables): set, and hidden from the artist
        script.inputs["lut_dir"].default_value = lut_dir
        script.inputs["lut_dir"].hide = True
    nt = mat.node_tree
    if not output.inputs["Surface"].is_linked:
        nt.links.new(script.outputs["BSDF"], output.inputs["Surface"])
    if "Tangent" in script.inputs and not script.inputs["Tangent"].is_linked:
        nt.links.new(tangent.outputs["Tangent"], script.inputs["Tangent"])


def refresh_lut_dir(mat, lut_dir: str) -> bool:
    """Point an existing shader at this installation's tables (a .blend made on another machine).
    Returns whether anything changed."""
    script, _, _ = lamella_nodes(mat)
    if script is None or "lut_dir" not in script.inputs:
        return False
    sock = script.inputs["lut_dir"]
    if sock.default_value == lut_dir:
        return False
    sock.default_value = lut_dir
    return True


def osl_usable(scene) -> bool:
    """Whether Cycles in ``scene`` can run the OSL shader: Open Shading Language on, and the CPU
    or an OptiX device (no other GPU backend runs OSL)."""
    cy = scene.cycles
    if not cy.shading_system:
        return False
    if cy.device == "CPU":
        return True
    import bpy

    prefs = bpy.context.preferences.addons.get("cycles")
    return prefs is not None and getattr(prefs.preferences, "compute_device_type", "") == "OPTIX"


def ensure_group_nodes(mat):
    """(group node, EEVEE output), created where missing; the group node's tree is set later."""
    nt = mat.node_tree
    node, out = nt.nodes.get(GROUP), nt.nodes.get(EEVEE_OUTPUT)
    script = nt.nodes.get(SCRIPT)
    x, y = (script.location.x, script.location.y - 300.0) if script is not None else _place(nt)
    if node is None:
        node = _new_owned(nt, "ShaderNodeGroup", GROUP, "Lamella (nodes)", (x, y), width=240.0)
    if out is None:
        out = _new_owned(nt, "ShaderNodeOutputMaterial", EEVEE_OUTPUT, EEVEE_OUTPUT, (x + 320.0, y), target="EEVEE")
    return node, out


def group_needed(scene) -> bool:
    """Whether ``scene`` renders Lamella materials through the node group now: EEVEE, or Cycles
    where it cannot run OSL."""
    engine = scene.render.engine
    return engine.startswith("BLENDER_EEVEE") or (engine == "CYCLES" and not osl_usable(scene))


def table_image_name(mat) -> str:
    return f".lamella_table {mat.name}"


def install_group(mat, stack, model: str, shader, build: bool = True) -> bool | None:
    """Give ``mat`` the node group of ``stack``, staged like ``shader`` (an ``OslShader``, or the
    pair (live parameters, lobe budget)): rebuilt only when the structure changed (the staged
    graph's structure key), and then only the nested groups whose content changed; a value edit
    only rewrites the material table's image and the sockets' values, so links into them stay. A
    group another material shares is copied first (copies stay independent). With ``build``
    False the group is left as it is (the caller builds it later). Returns whether the group was
    rebuilt, None when it was left out of date.""" 
    import bpy

    from ..core.backends.node_graph import emit_plan, live_values
    from ..core.backends.sockets import sockets
    from . import node_group
    from .osl_compile import set_socket

    node, out = ensure_group_nodes(mat)
    nt = mat.node_tree
    live, budget = (shader.live, mat.lamella.lobe_budget) if hasattr(shader, "live") else shader
    tree = node.node_tree
    if tree is not None and tree.users > 1:  # shared with a copied material: make it this one's own
        tree = tree.copy()
        node.node_tree = tree
    if not build:  # staged, even a value edit changes the group's table: all of it waits
        return None
    staged = getattr(shader, "staged", None)  # the OSL shader's staging of this stack, when it has one
    plan = emit_plan(stack, model, live=live, budget=budget, image=table_image_name(mat),
                     staged_ir=staged if staged is not None and staged.stack == stack else None)
    key = plan.staged.structure_key() if plan.staged is not None else ""
    rebuilt = tree is None or tree.get(STRUCTURE_KEY) != key
    if rebuilt:
        if tree is None:
            tree = bpy.data.node_groups.new(f"Lamella {mat.name}", "ShaderNodeTree")
        node_group.build_group(plan, tree.name, tree)
        tree[STRUCTURE_KEY] = key
        mat.lamella.node_live_values = live_values(plan)
        node.node_tree = tree
    else:
        for image, pixels in plan.images.items():
            node_group.material_table_image(image, pixels)
    for sk in sockets(plan.params):
        sock = node.inputs.get(sk.name)
        if sock is not None:
            set_socket(sock, sk.value)
    tangent = nt.nodes.get(TANGENT)
    if tangent is not None and "Tangent" in node.inputs and not node.inputs["Tangent"].is_linked:
        nt.links.new(tangent.outputs["Tangent"], node.inputs["Tangent"])
    if not node.outputs["BSDF"].is_linked or all(l.to_node != out for l in node.outputs["BSDF"].links):
        nt.links.new(node.outputs["BSDF"], out.inputs["Surface"])
    return rebuilt


def wire_cycles(mat, scene) -> bool:
    """Show in the Cycles output the Script node where ``scene`` runs OSL, else the node group.
    Returns whether a link changed."""
    nt = mat.node_tree
    if nt is None:
        return False
    out, script, group = nt.nodes.get(OUTPUT), nt.nodes.get(SCRIPT), nt.nodes.get(GROUP)
    if out is None:
        return False
    src = script if osl_usable(scene) or group is None or group.node_tree is None else group
    if src is None:
        return False
    sock = src.outputs[0]
    surface = out.inputs["Surface"]
    if surface.is_linked and surface.links[0].from_socket == sock:
        return False
    nt.links.new(sock, surface)
    return True


def source_digest(source: str) -> str:
    return hashlib.sha256(source.encode()).hexdigest()[:16]
