"""The models against the spectral stochastic reference on stacks with thin films: each model's
albedo and its relative L1 on the half-vector grid of ``suite.wo_grid`` (docs/design.md "Metrics",
as ``bench.accuracy`` computes them, the reference averaged over the directions the stack's
symmetry cannot tell apart), beside the same stack without its film, so that what the
film adds to a model's error shows.

    PYTHONPATH=addon python -m lamella_dev.film_accuracy [--spp 1024] [--albedo-spp 262144]
        [--interfaces multiple] [--models auto] [--no-bare]

prints a Markdown table (a few minutes on one core at the defaults).
"""
from __future__ import annotations

import argparse
import copy
import time

import numpy as np

from lamella.core import api
from lamella.core.stack import Stack
from . import reference, suite
from .bench.accuracy import _orbits, symmetrized, symmetry
from .metrics import albedo_error, relative_l1

GOLD = {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603]}


def _coat(ior, roughness, film_ior, film_nm):
    return {"type": "coat", "ior": ior, "roughness": roughness, "film_thickness": film_nm, "film_ior": film_ior}


STACKS = {
    "soap film on a rough clear coat over gold": {
        "layers": [_coat(1.5, 0.1, 1.33, 350.0)], "base": dict(GOLD, roughness=0.1)},
    "anodised titanium": {
        "layers": [], "base": {"type": "conductor", "eta": [2.74, 2.54, 2.2], "k": [3.8, 3.43, 3.0], "roughness": 0.1,
                               "film_thickness": 250.0, "film_ior": 2.3}},
    "soap film on a glass plate": {
        "layers": [_coat(1.5, 0.0, 1.33, 400.0)], "base": {"type": "dielectric", "ior": 1.0}},
    "oil film on water over a dark diffuse base": {
        "layers": [_coat(1.33, 0.02, 1.5, 300.0)], "base": {"type": "diffuse", "albedo": [0.04, 0.04, 0.04]}},
}
ANGLES = (0.0, 30.0, 60.0)


def without_film(d: dict) -> dict:
    out = copy.deepcopy(d)
    for layer in [*out["layers"], out["base"]]:
        layer.pop("film_thickness", None)
        layer.pop("film_ior", None)
    return out


def _all_delta(stack: Stack) -> bool:
    rough = [c.roughness for c in stack.coats]
    if stack.base.type != "diffuse":
        rough.append(stack.base.roughness)
    return stack.base.type != "diffuse" and all(max(np.atleast_1d(r)) == 0.0 for r in rough)


def measure(d: dict, spp: int, albedo_spp: int, interfaces: str, models=("auto",), seed: int = 1) -> list[dict]:
    """Rows (model, incidence, albedos and their errors, relative L1 where the stack has a density)
    for one stack."""
    stack = Stack.from_dict(d)
    transmits = stack.base.type == "dielectric"
    rows = []
    for k, deg in enumerate(ANGLES):
        wi = suite.incident(deg)
        s = seed + 10 * k
        a_ref, a_err = reference.albedo(stack, wi, spp=albedo_spp, seed=s, interfaces=interfaces)
        t_ref = t_err = None
        if transmits:
            t_ref, t_err = reference.albedo(stack, wi, spp=albedo_spp, seed=s, side="transmitted", interfaces=interfaces)
        f_ref = None
        if not _all_delta(stack):
            wo, weight = suite.wo_grid(wi)
            f_ref, f_err = reference.eval_brdf_cos(stack, wi, wo, spp=spp, seed=s + 1, interfaces=interfaces)
            kind = symmetry(stack, deg)  # averaged over the directions the stack cannot tell apart
            if kind is not None:
                f_ref, f_err = symmetrized(f_ref, f_err, _orbits(wi, wo, kind))
            noise = float(np.mean((f_err * weight[:, None]).sum(0) / np.maximum((f_ref * weight[:, None]).sum(0), 1e-30)))
        for m in models:
            a = api.albedo(stack, wi, m)[0]
            row = {"model": m, "wi": deg, "albedo": a, "albedo_ref": a_ref[0], "albedo_stderr": a_err[0],
                   "albedo_err": albedo_error(a, a_ref[0])}
            if transmits:
                t = api.albedo(stack, wi, m, side="transmitted")[0]
                row.update({"albedo_t": t, "albedo_t_ref": t_ref[0], "albedo_t_stderr": t_err[0],
                            "albedo_t_err": albedo_error(t, t_ref[0])})
            if f_ref is not None:
                f = api.evaluate(stack, wi, wo, m, deltas=False)
                row.update({"rel_l1": relative_l1(f, f_ref, weight), "ref_noise": noise})
            rows.append(row)
    return rows


def _rgb(v) -> str:
    return "(" + ", ".join(f"{x:.3f}" for x in v) + ")"


def table(name: str, rows: list[dict], bare: list[dict] | None) -> list[str]:
    out = [f"### {name}", ""]
    t = "albedo_t" in rows[0]
    head = ["model", "wi", "albedo model", "albedo reference (stderr)", "albedo err"]
    if t:
        head += ["transmitted model", "transmitted reference", "transmitted err"]
    if "rel_l1" in rows[0]:
        head += ["rel L1 (ref noise)"]
    if bare is not None:
        head += ["without film: albedo err" + (" / rel L1" if "rel_l1" in rows[0] else "")]
    out += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for i, r in enumerate(rows):
        cells = [r["model"], f"{r['wi']:.0f}", _rgb(r["albedo"]),
                 f"{_rgb(r['albedo_ref'])} ({np.max(r['albedo_stderr']):.4f})", f"{r['albedo_err']:.3f}"]
        if t:
            cells += [_rgb(r["albedo_t"]), f"{_rgb(r['albedo_t_ref'])} ({np.max(r['albedo_t_stderr']):.4f})",
                      f"{r['albedo_t_err']:.3f}"]
        if "rel_l1" in r:
            cells += [f"{r['rel_l1']:.3f} ({r['ref_noise']:.3f})"]
        if bare is not None:
            b = bare[i]
            cells += [f"{b['albedo_err']:.3f}" + (f" / {b['rel_l1']:.3f}" if "rel_l1" in b else "")]
        out.append("| " + " | ".join(cells) + " |")
    return out + [""]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spp", type=int, default=1024, help="reference samples per direction of the grid")
    ap.add_argument("--albedo-spp", type=int, default=1 << 18)
    ap.add_argument("--interfaces", choices=reference.INTERFACES, default="multiple")
    ap.add_argument("--models", default="auto", help="comma-separated model names")
    ap.add_argument("--no-bare", action="store_true", help="skip the stacks without their films")
    args = ap.parse_args(argv)
    models = tuple(args.models.split(","))
    print(f"Models against the spectral reference (interfaces={args.interfaces}, spp {args.spp}, "
          f"albedo spp {args.albedo_spp}); relative albedo error mean(|a - a_ref| / a_ref) over RGB.\n")
    for name, d in STACKS.items():
        t0 = time.perf_counter()
        rows = measure(d, args.spp, args.albedo_spp, args.interfaces, models)
        bare = None if args.no_bare else measure(without_film(d), args.spp, args.albedo_spp, args.interfaces, models)
        print("\n".join(table(name, rows, bare)) + f"({time.perf_counter() - t0:.0f} s)\n", flush=True)


if __name__ == "__main__":
    main()
