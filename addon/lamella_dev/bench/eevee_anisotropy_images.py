"""`lamella bench eevee-anisotropy-images`: the anisotropic suite stacks rendered in EEVEE against
Cycles, as the node group draws them.

EEVEE draws every Glossy BSDF round. The node group gives EEVEE, in place of each anisotropic lobe,
isotropic lobes about normals tilted along its long axis (``lamella.core.lobe_kinds.isotropic_fit``,
staged per material: ``Staged.stand_ins``), behind a switch Cycles reads as 0 (``node_group``).
Each stack is rendered on the canonical sphere (radial tangent about z) in two lights, the forest
HDRI (``sphere-env``) and one sun (``sphere-sun``):

- **Cycles**: the node group in Cycles without OSL (the anisotropic lobes as they are), the
  reference of the row;
- **EEVEE, stand-ins**: the node group in EEVEE as it ships;
- **EEVEE, round**: the group without stand-ins (before them: the anisotropic Glossy BSDF, which
  EEVEE draws with alpha = sqrt(ax ay));
- **Principled, EEVEE against Cycles**: the control, the Principled stand-in artists use (the
  conductor's colour and anisotropic roughness, one clear coat) with its own anisotropy, rendered
  in both engines: how much of its streak EEVEE keeps.

Figures over the sphere's pixels: relative L1 (sum |a - b| / sum b) and mean delta-E00 (CIEDE2000
of the tone-mapped renders, ``image_metrics``). A contact sheet per light shows the renders."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .. import suite
from ..image_metrics import mean_delta_e00
from .eevee_standins import anisotropic_cases
from .image_references import sphere_mask
from .page import write_page
from .paths import BENCH_DIR
from .registry import Bench, cases_argument, register

RES, SPP = 96, 64
SCENES = ("sphere-env", "sphere-sun")
SUN_DIR = (0.35, -0.75, 0.56)
COLUMNS = ("EEVEE, stand-ins", "EEVEE, round", "Principled, EEVEE against Cycles")


def _principled_anisotropic(nt, stack):
    """The Principled stand-in (``render._principled``) with the conductor's anisotropy, on the
    radial tangent the group uses. Cycles' Principled BSDF takes alpha = r^2 and, for Anisotropic
    a > 0, alpha_x = alpha / s, alpha_y = alpha s with s = sqrt(1 - 0.9 a) (``svm_node_closure_bsdf``):
    so r^2 = sqrt(ax ay) and a = (1 - small / large) / 0.9 (an axis ratio of 10 at most), the
    tangent turned by the base's rotation, and a quarter turn more where the larger axis is y."""
    from lamella.core.param_id import r_from_alpha
    from ..render import _principled

    p = _principled(nt, stack)
    b = stack.base
    if b.type == "conductor":
        ax, ay = b.roughness
        big, small = max(ax, ay), min(ax, ay)
        turn = b.rotation / (2.0 * math.pi) + (0.25 if ay > ax else 0.0)
        p.inputs["Roughness"].default_value = r_from_alpha(math.sqrt(ax * ay))
        p.inputs["Anisotropic"].default_value = min((1.0 - small / big) / 0.9, 1.0) if big > 0 else 0.0
        p.inputs["Anisotropic Rotation"].default_value = turn % 1.0
        tangent = nt.nodes.new("ShaderNodeTangent")
        tangent.direction_type, tangent.axis = "RADIAL", "Z"
        nt.links.new(tangent.outputs["Tangent"], p.inputs["Tangent"])
    return p


def _render(scene: str, make, eevee: bool) -> np.ndarray:
    from ..render import build_scene, render_scene, use_eevee

    sc, sphere = build_scene(scene, RES, SPP, SUN_DIR)
    make(sphere)
    if eevee:
        use_eevee(sc)
        render_scene(sc)  # the first EEVEE render compiles the shaders
    else:
        sc.cycles.shading_system = False
    return render_scene(sc)[0]


def renders(name: str, scene: str) -> dict:
    """The four renders of one stack in one light."""
    from ..render import assign_material, sphere_material

    stack = suite.load(name)

    def ours(eevee, stand_ins=None):
        def make(sphere):
            assign_material(sphere, stack, "eevee" if eevee else "cycles-nodes",
                            **({} if stand_ins is None else {"stand_ins": stand_ins}))
        return _render(scene, make, eevee)

    def principled(eevee):
        def make(sphere):
            _, nt, out = sphere_material(sphere, "principled")
            nt.links.new(_principled_anisotropic(nt, stack).outputs["BSDF"], out.inputs["Surface"])
        return _render(scene, make, eevee)

    return {"Cycles": ours(False), "EEVEE, stand-ins": ours(True), "EEVEE, round": ours(True, 0),
            "Principled, Cycles": principled(False), "Principled, EEVEE": principled(True)}


def _figures(img, ref, mask) -> dict:
    a, b = img[mask, :3], ref[mask, :3]
    return {"rel_l1": float(np.abs(a - b).sum() / max(np.abs(b).sum(), 1e-12)),
            "delta_e00": mean_delta_e00(img, ref, mask)}


def measure(cases=None, out_dir: Path = BENCH_DIR, progress: bool = True) -> dict:
    from tqdm import tqdm

    from ..plots import contact_sheet

    cases = list(cases) if cases else anisotropic_cases()
    rows, sheets = [], {}
    work = [(scene, name) for scene in SCENES for name in cases]
    images = {scene: {} for scene in SCENES}
    for scene, name in tqdm(work, desc="eevee-anisotropy-images", disable=not progress):
        r = renders(name, scene)
        mask = sphere_mask(r["Cycles"])
        row = {"stack": name, "scene": scene,
               "EEVEE, stand-ins": _figures(r["EEVEE, stand-ins"], r["Cycles"], mask),
               "EEVEE, round": _figures(r["EEVEE, round"], r["Cycles"], mask),
               "Principled, EEVEE against Cycles": _figures(r["Principled, EEVEE"], r["Principled, Cycles"], mask)}
        rows.append(row)
        for k in ("Cycles", "EEVEE, stand-ins", "EEVEE, round", "Principled, Cycles", "Principled, EEVEE"):
            images[scene][f"{name}: {k}"] = r[k]
    for scene in SCENES:
        sheets[scene] = contact_sheet(images[scene], Path(out_dir) / f"eevee_anisotropy_images_{scene}.png", ncols=5,
                                      title=f"{scene}: Cycles (node group) | EEVEE stand-ins | EEVEE round | "
                                            "Principled Cycles | Principled EEVEE").name
    return {"settings": {"res": RES, "spp": SPP, "scenes": SCENES, "sun_dir": SUN_DIR}, "rows": rows, "sheets": sheets}


def format_markdown(data: dict) -> str:
    st = data["settings"]
    lines = [
        "# EEVEE: anisotropic stacks against Cycles",
        "",
        f"Generated by `lamella bench eevee-anisotropy-images` (`lamella_dev/bench/eevee_anisotropy_images.py`): "
        f"the anisotropic suite stacks on the canonical sphere (radial tangent about z), {st['res']} px, "
        f"{st['spp']} samples in both engines. Each anisotropic lobe is drawn in EEVEE as three isotropic lobes "
        "about normals tilted along its long axis (*stand-ins*, `lamella/core/lobe_kinds/isotropic_fit.py`), "
        "against the anisotropic lobes Cycles draws from the same node group; *round*: the same group without "
        "them (EEVEE reads the anisotropic Glossy BSDF as alpha = sqrt(ax ay)); the control is the Principled "
        "BSDF with the conductor's anisotropy, EEVEE against Cycles. Relative L1 / mean delta-E00 over the "
        "sphere (lower is better).",
        "",
    ]
    for scene in st["scenes"]:
        rows = [r for r in data["rows"] if r["scene"] == scene]
        lines += [f"## {scene}", "", "| stack | " + " | ".join(COLUMNS) + " |", "|---|" + "---:|" * len(COLUMNS)]
        for r in rows:
            best = min(COLUMNS[:2], key=lambda c: r[c]["rel_l1"])
            cells = [(f"**{r[c]['rel_l1']:.3f}** / {r[c]['delta_e00']:.2f}" if c == best else
                      f"{r[c]['rel_l1']:.3f} / {r[c]['delta_e00']:.2f}") for c in COLUMNS]
            lines.append(f"| {r['stack']} | " + " | ".join(cells) + " |")
        means = {c: (np.mean([r[c]["rel_l1"] for r in rows]), np.mean([r[c]["delta_e00"] for r in rows])) for c in COLUMNS}
        lines.append("| **mean** | " + " | ".join(f"{l1:.3f} / {de:.2f}" for l1, de in means.values()) + " |")
        lines += ["", f"![{scene}]({data['sheets'][scene]})", ""]
    return "\n".join(lines)


def run(out_dir: Path = BENCH_DIR, cases=None, progress: bool = True) -> Path:
    import bpy  # noqa: F401

    data = measure(cases, out_dir, progress)
    return write_page(out_dir, "eevee_anisotropy_images", lambda: format_markdown(data), data)


BENCH = register(Bench("eevee-anisotropy-images",
                       "the anisotropic suite stacks in EEVEE (tilted isotropic stand-ins, and round) against Cycles, "
                       "beside the Principled BSDF's anisotropy",
                       lambda out_dir, args: run(out_dir, cases=args.cases or None),
                       lambda parser: cases_argument(parser, anisotropic_cases, "anisotropic suite case")))
