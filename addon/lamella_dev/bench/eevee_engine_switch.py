"""`lamella bench eevee-engine-switch`: how one material can draw one thing in EEVEE and another in
Cycles without OSL (the anisotropic lobes' isotropic stand-ins in EEVEE, the anisotropic Glossy
BSDF in Cycles), measured by rendering tiny scenes in both engines.

Candidates, each a value that should read 1 in EEVEE and 0 in Cycles (drawn as an emission of that
value on the canonical sphere, black world, and read back at the centre of the image):

- every output of the Light Path node (the survey: what EEVEE gives for the "Cycles only" ones);
- ``1 - (Ray Length > 0)``: Cycles measures the camera ray's length (about 9 here), EEVEE has no
  rays;
- Shader to RGB of a white emission (an EEVEE-only node);
- the Material Output's target: an output for EEVEE and one for Cycles in one material (and which
  wins beside an output for all engines);
- a driver reading the scene's render engine (a simple expression, no Python).

Then the switches that work are put between real closures: a Mix Shader choosing the anisotropic
Glossy BSDF (Cycles) or three isotropic Glossy BSDFs about normals tilted along the anisotropy's
long axis (EEVEE; ``lamella.core.lobe_kinds.isotropic_fit``), on the sphere in the forest HDRI:
each engine's render against the branch it should draw rendered alone (a switch that costs nothing
and changes nothing gives 0 up to noise), and the render times.

``--also PYTHON``: also run the probe in another Python with bpy (the 4.2 wheel) and add its
column."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

from .page import write_page
from .paths import BENCH_DIR
from .registry import Bench, register

RES = 32
SPP = 8
SWITCH_RES = 64
SWITCH_SPP = 16
ENGINES = ("eevee", "cycles-svm", "cycles-osl")
ANISO = (0.4, 0.1)  # alpha along the tangent, across it: a brushed metal
METAL = (0.9, 0.6, 0.3)


# ---------------------------------------------------------------- scenes (bpy)
def _scene(engine: str, scene: str, res: int, spp: int):
    from ..render import build_scene, use_eevee

    sc, sphere = build_scene(scene, res, spp)
    if engine == "eevee":
        use_eevee(sc)
    else:
        sc.cycles.shading_system = engine == "cycles-osl"
    return sc, sphere


def _render(sc):
    from ..render import render_scene

    return render_scene(sc)


def _centre(px: np.ndarray) -> list:
    n = px.shape[0]
    c = px[n // 2 - 2:n // 2 + 2, n // 2 - 2:n // 2 + 2, :3]
    return [float(v) for v in c.reshape(-1, 3).mean(0)]


def _emission(nt, rgb=None, strength=1.0):
    e = nt.nodes.new("ShaderNodeEmission")
    if rgb is not None:
        e.inputs["Color"].default_value = (*rgb, 1.0)
    e.inputs["Strength"].default_value = strength
    return e


def _value_material(sphere, build):
    """A material emitting, as its colour, the value ``build(nt)`` returns (an output socket)."""
    from ..render import sphere_material

    mat, nt, out = sphere_material(sphere, "probe")
    e = _emission(nt, (0.0, 0.0, 0.0))  # a link an engine drops leaves this black default
    nt.links.new(build(nt), e.inputs["Color"])
    nt.links.new(e.outputs[0], out.inputs["Surface"])
    return mat


def _light_path(output):
    def build(nt):
        return nt.nodes.new("ShaderNodeLightPath").outputs[output]
    return build


def _ray_length_switch(nt):
    lp = nt.nodes.new("ShaderNodeLightPath")
    gt = nt.nodes.new("ShaderNodeMath")
    gt.operation = "GREATER_THAN"
    gt.inputs[1].default_value = 0.0
    nt.links.new(lp.outputs["Ray Length"], gt.inputs[0])
    inv = nt.nodes.new("ShaderNodeMath")
    inv.operation = "SUBTRACT"
    inv.inputs[0].default_value = 1.0
    nt.links.new(gt.outputs[0], inv.inputs[1])
    return inv.outputs[0]


def _shader_to_rgb_switch(nt):
    e = _emission(nt, (1.0, 1.0, 1.0))
    s2r = nt.nodes.new("ShaderNodeShaderToRGB")
    nt.links.new(e.outputs[0], s2r.inputs[0])
    return s2r.outputs["Color"]


def _driver_switch(nt):
    """A Value node whose value a driver sets from the scene's render engine (the enum's index)."""
    import bpy

    v = nt.nodes.new("ShaderNodeValue")
    fc = v.outputs[0].driver_add("default_value")
    d = fc.driver
    d.type = "SCRIPTED"
    var = d.variables.new()
    var.name = "engine"
    var.type = "SINGLE_PROP"
    var.targets[0].id_type = "SCENE"
    var.targets[0].id = bpy.context.scene
    var.targets[0].data_path = "render.engine"
    d.expression = "engine"
    return v.outputs[0]


def _target_material(sphere, outputs: dict):
    """A material with one Material Output per target in ``outputs`` (target -> emitted RGB)."""
    from ..render import sphere_material

    mat, nt, first = sphere_material(sphere, "probe")
    nt.nodes.remove(first)
    for target, rgb in outputs.items():
        out = nt.nodes.new("ShaderNodeOutputMaterial")
        out.target = target
        out.is_active_output = True
        nt.links.new(_emission(nt, rgb).outputs[0], out.inputs["Surface"])
    return mat


def _probe(engine: str) -> dict:
    """Every candidate's value at the sphere's centre in ``engine`` (RGB means; the value in R)."""
    import bpy

    out = {}
    sc, sphere = _scene(engine, "sphere-sun", RES, SPP)
    lp_outputs = [s.name for s in bpy.data.node_groups.new("probe", "ShaderNodeTree").nodes.new(
        "ShaderNodeLightPath").outputs]
    for name in lp_outputs:
        _value_material(sphere, _light_path(name))
        out[f"Light Path: {name}"] = _centre(_render(sc)[0])[0]
    for label, build in (("1 - (Ray Length > 0)", _ray_length_switch),
                         ("Shader to RGB of a white emission", _shader_to_rgb_switch),
                         ("driver on scene.render.engine (enum index)", _driver_switch)):
        _value_material(sphere, build)
        out[label] = _centre(_render(sc)[0])[0]
    red, green, blue = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
    for label, outputs in (("outputs EEVEE (red) + Cycles (green)", {"EEVEE": red, "CYCLES": green}),
                           ("outputs All (blue) + EEVEE (red) + Cycles (green)",
                            {"ALL": blue, "EEVEE": red, "CYCLES": green}),
                           ("outputs All (blue) + EEVEE (red)", {"ALL": blue, "EEVEE": red}),
                           ("outputs All (blue) + Cycles (green)", {"ALL": blue, "CYCLES": green})):
        _target_material(sphere, outputs)
        rgb = _centre(_render(sc)[0])
        out[label] = "/".join(n for n, c in zip(("red", "green", "blue"), rgb) if c > 0.5) or "black"
    out["engine"] = sc.render.engine
    return out


# ---------------------------------------------------------------- the switch between real closures
def _aniso_branch(nt, tangent):
    from lamella.core.lobe_kinds.bsdf_node import blender_anisotropy
    from lamella.core.backends.numpy_ops import NumpyOps

    r, a = blender_anisotropy(NumpyOps(np.float64), np.float64(ANISO[0]), np.float64(ANISO[1]))
    g = nt.nodes.new("ShaderNodeBsdfAnisotropic")
    g.distribution = "GGX"
    g.inputs["Roughness"].default_value = float(r)
    g.inputs["Anisotropy"].default_value = float(a)
    g.inputs["Color"].default_value = (*METAL, 1.0)
    nt.links.new(tangent, g.inputs["Tangent"])
    return g.outputs[0]


def _stand_in_branch(nt, tangent, k: int = 3):
    """K Glossy BSDFs about normals tilted along the tangent (the long axis), the stand-ins of the
    anisotropic lobe at normal incidence (``isotropic_fit.fit``), added up."""
    from lamella.core.lobe_kinds import isotropic_fit

    st = isotropic_fit.fit(np.array([ANISO[0]]), np.array([ANISO[1]]), np.array([[0.0, 0.0, 1.0]]), k=k)
    geo = nt.nodes.new("ShaderNodeNewGeometry")
    shader = None
    for alpha, tilt, scale in zip(st.alpha[0], st.tilt[0], st.scale[0]):
        n_scaled = nt.nodes.new("ShaderNodeVectorMath")
        n_scaled.operation = "SCALE"
        nt.links.new(geo.outputs["Normal"], n_scaled.inputs[0])
        n_scaled.inputs["Scale"].default_value = math.cos(tilt)
        t_scaled = nt.nodes.new("ShaderNodeVectorMath")
        t_scaled.operation = "SCALE"
        nt.links.new(tangent, t_scaled.inputs[0])
        t_scaled.inputs["Scale"].default_value = math.sin(tilt)
        add = nt.nodes.new("ShaderNodeVectorMath")
        add.operation = "ADD"
        nt.links.new(n_scaled.outputs[0], add.inputs[0])
        nt.links.new(t_scaled.outputs[0], add.inputs[1])
        norm = nt.nodes.new("ShaderNodeVectorMath")
        norm.operation = "NORMALIZE"
        nt.links.new(add.outputs[0], norm.inputs[0])
        g = nt.nodes.new("ShaderNodeBsdfAnisotropic")
        g.distribution = "GGX"
        g.inputs["Roughness"].default_value = math.sqrt(alpha)
        g.inputs["Anisotropy"].default_value = 0.0
        g.inputs["Color"].default_value = (*(c * scale for c in METAL), 1.0)
        nt.links.new(norm.outputs[0], g.inputs["Normal"])
        if shader is None:
            shader = g.outputs[0]
        else:
            s = nt.nodes.new("ShaderNodeAddShader")
            nt.links.new(shader, s.inputs[0])
            nt.links.new(g.outputs[0], s.inputs[1])
            shader = s.outputs[0]
    return shader


def _closure_material(sphere, how: str):
    """``how``: "aniso" / "stand-ins" (one branch alone), "switch:ray-length",
    "switch:shader-to-rgb" (a Mix Shader, Fac = the switch: 0 the anisotropic branch, 1 the
    stand-ins), "targets" (the stand-ins into an EEVEE output, the anisotropic BSDF into a Cycles
    one)."""
    from ..render import sphere_material

    mat, nt, out = sphere_material(sphere, how)
    tan = nt.nodes.new("ShaderNodeTangent")
    tan.direction_type = "RADIAL"
    tan.axis = "Z"
    tangent = tan.outputs[0]
    if how == "aniso":
        nt.links.new(_aniso_branch(nt, tangent), out.inputs["Surface"])
    elif how == "stand-ins":
        nt.links.new(_stand_in_branch(nt, tangent), out.inputs["Surface"])
    elif how.startswith("switch:"):
        fac = {"ray-length": _ray_length_switch, "shader-to-rgb": _shader_to_rgb_switch}[how.split(":")[1]](nt)
        mix = nt.nodes.new("ShaderNodeMixShader")
        mix.inputs["Fac"].default_value = 0.0
        nt.links.new(fac, mix.inputs["Fac"])
        nt.links.new(_aniso_branch(nt, tangent), mix.inputs[1])
        nt.links.new(_stand_in_branch(nt, tangent), mix.inputs[2])
        nt.links.new(mix.outputs[0], out.inputs["Surface"])
    elif how == "targets":
        out.target = "CYCLES"
        nt.links.new(_aniso_branch(nt, tangent), out.inputs["Surface"])
        ev = nt.nodes.new("ShaderNodeOutputMaterial")
        ev.target = "EEVEE"
        ev.is_active_output = True
        out.is_active_output = True
        nt.links.new(_stand_in_branch(nt, tangent), ev.inputs["Surface"])
    else:
        raise ValueError(how)
    return mat


def _rel_l1(a, b):
    m = b[..., 3] > 0.5
    return float(np.abs(a[..., :3][m] - b[..., :3][m]).sum() / max(np.abs(b[..., :3][m]).sum(), 1e-12))


def _glowing_box():
    """An emitting box beside the sphere, in view: what EEVEE's ray tracing reflects from the screen."""
    import bpy
    from ..render import node_tree

    bpy.ops.mesh.primitive_cube_add(size=0.6, location=(-0.9, -1.2, 0.6))
    box = bpy.context.object
    mat = bpy.data.materials.new("glow")
    nt = node_tree(mat)
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(_emission(nt, (1.0, 1.0, 1.0), 8.0).outputs[0], out.inputs["Surface"])
    box.data.materials.append(mat)


def _closures(engine: str, raytraced: bool = False) -> dict:
    """Each switch's render in ``engine`` against the branch the engine should draw rendered
    alone, and the render times (EEVEE's include compiling the material's shaders).
    ``raytraced``: EEVEE's ray tracing on and a glowing box in view (screen-space reflections)."""
    sc, sphere = _scene(engine, "sphere-env", SWITCH_RES, SWITCH_SPP)
    sc.render.film_transparent = True
    if raytraced:
        sc.eevee.use_raytracing = True
        _glowing_box()
    renders, seconds = {}, {}
    for how in ("aniso", "stand-ins", "switch:ray-length", "switch:shader-to-rgb", "targets"):
        _closure_material(sphere, how)
        renders[how], seconds[how] = _render(sc)
    own = "stand-ins" if engine == "eevee" else "aniso"
    out = {"seconds": seconds, "branch": own}
    for how in ("switch:ray-length", "switch:shader-to-rgb", "targets"):
        out[how] = _rel_l1(renders[how], renders[own])
    out["stand-ins vs aniso (same engine)"] = _rel_l1(renders["stand-ins"], renders["aniso"])
    return out, renders


def measure() -> dict:
    import bpy

    result = {"blender": bpy.app.version_string, "probe": {}, "closures": {}}
    images = {}
    for engine in ENGINES:
        result["probe"][engine] = _probe(engine)
        result["closures"][engine], images[engine] = _closures(engine)
    result["closures"]["eevee, ray tracing, glowing box"], _ = _closures("eevee", raytraced=True)
    # EEVEE's stand-ins and EEVEE's round lobe against Cycles' anisotropic lobe
    cyc = images["cycles-svm"]["aniso"]
    result["eevee vs cycles"] = {"EEVEE, the anisotropic node (drawn round)": _rel_l1(images["eevee"]["aniso"], cyc),
                                 "EEVEE, K = 3 stand-ins": _rel_l1(images["eevee"]["stand-ins"], cyc),
                                 "Cycles, K = 3 stand-ins": _rel_l1(images["cycles-svm"]["stand-ins"], cyc)}
    return result


# ---------------------------------------------------------------- the page
def _fmt(v):
    return f"{v:.3g}" if isinstance(v, float) else str(v)


def _page(results: list[dict]) -> str:
    lines = ["# One material, two engines: EEVEE's stand-ins, Cycles' anisotropic lobe", "",
             "`lamella bench eevee-engine-switch` (" + ", ".join(f"Blender {r['blender']}" for r in results) + "). "
             "Each candidate renders its value as an emission on the sphere (black world, "
             f"{RES} px, {SPP} samples; the value read at the centre). A switch for the stand-ins reads 1 in EEVEE "
             "and 0 in Cycles.", ""]
    for r in results:
        probe = r["probe"]
        keys = list(probe[ENGINES[0]])
        lines += [f"## Blender {r['blender']}: the candidates", "",
                  "| candidate | " + " | ".join(ENGINES) + " |", "|---|" + "---|" * len(ENGINES)]
        for k in keys:
            lines.append(f"| {k} | " + " | ".join(_fmt(probe[e].get(k)) for e in ENGINES) + " |")
        lines += ["", f"## Blender {r['blender']}: the switch between real closures", "",
                  "A Mix Shader (Fac = the switch) choosing the anisotropic Glossy BSDF (alpha "
                  f"{ANISO[0]} x {ANISO[1]}, radial tangent) or its K = 3 stand-ins, and the two Material Outputs; "
                  "relative L1 over the sphere against the branch the engine should draw rendered alone "
                  f"(sphere-env, {SWITCH_RES} px, {SWITCH_SPP} samples; Cycles' noise floor is the two renders' "
                  "own noise). Render seconds beside.", "",
                  "| engine | branch | Mix on Ray Length | Mix on Shader to RGB | two outputs | "
                  "seconds: branch alone / Ray Length / Shader to RGB / outputs |", "|---|---|---:|---:|---:|---|"]
        for e in r["closures"]:
            c = r["closures"][e]
            s = c["seconds"]
            lines.append(f"| {e} | {c['branch']} | {c['switch:ray-length']:.4f} | {c['switch:shader-to-rgb']:.4f} | "
                         f"{c['targets']:.4f} | {s[c['branch']]:.2f} / {s['switch:ray-length']:.2f} / "
                         f"{s['switch:shader-to-rgb']:.2f} / {s['targets']:.2f} |")
        lines += ["", "Against Cycles (SVM) drawing the anisotropic lobe (relative L1 over the sphere):", ""]
        lines += [f"- {k}: {v:.3f}" for k, v in r["eevee vs cycles"].items()]
        lines.append("")
    return "\n".join(lines)


def run(out_dir: Path = BENCH_DIR, also=()) -> Path:
    results = [measure()]
    for python in also or ():
        code = ("import json, sys; from lamella_dev.bench import eevee_engine_switch as m; "
                "sys.stdout.write('@@' + json.dumps(m.measure()))")
        env = {**__import__("os").environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
        p = subprocess.run([python, "-c", code], capture_output=True, text=True, env=env, timeout=3600)
        if p.returncode != 0 or "@@" not in p.stdout:
            sys.stderr.write(p.stderr[-2000:])
            raise RuntimeError(f"the probe failed in {python}")
        results.append(json.loads(p.stdout.rsplit("@@", 1)[1]))
    return write_page(out_dir, "eevee_engine_switch", lambda: _page(results), results)


def _arguments(parser):
    from ..arguments import program

    parser.add_argument("--also", type=program("a Python with bpy"), action="append", default=[],
                        help="another Python with bpy (e.g. the 4.2 wheel's) to run the probe in too")


BENCH = register(Bench("eevee-engine-switch", "one material drawing EEVEE's stand-ins and Cycles' anisotropic lobe: "
                       "the candidate switches rendered in both engines", lambda out_dir, args: run(out_dir, args.also),
                       _arguments))
