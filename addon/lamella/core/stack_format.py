"""The stack description's format version, and the migrations that bring older stacks up to it.

Every stack Lamella writes (``Stack.to_dict``, presets, the OSL bundle's copy, the data stored on
a material) carries ``"format": FORMAT``. A stack without the key is read as format 1, the format
of every stack written before the key existed. Reading a stack runs ``MIGRATIONS[v]`` for each
older version v in turn (each takes a format-v dict and returns a format-(v + 1) dict, never
touching its argument), so the parser only ever sees the current format; a stack from a newer
Lamella is refused with a message that says so, before any field is read.

The history of the format (what each version changed) is in ``CHANGES`` and in the generated
reference page ``docs/stack-format.md``.
"""
from __future__ import annotations

from typing import Any, Callable, Mapping

from .layers.schema import StackError

FORMAT = 3  # the format this Lamella writes
KEY = "format"

# What each version changed, newest last: the reference page prints it.
CHANGES: dict[int, str] = {
    1: "The first versioned format: coats top to bottom under `layers`, a `base` of kind conductor, diffuse or "
       "dielectric, an optional `name`. Stacks written without a `format` key are read as format 1.",
    2: "Coats gain `coverage`, the fraction of the surface a coat covers (0 to 1; a format-1 coat covers all of it, "
       "coverage 1); coats, conductor and dielectric bases gain a thin film on their interface, `film_thickness` "
       "(nm; 0, no film, as in format 1) and `film_ior`.",
    3: "Dielectric bases gain `thin_walled` (false: the substrate is solid, and a closed mesh's far side shows the "
       "stack from inside it; true: a thin sheet, a pane or a bubble). A format-2 dielectric base reads as solid.",
}


def _coverage_whole(d: dict) -> dict:
    """Format 1 to 2: every coat covers the whole surface and no interface has a film, which is what
    a layer without ``coverage`` and ``film_thickness`` reads as (their defaults, 1 and 0), so the
    stack passes as it is."""
    return dict(d)


def _solid_glass(d: dict) -> dict:
    """Format 2 to 3: a dielectric base without ``thin_walled`` is solid, its default, so the stack
    passes as it is. (Format-2 shaders drew the stack as seen from outside on both faces of a
    closed mesh, which no glass object does; a base of index 1 under a glass coat, the way a pane
    was written, looks the same either way.)"""
    return dict(d)


# v -> the function taking a format-v stack dict to format v + 1
MIGRATIONS: dict[int, Callable[[dict], dict]] = {1: _coverage_whole, 2: _solid_glass}


def version_of(d: Mapping[str, Any]) -> int:
    """The format a stack dict declares (1 without the key); a ``StackError`` for anything but a
    whole number from 1 to ``FORMAT``."""
    v = d.get(KEY, 1)
    if isinstance(v, bool) or not isinstance(v, int):
        if isinstance(v, float) and v.is_integer():
            v = int(v)
        else:
            raise StackError("stack", KEY, f"expected a whole number (the stack format version), got {v!r:.40}")
    if v > FORMAT:
        raise StackError("stack", KEY, f"format {v} was written by a newer Lamella; this one reads formats 1 to "
                                       f"{FORMAT}: update the extension to open it")
    if v < 1:
        raise StackError("stack", KEY, f"must be at least 1, got {v}")
    return v


def upgrade(d: Mapping[str, Any]) -> dict:
    """``d`` brought to the current format (a new dict; ``d`` is left as it was), its ``format``
    key set to ``FORMAT``."""
    v = version_of(d)
    out = dict(d)
    while v < FORMAT:
        out = MIGRATIONS[v](out)
        v += 1
    out[KEY] = FORMAT
    return out


__all__ = ["FORMAT", "KEY", "CHANGES", "MIGRATIONS", "version_of", "upgrade"]
