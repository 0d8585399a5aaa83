"""The traced model's closures: what the OSL emitter prints and the node-graph emitter builds.

Both emitters trace the one model the same way: the stack's model (``resolve``) runs on a
``Tracer`` with the view direction ``wi_x``/``wi_y``/``wi_z`` in the local frame as inputs, and
every lobe it returns becomes a closure of its kind (``lamella.core.lobe_kinds``), weighted by
its energy times the kind's normaliser (for GGX, 1 / GD: Randrianandrasana et al. 2021 Eq. 37).
"""
from __future__ import annotations

from dataclasses import dataclass

from .. import lobe_kinds
from ..models import resolve
from ..stack import Stack
from .trace import Tracer


@dataclass
class Closure:
    """One lobe as a closure: its kind's table entry, its weight (three traced values: energy x
    normaliser) and its arguments (named traced values, ``LobeKind.args``)."""

    lobe: object
    kind: lobe_kinds.LobeKind
    weight: tuple
    args: dict
    label: str


@dataclass
class TracedClosures:
    stack: Stack
    model: str
    tracer: Tracer
    wi: tuple
    closures: list


def trace_closures(stack, model: str = "auto") -> TracedClosures:
    """Trace ``stack`` (a Stack, dict or JSON) under ``model`` down to its closures; the nodes
    made for the weights carry the scope "closures"."""
    stack = Stack.coerce(stack)
    v = resolve(model, stack)
    t = Tracer()
    wi = tuple(t.input(n) for n in ("wi_x", "wi_y", "wi_z"))
    lobes = v.run(t, stack, wi)
    t.set_scope("closures")
    closures = []
    for k, lobe in enumerate(lobes):
        kind = lobe_kinds.kind(lobe.kind)
        scale = kind.scale(t, lobe, wi)
        label = f"lobe {k} ({lobe.kind}): {'coat ' + str(k) if k < len(stack.coats) else 'base'}"
        closures.append(Closure(lobe, kind, tuple(c * scale for c in lobe.weight), kind.args(t, lobe, wi), label))
    return TracedClosures(stack, v.name, t, wi, closures)
