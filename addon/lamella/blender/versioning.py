"""The stack format of the Lamella data stored on a material, checked when a file is opened (as
Blender's own ``versioning`` code brings old files up to date on load).

Every material Lamella writes or compiles records the stack format it is stored in
(``Material.lamella.format``, ``lamella.core.stack_format.FORMAT``; 0 on materials saved before
the field existed, read as format 1). On load:

* an older format is migrated: the stored stack, read as that format, goes through the format's
  migrations and is written back, then compiled again;
* a newer format (a file saved by a newer Lamella) is left exactly as it was saved, shader
  included, and the material says why; its edits are refused until a Lamella that reads the format
  opens it (``refuses_edits``), so nothing written by the newer version is overwritten.
"""
from __future__ import annotations

from ..core import stack_format
from ..core.stack import Stack
from .stack_props import stack_dict, write_stack


def stored_format(settings) -> int:
    """The format a material's data is stored in (0, before the field existed, is format 1)."""
    return max(int(settings.format), 1)


def newer_message(version: int) -> str:
    return (f"Stored by a newer Lamella (stack format {version}; this one reads formats up to "
            f"{stack_format.FORMAT}): update the extension to edit it. The material keeps the shader it was saved with.")


def refuses_edits(settings) -> bool:
    return stored_format(settings) > stack_format.FORMAT


def check_loaded(mat) -> str:
    """Bring one loaded material's Lamella data to the current format. Returns what happened:
    ``"current"``, ``"migrated"`` (its stack rewritten; compile it again) or ``"newer"`` (left
    untouched, its status says why)."""
    settings = mat.lamella
    version = stored_format(settings)
    if version > stack_format.FORMAT:
        settings.status = "ERROR"
        settings.status_message = newer_message(version)
        return "newer"
    if version == stack_format.FORMAT:
        if settings.format != version:
            settings.format = version
        return "current"
    d = stack_dict(settings, include_muted=True)
    d[stack_format.KEY] = version
    stack = Stack.from_dict(d)  # the migrations, then the parser: a StackError leaves the data as it was
    kept = [(c.name, c.show) for c in settings.coats]
    write_stack(settings, stack)
    if len(kept) == len(settings.coats):  # a migration that keeps the coats keeps their names and switches
        for (name, show), item in zip(kept, settings.coats):
            item.name, item.show = name, show
    settings.format = stack_format.FORMAT
    return "migrated"


__all__ = ["check_loaded", "refuses_edits", "stored_format", "newer_message"]
