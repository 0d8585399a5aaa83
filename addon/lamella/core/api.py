"""The Python API of docs/design.md ("Contract: the Python API"): ``lobes``, ``evaluate``, ``albedo``.

Runs the one model on the numpy backend. ``model`` is a name of ``MODELS`` (``"auto"`` picks one
by the stack's structure, ``models.choose_auto``) or a model object (e.g.
``models.variant("yamaguchi2019", mapping="weier")``); ``dtype`` selects float64 (default) or
float32 evaluation. Lobes are evaluated through the lobe-kind table (``lobe_kinds``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import lobe_kinds
from .backends.numpy_ops import NumpyOps
from .models import MODELS as _REGISTRY
from .models import UnsupportedStack, resolve, run_model
from .models.sides import OUTSIDE
from .models.types import Lobe
from .layer_normals import frame_key, tilts
from .stack import Stack

MODELS = ("auto", *_REGISTRY)


@dataclass
class Lobes:
    """Lobes per incident direction: ``weight`` (N, K, 3), ``alpha_x``, ``alpha_y``,
    ``rotation`` (N, K), ``kinds`` (K,) and ``model``, the model that made them (what ``auto``
    picked)."""

    weight: np.ndarray
    alpha_x: np.ndarray
    alpha_y: np.ndarray
    rotation: np.ndarray
    kinds: tuple[str, ...]
    model: str


def _dirs(w, dtype) -> np.ndarray:
    w = np.asarray(w, dtype=dtype)
    if w.ndim == 1:
        w = w[None, :]
    if w.ndim != 2 or w.shape[1] != 3:
        raise ValueError(f"directions must have shape (3,) or (N, 3), got {w.shape}")
    return w


def _run(stack, wi, model, dtype, seen_from=OUTSIDE):
    stack = Stack.coerce(stack)
    v = resolve(model, stack)
    ops = NumpyOps(dtype)
    wi = _dirs(wi, ops.dtype)
    wi_vals = tuple(ops.input(n, wi[:, k]) for k, n in enumerate(("wi_x", "wi_y", "wi_z")))
    # a partly covering coat's lobes weigh the fraction of the surface they are on
    ls = [lobe if _is_one(lobe.cover) else
          Lobe(lobe.weight * lobe.cover, lobe.alpha_x, lobe.alpha_y, lobe.rotation, lobe.kind, lobe.eta)
          for lobe in run_model(ops, stack, wi_vals, model, seen_from=seen_from)]
    return ops, v, wi_vals, ls


def _is_one(x) -> bool:
    return isinstance(x, float) and x == 1.0


def _full(x, n, dtype):
    return np.broadcast_to(np.asarray(x, dtype=dtype), (n,))


def lobes(stack, wi, model="auto", dtype=np.float64, seen_from=OUTSIDE) -> Lobes:
    """The model's lobes for view directions ``wi`` ((3,) or (N, 3), upper hemisphere of the local
    frame). ``seen_from="inside"``: the surface seen from within a solid dielectric base (the far
    side of a glass object: ``models.sides``); the same as "outside" for an opaque or thin-walled base."""
    ops, v, wi_vals, ls = _run(stack, wi, model, dtype, seen_from)
    n = wi_vals[0].shape[0]
    dt = ops.dtype
    return Lobes(
        weight=np.stack([np.stack([_full(c, n, dt) for c in lobe.weight], -1) for lobe in ls], 1),
        alpha_x=np.stack([_full(lobe.alpha_x, n, dt) for lobe in ls], 1),
        alpha_y=np.stack([_full(lobe.alpha_y, n, dt) for lobe in ls], 1),
        rotation=np.stack([_full(lobe.rotation, n, dt) for lobe in ls], 1),
        kinds=tuple(lobe.kind for lobe in ls),
        model=v.name,
    )


def evaluate(stack, wi, wo, model="auto", dtype=np.float64, deltas: bool = True, normals=None,
             seen_from=OUTSIDE) -> np.ndarray:
    """f(wi, wo) * |wo.z| as an (N, 3) array (wi broadcasts against wo). ``deltas=False`` leaves
    out the lobes of zero roughness (smooth interfaces), which a pointwise comparison cannot see:
    evaluated at the roughness floor they are a spike at the one direction nearest the mirror, and
    a reference that estimates f pointwise never samples a delta (their energy is in ``albedo``).

    ``normals``: layers with a normal of their own, ``{"coat0": n, "base": n}`` (unit vectors in the
    shading frame, (3,) or (N, 3)), as a material whose layers' Normal inputs are linked renders
    them: the model's energies are the stack's at ``wi`` about the shading normal, and each lobe
    is the closure the shaders make about the normal its layer and the tilted layers above it
    give it (``layer_normals``; its tangent the shading tangent made orthogonal to it), its cosine
    factor about it too. ``seen_from``: as for ``lobes``."""
    wo = _dirs(wo, dtype)
    wi_given = _dirs(wi, dtype)
    wi = np.broadcast_to(wi_given, wo.shape)
    # one view for every outgoing direction (a BRDF slice): the model runs once, its lobes
    # broadcast against ``wo`` (a look-up at one point gives the same bits as one lane of many)
    ops, v, wi_vals, ls = _run(stack, wi_given if wi_given.shape[0] == 1 else wi, model, dtype, seen_from)
    if not deltas:
        ls = [lobe for lobe in ls if not (lobe_kinds.kind(lobe.kind).rough and np.all(np.asarray(lobe.alpha_x) == 0.0)
                                          and np.all(np.asarray(lobe.alpha_y) == 0.0))]
    wo_vals = tuple(ops.input(n, wo[:, k]) for k, n in enumerate(("wo_x", "wo_y", "wo_z")))
    normals = {k: np.broadcast_to(_dirs(n, dtype), wo.shape) for k, n in (normals or {}).items()}
    stack = Stack.coerce(stack)
    keys = [frame_key(tilts(stack, lobe.normal, lobe.above or (), lobe.kind), normals) for lobe in ls]
    f = lobe_kinds.eval_lobes_cos(ops, [lobe for lobe, key in zip(ls, keys) if not key], wi_vals, wo_vals)
    z = np.array([0.0, 0.0, 1.0])
    for lobe, key in zip(ls, keys):
        if key:
            n = z + sum(w * (_unit(normals[layer]) - _unit(normals[layer])[:, 2:3] * z) for layer, w in key)
            frame = layer_frame(n)
            k = lobe_kinds.kind(lobe.kind)
            a = k.args(ops, lobe, wi_vals)
            f = f + lobe.weight * (k.cos_of_args(ops, a, _in(frame, wi, ops), _in(frame, wo, ops))
                                   * k.scale_of_args(ops, a, wi_vals))
    return np.stack([_full(c, wo.shape[0], ops.dtype) for c in f], -1)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def layer_frame(n: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(tangent, bitangent, normal) of a layer's own normal ``n`` ((N, 3) in the shading frame): the
    shading tangent x made orthogonal to it (the bitangent y where x lies along it), as the shaders
    make it."""
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    t = np.array([1.0, 0.0, 0.0]) - n[:, :1] * n
    alt = np.array([0.0, 1.0, 0.0]) - n[:, 1:2] * n
    t = np.where(np.linalg.norm(t, axis=-1, keepdims=True) < 1e-6, alt, t)
    t = t / np.linalg.norm(t, axis=-1, keepdims=True)
    return t, np.cross(n, t), n


def _in(frame, w, ops):
    """``w`` ((N, 3), shading frame) in the components of ``frame``, as backend values."""
    return tuple(ops.input(f"w_{k}", np.sum(w * axis, -1)) for k, axis in enumerate(frame))


def albedo(stack, wi, model="auto", side="reflected", dtype=np.float64, seen_from=OUTSIDE) -> np.ndarray:
    """Total energy the model sends back up (``side="reflected"``: the sum of its lobes'
    energies) or through a dielectric base (``"transmitted"``; zero for opaque bases), for a view
    ``seen_from`` either side of the surface (``lobes``)."""
    if side not in ("reflected", "transmitted"):
        raise ValueError(f"side must be 'reflected' or 'transmitted', got {side!r}")
    lb = lobes(stack, wi, model, dtype, seen_from)
    sel = [k for k, name in enumerate(lb.kinds) if lobe_kinds.kind(name).side == side]
    return lb.weight[:, sel, :].sum(1)


__all__ = ["MODELS", "Lobes", "lobes", "evaluate", "albedo", "layer_frame", "UnsupportedStack"]
