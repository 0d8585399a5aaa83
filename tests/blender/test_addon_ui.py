"""The panel's draw code against a recording stand-in layout (panels never draw headless): every
property path it draws resolves on a real material, every operator, menu and list it names is
registered, in every state the panel has (each base kind and conductor mode, anisotropic layers,
media, errors, a plain material, render-setting problems)."""
import pytest

from lamella_dev import suite

pytest.importorskip("bpy")
from lamella.blender import api, ui  # noqa: E402

from .addon_helpers import RecordingLayout  # noqa: E402


class _Context:
    def __init__(self, scene):
        self.scene = scene


def _draw(addon, mat):
    layout = RecordingLayout()
    ui.draw_material(layout, _Context(addon.context.scene), mat)
    return layout


def _check(addon, layout):
    assert layout.props or layout.operators, "nothing drawn"
    for data, name in layout.props:
        assert name in data.bl_rna.properties, f"{data!r} has no property {name!r}"
        getattr(data, name)  # resolves
    for idname in layout.operators:
        cat, op = idname.split(".")
        assert hasattr(getattr(addon.ops, cat), op) and getattr(getattr(addon.ops, cat), op).get_rna_type(), idname
    for menu in layout.menus:
        assert hasattr(addon.types, menu), menu
    for ul in layout.lists:
        assert hasattr(addon.types, ul), ul


def _paths(layout):
    return {name for _, name in layout.props}


@pytest.mark.parametrize("case", ["gold_coated", "rotated_60", "fog_g09_d1", "varnished_wood", "rough_glass_plate",
                                  "tinted_varnish"])
def test_panel_draws_only_real_properties(addon, case):
    mat = addon.data.materials.new(f"ui_{case}")
    api.apply_stack(mat, suite.load(case))
    layout = _draw(addon, mat)
    _check(addon, layout)
    assert {"coats", "active_index", "kind", "model", "inspect_angle"} <= _paths(layout)


def test_anisotropic_layers_show_both_roughnesses_and_the_rotation(addon):
    mat = addon.data.materials.new("ui_aniso")
    api.apply_stack(mat, suite.load("rotated_60"))
    paths = _paths(_draw(addon, mat))
    assert {"roughness", "roughness_y", "roughness_anisotropic", "rotation"} <= paths
    iso = addon.data.materials.new("ui_iso")
    api.apply_stack(iso, suite.load("gold_coated"))
    paths = _paths(_draw(addon, iso))
    assert "roughness_y" not in paths and "rotation" not in paths


@pytest.mark.parametrize("mode,shown", [("MEASURED", "metal"), ("ARTIST", "edge_tint"), ("CUSTOM", "eta")])
def test_every_conductor_mode_draws(addon, mode, shown):
    mat = addon.data.materials.new(f"ui_{mode}")
    api.apply_stack(mat, suite.load("gold_coated"))
    mat.lamella.base.conductor.mode = mode
    layout = _draw(addon, mat)
    _check(addon, layout)
    assert shown in _paths(layout)


def test_plain_material_error_state_and_render_problems_draw(addon):
    plain = addon.data.materials.new("ui_plain")
    layout = _draw(addon, plain)
    _check(addon, layout)
    assert "lamella.enable" in layout.operators
    mat = addon.data.materials.new("ui_error")
    api.apply_stack(mat, suite.load("gold_coated"))
    mat.lamella.status, mat.lamella.status_message = "ERROR", "coat 0, field 'ior': a message"
    sc = addon.context.scene
    engine, osl = sc.render.engine, sc.cycles.shading_system
    try:
        sc.render.engine = "CYCLES"
        sc.cycles.shading_system = False
        layout = _draw(addon, mat)
        _check(addon, layout)
        assert "lamella.fix_render_settings" in layout.operators
        assert any("coat 0, field 'ior'" in t for t in layout.labels)
    finally:
        sc.render.engine, sc.cycles.shading_system = engine, osl


def test_menus_draw(addon):
    for menu in (ui.LAMELLA_MT_add_layer, ui.LAMELLA_MT_presets, ui.LAMELLA_MT_stack_files):
        layout = RecordingLayout()
        fake = type("M", (), {"layout": layout})()
        menu.draw(fake, None)
        _check(addon, layout)
        assert layout.operators, menu.__name__


def test_layer_list_draws_each_item(addon):
    mat = addon.data.materials.new("ui_list")
    api.apply_stack(mat, suite.load("three_coats"))
    layout = RecordingLayout()
    for item in mat.lamella.coats:
        ui.LAMELLA_UL_layers.draw_item(None, None, layout, mat.lamella, item, 0, mat.lamella, "active_index")
    _check(addon, layout)
    assert _paths(layout) == {"name", "show"}


def test_the_node_group_note_says_what_svm_can_hold(addon):
    """With OSL off the panel says the group renders the OSL shader's image, that it may not fit
    Cycles' SVM stack where linked inputs keep a large part live (the estimate is rough there),
    that it renders black above what SVM holds, and which linked inputs it reads from tables
    (and over what range) where it falls back to them."""
    mat = addon.data.materials.new("ui_svm")
    api.apply_stack(mat, suite.load("gold_coated"))
    sc = addon.context.scene
    engine, osl = sc.render.engine, sc.cycles.shading_system
    try:
        sc.render.engine = "CYCLES"
        sc.cycles.shading_system = False
        s = mat.lamella
        for live, values, tables, want in (
                ("", 20, "", "the same image"), ("coat0_roughness", 120, "", "the same image"),
                ("coat0_roughness", 206, "", "may render black"),
                ("coat0_roughness", 90, "coat0_roughness 0 to 1", "tables over their range: coat0_roughness 0 to 1"),
                ("coat0_roughness", 290, "", "and renders black")):
            s.live_params, s.node_live_values, s.node_tables = live, values, tables
            text = " ".join(_draw(addon, mat).labels)
            assert want in text, (live, values, text)
    finally:
        sc.render.engine, sc.cycles.shading_system = engine, osl


class _Space:
    def __init__(self, tree_type, id):
        self.tree_type, self.id = tree_type, id


class _PanelContext:
    def __init__(self, scene, material=None, space_data=None):
        self.scene, self.material, self.space_data = scene, material, space_data


def test_the_two_panels_share_one_poll_and_draw(addon):
    """Properties > Material and the shader editor's sidebar are one panel (``ui.LamellaPanel``):
    the same poll and draw, each showing its editor's material."""
    mat = addon.data.materials.new("ui_panels")
    api.apply_stack(mat, suite.load("gold_coated"))
    sc = addon.context.scene
    props, sidebar = ui.LAMELLA_PT_material, ui.LAMELLA_PT_node_editor
    assert props.draw is sidebar.draw is ui.LamellaPanel.draw
    assert props.poll.__func__ is sidebar.poll.__func__
    in_props = _PanelContext(sc, material=mat)
    in_sidebar = _PanelContext(sc, space_data=_Space("ShaderNodeTree", mat))
    assert props.poll(in_props) and sidebar.poll(in_sidebar)
    assert not props.poll(_PanelContext(sc))
    assert not sidebar.poll(_PanelContext(sc, space_data=_Space("GeometryNodeTree", mat)))
    assert not sidebar.poll(_PanelContext(sc, space_data=_Space("ShaderNodeTree", sc.world)))
    drawn = []
    for panel, context in ((props, in_props), (sidebar, in_sidebar)):
        layout = RecordingLayout()
        panel.draw(type("P", (), {"layout": layout, "shown_material": staticmethod(panel.shown_material)})(), context)
        _check(addon, layout)
        drawn.append(([(d.as_pointer(), name) for d, name in layout.props], layout.operators, layout.labels))
    assert drawn[0] == drawn[1]


@pytest.fixture
def no_computing(monkeypatch):
    """Within the block it yields, any JSON parse, hash, node-tree check, cache read that could
    parse, or compile raises: what a draw function must never do (``ui``'s docstring)."""
    import contextlib
    import hashlib
    import json
    import sys

    from lamella.blender import compiled, material_nodes, node_group, osl_compile, recompile
    from lamella.core import presets

    def refuse(what):
        def call(*args, **kwargs):
            raise AssertionError(f"a draw function called {what}")
        return call

    refused = {}
    for mod, names in ((json, ("loads", "load")), (hashlib, ("sha256", "md5", "sha1", "new")),
                       (material_nodes, ("broken", "inner_nodes", "shader_source", "linked_sockets")),
                       (node_group, ("missing_images",)), (compiled, ("get",)),
                       (recompile, ("compile_material", "build_shader", "check_nodes", "flush")),
                       (osl_compile, ("compile_source",)),
                       (presets, ("builtin", "scan_user", "all_presets", "layer_templates"))):
        for name in names:
            refused[id(getattr(mod, name))] = f"{mod.__name__}.{name}"

    @contextlib.contextmanager
    def block():
        with monkeypatch.context() as m:
            # the function wherever it is bound: its module, and every module that imported it by name
            for module in [v for k, v in sys.modules.items() if v is not None and (
                    k in ("json", "hashlib") or k.split(".")[0] == "lamella")]:
                for attr, value in list(vars(module).items()):
                    if callable(value) and id(value) in refused:
                        m.setattr(module, attr, refuse(refused[id(value)]))
            yield

    return block


def _draw_all(addon, mat, scene):
    """The panel, its list's rows and the menus, as Blender would draw them."""
    layout = RecordingLayout()
    ui.LAMELLA_PT_material.draw(type("P", (), {"layout": layout, "shown_material": staticmethod(
        ui.LAMELLA_PT_material.shown_material)})(), _PanelContext(scene, material=mat))
    for item in mat.lamella.coats:
        ui.LAMELLA_UL_layers.draw_item(None, None, layout, mat.lamella, item, 0, mat.lamella, "active_index")
    for menu in (ui.LAMELLA_MT_add_layer, ui.LAMELLA_MT_presets, ui.LAMELLA_MT_stack_files):
        menu.draw(type("M", (), {"layout": layout})(), None)
    return layout


@pytest.mark.parametrize("engine,osl", [("CYCLES", True), ("CYCLES", False), ("BLENDER_EEVEE_NEXT", None)])
def test_draw_functions_parse_hash_check_and_compile_nothing(addon, no_computing, engine, osl):
    """Every draw of the panel and its menus only reads: in each engine's branch, for a material
    whose nodes are checked, one never checked since the cache went (a file loaded) and one whose
    shader text was edited since its check, with a user preset and a broken one in the presets
    menu. A draw that finds the check stale asks for one (it runs after the draw:
    ``recompile.check_soon``), and the next draw shows what it found."""
    from lamella.blender import compiled, material_nodes, operators, paths, recompile

    sc = addon.context.scene
    folder = paths.user_presets_dir()
    user_presets = {folder / "ui_pure_mine.json": '{"layers": [], "base": {"type": "diffuse"}}',
                    folder / "ui_pure_broken.json": "{"}
    if engine.startswith("BLENDER_EEVEE") and engine not in {i.identifier for i in
                                                              sc.render.bl_rna.properties["engine"].enum_items}:
        engine = "BLENDER_EEVEE"  # its name before 4.2's EEVEE Next and again from 5.0
    saved = sc.render.engine, sc.cycles.shading_system
    try:
        for path, text in user_presets.items():
            path.write_text(text)
        operators.preset_items()  # what Blender does before a menu draws (the items of the operators' enums)
        sc.render.engine = engine
        if osl is not None:
            sc.cycles.shading_system = osl
        mats = []
        for case in ("gold_coated", "fog_g09_d1", "rough_glass_plate"):
            mat = addon.data.materials.new(f"ui_pure_{case}_{engine}_{osl}")
            api.apply_stack(mat, suite.load(case))
            mats.append(mat)
        checked, unchecked, edited = mats
        compiled.clear()  # as a file load leaves it: nothing read, nothing checked
        recompile.check_nodes(checked)
        recompile.check_nodes(edited)
        material_nodes.inner_nodes(edited)[1].script.write("\n// an edit in the Text Editor")
        compiled.forget_nodes()
        recompile._to_check.clear()
        for mat in mats:
            with no_computing():
                layout = _draw_all(addon, mat, sc)
            _check(addon, layout)
            assert not any("Needs repair" in t for t in layout.labels), (mat.name, layout.labels)
            assert any(t.startswith("Skipped ui_pure_broken.json") for t in layout.labels)
        assert recompile._to_check == {m.session_uid for m in mats}  # each asked for a check
        recompile._on_check_timer()  # the timer the draw registered (background mode runs none)
        for mat in mats:
            with no_computing():
                layout = _draw_all(addon, mat, sc)
            repair = any("Needs repair: the shader text" in t for t in layout.labels)
            assert repair == (mat is edited), (mat.name, layout.labels)
            if engine == "CYCLES" and osl:
                assert any("Cycles renders the OSL shader" in t for t in layout.labels), layout.labels
        assert not recompile._to_check  # fresh checks: nothing asked again
    finally:
        sc.render.engine, sc.cycles.shading_system = saved
        for path in user_presets:
            path.unlink(missing_ok=True)
