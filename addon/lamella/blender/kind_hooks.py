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
converted to eta and k inside the node).

Hooks are registered before the extension registers its properties: the built-in kinds' by
``lamella.blender`` when it is imported (the coat's ``COAT_HOOKS`` below, the conductor's in
``conductor_modes``), an extension kind's by its module, which calls :func:`register` beside
``lamella.core.layers.register``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

MEDIUM_ICON = "OUTLINER_DATA_VOLUME"


@dataclass(frozen=True)
class KindHooks:
    properties: Callable[[], dict] | None = None
    draw: Callable | None = None
    icon: Callable | None = None
    written: Callable | None = None
    face_inputs: Callable | None = None


NO_HOOKS = KindHooks()
HOOKS: dict[str, KindHooks] = {}


def register(kind_type: str, hooks: KindHooks) -> None:
    HOOKS[kind_type] = hooks


def unregister(kind_type: str) -> None:
    HOOKS.pop(kind_type, None)


def hooks(kind_type: str) -> KindHooks:
    return HOOKS.get(kind_type, NO_HOOKS)


def layer_icon(kind, pg) -> str:
    """The icon of one layer of ``kind`` held in ``pg``."""
    h = hooks(kind.type)
    return h.icon(pg) if h.icon is not None else kind.icon


def _coat_icon(pg) -> str:
    return MEDIUM_ICON if pg.thickness > 0 and any(x > 0 for x in pg.sigma_s) else "MOD_THICKNESS"


COAT_HOOKS = KindHooks(icon=_coat_icon)
