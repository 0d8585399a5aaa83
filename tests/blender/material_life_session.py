"""Run in a fresh process by test_material_life: a material's life across machines.

``author ZIP BLEND``: a stock-Blender session (the development copy blocked) installs the built
zip, makes four spheres in one frame and saves the file:
  0 gold_coated through the batch API (no texture: the OSL shader where Cycles runs OSL),
  1 a coat whose roughness a Noise texture drives, linked into the Lamella node's input, over a
    base whose colour is keyframed in the panel (frame 1 warm, frame 3 cold),
  2 a copy of material 0 (``Material.copy()``) whose top coat was made rough and tinted in the
    panel,
  3 a new material with the stack of 2 (what 2 must render),
renders the frame in Cycles with OSL, Cycles without OSL and EEVEE (before the copy's edit too,
and on frame 3) and saves the file with OSL on, on frame 1.
``farm BLEND``: a render farm's Blender: neither the extension nor the checkout can be imported
and no add-on is enabled; opens the file and renders it in the three engine paths, on the frame
it was saved on and on frame 3.

Prints one JSON line: for each engine path, the mean RGB of each sphere."""
import json
import os
import sys
from pathlib import Path

for name in ("lamella", "lamella_dev", "OpenEXR", "matplotlib", "colour", "flip_evaluator", "hypothesis", "scipy"):
    sys.modules[name] = None

import bpy  # noqa: E402
import numpy as np  # noqa: E402

ENGINES = (("cycles-osl", "CYCLES", True), ("cycles-nodes", "CYCLES", False), ("eevee", "BLENDER_EEVEE", False))
CENTRES = ((-1.1, 1.1), (1.1, 1.1), (-1.1, -1.1), (1.1, -1.1))  # (x, z) of spheres 0-3
RES = 64


def sphere_means(sc, out: Path, tag: str) -> list:
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    sc.render.filepath = str(out / f"{tag}.exr")
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(str(out / f"{tag}.exr"), check_existing=False)
    px = np.empty(len(img.pixels), dtype=np.float32)
    img.pixels.foreach_get(px)
    px = px.reshape(RES, RES, 4)[::-1]  # top row first
    bpy.data.images.remove(img)
    # pixel centres in the camera's frame: ortho_scale 4.4 over RES pixels, x right, z up
    c = (np.arange(RES) + 0.5) / RES * 4.4 - 2.2
    x, z = np.meshgrid(c, -c)
    means = []
    for cx, cz in CENTRES:
        inside = (x - cx) ** 2 + (z - cz) ** 2 < 0.95 ** 2
        means.append([float(v) for v in px[inside, :3].mean(axis=0)])
    return means


def render_all(sc, out: Path, tag: str) -> dict:
    found = {}
    eevee = {e.identifier for e in bpy.types.RenderSettings.bl_rna.properties["engine"].enum_items}  # EEVEE's name
    for name, engine, osl in ENGINES:
        sc.render.engine = engine if engine != "BLENDER_EEVEE" or engine in eevee else "BLENDER_EEVEE_NEXT"  # 4.2-4.5
        if engine == "CYCLES":
            sc.cycles.shading_system = osl
        found[name] = sphere_means(sc, out, f"{tag}_{name}")
    sc.render.engine = "CYCLES"
    sc.cycles.shading_system = True
    return found


def studio_scene():
    """A new file's scene: four spheres (``CENTRES``) under the forest HDRI, each seeing the world only,
    an orthographic camera, Cycles with OSL at 64 samples and ``RES`` pixels: (scene, spheres)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.shading_system = True
    sc.cycles.samples = 64
    sc.cycles.seed = 0
    sc.cycles.use_denoising = False
    sc.cycles.use_adaptive_sampling = False
    sc.view_settings.view_transform = "Standard"
    # EEVEE on this machine's software OpenGL: every render after the first takes half a minute with
    # shadows on (lamella_dev.render.use_eevee); the spheres cast none on each other anyway
    sc.eevee.use_shadows = False
    sc.render.resolution_x = sc.render.resolution_y = RES
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    sc.collection.objects.link(cam)
    sc.camera = cam
    cam.data.type, cam.data.ortho_scale = "ORTHO", 4.4
    cam.location, cam.rotation_euler = (0.0, -10.0, 0.0), (1.5707963, 0.0, 0.0)
    world = bpy.data.worlds.new("world")
    sc.world = world
    if world.node_tree is None:
        world.use_nodes = True
    hdri = Path(bpy.utils.system_resource("DATAFILES", path="studiolights/world")) / "forest.exr"
    env = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(str(hdri))
    world.node_tree.links.new(env.outputs["Color"], world.node_tree.nodes["Background"].inputs["Color"])
    spheres = []
    for k, (x, z) in enumerate(CENTRES):
        bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=1.0, location=(x, 0.0, z))
        bpy.ops.object.shade_smooth()
        ob = bpy.context.object
        ob.visible_diffuse = ob.visible_glossy = ob.visible_transmission = ob.visible_shadow = False  # each sees the world only
        spheres.append(ob)
    return sc, spheres


def author(zip_path: Path, blend: Path) -> dict:
    bpy.ops.extensions.package_install_files(filepath=str(zip_path), repo="user_default", enable_on_install=True)
    ext = sys.modules["bl_ext.user_default.lamella"]
    import importlib

    recompile = importlib.import_module("bl_ext.user_default.lamella.addon.lamella.blender.recompile")
    sc, spheres = studio_scene()

    gold = {"layers": [{"ior": 1.5, "roughness": 0.01}],
            "base": {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603], "roughness": 0.05}}
    mats = [bpy.data.materials.new(n) for n in ("plain", "textured")]
    ext.apply_stack(mats[0], gold)
    ext.apply_stack(mats[1], {"layers": [{"ior": 1.5, "roughness": 0.1, "thickness": 1.0, "sigma_a": [0.1, 0.5, 1.0]}],
                              "base": {"type": "diffuse", "albedo": [0.8, 0.6, 0.3]}})
    nt = mats[1].node_tree
    noise = nt.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 3.0
    rng = nt.nodes.new("ShaderNodeMapRange")
    rng.inputs["To Min"].default_value, rng.inputs["To Max"].default_value = 0.2, 0.8
    nt.links.new(noise.outputs["Fac"], rng.inputs["Value"])
    nt.links.new(rng.outputs["Result"], ext.input_socket(mats[1], 0, "roughness"))
    base = mats[1].lamella.base.diffuse  # the panel's base colour, keyframed: warm on frame 1, cold on 3
    for frame, colour in ((1, (0.8, 0.6, 0.3)), (3, (0.2, 0.4, 0.8))):
        base.albedo = colour
        mats[1].keyframe_insert("lamella.base.diffuse.albedo", frame=frame)
    sc.frame_set(1)
    for sphere, mat in zip(spheres, mats):
        sphere.data.materials.append(mat)
    spheres[2].data.materials.append(mats[0])  # the copy-to-be shows the original for now
    control = bpy.data.materials.new("control")
    spheres[3].data.materials.append(control)
    ext.apply_stack(control, {**gold, "layers": [{"ior": 1.5, "roughness": 0.3, "thickness": 1.0,
                                                   "sigma_a": [0.0, 0.5, 1.0]}]})
    recompile.flush()
    out = blend.parent
    found = {"before_copy": render_all(sc, out, "before")}

    copy = mats[0].copy()
    copy.name = "copy"
    spheres[2].data.materials[0] = copy
    coat = copy.lamella.coats[0].coat  # the panel's edits: roughness in Blender's r, a tint
    coat.roughness, coat.thickness, coat.sigma_a = 0.3 ** 0.5, 1.0, (0.0, 0.5, 1.0)
    recompile.flush()
    found["status"] = {m.name: [m.lamella.status, m.lamella.status_message] for m in (*mats, copy, control)}
    found["author"] = render_all(sc, out, "author")
    sc.frame_set(3)
    found["author_frame3"] = render_all(sc, out, "author3")
    sc.frame_set(1)  # saved on frame 1: the farm renders frame 3 from the file's animation alone
    # the scene's own HDRI stays where Blender keeps it (absolute): only Lamella's data must travel
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), relative_remap=False)
    return found


def farm(blend: Path) -> dict:
    import addon_utils

    bpy.ops.wm.open_mainfile(filepath=str(blend), load_ui=False)
    enabled = [m.__name__ for m in addon_utils.modules() if addon_utils.check(m.__name__)[1]]
    sc = bpy.context.scene
    farm = render_all(sc, blend.parent, "farm")
    sc.frame_set(3)
    return {"farm": farm, "farm_frame3": render_all(sc, blend.parent, "farm3"),
            "lamella_enabled": [m for m in enabled if "lamella" in m],
            "missing_files": sorted(i.filepath for i in bpy.data.images
                                    if i.source == "FILE" and i.packed_file is None
                                    and not os.path.exists(bpy.path.abspath(i.filepath)))}


if __name__ == "__main__":
    mode = sys.argv[1]
    result = author(Path(sys.argv[2]), Path(sys.argv[3])) if mode == "author" else farm(Path(sys.argv[2]))
    print("FOUND " + json.dumps(result))
    sys.stdout.flush()
    os._exit(0)
