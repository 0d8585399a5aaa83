"""What a material's last compile produced, read once per session: its stack and live parameters,
parsed from what the material stores, and what the last check of its nodes found (for the panel).

A compile stores its stack as JSON and its live parameters as text on the material
(``Material.lamella.compiled_json``, ``live_params``); those strings are the truth: a file renders,
saves and opens again without anything here. Within a session every reader gets them parsed from
this cache (``get``), and the panel, whose draw code computes nothing, reads what a check of the
nodes found (``peek``), a check that runs outside the draw (``recompile.check_nodes``).

An entry belongs to one material, by its ``session_uid`` (kept through renames and undo steps, new
for a copy, never reused within a session), and to the two strings it was read from: it serves only
while the material still stores exactly those (compared on every read): a compile, an undo or a
script writing the strings gets a new entry, and a copy has its own from the start (equal to the
original's until one of them is compiled again); none reads another material's.

- ``record``: a compile puts what it knows in place (its Stack, and that the nodes it built are
  whole) without parsing anything;
- ``note_nodes``: a check of the nodes (``recompile.check_nodes``) records what it found;
- the checks are stale after anything that may change nodes: a depsgraph update of a material, node
  group, image or text (``forget_nodes``), and after ``NODES_RECHECK`` seconds (a shader text edited
  in the Text Editor sends no update); the panel asks for a new check then (``stale``);
- everything goes when a file is loaded and on undo and redo (``clear``).
"""
from __future__ import annotations

import time
from functools import cached_property
from typing import NamedTuple

import bpy
from bpy.app.handlers import persistent

from ..core.stack import Stack
from . import app_handlers

NODES_RECHECK = 1.0  # seconds after which the panel has a material's nodes checked again


class NodesCheck(NamedTuple):
    """What a check of a compiled material's nodes found: ``why`` they do not render what Lamella
    built (``material_nodes.broken``), None if they do; ``script`` whether the OSL shader's Script
    node is in place (else every engine renders the node group); when (``time.monotonic``) and in
    which ``generation`` of the data (``forget_nodes``)."""

    why: str | None
    script: bool
    at: float
    generation: int


class Compiled:
    """The products of one material's last compile, read from the strings it stores."""

    def __init__(self, compiled_json: str, live_params: str, stack: Stack | None = None):
        self.compiled_json = compiled_json
        self.live_params = live_params
        self.live: tuple[str, ...] = tuple(p for p in live_params.split(", ") if p)
        self.nodes: NodesCheck | None = None
        if stack is not None:
            self.stack = stack  # what the compile had (fills the cached property)

    @cached_property
    def stack(self) -> Stack:
        """The compiled stack (parsed on first use)."""
        return Stack.from_json(self.compiled_json)

    def matches(self, settings) -> bool:
        return self.compiled_json == settings.compiled_json and self.live_params == settings.live_params


_entries: dict[int, Compiled] = {}  # material session_uid -> its entry
_generation = 0  # bumped whenever nodes may have changed: checks of an older generation are stale


def peek(mat) -> Compiled | None:
    """``mat``'s entry if it has one that matches what it stores; never reads or parses anything
    else (the panel's draw code calls this)."""
    entry = _entries.get(mat.session_uid)
    return entry if entry is not None and entry.matches(mat.lamella) else None


def get(mat) -> Compiled | None:
    """``mat``'s entry, read from what it stores where it has none that matches; None for a
    material never compiled."""
    entry = peek(mat)
    if entry is None:
        s = mat.lamella
        if not s.compiled_json:
            return None
        entry = _entries[mat.session_uid] = Compiled(s.compiled_json, s.live_params)
    return entry


def record(mat, stack: Stack, script: bool) -> Compiled:
    """A compile wrote ``stack`` into ``mat`` (``compiled_json``, ``live_params``) and built its
    nodes whole, with the OSL shader's Script node or (``script`` False) without."""
    s = mat.lamella
    entry = _entries[mat.session_uid] = Compiled(s.compiled_json, s.live_params, stack)
    entry.nodes = NodesCheck(None, script, time.monotonic(), _generation)
    return entry


def note_nodes(mat, why: str | None, script: bool) -> None:
    """Record what a check of ``mat``'s nodes found."""
    entry = get(mat)
    if entry is not None:
        entry.nodes = NodesCheck(why, script, time.monotonic(), _generation)


def shown_nodes(mat) -> tuple | None:
    """What the panel shows of ``mat``'s nodes now: (why they are broken, whether the Script node
    is in place) of the last check, None before one."""
    entry = peek(mat)
    return None if entry is None or entry.nodes is None else (entry.nodes.why, entry.nodes.script)


def stale(check: NodesCheck | None) -> bool:
    """Whether a check (``Compiled.nodes``) is missing or out of date: the panel then shows it
    still and has the nodes checked again."""
    return (check is None or check.generation != _generation
            or time.monotonic() - check.at > NODES_RECHECK)


def forget_nodes() -> None:
    """Nodes may have changed: every check is stale."""
    global _generation
    _generation += 1


def clear() -> None:
    _entries.clear()
    forget_nodes()


# ---------------------------------------------------------------- handlers
_NODE_DATA = (bpy.types.Material, bpy.types.NodeTree, bpy.types.Image, bpy.types.Text)


@persistent
def _after_depsgraph(scene, depsgraph=None, *_args):
    if depsgraph is not None and any(isinstance(u.id, _NODE_DATA) for u in depsgraph.updates):
        forget_nodes()


@persistent
def _forget_all(*_args):
    clear()


_HANDLERS = (("load_post", _forget_all), ("undo_post", _forget_all), ("redo_post", _forget_all),
             ("depsgraph_update_post", _after_depsgraph))


def register():
    app_handlers.add(_HANDLERS)


def unregister():
    app_handlers.remove(_HANDLERS)
    clear()
