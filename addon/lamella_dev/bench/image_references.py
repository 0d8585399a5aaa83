"""Stored image references (Heitz et al. 2016's walk on each interface, or single scattering): every suite case rendered as nested interface spheres
(``lamella_dev.reference_scene``) in the canonical ``sphere-env`` scene.

Each reference is the average of renders ("chunks") with seeds 0, 1, 2, ...; the spread between
chunks gives the reference's own noise at its full sample count (the noise floor reported beside
every image error in ``bench/images.md``). ``--add`` refines stored references by two more chunks. Tests read these files; they never regenerate them:
``make image-references`` (or the command stored in ``INDEX.json``) does.
"""
from __future__ import annotations

import json
import platform
import time
from pathlib import Path

import numpy as np

from .. import suite
from lamella.core.exr import read_rgba, write_rgba
from .paths import REPO
from .page import write_page
from .registry import Bench, register

IMAGE_REFERENCE_DIR = REPO / "tests" / "references" / "images"
IMAGE_REFERENCE_DIR_MULTIPLE = REPO / "tests" / "references" / "images_multiple"  # energy-conserving interfaces
INDEX = "INDEX.json"
RES = 128
SPP = 2048


def sphere_normals(res: int) -> tuple[np.ndarray, np.ndarray]:
    """The unit sphere's normal (world space, (res, res, 3)) at each pixel centre of the canonical
    orthographic view (``render.build_scene``: ortho scale 2.2, the camera looking along +y, top
    row first), and the pixels whose centre lies inside the sphere, away from its silhouette."""
    u = (np.arange(res) + 0.5) / res * 2.2 - 1.1
    x, z = np.meshgrid(u, -u)
    r2 = x * x + z * z
    return np.stack([x, -np.sqrt(np.clip(1.0 - r2, 0.0, 1.0)), z], -1), r2 < 0.97


def sphere_pixels(res: int) -> np.ndarray:
    """Pixels of the canonical orthographic view whose centre lies inside the sphere, away from its
    silhouette (``sphere_normals``)."""
    return sphere_normals(res)[1]


def sphere_mask(rgba: np.ndarray) -> np.ndarray:
    """The pixels of a canonical render (``rgba``, square, top row first) the sphere covers:
    image metrics are taken there, so the background (the same HDRI in every render) does not
    dilute them. Geometric: the renders' alpha is 1 everywhere (the world is rendered, not a
    transparent film), so it cannot tell the sphere from the background."""
    h, w = rgba.shape[:2]
    if h != w:
        raise ValueError(f"a canonical render is square, got {w}x{h}")
    return sphere_pixels(h)


def load_index(out_dir: Path = IMAGE_REFERENCE_DIR) -> dict:
    p = Path(out_dir) / INDEX
    return json.loads(p.read_text()) if p.exists() else {"cases": {}}


def render_chunks(name: str, seeds, chunk_spp: int, res: int = RES, thickness: float | None = None,
                  interfaces: str = "single"):
    """The reference renders of suite case ``name``, one per seed: (list of RGBA images, seconds).
    ``interfaces``: as ``reference_scene.build_reference``."""
    from ..render import render_stack

    stack = suite.load(name)
    images, seconds = [], 0.0
    for seed in seeds:
        img, t = render_stack(stack, "sphere-env", res=res, spp=chunk_spp, engine="reference", seed=seed,
                              thickness=thickness, interfaces=interfaces)
        images.append(img)
        seconds += t
    return images, seconds


def chunk_noise(a: np.ndarray, b: np.ndarray, mask: np.ndarray) -> float:
    """Per-pixel standard deviation of one chunk, RMS over the mask, from two independent chunks:
    RMS(a - b) / sqrt(2)."""
    d = a[mask, :3] - b[mask, :3]
    return float(np.sqrt(np.mean(d * d) / 2.0))


def compute(cases=None, res: int = RES, spp: int = SPP, out_dir: Path = IMAGE_REFERENCE_DIR,
            thickness: float | None = None, command: str = "", add: bool = False, interfaces: str = "single") -> Path:
    """Render (or with ``add``, refine) the stored references. A reference is the mean of chunks of
    ``spp / 2`` samples with seeds 0, 1, 2, ...; refining renders two more chunks and folds them in,
    so references can be improved in steps. The noise figure is the chunk standard deviation (from
    the newest pair of chunks) divided by sqrt(number of chunks). ``interfaces``: the nested
    spheres' rough interfaces (``reference_scene.INTERFACES``), recorded per case."""
    from ..reference_scene import SHELL_THICKNESS

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    index = load_index(out_dir)
    chunk_spp = max(spp // 2, 1)
    for name in cases or suite.names():
        t0 = time.time()
        old = index["cases"].get(name) if add else None
        if old is not None and old["spp"] // len(old["seeds"]) != chunk_spp:
            raise ValueError(f"{name}: stored chunks have {old['spp'] // len(old['seeds'])} spp; refine with "
                             f"--spp {2 * old['spp'] // len(old['seeds'])}")
        first = len(old["seeds"]) if old else 0
        seeds = [first, first + 1]
        used_thickness = old["shell_thickness"] if old is not None else (thickness or SHELL_THICKNESS)
        if old is not None and old.get("interfaces", "single") != interfaces:
            raise ValueError(f"{name}: stored with {old.get('interfaces', 'single')} interfaces, not {interfaces}")
        (a, b), seconds = render_chunks(name, seeds, chunk_spp, res, used_thickness, interfaces)
        new = 0.5 * (a + b)
        if old is not None:
            k_old = len(old["seeds"])
            img = (read_rgba(out_dir / old["file"]).astype(np.float64) * k_old + new * 2) / (k_old + 2)
            seconds += old["render_seconds"]
            seeds = old["seeds"] + seeds
        else:
            img = new
        m = sphere_mask(img)
        sigma = chunk_noise(a, b, m)
        write_rgba(out_dir / f"{name}.exr", img, half=True)
        index["cases"][name] = {
            "file": f"{name}.exr", "res": res, "spp": chunk_spp * len(seeds), "chunk_spp": chunk_spp,
            "seeds": seeds, "shell_thickness": used_thickness, "interfaces": interfaces,
            "chunk_noise_rmse": sigma, "noise_rmse": sigma / np.sqrt(len(seeds)),
            "render_seconds": round(seconds, 1),
            "mean_radiance": [float(x) for x in img[m, :3].mean(0)],
        }
        index["command"] = command or f"lamella image-references --spp {spp} --res {res}"
        index["machine"] = f"{platform.machine()}, {platform.python_version()}"
        (out_dir / INDEX).write_text(json.dumps(index, indent=2, sort_keys=True) + "\n")
        print(f"{name}: {len(seeds)} chunks of {chunk_spp} spp, noise RMSE {index['cases'][name]['noise_rmse']:.4f} "
              f"({time.time() - t0:.0f} s)", flush=True)
    return out_dir / INDEX


def thickness_study(cases=("tinted_varnish", "three_coats"), thicknesses=(0.002, 0.004, 0.008), spp: int = 512,
                    res: int = RES, out_dir: Path | None = None, progress=print) -> Path:
    """bench/reference_shells.md: does the shell thickness of the nested-sphere reference change
    the image? Each case rendered with shells of each thickness (same seeds), compared with the
    default thickness on 8x8-pixel tiles (per-pixel noise divided by 8) and by mean radiance."""
    from ..reference_scene import SHELL_THICKNESS
    from ..image_metrics import block_rmse, mean_bias
    from .paths import BENCH_DIR

    out_dir = Path(out_dir or BENCH_DIR)
    rows = []
    for name in cases:
        imgs, noise = {}, {}
        for d in thicknesses:
            (a, b), seconds = render_chunks(name, (0, 1), max(spp // 2, 1), res, d)
            imgs[d] = 0.5 * (a + b)
            noise[d] = chunk_noise(a, b, sphere_mask(imgs[d])) / np.sqrt(2.0)
            progress(f"{name} d={d}: {seconds:.0f} s")
        ref = imgs[SHELL_THICKNESS]
        m = sphere_mask(ref)
        for d in thicknesses:
            rows.append({"case": name, "thickness": d, "mean_radiance": [float(x) for x in imgs[d][m, :3].mean(0)],
                         "bias_vs_default": mean_bias(imgs[d], ref, m), "rmse_8px_vs_default": block_rmse(imgs[d], ref, m, 8),
                         "noise_rmse": noise[d]})
    lines = ["# Shell thickness of the nested-sphere references", "",
             f"Generated by `lamella bench shells`: {res} px, {spp} spp (seeds 0 and 1), canonical `sphere-env`. The",
             f"stored references use shells {SHELL_THICKNESS} thick per coat (sphere radius 1; a pixel is {2.2 / res:.4f}).",
             "`RMSE 8px` compares 8×8-pixel tile means with the default thickness (the per-pixel noise floor",
             "divided by 8 is about `noise`/8); `bias` is the relative change of the mean radiance over the sphere.", "",
             "| case | shell thickness | mean radiance RGB | bias vs default | RMSE 8px vs default | noise (per pixel) |",
             "|---|---:|---|---:|---:|---:|"]
    for r in rows:
        rgb = ", ".join(f"{x:.4f}" for x in r["mean_radiance"])
        lines.append(f"| {r['case']} | {r['thickness']} | {rgb} | {r['bias_vs_default']:+.4f} | "
                     f"{r['rmse_8px_vs_default']:.4f} | {r['noise_rmse']:.4f} |")
    return write_page(out_dir, "reference_shells", "\n".join(lines), rows)


BENCH = register(Bench("shells", "effect of the nested-sphere reference's shell thickness",
                       lambda out_dir, args: thickness_study(out_dir=out_dir)))
