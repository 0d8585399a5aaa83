"""Installing a module's ``bpy.app.handlers`` once and removing them again: ``handlers`` is a tuple
of (handler list name, function), e.g. ``(("load_post", _after_load),)``."""
from __future__ import annotations

import bpy


def add(handlers) -> None:
    """Append each function to its handler list, unless it is there already (a second register)."""
    for name, fn in handlers:
        lst = getattr(bpy.app.handlers, name)
        if fn not in lst:
            lst.append(fn)


def remove(handlers) -> None:
    """Remove every occurrence of each function from its handler list."""
    for name, fn in handlers:
        lst = getattr(bpy.app.handlers, name)
        while fn in lst:
            lst.remove(fn)
