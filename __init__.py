"""Lamella, the Blender extension: layered materials compiled to OSL shaders.

This module only registers and unregisters; everything else is imported when used. The batch API
of the extension (``bl_ext.<repo>.lamella``): ``apply_stack(material, stack)`` and
``read_stack(material)``, with ``StackError`` for bad input.
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


def read_stack(material):
    """The stack ``material`` renders as a dict, or None if Lamella does not build it."""
    from .addon.lamella.blender.api import read_stack as _read

    return _read(material)


def __getattr__(name):
    if name == "StackError":
        from .addon.lamella.core.stack import StackError

        return StackError
    raise AttributeError(name)
