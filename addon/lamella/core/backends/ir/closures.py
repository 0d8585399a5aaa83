"""The traced model's closures: what the OSL emitter prints and the node-graph emitter builds.

Both emitters trace the one model the same way: the stack's model (``resolve``) runs on a
``Tracer`` with the view direction ``wi_x``/``wi_y``/``wi_z`` in the local frame as inputs, and
every lobe it returns becomes a closure of its kind (``lamella.core.lobe_kinds``), weighted by
its energy times the kind's normaliser (for GGX, 1 / GD: Randrianandrasana et al. 2021 Eq. 37)
and by the fraction of the surface it is on (``cover``: a stack with partly covering coats,
``models.coverage``; staging keeps it apart from the weight, so lobes merge only with lobes of
their own part).
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field, replace

from ... import lobe_kinds
from ...layer_normals import frame_key, tilts
from ...models import resolve, run_model, sides
from ...models.coverage import cover_params, partial_coats
from ...param_id import split_normals
from ...models.types import layer_params
from ...stack import Stack
from .trace import Tracer


@dataclass
class Closure:
    """One lobe as a closure: its kind's table entry, its weight (three traced values: energy x
    normaliser), its arguments (named traced values, ``LobeKind.args``) and ``cover``, the
    fraction of the surface it is on (a traced value, or 1.0), which the shader multiplies the
    weight by (``covered``)."""

    lobe: object
    kind: lobe_kinds.LobeKind
    weight: tuple
    args: dict
    label: str
    cover: object = 1.0
    normal: str | None = None  # the layer the lobe leaves (``Lobe.normal``)
    tilts: dict = field(default_factory=dict)  # layer -> weight of its normal's tilt (``layer_normals.tilts``)

    def framed(self, normals) -> tuple | None:
        """The frame the closure is about when the layers ``normals`` have normals of their own
        (``layer_normals.frame_key``), or None: the shading frame."""
        return frame_key(self.tilts, normals) or None

    def covered(self, t) -> "Closure":
        """This closure with its weight times its ``cover`` (made in tracer ``t``)."""
        if isinstance(self.cover, float) and self.cover == 1.0:
            return self
        lobe = replace(self.lobe, weight=self.lobe.weight * self.cover, cover=1.0)
        return Closure(lobe, self.kind, tuple(w * self.cover for w in self.weight), self.args, self.label, 1.0,
                       self.normal, self.tilts)


@dataclass
class TracedClosures:
    stack: Stack
    model: str
    tracer: Tracer
    wi: tuple
    closures: list  # their weights without ``cover``
    partial: tuple = ()  # the partly covering coats (``models.coverage.partial_coats``)
    covered: list | None = None  # the closures with their weights times ``cover`` (the whole model)


def declared_params(stack, partial=None) -> dict:
    """Parameter name -> value of ``stack``, as its layer kinds declare them (``layers.params``),
    in the order they declare them, then the coverages of its ``partial`` coats (default: those
    below 1, ``models.coverage``). A kind's ``params`` may compute with its parameters (a colour
    turned into an absorption), so they are traced, which costs only those few nodes."""
    t = Tracer()
    layer_params(t, stack)
    cover_params(t, stack, partial_coats(stack) if partial is None else partial)
    return dict(t.defaults)


def structure_of(stack, model: str = "auto", partial=None) -> tuple:
    """What the traced graph of ``stack`` depends on: the model asked for and the names of the
    parameters its layers declare. The models branch only on the stack's structure (the number of
    coats, the base's kind, which layers are isotropic, absorbing or scattering), every one of
    which shows in those names; every value reaches the graph as a parameter. So two stacks of one
    structure trace to the same graph with other defaults. The partly covering coats
    (``partial``, default those with coverage below 1: ``models.coverage``) declare a coverage
    parameter each, so they show in the names too."""
    return (model, stack.base.type, len(stack.coats), tuple(declared_params(stack, partial)), sides.faces(stack))


INSIDE_INPUT = "inside"  # the shading input that is 1 where the surface is seen from behind (OSL's backfacing())

_TRACES: dict = {}  # structure_of -> TracedClosures: a value edit does not trace again
_TRACES_KEPT = 16


def trace_closures(stack, model: str = "auto", live=()) -> TracedClosures:
    """Trace ``stack`` (a Stack, dict or JSON) under ``model`` down to its closures; the nodes
    made for the weights carry the scope "closures". ``live``: the inputs a material links (a
    linked coverage makes its coat partly covering). A stack of a structure traced before reuses
    that graph with its own values as the parameters' defaults (``structure_of``)."""
    stack = Stack.coerce(stack)
    partial = partial_coats(stack, split_normals(live)[0])
    key = structure_of(stack, model, partial)
    hit = _TRACES.get(key)
    if hit is not None:
        tracer = copy.copy(hit.tracer)
        tracer.defaults = declared_params(stack, partial)
        # the closures' frames weigh the layers' tilts by this stack's indices (``layer_normals``)
        return TracedClosures(stack, hit.model, tracer, hit.wi, _tilted(stack, hit.closures), partial,
                              _tilted(stack, hit.covered))
    traced = _trace(stack, model, partial)
    if len(_TRACES) >= _TRACES_KEPT:
        _TRACES.pop(next(iter(_TRACES)))
    _TRACES[key] = traced
    return traced


def _tilted(stack, closures: list) -> list:
    """``closures`` with the tilt weights of ``stack``'s indices."""
    return [replace(c, tilts=tilts(stack, c.normal, c.lobe.above or (), c.lobe.kind)) for c in closures]


def _trace(stack, model: str, partial=()) -> TracedClosures:
    v = resolve(model, stack)
    t = Tracer()
    wi = tuple(t.input(n) for n in ("wi_x", "wi_y", "wi_z"))
    lobes = run_model(t, stack, wi, model, partial)
    labels = [f"lobe {k} ({lobe.kind}): {'coat ' + str(k) if k < len(stack.coats) else 'base'}"
              for k, lobe in enumerate(lobes)]
    if sides.is_solid(stack):
        # the far side of a solid dielectric base, seen from inside it where the surface faces away
        # from the view (``INSIDE_INPUT``, 1 there): each side's lobes weigh on their own side only,
        # as a coverage mask's parts do (``staging`` keeps them apart)
        inside = t.input(INSIDE_INPUT)
        back = run_model(t, stack, wi, model, partial, seen_from=sides.INSIDE)
        for lobe in lobes:
            lobe.cover = lobe.cover * (1.0 - inside)
        for lobe in back:
            lobe.cover = lobe.cover * inside
        labels += [f"lobe {k} ({lobe.kind}): seen from inside the base" for k, lobe in enumerate(back, len(lobes))]
        lobes = lobes + back
    t.set_scope("closures")
    closures = []
    for k, (lobe, label) in enumerate(zip(lobes, labels)):
        kind = lobe_kinds.kind(lobe.kind)
        scale = kind.scale(t, lobe, wi)
        closures.append(Closure(lobe, kind, tuple(c * scale for c in lobe.weight), kind.args(t, lobe, wi), label,
                                lobe.cover, lobe.normal, tilts(stack, lobe.normal, lobe.above or (), lobe.kind)))
    covered = [c.covered(t) for c in closures]
    return TracedClosures(stack, v.name, t, wi, closures, tuple(partial), covered)
