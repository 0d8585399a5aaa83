"""A value typed on the Lamella node is the panel's value.

The panel's properties hold the stack (what compiles, what ``read_stack`` says); the Lamella node's
inputs show it (``face.set_node_values``, at every compile) and record what they were given. An
input the artist then types a value into holds another value than the one recorded
(``face.typed_values``): ``take`` writes it into the panel's property of that layer and field,
which schedules a compile like any panel edit, so the value renders in every engine and shows in
the panel. It runs after every depsgraph update of a material's node tree (the node editor), and
before every compile, render and save and in ``read_stack`` (scripts, and Blender run as a module,
where no depsgraph updates run between a script's writes). Linked and animated inputs are read by
the shader itself and are left alone; undo and redo restore the panel and the node together (both
are the material's data).
"""
from __future__ import annotations

from ..core.layers import BASE_KINDS, COAT_KINDS
from . import animation, face
from .kind_hooks import hooks


def layer_settings(settings, uid: str):
    """(kind, PropertyGroup) of the layer whose identity is ``uid`` (``face.BASE_UID``: the base),
    or None."""
    if uid == face.BASE_UID:
        return BASE_KINDS[settings.base.kind], settings.base.settings()
    item = next((c for c in settings.coats if c.uid == uid), None)
    return None if item is None else (COAT_KINDS[item.kind], item.settings())


def write_value(settings, i: face.FaceInput, value: tuple) -> bool:
    """Write the value ``value`` (a socket's numbers) of face input ``i`` into the panel's property
    of its layer and field. Returns whether the layer still exists."""
    found = layer_settings(settings, i.key.split("/", 1)[0])
    if found is None:
        return False
    kind, pg = found
    hook = hooks(kind.type).face_value
    if hook is not None and hook(pg, i.field, value):
        return True
    if i.axis == "y":
        setattr(pg, f"{i.field}_y", value[0])
    elif len(value) == 1:
        setattr(pg, i.field, value[0])
    else:
        setattr(pg, i.field, tuple(value[:3]))
    return True


def take(mat) -> bool:
    """Write every value typed on ``mat``'s Lamella node into its panel (module docstring).
    Returns whether any was."""
    settings = getattr(mat, "lamella", None)
    if settings is None or not settings.enabled or mat.library is not None:
        return False
    node = face.face_node(mat)
    if node is None or node.node_tree is None:
        return False
    typed = face.typed_values(node, face.face_inputs(settings), animation.animated_paths(node.id_data))
    return any([write_value(settings, i, value) for i, value in typed])
