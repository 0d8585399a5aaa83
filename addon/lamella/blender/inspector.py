"""The lobe inspector: what the compiled stack does at one view angle, for the panel.

For the material's compiled stack and its inspector angle it writes the lobe table (kind, energy,
roughness, anisotropy: the same numbers the shader computes, from the numpy backend) into
``Material.lamella.lobes`` and draws a BRDF slice in the plane of incidence into a small image
(numpy straight into ``bpy.data.images``, no plotting library). Runs from the recompile timer,
never from a draw callback.
"""
from __future__ import annotations

import json
import math

import bpy
import numpy as np

from ..core.api import evaluate, lobes
from ..core.param_id import r_from_alpha
from . import compiled

SIZE = 160  # preview image is SIZE x SIZE pixels
N_ANGLES = 181
BACKGROUND = (0.09, 0.09, 0.09)
_fresh: set[str] = set()  # materials whose preview was drawn in this session


def incident(theta: float) -> np.ndarray:
    """The view direction at zenith ``theta`` in the plane of the tangent."""
    return np.array([math.sin(theta), 0.0, math.cos(theta)])


def slice_values(stack, model: str, theta: float, transmitted: bool) -> tuple[np.ndarray, np.ndarray]:
    """(angles, f * cos) along the plane of incidence: outgoing zenith from -90 to 90 degrees
    (negative on the mirror side) above the surface, and below it for a transmissive base."""
    t = np.linspace(-math.pi / 2, math.pi / 2, N_ANGLES)
    wo = np.stack([np.sin(t), np.zeros_like(t), np.cos(t)], axis=1)
    wi = np.broadcast_to(incident(theta), wo.shape)
    up = evaluate(stack, wi, wo, model)
    down = evaluate(stack, wi, wo * np.array([1.0, 1.0, -1.0]), model) if transmitted else np.zeros_like(up)
    return t, np.concatenate([up, down])


def draw_slice(values: np.ndarray, theta: float, transmitted: bool) -> np.ndarray:
    """RGBA pixels (SIZE, SIZE, 4), bottom row first (Blender's order): a polar plot whose radius
    is the square root of f * cos relative to its maximum, each colour channel filled on its own
    (white where the channels agree, tinted where the lobe is coloured); the view direction as a
    yellow ray, the surface as a grey line."""
    n = N_ANGLES
    img = np.empty((SIZE, SIZE, 4), dtype=np.float32)
    img[..., :3] = BACKGROUND
    img[..., 3] = 1.0
    cy = SIZE / 2 if transmitted else SIZE * 0.12
    radius = SIZE * (0.46 if transmitted else 0.84)
    y, x = np.mgrid[0:SIZE, 0:SIZE].astype(np.float64) + 0.5
    dx, dy = (x - SIZE / 2) / radius, (y - cy) / radius
    rho = np.hypot(dx, dy)
    zen = np.arctan2(dx, np.abs(dy))  # outgoing zenith: plus toward the viewer's side
    vmax = max(float(values.max()), 1e-12)
    scale = np.sqrt(np.clip(values / vmax, 0.0, None))
    up = dy >= 0
    k = np.clip(np.round((zen / math.pi + 0.5) * (n - 1)).astype(int), 0, n - 1)  # mirror side left
    idx = np.where(up, k, n + k) if transmitted else k
    inside = scale[idx] >= rho[..., None]
    if not transmitted:
        inside &= up[..., None]
    img[..., :3] = np.where(inside, 0.9, img[..., :3])
    # the surface, and the view direction
    img[np.abs(dy * radius) < 0.8, :3] = 0.45
    t = np.linspace(0.0, 1.0, 2 * SIZE)
    px = np.clip((SIZE / 2 + t * radius * math.sin(theta)).astype(int), 0, SIZE - 1)
    py = np.clip((cy + t * radius * math.cos(theta)).astype(int), 0, SIZE - 1)
    img[py, px, :3] = (1.0, 0.8, 0.1)
    return img


def lobe_rows(stack, model: str, theta: float) -> list[dict]:
    lb = lobes(stack, incident(theta), model)
    rows = []
    for k, kind in enumerate(lb.kinds):
        ax, ay = float(lb.alpha_x[0, k]), float(lb.alpha_y[0, k])
        rows.append({"kind": kind, "weight": tuple(float(w) for w in lb.weight[0, k]),
                     "roughness": r_from_alpha(math.sqrt(max(ax * ay, 0.0))),
                     "anisotropy": (ax - ay) / (ax + ay) if ax + ay > 0 else 0.0,
                     "rotation": float(lb.rotation[0, k])})
    return rows


def _image(mat):
    img = mat.lamella.preview
    if img is None or tuple(img.size) != (SIZE, SIZE):
        img = bpy.data.images.new(f".lamella_preview_{mat.name}"[:63], SIZE, SIZE, alpha=True)
        mat.lamella.preview = img
    return img


def update(mat) -> None:
    """Refresh the lobe table and the slice preview of ``mat`` from its compiled stack."""
    s = mat.lamella
    if not s.compiled_json:
        return
    stack = compiled.get(mat).stack
    model = s.picked_model or "auto"
    theta = float(s.inspect_angle)
    s.lobes.clear()
    for r in lobe_rows(stack, model, theta):
        item = s.lobes.add()
        item.kind, item.weight = r["kind"], r["weight"]
        item.roughness, item.anisotropy, item.rotation = r["roughness"], r["anisotropy"], r["rotation"]
    transmitted = stack.base.kind.transmits
    _, values = slice_values(stack, model, theta, transmitted)
    img = _image(mat)
    img.pixels.foreach_set(draw_slice(values, theta, transmitted).ravel())
    img.update()
    if not bpy.app.background:  # the panel's icon; headless there is no panel (and 4.5 hangs at exit)
        img.preview_ensure()
        img.preview.reload()
    s.inspected_json = json.dumps({"stack": s.compiled_json, "angle": round(theta, 6)})
    _fresh.add(mat.name_full)


def is_fresh(mat) -> bool:
    return mat.name_full in _fresh
