"""`lamella bench thin-film`: Lamella's thin film against Blender's own (the Principled BSDF's and the
Metallic BSDF's Thin Film inputs), against the exact spectral colour, and each model against the
spectral stochastic reference (binned BRDF and albedo, ``film_accuracy``).

Where both can express a film: a dielectric interface under a film (Lamella: a coat of index 1.5
over a black base, so only the interface reflects; Blender: the Principled BSDF with a black base
colour, IOR 1.5), and a metal under a film (Lamella: a conductor base; Blender: the Metallic BSDF,
Physical Conductor, with the same complex index). Each is rendered in the ``white-furnace`` scene,
so every pixel of the sphere is the surface's directional albedo at that pixel's view angle, with
Cycles (OSL for Lamella's shader, Blender's closures in the same scene), and compared by mean
CIEDE2000 over the sphere (``image_metrics``). For a smooth interface the exact answer is known
per pixel: the film's reflectance at that angle per wavelength, integrated against the CIE 1931
colour matching functions (``thin_film_spectral``); both are measured against it.

Both follow Belcour and Barla 2017; Blender (since 4.2) reads a table of the exact transform of the
colour matching functions, Lamella a Gaussian fit of it that traces to a few exp/cos/sin
(``models.thin_film``), and Lamella's rough interfaces average the film over their facets
(``models.film``).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from lamella.core import Stack
from lamella.core.param_id import r_from_alpha
from ..image_metrics import mean_delta_e00
from .paths import BENCH_DIR
from .page import write_page
from .registry import Bench, register

RES, SPP = 96, 64
TITANIUM = {"eta": [2.698, 2.479, 2.305], "k": [3.757, 3.351, 3.082]}  # Johnson and Christy 1974 (metals.json)
GOLD = {"eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603]}
# (label, kind, film thickness nm, film ior, alpha, metal)
CASES = tuple(
    [(f"dielectric 1.5, film {n} / {t} nm" + (f", alpha {a}" if a else ""), "dielectric", t, n, a, None)
     for n in (1.33, 2.0) for t in (150, 300, 500, 800) for a in (0.0, 0.1)]
    + [(f"{name}, film {n} / {t} nm" + (f", alpha {a}" if a else ""), "metal", t, n, a, metal)
       for name, metal, n, ts in (("titanium", TITANIUM, 2.3, (30, 60, 130)), ("gold", GOLD, 1.5, (150, 300)))
       for t in ts for a in (0.0, 0.1)])


def _stack(kind, t, n, alpha, metal) -> Stack:
    if kind == "dielectric":
        return Stack.from_dict({"layers": [{"ior": 1.5, "roughness": alpha, "film_thickness": t, "film_ior": n}],
                                "base": {"type": "diffuse", "albedo": [0.0, 0.0, 0.0]}})
    return Stack.from_dict({"layers": [], "base": {"type": "conductor", **metal, "roughness": alpha,
                                                   "film_thickness": t, "film_ior": n}})


def _blender(kind, t, n, alpha, metal):
    """The furnace scene with Blender's own film on the sphere: (RGBA, seconds)."""
    from ..render import build_scene, render_scene, sphere_material

    sc, sphere = build_scene("white-furnace", RES, SPP)
    _, nt, out = sphere_material(sphere, "blender_film")
    if kind == "dielectric":
        node = nt.nodes.new("ShaderNodeBsdfPrincipled")
        node.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
        node.inputs["IOR"].default_value = 1.5
    else:
        node = nt.nodes.new("ShaderNodeBsdfMetallic")
        node.fresnel_type = "PHYSICAL_CONDUCTOR"
        node.inputs["IOR"].default_value = metal["eta"]
        node.inputs["Extinction"].default_value = metal["k"]
    node.inputs["Roughness"].default_value = r_from_alpha(alpha)
    node.inputs["Thin Film Thickness"].default_value = t
    node.inputs["Thin Film IOR"].default_value = n
    nt.links.new(node.outputs[0], out.inputs["Surface"])
    return render_scene(sc)


def _exact(kind, t, n, metal, res: int) -> tuple[np.ndarray, np.ndarray]:
    """The exact spectral reflectance of the smooth filmed interface at every pixel's view angle of
    the canonical orthographic camera, and the sphere mask."""
    from ..thin_film_spectral import film_reflectance_rgb

    from .image_references import sphere_normals

    n_px, mask = sphere_normals(res)  # inside the rim (its pixels mix the background)
    cos = -n_px[..., 1]  # the view, along -y toward the camera
    img = np.zeros((res, res, 3))
    kw = {"n_below": 1.5} if kind == "dielectric" else {"eta": metal["eta"], "k": metal["k"]}
    img[mask] = np.asarray(film_reflectance_rgb(cos[mask], 1.0, n, t, **kw)).reshape(-1, 3)
    return img, mask


def rows(progress=print) -> list[dict]:
    import bpy  # noqa: F401

    from ..render import render_stack

    out = []
    for label, kind, t, n, alpha, metal in CASES:
        ours, s_ours = render_stack(_stack(kind, t, n, alpha, metal), "white-furnace", res=RES, spp=SPP,
                                    engine="cycles-osl")
        theirs, s_theirs = _blender(kind, t, n, alpha, metal)
        on = (ours[..., 3] > 0.999) & (theirs[..., 3] > 0.999)
        row = {"case": label, "kind": kind, "thickness_nm": t, "film_ior": n, "alpha": alpha,
               "de_lamella_blender": mean_delta_e00(ours[..., :3], theirs[..., :3], on)}
        if alpha == 0.0:
            exact, inside = _exact(kind, t, n, metal, ours.shape[0])
            m = on & inside
            row["de_lamella_exact"] = mean_delta_e00(ours[..., :3], exact, m)
            row["de_blender_exact"] = mean_delta_e00(theirs[..., :3], exact, m)
        out.append(row)
        progress(f"{label}: dE00 Lamella-Blender {row['de_lamella_blender']:.2f}"
                 + (f", Lamella-exact {row['de_lamella_exact']:.2f}, Blender-exact {row['de_blender_exact']:.2f}"
                    if "de_lamella_exact" in row else ""))
    return out


REFERENCE_SPP, REFERENCE_ALBEDO_SPP = 2048, 1 << 17


def _plain(rows: list[dict]) -> list[dict]:
    return [{k: (np.asarray(v).tolist() if isinstance(v, np.ndarray) else v) for k, v in r.items()} for r in rows]


def reference_rows(progress=print) -> dict:
    """Each model (``auto``) against the spectral stochastic reference (``lamella_dev.reference``:
    the film's exact reflectance per wavelength) on the stacks of ``film_accuracy``, beside the same
    stacks without their films."""
    from .. import film_accuracy as fa

    out = {}
    for name, d in fa.STACKS.items():
        rows = fa.measure(d, REFERENCE_SPP, REFERENCE_ALBEDO_SPP, "multiple")
        bare = fa.measure(fa.without_film(d), REFERENCE_SPP, REFERENCE_ALBEDO_SPP, "multiple")
        out[name] = {"rows": _plain(rows), "bare": _plain(bare)}
        errs = ", ".join(f"{r['albedo_err']:.3f}" for r in rows)
        progress(f"{name}: albedo err {errs}")
    return out


def _f(x) -> str:
    return "" if x is None else f"{x:.2f}"


def format_markdown(data) -> str:
    lines = ["# Thin film: Lamella against Blender's own and the exact spectral colour", "",
             "Generated by `lamella bench thin-film` (`lamella_dev/bench/thin_film.py`).", "",
             f"`white-furnace`, {RES} px, {SPP} spp, Cycles: every sphere pixel is the directional albedo at its view "
             "angle. Mean CIEDE2000 over the sphere between Lamella's shader (OSL) and Blender's closure with the same "
             "film (the Principled BSDF over a black base for a dielectric interface of index 1.5, the Metallic BSDF as "
             "a physical conductor for a metal), and, for a smooth interface, of each against the exact spectral colour "
             "(the film's reflectance per wavelength at the pixel's angle through the CIE 1931 curves). Below about "
             "1 a difference is hard to see; a film's colour changes by tens along its thickness.", "",
             "| case | dE00 Lamella - Blender | dE00 Lamella - exact | dE00 Blender - exact |", "|---|---:|---:|---:|"]
    for r in data["rows"]:
        lines.append(f"| {r['case']} | {_f(r['de_lamella_blender'])} | {_f(r.get('de_lamella_exact'))} | "
                     f"{_f(r.get('de_blender_exact'))} |")
    rs = data["rows"]
    smooth = [r for r in rs if "de_lamella_exact" in r]
    lines += ["", f"Over the {len(rs)} cases: mean dE00 Lamella - Blender "
              f"{np.mean([r['de_lamella_blender'] for r in rs]):.2f} (largest "
              f"{max(r['de_lamella_blender'] for r in rs):.2f}); over the {len(smooth)} smooth ones, against the exact "
              f"colour, Lamella {np.mean([r['de_lamella_exact'] for r in smooth]):.2f} and Blender "
              f"{np.mean([r['de_blender_exact'] for r in smooth]):.2f}.", ""]
    if data.get("reference"):
        from .. import film_accuracy as fa

        lines += ["## Against the spectral stochastic reference", "",
                  "The model (`auto`) against `lamella_dev.reference` with the film's exact reflectance per "
                  "wavelength (a spectral walk, RGB through the CIE 1931 curves; energy-conserving rough interfaces), "
                  f"{REFERENCE_SPP} samples per direction of the hemisphere grid, {REFERENCE_ALBEDO_SPP} walkers per "
                  "albedo; beside the same stack without its film (what the film adds to the model's error). Relative "
                  "L1 as `bench/accuracy.md` computes it, the reference's own noise in brackets.", ""]
        for name, r in data["reference"].items():
            lines += fa.table(name, r["rows"], r["bare"])
    return "\n".join(lines)


def run(out_dir: Path = BENCH_DIR, progress=print) -> Path:
    data = {"res": RES, "spp": SPP, "rows": rows(progress), "reference": reference_rows(progress)}
    return write_page(out_dir, "thin_film", lambda: format_markdown(data), data)


BENCH = register(Bench("thin-film", "Lamella's thin film against Blender's Principled/Metallic thin film and the "
                       "exact spectral colour", lambda out_dir, args: run(out_dir)))

__all__ = ["CASES", "rows", "run", "format_markdown"]
