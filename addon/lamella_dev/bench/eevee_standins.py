"""`lamella bench eevee-anisotropy`: which isotropic roughness stands in best for an anisotropic
lobe where the renderer has none (EEVEE ignores the Glossy BSDF's anisotropy).

For every anisotropic stack of the suite, at incidence 0-60 degrees and all azimuths, the model's
lobes are evaluated as they are (anisotropic GGX on their rotated axes) and with every
anisotropic lobe replaced by an isotropic one of the candidate roughness (each normalised to its
own energy, as the node group does); the table gives the relative L1 difference of f cos over the
hemisphere of outgoing directions, averaged over the incident directions."""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from lamella.core import lobe_kinds
from .. import suite
from lamella.core.api import _run
from lamella.core.backends.numpy_ops import NumpyOps
from .paths import BENCH_DIR
from .page import write_page
from .registry import Bench, register


def _candidates(ops, lobe, wi):
    ax, ay = lobe.alpha_x, lobe.alpha_y
    # the incident azimuth in the lobe's own axes: the view's projected roughness
    c, s = np.cos(lobe.rotation), np.sin(lobe.rotation)
    lx, ly = wi[0] * c + wi[1] * s, -wi[0] * s + wi[1] * c
    r2 = np.maximum(lx * lx + ly * ly, 1e-12)
    projected = np.sqrt((ax * ax * lx * lx + ay * ay * ly * ly) / r2)
    return {
        "geometric mean sqrt(ax ay) (EEVEE's own reading of the Glossy BSDF)": np.sqrt(ax * ay),
        "arithmetic mean (ax + ay) / 2": 0.5 * (ax + ay),
        "RMS sqrt((ax^2 + ay^2) / 2)": np.sqrt(0.5 * (ax * ax + ay * ay)),
        "larger axis max(ax, ay)": np.maximum(ax, ay),
        "projected on the view azimuth": np.where(lx * lx + ly * ly > 1e-12, projected, np.sqrt(ax * ay)),
    }


def anisotropic_cases() -> list[str]:
    out = []
    for name in suite.names():
        ops, v, wi_vals, ls = _run(suite.load(name), np.array([[0.0, 0.0, 1.0]]), "auto", np.float64)
        if any(not np.allclose(lobe.alpha_x, lobe.alpha_y) for lobe in ls if lobe_kinds.kind(lobe.kind).rough):
            out.append(name)
    return out


def measure(cases=None, thetas=(0.0, 30.0, 60.0), n_phi: int = 12) -> dict:
    """{case: {candidate: mean relative L1}} over the incident directions."""
    cases = cases or anisotropic_cases()
    result = {}
    for name in cases:
        stack = suite.load(name)
        errs: dict[str, list] = {}
        for th in thetas:
            for ph in np.linspace(0.0, 2 * math.pi, n_phi, endpoint=False):
                wi = np.array([math.sin(math.radians(th)) * math.cos(ph), math.sin(math.radians(th)) * math.sin(ph),
                               math.cos(math.radians(th))])
                wo, weight = suite.wo_grid(wi, 32, 48)
                ops = NumpyOps(np.float64)
                _, _, wi_vals, ls = _run(stack, np.broadcast_to(wi, wo.shape), "auto", np.float64)
                wo_vals = tuple(wo[:, k] for k in range(3))
                truth = np.stack(list(lobe_kinds.eval_lobes_cos(ops, ls, wi_vals, wo_vals)), -1)
                norm = (np.abs(truth).sum(-1) * weight).sum()
                per_lobe = [_candidates(ops, lobe, wi_vals) if lobe_kinds.kind(lobe.kind).rough else None for lobe in ls]
                for cand in next(p for p in per_lobe if p is not None):
                    alt = [lobe if p is None else replace(lobe, alpha_x=p[cand], alpha_y=p[cand]) for lobe, p in zip(ls, per_lobe)]
                    f = np.stack(list(lobe_kinds.eval_lobes_cos(ops, alt, wi_vals, wo_vals)), -1)
                    errs.setdefault(cand, []).append(float((np.abs(f - truth).sum(-1) * weight).sum() / norm))
        result[name] = {k: float(np.mean(v)) for k, v in errs.items()}
    return result


def run(out_dir: Path = BENCH_DIR) -> Path:
    res = measure()
    cands = list(next(iter(res.values())))
    lines = [
        "# EEVEE: the isotropic stand-in for anisotropic lobes",
        "",
        "`lamella bench eevee-anisotropy`. EEVEE ignores the Glossy BSDF's anisotropy, so the node group's EEVEE "
        "target gives every anisotropic lobe one isotropic roughness. Relative L1 of f cos over the hemisphere "
        "against the anisotropic lobes, mean over incidence 0, 30, 60 degrees x 12 azimuths (model lobes in numpy; "
        "EEVEE's own approximations come on top).",
        "",
        "| stack | " + " | ".join(cands) + " |",
        "|---|" + "---|" * len(cands),
    ]
    for name, row in res.items():
        best = min(row.values())
        lines.append(f"| {name} | " + " | ".join(f"**{row[c]:.3f}**" if row[c] == best else f"{row[c]:.3f}"
                                                    for c in cands) + " |")
    mean = {c: float(np.mean([row[c] for row in res.values()])) for c in cands}
    best = min(mean.values())
    lines.append("| **mean** | " + " | ".join(f"**{mean[c]:.3f}**" if mean[c] == best else f"{mean[c]:.3f}"
                                              for c in cands) + " |")
    return write_page(out_dir, "eevee_anisotropy", "\n".join(lines))


BENCH = register(Bench("eevee-anisotropy", "the isotropic stand-ins for anisotropic lobes in EEVEE",
                       lambda out_dir, args: run(out_dir)))
