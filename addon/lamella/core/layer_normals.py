"""A normal per layer: the normal each lobe's closure is about, from the layers' own normals.

A material may give a coat or the base a normal of its own (a bump on a clear coat, flakes on the
base; the Lamella node's per-layer Normal inputs). Light reflected by the base comes up through
every interface above it, and a tilted interface bends it on the way down and on the way back up
as a thin prism does (deviation (n - 1) A for a prism of apex angle A and index n, Born and Wolf,
*Principles of Optics*, 7th ed., Section 4.7.2). To first order in the tilts, for light near the
normal, a lobe leaving interface k (below media of indices n_0 = 1, n_1, ..., the medium right
above it of index m_k) whose interfaces i above it are tilted by t_i (the tangential part of
their normals) and itself by t_k leaves deviated by twice

    T_k = m_k t_k - sum_{i above k} (n_i - n_{i-1}) t_i,

the tilt of the normal a mirror would need to reflect it there (derivation: Snell's law linearised
at each interface on the way down and up; a bumped coat of index 1.5 over a flat base moves the
base's reflection by half its own tilt, the other way; a flat coat over a bumped base magnifies the
base's tilt 1.5 times; a stack tilted as a whole, every t_i = t, gives T_k = t). So the closure of a
reflected lobe is about normalize(N + T_k) (``tilts``: the weights of each layer's tangential part).
A diffuse or transmitted lobe is about its own layer's normal (its light is broad; the cosine it
takes is its surface's). The energies stay the stack's about the shading normal: what this leaves
out is their change with the local tilt (``bench/layer_normals.md`` measures it all against nested
spheres with a normal per shell).
"""
from __future__ import annotations

from .param_id import layer_prefix

PRISM_KINDS = ("reflection",)  # lobe kinds whose closures take the prism-weighted normal; others their own


def coats_above(stack, layer: str | None) -> tuple[int, ...]:
    """The coats (indices in the whole stack, top first) present in ``stack`` (a stack or a part of
    one, ``Stack.part``) above the interface of ``layer`` ("coatK" or "base")."""
    present = tuple(stack.layer_index(i) for i in range(len(stack.coats)))
    if layer is None or layer == "base":
        return present
    k = int(layer[4:])
    return tuple(i for i in present if i < k)


def tilts(stack, layer: str | None, above: tuple[int, ...], kind: str) -> dict[str, float]:
    """Layer prefix -> the weight of its normal's tangential part in the normal of a lobe of
    ``kind`` leaving ``layer`` with the coats ``above`` present above it (module docstring); empty
    for a lobe about the shading normal (``layer`` None)."""
    if layer is None:
        return {}
    if kind not in PRISM_KINDS:
        return {layer: 1.0}
    out: dict[str, float] = {}
    n_prev = 1.0
    for i in above:
        n_i = stack.coats[i].ior
        out[layer_prefix(i)] = -(n_i - n_prev)
        n_prev = n_i
    out[layer] = out.get(layer, 0.0) + n_prev
    return out


def frame_key(weights: dict, linked) -> tuple:
    """The frame a closure is about when the layers ``linked`` have normals of their own: its
    weights on those layers, sorted (empty: the shading frame)."""
    return tuple(sorted((layer, w) for layer, w in weights.items() if layer in linked and w != 0.0))


__all__ = ["PRISM_KINDS", "coats_above", "tilts", "frame_key"]
