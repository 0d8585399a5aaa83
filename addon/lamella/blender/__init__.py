"""Everything that needs bpy: the extension's properties, panel, operators, node wiring, handlers
and its asset library. ``register()`` / ``unregister()`` install the extension's classes
and handlers (the top-level extension module calls them, and imports this package only then:
``import lamella`` and ``lamella.core`` never import bpy)."""
from __future__ import annotations

import atexit
import os
import sys

from . import (asset_library, compiled, conductor_modes, kind_hooks, operators, osl_compile, paths, properties,
               recompile, ui)

# the built-in kinds' Blender hooks, registered first (an extension kind's module registers its own
# before the extension registers)
_HOOKS = (kind_hooks.COAT_HOOKS, conductor_modes.HOOKS)

# registered in this order, unregistered in reverse
_MODULES = (properties, compiled, recompile, operators, ui, asset_library)
_registered = False
_exit_hook = False


def register():
    global _registered, _exit_hook
    osl_compile.set_cache_root(paths.cache_dir())
    for h in _HOOKS:
        kind_hooks.register(h)
    for m in _MODULES:
        m.register()
    _registered = True
    if not _exit_hook:
        # Blender disables its add-ons before it finalises Python; the bpy module (4.x) does not,
        # and a process that still holds a property with a Python update callback then never
        # exits. Unregistering at interpreter exit does what Blender's own exit would.
        atexit.register(_unregister_at_exit)
        _exit_hook = True


def unregister():
    """Undo ``register``; a second call does nothing (the exit hook may have run first, and
    Blender's ``addon_utils.disable`` then calls it again)."""
    global _registered
    if not _registered:
        return
    for m in reversed(_MODULES):
        m.unregister()
    for h in _HOOKS:
        kind_hooks.unregister(h)
    _registered = False


def _unregister_at_exit():
    if _registered:
        unregister()


def exit_process(code: int = 0):
    """End a process that imported the bpy module the way Blender ends (its own exit path, not
    Python's finalisation): the bpy module 4.2 crashes while finalising Python once an add-on
    property has a Python callback, after all work is done, and a pipeline would read the crash as
    a failure. Output streams are flushed first."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
