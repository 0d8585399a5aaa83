"""Everything that needs bpy: the extension's properties, panel, operators and node wiring, and
the canonical render scenes. ``register()`` / ``unregister()`` install the extension's classes
and handlers (the top-level extension module calls them)."""
from __future__ import annotations

import importlib

_MODULES = ("properties", "recompile", "operators", "ui")


def _modules():
    return [importlib.import_module(f".{name}", __name__) for name in _MODULES]


def register():
    from . import osl_compile, paths

    osl_compile.set_cache_root(paths.cache_dir())
    for m in _modules():
        m.register()


def unregister():
    for m in reversed(_modules()):
        m.unregister()
