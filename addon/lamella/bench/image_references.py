"""Stored image references (issue 3): every suite case rendered as nested interface spheres
(``lamella.blender.reference_scene``) in the canonical ``sphere-env`` scene.

Each reference is the average of two renders with different seeds; half their per-pixel RMS
difference is the reference's own noise at its full sample count (the noise floor reported beside
every image error in ``bench/images.md``). Tests read these files; they never regenerate them:
``make image-references`` (or the command stored in ``INDEX.json``) does.
"""
from __future__ import annotations

import json
import platform
import time
from pathlib import Path

import numpy as np

from ..core import suite
from . import REPO

IMAGE_REFERENCE_DIR = REPO / "tests" / "references" / "images"
INDEX = "INDEX.json"
RES = 128
SPP = 2048


def sphere_mask(rgba: np.ndarray) -> np.ndarray:
    """Pixels fully covered by the sphere (alpha of the reference = 1): image metrics are taken
    there, so the background (the same HDRI in every render) does not dilute them."""
    return rgba[..., 3] > 0.999


def read_exr(path) -> np.ndarray:
    import OpenEXR

    with OpenEXR.File(str(path)) as f:
        return np.array(f.channels()["RGBA"].pixels, dtype=np.float32)


def write_half_exr(path, rgba: np.ndarray) -> None:
    """RGBA half-float EXR with ZIP compression: the stored format of the references (half keeps
    3 significant digits, well below their noise floor)."""
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGBA": np.ascontiguousarray(rgba, dtype=np.float16)}) as f:
        f.write(str(path))


def load_index(out_dir: Path = IMAGE_REFERENCE_DIR) -> dict:
    p = Path(out_dir) / INDEX
    return json.loads(p.read_text()) if p.exists() else {"cases": {}}


def render_reference(name: str, res: int = RES, spp: int = SPP, thickness: float | None = None):
    """(RGBA mean image, noise RMSE over the sphere, seconds) for suite case ``name``."""
    from ..blender.render import render_stack

    stack = suite.load(name)
    half = max(spp // 2, 1)
    a, ta = render_stack(stack, "sphere-env", res=res, spp=half, engine="reference", seed=0, thickness=thickness)
    b, tb = render_stack(stack, "sphere-env", res=res, spp=half, engine="reference", seed=1, thickness=thickness)
    mean = 0.5 * (a + b)
    m = sphere_mask(mean)
    noise = float(np.sqrt(np.mean((0.5 * (a[m, :3] - b[m, :3])) ** 2)))
    return mean, noise, ta + tb


def compute(cases=None, res: int = RES, spp: int = SPP, out_dir: Path = IMAGE_REFERENCE_DIR,
            thickness: float | None = None, command: str = "") -> Path:
    from ..blender.reference_scene import SHELL_THICKNESS

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    index = load_index(out_dir)
    for name in cases or suite.names():
        t0 = time.time()
        img, noise, seconds = render_reference(name, res, spp, thickness)
        write_half_exr(out_dir / f"{name}.exr", img)
        index["cases"][name] = {
            "file": f"{name}.exr", "res": res, "spp": spp, "seeds": [0, 1],
            "shell_thickness": thickness if thickness is not None else SHELL_THICKNESS,
            "noise_rmse": noise, "render_seconds": round(seconds, 1),
            "mean_radiance": [float(x) for x in img[sphere_mask(img), :3].mean(0)],
        }
        index["command"] = command or f"lamella image-references --spp {spp} --res {res}"
        index["machine"] = f"{platform.machine()}, {platform.python_version()}"
        (out_dir / INDEX).write_text(json.dumps(index, indent=2, sort_keys=True) + "\n")
        print(f"{name}: {seconds:.0f} s render, noise RMSE {noise:.4f} ({time.time() - t0:.0f} s)", flush=True)
    return out_dir / INDEX
