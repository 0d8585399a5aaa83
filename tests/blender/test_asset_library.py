"""The presets as an asset library (``lamella.blender.asset_library``): one asset material per
built-in preset, built from the preset JSON (``tools/build_asset_library.py``); the extension lists
the library in the Preferences while it is enabled; an asset dropped into a scene compiles there
and renders as its preset applied in the panel does."""
import numpy as np
import pytest

from lamella.core import presets

pytest.importorskip("bpy")
from lamella.blender import api, asset_library  # noqa: E402

from . import addon_helpers  # noqa: E402
from .addon_helpers import new_material, render, sphere_scene  # noqa: E402

CATALOGS = asset_library.LIBRARY_DIR / "blender_assets.cats.txt"


def _append(addon, names):
    with addon.data.libraries.load(str(asset_library.LIBRARY_FILE)) as (src, dst):
        dst.materials = list(names) if names is not None else list(src.materials)
    return dst.materials


def _stored(addon, stack):
    """The stack as a material holds it (float32 properties read back to 7 digits)."""
    from lamella.blender import recompile
    from lamella.blender.stack_props import write_stack

    mat = addon.data.materials.new("stored")
    with recompile.suspended():
        write_stack(mat.lamella, stack)
        mat.lamella.enabled = True
    try:
        return api.read_stack(mat)
    finally:
        addon.data.materials.remove(mat)


def test_the_library_holds_every_preset_as_an_asset_of_its_stack(addon):
    """One source: a preset edited without rebuilding the library fails here."""
    sphere_scene()
    built = presets.builtin()
    mats = {m.name: m for m in _append(addon, None)}
    assert sorted(mats) == sorted(p.label for p in built)
    catalog_ids = {line.split(":")[0] for line in CATALOGS.read_text().splitlines() if line.count(":") == 2}
    for p in built:
        m = mats[p.label]
        assert m.asset_data is not None and m.asset_data.description == p.description, p.id
        assert m.asset_data.catalog_id in catalog_ids, p.id
        assert tuple(m.preview.image_size) == (128, 128) and max(m.preview.image_pixels_float[:]) > 0.1, p.id
        assert api.read_stack(m) == _stored(addon, p.load()), p.id
        assert tuple(c.name for c in m.lamella.coats) == p.layer_labels, p.id  # the preset's labels


def test_the_library_opens_in_the_oldest_blender_the_extension_supports():
    """Saved by Blender 4.2 (blender_manifest.toml's minimum): a .blend written by 5.x does not
    open in 4.2 ("not a blend file"). The file is zstd-compressed; its header names the version."""
    import io
    import tomllib

    import zstandard

    raw = asset_library.LIBRARY_FILE.read_bytes()
    head = raw[:12] if raw.startswith(b"BLENDER") else zstandard.ZstdDecompressor().stream_reader(io.BytesIO(raw)).read(12)
    minimum = tomllib.loads((asset_library.LIBRARY_DIR.parents[3] / "blender_manifest.toml").read_text())
    major, minor = (int(x) for x in minimum["blender_version_min"].split(".")[:2])
    assert head[:7] == b"BLENDER" and head[9:12] == f"{major}{minor:02d}".encode(), head


def test_the_extension_lists_the_library_while_it_is_enabled(addon):
    def listed():
        return [lib for lib in addon.context.preferences.filepaths.asset_libraries
                if lib.path and str(asset_library.LIBRARY_DIR) == addon.path.abspath(lib.path).rstrip("/")]

    addon_helpers.unregister()
    try:
        assert not listed()
    finally:
        addon_helpers.register()
    assert len(listed()) == 1 and listed()[0].name == asset_library.LIBRARY_NAME
    asset_library.register()  # registering again adds no second entry
    assert len(listed()) == 1


@pytest.mark.parametrize("preset_id", ["lacquered_gold", "worn_lacquer_on_wood"])
def test_an_asset_dropped_into_a_scene_compiles_and_renders_as_its_preset(addon, preset_id):
    """Its procedural inputs too (the wear mask of Worn Lacquer on Wood is linked into the lacquer's
    coverage when the asset first compiles)."""
    preset = presets.find(preset_id)
    sc, sphere = sphere_scene()
    mat = new_material(sphere, "by_hand")
    api.apply_preset(mat, preset.id)
    live = mat.lamella.live_params
    expected = render(sc)

    sc, sphere = sphere_scene()
    (asset,) = _append(addon, [preset.label])
    assert asset.lamella.status == "NONE" and not asset.lamella.compiled_json  # the stack only
    sphere.data.materials.clear()
    sphere.data.materials.append(asset)
    addon.context.view_layer.update()  # the depsgraph update that brings it in schedules its compile
    assert asset.lamella.status == "PENDING"
    got = render(sc)  # a render compiles what is pending (no timers run in background mode)
    assert asset.lamella.status == "OK"
    assert asset.lamella.live_params == live
    d = np.abs(got - expected)
    assert np.percentile(d, 99) < 1e-3 and d.mean() < 1e-4, (np.percentile(d, 99), d.mean())
