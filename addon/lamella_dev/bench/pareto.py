"""`lamella bench pareto`: run time against error, for every way Lamella renders a stack and for
the brute-force reference.

For each suite stack, in the canonical ``sphere-env`` at the stored references' resolution, each
*variant* renders at a ladder of samples per pixel:

- ``osl all``: the staged OSL shader with every lobe; ``osl auto`` and ``osl K``: its lobes merged
  to the automatic budget and to K closures (``lobe_budget``);
- ``nodes svm``: the staged node group in Cycles without OSL (what GPUs run); ``nodes eevee``: the
  same group in EEVEE (its frame: the second render of the material, the first compiles it);
- ``principled``: the Principled BSDF stand-in (Cycles, OSL on), the time unit;
- ``brute force``: the stack built as nested interface spheres (``reference_scene``), path traced,
  seeded apart from the stored references' chunks.

Time is each render's wall time divided by the Principled stand-in's at the same samples, in the
same run (so the ratio, not the machine, is what carries over); error is RMSE, mean ΔE00 and mean
FLIP over the sphere against the stored converged reference (``tests/references/images``), whose
own noise (``noise_rmse`` in its index) is a floor no variant can go under. From these:

- a Pareto plot per stack (error against time, one line per variant over the sample ladder);
- cost against the number of coats (1 to 8 clear coats over gold) and against the optical depth of
  a scattering coat (flat is the aim: the staged shader's cost is its closures, not the model);
- an equal-time view: at the time of ``osl auto``'s largest sample count, the brute force's error
  interpolated on its own curve (log-log), and the time the brute force needs to reach ``osl
  auto``'s error (extrapolated at the Monte Carlo rate, error^2 - floor^2 proportional to 1/time,
  where its ladder does not reach it).

The full run renders for 1.5 to 4 hours. Each stack's measurements are kept as they finish
(``cache/pareto/{full,quick}/<case>.json`` in the repository, with a fingerprint, ``fingerprint``);
``--resume`` reuses the ones whose fingerprint still matches, so an interrupted run renders only
the stacks it had not finished (and the cost sweeps, a few minutes, which are never kept).

``--quick`` (what the test suite runs): one scattering stack at 32 px against its reference averaged
down, two sample counts, each cost sweep at one size (eight coats; optical depth 4).
"""
from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import suite
from lamella.core.stack import Stack
from .paths import BENCH_DIR, REPO
from .image_references import IMAGE_REFERENCE_DIR, RES, load_index, sphere_mask
from .page import write_page
from .registry import Bench, cases_argument, register

REFERENCE_SEED = 7919  # far from the seeds of the stored references' chunks (0, 1, ...)
# The pixels the errors are taken over, recorded with the measurements: the sphere's
# (``image_references.sphere_mask``). Measurements stored without it were made while that mask
# read the renders' alpha, which is 1 everywhere: over the whole frame.
PIXELS = "sphere"


@dataclass(frozen=True)
class Variant:
    label: str
    engine: str  # render.ENGINES
    budget: object = "auto"


VARIANTS = (Variant("principled", "principled"), Variant("osl all", "cycles-osl", "all"),
            Variant("osl auto", "cycles-osl"), Variant("osl 1", "cycles-osl", 1), Variant("osl 2", "cycles-osl", 2),
            Variant("nodes svm", "cycles-nodes"), Variant("nodes eevee", "eevee"),
            Variant("brute force", "reference"))


@dataclass(frozen=True)
class Settings:
    cases: tuple
    res: int
    ladder: tuple
    brute_ladder: tuple
    coats: tuple
    depths: tuple
    cost_spp: int
    variants: tuple = VARIANTS


# brute force stops at 256 spp (a scattering stack's 256-bounce walk takes minutes beyond); the equal-time
# view extrapolates it at the Monte Carlo rate
FULL = Settings(cases=tuple(suite.names()), res=RES, ladder=(4, 16, 64, 256), brute_ladder=(16, 64, 256),
                coats=(1, 2, 4, 6, 8), depths=(0.1, 1.0, 4.0, 16.0), cost_spp=128)
QUICK = Settings(cases=("fog_g09_d1",), res=32, ladder=(4, 16), brute_ladder=(16, 64), coats=(8,),
                 depths=(4.0,), cost_spp=8)


@dataclass
class Curve:
    """One variant's points on one stack: (samples, time ratio, seconds, errors)."""

    variant: str
    points: list = field(default_factory=list)


# ---------------------------------------------------------------- rendering
def _reference(name: str, res: int) -> np.ndarray:
    """The stored reference of ``name`` at ``res`` (box-averaged down from the stored size)."""
    from lamella.core.exr import read_rgba

    ref = read_rgba(IMAGE_REFERENCE_DIR / f"{name}.exr").astype(np.float64)
    k = ref.shape[0] // res
    if k * res != ref.shape[0]:
        raise ValueError(f"resolution {res} does not divide the reference's {ref.shape[0]}")
    return ref.reshape(res, k, res, k, 4).mean((1, 3)) if k > 1 else ref


def render_variant(stack: Stack, v: Variant, res: int, spp: int, seed: int = 0):
    """(image, seconds) of one render; EEVEE's is its second render (the first compiles)."""
    from ..reference_scene import SHELL_THICKNESS, build_reference
    from ..render import assign_material, build_scene, render_scene

    sc, sphere = build_scene("sphere-env", res, spp, seed=seed)
    if v.engine == "reference":
        build_reference(sc, sphere, stack, SHELL_THICKNESS)
    else:
        assign_material(sphere, stack, v.engine, budget=v.budget)
    if v.engine.startswith("eevee"):
        render_scene(sc)
    return render_scene(sc)


def _errors(img, ref, mask) -> dict:
    from ..image_metrics import mean_delta_e00, mean_flip, rmse

    return {"rmse": rmse(img, ref, mask), "delta_e00": mean_delta_e00(img, ref, mask), "flip": mean_flip(img, ref, mask)}


def stack_curves(name: str, s: Settings, bar=None) -> dict:
    """Every variant of ``s`` on suite stack ``name`` at each sample count: the Principled stand-in
    first at each count, so each ratio's two renders are neighbours in time."""
    stack = suite.load(name)
    ref = _reference(name, s.res)
    mask = sphere_mask(ref)
    curves = {v.label: Curve(v.label) for v in s.variants}
    ladders = {v.label: (s.brute_ladder if v.engine == "reference" else s.ladder) for v in s.variants}
    principled = {}
    for spp in sorted({n for lad in ladders.values() for n in lad}):
        base_img, principled[spp] = render_variant(stack, Variant("principled", "principled"), s.res, spp)
        for v in s.variants:
            if spp not in ladders[v.label]:
                continue
            if v.engine == "principled":
                img, sec = base_img, principled[spp]
            else:
                img, sec = render_variant(stack, v, s.res, spp, seed=REFERENCE_SEED if v.engine == "reference" else 0)
            curves[v.label].points.append({"spp": spp, "seconds": sec, "x_principled": sec / principled[spp],
                                           **_errors(img, ref, mask)})
            if bar is not None:
                bar.update(1)
    index = load_index()["cases"][name]
    return {"stack": name, "noise_rmse": index["noise_rmse"] * (s.res / index["res"]),
            "curves": {k: c.points for k, c in curves.items()}}


# ---------------------------------------------------------------- resuming
PARTIAL_DIR = REPO / "cache" / "pareto"


def fingerprint(name: str, s: Settings) -> str:
    """What a stack's stored measurements depend on, hashed: the settings, the stack, ``auto``'s
    lobes (energies and roughnesses at 0 to 75 degrees), the stored reference (its index entry and
    its file's bytes) and Blender's version. Not in it: the code that turns lobes into a shader
    (staging, the emitters, the node groups) and the machine, whose speed the time ratios do not
    depend on; after a change there, run without ``--resume`` (it is asked for, never implied)."""
    import bpy

    from lamella.core import api

    stack = suite.load(name)
    reference = hashlib.sha256((IMAGE_REFERENCE_DIR / f"{name}.exr").read_bytes()).hexdigest()
    lobes = []
    for deg in (0.0, 30.0, 45.0, 60.0, 75.0):
        lb = api.lobes(stack, suite.incident(deg))
        lobes.append([list(lb.kinds)] + [np.round(np.asarray(x, dtype=np.float64), 6).tolist()
                                         for x in (lb.weight, lb.alpha_x, lb.alpha_y, lb.rotation)])
    settings = {"res": s.res, "ladder": s.ladder, "brute_ladder": s.brute_ladder,
                "variants": [(v.label, v.engine, str(v.budget)) for v in s.variants], "pixels": PIXELS}
    text = json.dumps({"settings": settings, "stack": stack.to_dict(), "lobes": lobes, "reference": reference,
                       "index": load_index()["cases"].get(name), "blender": list(bpy.app.version)}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _partial_path(name: str, quick: bool) -> Path:
    return PARTIAL_DIR / ("quick" if quick else "full") / f"{name}.json"


def load_partial(name: str, s: Settings, quick: bool) -> dict | None:
    """The stored measurements of stack ``name`` if their fingerprint matches, else None."""
    path = _partial_path(name, quick)
    if not path.exists():
        return None
    stored = json.loads(path.read_text())
    return stored["row"] if stored.get("fingerprint") == fingerprint(name, s) else None


def save_partial(row: dict, stamp: str, quick: bool) -> None:
    """Keep one stack's measurements under ``stamp``, its ``fingerprint`` taken before it rendered."""
    path = _partial_path(row["stack"], quick)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps({"fingerprint": stamp, "row": row}))
    tmp.replace(path)


# ---------------------------------------------------------------- cost sweeps
def _coats_stack(n: int) -> Stack:
    coat = {"type": "coat", "ior": 1.5, "roughness": 0.05}
    return Stack.from_dict({"name": f"{n} coats", "layers": [dict(coat, roughness=0.02 + 0.03 * k) for k in range(n)],
                            "base": {"type": "conductor", "eta": [0.18, 0.42, 1.37], "k": [3.42, 2.35, 1.77],
                                     "roughness": 0.1}})


def _depth_stack(depth: float) -> Stack:
    return Stack.from_dict({"name": f"fog d{depth:g}", "layers": [
        {"type": "coat", "ior": 1.3, "roughness": 0.1, "thickness": depth, "sigma_s": [1.0, 1.0, 1.0],
         "sigma_a": [0.02, 0.05, 0.1], "g": 0.6}],
        "base": {"type": "conductor", "eta": [0.18, 0.42, 1.37], "k": [3.42, 2.35, 1.77], "roughness": 0.1}})


COST_VARIANTS = (Variant("osl auto", "cycles-osl"), Variant("nodes svm", "cycles-nodes"), Variant("nodes eevee", "eevee"))
COST_REFERENCE = {"cycles-osl": "principled", "cycles-nodes": "principled-svm", "eevee": "eevee-principled"}


def cost_sweep(stacks: list[tuple[float, Stack]], s: Settings, bar=None) -> list[dict]:
    """Render-time ratio to the Principled stand-in (in the same shading system) of each staged
    variant on each stack, with the closures it kept."""
    from lamella.core.backends.ir.staging import stage

    rows = []
    for x, stack in stacks:
        row = {"x": x, "closures": len(stage(stack).closures)}
        for v in COST_VARIANTS:
            _, ref = render_variant(stack, Variant("ref", COST_REFERENCE[v.engine]), s.res, s.cost_spp)
            _, sec = render_variant(stack, v, s.res, s.cost_spp)
            row[v.label] = sec / ref
            if bar is not None:
                bar.update(1)
        rows.append(row)
    return rows


# ---------------------------------------------------------------- equal time
def _loglog(xs, ys, x):
    """y at x on the piecewise log-log line through (xs, ys) (xs increasing)."""
    lx, ly = np.log(xs), np.log(ys)
    if len(xs) == 1:
        return float(ys[0])
    k = int(np.clip(np.searchsorted(lx, math.log(x)) - 1, 0, len(xs) - 2))
    t = (math.log(x) - lx[k]) / (lx[k + 1] - lx[k])
    return float(math.exp(ly[k] + t * (ly[k + 1] - ly[k])))


def time_unit(row: dict) -> float:
    """The stack's time unit: the Principled stand-in's render at the ladder's largest sample
    count, in the same run (every variant's wall time is plotted over it)."""
    return row["curves"]["principled"][-1]["seconds"]


def _brute_error_at(t: np.ndarray, e: np.ndarray, floor: float, at: float) -> float:
    """The brute force's error at wall time ``at``: log-log interpolation between its renders,
    and beyond them the Monte Carlo rate anchored at the nearest (error^2 - floor^2 proportional
    to 1 / time)."""
    if t[0] <= at <= t[-1]:
        return _loglog(t, e, at)
    k = 0 if at < t[0] else -1
    return float(math.sqrt(floor ** 2 + max(e[k] ** 2 - floor ** 2, 0.0) * t[k] / at))


def equal_time(row: dict, ours: str = "osl auto", metric: str = "rmse") -> dict | None:
    """Our error at our largest sample count and its wall time; the brute force's error in that
    same time; and the time the brute force needs for our error, as a multiple of ours (None:
    never, our error is below its noise floor). Times are seconds in the same run."""
    mine, brute = row["curves"].get(ours), row["curves"].get("brute force")
    if not mine or not brute:
        return None
    last = mine[-1]
    t = np.array([p["seconds"] for p in brute])
    e = np.array([p[metric] for p in brute])
    floor = row["noise_rmse"] if metric == "rmse" else 0.0
    goal = last[metric]
    reached = [p["seconds"] for p in brute if p[metric] <= goal]
    if reached:
        need = min(reached)
    elif goal > floor:
        c = (e[-1] ** 2 - floor ** 2) * t[-1]  # the Monte Carlo rate from the longest render
        need = c / (goal ** 2 - floor ** 2) if c > 0 else None
    else:
        need = None
    return {"ours": ours, "ours_spp": last["spp"], "ours_seconds": last["seconds"], "ours_error": goal,
            "brute_error_then": _brute_error_at(t, e, floor, last["seconds"]),
            "brute_x_needed": None if need is None else need / last["seconds"]}


# ---------------------------------------------------------------- the run
def run(out_dir: Path = BENCH_DIR, quick: bool = False, cases=None, progress: bool = True,
        resume: bool = False) -> Path:
    """Every stack's curves and the cost sweeps, then the page. ``resume``: a stack whose stored
    measurements still match (``load_partial``) is not rendered again."""
    import bpy  # noqa: F401  (the renders)
    from tqdm import tqdm

    s = QUICK if quick else FULL
    if cases:
        s = Settings(**{**s.__dict__, "cases": tuple(cases)})
    stored = {name: load_partial(name, s, quick) for name in s.cases} if resume else {}
    todo = [name for name in s.cases if stored.get(name) is None]
    per_stack = sum(len(s.brute_ladder if v.engine == "reference" else s.ladder) for v in s.variants) + len(s.ladder)
    n_renders = len(todo) * per_stack + (len(s.coats) + len(s.depths)) * len(COST_VARIANTS)
    if resume:
        print(f"pareto: {len(s.cases) - len(todo)} of {len(s.cases)} stacks measured already, {len(todo)} to render")
    with tqdm(total=n_renders, desc="pareto renders", disable=not progress, unit="render") as bar:
        rows = []
        for name in s.cases:
            row = stored.get(name)
            if row is None:
                stamp = fingerprint(name, s)
                row = stack_curves(name, s, bar)
                save_partial(row, stamp, quick)
            rows.append(row)
        coats = cost_sweep([(n, _coats_stack(n)) for n in s.coats], s, bar)
        depths = cost_sweep([(d, _depth_stack(d)) for d in s.depths], s, bar)
    data = {"settings": {"res": s.res, "ladder": s.ladder, "brute_ladder": s.brute_ladder, "cost_spp": s.cost_spp,
                         "quick": quick, "pixels": PIXELS},
            "stacks": rows, "coats": coats, "depths": depths,
            "equal_time": [dict(stack=r["stack"], **et) for r in rows if (et := equal_time(r)) is not None]}
    return _write(Path(out_dir), "pareto_quick" if quick else "pareto", data)


def rewrite(out_dir: Path = BENCH_DIR, quick: bool = False) -> Path:
    """The tables and plots again from the stored measurements (``pareto.json``), without
    rendering: the equal-time view recomputed from them."""
    out_dir = Path(out_dir)
    stem = "pareto_quick" if quick else "pareto"
    data = json.loads((out_dir / f"{stem}.json").read_text())
    data["equal_time"] = [dict(stack=r["stack"], **et) for r in data["stacks"] if (et := equal_time(r)) is not None]
    return _write(out_dir, stem, data)


def _write(out_dir: Path, stem: str, data: dict) -> Path:
    """The data, then the plots (``out_dir/plots``) and the page."""
    def page() -> str:
        plots = write_plots(data, out_dir / "plots", stem)
        return format_markdown(data, {k: p.relative_to(out_dir).as_posix() for k, p in plots.items()})

    return write_page(out_dir, stem, page, data)


def write_plots(data: dict, plot_dir: Path, stem: str) -> dict:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..plots import save_figure

    rows = data["stacks"]
    cols = min(4, len(rows))
    nrows = -(-len(rows) // cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(3.2 * cols, 2.6 * nrows), squeeze=False)
    from matplotlib.ticker import NullFormatter

    for ax, r in zip(axes.flat, rows):
        unit = time_unit(r)
        for label, pts in r["curves"].items():
            if pts:
                ax.plot([p["seconds"] / unit for p in pts], [p["rmse"] for p in pts],
                        "o-" if label != "brute force" else "s--", ms=3, lw=1, label=label)
        ax.axhline(r["noise_rmse"], color="0.6", lw=0.8, ls=":")
        ax.set_xscale("log")
        ax.set_yscale("log")
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_minor_formatter(NullFormatter())
        ax.set_title(r["stack"], fontsize=8)
        ax.tick_params(labelsize=6)
    for ax in list(axes.flat)[len(rows):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=5)
    fig.supxlabel(f"wall time / the Principled stand-in's at {max(data['settings']['ladder'])} samples "
                  "(points: the sample ladder)", fontsize=8)
    fig.supylabel("RMSE against the converged reference (dotted: its own noise)", fontsize=8)
    out = {"pareto": save_figure(fig, plot_dir / f"{stem}_fronts.png")}

    fig, axes = plt.subplots(1, 2, figsize=(8, 3))
    for ax, key, xlabel, logx in ((axes[0], "coats", "clear coats over gold", False),
                                  (axes[1], "depths", "optical depth of a scattering coat", True)):
        rows_ = data[key]
        for v in COST_VARIANTS:
            ax.plot([r["x"] for r in rows_], [r[v.label] for r in rows_], "o-", ms=3, label=v.label)
        ax.axhline(1.0, color="0.6", lw=0.8, ls=":")
        ax.set_xlabel(xlabel, fontsize=8)
        if logx:
            ax.set_xscale("log")
        ax.set_ylim(0, max(2.5, max(r[v.label] for r in rows_ for v in COST_VARIANTS) * 1.1))
        ax.tick_params(labelsize=7)
    axes[0].set_ylabel("time / Principled (same shading system)", fontsize=8)
    axes[0].legend(fontsize=6)
    out["cost"] = save_figure(fig, plot_dir / f"{stem}_cost.png")
    return out


def error_pixels(settings: dict) -> str:
    """What the stored errors were taken over, said once for the page (the settings record it)."""
    if settings.get("pixels", "frame") == "sphere":
        return "over the pixels the sphere covers (`image_references.sphere_mask`)"
    return ("over every pixel of the frame, background included: these measurements predate the geometric "
            "sphere mask (the mask then read the renders' alpha, which is 1 everywhere), which dilutes every "
            "error alike, and the time ratios do not depend on it; re-run `lamella bench pareto` to measure "
            "them over the sphere")


def format_markdown(data: dict, plots: dict) -> str:
    st = data["settings"]
    lines = [
        "# Run time against error",
        "",
        f"Generated by `lamella bench pareto{' --quick' if st['quick'] else ''}` (`lamella_dev/bench/pareto.py`): "
        f"`sphere-env`, {st['res']} px, samples {', '.join(map(str, st['ladder']))} "
        f"(brute force {', '.join(map(str, st['brute_ladder']))}); time is each render's wall time over the "
        "Principled stand-in's at the same samples in the same run (Cycles, OSL on); error (RMSE, ΔE00, FLIP) "
        f"against the stored converged nested-sphere reference, {error_pixels(st)}. "
        "*floor*: the reference's own noise (RMSE).",
        "",
        f"![Pareto fronts]({plots['pareto']})",
        "",
        "## At the largest sample count",
        "",
        "| stack | floor | " + " | ".join(data["stacks"][0]["curves"]) + " |",
        "|---|---:|" + "---:|" * len(data["stacks"][0]["curves"]),
    ]
    for r in data["stacks"]:
        cells = []
        for pts in r["curves"].values():
            p = pts[-1] if pts else None
            cells.append(f"{p['rmse']:.4f} / {p['delta_e00']:.2f} / {p['flip']:.3f} @ {p['x_principled']:.2f}x"
                         if p else "")
        lines.append(f"| {r['stack']} | {r['noise_rmse']:.4f} | " + " | ".join(cells) + " |")
    lines += ["", "Cells: RMSE / mean ΔE00 / mean FLIP @ time ratio.", "",
              "## Equal time: the staged shader (`osl auto`) against brute force", "",
              "Our render at the largest sample count and its wall time; the brute force's RMSE in the same wall "
              "time (between its renders log-log, beyond them at the Monte Carlo rate); the wall time the brute force "
              "needs to reach our RMSE, as a multiple of ours (past its longest render: the Monte Carlo rate).", "",
              "| stack | ours: spp, seconds | ours: RMSE | brute force's RMSE in that time | time brute force needs |",
              "|---|---:|---:|---:|---:|"]
    for e in data["equal_time"]:
        need = f"{e['brute_x_needed']:.1f}x ours" if e["brute_x_needed"] is not None else "never (below its floor)"
        lines.append(f"| {e['stack']} | {e['ours_spp']}, {e['ours_seconds']:.1f} s | {e['ours_error']:.4f} | "
                     f"{e['brute_error_then']:.4f} | {need} |")
    lines += ["", "## Cost against stack size", "", f"![Cost]({plots['cost']})", "",
              f"{st['cost_spp']} samples; time over the Principled stand-in's in the same shading system.", "",
              "| stack | closures | " + " | ".join(v.label for v in COST_VARIANTS) + " |",
              "|---|---:|" + "---:|" * len(COST_VARIANTS)]
    for key, fmt in (("coats", "{:g} clear coats over gold"), ("depths", "scattering coat, optical depth {:g}")):
        for r in data[key]:
            lines.append(f"| {fmt.format(r['x'])} | {r['closures']} | "
                         + " | ".join(f"{r[v.label]:.2f}" for v in COST_VARIANTS) + " |")
    return "\n".join(lines) + "\n"


def _arguments(parser) -> None:
    cases_argument(parser)
    parser.add_argument("--quick", action="store_true", help="one scattering stack, 32 px, two sample counts")
    parser.add_argument("--replot", action="store_true", help="tables and plots again from the stored pareto.json")
    parser.add_argument("--resume", action="store_true",
                        help="reuse each stack's measurements kept by an earlier run (cache/pareto) while they match")


def _bench(out_dir: Path, args) -> Path:
    if args.replot:
        return rewrite(out_dir, quick=args.quick)
    return run(out_dir, quick=args.quick, cases=args.cases or None, resume=args.resume)


BENCH = register(Bench("pareto", "run time against error for every way a stack renders; cost against stack size",
                       _bench, _arguments))
