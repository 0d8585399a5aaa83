"""`lamella bench coat-darkening`: what a smooth clear coat does to a diffuse base, beside the
classical internal-reflection sum and the random walk.

A smooth dielectric coat of index 1.5 over a Lambertian base of albedo a: light refracts in,
reaches the base, and the base's light leaves through the coat only where it meets the interface
inside the escape cone; the rest is reflected back down (60 % of diffuse light at index 1.5, total
internal reflection beyond 41.8 degrees) and meets the base again. The classical sum of those
round trips (the internal-reflection series of a diffuse layer under a smooth interface, as in
Kubelka-Munk theory's interface corrections) gives the directional albedo

    R(theta) = F(theta) + (1 - F(theta)) a (1 - F_i) / (1 - a F_i),

F the Fresnel reflectance at the view, F_i the cosine-weighted hemispherical reflectance from
inside (0.596 at index 1.5). The base's share, (R - F) / a = (1 - F) (1 - F_i) / (1 - a F_i), is
what the coat leaves of the bare colour: 0.74 at a = 0.8 and normal incidence, 0.41 at a = 0.1 (a
dark base absorbs the light the coat sends back to it; a white one returns it until it escapes),
while Blender's Principled BSDF coat layers a specular lobe over the base's own light and keeps
nearly all of it. The page compares ``auto``'s albedo with that sum and with the energy-conserving
random walk (``reference.albedo``), and plots the base's share against the albedo. Numpy only.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from lamella.core import Stack, api
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.models.fresnel import fresnel_dielectric
from .. import reference, suite
from .paths import BENCH_DIR
from .page import write_page
from .registry import Bench, register

IOR = 1.5
ALBEDOS = (0.1, 0.3, 0.5, 0.8, 0.95)
ANGLES = (0.0, 45.0, 70.0)
WALKERS = 20000
PLOT = "plots/coat_darkening.png"


def fresnel(cos_i, n: float):
    """Unpolarised Fresnel reflectance at cosine ``cos_i`` onto relative index ``n`` (1 beyond the
    critical angle): the models' own (``models.fresnel``), in float64."""
    return fresnel_dielectric(NumpyOps(np.float64), np.asarray(cos_i, dtype=np.float64), n)


def internal_reflectance(n: float = IOR, steps: int = 200000) -> float:
    """F_i: the cosine-weighted hemispherical reflectance of the interface seen from inside the coat
    (relative index 1 / n), by the midpoint rule in cos^2 theta."""
    u = (np.arange(steps) + 0.5) / steps  # u = cos^2 theta: the cosine weight made uniform
    return float(fresnel(np.sqrt(u), 1.0 / n).mean())


def classical(albedo: float, deg: float, n: float = IOR) -> float:
    """The internal-reflection sum's directional albedo (module docstring)."""
    f = float(fresnel(np.cos(np.radians(deg)), n))
    fi = internal_reflectance(n)
    return f + (1.0 - f) * albedo * (1.0 - fi) / (1.0 - albedo * fi)


def stack(albedo: float) -> Stack:
    return Stack.from_dict({"name": "coat_darkening", "layers": [{"ior": IOR, "roughness": 0.0}],
                            "base": {"type": "diffuse", "albedo": [albedo] * 3}})


def rows(walkers: int = WALKERS, seed: int = 0) -> list[dict]:
    out = []
    for a in ALBEDOS:
        s = stack(a)
        for deg in ANGLES:
            wi = suite.incident(deg)[None]
            model = float(api.albedo(s, wi)[0, 0])
            walk, err = reference.albedo(s, wi, walkers, seed, interfaces="multiple")
            out.append({"albedo": a, "wi": deg, "model": model, "classical": classical(a, deg),
                        "walk": float(walk[0, 0]), "stderr": float(err[0, 0]),
                        "fresnel": float(fresnel(np.cos(np.radians(deg)), IOR))})
    return out


def share(row: dict, what: str) -> float:
    """What the coat leaves of the bare colour in ``row``: (R - F) / a of ``what`` ("model",
    "classical", "walk"; F the smooth coat's own reflection)."""
    return (row[what] - row["fresnel"]) / row["albedo"]


def _plot(data: list[dict], out_dir: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.2, 3.4), dpi=120)
    a = np.linspace(0.02, 1.0, 50)
    f0 = float(fresnel(1.0, IOR))
    ax.plot(a, [(classical(x, 0.0) - f0) / x for x in a], color="0.5", lw=1.5, label="internal-reflection sum, 0°")
    for deg, marker in zip(ANGLES, ("o", "s", "^")):
        pts = [r for r in data if r["wi"] == deg]
        ax.plot([r["albedo"] for r in pts], [share(r, "model") for r in pts], marker, ms=5, label=f"Lamella, {deg:g}°")
        ax.plot([r["albedo"] for r in pts], [share(r, "walk") for r in pts], marker, ms=9, mfc="none", color="k", lw=0)
    ax.axhline(1.0, color="0.8", lw=1)
    ax.set_ylim(0.0, 1.05)
    ax.set_xlabel("diffuse albedo a")
    ax.set_ylabel("base's share (R - F) / a")
    ax.set_title("a smooth clear coat (index 1.5) over a diffuse base\n(open circles: the random walk)", fontsize=9)
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    (out_dir / PLOT).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_dir / PLOT)
    plt.close(fig)


def format_markdown(data: list[dict]) -> str:
    fi = internal_reflectance()
    md = ["# A clear coat over a diffuse base: the light the coat traps",
          "",
          f"`lamella bench coat-darkening`: a smooth coat of index {IOR:g} over a Lambertian albedo a. Directional "
          f"albedo of `auto`, of the classical internal-reflection sum R = F + (1 - F) a (1 - F_i) / (1 - a F_i) "
          f"(F_i = {fi:.3f}, the interface's diffuse reflectance from inside: {100 * fi:.0f} % of the base's light "
          f"goes back down, total internal reflection past {np.degrees(np.arcsin(1.0 / IOR)):.1f}°) and of the "
          "energy-conserving random "
          f"walk (`reference.albedo`, {WALKERS} walkers): R, R / a (beside the bare base, the coat's reflection "
          "included) and the base's share (R - F) / a (what the coat leaves of the bare colour).",
          "",
          f"![darkening factor against albedo]({PLOT})",
          "",
          "| a | θi | F | R model | R sum | R walk | model R / a | share: model | share: sum | share: walk |",
          "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in data:
        md.append(f"| {r['albedo']:g} | {r['wi']:g}° | {r['fresnel']:.3f} | {r['model']:.3f} | {r['classical']:.3f} | "
                  f"{r['walk']:.3f} | {r['model'] / r['albedo']:.3f} | {share(r, 'model'):.3f} | "
                  f"{share(r, 'classical'):.3f} | {share(r, 'walk'):.3f} |")
    at = next(r for r in data if r["albedo"] == 0.8 and r["wi"] == 0.0)
    dark = next(r for r in data if r["albedo"] == ALBEDOS[0] and r["wi"] == 0.0)
    worst = max(abs(r["model"] / r["walk"] - 1.0) for r in data)
    md += ["", "Reading it:", "",
           f"- At a = 0.8 and normal incidence the coated albedo is {at['model'] / at['albedo']:.3f} of the bare "
           f"albedo, the coat's own reflection ({at['fresnel']:.3f}) included (the sum: "
           f"{at['classical'] / at['albedo']:.3f}, the walk: {at['walk'] / at['albedo']:.3f}); the coat leaves "
           f"{share(at, 'model'):.3f} of the base's own colour. At a = {ALBEDOS[0]:g} it leaves "
           f"{share(dark, 'model'):.3f}: the light the coat reflects back down is absorbed by the base at every "
           "return, so a dark colour loses relatively more, a white one, which returns it until it escapes, less.",
           f"- The model is within {100 * worst:.1f} % of the walk at every albedo and angle.",
           "- Where a coat is worn away (a coverage mask), the bare base reads brighter than the lacquered parts: "
           "that is the physics of a clear coat over a diffuse colour, not a fault of the shader. Blender's "
           "Principled BSDF coat keeps nearly all of the base's light under its coat.", ""]
    return "\n".join(md)


def run(out_dir: Path = BENCH_DIR) -> Path:
    data = rows()
    out_dir = Path(out_dir)

    def page():
        _plot(data, out_dir)
        return format_markdown(data)

    return write_page(out_dir, "coat_darkening", page, data)


BENCH = register(Bench("coat-darkening",
                       "a smooth clear coat over a diffuse base: the model's albedo beside the internal-reflection "
                       "sum and the random walk",
                       lambda out_dir, args: run(out_dir)))

__all__ = ["classical", "fresnel", "internal_reflectance", "rows", "run", "format_markdown"]
