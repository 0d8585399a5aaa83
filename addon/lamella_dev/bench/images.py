"""`lamella bench images`: every suite stack rendered by its generated OSL shader, by its node
group in EEVEE, and by the Principled BSDF stand-in artists use today (in Cycles and in EEVEE) in
the canonical ``sphere-env`` scene, compared with its stored nested-sphere reference
(``tests/references/images``), with the render times; EEVEE also against the OSL render.

Writes ``bench/images.md`` / ``.json`` and one comparison PNG per case
(``bench/images/<case>.png``: ours | reference | Principled | ΔE00 heat maps). The render
settings here (``RES``, ``SPP``, seed 0) are the ones the regression test re-renders with.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import suite
from lamella.core.exr import read_rgba
from ..image_metrics import delta_e00_map, display_srgb, image_errors
from ..arguments import count
from ..plots import save_figure
from .paths import BENCH_DIR
from .image_references import IMAGE_REFERENCE_DIR, RES, load_index, sphere_mask
from .page import write_page
from .registry import Bench, cases_argument, register

SPP = 64
BUDGET = "auto"  # the lobe budget of our shaders here: the default an artist gets
ENGINES = ("cycles-osl", "principled", "eevee", "eevee-principled")
# The noise control: the shader again at many samples (its own noise gone, the model's error and the
# reference's noise left), and the brute-force renderer itself at SPP (noise alone, no model error).
CONVERGED_SPP = 512
CONVERGED = "cycles-osl-converged"
BRUTE_FORCE = "brute-force"


def render_case(name: str, engine: str, spp: int = SPP, res: int = RES, budget=BUDGET):
    """(image, seconds). EEVEE renders twice and times the second render: its first compiles the
    material's shader (``bench/nodes.md`` has that time), the frame time is the second's."""
    from ..render import assign_material, build_scene, render_scene, render_stack

    if not engine.startswith("eevee"):
        return render_stack(suite.load(name), "sphere-env", res=res, spp=spp, engine=engine, seed=0, budget=budget)
    sc, sphere = build_scene("sphere-env", res, spp, seed=0)
    assign_material(sphere, suite.load(name), engine, budget=budget)
    render_scene(sc)
    return render_scene(sc)


def brute_force_case(name: str, meta: dict, spp: int = SPP, res: int = RES):
    """(image, seconds): the nested-sphere renderer that made the stored reference, at ``spp``
    samples with a seed the reference did not use (the same seed would repeat its first samples),
    its shells and interfaces as recorded in the reference's index entry ``meta``."""
    from ..render import render_stack

    return render_stack(suite.load(name), "sphere-env", res=res, spp=spp, engine="reference",
                        seed=max(meta["seeds"]) + 1, thickness=meta["shell_thickness"],
                        interfaces=meta.get("interfaces", "single"))


def compare_case(name: str, engine: str, spp: int = SPP, ref_dir: Path = IMAGE_REFERENCE_DIR, budget=BUDGET):
    """(figures dict, rendered image, reference image) for one case and engine, the shader's lobes
    merged to ``budget``."""
    ref = read_rgba(Path(ref_dir) / f"{name}.exr")
    img, seconds = render_case(name, engine, spp, ref.shape[0], budget)
    figures = image_errors(img, ref, sphere_mask(ref))
    figures.update({"case": name, "engine": engine, "spp": spp, "seconds": round(seconds, 2)})
    return figures, img, ref


def comparison_png(path: Path, name: str, images: dict, ref: np.ndarray, figures: dict, ref_spp=None) -> Path:
    """One row: each engine's render, the reference, then each engine's ΔE00 map."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    mask = sphere_mask(ref)
    panels = [(f"{e} ({figures[e]['seconds']:.1f} s)", display_srgb(im)) for e, im in images.items()]
    panels.insert(1, (f"reference ({ref_spp or '?'} spp)", display_srgb(ref)))
    maps = [(f"ΔE00 {e}: mean {figures[e]['delta_e00']:.2f}", np.where(mask, delta_e00_map(im, ref), np.nan))
            for e, im in images.items()]
    fig, axes = plt.subplots(1, len(panels) + len(maps), figsize=(3.0 * (len(panels) + len(maps)), 3.4))
    for ax, (title, im) in zip(axes, panels):
        ax.imshow(im)
        ax.set_title(title, fontsize=8)
    for ax, (title, m) in zip(axes[len(panels):], maps):
        h = ax.imshow(m, cmap="magma", vmin=0.0, vmax=10.0)
        ax.set_title(title, fontsize=8)
        fig.colorbar(h, ax=ax, fraction=0.046, pad=0.02)
    for ax in axes:
        ax.set_axis_off()
    fig.suptitle(f"{name}: {suite.descriptions()[name]}", fontsize=9)
    return save_figure(fig, path, dpi=90)


def run(cases=None, spp: int = SPP, out_dir: Path = BENCH_DIR, ref_dir: Path = IMAGE_REFERENCE_DIR,
        progress=print, interfaces: str = "single", converged_spp: int = CONVERGED_SPP) -> tuple[Path, Path]:
    """Every case of ``cases`` (default: every suite stack; with ``interfaces="multiple"``, every
    case stored in the energy-conserving set) against the references of ``interfaces``: the
    single-scattering set writes ``bench/images.md``, the energy-conserving one
    (``tests/references/images_multiple``) ``bench/images_multiple.md``. Beside the engines, the
    noise control: the OSL shader at ``converged_spp`` (0: left out) and the brute-force renderer at
    ``spp``."""
    from ..plots import contact_sheet
    from .image_references import IMAGE_REFERENCE_DIR_MULTIPLE

    stem = "images" if interfaces == "single" else "images_multiple"
    if interfaces == "multiple" and ref_dir == IMAGE_REFERENCE_DIR:
        ref_dir = IMAGE_REFERENCE_DIR_MULTIPLE
    index = load_index(ref_dir)
    if cases is None and interfaces == "multiple":
        cases = [n for n in suite.names() if n in index["cases"]]
    rows, sheet, captions = [], {}, {}
    for name in cases or suite.names():
        if name not in index["cases"]:
            raise FileNotFoundError(f"no stored image reference for {name}: run `lamella image-references --cases {name}`")
        figures, images = {}, {}
        for engine in ENGINES:
            f, img, ref = compare_case(name, engine, spp, ref_dir)
            figures[engine], images[engine] = f, img
            rows.append(f)
            progress(f"{name} {engine}: {f['seconds']:.1f} s, RMSE {f['rmse']:.4f}, ΔE00 {f['delta_e00']:.2f}")
        mask, meta = sphere_mask(ref), index["cases"][name]
        img, seconds = brute_force_case(name, meta, spp, ref.shape[0])
        brute = {**image_errors(img, ref, mask), "case": name, "engine": BRUTE_FORCE, "spp": spp,
                 "seconds": round(seconds, 2)}
        rows.append(brute)
        said = f"{name} noise control: brute force at {spp} spp ΔE00 {brute['delta_e00']:.2f}"
        if converged_spp:
            f, _, _ = compare_case(name, "cycles-osl", converged_spp, ref_dir)
            rows.append({**f, "engine": CONVERGED})
            said += f", ours at {converged_spp} spp ΔE00 {f['delta_e00']:.2f}"
        progress(said)
        vs_osl = image_errors(images["eevee"], images["cycles-osl"], mask)
        figures["eevee"]["vs_osl"] = {k: vs_osl[k] for k in ("rmse", "rmse_8px", "mean_bias", "delta_e00", "flip")}
        comparison_png(Path(out_dir) / stem / f"{name}.png", name, images, ref, figures,
                       index["cases"][name]["spp"])
        sheet[f"{name}: ours"], sheet[f"{name}: reference"] = images["cycles-osl"], ref
        captions[f"{name}: ours"] = f"{spp} spp, {figures['cycles-osl']['seconds']:.1f} s, ΔE00 {figures['cycles-osl']['delta_e00']:.2f}"
        captions[f"{name}: reference"] = f"{index['cases'][name]['spp']} spp nested spheres"
    contact_sheet(sheet, Path(out_dir) / stem / "contact_sheet.png", captions, ncols=4,
                  title="Generated OSL shader (ours) next to the brute-force reference, canonical sphere-env")
    mpath = write_page(out_dir, stem, lambda: format_markdown(rows, index, spp, interfaces),
                       {"spp": spp, "res": RES, "budget": BUDGET, "interfaces": interfaces,
                        "converged_spp": converged_spp, "rows": rows})
    return mpath, mpath.with_suffix(".json")


def format_markdown(rows: list[dict], index: dict, spp: int, interfaces: str = "single") -> str:
    energy = interfaces == "multiple"
    lines = [
        "# Image accuracy against the stored nested-sphere references"
        + (", energy-conserving interfaces" if energy else ""),
        "",
        *(["The nested spheres' rough interfaces keep the energy their microsurface scatters again "
           "(Cycles' multiscatter GGX: the single-scattering lobe scaled by 1 / E and darkened by Kulla and "
           "Conty 2017's multiple-bounce Fresnel), in `tests/references/images_multiple/`; only the cases "
           "rendered there so far. `lamella bench images --interfaces multiple`.", ""] if energy else []),
        f"Generated by `lamella bench images`: each suite stack rendered at {RES}×{RES}, {spp} spp, seed 0 in the",
        f"canonical `sphere-env` scene by its generated OSL shader (`cycles-osl`, lobe budget {BUDGET}), by its node group in EEVEE",
        "(`eevee`, shadows off as headless EEVEE needs here, the same samples) and by the Principled BSDF",
        "stand-in (`principled`, the baseline artists use today; `eevee-principled` in EEVEE), against the",
        "brute-force reference in",
        f"`tests/references/{'images_multiple' if energy else 'images'}/` (the stack as nested interface spheres, path traced; made by",
        f"`{index.get('command', 'lamella image-references')}`). Figures over the pixels the sphere fully covers:",
        "",
        "- **RMSE**: linear RGB, per pixel (includes both renders' noise; `ref noise` is the reference's own);",
        "- **RMSE 8px**: the same on 8×8-pixel tile means (divides per-pixel noise by 8, keeps model error);",
        "- **bias**: relative error of the mean radiance over the sphere (energy gained or lost);",
        "- **ΔE00**: mean CIEDE2000 after the fixed tone map (Reinhard per channel, D65);",
        "- **FLIP**: mean HDR-FLIP (flip-evaluator).",
        "",
        "Times are wall-clock seconds on this machine (2 cores), same run: compare the ratio, not the seconds.",
        "EEVEE's are its second render of the material (the first compiles the shader: `bench/nodes.md`).",
        "",
        "| case | ref spp | ref noise | engine | time s | RMSE | RMSE 8px | bias | ΔE00 | FLIP |",
        "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        meta = index["cases"][r["case"]]
        lines.append(f"| {r['case']} | {meta['spp']} | {meta['noise_rmse']:.4f} | {r['engine']} | {r['seconds']:.1f} | "
                     f"{r['rmse']:.4f} | {r['rmse_8px']:.4f} | {r['mean_bias']:+.3f} | {r['delta_e00']:.2f} | {r['flip']:.3f} |")
    lines += ["", "## Means over " + ("the cases stored" if energy else "the suite"), "",
              "| engine | time s | RMSE | RMSE 8px | |bias| | ΔE00 | FLIP |", "|---|---:|---:|---:|---:|---:|---:|"]
    for e in sorted({r["engine"] for r in rows}):
        rs = [r for r in rows if r["engine"] == e]
        mean = lambda k: float(np.mean([abs(r[k]) for r in rs]))  # noqa: E731
        lines.append(f"| {e} | {mean('seconds'):.1f} | {mean('rmse'):.4f} | {mean('rmse_8px'):.4f} | "
                     f"{mean('mean_bias'):.3f} | {mean('delta_e00'):.2f} | {mean('flip'):.3f} |")
    by = {(r["case"], r["engine"]): r for r in rows}
    noisy = [c for c, e in by if e == BRUTE_FORCE]
    if noisy:
        conv = next((r["spp"] for r in rows if r["engine"] == CONVERGED), None)
        lines += ["", "## Noise against model error (the noise control)", "",
                  "ΔE00 is not linear in the error: per-pixel noise alone raises it. `brute force` is the renderer "
                  f"that made the reference, at the same {spp} spp with a seed the reference did not use, against it: "
                  "it has no model error, so its ΔE00 is what the two renders' noise costs. `reference noise` "
                  "estimates the part of that which is the reference's own (its noise is sqrt(spp / ref spp) of the "
                  "brute force's; ΔE00 taken as proportional to the noise, which holds where noise dominates it)."
                  + (f" `ours at {conv} spp` is the OSL shader with its own noise gone: its ΔE00 is the model's error "
                     "and the reference's noise." if conv else ""), "",
                  f"| case | ref spp | ours at {spp} spp | brute force at {spp} spp (noise alone) | reference noise |"
                  + (f" ours at {conv} spp |" if conv else ""),
                  "|---|---:|---:|---:|---:|" + ("---:|" if conv else "")]

        def ref_noise(c):
            return by[(c, BRUTE_FORCE)]["delta_e00"] * float(np.sqrt(spp / (spp + index["cases"][c]["spp"])))

        for c in noisy:
            lines.append(f"| {c} | {index['cases'][c]['spp']} | {by[(c, 'cycles-osl')]['delta_e00']:.2f} | "
                         f"{by[(c, BRUTE_FORCE)]['delta_e00']:.2f} | {ref_noise(c):.2f} |"
                         + (f" {by[(c, CONVERGED)]['delta_e00']:.2f} |" if conv else ""))
        mean = lambda e: float(np.mean([by[(c, e)]["delta_e00"] for c in noisy]))  # noqa: E731
        lines.append(f"| **mean** | | {mean('cycles-osl'):.2f} | {mean(BRUTE_FORCE):.2f} | "
                     f"{float(np.mean([ref_noise(c) for c in noisy])):.2f} |" + (f" {mean(CONVERGED):.2f} |" if conv else ""))
    ev = [r for r in rows if r["engine"] == "eevee" and "vs_osl" in r]
    if ev:
        lines += ["", "## EEVEE against the Cycles OSL render of the same stack", "",
                  "What EEVEE's own approximations cost (anisotropy ignored, its closure handling, its lighting), "
                  "the model being the same:", "",
                  "| case | RMSE | RMSE 8px | bias | ΔE00 | FLIP |", "|---|---:|---:|---:|---:|---:|"]
        for r in ev:
            v = r["vs_osl"]
            lines.append(f"| {r['case']} | {v['rmse']:.4f} | {v['rmse_8px']:.4f} | {v['mean_bias']:+.3f} | "
                         f"{v['delta_e00']:.2f} | {v['flip']:.3f} |")
        mean = lambda k: float(np.mean([abs(r["vs_osl"][k]) for r in ev]))  # noqa: E731
        lines.append(f"| **mean** | {mean('rmse'):.4f} | {mean('rmse_8px'):.4f} | {mean('mean_bias'):.3f} | "
                     f"{mean('delta_e00'):.2f} | {mean('flip'):.3f} |")
    lines += ["", f"Comparison images (each engine | reference | ΔE00 maps): `bench/{'images_multiple' if energy else 'images'}/<case>.png`.", ""]
    return "\n".join(lines)


def _arguments(parser) -> None:
    cases_argument(parser)
    parser.add_argument("--interfaces", choices=["single", "multiple"], default="single",
                        help="against the single-scattering references (bench/images.md) or the energy-conserving "
                             "ones (tests/references/images_multiple, bench/images_multiple.md)")
    parser.add_argument("--converged-spp", type=count(lo=0), default=CONVERGED_SPP,
                        help="samples of the noise control's second OSL render (0: leave it out)")


BENCH = register(Bench("images",
                       "each suite stack's shader, node group and Principled stand-in against the image references",
                       lambda out_dir, args: run(args.cases or None, out_dir=out_dir, interfaces=args.interfaces,
                                                 converged_spp=args.converged_spp)[0],
                       _arguments))
