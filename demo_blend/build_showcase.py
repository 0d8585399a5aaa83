"""Build the showcase scene with the Lamella extension and render it.

    python demo_blend/build_showcase.py [--out out] [--full]      (what `make demo` runs)

Every built-in preset on a sphere, in a grid, with a shader-ball-like object (a sphere on a
pedestal, ringed) wearing lacquered gold in front, under Blender's bundled forest HDRI. Saves
demo_blend/showcase.blend and renders it with Cycles (OSL on the CPU) to OUT/showcase.png: small
(480 x 270, 16 samples) by default, 1920 x 1080 at 128 samples with --full.
"""
import argparse
import math
import sys
import time
from pathlib import Path

import bpy

HERE = Path(__file__).resolve().parent


def material(name: str, preset: str):
    mat = bpy.data.materials.new(name)
    bpy.ops.lamella.preset_apply(material=mat.name, preset=preset)
    return mat


def add(kind: str, location, material=None, **kw):
    getattr(bpy.ops.mesh, f"primitive_{kind}_add")(location=location, **kw)
    ob = bpy.context.object
    bpy.ops.object.shade_smooth()
    if material is not None:
        ob.data.materials.append(material)
    return ob


def build(full: bool):
    from lamella.core import presets

    bpy.ops.wm.read_factory_settings(use_empty=True)
    import lamella.blender

    lamella.blender.register()
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.shading_system = True
    sc.cycles.samples = 128 if full else 16
    sc.cycles.use_denoising = False
    sc.render.resolution_x, sc.render.resolution_y = (1920, 1080) if full else (480, 270)
    world = bpy.data.worlds.new("forest")
    sc.world = world
    if world.node_tree is None:
        world.use_nodes = True
    env = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
    hdri = Path(bpy.utils.system_resource("DATAFILES", path="studiolights/world")) / "forest.exr"
    env.image = bpy.data.images.load(str(hdri))
    world.node_tree.links.new(env.outputs["Color"], world.node_tree.nodes["Background"].inputs["Color"])

    shown = presets.builtin()
    cols = 6
    for i, p in enumerate(shown):
        r, c = divmod(i, cols)
        x, y = (c - (cols - 1) / 2) * 2.3, 2.0 + r * 2.3
        add("uv_sphere", (x, y, 1.0), material(p.label, p.id), segments=64, ring_count=32)
    # the shader ball: a sphere on a pedestal with a ring, in front
    gold = bpy.data.materials["Lacquered Gold"]
    plastic = material("Pedestal", "coated_plastic")
    add("cylinder", (0.0, -2.5, 0.25), plastic, radius=1.1, depth=0.5, vertices=96)
    add("uv_sphere", (0.0, -2.5, 1.55), gold, radius=1.0, segments=96, ring_count=48)
    ring = add("torus", (0.0, -2.5, 1.55), material("Ring", "brushed_steel_clear_coat"), major_radius=1.25,
               minor_radius=0.08, major_segments=96)
    ring.rotation_euler = (math.radians(70), 0.0, math.radians(20))
    add("plane", (0.0, 3.0, 0.0), material("Floor", "varnished_wood"), size=400.0)

    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    sc.collection.objects.link(cam)
    sc.camera = cam
    cam.location = (0.0, -14.0, 7.5)
    cam.rotation_euler = (math.radians(66), 0.0, 0.0)
    cam.data.lens = 32
    bpy.ops.lamella.fix_render_settings()
    return sc


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out")
    ap.add_argument("--full", action="store_true", help="1920 x 1080, 128 samples")
    ap.add_argument("--no-render", action="store_true")
    ap.add_argument("--blend", default=str(HERE / "showcase.blend"), help="where to save the scene")
    a = ap.parse_args(argv)
    sc = build(a.full)
    blend = Path(a.blend).resolve()
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    print(f"wrote {blend}")
    if a.no_render:
        return 0
    out = Path(a.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    sc.render.image_settings.file_format = "PNG"
    sc.render.filepath = str(out / "showcase.png")
    t0 = time.time()
    bpy.ops.render.render(write_still=True)
    print(f"wrote {out / 'showcase.png'} ({time.time() - t0:.0f} s render)")
    return 0


if __name__ == "__main__":
    from lamella.blender import exit_process

    exit_process(main())
