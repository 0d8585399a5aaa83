"""`lamella bench lobe-floor`: how close can one lobe per path get?

Two measurements against the stored energy-conserving references (``tests/references/brdf_multiple``).

**Every suite case** (``measure_paths``): the model's visible lobes (``auto``) with each one's
energy and roughness fitted to the reference (``lamella_dev.path_fit``). What remains is the floor
of the closures' shapes, per case and incidence: a model that got every path's energy and
roughness exactly right would still be that far from the reference, so the model's own error is
its relative L1 minus the floor (the column ``bench/accuracy.md`` shows beside ``auto``).

**Other shapes for one coat over a conductor** (``measure``): for the suite's stacks of one
isotropic coat over an isotropic conductor, ``auto`` emits two lobes, the coat's surface
reflection and the light that crossed the coat, met the base and came back out. This part keeps
the surface lobe as the model has it and replaces the base lobe by the best isotropic GGX lobe,
its roughness scanned on a log grid and its energy either the model's or the reference's albedo
minus the surface lobe's. Three candidate shapes are measured the same way: two GGX lobes about
the mirror direction for the base path (two roughnesses and the split of the energy scanned: a
path whose roughness distribution is bimodal); one GGX lobe about the mirror of a tilted incidence
(the incidence angle of the lobe and its roughness scanned: a lobe off the specular direction);
and one GGX lobe with its roughness along and across the incidence plane scanned separately.

Both lobes are normalised over the same half-vector grid as the metric (``suite.wo_grid``), so
the comparison isolates shape from the grid's quadrature.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from lamella.core import api
from .. import suite
from lamella.core.backends.numpy_ops import NumpyOps
from ..metrics import relative_l1
from lamella.core.models.ggx import ggx_lobe_cos
from .paths import BENCH_DIR, REFERENCE_DIR_MULTIPLE
from .accuracy import load_reference, reference_by_symmetry, reference_noise
from ..path_fit import fit_paths
from .page import write_page
from .registry import Bench, register

ALPHAS = np.geomspace(0.01, 1.0, 81)  # the scan of the base lobe's roughness
PAIR_ALPHAS = np.geomspace(0.01, 1.0, 41)  # the two lobes' roughnesses (every pair)
SPLITS = np.linspace(0.0, 1.0, 21)  # the first of two lobes' share of the energy
TILT_STEP = 2.5  # degrees: the tilted lobe's incidence, scanned within 30 degrees of the view


def cases() -> list[str]:
    """Suite stacks of one isotropic coat over an isotropic conductor (two lobes under ``auto``)."""
    out = []
    for name in suite.names():
        st = suite.load(name)
        layers = (*st.coats, st.base)
        if (len(st.coats) == 1 and st.base.type == "conductor" and not st.has_scattering
                and all(layer.roughness[0] == layer.roughness[1] for layer in layers)):
            out.append(name)
    return out


def _shape(ops, wi, wo, weight, alpha):
    """A GGX lobe of roughness ``alpha`` about the mirror direction, f cos, unit integral on the grid."""
    wib = np.broadcast_to(wi, wo.shape)
    v = ggx_lobe_cos(ops, tuple(wib.T), tuple(wo.T), alpha, alpha, 1.0, 0.0)
    return v / max(float((v * weight).sum()), 1e-12)


def _aniso_floor(ops, wi, wo, w, top, energy, f_ref) -> tuple[float, float, float]:
    """The best GGX lobe with axes along (x) and across (y) the incidence plane (wi has azimuth 0):
    (relative L1, alpha_x, alpha_y), both roughnesses scanned on ``ALPHAS``."""
    wib = np.broadcast_to(wi, wo.shape)
    best = (np.inf, 0.0, 0.0)
    for ax in ALPHAS:
        v = ggx_lobe_cos(ops, tuple(wib.T), tuple(wo.T), ax, ALPHAS[:, None], 1.0, 0.0)
        v = v / np.maximum((v * w).sum(-1, keepdims=True), 1e-12)
        for k, ay in enumerate(ALPHAS):
            err = relative_l1(top + energy[None] * v[k][:, None], f_ref, w)
            if err < best[0]:
                best = (err, float(ax), float(ay))
    return best


def _two_lobe_floor(ops, wi, wo, w, top, energy, f_ref) -> tuple[float, float, float, float]:
    """The best pair of GGX lobes about the mirror direction: (relative L1, alpha_1, alpha_2, the
    first's share of ``energy``), every pair of ``PAIR_ALPHAS`` and share of ``SPLITS``."""
    shapes = np.stack([_shape(ops, wi, wo, w, a) for a in PAIR_ALPHAS])
    resid = f_ref - top
    den = np.maximum((f_ref * w[:, None]).sum(0), 1e-30)  # as metrics.relative_l1
    best = (np.inf, 0.0, 0.0, 0.0)
    for i in range(len(PAIR_ALPHAS)):
        for j in range(i + 1, len(PAIR_ALPHAS)):
            mix = SPLITS[:, None] * shapes[i][None] + (1.0 - SPLITS[:, None]) * shapes[j][None]
            err = ((np.abs(energy[None, None] * mix[:, :, None] - resid[None]) * w[None, :, None]).sum(1) / den).mean(-1)
            k = int(np.argmin(err))
            if err[k] < best[0]:
                best = (float(err[k]), float(PAIR_ALPHAS[i]), float(PAIR_ALPHAS[j]), float(SPLITS[k]))
    return best


def _tilted_floor(ops, wi, wo, w, top, energy, f_ref, theta: float) -> tuple[float, float, float]:
    """The best GGX lobe about the mirror direction of an incidence tilted in the incidence plane:
    (relative L1, its incidence in degrees, alpha), the incidence within 30 degrees of ``theta``."""
    best = (np.inf, theta, 0.0)
    for tilt in np.arange(max(0.0, theta - 30.0), min(89.0, theta + 30.0) + 1e-9, TILT_STEP):
        wv = np.broadcast_to(suite.incident(float(tilt)), wo.shape)
        v = ggx_lobe_cos(ops, tuple(wv.T), tuple(wo.T), ALPHAS[:, None], ALPHAS[:, None], 1.0, 0.0)
        v = v / np.maximum((v * w).sum(-1, keepdims=True), 1e-12)
        for k, a in enumerate(ALPHAS):
            err = relative_l1(top + energy[None] * v[k][:, None], f_ref, w)
            if err < best[0]:
                best = (err, float(tilt), float(a))
    return best


def measure(names=None) -> list[dict]:
    """The rows of ``names`` (default: every case of ``cases``)."""
    ops = NumpyOps(np.float64)
    rows = []
    for name in names or cases():
        stack = suite.load(name)
        ref = load_reference(name, REFERENCE_DIR_MULTIPLE)
        for i, deg in enumerate(ref["wi_degrees"]):
            wi = suite.incident(float(deg))
            wo, w, f_ref = ref[f"wo_{i}"], ref[f"weight_{i}"], ref[f"mean_{i}"]
            lb = api.lobes(stack, wi, "auto")
            top = lb.weight[0, 0][None] * _shape(ops, wi, wo, w, lb.alpha_x[0, 0])[:, None]
            e_model = lb.weight[0, 1]
            e_ref = np.maximum((f_ref * w[:, None]).sum(0) - lb.weight[0, 0], 0.0)

            def err(energy, alpha):
                return relative_l1(top + energy[None] * _shape(ops, wi, wo, w, alpha)[:, None], f_ref, w)

            best_m = min((err(e_model, a), a) for a in ALPHAS)
            best_r = min((err(e_ref, a), a) for a in ALPHAS)
            aniso = _aniso_floor(ops, wi, wo, w, top, e_ref, f_ref)
            two = _two_lobe_floor(ops, wi, wo, w, top, e_ref, f_ref)
            tilted = _tilted_floor(ops, wi, wo, w, top, e_ref, f_ref, float(deg))
            rows.append({"case": name, "wi": float(deg), "model": lb.model,
                         "alpha_model": float(lb.alpha_x[0, 1]),
                         "rel_l1_auto": relative_l1(api.evaluate(stack, wi, wo, "auto", deltas=False), f_ref, w),
                         "rel_l1_model_shape": err(e_model, lb.alpha_x[0, 1]),
                         "alpha_best": float(best_m[1]), "rel_l1_best_alpha": float(best_m[0]),
                         "alpha_best_ref_energy": float(best_r[1]), "rel_l1_floor": float(best_r[0]),
                         "rel_l1_floor_aniso": aniso[0], "alpha_along": aniso[1], "alpha_across": aniso[2],
                         "rel_l1_floor_two": two[0], "two_alphas": [two[1], two[2]], "two_share": two[3],
                         "rel_l1_floor_tilted": tilted[0], "tilted_theta": tilted[1], "tilted_alpha": tilted[2],
                         "ref_noise": reference_noise(ref, i)})
    return rows


def measure_paths(names=None, progress: bool = False) -> list[dict]:
    """Per suite case (default: every one) and stored incidence: ``auto``'s relative L1 and its
    floor, the same lobes with every energy and roughness fitted to the reference (the reference
    averaged over the directions the stack cannot tell apart, as ``bench/accuracy.md`` measures),
    and the two partial fits that tell the model's error apart (``path_fit``'s ``fit``): the
    roughnesses alone, every lobe keeping the model's energy (*widths*), and the energies alone."""
    from tqdm import tqdm

    rows = []
    for name in tqdm(names or suite.names(), desc="lobe-floor", disable=not progress):
        stack = suite.load(name)
        ref = load_reference(name, REFERENCE_DIR_MULTIPLE)
        for i, deg in enumerate(ref["wi_degrees"]):
            f_ref, _ = reference_by_symmetry(ref, i, stack)
            args = (stack, suite.incident(float(deg)), ref[f"wo_{i}"], ref[f"weight_{i}"], f_ref)
            fit, plane = fit_paths(*args), fit_paths(*args, plane=True)
            widths, energies = fit_paths(*args, fit="roughness"), fit_paths(*args, fit="energies")
            rows.append({"case": name, "wi": float(deg), "model": api.lobes(stack, suite.incident(float(deg))).model,
                         "rel_l1_auto": fit.rel_l1_model, "rel_l1_floor": fit.rel_l1,
                         "above_floor": fit.rel_l1_model - fit.rel_l1, "kinds": list(fit.kinds),
                         "alphas_model": fit.alphas_model, "alphas_fit": fit.alphas, "energies_fit": fit.energies,
                         "rel_l1_floor_plane": min(plane.rel_l1, fit.rel_l1), "alphas_fit_plane": plane.alphas,
                         "rel_l1_widths": widths.rel_l1, "alphas_fit_widths": widths.alphas,
                         "rel_l1_energies": energies.rel_l1,
                         "ref_noise": reference_noise(ref, i)})
    return rows


def run(out_dir: Path = BENCH_DIR) -> Path:
    paths, rows = measure_paths(progress=True), measure()
    return write_page(out_dir, "lobe_floor", lambda: _markdown(paths, rows), {"paths": paths, "one_coat_shapes": rows})


def _paths_markdown(rows: list[dict]) -> list[str]:
    angles = sorted({r["wi"] for r in rows})
    md = ["## Every suite case: the model's lobes with their energies and roughnesses fitted", "",
          "Per case and incidence: *auto*, the model's relative L1 (deltas left out, as `bench/accuracy.md`); "
          "*floor*, the same lobes (kind and axes kept) with every energy (per channel) and roughness fitted to the "
          "reference (`lamella_dev/path_fit.py`); *above*, auto minus floor, the model's own error; *in plane*, the "
          "floor if every isotropic rough lobe were anisotropic with its axes along and across the plane of incidence "
          "(both roughnesses fitted: a closure the models do not emit yet); *noise*, the reference's. "
          "Each cell: auto / floor / **above** / in plane.", "",
          "| case | model | lobes | " + " | ".join(f"{a:g}°" for a in angles) + " | noise (mean) |",
          "|---|---|---:|" + "---|" * len(angles) + "---:|"]
    for name in dict.fromkeys(r["case"] for r in rows):
        sel = {r["wi"]: r for r in rows if r["case"] == name}
        first = next(iter(sel.values()))
        cells = [f"{sel[a]['rel_l1_auto']:.3f} / {sel[a]['rel_l1_floor']:.3f} / **{sel[a]['above_floor']:.3f}** / "
                 f"{sel[a]['rel_l1_floor_plane']:.3f}" if a in sel else "" for a in angles]
        md.append(f"| {name} | {first['model']} | {len(first['kinds'])} | " + " | ".join(cells)
                  + f" | {np.mean([r['ref_noise'] for r in sel.values()]):.3f} |")
    md += ["", "Over the suite, per incidence:", "",
           "| θi | auto median | floor median | above: median | above: mean | above: worst | cases above 0.05 | "
           "in-plane floor median |",
           "|---:|---:|---:|---:|---:|---|---:|---:|"]
    for a in angles:
        sel = [r for r in rows if r["wi"] == a]
        worst = max(sel, key=lambda r: r["above_floor"])
        md.append(f"| {a:g}° | {np.median([r['rel_l1_auto'] for r in sel]):.3f} | "
                  f"{np.median([r['rel_l1_floor'] for r in sel]):.3f} | {np.median([r['above_floor'] for r in sel]):.3f} | "
                  f"{np.mean([r['above_floor'] for r in sel]):.3f} | {worst['above_floor']:.3f} ({worst['case']}) | "
                  f"{sum(r['above_floor'] > 0.05 for r in sel)} / {len(sel)} | "
                  f"{np.median([r['rel_l1_floor_plane'] for r in sel]):.3f} |")
    md += ["", "### What the model's error above the floor is made of", "",
           "The same lobes with only their roughnesses fitted, each keeping the model's energy (*widths*: every "
           "path keeps its own light), and with only their energies fitted (*energies*: the model's roughnesses). "
           "Where *widths* is near the floor, the lobes' widths are the model's error; where only the full fit "
           "reaches the floor, the floor gives one path's light to another path's lobe (its energies are free "
           "per lobe) or needs both at once. Each cell: auto / widths / energies / floor; the (case, angle) pairs "
           "more than 0.05 above their floor at 0-60° in bold.", "",
           "| case | " + " | ".join(f"{a:g}°" for a in angles) + " |",
           "|---|" + "---|" * len(angles)]
    for name in dict.fromkeys(r["case"] for r in rows):
        sel = {r["wi"]: r for r in rows if r["case"] == name}
        md.append(f"| {name} | " + " | ".join(_parts_cell(sel[a]) if a in sel else "" for a in angles) + " |")
    md += ["", "| θi | pairs above 0.05 | of them, widths within 0.05 of the floor | energies within 0.05 | "
           "neither |", "|---:|---:|---:|---:|---:|"]
    for a in angles:
        above = [r for r in rows if r["wi"] == a and r["above_floor"] > 0.05]
        widths = sum(r["rel_l1_widths"] - r["rel_l1_floor"] <= 0.05 for r in above)
        energies = sum(r["rel_l1_energies"] - r["rel_l1_floor"] <= 0.05 for r in above)
        neither = sum(min(r["rel_l1_widths"], r["rel_l1_energies"]) - r["rel_l1_floor"] > 0.05 for r in above)
        md.append(f"| {a:g}° | {len(above)} | {widths} | {energies} | {neither} |")
    return md


def _parts_cell(r: dict) -> str:
    """auto / widths / energies / floor, bold where the pair is more than 0.05 above its floor at 0-60 degrees."""
    text = f"{r['rel_l1_auto']:.3f} / {r['rel_l1_widths']:.3f} / {r['rel_l1_energies']:.3f} / {r['rel_l1_floor']:.3f}"
    return f"**{text}**" if r["above_floor"] > 0.05 and r["wi"] <= 60.0 else text


def _markdown(paths: list[dict], rows: list[dict]) -> str:
    md = ["# One lobe per path: the floor of its shape", "",
          "`lamella bench lobe-floor` (`lamella_dev/bench/lobe_floor.py`), against the energy-conserving references.", ""]
    md += _paths_markdown(paths) + [""]
    return "\n".join(md + _shapes_markdown(rows))


def _shapes_markdown(rows: list[dict]) -> list[str]:
    angles = sorted({r["wi"] for r in rows})
    md = ["## One coat over a conductor: other shapes for the base path", "",
          "The suite's stacks of one isotropic coat over an isotropic conductor, "
          "against the energy-conserving references. *auto*: the model's relative L1. *best α*: the base lobe's "
          "roughness scanned (energy the model's). *base floor*: the base lobe alone fitted, roughness scanned and energy the reference's albedo "
          "minus the surface lobe's, i.e. the error left if energy and roughness were exact "
          "(`lamella_dev/bench/lobe_floor.py`). Other shapes for the base path, energy the reference's as for the base floor: "
          "*two lobes*: two GGX lobes about the mirror direction (roughnesses and energy split scanned); *tilted*: one "
          "GGX lobe about the mirror of another incidence in the incidence plane (that incidence and α scanned); "
          "*anisotropic*: two roughnesses, along and across the incidence plane. *noise*: the reference's own stderr "
          "on the metric (a floor of its own).", "",
          "| case | θi | model α → best α | auto | best α | base floor | two lobes (α, α, share) | tilted (θ, α) | "
          "anisotropic (α along, across) | noise |",
          "|---|---:|---|---:|---:|---:|---|---|---|---:|"]
    for r in rows:
        md.append(f"| {r['case']} | {r['wi']:g}° | {r['alpha_model']:.3f} → {r['alpha_best']:.3f} | "
                  f"{r['rel_l1_auto']:.3f} | {r['rel_l1_best_alpha']:.3f} | {r['rel_l1_floor']:.3f} | "
                  f"{r['rel_l1_floor_two']:.3f} ({r['two_alphas'][0]:.3f}, {r['two_alphas'][1]:.3f}, {r['two_share']:.2f}) | "
                  f"{r['rel_l1_floor_tilted']:.3f} ({r['tilted_theta']:g}°, {r['tilted_alpha']:.3f}) | "
                  f"{r['rel_l1_floor_aniso']:.3f} ({r['alpha_along']:.3f}, {r['alpha_across']:.3f}) | {r['ref_noise']:.3f} |")
    md += ["", "Median over these cases:", "", "| θi | auto | best α | base floor | two lobes | tilted | anisotropic | noise |",
           "|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for a in angles:
        sel = [r for r in rows if r["wi"] == a]
        md.append(f"| {a:g}° | {np.median([r['rel_l1_auto'] for r in sel]):.3f} | "
                  f"{np.median([r['rel_l1_best_alpha'] for r in sel]):.3f} | "
                  f"{np.median([r['rel_l1_floor'] for r in sel]):.3f} | "
                  f"{np.median([r['rel_l1_floor_two'] for r in sel]):.3f} | "
                  f"{np.median([r['rel_l1_floor_tilted'] for r in sel]):.3f} | "
                  f"{np.median([r['rel_l1_floor_aniso'] for r in sel]):.3f} | {np.median([r['ref_noise'] for r in sel]):.3f} |")
    return md


BENCH = register(Bench("lobe-floor",
                       "every case: the error left if each path's lobe had the reference's energy and roughness",
                       lambda out_dir, args: run(out_dir)))
