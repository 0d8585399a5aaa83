"""`lamella bench staging`: what staging a material buys and what it costs in accuracy.

Two parts, written to ``bench/staging.md`` (and ``staging.json``):

- **Baked against traced** (numpy, no Blender): for every suite stack and example, the staged
  shader (every lobe, ``budget="all"``) evaluated as the emitters compute it (float32 table,
  linear reads) against the traced model (``lamella.core.evaluate``), relative L1 (RGB averaged)
  on the hemisphere grid of ``suite.wo_grid`` (and its mirror below the surface for a glass
  base), at incidence 0-85 degrees and five azimuths where the stack is anisotropic: the worst
  view. Then the lobe budget: for the stacks with many lobes, each merge rule and budget against
  every lobe.
- **Render cost** (Blender): one coat over gold and eight coats with media in the canonical
  ``sphere-env``, median of interleaved renders in one process, as ratios to the Principled
  stand-in in the same shading system: the traced OSL shader, the staged OSL shader (budget
  auto and all), the staged node group rendered by Cycles with OSL on (which compiles it to OSL)
  and without (SVM), the group in EEVEE, and the node counts; and what a coverage mask costs
  (the Lamella node with a node linked into a coat's coverage: a mask of 1 or 0 everywhere
  against the stack it leaves, a noise mask against the Principled BSDF's Coat Weight).
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from lamella.core import Stack, api
from .. import suite
from lamella.core.backends.ir import lobe_budget, staging
from lamella.core.backends.evaluate import evaluate_staged
from .paths import BENCH_DIR
from .page import write_page
from .registry import Bench, register

ANGLES = (0.0, 15.0, 30.0, 45.0, 60.0, 70.0, 75.0, 80.0, 85.0)
AZIMUTHS = (0.0, 0.37, 1.3, 2.9, 4.4)
RES, SPP, REPEATS = 160, 128, 3  # the scene's size, samples and repeats of every measurement here


def _stacks():
    out = [(n, suite.load(n)) for n in suite.names()]
    out += [(n, suite.example(n)) for n in ("four_coats", "coated_glass")]
    from .recompile import _stack

    out += [(label, _stack(label, None)) for label in ("4 coats + medium", "8 coats + media")]
    return out


def relative_l1(a, b, w) -> float:
    a, b = a * w[:, None], b * w[:, None]
    den = np.abs(a).sum(0)
    return float((np.abs(a - b).sum(0) / np.maximum(den, 1e-12)).mean())


def baked_error(stack, st) -> tuple[float, tuple]:
    """The worst relative L1 of the staged shader against the traced model over the views."""
    worst, where = 0.0, None
    for th in ANGLES:
        for phi in ((0.0,) if st.frame == "view" else AZIMUTHS):
            wi = suite.incident(th, phi)
            wo, w = suite.wo_grid(wi)
            sides = [wo] + ([wo * np.array([1.0, 1.0, -1.0])] if stack.base.kind.transmits else [])
            for wo_s in sides:
                e = relative_l1(api.evaluate(stack, wi, wo_s), evaluate_staged(st, wi, wo_s).astype(float), w)
                if e > worst:
                    worst, where = e, (th, phi)
    return worst, where


def accuracy_rows(progress=print) -> list[dict]:
    rows = []
    for name, stack in _stacks():
        t0 = time.perf_counter()
        st = staging.stage(stack, budget="all")
        seconds = time.perf_counter() - t0
        worst, where = baked_error(stack, st)
        rows.append({"stack": name, "frame": st.frame, "table": list(st.table.shape), "lobes": st.lobes_all,
                     "worst_rel_l1": worst, "at_degrees": where[0] if where else 0.0, "stage_s": seconds})
        progress(f"{name}: {worst:.4f}")
    return rows


def budget_rows(progress=print) -> list[dict]:
    """Every merge rule at every budget, on the stacks with more than four lobes: the largest
    relative L1 against every lobe at the checked views (``lobe_budget.brdf_error``)."""
    rows = []
    for name, stack in _stacks():
        st = staging.stage(stack, budget="all")
        if st.lobes_all <= 4:
            continue
        for rule in lobe_budget.RULES:
            row = {"stack": name, "rule": rule, "lobes": st.lobes_all, "errors": {}}
            grid = st.grid
            dirs = grid.directions().reshape(-1, 3)
            full = _samples(stack, dirs)
            views = lobe_budget.check_views(dirs, turn=st.frame == "shading" and grid.n_phi == 1)
            order = lobe_budget.merge_order(full, rule)
            for level in order:
                if len(level) <= 8:
                    row["errors"][len(level)] = lobe_budget.brdf_error(full, level, views)
            auto = staging.stage(stack, budget="auto")
            row["auto"] = len(auto.closures)
            rows.append(row)
            progress(f"{name} {rule}: {row['errors']}")
    return rows


def _samples(stack, dirs):
    """Every lobe of the model on the grid views ``dirs``."""
    from lamella.core.backends.ir.closures import trace_closures

    traced = trace_closures(stack)
    on_grid = staging.grid_values(traced.tracer, dirs, ())
    return [lobe_budget.LobeSamples.of(c, on_grid, k) for k, c in enumerate(traced.closures)]


# (label, shading system, render_stack arguments); the first of each system is its reference
COST_VARIANTS = (("principled (OSL)", "OSL", dict(engine="principled")),
                 ("traced OSL", "OSL", dict(engine="cycles-osl", staged=False)),
                 ("staged OSL, auto", "OSL", dict(engine="cycles-osl")),
                 ("staged OSL, all lobes", "OSL", dict(engine="cycles-osl", budget="all")),
                 ("staged nodes (OSL on), auto", "OSL", dict(engine="cycles-nodes", osl=True)),
                 ("principled (SVM)", "SVM", dict(engine="principled-svm")),
                 ("staged nodes (SVM), auto", "SVM", dict(engine="cycles-nodes")),
                 ("principled (EEVEE)", "EEVEE", dict(engine="eevee-principled")),
                 ("staged nodes (EEVEE), auto", "EEVEE", dict(engine="eevee")),
                 ("the Lamella node (OSL)", "OSL", dict(engine="lamella-osl")),
                 ("the Lamella node (SVM)", "SVM", dict(engine="lamella-svm")),
                 ("the Lamella node (EEVEE)", "EEVEE", dict(engine="lamella-eevee")))


def _timed_render(stack, engine, budget="auto", staged=True, osl=None):
    """(first render seconds, second render seconds) of ``stack`` in a fresh ``sphere-env``: the
    first includes what a renderer does once per material (OSL JIT, EEVEE's shader compile), the
    second is a frame. ``osl``: Cycles' shading system forced on or off after the material is
    assigned (the node group rendered by Cycles with OSL on: what a scene with OSL on and no
    Script node runs)."""
    from ..render import assign_material, build_scene, render_scene

    sc, sphere = build_scene("sphere-env", RES, SPP)
    assign_material(sphere, stack, engine, budget=budget, staged=staged)
    if osl is not None:
        sc.cycles.shading_system = osl
    _, first = render_scene(sc)
    _, second = render_scene(sc) if "eevee" in engine else (None, first)
    return first, second


def cost_rows(repeats: int = REPEATS, progress=print, variants=COST_VARIANTS) -> list[dict]:
    import bpy  # noqa: F401

    from lamella.core.backends.nodes.lower import emit_plan
    from .recompile import _stack

    cases = [("1 coat (gold_coated)", suite.load("gold_coated")), ("8 coats + media", _stack("8 coats + media", None))]
    rows = []
    for label, stack in cases:
        first = {v: [] for v, _, _ in variants}
        frame = {v: [] for v, _, _ in variants}
        for r in range(repeats):
            for v, _, kw in variants:
                a, b = _timed_render(stack, **kw)
                first[v].append(a)
                frame[v].append(b)
                progress(f"{label} {v}: {a:.2f} s, frame {b:.2f} s")
        med = {v: float(np.median(ts)) for v, ts in frame.items()}
        med_first = {v: float(np.median(ts)) for v, ts in first.items()}
        reference = {}
        for v, system, _ in variants:
            reference.setdefault(system, v)
        ratio = {v: med[v] / med[reference[system]] for v, system, _ in variants}
        plan = emit_plan(stack)
        rows.append({"stack": label, "seconds": med, "first_seconds": med_first, "x_principled": ratio,
                     "plan_nodes": len(plan.nodes), "closures": len(plan.bsdfs)})
    return rows


# What a coverage mask costs: (label, stack, what is linked into coat 0's coverage). A mask of 1
# everywhere should cost what the whole stack costs, a mask of 0 what the bare base costs: the
# closures of the part that is absent weigh 0 and the renderer skips them (``models.coverage``).
COVER_COAT = {"ior": 1.5, "roughness": 0.01, "thickness": 0.4, "sigma_a": [0.1, 0.5, 1.5]}
COVER_BASE = {"type": "diffuse", "albedo": [0.5, 0.3, 0.15]}
COVER_FILM = {**COVER_COAT, "film_thickness": 300.0, "film_ior": 1.45}
COVER_VARIANTS = (("the whole stack, no mask", [COVER_COAT], None),
                  ("mask linked, 1 everywhere", [COVER_COAT], 1.0),
                  ("the bare base", [], None),
                  ("mask linked, 0 everywhere", [COVER_COAT], 0.0),
                  ("mask linked, a noise texture", [COVER_COAT], "noise"),
                  ("mask linked, a noise texture; a 300 nm film on the coat", [COVER_FILM], "noise"))
COVER_ENGINES = (("OSL", "lamella-osl", "principled"), ("SVM", "lamella-svm", "principled-svm"),
                 ("EEVEE", "lamella-eevee", "eevee-principled"))


def _timed_cover_render(layers, mask, engine):
    """(first, frame) seconds of the Lamella node with ``layers`` over ``COVER_BASE``, ``mask``
    (None, a number or "noise") linked into coat 0's coverage; ``engine`` may be a Principled
    stand-in (its Coat Weight takes the mask)."""
    from lamella.blender import api as blender_api

    from ..render import assign_material, build_scene, node_tree, render_scene

    sc, sphere = build_scene("sphere-env", RES, SPP)
    stack = {"layers": layers, "base": COVER_BASE}
    mat = assign_material(sphere, Stack.coerce(stack), engine)
    if mask is not None:
        nt = node_tree(mat)
        if mask == "noise":
            src = nt.nodes.new("ShaderNodeTexNoise").outputs["Fac"]
        else:
            value = nt.nodes.new("ShaderNodeValue")
            value.outputs[0].default_value = mask
            src = value.outputs[0]
        if engine.startswith("lamella"):
            nt.links.new(src, blender_api.input_socket(mat, 0, "coverage"))
        else:
            principled = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
            nt.links.new(src, principled.inputs["Coat Weight"])
            if layers and layers[0].get("film_thickness", 0.0) > 0.0:  # Principled's film is on its base
                principled.inputs["Thin Film Thickness"].default_value = layers[0]["film_thickness"]
                principled.inputs["Thin Film IOR"].default_value = layers[0]["film_ior"]
    _, first = render_scene(sc)  # the render handler compiles the linked mask first
    _, second = render_scene(sc) if "eevee" in engine else (None, first)
    return first, second


def cover_rows(repeats: int = REPEATS, progress=print) -> list[dict]:
    """Median frame seconds of each ``COVER_VARIANTS`` in each engine (the Lamella node) and of
    the Principled stand-in with the noise mask in its Coat Weight, interleaved."""
    rows = []
    for system, engine, principled in COVER_ENGINES:
        variants = [(label, layers, mask, engine) for label, layers, mask in COVER_VARIANTS]
        variants.append(("Principled, the noise in its Coat Weight", [COVER_COAT], "noise", principled))
        variants.append(("Principled, the noise in its Coat Weight and a 300 nm film", [COVER_FILM], "noise",
                         principled))
        frames = {v[0]: [] for v in variants}
        for _ in range(repeats):
            for label, layers, mask, eng in variants:
                _, frame = _timed_cover_render(layers, mask, eng)
                frames[label].append(frame)
                progress(f"coverage {system} {label}: {frame:.2f} s")
        rows.append({"system": system, "seconds": {k: float(np.median(v)) for k, v in frames.items()}})
    return rows


def run(out_dir: Path = BENCH_DIR, progress=print, renders: bool = True) -> Path:
    data = {"accuracy": accuracy_rows(progress), "budget": budget_rows(progress)}
    if renders:
        data["cost"] = cost_rows(progress=progress)
        data["coverage"] = cover_rows(progress=progress)
    return write_page(out_dir, "staging", lambda: format_markdown(data), data)


def format_markdown(data) -> str:
    lines = [
        "# Staging: the baked shader against the traced model, the lobe budget, and what it costs",
        "",
        "Generated by `lamella bench staging` (`lamella_dev/bench/staging.py`).",
        "",
        "## Baked against traced",
        "",
        "Worst relative L1 (RGB averaged) of the staged shader (every lobe, float32 table, linear reads) against",
        "the traced model, over incidence 0-85 degrees (and five azimuths for anisotropic stacks), on the",
        "hemisphere grid of `suite.wo_grid` (and below the surface for a glass base). Target: 0.5 %.",
        "",
        "| stack | frame | table | lobes | worst rel. L1 | at (deg) | stage s |",
        "|---|---|---|---:|---:|---:|---:|",
    ]
    for r in data["accuracy"]:
        lines.append(f"| {r['stack']} | {r['frame']} | {' x '.join(map(str, r['table']))} | {r['lobes']} | "
                     f"{100 * r['worst_rel_l1']:.2f} % | {r['at_degrees']:.0f} | {r['stage_s']:.2f} |")
    lines += ["", "## Lobe budget", "",
              "Largest relative L1 of the merged lobes against every lobe (views 0-75 degrees, four azimuths), by",
              "merge rule (energy-weighted power mean of the roughness tensors: `alpha` p = 1, `alpha2` p = 2,",
              "`geometric` p = 0) and closures kept; *auto* is what the automatic budget (1 %) keeps.", ""]
    if data["budget"]:
        ks = sorted({int(k) for r in data["budget"] for k in r["errors"]})
        lines += ["| stack | lobes | rule | auto | " + " | ".join(f"{k}" for k in ks) + " |",
                  "|---|---:|---|---:|" + "---:|" * len(ks)]
        for r in data["budget"]:
            errs = {int(k): v for k, v in r["errors"].items()}
            lines.append(f"| {r['stack']} | {r['lobes']} | {r['rule']} | {r['auto']} | "
                         + " | ".join(f"{100 * errs[k]:.1f} %" if k in errs else "" for k in ks) + " |")
    if "cost" in data:
        lines += ["", "## Render cost", "",
                  f"`sphere-env`, {RES} px, {SPP} spp, median of {REPEATS} interleaved renders in one process (whole render",
                  "call, including Cycles' shader set-up); ratios to the Principled stand-in in the same shading system",
                  "(OSL, SVM = Cycles without OSL, EEVEE). *First* is the first render of a new material (OSL's JIT,",
                  "EEVEE's shader compile); the ratio uses the frame (for Cycles the same render).", ""]
        for r in data["cost"]:
            lines.append(f"**{r['stack']}** (staged node group: {r['plan_nodes']} plan nodes, {r['closures']} closures)")
            lines += ["", "| shader | first s | frame s | x Principled |", "|---|---:|---:|---:|"]
            for v, s in r["seconds"].items():
                lines.append(f"| {v} | {r['first_seconds'][v]:.2f} | {s:.2f} | {r['x_principled'][v]:.2f} |")
            lines.append("")
    if "coverage" in data:
        lines += ["## What a coverage mask costs", "",
                  "A tinted clear coat over a diffuse base (the Lamella node), `sphere-env`, "
                  f"{RES} px, {SPP} spp, median frame of {REPEATS} interleaved renders, with a node linked into the coat's",
                  "coverage: a mask of 1 everywhere against the whole stack, a mask of 0 against the bare base, and a",
                  "noise texture against the Principled BSDF with the same noise in its Coat Weight (with a film: a 300 nm "
                  "film on the coat against Principled's Thin Film on its base, the closest it has).", "",
                  "| shading | variant | frame s | ratio | against |", "|---|---|---:|---:|---|"]
        against = {"mask linked, 1 everywhere": "the whole stack, no mask",
                   "mask linked, 0 everywhere": "the bare base",
                   "mask linked, a noise texture": "Principled, the noise in its Coat Weight",
                   "mask linked, a noise texture; a 300 nm film on the coat":
                       "Principled, the noise in its Coat Weight and a 300 nm film"}
        for r in data["coverage"]:
            sec = r["seconds"]
            for label, s in sec.items():
                ref = against.get(label)
                ratio = f"{s / sec[ref]:.2f}" if ref else ""
                lines.append(f"| {r['system']} | {label} | {s:.2f} | {ratio} | {ref or ''} |")
        lines.append("")
    return "\n".join(lines) + "\n"


BENCH = register(Bench("staging",
                       "the staged shader against the traced model, the lobe budget's merge rules, render cost",
                       lambda out_dir, args: run(out_dir)))
