"""`lamella bench energy`: does a model deliver the energy it reports?

A model's lobes carry weights (``api.albedo``: what the closures are normalised to and what the
panel shows); ``api.evaluate`` is the BSDF the renderers integrate. The two must agree: the
integral of f(wi, wo) |wo.z| over the upper hemisphere equals the sum of the weights of the rough
reflected lobes (smooth lobes are deltas, outside ``evaluate``). A lobe whose closure reaches
below the horizon delivers less than its weight unless its normaliser accounts for the cut.

The integral is a midpoint rule over the half vector (``suite.wo_grid``, cells crowded around the
mirror direction where the narrow lobes are), fine enough that its own error is below 0.2 % for
a lobe of alpha 0.02 (``QUADRATURE``).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from lamella.core import api, lobe_kinds
from .. import suite
from lamella.core.models import UnsupportedStack
from .paths import BENCH_DIR
from .page import write_page
from .registry import Bench, register

QUADRATURE = (160, 240)  # (n_theta, n_phi) of the half-vector grid
ANGLES = (0.0, 30.0, 45.0, 60.0, 75.0)
TOLERANCE = 0.02  # the relative gap allowed between the lobe weights and the integral of evaluate


def delivered(stack, wi, model="auto") -> tuple[np.ndarray, np.ndarray]:
    """(weights, integral), RGB: the rough reflected lobes' weights and the integral of
    ``evaluate`` (deltas left out) over the upper hemisphere."""
    lb = api.lobes(stack, wi, model)
    rough = [k for k, name in enumerate(lb.kinds) if lobe_kinds.kind(name).side == "reflected"
             and not (lobe_kinds.kind(name).rough and lb.alpha_x[0, k] == 0.0 and lb.alpha_y[0, k] == 0.0)]
    weights = lb.weight[0, rough, :].sum(0)
    wo, dw = suite.wo_grid(wi, *QUADRATURE)
    f = api.evaluate(stack, wi, wo, model, deltas=False)
    return weights, (f * dw[:, None]).sum(0)


def rows(cases=None, models=("auto",), angles=ANGLES, progress=print) -> list[dict]:
    out = []
    for name in cases or suite.names():
        stack = suite.load(name)
        for model in models:
            for deg in angles:
                try:
                    w, i = delivered(stack, suite.incident(deg), model)
                except UnsupportedStack:
                    continue
                ratio = float(i.mean() / w.mean()) if w.mean() > 1e-9 else 1.0
                out.append({"case": name, "model": model, "wi": deg, "weights": w.tolist(), "integral": i.tolist(),
                            "ratio": ratio})
        progress(f"{name}: done")
    return out


def run(out_dir: Path = BENCH_DIR, progress=print) -> Path:
    rs = rows(progress=progress)
    return write_page(out_dir, "energy", lambda: _markdown(rs), {"quadrature": QUADRATURE, "rows": rs})


def _markdown(rs: list[dict]) -> str:
    bad = [r for r in rs if abs(r["ratio"] - 1.0) > TOLERANCE]
    md = ["# Energy given against energy delivered", "",
          "`lamella bench energy`: for every suite stack under `auto`, the integral of `evaluate` over the upper",
          "hemisphere (rough reflected lobes) divided by the sum of those lobes' weights (what `albedo` reports and",
          f"the closures are normalised to), at {', '.join(f'{a:g}' for a in ANGLES)} degrees. 1 is right; below 1 a",
          "lobe reaches below the horizon and its normaliser does not account for the cut. Half-vector midpoint",
          f"grid {QUADRATURE[0]} x {QUADRATURE[1]} (`suite.wo_grid`).", "",
          f"{len(bad)} of {len(rs)} (case, angle) pairs are off by more than {TOLERANCE:.0%}.", "",
          "| case | " + " | ".join(f"{a:g}°" for a in ANGLES) + " |", "|---|" + "---|" * len(ANGLES)]
    for name in dict.fromkeys(r["case"] for r in rs):
        cells = {r["wi"]: r["ratio"] for r in rs if r["case"] == name}
        md.append(f"| {name} | " + " | ".join(
            (f"**{cells[a]:.3f}**" if abs(cells[a] - 1.0) > TOLERANCE else f"{cells[a]:.3f}") if a in cells else ""
            for a in ANGLES) + " |")
    return "\n".join(md)


BENCH = register(Bench("energy", "every model's integral of evaluate against the lobe weights it reports",
                       lambda out_dir, args: run(out_dir)))
