"""`lamella bench linked-tables`: the node group's tables over linked parameters, against the model.

For each stack class (1, 4 coats, 4 coats + a medium, 8 coats + media) with textures on two coat
roughnesses and the base colour (``node_cost.textured_sockets``), staged with tables over (view,
linked parameters) (``live_axes``, what the node group falls back to where its traced part is
too large for Cycles' SVM) and traced (what the OSL shader does): at random values of the linked
parameters (roughness r uniform in [0.1, 0.95], each base eta channel in [0.05, 2]), relative L1
(RGB summed) of each against the model of the stack with those values (``lamella.core.evaluate``)
on ``suite.wo_grid`` at incidence 0, 30, 60 and 80 degrees, the worst incidence per draw; the
median and largest over the draws. Beside: the staging time, the size of the tables and of the
node plan, and whether ``emit_plan`` picks the tables for that stack. Numpy only, no Blender.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from lamella.core import Stack, api
from .. import suite
from lamella.core.backends.ir import staging
from lamella.core.backends.evaluate import evaluate_staged
from lamella.core.backends.ir.live_axes import MAX_AXES, N_AXIS, N_AXIS_WIDE
from lamella.core.param_id import AXES, COLOUR_CHANNELS
from .paths import BENCH_DIR
from .page import write_page
from .registry import Bench, register

ANGLES = (0.0, 30.0, 60.0, 80.0)
DRAWS = 12


def with_values(stack: Stack, values: dict, ids: dict) -> Stack:
    """``stack`` with the parameters ``values`` (name -> model value; ``ids``: name -> ``ParamId``,
    what each is) set in its layers."""
    d = stack.to_dict()
    for p, v in values.items():
        pid = ids[p]
        layer = d["base"] if pid.layer is None else d["layers"][pid.layer]
        if pid.is_roughness:
            r = layer[pid.field]
            r = list(r) if isinstance(r, (list, tuple)) else [r, r]
            if pid.channel:
                r[AXES.index(pid.channel)] = float(v)
            else:
                r = [float(v), float(v)]
            layer[pid.field] = r
        elif pid.is_colour:
            c = list(layer[pid.field])
            c[COLOUR_CHANNELS.index(pid.channel)] = float(v)
            layer[pid.field] = c
        else:
            layer[pid.field] = float(v)
    return Stack.from_dict(d)


SWEEP = tuple(float(r) for r in np.geomspace(0.02, 0.95, 24))  # r of the sweep over every textured roughness
BANDS = ((0.0, 0.1), (0.1, 0.3), (0.3, 1.0))  # the sweep's r ranges the page reports


def _draw(rng, live, ids) -> dict:
    return {p: rng.uniform(0.1, 0.95) ** 2 if ids[p].is_roughness else rng.uniform(0.05, 2.0) for p in live}


def rows(labels=None, draws: int = DRAWS, seed: int = 0, progress=print, controls: bool = True) -> list[dict]:
    """One row per stack class of ``recompile.STACKS`` (those named in ``labels``, default all).
    ``controls=False``: the tables' errors only (the draws and the sweep), without the traced
    staging they are compared with nor the node plans (what the page reports beside them)."""
    from lamella.core.backends.nodes.lower import emit_plan
    from lamella.core.backends.nodes.svm import live_values
    from .node_cost import textured_sockets
    from .recompile import STACKS, _stack

    out = []
    for label, case in STACKS:
        if labels is not None and label not in labels:
            continue
        stack = _stack(label, case)
        sockets = textured_sockets(stack)
        t0 = time.perf_counter()
        tab = staging.stage(stack, live=sockets, live_axes=MAX_AXES)
        seconds = time.perf_counter() - t0
        compared = {"tables": tab}
        if controls:
            compared["traced"] = staging.stage(stack, live=sockets)
        rng = np.random.default_rng(seed)
        errors = {k: [] for k in compared}
        for _ in range(draws):
            values = _draw(rng, tab.live, tab.ids)
            model = with_values(stack, values, tab.ids)
            worst = {k: 0.0 for k in errors}
            for theta in ANGLES:
                wi = suite.incident(theta)
                wo, _ = suite.wo_grid(wi)
                want = api.evaluate(model, wi, wo)
                for k, st in compared.items():
                    got = evaluate_staged(st, wi, wo, np.float32, values=values).astype(float)
                    worst[k] = max(worst[k], float(np.abs(got - want).sum() / np.abs(want).sum()))
            for k in errors:
                errors[k].append(worst[k])
        sweep = {}
        for r in SWEEP:  # every textured roughness at r, the other linked values the stack's own
            values = {p: (r * r if tab.ids[p].is_roughness else tab.params[p]) for p in tab.live}
            model = with_values(stack, values, tab.ids)
            worst = 0.0
            for theta in ANGLES:
                wi = suite.incident(theta)
                wo, _ = suite.wo_grid(wi)
                want = api.evaluate(model, wi, wo)
                got = evaluate_staged(tab, wi, wo, np.float32, values=values).astype(float)
                worst = max(worst, float(np.abs(got - want).sum() / np.abs(want).sum()))
            sweep[f"{r:.4f}"] = worst
        row = {"stack": label, "live": sockets, "stage_s": seconds, "sweep": sweep,
               **{f"{k}_median": float(np.median(v)) for k, v in errors.items()},
               **{f"{k}_max": float(np.max(v)) for k, v in errors.items()}}
        if not controls:
            out.append(row)
            continue
        plan = emit_plan(stack, live=sockets)
        tab_plan = emit_plan(stack, live=sockets, live_axes=MAX_AXES)
        image = next(iter(tab_plan.images.values()))
        row.update({"tables": [[list(t.params), list(t.data.shape)] for t in tab.axis_tables],
                    "image": list(image.shape[:2]), "image_mb": image.nbytes / 2**20,
                    "nodes_tables": len(tab_plan.nodes),
                    "nodes_traced": len(emit_plan(stack, live=sockets, live_axes=0).nodes),
                    "live_values_tables": live_values(tab_plan), "picked": plan.staged.live_axes > 0,
                    "still_traced": list(tab.traced_params)})
        progress(f"{label}: tables {row['tables_median']:.4f} / {row['tables_max']:.4f}, "
                 f"traced {row['traced_median']:.4f} / {row['traced_max']:.4f}")
        out.append(row)
    return out


def run(out_dir: Path = BENCH_DIR, progress=print) -> Path:
    data = rows(progress=progress)
    return write_page(out_dir, "linked_tables", lambda: _markdown(data), data)


def _markdown(data: list[dict]) -> str:
    md = [
        "# Tables over linked parameters (the node group's fallback for Cycles without OSL)",
        "",
        "`lamella bench linked-tables` (numpy, no Blender). Textures on two coat roughnesses and the base "
        "colour. *Tables*: the node group's staging with values that depend on the view and at most "
        f"{MAX_AXES} linked parameters read from tables ({N_AXIS} nodes along a roughness axis, {N_AXIS} along "
        f"another in a table over one or two parameters, {N_AXIS_WIDE} in a table over three); *traced*: what "
        f"the OSL shader does. Relative L1 against the model at the same linked values, worst of "
        f"{', '.join(f'{a:g}' for a in ANGLES)} degrees, median and largest over {DRAWS} random draws "
        "(roughness r in [0.1, 0.95], base eta channels in [0.05, 2]). *Picked*: whether `emit_plan` uses the "
        "tables for this stack (its traced part is above what SVM surely holds). *Still traced*: the linked "
        "parameters some arithmetic outside the tables reads (values that depend on more of them at once). "
        "Image: the material table image (rows x texels, RGBA float).",
        "",
        "| stack | tables: median | tables: max | traced: median | traced: max | staging s | tables (params: shape) | still traced | image | MB | plan nodes, tables / traced | live values | picked |",
        "|---|---:|---:|---:|---:|---:|---|---|---|---:|---|---:|---|",
    ]
    for r in data:
        tabs = "; ".join(f"{'+'.join(p)}: {'x'.join(map(str, s[:-1]))}x{s[-1]}" for p, s in r["tables"])
        md.append(f"| {r['stack']} | {r['tables_median']:.4f} | {r['tables_max']:.4f} | {r['traced_median']:.4f} | "
                  f"{r['traced_max']:.4f} | {r['stage_s']:.2f} | {tabs} | {', '.join(r['still_traced']) or 'nothing'} | "
                  f"{r['image'][0]} x {r['image'][1]} | "
                  f"{r['image_mb']:.1f} | {r['nodes_tables']} / {r['nodes_traced']} | {r['live_values_tables']} | "
                  f"{'yes' if r['picked'] else 'no'} |")
    if data and "sweep" in data[0]:
        rs = [float(k) for k in data[0]["sweep"]]
        md += ["", "## Glossy to rough: every textured roughness at one r", "",
               "The tables' relative L1 against the model (worst of the same angles) with every linked roughness "
               f"at r and the other linked values the stack's own, at {len(rs)} values of r evenly spaced in log r "
               f"from {rs[0]:g} to {rs[-1]:g}: where the draws above (r from 0.1) do not go, and where a coat's lobe "
               "is narrow. The largest in each range of r, and the mean over all. A roughness axis has its nodes "
               "evenly spaced in (2 / pi) asin(sqrt(r)) (`live_axes`), and a live lobe's own roughness is read "
               "from the tables as its fourth root (`staging`).", "",
               "| stack | " + " | ".join(f"r {lo:g}-{hi:g}: largest" for lo, hi in BANDS) + " | mean |",
               "|---|" + "---:|" * (len(BANDS) + 1)]
        for r in data:
            errs = [(float(k), v) for k, v in r["sweep"].items()]
            bands = [max((v for x, v in errs if lo <= x < hi), default=float("nan")) for lo, hi in BANDS]
            md.append(f"| {r['stack']} | " + " | ".join(f"{b:.4f}" for b in bands)
                      + f" | {np.mean([v for _, v in errs]):.4f} |")
    md += ["", "The OSL shader traces the linked part exactly; Cycles with OSL on renders that.", ""]
    return "\n".join(md)


BENCH = register(Bench("linked-tables",
                       "the node group's tables over linked parameters against the model, their size and staging time",
                       lambda out_dir, args: run(out_dir)))

__all__ = ["rows", "run", "with_values"]
