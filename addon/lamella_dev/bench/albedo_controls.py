"""`lamella bench albedo-controls`: where the coated conductor's energy goes wrong, one factor at
a time.

One coat of index 1.5 over gold, every combination of a smooth or rough coat (GGX alpha 0 or
0.2), a smooth or rough base (0 or 0.2) and three absorptions of the coat's interior (none,
``absorbing_rough_coat``'s, a strong one), plus bare gold at three roughnesses: the directional
albedo of ``auto`` against the energy-conserving random walk (``reference.albedo`` with
multiple-scattering interfaces, Heitz et al. 2016) at 0 and 60 degrees, as the ratio model /
walk per channel. Smooth-over-smooth is an exact limit (ratio 1); each factor that moves the
ratio away from 1 is a term the model misses. Numpy only, a few seconds.
"""
from __future__ import annotations

from pathlib import Path


from lamella.core import Stack, api
from .. import reference, suite
from .paths import BENCH_DIR
from .page import write_page
from .registry import Bench, register

GOLD = {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603]}
ABSORPTIONS = ((0.0, 0.0, 0.0), (0.2, 0.8, 0.8), (1.0, 2.0, 4.0))  # 1 / length, over thickness 0.5
ANGLES = (0.0, 60.0)
WALKERS = 20000


def controls() -> list[tuple[str, Stack]]:
    """(label, stack) of every control."""
    out = []
    for a in (0.1, 0.3, 0.6):
        out.append((f"bare gold, alpha {a:g}", Stack.from_dict({"name": "bare", "layers": [],
                                                                "base": dict(GOLD, roughness=a)})))
    for sig in ABSORPTIONS:
        for coat_a in (0.0, 0.2):
            for base_a in (0.0, 0.2):
                coat = {"type": "coat", "ior": 1.5, "roughness": coat_a, "thickness": 0.5, "sigma_a": list(sig)}
                label = f"coat alpha {coat_a:g}, sigma_a {'/'.join(f'{s:g}' for s in sig)}, gold alpha {base_a:g}"
                out.append((label, Stack.from_dict({"name": "control", "layers": [coat],
                                                    "base": dict(GOLD, roughness=base_a)})))
    return out


def rows(walkers: int = WALKERS, seed: int = 0) -> list[dict]:
    out = []
    for label, stack in controls():
        for deg in ANGLES:
            wi = suite.incident(deg)[None]
            model = api.albedo(stack, wi)[0]
            walk, err = reference.albedo(stack, wi, walkers, seed, interfaces="multiple")
            out.append({"control": label, "wi": deg, "model": model.tolist(), "walk": walk[0].tolist(),
                        "stderr": err[0].tolist(), "ratio": (model / walk[0]).tolist()})
    return out


def _off(data: list[dict], control: str, deg: float, channels=(0, 1, 2)) -> list[float]:
    """How far the model is from the walk on one row of ``data``, per channel, in percent."""
    row = next(r for r in data if r["control"] == control and r["wi"] == deg)
    return [100.0 * (row["ratio"][c] - 1.0) for c in channels]


def _span(values: list[float]) -> str:
    lo, hi = min(values), max(values)
    return f"{lo:.0f} %" if round(lo) == round(hi) else f"{lo:.0f}-{hi:.0f} %"


def format_markdown(data: list[dict]) -> str:
    """The page, its reading computed from the rows it shows (no figure written by hand)."""
    md = ["# Albedo of coated gold, one factor at a time",
          "",
          f"`lamella bench albedo-controls`: `auto`'s directional albedo over the energy-conserving walk's "
          f"(`reference.albedo`, multiple-scattering interfaces, {WALKERS} walkers; stderr at most about 0.002), per "
          "channel (R, G, B). Coats: index 1.5, thickness 0.5.",
          "",
          "| control | θi | model | walk | model / walk |",
          "|---|---:|---|---|---|"]
    for r in data:
        md.append(f"| {r['control']} | {r['wi']:g}° | {' '.join(f'{x:.3f}' for x in r['model'])} | "
                  f"{' '.join(f'{x:.3f}' for x in r['walk'])} | {' '.join(f'{x:.3f}' for x in r['ratio'])} |")
    bare = max(abs(x) for r in data if r["control"].startswith("bare gold")
               for x in _off(data, r["control"], r["wi"]))
    over_mirror = max(abs(x) for x in _off(data, "coat alpha 0.2, sigma_a 0/0/0, gold alpha 0", 60))
    over_rough = max(abs(x) for deg in (0, 60) for x in _off(data, "coat alpha 0.2, sigma_a 0/0/0, gold alpha 0.2", deg))
    absorbing = [(abs(x), x, r["control"], r["wi"]) for r in data if "sigma_a 0/0/0" not in r["control"]
                 and not r["control"].startswith("bare") for x in _off(data, r["control"], r["wi"])]
    _, worst, worst_control, worst_wi = max(absorbing)
    md += ["", "Reading it:", "",
           "- A smooth coat over smooth gold is exact at every absorption (the exact limit).",
           f"- Bare rough gold is within {bare:.1f} % up to alpha 0.6: its GGX lobe holds the single-scattering "
           "FGD and a diffuse lobe what its microsurface scatters more than once (Turquin 2019 with Kulla and "
           "Conty 2017's mean Fresnel factor, `fgd.conductor_scattered`); single scattering alone was 12 % short "
           "at alpha 0.3 when it was measured.",
           f"- Under a coat, within {over_mirror:.1f} % over a smooth mirror at 60° and {over_rough:.1f} % over "
           "rough gold (alpha 0.2 both, 0 and 60°): the round trips of the base's light come from tables of random "
           "walks through a coat over a base (`luts.coat_first_escape` for the first way up, which depends on the "
           "view; `luts.coat_trapped_equilibrium` for the later ones, which do not; `docs/models.md`). Counting "
           "every round trip as the first made the coat over the mirror 5, 12 and 6 % too bright when it was "
           "measured; the adding equations along the mean direction left the coat over rough gold 3-12 % too "
           "dark at 60°.",
           f"- Under absorption the largest gap is {worst:+.1f} % ({worst_control} at {worst_wi:g}°): the base's "
           "light crosses the coat along the mean direction (Beer-Lambert), and a rough base's lobe holds "
           "oblique, longer paths.", ""]
    return "\n".join(md)


def run(out_dir: Path = BENCH_DIR) -> Path:
    data = rows()
    return write_page(out_dir, "albedo_controls", lambda: format_markdown(data), data)


BENCH = register(Bench("albedo-controls",
                       "coated gold one factor at a time: the model's albedo over the energy-conserving walk's",
                       lambda out_dir, args: run(out_dir)))

__all__ = ["controls", "format_markdown", "rows", "run"]
