"""`lamella bench eevee-gap`: why EEVEE does not show what Cycles renders, with the control that
tells whose the gap is.

In ``sphere-sun`` (one sun lamp, black world) the staged node group rendered in EEVEE is compared
with the same stack's OSL shader rendered in Cycles, for every isotropic suite stack (EEVEE ignores
anisotropy: that gap is another bench's, ``eevee-anisotropy``). Two controls render in both
engines beside it:

- the **Principled stand-in** (``render._principled``): what artists use today, but with its own
  roughnesses (the stack's top coat and base), so its lobes are not ours;
- the **lobe-matched control**: one plain Glossy BSDF per lobe of ours (Diffuse BSDF for a
  Lambertian lobe, a Glossy BSDF about the view direction for a back-scatter lobe; transmission
  lobes left out), with the lobe's roughness and energy at normal incidence as constants: the
  closures our group hands EEVEE, without its table reads and view-dependent math. If our gap
  equals this control's, the group is exact in EEVEE and the gap is EEVEE's evaluation of those
  closures.

A sweep of a white metallic Principled BSDF over roughness shows where EEVEE's glossy light
falls short: the ratio EEVEE / Cycles binned by the angle between normal and sun. EEVEE evaluates
a GGX lobe under a lamp with a linearly transformed cosine (Heitz, Dupuy, Hill and Neubelt 2016,
"Real-time polygonal-light shading with linearly transformed cosines"): a clamped cosine mapped
by a 3x3 matrix fitted per (roughness, view). That distribution is exactly zero beyond the mapped
cosine's horizon, so the long tail of a rough GGX lobe is missing where the lamp is low over the
surface. Diffuse light is exact (the Lambertian row).

Metrics, on the sphere pixels where the Cycles render is above ``FLOOR``: the median per-pixel
relative difference of the luminance-like RGB mean (the figure the gap was first reported in) and
the relative L1 (sum |e - c| / sum c), which weighs pixels by their light.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .. import suite
from .paths import BENCH_DIR
from .eevee_closures import lobe_sum_material
from .page import write_page
from .registry import Bench, cases_argument, register

SUN_DIR = (0.35, -0.75, 0.56)  # normalised by the scene builder
RES, SPP = 96, 64
FLOOR = 1e-4  # Cycles radiance below which a pixel is left out of the per-pixel figures
LIT = 0.01  # "lit" pixels: Cycles above this fraction of its 99th percentile on the sphere
NL_BINS = ((0.0, 0.1), (0.1, 0.3), (0.3, 0.5), (0.5, 0.7), (0.7, 1.01))
SWEEP_ROUGHNESS = (0.1, 0.316, 0.464, 0.6)


def isotropic_cases() -> list[str]:
    out = []
    for name in suite.names():
        s = suite.load(name)
        if all(r[0] == r[1] for r in (getattr(layer, "roughness", (0.0, 0.0)) for layer in (*s.coats, s.base))):
            out.append(name)
    return out


def _normal_dot_sun(res: int = RES) -> tuple[np.ndarray, np.ndarray]:
    """(N . sun, on-sphere mask) per pixel of the canonical orthographic view (top row first)."""
    from .image_references import sphere_normals

    s = np.asarray(SUN_DIR, float)
    s /= np.linalg.norm(s)
    n, on = sphere_normals(res)
    return n @ s, on


def gap(eevee: np.ndarray, cycles: np.ndarray) -> dict:
    """EEVEE against Cycles: median per-pixel relative difference, relative L1, and the ratio of
    sums per bin of N . sun."""
    e, c = eevee[..., :3].mean(-1), cycles[..., :3].mean(-1)
    nl, on = _normal_dot_sun(c.shape[0])
    m = on & (c > FLOOR)
    rel = np.abs(e - c)[m] / c[m]
    lit = on & (c > LIT * np.percentile(c[on], 99))
    bins = {}
    for lo, hi in NL_BINS:
        k = m & (nl >= lo) & (nl < hi)
        bins[f"{lo:g}-{min(hi, 1.0):g}"] = float(e[k].sum() / c[k].sum()) if c[k].sum() > 0 else None
    return {"median_rel": float(np.median(rel)), "median_rel_lit": float(np.median(np.abs(e - c)[lit] / c[lit])),
            "rel_l1": float(np.abs(e - c)[m].sum() / c[m].sum()),
            "pixels": int(m.sum()), "ratio_by_n_dot_sun": bins}


# ---------------------------------------------------------------- renders
def _scene():
    from ..render import build_scene

    return build_scene("sphere-sun", RES, SPP, SUN_DIR)


def _render(sc, eevee: bool) -> np.ndarray:
    from ..render import render_scene, use_eevee

    if eevee:
        use_eevee(sc)
    else:
        sc.cycles.shading_system = False  # a plain node material: SVM renders it as OSL would
    return render_scene(sc)[0]


def _material(sphere, build):
    """The only material of ``sphere``: what ``build(nt)`` returns (a shader socket) on its output."""
    from ..render import sphere_material

    _, nt, out = sphere_material(sphere, "control")
    nt.links.new(build(nt), out.inputs["Surface"])


def matched_lobes(stack) -> list[tuple]:
    """Our lobes at normal incidence as (kind, RGB energy, GGX alpha) for plain BSDF nodes
    (``eevee_closures.lobe_sum_material``); an anisotropic lobe as alpha = sqrt(ax ay), as the
    group gives EEVEE. Transmission lobes are left out: a closed sphere lit from the front shows
    them only after bounces."""
    from lamella.core.api import lobes

    ls = lobes(stack, np.array([[0.0, 0.0, 1.0]]))
    return [(kind, tuple(map(float, ls.weight[0, k])), math.sqrt(ls.alpha_x[0, k] * ls.alpha_y[0, k]))
            for k, kind in enumerate(ls.kinds) if kind in ("reflection", "backscatter", "diffuse")]


def _pair(make) -> tuple[np.ndarray, np.ndarray]:
    """(EEVEE, Cycles) renders of the material ``make(sphere)`` gives the sphere."""
    out = []
    for eevee in (True, False):
        sc, sphere = _scene()
        make(sphere)
        if eevee:
            _render(sc, True)  # the first EEVEE render compiles
        out.append(_render(sc, eevee))
    return out[0], out[1]


def stack_row(name: str) -> dict:
    from ..render import _principled, assign_material, render_scene

    stack = suite.load(name)
    renders = {}
    for engine in ("cycles-osl", "eevee"):
        sc, sphere = _scene()
        assign_material(sphere, stack, engine)
        if engine == "eevee":
            render_scene(sc)
        renders[engine] = render_scene(sc)[0]
    pe, pc = _pair(lambda sphere: _material(sphere, lambda nt: _principled(nt, stack).outputs["BSDF"]))
    le, lc = _pair(lambda sphere: lobe_sum_material(sphere, matched_lobes(stack)))
    return {"stack": name, "ours": gap(renders["eevee"], renders["cycles-osl"]), "principled": gap(pe, pc),
            "lobe_matched": gap(le, lc)}


def sweep_rows() -> list[dict]:
    def principled(r):
        def build(nt):
            p = nt.nodes.new("ShaderNodeBsdfPrincipled")
            p.inputs["Base Color"].default_value = (0.8, 0.8, 0.8, 1.0)
            p.inputs["Metallic"].default_value = 1.0
            p.inputs["Roughness"].default_value = r
            return p.outputs["BSDF"]
        return build

    def lambert(nt):
        return nt.nodes.new("ShaderNodeBsdfDiffuse").outputs[0]

    rows = [{"material": "Diffuse BSDF", **gap(*_pair(lambda sphere: _material(sphere, lambert)))}]
    rows += [{"material": f"Principled metal r {r:g}", **gap(*_pair(lambda sphere, r=r: _material(sphere, principled(r))))}
             for r in SWEEP_ROUGHNESS]
    return rows


def run(out_dir: Path = BENCH_DIR, cases=None, progress: bool = True) -> Path:
    import bpy  # noqa: F401
    from tqdm import tqdm

    cases = list(cases) if cases else isotropic_cases()
    sweep = sweep_rows()
    rows = [stack_row(n) for n in tqdm(cases, desc="eevee-gap", disable=not progress)]
    data = {"settings": {"res": RES, "spp": SPP, "sun_dir": SUN_DIR, "floor": FLOOR}, "sweep": sweep, "stacks": rows}
    return write_page(out_dir, "eevee_gap", lambda: format_markdown(data), data)


def _pct(x) -> str:
    return f"{100 * x:.1f} %"


def _three(g: dict) -> str:
    return f"{_pct(g['median_rel'])} / {_pct(g['median_rel_lit'])} / {_pct(g['rel_l1'])}"


def format_markdown(data: dict) -> str:
    bins = [f"{lo:g}-{min(hi, 1.0):g}" for lo, hi in NL_BINS]
    st = data["settings"]
    lines = [
        "# EEVEE against Cycles: whose gap it is",
        "",
        f"Generated by `lamella bench eevee-gap` (`lamella_dev/bench/eevee_gap.py`): `sphere-sun`, sun "
        f"{','.join(map(str, st['sun_dir']))} (normalised), {st['res']} px, {st['spp']} samples; pixels where Cycles "
        f"is above {st['floor']:g}. *median*: median per-pixel relative difference; *lit*: the same over the pixels "
        f"above {LIT:g} of the sphere's 99th percentile (leaves out the dim tail); *rel. L1*: sum |EEVEE - Cycles| / "
        "sum Cycles; the N . sun columns: EEVEE's light over Cycles' in that band of the sphere.",
        "",
        "## Where EEVEE's glossy light falls short",
        "",
        "| material | median | lit | rel. L1 | " + " | ".join(f"N.sun {b}" for b in bins) + " |",
        "|---|---:|---:|---:|" + "---:|" * len(bins),
    ]
    for r in data["sweep"]:
        lines.append(f"| {r['material']} | {_pct(r['median_rel'])} | {_pct(r['median_rel_lit'])} | {_pct(r['rel_l1'])} | "
                     + " | ".join("" if r["ratio_by_n_dot_sun"][b] is None else f"{r['ratio_by_n_dot_sun'][b]:.2f}"
                                  for b in bins) + " |")
    lines += [
        "",
        "## Every isotropic suite stack",
        "",
        "*ours*: the staged node group in EEVEE against the OSL shader in Cycles; *Principled*: the stand-in in "
        "EEVEE against itself in Cycles; *lobe-matched*: Glossy BSDFs with our lobes' roughness and energy at "
        "normal incidence, EEVEE against Cycles. Last column: our relative L1 over the lobe-matched control's.",
        "",
        "| stack | ours: median / lit / rel. L1 | Principled: median / lit / rel. L1 | "
        "lobe-matched: median / lit / rel. L1 | ours / lobe-matched (rel. L1) |",
        "|---|---:|---:|---:|---:|",
    ]
    for r in data["stacks"]:
        o, p, m = r["ours"], r["principled"], r["lobe_matched"]
        lines.append(f"| {r['stack']} | {_three(o)} | {_three(p)} | {_three(m)} | "
                     f"{o['rel_l1'] / max(m['rel_l1'], 1e-9):.2f} |")
    return "\n".join(lines) + "\n"


BENCH = register(Bench("eevee-gap",
                       "EEVEE against Cycles per isotropic suite stack, with controls that tell whose the gap is",
                       lambda out_dir, args: run(out_dir, cases=args.cases or None),
                       lambda parser: cases_argument(parser, isotropic_cases, "isotropic suite case")))
