"""The nodes Lamella owns in a material, and nothing else.

A Lamella material has a Script node running the generated OSL shader (INTERNAL text, so the
shader travels with the .blend) feeding a Material Output whose target is Cycles, and a Tangent
node (radial about the object's z, switchable to a UV map by the user) feeding the shader's
Tangent input. Blender renders with the output whose target matches the engine in preference to
an "All" output, so the user's own nodes, and their output, stay in the material untouched; the
EEVEE target is left to an EEVEE output.

The nodes are found by name; a recompile reuses them, so textures linked into the Script node's
parameter sockets stay linked (a socket is kept while its parameter keeps its name and type).
"""
from __future__ import annotations

import hashlib

SCRIPT = "Lamella Shader"
OUTPUT = "Lamella Output"
TANGENT = "Lamella Tangent"


def _place(nt):
    """A spot right of the material's existing nodes."""
    xs = [n.location.x + n.width for n in nt.nodes if n.name not in (SCRIPT, OUTPUT, TANGENT)]
    ys = [n.location.y for n in nt.nodes if n.name not in (SCRIPT, OUTPUT, TANGENT)]
    return (max(xs) + 200.0 if xs else 0.0), (min(ys) - 400.0 if ys else 0.0)


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
        tangent = nt.nodes.new("ShaderNodeTangent")
        tangent.name = tangent.label = TANGENT
        tangent.direction_type = "RADIAL"
        tangent.axis = "Z"
        tangent.location = (x, y)
    if script is None:
        script = nt.nodes.new("ShaderNodeScript")
        script.name = SCRIPT
        script.label = "Lamella"
        script.location = (x + 200.0, y)
        script.width = 240.0
    if output is None:
        output = nt.nodes.new("ShaderNodeOutputMaterial")
        output.name = output.label = OUTPUT
        output.target = "CYCLES"
        output.location = (x + 520.0, y)
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


def install_shader(mat, source: str, oso_path, lut_dir: str) -> None:
    """Put the compiled shader into ``mat``: the Script node runs it, its parameter sockets take the
    shader's defaults (the stack's values: existing sockets keep their links but get the new
    value), its output and tangent are linked."""
    from .osl_compile import assign_compiled

    script, output, tangent = ensure_nodes(mat)
    text = shader_text(mat, script)
    assign_compiled(script, text, source, oso_path)
    if "lut_dir" in script.inputs:
        script.inputs["lut_dir"].default_value = lut_dir
    nt = mat.node_tree
    if not script.outputs["BSDF"].is_linked or script.outputs["BSDF"].links[0].to_node != output:
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


def source_digest(source: str) -> str:
    return hashlib.sha256(source.encode()).hexdigest()[:16]
