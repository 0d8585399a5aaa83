"""The presets as a Blender asset library: ``data/assets/lamella_presets.blend`` holds one asset
material per built-in preset (its Lamella stack, a preview, the preset's description, a catalog),
built from the preset JSON by ``tools/build_asset_library.py`` so the presets stay one source.
While the extension is enabled the folder is an asset library in the Preferences ("Lamella
Presets"), so artists drag a preset from the Asset Browser onto an object.

The asset materials hold their stack only (no shader: a compiled shader and node group would
weigh about 100 KB each): a Lamella material that has never been compiled is compiled when it
first appears in a scene (``recompile``: on the depsgraph update that brings it in, and before
any render), like one made in the panel.
"""
from __future__ import annotations

from pathlib import Path

import bpy

LIBRARY_NAME = "Lamella Presets"
LIBRARY_DIR = Path(__file__).resolve().parents[1] / "data" / "assets"
LIBRARY_FILE = LIBRARY_DIR / "lamella_presets.blend"


def _entries():
    libs = bpy.context.preferences.filepaths.asset_libraries
    here = str(LIBRARY_DIR)
    return libs, [lib for lib in libs if Path(bpy.path.abspath(lib.path)) == Path(here)]


def register() -> None:
    """Add the library to the Preferences unless an entry already points at its folder."""
    if not LIBRARY_FILE.is_file():
        return
    libs, mine = _entries()
    if not mine:
        libs.new(name=LIBRARY_NAME, directory=str(LIBRARY_DIR))


def unregister() -> None:
    """Remove the entries pointing at the library's folder (a disabled extension leaves none)."""
    libs, mine = _entries()
    for lib in mine:
        libs.remove(lib)
