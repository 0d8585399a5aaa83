"""Lamella, the Blender extension: layered materials compiled to OSL shaders.

This module only registers and unregisters; everything else is imported when used. The batch API
of the extension (``bl_ext.<repo>.lamella``): ``apply_stack(material, stack)`` and
``read_stack(material)``, ``apply_preset(material, preset_id)``, ``input_socket(material, layer,
field)``, with ``StackError`` for bad input.
"""


def register():
    from .addon.lamella import blender

    blender.register()


def unregister():
    from .addon.lamella import blender

    blender.unregister()


def apply_stack(material, stack, model=None):
    """Make ``material`` show ``stack`` (a dict, JSON text or Stack). Raises StackError, leaving
    the material untouched, on bad input."""
    from .addon.lamella.blender.api import apply_stack as _apply

    return _apply(material, stack, model)


def apply_preset(material, preset_id):
    """Apply a preset (a built-in id such as "worn_lacquer_on_wood", or "user:<name>"): its stack,
    and the nodes of its procedural inputs (a wear mask, ...) linked into the Lamella node."""
    from .addon.lamella.blender.api import apply_preset as _apply

    return _apply(material, preset_id)


def read_stack(material):
    """The stack ``material`` renders as a dict, or None if Lamella does not build it."""
    from .addon.lamella.blender.api import read_stack as _read

    return _read(material)


def input_socket(material, layer, field):
    """The input of ``material``'s Lamella node for ``field`` of ``layer`` (a coat's index, 0 = top,
    or "base"): where a script links a texture. It stays that layer's through other layers' edits."""
    from .addon.lamella.blender.api import input_socket as _input

    return _input(material, layer, field)


def __getattr__(name):
    if name == "StackError":
        from .addon.lamella.core.stack import StackError

        return StackError
    raise AttributeError(name)
