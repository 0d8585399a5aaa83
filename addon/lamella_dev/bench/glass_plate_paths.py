"""`lamella bench glass-plate-paths`: the light a rough glass plate reflects, split by how many
times it met the plate's lower face, from the stochastic reference's walk.

For each incidence and each yardstick (interfaces that scatter once; interfaces that scatter as
often as their microsurface makes them, Heitz et al. 2016), the reflected light of the packets
that met the base 0 times (the top interface alone), once, twice, and three or more times: its
share of the directional albedo and its spread. The spread is read off the half vector of the
light's exit direction and the incidence, as the GGX roughness with the same energy-weighted
median |slope| along and across the plane of incidence: the marginal of a GGX slope distribution
of roughness alpha has median |slope| alpha / sqrt(3). *centre* is the signed median slope along
the plane (positive: toward grazing on the mirror side). The top interface's own light (0
meetings) is the measure's control: it is one GGX interface of the stack's roughness, 0.1. The
measure reads reflected light, whose half vectors are the visible normals that masking lets out,
so it reads a little under a lobe's alpha toward grazing and on rougher surfaces (0.265 for one
glass surface of alpha 0.3 at normal incidence, `tests/unit/test_reference.py`).

The model's lobes (``auto``) are listed beside it: the top interface's lobe, and one lobe for all
the light that met the base, about the mirror direction (energy / roughness along / across the
plane of incidence, where the two differ). *What the spread
buys*: the relative L1 against the energy-conserving reference (as `bench/accuracy.md`) of the
model's lobes, then of the same with the base lobe given the walk's spread (a GGX lobe with axes
along and across the plane of incidence, the roughnesses of *all that met the base* in the
energy-conserving walk), at the model's energy and at the walk's.

*Where the light leaves* places each path's exit directions: light that met the lower face three
times or more leaves at the same angles from the normal whatever the incidence, spread in azimuth
about the incidence plane (a ring, not a lobe about the mirror direction).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from lamella.core import api
from lamella.core.backends.numpy_ops import NumpyOps
from .. import reference, suite
from ..metrics import relative_l1
from ..path_fit import direction_inputs, lobe_shape
from .accuracy import load_reference, reference_by_symmetry
from .paths import REFERENCE_DIR_MULTIPLE
from .page import write_page
from .registry import Bench, register

CASE = "rough_glass_plate"
ANGLES = (0.0, 30.0, 45.0, 60.0, 75.0)
CLASSES = ((0, 0, "0"), (1, 1, "1"), (2, 2, "2"), (3, None, "3+"))  # base meetings: first, last (None: any more)
SPP = 1 << 19


def quantile(x: np.ndarray, energy: np.ndarray, p: float) -> float:
    """The energy-weighted ``p`` quantile of ``x``."""
    order = np.argsort(x)
    c = np.cumsum(energy[order])
    return float(x[order][np.searchsorted(c, p * c[-1])])


def spread(wi: np.ndarray, up: np.ndarray, energy: np.ndarray) -> dict:
    """GGX-equivalent roughness along and across the plane of incidence (x, z) of light leaving
    along ``up`` (M, 3) with ``energy`` (M,), and the signed median slope along it."""
    h = up + wi[None, :]
    h = h / np.linalg.norm(h, axis=1, keepdims=True)
    along, across = h[:, 0] / h[:, 2], h[:, 1] / h[:, 2]
    if wi[0] > 0.0:
        along = -along  # positive toward grazing on the mirror side

    return {"alpha_along": math.sqrt(3.0) * quantile(np.abs(along), energy, 0.5),
            "alpha_across": math.sqrt(3.0) * quantile(np.abs(across), energy, 0.5),
            "centre": quantile(along, energy, 0.5)}


def spread_buys(stack, deg: float, model: list[dict], base_light: dict) -> dict:
    """Relative L1 against the stored energy-conserving reference at ``deg`` of the model's
    reflection lobes (``model``: top, base), and of the same with the base lobe anisotropic with
    ``base_light``'s roughnesses, axes along and across the plane of incidence, at the model's
    energy and at the walk's (``base_light["energy"]``)."""
    ref = load_reference(CASE, REFERENCE_DIR_MULTIPLE)
    i = [float(x) for x in ref["wi_degrees"]].index(deg)
    wi, wo, w = suite.incident(deg), ref[f"wo_{i}"], ref[f"weight_{i}"]
    f_ref, _ = reference_by_symmetry(ref, i, stack)
    ops = NumpyOps(np.float64)
    wi_vals, wo_vals = direction_inputs(ops, wi, wo)
    azimuth = float(np.arctan2(wi[1], wi[0]))

    def l1(lobes):
        f = sum(e * lobe_shape(ops, wi_vals, wo_vals, w, "reflection", ax, ay, rot) for e, ax, ay, rot in lobes)
        return relative_l1(np.repeat(f[:, None], 3, 1), f_ref, w)

    (top, base) = model
    top_lobe = (top["energy"], top["alpha_x"], top["alpha_y"], top["rotation"])
    walk = (base_light["alpha_along"], base_light["alpha_across"], azimuth)
    return {"model": l1([top_lobe, (base["energy"], base["alpha_x"], base["alpha_y"], base["rotation"])]),
            "walk_spread": l1([top_lobe, (base["energy"], *walk)]),
            "walk_spread_energy": l1([top_lobe, (base_light["energy"], *walk)])}


def exits(wi: np.ndarray, up: np.ndarray, energy: np.ndarray) -> dict:
    """Energy-weighted quantiles of the exit direction's angle from the normal (``theta``: 25, 50
    and 75 %) and of its azimuth from the mirror direction's (``azimuth``, absolute: 50 and 90 %),
    in degrees."""
    theta = np.degrees(np.arccos(np.clip(up[:, 2], -1.0, 1.0)))
    mirror = math.atan2(-wi[1], -wi[0]) if np.hypot(wi[0], wi[1]) > 0.0 else 0.0
    azimuth = np.abs(np.degrees(np.angle(np.exp(1j * (np.arctan2(up[:, 1], up[:, 0]) - mirror)))))
    return {"theta": [quantile(theta, energy, p) for p in (0.25, 0.5, 0.75)],
            "azimuth": [quantile(azimuth, energy, p) for p in (0.5, 0.9)]}


def rows(spp: int = SPP, seed: int = 5, progress=print) -> list[dict]:
    stack = suite.load(CASE)
    out = []
    for deg in ANGLES:
        wi = suite.incident(deg)
        lobes = api.lobes(stack, wi)
        model = [{"kind": k, "energy": float(np.mean(lobes.weight[0, j])), "alpha_x": float(lobes.alpha_x[0, j]),
                  "alpha_y": float(lobes.alpha_y[0, j]), "rotation": float(lobes.rotation[0, j])}
                 for j, k in enumerate(lobes.kinds) if k == "reflection"]
        for interfaces in ("single", "multiple"):
            up, energy, meetings = reference.reflected_paths(stack, wi, spp, seed, interfaces)
            e = energy.mean(1)
            row = {"wi": deg, "interfaces": interfaces, "albedo": float(e.sum() / spp), "model": model,
                   "model_albedo": float(np.mean(api.albedo(stack, wi)[0])), "classes": []}
            for first, last, label in CLASSES:
                sel = (meetings >= first) & ((meetings <= last) if last is not None else True)
                cls = {"meetings": label, "energy": float(e[sel].sum() / spp)}
                if sel.sum() > 100:
                    cls.update(spread(wi, up[sel], e[sel]))
                    cls["exits"] = exits(wi, up[sel], e[sel])
                row["classes"].append(cls)
            sel = meetings >= 1
            row["base_light"] = {"energy": float(e[sel].sum() / spp), **spread(wi, up[sel], e[sel])}
            if interfaces == "multiple":
                row["buys"] = spread_buys(stack, deg, model, row["base_light"])
            progress(f"{deg:g} degrees, {interfaces}: albedo {row['albedo']:.4f}")
            out.append(row)
    return out


def _markdown(data: list[dict], spp: int) -> str:
    lines = ["# A rough glass plate's reflected light, by its meetings with the lower face", "",
             f"Generated by `lamella bench glass-plate-paths` (`lamella_dev/bench/glass_plate_paths.py`; "
             f"`{CASE}`, {spp} packets per incidence and yardstick, `lamella_dev.reference.reflected_paths`).",
             "", (__doc__ or "").split("\n\n", 1)[1].strip(), "",
             "Each cell: share of the albedo / alpha along / alpha across / centre.", "",
             "| θi | interfaces | albedo (model) | 0 meetings | 1 | 2 | 3 or more | all that met the base | "
             "model: top lobe | model: base lobe | what the spread buys: model / walk's spread / and energy |",
             "|---:|---|---|---|---|---|---|---|---|---|---|"]

    def cell(c):
        if "alpha_along" not in c:
            return f"{c['energy']:.4f}"
        return f"{c['energy']:.4f} / {c['alpha_along']:.3f} / {c['alpha_across']:.3f} / {c['centre']:+.3f}"

    for r in data:
        m = r["model"]
        model = [f"{lobe['energy']:.4f} / {lobe['alpha_x']:.3f}"
                 + (f" / {lobe['alpha_y']:.3f}" if lobe["alpha_y"] != lobe["alpha_x"] else "") for lobe in m] + ["", ""]
        lines.append(f"| {r['wi']:g}° | {r['interfaces']} | {r['albedo']:.4f} ({r['model_albedo']:.4f}) | "
                     + " | ".join(cell(c) for c in r["classes"]) + f" | {cell(r['base_light'])} | "
                     + " | ".join(model[:2]) + " | "
                     + (" / ".join(f"{r['buys'][k]:.3f}" for k in ("model", "walk_spread", "walk_spread_energy"))
                        if "buys" in r else "") + " |")
    lines += ["", "## Where the light leaves (energy-conserving walk)", "",
              "Per path, the exit direction's angle from the normal (quartiles, degrees) and its azimuth "
              "from the mirror direction's (median and 90th percentile of its absolute value); at 0° the "
              "azimuth is the angle from the x axis.", "",
              "| θi | 0 meetings: θo / azimuth | 1 | 2 | 3 or more |", "|---:|---|---|---|---|"]
    for r in data:
        if r["interfaces"] != "multiple":
            continue
        lines.append(f"| {r['wi']:g}° | " + " | ".join(
            "{:.0f}-{:.0f}-{:.0f} / {:.0f}, {:.0f}".format(*c["exits"]["theta"], *c["exits"]["azimuth"])
            if "exits" in c else "" for c in r["classes"]) + " |")
    lines.append("")
    return "\n".join(lines)


def run(out_dir: Path, spp: int = SPP) -> Path:
    data = rows(spp)
    return write_page(out_dir, "glass_plate_paths", _markdown(data, spp), data)


BENCH = register(Bench("glass-plate-paths",
                       "a rough glass plate's reflected light split by its meetings with the lower face, from the walk",
                       lambda out_dir, args: run(out_dir)))
