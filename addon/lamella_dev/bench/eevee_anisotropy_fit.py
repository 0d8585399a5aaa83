"""`lamella bench eevee-anisotropy-fit`: each anisotropic lobe drawn by K isotropic GGX lobes about
normals tilted along its long axis (``lamella.core.lobe_kinds.isotropic_fit``), for EEVEE, which
draws every lobe round.

For the anisotropic stacks of the suite (``eevee_standins.anisotropic_cases``), at incidence 0-75
degrees and eight azimuths, the model's lobes are evaluated as they are and with every anisotropic
lobe replaced by: today's stand-in (one lobe of alpha sqrt(ax ay) about the normal), the best
single isotropic lobe (the fit with K = 1), and the fitted K = 2 and K = 3 stand-ins; relative L1 of
f cos over the hemisphere of outgoing directions (RGB averaged), and the energy the stand-ins
reflect over the lobes'. A second table measures the fit on single lobes against the fit made at
that very view (the best the structure can do), and least squares against L1 as the fit's
criterion; a third the time the fit takes at staging."""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from lamella.core import lobe_kinds
from lamella.core.api import _run
from lamella.core.backends.ir.staging import stage
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.hemisphere import wo_grid
from lamella.core.lobe_kinds import isotropic_fit as fitm

from .. import suite
from .eevee_standins import anisotropic_cases
from .page import write_page
from .paths import BENCH_DIR
from .registry import Bench, register

THETAS = (0.0, 15.0, 30.0, 45.0, 60.0, 75.0)
N_PHI = 8
GRID = (64, 128)  # the half-vector grid of wo: the coats' lobes are as narrow as alpha 0.01
METHODS = ("geometric mean (today)", "best single lobe (K = 1)", "K = 2", "K = 3", "K = 3, no view shift")
ANISOTROPY_RATIO = 0.999  # a reflection lobe is anisotropic below this axis ratio
LOBE_SHAPES = ((0.1, 0.01), (0.16, 0.04), (0.4, 0.1), (0.6, 0.3))
LOBE_VIEWS = ((0.0, 0.0), (45.0, 0.0), (75.0, 0.0), (75.0, 90.0))


def _scalar(x) -> float:
    return float(np.ravel(np.asarray(x, dtype=np.float64))[0])


def _to_lobe(v: np.ndarray, rotation: float) -> np.ndarray:
    """Directions (..., 3) of the shading frame in the frame of a lobe turned by ``rotation``."""
    c, s = math.cos(rotation), math.sin(rotation)
    return np.stack([v[..., 0] * c + v[..., 1] * s, -v[..., 0] * s + v[..., 1] * c, v[..., 2]], -1)


def _stand_in_cos(method: str, ax: float, ay: float, wi_l: np.ndarray, wo_l: np.ndarray) -> np.ndarray:
    """f cos (unit energy) of ``method``'s stand-ins for the lobe (ax, ay), in the lobe's frame."""
    if method.startswith("geometric"):
        a = math.sqrt(ax * ay)
        g = float(fitm.gd(fitm._OPS, np.array(max(wi_l[2], 0.0)), np.array(a)))
        return fitm.tilted_cos(wi_l, wo_l, a, np.array([0.0, 0.0, 1.0])) / max(g, 1e-6)
    k = {"best single lobe (K = 1)": 1, "K = 2": 2}.get(method, 3)
    st = fitm.fit(np.array([ax]), np.array([ay]), wi_l[None, :], k=k, shift="no view shift" not in method)
    return fitm.fit_cos(st, 0, wi_l, wo_l)


def measure(cases=None, thetas=THETAS, n_phi: int = N_PHI) -> dict:
    """{case: {method: {"l1": mean relative L1, "energy": mean energy ratio, "by_theta": {theta: L1}},
    "lobes": the anisotropic lobes at normal incidence}}."""
    cases = cases or anisotropic_cases()
    ops = NumpyOps(np.float64)
    out = {}
    for name in cases:
        stack = suite.load(name)
        errs = {m: {} for m in METHODS}
        energy = {m: [] for m in METHODS}
        lobes_seen = []
        for th in thetas:
            for ph in np.linspace(0.0, 2.0 * math.pi, n_phi, endpoint=False):
                wi = suite.incident(th, ph)
                wo, weight = wo_grid(wi, *GRID)
                _, _, wi_vals, ls = _run(stack, np.broadcast_to(wi, wo.shape), "auto", np.float64)
                wo_vals = tuple(wo[:, k] for k in range(3))
                truth = np.stack(list(lobe_kinds.eval_lobes_cos(ops, ls, wi_vals, wo_vals)), -1)
                norm = float((np.abs(truth).sum(-1) * weight).sum())
                aniso, rest = [], []
                for lobe in ls:
                    ax, ay = _scalar(lobe.alpha_x), _scalar(lobe.alpha_y)
                    rough = lobe_kinds.kind(lobe.kind).rough and lobe.kind == "reflection"
                    if rough and min(ax, ay) < ANISOTROPY_RATIO * max(ax, ay):
                        aniso.append((lobe, ax, ay, _scalar(lobe.rotation)))
                    else:
                        rest.append(lobe)
                if th == 0.0 and ph == 0.0:
                    lobes_seen = [(round(ax, 3), round(ay, 3)) for _, ax, ay, _ in aniso]
                base = np.stack(list(lobe_kinds.eval_lobes_cos(ops, rest, wi_vals, wo_vals)), -1) if rest else 0.0
                a_truth = truth - base
                for m in METHODS:
                    f = base
                    for lobe, ax, ay, rot in aniso:
                        w = np.array([_scalar(c) for c in lobe.weight])
                        s = _stand_in_cos(m, ax, ay, _to_lobe(wi, rot), _to_lobe(wo, rot))
                        f = f + s[:, None] * w[None, :]
                    err = float((np.abs(f - truth).sum(-1) * weight).sum() / norm)
                    errs[m].setdefault(th, []).append(err)
                    e_true = float((a_truth.sum(-1) * weight).sum())
                    if e_true > 1e-9:
                        energy[m].append(float(((f - base).sum(-1) * weight).sum()) / e_true)
        out[name] = {m: {"l1": float(np.mean([v for vs in errs[m].values() for v in vs])),
                         "energy": float(np.mean(energy[m])),
                         "by_theta": {str(t): float(np.mean(v)) for t, v in errs[m].items()}} for m in METHODS}
        out[name]["lobes"] = lobes_seen
        closures = len(stage(stack).closures)  # the node group's closures today (lobe budget "auto")
        out[name]["closures"] = [closures + (k - 1) * len(lobes_seen) for k in (1, 2, 3)]
    return out


def lobe_table(shapes=LOBE_SHAPES, views=LOBE_VIEWS) -> list[dict]:
    """Single lobes of unit energy: relative L1 of today's stand-in, the tabulated fit (K = 1, 2, 3)
    and the fit made at the view itself (the structure's best there: the shape and a shift of its
    tilts fitted at that view, ``fit_shape(wi=..., offset=True)``)."""
    rows = []
    for ax, ay in shapes:
        for th, ph in views:
            wi = suite.incident(th, math.radians(ph))
            h, dh = fitm.h_grid(ax, ay, 64, 160)
            wo, dwo = fitm.wo_of_h(wi, h, dh)
            target = fitm.anisotropic_cos(wi, wo, ax, ay)
            norm = float((target * dwo).sum())

            def l1(f):
                return float((np.abs(f - target) * dwo).sum() / norm)

            row = {"lobe": (ax, ay), "view": (th, ph)}
            row["geometric mean (today)"] = l1(_stand_in_cos("geometric mean", ax, ay, wi, wo))
            for k in (1, 2, 3):
                row[f"K = {k}"] = l1(_stand_in_cos({1: "best single lobe (K = 1)", 2: "K = 2", 3: "K = 3"}[k],
                                                   ax, ay, wi, wo))
            for k in (2, 3):
                best = fitm.fit_shape(ax, ay, k, wi=wi, offset=True, rounds=6)
                row[f"K = {k} fitted at this view"] = l1(fitm.stand_ins_cos(best, ax, ay, wi, wo))
            rows.append(row)
    return rows


def criterion_table(shapes=LOBE_SHAPES) -> list[dict]:
    """The fit's criterion at normal incidence: relative L1 of the shapes fitted by L1 and by least
    squares (f cos), K = 2 and 3."""
    rows = []
    for ax, ay in shapes:
        row = {"lobe": (ax, ay)}
        for k in (2, 3):
            for metric in ("l1", "l2"):
                row[f"K = {k}, {metric}"] = fitm.fit_shape(ax, ay, k, metric=metric).error
        rows.append(row)
    return rows


def timing(n_views: int = 64 * 16, n_lobes: int = 5) -> dict:
    """Seconds ``isotropic_fit.fit`` takes for ``n_lobes`` lobes on a staging grid of ``n_views``
    views (random shapes and views), and one ``fit_shape`` (a table entry)."""
    rng = np.random.default_rng(0)
    n = n_views * n_lobes
    ax, ay = rng.uniform(0.01, 0.8, n), rng.uniform(0.01, 0.8, n)
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    fitm.load_table()
    out = {}
    for k in (2, 3):
        t = time.perf_counter()
        fitm.fit(ax, ay, v, k=k)
        out[f"fit, K = {k}, {n_lobes} lobes x {n_views} views"] = time.perf_counter() - t
    t = time.perf_counter()
    fitm.fit_shape(0.4, 0.1, 3)
    out["fit_shape (one table entry, K = 3)"] = time.perf_counter() - t
    return out


def _page(res: dict, lobes: list, criteria: list, times: dict) -> str:
    cases = [c for c in res]
    lines = [
        "# EEVEE: anisotropic lobes as tilted isotropic lobes",
        "",
        "`lamella bench eevee-anisotropy-fit`. EEVEE draws every Glossy BSDF round, so an anisotropic lobe loses "
        "its streak. Each anisotropic lobe is replaced by K isotropic GGX lobes about normals tilted along its long "
        "axis (`lamella/core/lobe_kinds/isotropic_fit.py`): a symmetric pair (K = 2) or a pair and a central lobe "
        "(K = 3), their roughnesses and tilt fitted at normal incidence to minimise the relative L1 of f cos, "
        "tabulated over (axis ratio, alpha_long); at a view the tilts shift together along the long axis (a second "
        "table over ratio, alpha_long and the view) and each stand-in's weight is its share of the microfacet "
        "normals times wi . n_k (normals facing the view catch more light), the energies matched to the lobe's. "
        "Each stand-in is a Glossy BSDF (Normal = the tilted normal), evaluated as the renderer does: GGX about that "
        "normal, nothing below its horizon or the surface's.",
        "",
        f"Relative L1 of f cos over the hemisphere (half-vector grid {GRID[0]} x {GRID[1]}) against the stack's "
        f"lobes with their anisotropy, mean over incidence {', '.join(f'{t:g}' for t in THETAS)} degrees x "
        f"{N_PHI} azimuths; the isotropic lobes of each stack stay as they are (numpy; EEVEE's own approximations "
        "come on top). *Energy*: what the stand-ins reflect over what the anisotropic lobes reflect (mean).",
        "",
        "| stack | anisotropic lobes (ax, ay at 0 deg) | closures: today / K = 2 / K = 3 | " + " | ".join(METHODS)
        + " |",
        "|---|---|---|" + "---:|" * len(METHODS),
    ]
    for name in cases:
        row = res[name]
        best = min(row[m]["l1"] for m in METHODS)
        cells = [f"**{row[m]['l1']:.3f}**" if row[m]["l1"] == best else f"{row[m]['l1']:.3f}" for m in METHODS]
        lines.append(f"| {name} | {', '.join(str(x) for x in row['lobes'])} | "
                     f"{' / '.join(str(n) for n in row['closures'])} | " + " | ".join(cells) + " |")
    mean = {m: float(np.mean([res[c][m]["l1"] for c in cases])) for m in METHODS}
    best = min(mean.values())
    lines.append("| **mean** | | | " + " | ".join(f"**{mean[m]:.3f}**" if mean[m] == best else f"{mean[m]:.3f}"
                                                for m in METHODS) + " |")
    lines.append("| energy (mean) | | | " + " | ".join(
        f"{np.mean([res[c][m]['energy'] for c in cases]):.3f}" for m in METHODS) + " |")
    lines += ["", "By incidence (mean over the stacks and azimuths):", "",
              "| incidence | " + " | ".join(METHODS) + " |", "|---:|" + "---:|" * len(METHODS)]
    for t in THETAS:
        lines.append(f"| {t:g} | " + " | ".join(
            f"{np.mean([res[c][m]['by_theta'][str(t)] for c in cases]):.3f}" for m in METHODS) + " |")
    cols = ["geometric mean (today)", "K = 1", "K = 2", "K = 3", "K = 2 fitted at this view",
            "K = 3 fitted at this view"]
    lines += ["", "## Single lobes", "",
              "One anisotropic lobe of unit energy (alpha_x along the view's azimuth 0), relative L1 of f cos: the "
              "tables against the fit made at that view (shape and shift, the structure's best there; seconds each, "
              "too slow for staging).", "",
              "| lobe (ax, ay) | view (theta, phi) | " + " | ".join(cols) + " |", "|---|---|" + "---:|" * len(cols)]
    for r in lobes:
        lines.append(f"| {r['lobe']} | {r['view']} | " + " | ".join(f"{r[c]:.3f}" for c in cols) + " |")
    ccols = ["K = 2, l1", "K = 2, l2", "K = 3, l1", "K = 3, l2"]
    lines += ["", "## The fit's criterion", "",
              "Relative L1 at normal incidence of the shapes fitted by L1 and by least squares on f cos, the "
              "energies matched to the lobe's either way (with free weights either criterion lowers its error by "
              "dropping energy, which would darken the material).", "",
              "| lobe (ax, ay) | " + " | ".join(ccols) + " |", "|---|" + "---:|" * len(ccols)]
    for r in criteria:
        lines.append(f"| {r['lobe']} | " + " | ".join(f"{r[c]:.3f}" for c in ccols) + " |")
    lines += ["", "## Cost", "",
              "Closures: each anisotropic lobe costs K Glossy BSDFs instead of one, so K = 3 adds two closures per "
              "anisotropic lobe (a brushed metal under a clear coat: 2 -> 4 Glossy BSDFs). EEVEE renders every "
              "closure (`docs/node_groups.md`: five and six Glossy BSDFs all contribute), but a render of a sum "
              "falls short of its parts by 5-10 % at 2-3 lobes and 14-21 % at 4-6, in EEVEE and Cycles alike "
              "(`bench/eevee_closures.md`, \"Additivity\"), so more lobes trade shape for that bias.", "",
              "Fit time (the tables, `lamella/data/luts/isotropic_fit.npz`, 10 kB, are built once by "
              "`isotropic_fit.write_table` or `--rebuild`, about 10 minutes on one core):", ""]
    lines += [f"- {k}: {v * 1e3:.1f} ms" if v < 1 else f"- {k}: {v:.2f} s" for k, v in times.items()]
    return "\n".join(lines)


def run(out_dir: Path = BENCH_DIR, cases=None, rebuild: bool = False) -> Path:
    if rebuild:
        fitm.write_table(progress=print)
    res = measure(cases)
    lobes = lobe_table()
    criteria = criterion_table()
    times = timing()
    data = {"stacks": res, "lobes": lobes, "criteria": criteria, "seconds": times}
    return write_page(out_dir, "eevee_anisotropy_fit", lambda: _page(res, lobes, criteria, times), data)


def _arguments(parser):
    from .registry import cases_argument

    cases_argument(parser, anisotropic_cases, "anisotropic suite case")
    parser.add_argument("--rebuild", action="store_true",
                        help="rebuild the fit tables (lamella/data/luts/isotropic_fit.npz) first (about 10 minutes)")


BENCH = register(Bench("eevee-anisotropy-fit", "anisotropic lobes as K tilted isotropic lobes for EEVEE: the fit "
                       "against today's stand-in", lambda out_dir, args: run(out_dir, args.cases, args.rebuild),
                       _arguments))
