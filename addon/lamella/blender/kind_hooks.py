"""What Blender does for a layer kind beyond its schema fields, keyed by the kind's ``type``.

A kind without hooks is complete: its PropertyGroup, panel section, icon and the way a stack is
written into and read from the panel all come from its schema (``LayerKind.fields``,
``LayerKind.icon``). A kind adds hooks for what the schema cannot say:

``properties()``: more properties on the kind's PropertyGroup (name -> bpy property), e.g. the
conductor's colour modes; ``draw(layout, pg)``: drawn above the fields, returns the names of the
fields left editable (None: all); ``icon(pg)``: one layer's icon where it depends on its values
(a coat that scatters shows as a medium); ``written(pg)``: after a stack's layer was written into
the PropertyGroup; ``face_inputs(pg, inputs, uid, label)``: the layer's inputs on the material's
Lamella node in place of its fields' (``face.FaceInput``; e.g. the conductor's artist colours,
converted to eta and k inside the node); ``face_value(pg, field, value)``: a value the artist typed
on one of those inputs, written into the PropertyGroup (returns whether ``field`` was the hook's).

Hooks are registered before the extension registers its properties: the built-in kinds' by
``lamella.blender`` when it is imported (the coat's ``COAT_HOOKS`` below, the conductor's in
``conductor_modes``), an extension kind's by its module, which calls :func:`register` beside
``lamella.core.layers.register``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from ..core.registry import Registry

MEDIUM_ICON = "OUTLINER_DATA_VOLUME"


@dataclass(frozen=True)
class KindHooks:
    """The hooks of the layer kind whose ``type`` is ``kind``; each hook is a function or None."""

    kind: str
    properties: Callable[[], dict] | None = None
    draw: Callable | None = None
    icon: Callable | None = None
    written: Callable | None = None
    face_inputs: Callable | None = None
    face_value: Callable | None = None


_HOOK_NAMES = ("properties", "draw", "icon", "written", "face_inputs", "face_value")


def _complete(h: KindHooks) -> None:
    if not isinstance(h, KindHooks):
        raise TypeError(f"a layer kind's Blender hooks are a KindHooks, got {type(h).__name__}")
    odd = [n for n in _HOOK_NAMES if getattr(h, n) is not None and not callable(getattr(h, n))]
    if odd:
        raise TypeError(f"the hooks of layer kind {h.kind!r}: {', '.join(odd)} must be functions or None")


HOOKS: Registry[KindHooks] = Registry("layer kind's Blender hooks", _complete, key=lambda h: h.kind)


def register(h: KindHooks) -> KindHooks:
    """Add the hooks of one layer kind (before the extension registers its properties)."""
    return HOOKS.register(h)


def unregister(h_or_kind) -> None:
    HOOKS.unregister(h_or_kind)


def hooks(kind_type: str) -> KindHooks:
    return HOOKS.get(kind_type) or KindHooks(kind_type)


def layer_icon(kind, pg) -> str:
    """The icon of one layer of ``kind`` held in ``pg``."""
    h = hooks(kind.type)
    return h.icon(pg) if h.icon is not None else kind.icon


def _coat_icon(pg) -> str:
    return MEDIUM_ICON if pg.thickness > 0 and any(x > 0 for x in pg.sigma_s) else "MOD_THICKNESS"


COAT_HOOKS = KindHooks("coat", icon=_coat_icon)
