"""Run in a fresh process by test_preset_exports: the presets' node groups (``node_groups/``) in a
Blender without the extension, against the extension's own materials, in the scene of
``material_life_session`` (four spheres, one preset each; its imports block the checkout's
``lamella``, ``lamella_dev`` and the pip packages a stock Blender lacks).

``library BLEND ENTRIES OUT``: no add-on enabled; a new file; the groups of the manifest entries
ENTRIES (JSON) appended from BLEND (a copy, deleted once they are appended); sphere k gets a new material with group k wired as the folder's
README says (BSDF into Surface, Thickness into Thickness; Raytraced Transmission where the base
transmits); renders Cycles with OSL, Cycles without OSL and EEVEE, then Cycles with OSL again with
each group's Script node linked straight to the group's output (the engine switch would otherwise
fall back on the node group where the stored shader did not run, and hide it).
``extension ZIP STACKS OUT``: the extension installed from its zip; each stack of STACKS (JSON
[[id, stack], ...]) applied to a new material by the batch API; the same three renders.

Prints one JSON line: for each render, the mean RGB of each sphere, and what the library session
found about where the groups' data lives."""
import json
import sys
from pathlib import Path

import material_life_session as life  # noqa: E402  (first: it blocks the checkout, then imports bpy)

bpy = life.bpy


def _trees(tree, seen=None):
    """``tree`` and every group nested in it."""
    seen = set() if seen is None else seen
    if tree.name_full in seen:
        return seen
    seen.add(tree.name_full)
    for n in tree.nodes:
        if n.bl_idname == "ShaderNodeGroup" and n.node_tree is not None:
            _trees(n.node_tree, seen)
    return seen


def library(blend: Path, entries: list, out: Path) -> dict:
    import addon_utils

    sc, spheres = life.studio_scene()
    names = [e["group"] for e in entries]
    with bpy.data.libraries.load(str(blend)) as (src, dst):
        missing = sorted(set(names) - set(src.node_groups))
        dst.node_groups = [n for n in names if n in src.node_groups]
    groups = list(dst.node_groups)
    blend.unlink()  # a copy of the library: nothing may read it once appended
    for sphere, entry, group in zip(spheres, entries, groups):
        mat = bpy.data.materials.new(entry["id"])
        if mat.node_tree is None:
            mat.use_nodes = True
        nt = mat.node_tree
        nt.nodes.clear()
        node = nt.nodes.new("ShaderNodeGroup")
        node.node_tree = group
        output = nt.nodes.new("ShaderNodeOutputMaterial")
        nt.links.new(node.outputs["BSDF"], output.inputs["Surface"])
        nt.links.new(node.outputs["Thickness"], output.inputs["Thickness"])
        if entry["transmits"]:
            mat.use_raytrace_refraction = True
        sphere.data.materials.append(mat)
    inside = sorted(set().union(*(_trees(g) for g in groups)))
    trees = [bpy.data.node_groups[name] for name in inside]
    images = {n.image for t in trees for n in t.nodes if n.bl_idname == "ShaderNodeTexImage" and n.image}
    scripts = [n for t in trees for n in t.nodes if n.bl_idname == "ShaderNodeScript"]
    try:
        import lamella  # noqa: F401
        importable = True
    except ImportError:
        importable = False
    found = {
        "missing_groups": missing,
        "lamella_importable": importable,
        "lamella_enabled": [m.__name__ for m in addon_utils.modules()
                            if addon_utils.check(m.__name__)[1] and "lamella" in m.__name__],
        "linked": sorted(i.name for i in [*trees, *images, *(s.script for s in scripts if s.script)] if i.library),
        "nested_groups": len(trees),
        "images": [[i.name, i.packed_file is not None, i.source] for i in images],
        "scripts": [[s.mode, s.script is not None and bool(s.script.as_string()), bool(s.bytecode)] for s in scripts],
        "library": life.render_all(sc, out, "library"),
    }
    for group in groups:
        script = next(n for n in group.nodes if n.bl_idname == "ShaderNodeScript")
        output = next(n for n in group.nodes if n.bl_idname == "NodeGroupOutput")
        group.links.new(script.outputs["BSDF"], output.inputs["BSDF"])
    sc.render.engine = "CYCLES"
    sc.cycles.shading_system = True
    found["script_only"] = life.sphere_means(sc, out, "script_only")
    return found


def extension(zip_path: Path, stacks: list, out: Path) -> dict:
    bpy.ops.extensions.package_install_files(filepath=str(zip_path), repo="user_default", enable_on_install=True)
    ext = sys.modules["bl_ext.user_default.lamella"]
    sc, spheres = life.studio_scene()
    for sphere, (name, preset) in zip(spheres, stacks):
        mat = bpy.data.materials.new(name)
        ext.apply_preset(mat, preset)
        sphere.data.materials.append(mat)
    return {"extension": life.render_all(sc, out, "extension")}


if __name__ == "__main__":
    import os

    mode, source, data, out = sys.argv[1], Path(sys.argv[2]), json.loads(sys.argv[3]), Path(sys.argv[4])
    out.mkdir(parents=True, exist_ok=True)
    result = library(source, data, out) if mode == "library" else extension(source, data, out)
    print("FOUND " + json.dumps(result))
    sys.stdout.flush()
    os._exit(0)
