"""`lamella bench eevee-closures`: how EEVEE renders a sum of lobes, and whether merging or
dropping lobes before EEVEE sees them would help.

Two measurements in ``sphere-env``, with plain BSDF nodes of constant weights (no Lamella model
code, so the renderers alone are compared):

- *Additivity*: N = 1..6 Glossy BSDFs of roughness spread from sharp to rough, added with Add
  Shader nodes. The render of the sum against the sum of the N lobes rendered one at a time, as
  the relative L1 over the sphere's pixels. Cycles is the control: a sum of closures should render
  as the sum of their renders up to sampling noise. (Measured: it does not either, by about as
  much as EEVEE; the cause is not known.)
- *Rules*: the lobes a suite stack's model gives at normal incidence (weights and roughness held
  constant over the sphere), rendered with all lobes, merged to ``KEEP`` lobes (the two lobes of a
  kind closest in log roughness merged again and again: energies added, roughness the
  energy-weighted geometric mean) and cut to the ``KEEP`` most energetic. Each against Cycles
  rendering all lobes (the truth of these lobes), in EEVEE and in Cycles (the rule's own error).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .paths import BENCH_DIR
from .page import write_page
from .registry import Bench, register

RES, SPP = 64, 32
KEEP = 3  # the closure count EEVEE Next was reported to evaluate per pixel
ADDITIVITY_ALPHAS = (0.02, 0.06, 0.12, 0.2, 0.35, 0.6)
RULE_CASES = ("three_coats", "fog_g0", "fog_g09_d1", "milky_coat_d2", "green_scatter_d1")
ENERGY_EPS = 1e-4


# ---------------------------------------------------------------- lobes and rules (numpy)
def stack_lobes(case: str) -> list[tuple[str, tuple, float]]:
    """(kind, RGB energy, alpha) of the lobes carrying energy for ``case`` at normal incidence
    (alpha = sqrt(ax ay): the isotropic roughness EEVEE renders)."""
    from lamella.core import api
    from .. import suite

    lobes = api.lobes(suite.load(case), np.array([[0.0, 0.0, 1.0]]))
    out = []
    for k, kind in enumerate(lobes.kinds):
        w = lobes.weight[0, k]
        if float(w.sum()) > ENERGY_EPS:
            out.append((kind, tuple(float(x) for x in w), float(np.sqrt(lobes.alpha_x[0, k] * lobes.alpha_y[0, k]))))
    return out


def merge(lobes: list, keep: int = KEEP) -> list:
    """Merge the two lobes of one kind closest in log roughness until ``keep`` remain (or no two
    share a kind): energies add, roughness is the energy-weighted geometric mean."""
    lobes = list(lobes)
    while len(lobes) > keep:
        best = None
        for i in range(len(lobes)):
            for j in range(i + 1, len(lobes)):
                if lobes[i][0] != lobes[j][0]:
                    continue
                d = abs(math.log(max(lobes[i][2], 1e-3)) - math.log(max(lobes[j][2], 1e-3)))
                if best is None or d < best[0]:
                    best = (d, i, j)
        if best is None:
            break
        _, i, j = best
        (kind, wa, aa), (_, wb, ab) = lobes[i], lobes[j]
        ea, eb = sum(wa), sum(wb)
        alpha = math.exp((ea * math.log(max(aa, 1e-3)) + eb * math.log(max(ab, 1e-3))) / (ea + eb))
        lobes[i] = (kind, tuple(x + y for x, y in zip(wa, wb)), alpha)
        del lobes[j]
    return lobes


def drop(lobes: list, keep: int = KEEP) -> list:
    """The ``keep`` lobes of most energy, in their order."""
    order = sorted(range(len(lobes)), key=lambda k: -sum(lobes[k][1]))[:keep]
    return [lobes[k] for k in sorted(order)]


def rel_l1(img: np.ndarray, ref: np.ndarray, mask: np.ndarray) -> float:
    """Relative L1 over the masked pixels, RGB averaged (``metrics.relative_l1``, equal weights)."""
    from ..metrics import relative_l1

    return relative_l1(img[..., :3][mask], ref[..., :3][mask], np.ones(int(mask.sum())))


# ---------------------------------------------------------------- renders (bpy)
def lobe_sum_material(sphere, lobes):
    """The only material of ``sphere``: one BSDF node per (kind, RGB, alpha) lobe added up: Glossy
    (GGX, Blender roughness sqrt(alpha)) about the normal, Glossy about the view (back-scatter),
    Diffuse."""
    from ..render import sphere_material

    mat, nt, out = sphere_material(sphere, "closures")
    geo = nt.nodes.new("ShaderNodeNewGeometry")
    shader = None
    for kind, rgb, alpha in lobes:
        if kind == "diffuse":
            node = nt.nodes.new("ShaderNodeBsdfDiffuse")
        else:
            node = nt.nodes.new("ShaderNodeBsdfAnisotropic")
            node.distribution = "GGX"
            node.inputs["Roughness"].default_value = math.sqrt(alpha)
            if kind == "backscatter":
                nt.links.new(geo.outputs["Incoming"], node.inputs["Normal"])
        node.inputs["Color"].default_value = (*rgb, 1.0)
        if shader is None:
            shader = node.outputs[0]
        else:
            add = nt.nodes.new("ShaderNodeAddShader")
            nt.links.new(shader, add.inputs[0])
            nt.links.new(node.outputs[0], add.inputs[1])
            shader = add.outputs[0]
    nt.links.new(shader, out.inputs["Surface"])
    return mat


def _renderer(engine: str):
    from ..render import build_scene, render_scene, use_eevee

    def render(lobes):
        sc, sphere = build_scene("sphere-env", RES, SPP)
        if engine == "eevee":
            use_eevee(sc)
        lobe_sum_material(sphere, lobes)
        px, _ = render_scene(sc)
        return px

    return render


def measure() -> dict:
    from ..image_metrics import mean_bias

    renders = {e: _renderer(e) for e in ("cycles", "eevee")}
    additivity = []
    for n in range(1, len(ADDITIVITY_ALPHAS) + 1):
        lobes = [("reflection", (0.8 / n,) * 3, a) for a in ADDITIVITY_ALPHAS[:n]]
        row = {"lobes": n}
        for engine, render in renders.items():
            total = render(lobes)
            parts = sum(render([lobe]) for lobe in lobes)
            mask = total[..., 3] > 0.999
            row[engine] = rel_l1(total, parts, mask)
            row[f"{engine}_bias"] = mean_bias(total, parts, mask)
        additivity.append(row)
    rules = []
    for case in RULE_CASES:
        lobes = stack_lobes(case)
        truth = renders["cycles"](lobes)
        mask = truth[..., 3] > 0.999
        row = {"case": case, "lobes": len(lobes), "merged": len(merge(lobes)), "dropped": len(drop(lobes))}
        for engine, render in renders.items():
            for rule, fn in (("all", list), ("merged", merge), ("dropped", drop)):
                if engine == "cycles" and rule == "all":
                    continue
                row[f"{engine}_{rule}"] = rel_l1(render(fn(lobes)), truth, mask)
        rules.append(row)
    return {"additivity": additivity, "rules": rules}


def run(out_dir: Path = BENCH_DIR) -> Path:
    res = measure()
    md = [
        "# EEVEE and sums of lobes",
        "",
        f"`lamella bench eevee-closures` (sphere-env, {RES}×{RES}, {SPP} samples; plain BSDF nodes of constant "
        "weights, so only the renderers are compared). Relative L1 over the sphere's pixels.",
        "",
        "## Additivity: the render of a sum against the sum of the lobes rendered alone",
        "",
        "GGX Glossy BSDFs of alpha " + ", ".join(f"{a:g}" for a in ADDITIVITY_ALPHAS) + " (the first N), each of "
        "grey energy 0.8 / N. Cycles is the control: a sum of closures should render as the sum of their "
        "renders up to noise. *Bias*: the relative error of the sum's mean radiance over the sphere against the "
        "parts' (RGB averaged).",
        "",
        "| lobes | EEVEE rel. L1 | EEVEE bias | Cycles rel. L1 | Cycles bias |",
        "|---:|---:|---:|---:|---:|",
    ]
    for r in res["additivity"]:
        md.append(f"| {r['lobes']} | {r['eevee']:.3f} | {r['eevee_bias']:+.3f} | {r['cycles']:.3f} | "
                  f"{r['cycles_bias']:+.3f} |")
    md += [
        "",
        f"## Rules: all lobes, merged to {KEEP}, or the {KEEP} most energetic",
        "",
        "The lobes of each stack's model at normal incidence (kind, energy, alpha = sqrt(ax ay)), held constant "
        "over the sphere. Every render against Cycles rendering all of them. *Merged*: the two lobes of a kind "
        "closest in log roughness merged until "
        f"{KEEP} remain (energies added, roughness the energy-weighted geometric mean); *dropped*: the {KEEP} "
        "lobes of most energy.",
        "",
        "| stack | lobes | EEVEE all | EEVEE merged | EEVEE dropped | Cycles merged | Cycles dropped |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in res["rules"]:
        md.append(f"| {r['case']} | {r['lobes']} → {r['merged']} / {r['dropped']} | {r['eevee_all']:.3f} | "
                  f"{r['eevee_merged']:.3f} | {r['eevee_dropped']:.3f} | {r['cycles_merged']:.3f} | "
                  f"{r['cycles_dropped']:.3f} |")
    keys = ("eevee_all", "eevee_merged", "eevee_dropped", "cycles_merged", "cycles_dropped")
    mean = {k: float(np.mean([r[k] for r in res["rules"]])) for k in keys}
    md.append("| **mean** | | " + " | ".join(f"{mean[k]:.3f}" for k in keys) + " |")
    return write_page(out_dir, "eevee_closures", "\n".join(md))


BENCH = register(Bench("eevee-closures", "sums of lobes in EEVEE and Cycles, and rules that merge or drop lobes",
                       lambda out_dir, args: run(out_dir)))
