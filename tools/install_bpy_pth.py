"""Add the bpy wheel's bundled site-packages (oslquery, OpenImageIO, ...) to the venv's sys.path.

Cycles' Script-node compile imports ``oslquery``, which the bpy wheel ships inside
``bpy/<version>/python/lib/python3.<minor>/site-packages`` (e.g. ``bpy/5.2/python/lib/python3.13``;
docs/extension.md). A ``.pth`` file in the venv's site-packages appends that folder at the *end*
of sys.path, so it never shadows a pip package. Run with the venv's python; idempotent.
"""
import sys
import sysconfig
from pathlib import Path

site = Path(sysconfig.get_paths()["purelib"])
try:
    import importlib.util

    spec = importlib.util.find_spec("bpy")
except Exception:  # pragma: no cover - bpy missing is reported below
    spec = None
if spec is None or not spec.submodule_search_locations:
    sys.exit("bpy is not installed in this environment")
bpy_dir = Path(list(spec.submodule_search_locations)[0])
bundled = sorted(bpy_dir.glob("*/python/lib/python3.*/site-packages"))
if not bundled:
    # older wheels (4.2) ship no Python packages of their own: nothing to add
    print(f"no bundled site-packages under {bpy_dir}: nothing to add")
    sys.exit(0)
pth = site / "lamella_bpy_bundled.pth"
pth.write_text(str(bundled[-1]) + "\n")
print(f"wrote {pth} -> {bundled[-1]}")
