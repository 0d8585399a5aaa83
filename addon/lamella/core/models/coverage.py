"""Coverage: a coat on part of the surface, read as a spatial mix of the stacks with and without it.

A coat's ``coverage`` c is the fraction of the surface where it is present. Where it is present
the light sees the whole stack; where it is absent, the stack without that coat (the coat below,
or the base, meets the medium above directly). Lateral transport between the two parts is
neglected (the texture scale is far above the layers' thickness), so the material is the
area-weighted mix of the two, exactly: for one coat,

    f = c f(stack) + (1 - c) f(stack without the coat),

and the same for the albedo, for every model. Several partly covering coats cover independently
(a coat's mask says nothing of another's): each subset S of the partly covering coats P is present
on a fraction prod_{i in S} c_i prod_{i in P - S} (1 - c_i) of the surface, and the material is the
mix of the 2^|P| stacks over the subsets. The rule is exact at 0 and 1 (a coat of coverage 1 is
everywhere, of coverage 0 nowhere) and linear in each c_i, so a mask's value is its coat's share of
the pixel, as Blender's Mix Shader and the Principled BSDF's Coat Weight are.

Which coats are partial is structure (``partial_coats``): those with coverage below 1 and those
whose coverage is read live (a linked mask). Each subset runs the model (``run``) as a part of the
stack (``Stack.part``: its parameters keep their coats' names), and its lobes carry the fraction in
``Lobe.cover``, which the closures multiply their weights by; the shaders keep the lobes of
different subsets apart (``lobe_budget``), so where a mask is 0 or 1 the other subsets' closures
weigh nothing. A named model that cannot represent a part (``endf`` has exactly one coat, so not
the bare base under it) runs ``auto`` on that part.
"""
from __future__ import annotations

import itertools

from ..layer_normals import coats_above
from ..layers.schema import StackError
from ..param_id import layer_label, slots, socket_name
from .sides import OUTSIDE, placed, view_of
from .types import Lobe, UnsupportedStack

FIELD = "coverage"
MAX_PARTIAL = 3  # partly covering coats in one stack: 2^3 = 8 parts, each a run of the model


def partial_coats(stack, live=()) -> tuple[int, ...]:
    """The coats (indices, top first) that cover part of the surface: coverage below 1, or a
    coverage read from a linked input (``live``: socket or parameter names). A ``StackError``
    naming the coat past ``MAX_PARTIAL``."""
    out = tuple(i for i, c in enumerate(stack.coats)
                if c.coverage < 1.0 or socket_name(stack.layer_index(i), FIELD) in live)
    if len(out) > MAX_PARTIAL:
        raise StackError(layer_label(out[MAX_PARTIAL]), FIELD,
                         f"{len(out)} coats cover part of the surface (coverage below 1 or a linked mask); at most "
                         f"{MAX_PARTIAL} can (each one doubles the stacks the shader mixes)")
    return out


def cover_params(ops, stack, partial) -> dict:
    """Coat index -> its coverage parameter (a backend value), for the ``partial`` coats."""
    coat_slots, _ = slots(stack)
    return {i: ops.param(coat_slots[i].id(FIELD), stack.coats[i].coverage) for i in partial}


def parts(ops, stack, partial):
    """(fraction of the surface, the part of ``stack`` there) for each subset of the ``partial``
    coats, every coat present first. Fractions are backend values (the coverage parameters)."""
    cover = cover_params(ops, stack, partial)
    whole = set(range(len(stack.coats))) - set(partial)
    for present in itertools.product((True, False), repeat=len(partial)):
        w = 1.0
        for i, here in zip(partial, present):
            w = w * (cover[i] if here else 1.0 - cover[i])
        yield w, stack.part(sorted(whole | {i for i, here in zip(partial, present) if here}))


def run(ops, stack, wi, model, resolve, partial=None, seen_from=OUTSIDE) -> list[Lobe]:
    """The lobes of ``stack`` under ``model`` (a name, ``"auto"``, or a model object; ``resolve``
    turns it into a model for a stack), each subset of the ``partial`` coats (default:
    ``partial_coats(stack)``) run as its own stack, its lobes' ``cover`` the fraction it covers;
    seen from ``seen_from`` (``models.sides``: "inside" a solid dielectric base)."""
    if partial is None:
        partial = partial_coats(stack)
    if not partial:
        seen = view_of(stack, seen_from)
        return _placed(seen, resolve(model, seen).run(ops, seen, wi))
    out = []
    for k, (w, part) in enumerate(parts(ops, stack, partial)):
        seen = view_of(part, seen_from)
        try:
            lobes = resolve(model, seen).run(ops, seen, wi)
        except UnsupportedStack:
            if k == 0:  # every coat present: the stack itself, which the model must represent
                raise
            lobes = resolve("auto", seen).run(ops, seen, wi)
        for lobe in lobes:
            lobe.cover = w if isinstance(lobe.cover, float) and lobe.cover == 1.0 else lobe.cover * w
        out += _placed(seen, lobes)
    return out


def _placed(stack, lobes):
    """``lobes`` of ``stack`` (a part of one, or a view of that: ``models.sides``), each told the
    coats present above its layer."""
    for lobe in lobes:
        lobe.above = coats_above(stack, lobe.normal)
    return placed(stack, lobes)


__all__ = ["FIELD", "MAX_PARTIAL", "partial_coats", "cover_params", "parts", "run"]
