"""Run in a fresh process by test_extension_package: a stock-Blender session (only numpy and
Blender's own modules importable: the development install and the pip-only packages are
blocked) installs the built zip into the user repository, enables it, and uses it.

Usage: python extension_session.py ZIP OUT_DIR. Prints one JSON line of findings."""
import json
import sys
from pathlib import Path

# what a stock Blender does not have: the development copy and the test/bench dependencies
for name in ("lamella", "lamella_dev", "OpenEXR", "matplotlib", "colour", "flip_evaluator", "hypothesis", "scipy"):
    sys.modules[name] = None

import bpy  # noqa: E402

zip_path, out = Path(sys.argv[1]), Path(sys.argv[2])
found = {}
r = bpy.ops.extensions.package_install_files(filepath=str(zip_path), repo="user_default", enable_on_install=True)
found["install"] = sorted(r)
import addon_utils  # noqa: E402

module = "bl_ext.user_default.lamella"
found["enabled"] = module in {m.__name__ for m in addon_utils.modules() if addon_utils.check(m.__name__)[1]}
ext = sys.modules[module]
ext_dir = Path(ext.__file__).parent
before = {p for p in ext_dir.rglob("*") if "__pycache__" not in p.parts}

# the canonical sphere, a material from a preset and one from the batch API
bpy.ops.wm.read_homefile(use_empty=True)  # factory settings would disable the extension
sc = bpy.context.scene
sc.render.engine = "CYCLES"
sc.cycles.shading_system = True
sc.cycles.samples = 4
sc.render.resolution_x = sc.render.resolution_y = 32
bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16)
sphere = bpy.context.object
cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
sc.collection.objects.link(cam)
sc.camera = cam
cam.location = (0, -6, 0)
cam.rotation_euler = (1.5708, 0, 0)
world = bpy.data.worlds.new("w")
sc.world = world
if world.node_tree is None:  # Blender < 5.0 makes the tree here
    world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Color"].default_value = (1, 1, 1, 1)

bpy.ops.lamella.material_new(name="from_preset", preset="dusty_copper")
mat = bpy.data.materials.new("from_api")
ext.apply_stack(mat, {"layers": [{"ior": 1.5, "roughness": 0.05}],
                      "base": {"type": "conductor", "roughness": 0.1}})
found["read_stack"] = ext.read_stack(mat)
try:
    ext.apply_stack(mat, {"layers": [{"ior": -2}], "base": {"type": "conductor"}})
except ext.StackError as e:
    found["stack_error"] = str(e)
sphere.data.materials.clear()
sphere.data.materials.append(mat)
sc.render.image_settings.file_format = "OPEN_EXR"
sc.render.filepath = str(out / "render.exr")
bpy.ops.render.render(write_still=True)
img = bpy.data.images.load(str(out / "render.exr"))
px = [0.0] * (len(img.pixels))
img.pixels.foreach_get(px)
found["finite"] = all(x == x and abs(x) < 1e30 for x in px)
found["mean"] = sum(px[0::4]) / (len(px) // 4)
found["status"] = [bpy.data.materials[n].lamella.status for n in ("from_preset", "from_api")]
found["lobes"] = len(mat.lamella.lobes)
found["user_dir"] = bpy.utils.extension_path_user(module)
found["cache_files"] = len(list(Path(found["user_dir"]).rglob("*.oso")))
after = {p for p in ext_dir.rglob("*") if "__pycache__" not in p.parts}
found["written_into_extension"] = sorted(str(p.relative_to(ext_dir)) for p in after - before)
found["loaded_dev_copy"] = any(k.split(".")[0] in ("lamella", "lamella_dev") for k, v in sys.modules.items() if v)
print("FOUND " + json.dumps(found))
