"""The stack format stored on materials: a file saved before versions were recorded opens as the
current format, a file from a newer Lamella opens untouched and says why, and an older format is
migrated on load (``lamella.blender.versioning``)."""
import pytest

from lamella.core import stack_format
from lamella_dev import suite

pytest.importorskip("bpy")
from lamella.blender import api, material_nodes, recompile  # noqa: E402

from .addon_helpers import new_material, sphere_scene  # noqa: E402


def _saved_and_reopened(addon, tmp_path, name, edit):
    """A material showing gold_coated, ``edit(settings)`` applied, saved, and the file opened
    again: the reopened material."""
    sc, sphere = sphere_scene()
    mat = new_material(sphere, name)
    api.apply_stack(mat, suite.load("gold_coated"))
    assert mat.lamella.format == stack_format.FORMAT
    edit(mat.lamella)
    path = tmp_path / f"{name}.blend"
    addon.ops.wm.save_as_mainfile(filepath=str(path))
    addon.ops.wm.open_mainfile(filepath=str(path))
    return addon.data.materials[name]


def test_a_file_saved_before_formats_were_recorded_opens_as_the_current_format(addon, tmp_path):
    mat = _saved_and_reopened(addon, tmp_path, "unversioned", lambda s: setattr(s, "format", 0))
    assert mat.lamella.format == stack_format.FORMAT
    recompile.flush()  # a migrated material compiles again (a render or the edit timer flushes it)
    assert mat.lamella.status == "OK"
    assert api.read_stack(mat)["format"] == stack_format.FORMAT


def test_a_file_from_a_newer_lamella_is_left_as_it_was_saved(addon, tmp_path):
    newer = stack_format.FORMAT + 1
    mat = _saved_and_reopened(addon, tmp_path, "from_the_future", lambda s: setattr(s, "format", newer))
    script = material_nodes.inner_nodes(mat)[1].script
    text_before = script.as_string()
    assert mat.lamella.format == newer
    assert mat.lamella.status == "ERROR" and "newer Lamella" in mat.lamella.status_message
    assert f"stack format {newer}" in mat.lamella.status_message
    # an edit is refused: neither the data's format nor the shader changes
    mat.lamella.coats[0].coat.ior = 1.7
    assert not recompile.compile_material(mat)
    assert mat.lamella.format == newer
    assert material_nodes.shader_source(mat) == text_before
    assert "newer Lamella" in mat.lamella.status_message


def test_an_older_format_is_migrated_on_load(addon, tmp_path, monkeypatch):
    """Pretend this Lamella writes format FORMAT + 1, whose migration renames the stack: a file of
    the current format opens migrated, its coats' names and switches kept, and compiles."""
    old = stack_format.FORMAT

    def rename(d):
        return {**d, "name": d["name"] + " (migrated)"}

    mat = _saved_and_reopened(addon, tmp_path, "older", lambda s: setattr(s, "stack_name", "lacquer"))
    muted = mat.lamella.coats[0]
    muted.name, muted.show = "My Coat", False
    path = tmp_path / "older_muted.blend"
    addon.ops.wm.save_as_mainfile(filepath=str(path))
    monkeypatch.setattr(stack_format, "FORMAT", old + 1)
    monkeypatch.setitem(stack_format.MIGRATIONS, old, rename)
    addon.ops.wm.open_mainfile(filepath=str(path))
    mat = addon.data.materials["older"]
    assert mat.lamella.format == old + 1
    assert mat.lamella.stack_name == "lacquer (migrated)"
    assert (mat.lamella.coats[0].name, mat.lamella.coats[0].show) == ("My Coat", False)
    assert recompile.compile_material(mat, raise_errors=True)
