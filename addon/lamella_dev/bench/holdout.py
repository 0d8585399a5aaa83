"""`lamella bench holdout`: the models on stacks no one tuned them on.

The suite's stacks (``lamella_dev.suite``) are the ones every model change was measured on, so a
change can fit them and not carry over. The hold-out set is drawn at random, once, from the
ranges artists use (``draw``: one to three coats, clear / absorbing / scattering, isotropic or
brushed, over a measured metal, a diffuse or a glass base), with a fixed seed, and its
energy-conserving references (multiple-scattering interfaces, Heitz et al. 2016) are stored in
``tests/references/brdf_holdout`` with the stack in their meta. A model change is kept when it
helps here as well as on the suite.

    lamella bench holdout --references   # draw the stacks and compute their references (CPU: ~30 min)
    lamella bench holdout                # the table, bench/holdout.md, from the stored references
    lamella bench holdout --references --cases holdout_00 --spp 65536   # one stack's, with more walkers

holdout_00 (a smooth absorbing coat over two rough ones) is stored with 65536 walkers per direction:
few paths cross its layers, and at 4096 the reference's own noise on the metric was 0.43-0.61, far
above what the keep rule tells apart.
"""
from __future__ import annotations

import json
import math
import platform
import time
from pathlib import Path

import numpy as np

from lamella.core import metals
from .. import suite
from lamella.core.stack import Stack
from .paths import BENCH_DIR, REPO
from .accuracy import MODELS, _angle_arrays, evaluate_case, load_reference
from .page import write_page
from .registry import Bench, register

HOLDOUT_DIR = REPO / "tests" / "references" / "brdf_holdout"
SEED = 20261126
COUNT = 16
SPP = 4096


def _roughness(rng, smooth_p: float, aniso_p: float) -> tuple[list[float], float]:
    """GGX alpha per axis and the rotation: alpha = r^2 with r uniform (how artists set it), a share
    of smooth layers and of brushed (anisotropic, rotated) ones."""
    if rng.random() < smooth_p:
        return [0.0, 0.0], 0.0
    r = float(rng.uniform(0.15, 0.65))
    a = r * r  # correctly rounded on every processor (libm's pow is not: the draw is a stored golden)
    if rng.random() < aniso_p:
        return [a, a * float(rng.uniform(0.15, 0.8))], float(rng.uniform(0.0, math.pi))
    return [a, a], 0.0


def _coat(rng) -> dict:
    rough, rot = _roughness(rng, smooth_p=0.3, aniso_p=0.2)
    c = {"type": "coat", "ior": round(float(rng.uniform(1.3, 1.7)), 3), "roughness": rough, "rotation": rot}
    u = rng.random()
    if u < 0.35:  # tinted: absorbing interior
        c.update(thickness=round(float(rng.uniform(0.2, 1.0)), 3),
                 sigma_a=[round(float(x), 3) for x in rng.uniform(0.0, 2.0, 3)])
    elif u < 0.55:  # milky: a scattering interior
        c.update(thickness=round(float(rng.uniform(0.1, 1.0)), 3),
                 sigma_a=[round(float(x), 3) for x in rng.uniform(0.0, 0.5, 3)],
                 sigma_s=[round(float(x), 3) for x in rng.uniform(0.2, 3.0, 3)],
                 g=round(float(rng.uniform(-0.3, 0.9)), 3))
    return c


def _base(rng) -> dict:
    u = rng.random()
    if u < 0.6:
        name = str(rng.choice(list(metals.measured())))
        m = metals.measured()[name]
        rough, rot = _roughness(rng, smooth_p=0.2, aniso_p=0.3)
        return {"type": "conductor", "eta": m["eta"], "k": m["k"], "roughness": rough, "rotation": rot}
    if u < 0.85:
        return {"type": "diffuse", "albedo": [round(float(x), 3) for x in rng.uniform(0.1, 0.9, 3)]}
    rough, rot = _roughness(rng, smooth_p=0.2, aniso_p=0.0)
    return {"type": "dielectric", "ior": round(float(rng.uniform(1.3, 1.7)), 3), "roughness": rough, "rotation": rot}


def draw(count: int = COUNT, seed: int = SEED) -> dict[str, Stack]:
    """The hold-out stacks, by name (``holdout_00`` ...): the same for the same seed."""
    rng = np.random.default_rng(seed)
    out = {}
    for k in range(count):
        n = int(rng.choice([1, 2, 3], p=[0.5, 0.35, 0.15]))
        name = f"holdout_{k:02d}"
        out[name] = Stack.from_dict({"name": name, "layers": [_coat(rng) for _ in range(n)], "base": _base(rng)})
    return out


def compute_references(stacks: dict[str, Stack], spp: int = SPP, albedo_spp: int = 1 << 17, seed: int = 1,
                       out_dir: Path = HOLDOUT_DIR, progress=print,
                       command: str = "lamella bench holdout --references") -> list[Path]:
    """Energy-conserving references of ``stacks`` at the suite's incidences and 45 degrees, stored as
    the suite's are (``accuracy.compute_references``) with the stack itself in the meta."""
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for name, stack in stacks.items():
        t0 = time.time()
        data: dict[str, np.ndarray] = {"wi_degrees": np.array(sorted(suite.REFERENCE_ANGLES))}
        for i, deg in enumerate(sorted(suite.REFERENCE_ANGLES)):
            arrays = _angle_arrays(stack, deg, spp, albedo_spp, seed, "multiple")
            data.update({f"{k}_{i}": v for k, v in arrays.items()})
        meta = {"case": name, "stack": stack.to_dict(), "spp": spp, "albedo_spp": albedo_spp, "seed": seed,
                "interfaces": "multiple", "draw_seed": SEED, "command": command,
                "seconds": round(time.time() - t0, 1), "machine": platform.machine()}
        data["meta"] = np.array(json.dumps(meta))
        path = out_dir / f"{name}.npz"
        np.savez_compressed(path, **data)
        written.append(path)
        progress(f"{name}: {meta['seconds']} s -> {path}")
    return written


def stored(ref_dir: Path = HOLDOUT_DIR) -> dict[str, dict]:
    """The stored hold-out references by name (each with its stack in ``meta``)."""
    return {p.stem: load_reference(p.stem, ref_dir) for p in sorted(ref_dir.glob("*.npz"))}


def describe(stack: Stack) -> str:
    """One line: the coats top to bottom, then the base."""
    parts = []
    for c in stack.coats:
        a = c.roughness
        s = f"coat {c.ior:g} a {a[0]:.2g}" + (f"/{a[1]:.2g}" if a[1] != a[0] else "")
        if c.thickness and max(c.sigma_s) > 0:
            s += f" scattering d {c.thickness:g}"
        elif c.thickness and max(c.sigma_a) > 0:
            s += f" absorbing d {c.thickness:g}"
        parts.append(s)
    b = stack.base
    if b.type == "diffuse":
        parts.append("diffuse " + "/".join(f"{x:g}" for x in b.albedo))
    else:
        a = b.roughness
        parts.append(f"{b.type} a {a[0]:.2g}" + (f"/{a[1]:.2g}" if a[1] != a[0] else ""))
    return ", ".join(parts)


def run(ref_dir: Path = HOLDOUT_DIR, out_dir: Path = BENCH_DIR, models=MODELS) -> tuple[Path, Path]:
    """Every model against the stored hold-out references: bench/holdout.md and .json."""
    refs = stored(ref_dir)
    if not refs:
        raise FileNotFoundError(f"no hold-out references in {ref_dir}: run `lamella bench holdout --references`")
    rows = []
    for name, ref in refs.items():
        stack = Stack.from_dict(ref["meta"]["stack"])
        rows.extend(evaluate_case(name, ref, models, stack=stack))
    mpath = write_page(out_dir, "holdout", lambda: _markdown(refs, rows, models),
                       {"models": list(models), "rows": rows})
    return mpath, mpath.with_suffix(".json")


def _walkers(refs: dict) -> str:
    """How many walkers per direction the references hold: the most common count, and the stacks
    rendered with another (a stack whose paths through its layers are rare gets more)."""
    counts = {name: ref["meta"]["spp"] for name, ref in refs.items()}
    usual = max(set(counts.values()), key=list(counts.values()).count)
    others = [f"{name}: {n}" for name, n in counts.items() if n != usual]
    return f"{usual} walkers per direction" + (f" ({', '.join(others)})" if others else "")


def _markdown(refs: dict, rows: list[dict], models) -> str:
    wis = sorted({r["wi"] for r in rows})
    lines = ["# The models on stacks drawn at random (the hold-out set)", "",
             f"`lamella bench holdout`: {len(refs)} stacks drawn once from the ranges artists use "
             f"(`lamella_dev.bench.holdout.draw`, seed {SEED}), never used to tune a model, against "
             "energy-conserving references (multiple-scattering interfaces, "
             f"{_walkers(refs)}, `tests/references/brdf_holdout`). "
             "Relative L1 / albedo error, reflected side, as in `bench/accuracy.md`.", "",
             "## Median over the set", ""]
    from .accuracy import median_table
    lines += median_table(rows, models, wis)
    lines += ["", "## Per stack (`auto`; `noise`: the reference's own noise on the metric)", "",
              "| stack | " + " | ".join(f"{w:g}°" for w in wis) + " |", "|---|" + "---|" * len(wis)]
    for name, ref in refs.items():
        stack = Stack.from_dict(ref["meta"]["stack"])
        cells = []
        for w in wis:
            r = next((r for r in rows if r["case"] == name and r["model"] == "auto" and r["wi"] == w), None)
            cells.append(f"{r['rel_l1']:.3f} / {r['albedo_err']:.3f} (noise {r['ref_noise']:.3f})"
                         if r and "rel_l1" in r else "—")
        lines.append(f"| {name}: {describe(stack)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _arguments(parser) -> None:
    from ..arguments import count, names

    parser.add_argument("--references", action="store_true",
                        help="draw the hold-out stacks and compute their energy-conserving references first "
                             "(about 30 minutes of CPU)")
    parser.add_argument("--cases", type=names("hold-out stack", lambda: list(draw())),
                        help="with --references: only these stacks (comma-separated names)")
    parser.add_argument("--spp", type=count(), default=SPP, help=f"with --references: walkers per direction "
                                                                f"(default {SPP})")


def _bench(out_dir: Path, args) -> Path:
    if args.references:
        stacks = draw()
        if args.cases:
            stacks = {n: stacks[n] for n in args.cases}
        compute_references(stacks, spp=args.spp,
                           command="lamella bench holdout --references"
                                   + (f" --cases {','.join(args.cases)}" if args.cases else "")
                                   + (f" --spp {args.spp}" if args.spp != SPP else ""))
    return run(out_dir=out_dir)[0]


BENCH = register(Bench("holdout", "every model on stacks drawn at random once and never tuned on",
                       _bench, _arguments))
