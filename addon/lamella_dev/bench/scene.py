"""`lamella bench scene`: a production-sized scene, Lamella against the Principled BSDF.

COUNT objects (real meshes: Suzanne subdivided once, a torus, a UV sphere, a cube with bevels,
in turn) in a grid before the forest HDRI, each with its own material drawn from the presets with
random value edits (roughness, index, colour: a seeded generator). The same scene is made twice
in one session: with Lamella materials through the extension's batch API, and with the
Principled stand-ins of the same stacks (``render._principled``). Measured:

- apply: seconds per material of ``apply_stack`` (the compile and the node group);
- edit: seconds per material of a value edit in the panel and the flush that compiles it;
- add a layer: seconds per material of the layer operator (a structure edit);
- .blend size: the saved file's bytes per material over the same scene without materials
  (Lamella, Principled);
- first frame: the first render of the scene (what a renderer does once per material, OSL's JIT,
  EEVEE's shader compiles, included) in Cycles with OSL, Cycles without OSL and EEVEE, Lamella over
  Principled in the same engine.

Targets (the issue that asked for this page): first frame within 1.5x Principled's, under 30 kB
per untextured material in the .blend.
"""
from __future__ import annotations

import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from ..arguments import count
from .paths import BENCH_DIR
from .page import write_page
from .registry import Bench, register

COUNT = 200
RES, SPP = 160, 16
ENGINES = (("Cycles with OSL", "CYCLES", True), ("Cycles without OSL", "CYCLES", False), ("EEVEE", "BLENDER_EEVEE", False))


def _stacks(count: int, seed: int = 7) -> list:
    from lamella.core import presets
    from lamella.core.stack import Stack

    rng = np.random.default_rng(seed)
    base = [p.load().to_dict() for p in presets.builtin()]
    out = []
    for k in range(count):
        d = json.loads(json.dumps(base[k % len(base)]))
        d["name"] = f"{d.get('name') or 'preset'}_{k}"
        for layer in d["layers"]:
            r = layer.get("roughness", 0.0)
            layer["roughness"] = float(np.clip((r[0] if isinstance(r, list) else r) * rng.uniform(0.5, 2.0) + 0.01, 0, 1))
            layer["ior"] = float(np.clip(layer.get("ior", 1.5) + rng.uniform(-0.1, 0.1), 1.0, 3.0))
        if d["base"].get("type") == "diffuse":
            d["base"]["albedo"] = [float(x) for x in rng.uniform(0.1, 0.9, 3)]
        out.append(Stack.from_dict(d))
    return out


def _scene(count: int):
    """The grid of meshes, camera and world (factory settings first); returns (scene, objects)."""
    import bpy

    from ..render import build_scene

    sc, sphere = build_scene("sphere-env", RES, SPP)
    bpy.data.objects.remove(sphere)
    side = int(np.ceil(np.sqrt(count)))
    makers = (lambda: bpy.ops.mesh.primitive_monkey_add(size=0.8), lambda: bpy.ops.mesh.primitive_torus_add(
        major_radius=0.35, minor_radius=0.12), lambda: bpy.ops.mesh.primitive_uv_sphere_add(radius=0.4),
        lambda: bpy.ops.mesh.primitive_cube_add(size=0.6))
    objects = []
    for k in range(count):
        makers[k % len(makers)]()
        ob = bpy.context.object
        ob.location = ((k % side - side / 2 + 0.5), 0.0, (k // side - side / 2 + 0.5))
        ob.rotation_euler = (0.3, 0.5, 0.2 * k)
        if k % len(makers) == 0:
            mod = ob.modifiers.new("subdivision", "SUBSURF")
            mod.levels = mod.render_levels = 1
        bpy.ops.object.shade_smooth()
        objects.append(ob)
    cam = sc.camera
    cam.data.ortho_scale = side * 1.05
    return sc, objects


def _first_frame(sc) -> dict:
    from ..render import render_scene

    out = {}
    for label, engine, osl in ENGINES:
        sc.render.engine = engine
        if engine == "CYCLES":
            sc.cycles.shading_system = osl
        else:
            sc.eevee.use_shadows = False
        _, out[label] = render_scene(sc)
    sc.render.engine, sc.cycles.shading_system = "CYCLES", True
    return out


def _saved_size(folder: Path, name: str) -> np.ndarray:
    """Bytes of the open file saved as Blender saves by default (uncompressed) and compressed
    (Preferences > Save & Load > Compress File)."""
    import bpy

    sizes = []
    for compress in (False, True):
        path = folder / f"{name}_{int(compress)}.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True, compress=compress)
        sizes.append(path.stat().st_size)
    return np.array(sizes, dtype=float)


def measure(count: int = COUNT, progress=print) -> dict:
    # a first frame compiles every shader: Mesa's on-disk shader cache (software OpenGL here) would
    # make EEVEE's depend on what earlier runs compiled, so it is off (read when EEVEE first makes a
    # GPU context, after this)
    os.environ["MESA_SHADER_CACHE_DISABLE"] = "true"
    import bpy

    from lamella.blender import api, recompile
    from ..render import _principled

    import lamella.blender

    if not hasattr(bpy.types.Material, "lamella"):
        lamella.blender.register()
    stacks = _stacks(count)
    data = {"count": count, "res": RES, "spp": SPP}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        # Principled first: its scene, its file and its first frames
        sc, objects = _scene(count)
        empty = _saved_size(folder, "empty")
        for ob, stack in zip(objects, stacks):
            mat = bpy.data.materials.new(f"principled {stack.name}")
            nt = mat.node_tree
            nt.nodes.clear()
            out = nt.nodes.new("ShaderNodeOutputMaterial")
            nt.links.new(_principled(nt, stack).outputs["BSDF"], out.inputs["Surface"])
            ob.data.materials.append(mat)
        data["principled_bytes"] = ((_saved_size(folder, "principled") - empty) / count).tolist()
        progress(f"Principled: {data['principled_bytes'][0] / 1e3:.1f} kB a material; rendering")
        data["principled_first_frame"] = _first_frame(sc)
        progress(f"Principled first frames: {data['principled_first_frame']}")

        sc, objects = _scene(count)
        mats = []
        t0 = time.perf_counter()
        for k, (ob, stack) in enumerate(zip(objects, stacks)):
            mat = bpy.data.materials.new(f"lamella {stack.name}")
            api.apply_stack(mat, stack)
            ob.data.materials.append(mat)
            mats.append(mat)
            if k % 50 == 49:
                progress(f"applied {k + 1} of {count}")
        data["apply_s"] = (time.perf_counter() - t0) / count
        data["lamella_bytes"] = ((_saved_size(folder, "lamella") - empty) / count).tolist()
        progress(f"Lamella: apply {data['apply_s'] * 1e3:.0f} ms, {data['lamella_bytes'][0] / 1e3:.1f} kB a material")
        data["lamella_first_frame"] = _first_frame(sc)
        progress(f"Lamella first frames: {data['lamella_first_frame']}")
        t0 = time.perf_counter()
        for mat in mats:
            coat = mat.lamella.coats[0] if mat.lamella.coats else None
            if coat is not None:
                coat.settings().ior = coat.settings().ior + 0.01
            else:
                mat.lamella.stack_name = mat.lamella.stack_name + "'"
            recompile.flush()
        data["edit_s"] = (time.perf_counter() - t0) / count
        t0 = time.perf_counter()
        for mat in mats:
            mat.lamella.active_index = 0
            bpy.ops.lamella.layer_add(material=mat.name, template="clear_coat")
        recompile.flush_groups()
        data["add_layer_s"] = (time.perf_counter() - t0) / count
        progress(f"edit {data['edit_s'] * 1e3:.0f} ms, add a layer {data['add_layer_s'] * 1e3:.0f} ms a material")
    data["x_principled"] = {k: data["lamella_first_frame"][k] / data["principled_first_frame"][k]
                            for k in data["lamella_first_frame"]}
    return data


def run(out_dir: Path = BENCH_DIR, count: int = COUNT, progress=print) -> Path:
    data = measure(count, progress)
    return write_page(out_dir, "scene", lambda: format_markdown(data), data)


def format_markdown(d: dict) -> str:
    lines = [
        "# A production-sized scene: Lamella against the Principled BSDF",
        "",
        "Generated by `lamella bench scene` (`lamella_dev/bench/scene.py`): "
        f"{d['count']} objects (Suzanne subdivided, torus, sphere, cube) in a grid, each with its own material "
        "drawn from the presets with random value edits; the same scene with the Principled stand-ins of the "
        f"same stacks. First frames at {d['res']} px, {d['spp']} spp (EEVEE without shadows), the whole render "
        "call, shader compiles included (with Mesa's on-disk shader cache off, as on a fresh render node).",
        "",
        "| engine | Principled s | Lamella s | x Principled |",
        "|---|---:|---:|---:|",
    ]
    for k, ratio in d["x_principled"].items():
        lines.append(f"| {k} | {d['principled_first_frame'][k]:.1f} | {d['lamella_first_frame'][k]:.1f} | "
                     f"{ratio:.2f} |")
    lines += [
        "",
        "| per material | Lamella | Principled |",
        "|---|---:|---:|",
        f"| .blend size (saved as Blender saves by default) | {d['lamella_bytes'][0] / 1e3:.1f} kB | "
        f"{d['principled_bytes'][0] / 1e3:.1f} kB |",
        f"| .blend size (compressed) | {d['lamella_bytes'][1] / 1e3:.1f} kB | {d['principled_bytes'][1] / 1e3:.1f} kB |",
        f"| apply (`apply_stack`) | {d['apply_s'] * 1e3:.0f} ms | |",
        f"| a value edit and its compile | {d['edit_s'] * 1e3:.0f} ms | |",
        f"| a layer added (operator) | {d['add_layer_s'] * 1e3:.0f} ms | |",
        "",
        "Targets: first frame within 1.5x Principled's in each engine; under 30 kB per untextured material.",
    ]
    return "\n".join(lines) + "\n"


def _arguments(parser) -> None:
    parser.add_argument("--count", type=count(), default=COUNT,
                        help=f"how many objects and materials (default {COUNT})")


BENCH = register(Bench("scene",
                       "a production-sized scene against the Principled BSDF: apply, edit, file size, first frames",
                       lambda out_dir, args: run(out_dir, count=args.count), _arguments))
