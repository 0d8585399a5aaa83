"""The Blender-side batch API (docs/design.md "Contract: the Blender-side batch API"), re-exported by
the extension's top-level module: ``apply_stack(material, stack)`` and ``read_stack(material)``.

``apply_stack`` validates and compiles before it touches the material: a bad stack raises
``StackError`` (naming the layer and field), a forced model that cannot run the stack raises
``UnsupportedStack``, and in both cases the material is left exactly as it was.
"""
from __future__ import annotations

import json
import time

from ..core import presets
from ..core.backends.ir.staging import NotAnInput
from ..core.stack import Stack, StackError
from . import input_recipes, material_nodes, paths, recompile, socket_edits
from .stack_props import stack_dict, write_stack


def apply_stack(material, stack, model: str | None = None, labels=None):
    """Make ``material`` a Lamella material showing ``stack`` (a Stack, dict or JSON text),
    optionally forcing ``model`` (default: the material's model setting, "auto" for a new one).
    The coat at each position keeps its label unless ``labels`` names the coats (top to bottom;
    a coat without one, or a new coat, is named by what it is). Builds or updates its nodes;
    returns the material."""
    t0 = time.perf_counter()
    stack = Stack.coerce(stack)
    if material.library is not None:
        raise StackError("stack", None, f"material {material.name!r} is linked from {material.library.filepath}: "
                                        "edit it in its own file, or make it local first")
    settings = material.lamella
    if model is None:
        model = settings.model if settings.enabled else "auto"
    # parameters whose sockets are linked (a texture) stay live; the rest is baked
    try:
        built = recompile.build_shader(stack, model, material_nodes.linked_sockets(material),
                                       material.lamella.lobe_budget)  # raises before anything changes
    except NotAnInput as e:  # a texture linked into a layer or field the new stack lacks
        raise StackError("stack", None, material_nodes.not_an_input_message(material, e.names)) from None
    with recompile.suspended():
        write_stack(settings, stack, labels)
        settings.model = model
        settings.enabled = True
    recompile.install(material, stack, built, t0)
    return material


def apply_preset(material, preset_id: str):
    """Apply the preset ``preset_id`` (a built-in id, or ``user:<name>``) to ``material`` as
    ``apply_stack`` does, then replace the nodes a previous preset built for its inputs by this
    preset's (``input_recipes``: a wear mask in a coat's coverage, ...), linked into the Lamella
    node; the artist's own nodes stay. Returns the material."""
    preset = presets.find(preset_id, paths.user_presets_dir())
    apply_stack(material, preset.load(), labels=preset.layer_labels)
    removed = input_recipes.remove(material)
    if preset.inputs:
        input_recipes.add(material, preset.inputs)
        input_recipes.link_pending(material)
    if removed or preset.inputs:  # what is linked changed: the shader reads other inputs live
        recompile.compile_material(material, raise_errors=True)
    return material


def read_stack(material) -> dict | None:
    """The stack ``material`` renders (muted layers left out) as a dict, or None for a material
    Lamella does not build. A value typed on its Lamella node since the last compile is the
    stack's (it schedules that compile)."""
    settings = getattr(material, "lamella", None)
    if settings is None or not settings.enabled:
        return None
    socket_edits.take(material)  # a value typed on the Lamella node is the panel's
    d = stack_dict(settings)
    try:
        return Stack.from_dict(d).to_dict()
    except StackError:
        return d


def input_socket(material, layer, field: str):
    """The input of ``material``'s Lamella node that a script links a texture into: ``layer`` is a
    coat's index (0 = top) or "base", ``field`` a field of that layer's kind as the stack names it
    (``"roughness"``, ``"ior"``, ``"sigma_a"``; ``"roughness_y"`` across the tangent of an
    anisotropic roughness). The socket speaks the panel's units (roughness as Blender's r). It
    stays the layer's through edits of other layers. Raises KeyError naming what exists."""
    if not getattr(material, "lamella", None) or not material.lamella.enabled:
        raise KeyError(f"material {material.name!r} is not a Lamella material")
    return material_nodes.input_socket(material, layer, field)


def read_stack_json(material, indent: int | None = 2) -> str | None:
    d = read_stack(material)
    return None if d is None else json.dumps(d, indent=indent)


__all__ = ["apply_stack", "apply_preset", "read_stack", "read_stack_json", "input_socket", "StackError"]
