"""The generated folders ``osl/`` and ``node_groups/`` (``lamella_dev.preset_exports``) are what the
current presets and code make: a preset, the shader generator or the node-group compiler changed
without ``make exports`` fails here, naming the presets. OSL only (a few seconds): the .blend is
judged by its manifest, and compiled and rendered by tests/blender/test_preset_exports.py."""
import json

from lamella.core import Stack, presets
from lamella.core.backends.osl.emit import VIEW_TARGETS
from lamella_dev import preset_exports as pe


def test_the_osl_folder_is_what_the_presets_export_now():
    changes = pe.osl_changes(pe.OSL_DIR)
    assert not changes, (f"osl/ is stale; run `{pe.REGENERATE}` (or `lamella export-presets --only osl`) and "
                         "commit it:\n  " + "\n  ".join(changes))


def test_the_osl_folder_has_every_preset_for_every_target():
    for target in VIEW_TARGETS:
        have = sorted(p.name for p in (pe.OSL_DIR / target).iterdir())
        assert have == sorted(p.id for p in presets.builtin()), target
        for p in presets.builtin():
            assert (pe.OSL_DIR / target / p.id / pe.shader_file(p)).is_file()


def test_the_node_groups_were_built_from_the_current_presets_and_compiler():
    changes = pe.node_group_changes(pe.NODE_GROUPS_DIR)
    assert not changes, (f"node_groups/ is stale; run `{pe.REGENERATE}` (or `lamella export-presets --only "
                         "node-groups`, which needs the bpy of Blender 4.2) and commit it:\n  " + "\n  ".join(changes))


def test_a_changed_preset_is_named():
    """The manifest check fails on the preset that changed, and only on it."""
    stored = json.loads((pe.NODE_GROUPS_DIR / pe.MANIFEST).read_text())
    first = presets.builtin()[0]
    entry = pe.manifest_entry(first)
    assert entry == next(e for e in stored["presets"] if e["id"] == first.id)
    stack = first.load().to_dict()
    stack["base"]["roughness"] = 0.5
    assert pe.stack_digest(Stack.from_dict(stack)) != entry["stack_sha256"]
    assert pe.compile_digest(Stack.from_dict(stack)) != entry["compile_digest"]


def test_the_catalogs_are_the_material_librarys():
    """Same catalog paths and UUIDs as the presets' material asset library, so Blender shows one tree."""
    materials = (presets.DATA_DIR / "assets" / "blender_assets.cats.txt").read_text()
    ours = (pe.NODE_GROUPS_DIR / pe.CATALOG_FILE).read_text()

    def entries(text):
        return {line for line in text.splitlines() if line.count(":") == 2}

    assert entries(ours) == entries(materials) == entries(pe.catalog_file())


def test_the_node_groups_readme_is_the_manifests():
    manifest = json.loads((pe.NODE_GROUPS_DIR / pe.MANIFEST).read_text())
    assert (pe.NODE_GROUPS_DIR / pe.README).read_text() == pe.node_groups_readme(manifest), (
        f"node_groups/README.md is stale: run `{pe.REGENERATE}`")
