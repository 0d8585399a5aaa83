"""Build the presets' asset library (``addon/lamella/data/assets``) from the preset JSON, so the
presets stay one source: one asset material per built-in preset, holding its stack (compiled when
it first appears in a scene) and the nodes of the preset's procedural inputs (linked then), the preset's description, a catalog (the artistic presets, the paper
figures) and a preview rendered with the material's own shader on the canonical sphere.

Run it with the oldest Blender the extension supports, so every supported Blender opens the file
(a .blend saved by 5.x is "not a blend file" to 4.2): after ``make test-blender-versions``,
``.venv-bpy-4.2.23/bin/python tools/build_asset_library.py``. ``tests/blender/test_asset_library.py``
fails when the library no longer matches the presets or was saved by a newer Blender.
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PREVIEW = 128  # pixels
PREVIEW_SPP = 64


def build(out_dir: Path) -> Path:
    import bpy
    import numpy as np

    from lamella.blender import api, input_recipes, recompile, register
    from lamella.blender.asset_library import LIBRARY_FILE
    from lamella.blender.stack_props import write_stack
    from lamella.core import presets
    from lamella_dev.image_metrics import display_srgb
    from lamella_dev.render import build_scene, render_scene

    register()
    previews = {}
    for preset in presets.builtin():  # each scene starts from factory settings: render first, build after
        sc, sphere = build_scene("sphere-env", PREVIEW, PREVIEW_SPP)
        sc.render.film_transparent = True  # the Asset Browser shows the sphere on its own background
        shown = bpy.data.materials.new(f"preview {preset.id}")
        api.apply_preset(shown, preset.id)
        sphere.data.materials.append(shown)
        rgba = render_scene(sc)[0]
        previews[preset.id] = np.concatenate([display_srgb(rgba), rgba[..., 3:4]], -1)[::-1]  # bottom row first
    assets = []
    for preset in presets.builtin():
        mat = bpy.data.materials.new(preset.label)
        # an empty node tree: a material saved without one (4.2's default) is given a Principled
        # tree by newer Blenders' versioning when they open it, whose output then renders instead
        mat.use_nodes = True
        mat.node_tree.nodes.clear()
        with recompile.suspended():  # the stack only: compiled where it is used
            write_stack(mat.lamella, preset.load(), preset.layer_labels)
            mat.lamella.enabled = True
        # the preset's procedural inputs (a wear mask, ...): linked into the Lamella node its first
        # compile builds (``input_recipes.link_pending``)
        input_recipes.add(mat, preset.inputs)
        mat.asset_mark()
        mat.asset_data.description = preset.description
        mat.asset_data.catalog_id = presets.catalog_id(presets.catalog_path(preset))
        mat.asset_data.tags.new("Lamella")
        preview = mat.preview_ensure()
        preview.image_size = (PREVIEW, PREVIEW)
        preview.image_pixels_float.foreach_set(np.ascontiguousarray(previews[preset.id], dtype=np.float32).ravel())
        assets.append(mat)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / LIBRARY_FILE.name
    bpy.data.libraries.write(str(path), set(assets), fake_user=True, compress=True)
    (out_dir / "blender_assets.cats.txt").write_text(
        presets.catalog_file("Asset catalogs of the Lamella presets (tools/build_asset_library.py)."))
    return path


def main() -> int:
    import argparse

    from lamella.blender.asset_library import LIBRARY_DIR

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=LIBRARY_DIR, help="the library folder (default: the package's)")
    path = build(ap.parse_args().out)
    print(f"wrote {path} ({path.stat().st_size // 1024} KB)")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT / "addon"))
    from lamella.blender import exit_process

    exit_process(main())
