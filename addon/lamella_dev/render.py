"""Canonical sphere scenes (docs/design.md "Contract: the canonical sphere scenes") rendered headless
through bpy. Used by `lamella render`, the references and the tests: one code path."""
from __future__ import annotations

import math
import time
from pathlib import Path

from lamella.core.param_id import r_from_alpha


ENGINES = ("cycles-osl", "cycles-nodes", "eevee", "principled", "eevee-principled", "principled-svm", "reference")
SCENES = ("sphere-env", "sphere-sun", "white-furnace")
# white-furnace (not a canonical comparison scene): a uniform white world of radiance 1, so every
# sphere pixel shows the material's directional albedo for that pixel's view direction.
DEFAULT_SUN_DIR = (0.0, -1.0, 1.0)


def _bpy():
    import bpy

    return bpy


def node_tree(idblock):
    """The node tree of a new material or world: present from Blender 5.0 on, made by
    ``use_nodes`` before (4.2 to 4.5)."""
    if idblock.node_tree is None:
        idblock.use_nodes = True
    return idblock.node_tree


def build_scene(scene: str, res: int, spp: int, sun_dir=DEFAULT_SUN_DIR, seed: int = 0, open_back: bool = False):
    """The canonical scene, unbiased: no denoiser, no adaptive sampling, no glossy filter and no
    sample clamping, one sampling pattern in every Blender version, so that renders converge to the same image at any spp and differences
    between engines are the materials' alone. ``open_back`` removes the half of the sphere the
    camera does not see, so a light behind it reaches the front through transmission lobes:
    Cycles' shadow rays stop at the far side of a closed mesh whose shader has no transparent
    closure, whatever its refracting closures would let through. The open scene renders direct
    light only (no bounces)."""
    bpy = _bpy()
    from mathutils import Vector

    if scene not in SCENES:
        raise ValueError(f"scene must be one of {SCENES}, got {scene!r}")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.shading_system = True
    sc.cycles.samples = spp
    sc.cycles.seed = seed
    sc.cycles.use_denoising = False
    sc.cycles.use_adaptive_sampling = False
    # the sequence 4.2-5.0 default to; 5.2 defaults to "Automatic" (blue noise at low sample
    # counts), which gives the same image in expectation and other noise, so figures measured at
    # a few samples would move between Blender versions for no reason
    sc.cycles.sampling_pattern = "TABULATED_SOBOL"
    sc.cycles.blur_glossy = 0.0
    sc.cycles.sample_clamp_direct = 0.0
    sc.cycles.sample_clamp_indirect = 0.0
    sc.view_settings.view_transform = "Standard"
    sc.render.resolution_x = sc.render.resolution_y = res
    sc.render.resolution_percentage = 100
    bpy.ops.mesh.primitive_uv_sphere_add(segments=128, ring_count=64, radius=1.0, location=(0, 0, 0))
    sphere = bpy.context.object
    bpy.ops.object.shade_smooth()
    if open_back:
        # the open half-sphere sees its own inside, which would add indirect light to the direct
        # light a transmission lobe lets through: render direct light only
        sc.cycles.max_bounces = 0
        import bmesh

        bm = bmesh.new()
        bm.from_mesh(sphere.data)
        bmesh.ops.delete(bm, geom=[v for v in bm.verts if v.co.y > 1e-6], context="VERTS")
        bm.to_mesh(sphere.data)
        bm.free()
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    sc.collection.objects.link(cam)
    sc.camera = cam
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 2.2
    cam.location = (0.0, -10.0, 0.0)
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)  # looks along +y, up = +z
    world = bpy.data.worlds.new("world")
    sc.world = world
    nodes = node_tree(world).nodes
    bg = nodes["Background"]
    if scene == "sphere-env":
        hdri = Path(bpy.utils.system_resource("DATAFILES", path="studiolights/world")) / "forest.exr"
        env = nodes.new("ShaderNodeTexEnvironment")
        env.image = bpy.data.images.load(str(hdri))
        world.node_tree.links.new(env.outputs["Color"], bg.inputs["Color"])
        bg.inputs["Strength"].default_value = 1.0
    elif scene == "white-furnace":
        bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
        bg.inputs["Strength"].default_value = 1.0
    else:
        bg.inputs["Strength"].default_value = 0.0
        sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
        sc.collection.objects.link(sun)
        sun.data.energy = 3.0
        sun.data.angle = 0.0
        d = Vector(sun_dir).normalized()
        sun.rotation_euler = d.to_track_quat("Z", "Y").to_euler()  # the lamp shines along its -Z
    return sc, sphere


def sphere_material(sphere, name: str):
    """A new, empty node material as the only material of ``sphere``: (material, node tree, its
    Material Output)."""
    mat = _bpy().data.materials.new(name)
    sphere.data.materials.clear()
    sphere.data.materials.append(mat)
    nt = node_tree(mat)
    nt.nodes.clear()
    return mat, nt, nt.nodes.new("ShaderNodeOutputMaterial")


LAMELLA_NODE_ENGINES = ("lamella-osl", "lamella-svm", "lamella-eevee")


def assign_material(sphere, stack, engine: str, model: str = "auto", budget="auto", staged: bool = True, live=(),
                    live_axes="auto", stand_ins: int | None = None):
    """A material showing ``stack`` through ``engine`` on ``sphere``: the staged shader (lobes
    merged to ``budget``, the sockets or parameters ``live`` read live, as if a texture were linked
    into them) or, with ``staged`` False, the whole traced model. ``live_axes``: the node group's
    tables over linked parameters (``lower.emit_plan``); ``stand_ins``: the node group's isotropic
    lobes per anisotropic one in EEVEE (``lower.emit_plan``; default: the product's)."""
    bpy = _bpy()
    mat, nt, out = sphere_material(sphere, "lamella")
    if engine == "cycles-osl":
        from lamella.core.backends.osl.emit import osl_shader
        from lamella.blender.osl_compile import assign_script

        node = nt.nodes.new("ShaderNodeScript")
        name = f"lamella_{stack.name or 'stack'}.osl"
        shader = osl_shader(stack, model, budget=budget, staged=staged, live=live)
        assign_script(node, bpy.data.texts.new(name), shader.source, name, shader.socket_values)
        nt.links.new(node.outputs["BSDF"], out.inputs["Surface"])
    elif engine in ("cycles-nodes", "eevee"):
        from lamella.core.backends.nodes.lower import emit_plan
        from lamella.blender.node_group import build_group, group_name

        extra = {} if stand_ins is None else {"stand_ins": stand_ins}
        group = build_group(emit_plan(stack, model, budget=budget, staged=staged, live=live,
                                      image=f".lamella_table {mat.name}", live_axes=live_axes, **extra),
                            group_name(stack.name))
        node = nt.nodes.new("ShaderNodeGroup")
        node.node_tree = group
        tangent = nt.nodes.new("ShaderNodeTangent")
        tangent.direction_type = "RADIAL"
        tangent.axis = "Z"
        nt.links.new(tangent.outputs["Tangent"], node.inputs["Tangent"])
        nt.links.new(node.outputs["BSDF"], out.inputs["Surface"])
        if engine == "cycles-nodes":
            sphere.users_scene[0].cycles.shading_system = False
        else:
            use_eevee(sphere.users_scene[0])
    elif engine in LAMELLA_NODE_ENGINES:
        # what an artist's material is: the extension's Lamella node (the Script node and the node
        # group behind the switch the renderer resolves)
        import lamella.blender
        from lamella.blender import api

        if not hasattr(bpy.types.Material, "lamella"):
            lamella.blender.register()
        if str(budget) != "auto":
            mat.lamella.lobe_budget = str(budget)
        api.apply_stack(mat, stack, model)
        sc = sphere.users_scene[0]
        if engine == "lamella-svm":
            sc.cycles.shading_system = False
        elif engine == "lamella-eevee":
            use_eevee(sc)
    elif engine == "reference":
        raise ValueError("the reference engine builds geometry, not a material: use render_stack")
    elif engine in ("principled", "eevee-principled", "principled-svm"):
        nt.links.new(_principled(nt, stack).outputs["BSDF"], out.inputs["Surface"])
        if engine == "eevee-principled":
            use_eevee(sphere.users_scene[0])
        elif engine == "principled-svm":  # Cycles' default shading system
            sphere.users_scene[0].cycles.shading_system = False
    else:
        raise ValueError(f"engine {engine!r} is not available yet (have: {', '.join(ENGINES)})")
    return mat


def use_eevee(sc):
    """Render ``sc`` with EEVEE as it works headless here: shadows off (see docs/extension.md)."""
    bpy = _bpy()
    engines = {e.identifier for e in bpy.types.RenderSettings.bl_rna.properties["engine"].enum_items}
    sc.render.engine = "BLENDER_EEVEE" if "BLENDER_EEVEE" in engines else "BLENDER_EEVEE_NEXT"
    sc.eevee.taa_render_samples = sc.cycles.samples
    sc.eevee.use_shadows = False


def _principled(nt, stack):
    """The closest Principled BSDF stand-in artists use today: a metal with the conductor's
    normal-incidence colour and roughness, under one clear coat with the top coat's IOR and
    roughness (Blender roughness r = sqrt(alpha))."""
    p = nt.nodes.new("ShaderNodeBsdfPrincipled")
    b = stack.base
    if b.type == "conductor":
        n_top = stack.coats[-1].ior if stack.coats else 1.0
        f0 = [((e / n_top - 1) ** 2 + (k / n_top) ** 2) / ((e / n_top + 1) ** 2 + (k / n_top) ** 2) for e, k in zip(b.eta, b.k)]
        p.inputs["Base Color"].default_value = (*f0, 1.0)
        p.inputs["Metallic"].default_value = 1.0
        ax, ay = b.roughness
        p.inputs["Roughness"].default_value = r_from_alpha(math.sqrt(ax * ay))
    if stack.coats:
        top = stack.coats[0]
        p.inputs["Coat Weight"].default_value = 1.0
        p.inputs["Coat IOR"].default_value = top.ior
        p.inputs["Coat Roughness"].default_value = r_from_alpha(math.sqrt(top.roughness[0] * top.roughness[1]))
    return p


def render_stack(stack, scene="sphere-env", sun_dir=DEFAULT_SUN_DIR, res=96, spp=32, engine="cycles-osl",
                 out: str | Path | None = None, filter_width: float | None = None, seed: int = 0,
                 thickness: float | None = None, open_back: bool = False, model: str = "auto", budget="auto",
                 staged: bool = True, interfaces: str = "single"):
    """Render ``stack`` into a canonical scene; returns (RGBA float32 array, top row first;
    render seconds). Writes a linear float EXR to ``out`` if given. ``engine="reference"`` builds
    the stack as nested interface spheres (reference_scene) of shell ``thickness``; ``open_back``
    as in ``build_scene``; ``model`` the layered model of the cycles-osl shader; ``interfaces`` the
    reference's rough interfaces (``reference_scene.INTERFACES``). A reference of a stack with partly
    covering coats is the mix of its parts' references (``reference.covered_parts``)."""
    from lamella.core.exr import write_rgba
    from lamella.core.stack import Stack

    stack = Stack.coerce(stack)
    if engine == "reference":
        from .reference import covered_parts

        parts = covered_parts(stack)
        if len(parts) > 1 or parts[0][0] != 1.0:  # partly covering coats: the mix of each part's spheres
            px, seconds = 0.0, 0.0
            for w, part in parts:
                p, s = render_stack(part, scene, sun_dir, res, spp, engine, None, filter_width, seed, thickness,
                                    open_back, model, budget, staged, interfaces)
                px, seconds = px + w * p, seconds + s
            if out is not None:
                write_rgba(out, px)
            return px, seconds
    sc, sphere = build_scene(scene, res, spp, sun_dir, seed=seed, open_back=open_back)
    if filter_width is not None:
        sc.cycles.filter_width = filter_width
    if engine == "reference":
        from .reference_scene import SHELL_THICKNESS, build_reference

        build_reference(sc, sphere, stack, thickness if thickness is not None else SHELL_THICKNESS, interfaces)
    else:
        assign_material(sphere, stack, engine, model, budget, staged)
    px, seconds = render_scene(sc)
    if out is not None:
        write_rgba(out, px)
    return px, seconds


def render_scene(sc):
    """Render scene ``sc`` as it is set up: (RGBA float32 array, top row first; render seconds)."""
    import tempfile

    from lamella.core.exr import read_rgba

    bpy = _bpy()
    with tempfile.TemporaryDirectory() as tmp:
        sc.render.image_settings.file_format = "OPEN_EXR"
        sc.render.image_settings.color_depth = "32"
        sc.render.filepath = str(Path(tmp) / "render.exr")
        t0 = time.time()
        bpy.ops.render.render(write_still=True, scene=sc.name)
        seconds = time.time() - t0
        return read_rgba(Path(tmp) / "render.exr"), seconds
