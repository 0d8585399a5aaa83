"""The lobe kinds: one table that says, for every kind of lobe a model emits, how it is evaluated,
how its weight is normalised and which side of the surface it lights: the physics of the closure
that renders it (docs/design.md "Where a new kind goes"). ``lamella.core.api.evaluate`` (numpy)
reads this table and nothing else about lobes; the OSL emitter prints a kind's ``osl`` closure
call and the node-graph emitter builds its ``node``, so one record (``kind.LobeKind``) says all a
backend needs. One module per kind; a new kind is one module calling :func:`register`.

A lobe of weight ``e`` (RGB energy) contributes ``e * scale(wi) * closure_cos(wi, wo)`` to
f(wi, wo) |wo.z|, where ``closure_cos`` is exactly what the renderer's closure evaluates (f cos
of a closure of weight 1) and ``scale`` the normaliser that makes the lobe carry its weight in
energy (Randrianandrasana et al. 2021 Section 6.6, Eqs. 37-38: 1 / GD for GGX). The shader gives its closure the
weight ``e * scale``.
"""
from __future__ import annotations

from ..models.rgb import RGB
from . import backscatter, diffuse, reflection, tilted, transmission
from .bsdf_node import BsdfNode
from .kind import GD_FLOOR, KINDS, SHADING_FRAME, SIDES, LobeKind, osl_frame


def register(kind_: LobeKind) -> LobeKind:
    """Add a lobe kind (evaluated, printed and built from its one record). Lobes of a new kind are
    never merged with others (``backends.ir.lobe_budget.MERGEABLE``)."""
    return KINDS.register(kind_)


def unregister(kind_or_name) -> None:
    """Remove a lobe kind registered by :func:`register`."""
    KINDS.unregister(kind_or_name)


def kind(name: str) -> LobeKind:
    if name not in KINDS:
        raise NotImplementedError(f"lobe kind {name!r} is not in the lobe-kind table (have: {', '.join(KINDS)})")
    return KINDS[name]


def eval_lobes_cos(ops, lobes, wi, wo):
    """f(wi, wo) |wo.z| of a list of lobes: sum_k e_k scale_k(wi) closure_cos_k(wi, wo)."""
    total = RGB.splat(0.0)
    for lobe in lobes:
        k = kind(lobe.kind)
        total = total + lobe.weight * (k.closure_cos(ops, lobe, wi, wo) * k.scale(ops, lobe, wi))
    return total


for _module in (reflection, diffuse, backscatter, transmission, tilted):
    register(_module.KIND)

__all__ = ["LobeKind", "BsdfNode", "KINDS", "SIDES", "GD_FLOOR", "SHADING_FRAME", "osl_frame", "register", "unregister", "kind",
           "eval_lobes_cos"]
