"""`lamella bench osl-cost`: what each feature of a stack costs in the fully traced OSL shader
(every parameter live: what a material pays for the part of its model that linked textures
reach; an untextured material is staged to a table instead, ``bench/staging.md``).

A one-coat isotropic stack, then the same with each feature added in turn: anisotropy, a rotated
anisotropic coat, an absorbing coat, and four coats. For each: generated source lines, live graph
nodes, texture reads per shading point, shader inputs, closures, compile time, and the render
time of the canonical ``sphere-env`` scene next to the Principled BSDF stand-in rendered in the
same run (ratios, not seconds, are the comparable figures on a shared machine).
"""
from __future__ import annotations

import json
import re
import time
from pathlib import Path

import numpy as np

from .. import suite
from lamella.core.stack import Stack
from .paths import BENCH_DIR
from .page import write_page
from .registry import Bench, register

RES, SPP, REPEATS = 96, 64, 3


def feature_ladder() -> list[tuple[str, Stack, str]]:
    """(label, stack, model): the one-coat isotropic stack and each feature added to it, then the
    other stack kinds (media at two depths: the same shader, so the cost cannot depend on depth)."""
    base = suite.load("gold_coated").to_dict()

    def variant(name, **changes):
        d = json.loads(json.dumps(base))
        d["name"] = name
        for path, value in changes.items():
            layer, key = path.split("__")
            (d["layers"][0] if layer == "coat" else d["base"])[key] = value
        return Stack.from_dict(d)

    return [
        ("one coat, isotropic", variant("iso"), "auto"),
        ("+ anisotropic base", variant("aniso", base__roughness=[0.15, 0.05]), "auto"),
        ("+ rotated anisotropic coat", variant("rotated", base__roughness=[0.15, 0.05],
                                               coat__roughness=[0.1, 0.02], coat__rotation=0.6), "auto"),
        ("+ absorbing coat", variant("absorbing", coat__thickness=0.5, coat__sigma_a=[0.05, 0.4, 1.2]), "auto"),
        ("four coats (all of the above)", suite.example("four_coats"), "auto"),
        ("one coat, isotropic, endf", variant("iso"), "endf"),
        ("scattering medium depth 0.1 over gold (tm6)", suite.load("fog_g09_d01"), "auto"),
        ("scattering medium depth 4 over gold (tm6)", suite.load("fog_g09_d4"), "auto"),
        ("scattering dielectric coat over gold (tm6)", suite.load("milky_coat_d2"), "auto"),
        ("varnish over a diffuse base", suite.load("varnished_wood"), "auto"),
        ("tinted coat over rough glass", suite.example("coated_glass"), "auto"),
    ]


def static_cost(stack: Stack, model: str = "auto") -> dict:
    from lamella.core.backends.osl.emit import emit_osl

    src = emit_osl(stack, model, staged=False)
    body = src[src.index("\nshader "):]
    return {
        "lines": len(src.splitlines()),
        "statements": body.count(";"),
        "texture_reads": len(re.findall(r"lamella_tex4?\(", body)) + 2 * len(re.findall(r"lamella_lut3\(", body))
        + len(re.findall(r"lamella_lut2\(", body)),
        "inputs": len(re.findall(r"^    (?:float|vector|normal|string|color) \w+ = ", body[:body.index("{")], re.M)),
        "closures": body.count("microfacet(") + body.count("diffuse("),
        "source": src,
    }


def compile_ms(source: str) -> float:
    import tempfile

    import _cycles

    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "s.osl"
        p.write_text(source)
        t0 = time.perf_counter()
        ok = _cycles.osl_compile(str(p), str(Path(tmp) / "s.oso"))
        dt = (time.perf_counter() - t0) * 1000.0
    if not ok:
        raise RuntimeError("compile failed")
    return dt


def run(out_dir: Path = BENCH_DIR, repeats: int = REPEATS, progress=print) -> tuple[Path, Path]:
    import bpy  # noqa: F401  (loads _cycles)

    from ..render import render_stack

    ladder = feature_ladder()
    rows = []
    for label, stack, model in ladder:
        row = {"label": label, **static_cost(stack, model)}
        row["compile_ms"] = compile_ms(row.pop("source"))
        row["seconds"], row["principled_seconds"] = [], []
        rows.append(row)
    # interleave engines and stacks so machine load drifts hit all of them alike
    for r in range(repeats):
        for row, (label, stack, model) in zip(rows, ladder):
            _, t = render_stack(stack, "sphere-env", res=RES, spp=SPP, engine="cycles-osl", model=model,
                                staged=False)
            _, tp = render_stack(stack, "sphere-env", res=RES, spp=SPP, engine="principled")
            row["seconds"].append(t)
            row["principled_seconds"].append(tp)
            progress(f"repeat {r}: {label}: {t:.2f} s (principled {tp:.2f} s)")
    for row in rows:
        row["median_seconds"] = float(np.median(row["seconds"]))
        row["median_principled_seconds"] = float(np.median(row["principled_seconds"]))
        row["ratio_to_principled"] = row["median_seconds"] / row["median_principled_seconds"]
    for row in rows:
        row["ratio_to_one_coat"] = row["median_seconds"] / rows[0]["median_seconds"]
    mpath = write_page(out_dir, "osl_cost", lambda: format_markdown(rows, repeats),
                       {"res": RES, "spp": SPP, "repeats": repeats, "rows": rows})
    return mpath, mpath.with_suffix(".json")


def format_markdown(rows, repeats) -> str:
    lines = [
        "# What each stack feature costs in the generated OSL",
        "",
        f"Generated by `lamella bench osl-cost`: {RES}×{RES} px, {SPP} spp, canonical `sphere-env`, median of {repeats}",
        "interleaved renders; `principled` is the Principled BSDF stand-in of the same stack rendered in the same",
        "run. Texture reads are per shading point (each a bilinear read of an EXR table). Features the stack does",
        "not have are not in its shader: an isotropic layer has one roughness input and no rotation, covariance or",
        "eigen-decomposition code; a coat without absorption has no medium code.",
        "",
        "| stack | lines | statements | texture reads | inputs | closures | compile ms | render s | × principled | × one coat |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(f"| {r['label']} | {r['lines']} | {r['statements']} | {r['texture_reads']} | {r['inputs']} | "
                     f"{r['closures']} | {r['compile_ms']:.0f} | {r['median_seconds']:.2f} | "
                     f"{r['ratio_to_principled']:.2f} | {r['ratio_to_one_coat']:.2f} |")
    lines.append("")
    return "\n".join(lines)


BENCH = register(Bench("osl-cost", "shader size, texture reads and render time per stack feature (traced OSL)",
                       lambda out_dir, args: run(out_dir)[0]))
