"""`lamella bench layer-normals`: a normal per layer against the nested spheres that give each
shell its own normal.

The Lamella node lets each coat and the base take a normal of its own (a bump on a clear coat over
a smooth metal, flakes under a smooth coat). The shaders read it this way (``Lobe.normal``): the
model's energies are the stack's at the view about the shading normal, and each lobe's closure is
about the normal of the layer it leaves, as the Principled BSDF reads its Coat Normal. What this
leaves out: the refraction of the light going down to a layer and back up through a tilted layer
above it (a bumped coat bends the base's reflection like a prism), and the energies' change with
the local tilt.

The ground truth: the stack as nested spheres (``reference_scene``), each shell with the same bump
in its own shading normal, path traced. For each case the table gives the image error (mean
CIEDE2000 over the sphere, RMSE, FLIP: ``image_metrics``) of the Lamella node (Cycles with OSL)
with the bump in that layer's Normal input, of the same with the bump in the node's one Normal
(every layer bumped: what a single normal input can do), and of the stack without any bump; the
references are rendered with the bump where the case puts it.

The BRDF itself: under one sun and a black world (``sphere-sun``) every pixel of the sphere is one
pair of directions (the sun, the camera) in its shading frame and shows f(wi, wo) cos(theta_i)
times the sun's irradiance, light that reaches it directly (the sphere never sees itself). Dividing
by cos(theta_i) gives the BRDF at that pair; the second table bins the pixels by the angle of the
half vector from the shading normal and gives the relative L1 of f per bin, for a constant tilt
(a Normal Map of one colour: every point's layer normal turned by ``TILT_DEGREES`` along the
UV tangent) and for the bump.
"""
from __future__ import annotations

from pathlib import Path

from lamella.core import Stack
from ..image_metrics import image_errors
from .paths import BENCH_DIR
from .page import write_page
from .registry import Bench, register

RES, SPP, REFERENCE_SPP = 96, 256, 2048
GOLD = {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603], "roughness": 0.15}
CLEAR = {"ior": 1.5, "roughness": 0.05}
# (label, stack, the layer bumped)
CASES = (("a bumped clear coat over smooth gold", {"layers": [CLEAR], "base": GOLD}, "coat0"),
         ("a smooth clear coat over bumped gold", {"layers": [CLEAR], "base": GOLD}, "base"),
         ("a bumped varnish over wood", {"layers": [{"ior": 1.5, "roughness": 0.0025, "thickness": 0.5,
                                                     "sigma_a": [0.1, 0.3, 0.6]}],
                                         "base": {"type": "diffuse", "albedo": [0.42, 0.24, 0.11]}}, "coat0"))
BUMP_SCALE, BUMP_STRENGTH, BUMP_DISTANCE = 1.5, 1.0, 0.3  # slow, broad tilts: a pixel compares with a pixel
TILT_DEGREES = 12.0
SUN_DIR = (0.35, -0.75, 0.56)  # the sun of the BRDF table (normalised where used)
# the BRDF table's cases: (label, stack, the layer given a normal, which normal)
SUN_CASES = (("a tilted clear coat over smooth gold", CASES[0][1], "coat0", "tilt"),
             ("a smooth clear coat over tilted gold", CASES[1][1], "base", "tilt"),
             ("a bumped clear coat over smooth gold", CASES[0][1], "coat0", "bump"))
THETA_H_BINS = ((0.0, 5.0), (5.0, 15.0), (15.0, 30.0), (30.0, 90.0))  # degrees from the shading normal
LIT_COS = 0.05  # pixels whose shading normal makes a smaller cosine with the sun are left out


def bump(nt):
    """A noise bump in object space (the same on every shell, each a scaled copy of the sphere):
    the normal socket."""
    coords = nt.nodes.new("ShaderNodeTexCoord")
    noise = nt.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = BUMP_SCALE
    node = nt.nodes.new("ShaderNodeBump")
    node.inputs["Strength"].default_value = BUMP_STRENGTH
    node.inputs["Distance"].default_value = BUMP_DISTANCE
    nt.links.new(coords.outputs["Object"], noise.inputs["Vector"])
    nt.links.new(noise.outputs["Fac"], node.inputs["Height"])
    return node.outputs["Normal"]


def tilt(nt):
    """A constant tilt in tangent space: the normal turned by ``TILT_DEGREES`` toward the UV
    tangent at every point (a Normal Map of one colour; each shell is a scaled copy of the sphere,
    so every shell turns alike): the normal socket."""
    import math

    t = math.radians(TILT_DEGREES)
    node = nt.nodes.new("ShaderNodeNormalMap")
    node.space = "TANGENT"
    node.inputs["Color"].default_value = (0.5 * (math.sin(t) + 1.0), 0.5, 0.5 * (math.cos(t) + 1.0), 1.0)
    return node.outputs["Normal"]


NORMALS = {"bump": bump, "tilt": tilt}


def _scene(scene: str, spp: int):
    from ..render import build_scene

    return build_scene(scene, RES, spp, SUN_DIR)


def _reference(stack, layer, normal="bump", scene="sphere-env"):
    from ..reference_scene import build_reference
    from ..render import render_scene

    sc, sphere = _scene(scene, REFERENCE_SPP)
    build_reference(sc, sphere, Stack.coerce(stack), normals={layer: NORMALS[normal]})
    return render_scene(sc)[0]


def _lamella(stack, where, normal="bump", scene="sphere-env"):
    """The Lamella node (Cycles with OSL) with ``normal`` in ``where``: a layer's prefix, "all"
    (the node's one Normal input) or None."""
    from lamella.blender import api, material_nodes

    from ..render import assign_material, node_tree, render_scene

    sc, sphere = _scene(scene, SPP)
    mat = assign_material(sphere, Stack.coerce(stack), "lamella-osl")
    if where is not None:
        nt = node_tree(mat)
        if where == "all":
            target = material_nodes.face_node(mat).inputs["Normal"]
        else:
            target = api.input_socket(mat, "base" if where == "base" else int(where[4:]), "normal")
        nt.links.new(NORMALS[normal](nt), target)
    return render_scene(sc)[0]


def _pixel_frame(res: int = RES):
    """Per pixel of the canonical orthographic view (top row first): the cosine of the sphere's
    normal with the sun, the half vector's angle from the normal (degrees) and the sphere mask."""
    import numpy as np

    from .image_references import sphere_normals

    s = np.asarray(SUN_DIR, float)
    s /= np.linalg.norm(s)
    n, on = sphere_normals(res)
    h = s + np.array([0.0, -1.0, 0.0])  # the camera looks along +y
    h /= np.linalg.norm(h)
    theta_h = np.degrees(np.arccos(np.clip(n @ h, -1.0, 1.0)))
    return n @ s, theta_h, on


def binned_brdf(img, ref) -> dict:
    """Relative L1 of the BRDF (radiance / cos theta_i) per bin of the half vector's angle from
    the shading normal, over the lit sphere pixels; and over all of them."""
    import numpy as np

    cos_i, theta_h, on = _pixel_frame(ref.shape[0])
    lit = on & (cos_i > LIT_COS)
    fa = img[..., :3].mean(-1) / np.maximum(cos_i, LIT_COS)
    fb = ref[..., :3].mean(-1) / np.maximum(cos_i, LIT_COS)
    out = {}
    for lo, hi in (*THETA_H_BINS, (0.0, 90.0)):
        m = lit & (theta_h >= lo) & (theta_h < hi)
        out[f"{lo:g}-{hi:g}"] = float(np.abs(fa - fb)[m].sum() / fb[m].sum()) if fb[m].sum() > 0 else None
    return out


def sun_rows(progress=print) -> list[dict]:
    import bpy  # noqa: F401

    out = []
    for label, stack, layer, normal in SUN_CASES:
        ref = _reference(stack, layer, normal, "sphere-sun")
        row = {"case": label, "layer": layer, "normal": normal}
        for key, where in (("own", layer), ("one", "all"), ("flat", None)):
            row[key] = binned_brdf(_lamella(stack, where, normal, "sphere-sun"), ref)
        out.append(row)
        progress(f"{label} (sun): relative L1 of f own normal {row['own']['0-90']:.3f}, one normal "
                 f"{row['one']['0-90']:.3f}, flat {row['flat']['0-90']:.3f}")
    return out


def rows(progress=print) -> list[dict]:
    import bpy  # noqa: F401

    out = []
    for label, stack, layer in CASES:
        ref = _reference(stack, layer)
        mask = ref[..., 3] > 0.999
        row = {"case": label, "layer": layer}
        for key, where in (("own", layer), ("one", "all"), ("flat", None)):
            row[key] = image_errors(_lamella(stack, where)[..., :3], ref[..., :3], mask)
        out.append(row)
        progress(f"{label}: dE00 own normal {row['own']['delta_e00']:.2f}, one normal {row['one']['delta_e00']:.2f}, "
                 f"flat {row['flat']['delta_e00']:.2f}")
    return out


def format_markdown(data) -> str:
    lines = ["# A normal per layer against nested spheres with a normal per shell", "",
             "Generated by `lamella bench layer-normals` (`lamella_dev/bench/layer_normals.py`).", "",
             f"`sphere-env`, {RES} px; the Lamella node in Cycles with OSL at {SPP} spp against the stack as nested "
             f"spheres (`reference_scene`, {REFERENCE_SPP} spp) whose bumped shell has the same bump (a noise of scale "
             f"{BUMP_SCALE:g} in object space, Bump strength {BUMP_STRENGTH:g}, distance {BUMP_DISTANCE:g}) in its own normal. *Own normal*: the "
             "bump in that layer's Normal input (each closure about its layer's normal, the energies about the shading "
             "normal); *one normal*: the bump in the node's Normal (every layer bumped); *flat*: no bump. *RMSE 8 px*: of 8 x 8 pixel "
             "means (the local appearance, without the sampling noise).", "",
             "| case | bumped | own normal dE00 | RMSE | RMSE 8 px | one normal dE00 | RMSE | RMSE 8 px | flat dE00 | RMSE | "
             "RMSE 8 px |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in data["rows"]:
        cells = [f"{r[k]['delta_e00']:.2f} | {r[k]['rmse']:.4f} | {r[k]['rmse_8px']:.4f}" for k in ("own", "one", "flat")]
        lines.append(f"| {r['case']} | {r['layer']} | " + " | ".join(cells) + " |")
    lines.append("")
    if data.get("sun_rows"):
        bins = [f"{lo:g}-{hi:g}" for lo, hi in THETA_H_BINS] + ["0-90"]
        lines += ["## The BRDF under one sun, binned", "",
                  f"`sphere-sun` (sun {', '.join(map(str, SUN_DIR))}, normalised; black world), {RES} px, the same "
                  "spp as above. Each lit pixel (cos theta_i above "
                  f"{LIT_COS:g}) is one (wi, wo) pair in its shading frame: radiance / cos theta_i is the BRDF there. "
                  "Relative L1 of that BRDF against the nested spheres per bin of the half vector's angle from the "
                  f"shading normal (degrees; *0-90*: every lit pixel). *tilt*: a constant tilt of {TILT_DEGREES:g} "
                  "degrees along the UV tangent in the layer's normal (a Normal Map of one colour); *bump*: the "
                  "noise bump above.", "",
                  "| case | normal | reading | " + " | ".join(bins) + " |",
                  "|---|---|---|" + "---:|" * len(bins)]
        for r in data["sun_rows"]:
            for key, name in (("own", "own normal"), ("one", "one normal"), ("flat", "flat")):
                cells = ["-" if r[key][b] is None else f"{r[key][b]:.3f}" for b in bins]
                lines.append(f"| {r['case']} | {r['normal']} | {name} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


def run(out_dir: Path = BENCH_DIR, progress=print) -> Path:
    data = {"res": RES, "spp": SPP, "reference_spp": REFERENCE_SPP, "rows": rows(progress),
            "sun_rows": sun_rows(progress)}
    return write_page(out_dir, "layer_normals", lambda: format_markdown(data), data)


BENCH = register(Bench("layer-normals", "a normal per layer against nested spheres with a normal per shell",
                       lambda out_dir, args: run(out_dir)))

__all__ = ["CASES", "SUN_CASES", "bump", "tilt", "binned_brdf", "rows", "sun_rows", "run", "format_markdown"]
