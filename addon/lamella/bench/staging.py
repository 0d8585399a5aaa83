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
  auto and all), the staged node group in Cycles without OSL (SVM), and the node counts.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from ..core import api, suite
from ..core.backends import lobe_budget, staging
from . import BENCH_DIR

ANGLES = (0.0, 15.0, 30.0, 45.0, 60.0, 70.0, 75.0, 80.0, 85.0)
AZIMUTHS = (0.0, 0.37, 1.3, 2.9, 4.4)
RES, SPP, REPEATS = 96, 32, 3


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
            sides = [wo] + ([wo * np.array([1.0, 1.0, -1.0])] if stack.base.type == "dielectric" else [])
            for wo_s in sides:
                e = relative_l1(api.evaluate(stack, wi, wo_s), staging.evaluate_staged(st, wi, wo_s).astype(float), w)
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
            order = lobe_budget.merge_order(full, rule)
            for level in order:
                if len(level) <= 8:
                    row["errors"][len(level)] = lobe_budget.brdf_error(full, level, dirs)
            auto = staging.stage(stack, budget="auto")
            row["auto"] = len(auto.closures)
            rows.append(row)
            progress(f"{name} {rule}: {row['errors']}")
    return rows


def _samples(stack, dirs):
    from ..core.backends.closures import trace_closures
    from ..core.backends.numpy_ops import NumpyOps

    traced = trace_closures(stack)
    t = traced.tracer
    values = dict(t.defaults)
    values.update({n: dirs[:, k] for k, n in enumerate(staging.VIEW_INPUTS)})

    def on_grid(exprs):
        with np.errstate(all="ignore"):
            vals = t.evaluate(list(exprs), NumpyOps(np.float64), values)
        return [np.broadcast_to(np.asarray(v, dtype=np.float64), (dirs.shape[0],)) for v in vals]

    return [lobe_budget.LobeSamples.of(c, on_grid, k) for k, c in enumerate(traced.closures)]


def cost_rows(repeats: int = REPEATS, progress=print) -> list[dict]:
    import bpy  # noqa: F401

    from ..blender.render import render_stack
    from ..core.backends.node_graph import emit_plan
    from .recompile import _stack

    cases = [("1 coat (gold_coated)", suite.load("gold_coated")), ("8 coats + media", _stack("8 coats + media", None))]
    variants = [("principled (OSL)", dict(engine="principled")),
                ("traced OSL", dict(engine="cycles-osl", staged=False)),
                ("staged OSL, auto", dict(engine="cycles-osl")),
                ("staged OSL, all lobes", dict(engine="cycles-osl", budget="all")),
                ("principled (SVM)", dict(engine="principled-svm")),
                ("staged nodes (SVM), auto", dict(engine="cycles-nodes"))]
    rows = []
    for label, stack in cases:
        times = {v: [] for v, _ in variants}
        for r in range(repeats):
            for v, kw in variants:
                _, t = render_stack(stack, "sphere-env", res=RES, spp=SPP, **kw)
                times[v].append(t)
                progress(f"{label} {v}: {t:.2f} s")
        med = {v: float(np.median(ts)) for v, ts in times.items()}
        plan = emit_plan(stack)
        rows.append({"stack": label, "seconds": med,
                     "osl_x_principled": {v: med[v] / med["principled (OSL)"] for v in med if "OSL" in v},
                     "svm_x_principled": {v: med[v] / med["principled (SVM)"] for v in med if "SVM" in v},
                     "plan_nodes": len(plan.nodes), "closures": len(plan.bsdfs)})
    return rows


def run(out_dir: Path = BENCH_DIR, progress=print, renders: bool = True) -> Path:
    data = {"accuracy": accuracy_rows(progress), "budget": budget_rows(progress)}
    if renders:
        data["cost"] = cost_rows(progress=progress)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "staging.json").write_text(json.dumps(data, indent=1) + "\n")
    path = out_dir / "staging.md"
    path.write_text(format_markdown(data))
    return path


def format_markdown(data) -> str:
    lines = [
        "# Staging: the baked shader against the traced model, the lobe budget, and what it costs",
        "",
        "Generated by `lamella bench staging` (`lamella/bench/staging.py`).",
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
                  "call, including Cycles' shader set-up); ratios to the Principled stand-in in the same shading system.", ""]
        for r in data["cost"]:
            lines.append(f"**{r['stack']}** (staged node group: {r['plan_nodes']} plan nodes, {r['closures']} closures)")
            lines += ["", "| shader | seconds | x Principled |", "|---|---:|---:|"]
            for v, s in r["seconds"].items():
                ratio = r["osl_x_principled"].get(v, r["svm_x_principled"].get(v))
                lines.append(f"| {v} | {s:.2f} | {ratio:.2f} |")
            lines.append("")
    return "\n".join(lines) + "\n"
