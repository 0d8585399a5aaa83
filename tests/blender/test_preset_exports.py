"""The generated folders (``lamella_dev.preset_exports``, ``make exports``): every shader of ``osl/``
compiles with Blender's bundled OSL compiler; ``node_groups/`` is a library saved by the oldest
supported Blender holding every preset's group as an asset; and appended into a new file in a
Blender that cannot import the extension (``node_groups_session.py``, with test_material_life's
machinery), the groups render in Cycles with OSL, Cycles without OSL and EEVEE what the
extension's own materials of the same presets render. Whether the folders are current is
tests/unit/test_preset_exports.py's."""
import io
import json
import math
import shutil
import tomllib
from pathlib import Path

import pytest

from lamella.core import presets
from lamella.core.backends.osl.emit import VIEW_TARGETS
from lamella_dev import preset_exports as pe

pytest.importorskip("bpy")
# one worker runs the module: its two Blender sessions (about half a minute) run once
pytestmark = pytest.mark.xdist_group("preset_exports")
from .test_material_life import ENGINES, _rel, _run  # noqa: E402

# one per model and kind of base: anisotropic and rotated (yamaguchi2019), a scattering medium
# (tm6), glass that transmits (endf), a diffuse base
RENDERED = ("paper_rotated_anisotropy", "dusty_copper", "frosted_glass", "worn_lacquer_on_wood")
SESSION = Path(__file__).with_name("node_groups_session.py")
LIBRARY = pe.NODE_GROUPS_DIR / pe.LIBRARY_FILE


def _manifest():
    return json.loads((pe.NODE_GROUPS_DIR / pe.MANIFEST).read_text())


@pytest.mark.parametrize("target", VIEW_TARGETS)
def test_every_exported_shader_compiles(tmp_path, target):
    """A preset's shader bakes every value: its inputs are the normal and the tangent, and the
    sockets its procedural inputs feed (a mask in a coat's coverage: a TD connects their own)."""
    pytest.importorskip("oslquery")  # the bpy wheels before 5.0 do not ship it where Python finds it
    from .test_osl_export import _compile

    for p in presets.builtin():
        osl = pe.OSL_DIR / target / p.id / pe.shader_file(p)
        names = {q.name for q in _compile(osl, tmp_path / f"{p.id}.oso")}
        assert names == {"Normal", "Tangent", "BSDF", *(socket for socket, _ in p.inputs)}, (target, p.id, names)


def test_the_library_is_saved_by_the_oldest_supported_blender():
    """A .blend written by 5.x does not open in 4.2 ("not a blend file"); the header names the version."""
    import zstandard

    raw = LIBRARY.read_bytes()
    head = raw[:12] if raw.startswith(b"BLENDER") else zstandard.ZstdDecompressor().stream_reader(io.BytesIO(raw)).read(12)
    minimum = tomllib.loads((pe.ROOT / "blender_manifest.toml").read_text())["blender_version_min"]
    major, minor = (int(x) for x in minimum.split(".")[:2])
    assert head[:7] == b"BLENDER" and head[9:12] == f"{major}{minor:02d}".encode(), head
    assert _manifest()["blender"].startswith(f"{major}.{minor}.")


def test_the_library_holds_every_preset_as_an_asset(addon):
    """One group per preset, named as the manifest says, marked as an asset in its catalog, with the
    preset's description and a preview; its inputs are the normal and the tangent, its outputs the
    BSDF and EEVEE's Thickness."""
    bpy = addon
    entries = {e["group"]: e for e in _manifest()["presets"]}
    assert sorted(e["id"] for e in entries.values()) == sorted(p.id for p in presets.builtin())
    catalogs = {line.split(":")[1]: line.split(":")[0] for line in
                (pe.NODE_GROUPS_DIR / pe.CATALOG_FILE).read_text().splitlines() if line.count(":") == 2}
    with bpy.data.libraries.load(str(LIBRARY), assets_only=True) as (src, dst):
        assert sorted(src.node_groups) == sorted(entries)
        dst.node_groups = list(src.node_groups)
    try:
        for g in dst.node_groups:
            e = entries[g.name]
            assert g.asset_data is not None and g.asset_data.description == e["description"], g.name
            assert g.asset_data.catalog_id == catalogs[e["catalog"]], g.name
            assert tuple(g.preview.image_size) == (pe.PREVIEW, pe.PREVIEW), g.name
            assert max(g.preview.image_pixels_float[:]) > 0.1, g.name
            sockets = [(s.in_out, s.name) for s in g.interface.items_tree if s.item_type == "SOCKET"]
            assert sorted(sockets) == [("INPUT", "Normal"), ("INPUT", "Tangent"), ("OUTPUT", "BSDF"),
                                       ("OUTPUT", "Thickness")], (g.name, sockets)
    finally:
        for g in list(dst.node_groups):
            bpy.data.node_groups.remove(g)


def _images(tree, seen=None) -> list:
    """Every image the node tree ``tree`` reads, its nested groups' too."""
    seen = set() if seen is None else seen
    found = []
    for n in tree.nodes:
        if getattr(n, "image", None) is not None:
            found.append(n.image)
        if n.type == "GROUP" and n.node_tree is not None and n.node_tree.name not in seen:
            seen.add(n.node_tree.name)
            found += _images(n.node_tree, seen)
    return found


def test_the_library_holds_the_tables_its_manifest_records(addon):
    """The .blend itself, not only its manifest: each group's table image holds the pixels that
    ``compiled_numbers.npz`` records for its preset, within the manifest's tolerance (the library
    is built on one machine, the numbers recomputed on another: measured 1e-22 to 8e-19 apart in
    one to three pixels of the anisotropic presets, none elsewhere)."""
    import numpy as np

    from lamella_dev import golden

    bpy = addon
    manifest = _manifest()
    tolerance = golden.Tolerance(**manifest["tolerance"])
    before = {"node_groups": set(bpy.data.node_groups), "images": set(bpy.data.images),
              "texts": set(bpy.data.texts)}
    with bpy.data.libraries.load(str(LIBRARY)) as (src, dst):
        dst.node_groups = [e["group"] for e in manifest["presets"]]
    try:
        with np.load(pe.NODE_GROUPS_DIR / pe.NUMBERS) as numbers:
            for e, group in zip(manifest["presets"], dst.node_groups):
                (image,) = {im.name: im for im in _images(group)}.values()  # one table, read by many nodes
                pixels = np.empty(len(image.pixels), dtype=np.float32)
                image.pixels.foreach_get(pixels)
                change = golden.number_changes(numbers[pe.numbers_key(e["id"], "image table")], pixels, tolerance)
                assert change is None, (e["id"], change)
    finally:  # what the load appended goes: a later test's groups must not find these by name
        for kind, had in before.items():
            collection = getattr(bpy.data, kind)
            for block in [b for b in collection if b not in had]:
                collection.remove(block)


@pytest.fixture(scope="module")
def renders(extension_zip, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("node_groups")
    entries = [next(e for e in _manifest()["presets"] if e["id"] == pid) for pid in RENDERED]
    copy = tmp / LIBRARY.name  # the session deletes it once the groups are appended
    shutil.copyfile(LIBRARY, copy)
    found = _run(["library", copy, json.dumps(entries), tmp / "library"], tmp, tmp / "library_user", SESSION)
    stacks = [[pid, pid] for pid in RENDERED]  # applied as presets: their procedural inputs too
    found.update(_run(["extension", extension_zip, json.dumps(stacks), tmp / "extension"], tmp, tmp / "extension_user",
                      SESSION))
    return found


def test_the_appended_groups_hold_everything_they_read(renders):
    """No extension importable or enabled, the library file deleted once the groups were appended
    and nothing of theirs linked to it, every image they read packed into the file, every Script
    node's shader an internal text with its bytecode."""
    assert renders["missing_groups"] == []
    assert not renders["lamella_importable"] and renders["lamella_enabled"] == []
    assert renders["linked"] == []
    assert renders["images"] and all(packed for _, packed, _ in renders["images"]), renders["images"]
    assert len(renders["scripts"]) == len(RENDERED)
    assert all(s == ["INTERNAL", True, True] for s in renders["scripts"]), renders["scripts"]


def test_the_groups_render_their_presets_in_every_engine_without_the_extension(renders):
    """Sphere by sphere, each engine path of the appended group against the extension's material
    of the same preset: finite, not black, within 1 % (test_material_life's bound for a file
    rendered on a farm; measured: under 1e-4). The control: the next preset's render is more than
    10 % away from each (measured: 21 % and more)."""
    for engine in ENGINES:
        wanted = renders["extension"][engine]
        for k, (pid, got, want) in enumerate(zip(RENDERED, renders["library"][engine], wanted)):
            assert all(math.isfinite(v) for v in got) and sum(got) > 0.05, (engine, pid, got)
            assert _rel(got, want) < 0.01, (engine, pid, got, want)
            assert _rel(got, wanted[(k + 1) % len(wanted)]) > 0.1, (engine, pid, "the control")


def test_the_stored_osl_shader_runs_in_this_blender(renders):
    """The groups' Script nodes, compiled by the Blender that saved the library, wired straight to
    the output: Cycles with OSL renders what the extension's material renders."""
    for pid, got, want in zip(RENDERED, renders["script_only"], renders["extension"]["cycles-osl"]):
        assert sum(got) > 0.05 and _rel(got, want) < 0.01, (pid, got, want)
