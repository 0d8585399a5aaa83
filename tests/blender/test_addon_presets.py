"""Every built-in preset applies through the operator and renders finite, and every measured
metal of the picker writes its published eta/k."""
import numpy as np
import pytest

from lamella.core import metals, presets

pytest.importorskip("bpy")
from lamella.blender import api  # noqa: E402

from .addon_helpers import new_material, render, sphere_scene  # noqa: E402


@pytest.mark.parametrize("preset", [p.id for p in presets.builtin()])
def test_preset_applies_and_renders_finite(addon, preset):
    sc, sphere = sphere_scene(res=32, spp=4)
    mat = new_material(sphere, preset)
    addon.ops.lamella.preset_apply(material=mat.name, preset=preset)
    assert mat.lamella.status == "OK", mat.lamella.status_message
    px = render(sc)
    assert np.isfinite(px).all() and (px >= 0).all()
    assert px[px[..., 3] > 0.999, :3].mean() > 0.005


@pytest.mark.parametrize("metal", list(metals.measured()))
def test_measured_metal_picker_writes_the_published_values(addon, metal):
    mat = addon.data.materials.new(f"metal_{metal}")
    api.apply_stack(mat, {"layers": [], "base": {"type": "conductor"}})
    c = mat.lamella.base.conductor
    c.mode = "MEASURED"
    c.metal = metal
    m = metals.measured()[metal]
    np.testing.assert_allclose(c.eta, m["eta"], rtol=1e-6)
    np.testing.assert_allclose(c.k, m["k"], rtol=1e-6)
    addon.ops.lamella.recompile(material=mat.name)
    np.testing.assert_allclose(api.read_stack(mat)["base"]["eta"], m["eta"], rtol=1e-6)


def test_artist_mode_stores_eta_k_with_the_asked_reflectivity(addon):
    mat = addon.data.materials.new("artist")
    api.apply_stack(mat, {"layers": [], "base": {"type": "conductor"}})
    c = mat.lamella.base.conductor
    c.mode = "ARTIST"
    c.reflectivity = (0.9, 0.5, 0.2)
    c.edge_tint = (0.3, 0.6, 0.9)
    f0 = [metals.normal_reflectance(n, k) for n, k in zip(c.eta, c.k)]
    np.testing.assert_allclose(f0, (0.9, 0.5, 0.2), atol=1e-5)
    r, g = metals.complex_to_artistic(c.eta, c.k)
    np.testing.assert_allclose(g, (0.3, 0.6, 0.9), atol=1e-4)


def test_malformed_user_preset_files_are_skipped_and_reported(addon):
    from lamella.blender import operators, paths, ui

    from .addon_helpers import RecordingLayout

    folder = paths.user_presets_dir()
    bad = {"deep.json": "[" * 5000 + "]" * 5000, "latin1.json": "{\"name\": \"caf\xe9\"}".encode("latin-1"),
           "list.json": "[1, 2]", "huge_k.json": '{"layers": [], "base": {"type": "conductor", "k": 1e300}}',
           "empty.json": ""}
    try:
        for name, text in bad.items():
            (folder / name).write_bytes(text if isinstance(text, bytes) else text.encode())
        items = operators.preset_items()
        assert not any(i[0].startswith("user:") and i[0][5:] + ".json" in bad for i in items)
        assert [p.name for p, _ in presets.scan_user(folder)[1]] == sorted(bad)
        m = addon.data.materials.new("after_bad_presets")
        addon.ops.lamella.preset_apply(material=m.name, preset=presets.builtin()[0].id)
        assert m.lamella.status == "OK"
        layout = RecordingLayout()
        menu = type("M", (), {"layout": layout})()
        ui.LAMELLA_MT_presets.draw(menu, addon.context)
        assert sum(t.startswith("Skipped ") for t in layout.labels) == len(bad)
    finally:
        for name in bad:
            (folder / name).unlink(missing_ok=True)
