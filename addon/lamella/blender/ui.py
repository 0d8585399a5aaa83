"""The Lamella panel: in Material Properties and in the shader editor's sidebar (one poll and draw
code, ``LamellaPanel``).

Layout, top to bottom (Blender's property split throughout):

- status: compiled (model, time) / pending / the error, and what renders the material where it
  is not the OSL shader (the node group in Cycles without OSL, in EEVEE, and wherever a linked
  input reaches the look-up tables), with a one-click switch to Cycles with OSL;
- presets menu, save-preset button and a menu of file actions (import/export JSON, export OSL);
- the layer list (icon per kind, name, eye toggle to mute a layer) with add (a menu of coat
  templates), remove, duplicate and move buttons, then the base as the last row below it;
- collapsible sections: the active coat's fields (its medium in a nested section), the base,
  the model ("Auto" shows what it picked), and the lobe inspector (view-angle slider, a BRDF
  slice preview and the table of lobes).

Fields are drawn from the layer-kind schema, like the properties themselves. Draw functions read
properties, and what was computed before the draw: the compile's products and the last check of
the material's nodes (``compiled``; a stale check is asked for again, to run after the draw), and
the menus' items (``operators``, read when the extension registers; the presets' again only when
a file in the user's preset folder changed). They parse, hash, walk node trees and compile
nothing.
"""
from __future__ import annotations

import textwrap

import bpy

from ..core.backends.ir.lobe_budget import MAX_CLOSURES
from ..core.backends.nodes.svm import SVM_HEADROOM, SVM_STACK, SVM_UNSURE
from ..core.layers import ANGLE, BASE_KINDS, COAT_KINDS, ROUGHNESS
from . import compiled, inspector, recompile
from .i18n import iface_
from .kind_hooks import hooks
from .kind_hooks import layer_icon as kind_layer_icon
from .material_nodes import osl_usable
from .operators import context_material, preset_items, skipped_presets, template_items

STATUS_ICONS = {"OK": "CHECKMARK", "PENDING": "TIME", "ERROR": "ERROR", "NONE": "INFO"}


def _wrapped(layout, text: str, icon: str = "NONE", width: int = 48) -> None:
    """``text`` (already in the interface language: ``iface_``) in lines of about ``width``."""
    col = layout.column(align=True)
    for i, line in enumerate(textwrap.wrap(text, width) or [""]):
        col.label(text=line, icon=icon if i == 0 else "BLANK1", translate=False)


def layer_icon(item) -> str:
    return kind_layer_icon(COAT_KINDS[item.kind], item.settings())


# ---------------------------------------------------------------- pieces
def draw_status(layout, context, mat) -> None:
    """The compile's status and what renders the material in the scene's engine. What the nodes
    are like is the last check's (``compiled``); where that is stale, a new check is asked for,
    to run after the draw (``recompile.check_soon``)."""
    s = mat.lamella
    shown = compiled.peek(mat)
    nodes = shown.nodes if shown is not None else None  # None: not checked yet
    if compiled.stale(nodes) and s.compiled_json:
        recompile.check_soon(mat)
    box = layout.box()
    if s.status == "ERROR":
        box.alert = True
        _wrapped(box, s.status_message.splitlines()[0] if s.status_message else iface_("error"), "ERROR")
        box.label(text="The material keeps its last working shader.", icon="BLANK1")
    elif s.status == "OK" and nodes is not None and nodes.why:
        box.alert = True
        _wrapped(box, iface_("Needs repair: {why}").format(why=nodes.why), "ERROR")
        box.label(text="Repaired at the next render or edit, or with Recompile.", icon="BLANK1")
    elif s.status == "OK":
        picked = iface_("auto: {model}").format(model=s.picked_model) if s.model == "auto" else s.picked_model
        box.label(text=iface_("Compiled ({model}, {ms:.0f} ms)").format(model=picked, ms=s.compile_ms), icon="CHECKMARK",
                  translate=False)
    else:
        box.label(text="Compiling..." if s.status == "PENDING" else "Not compiled",
                  icon=STATUS_ICONS.get(s.status, "INFO"))
    sc = context.scene

    note, fix = None, False
    if sc.render.engine == "CYCLES" and not osl_usable(sc):
        why = iface_("Open Shading Language is off") if not sc.cycles.shading_system else iface_(
            "this GPU device runs no OSL")
        values = {"why": why, "live": s.live_params or iface_("none"), "values": s.node_live_values,
                  "holds": SVM_STACK - SVM_HEADROOM, "tables": s.node_tables}
        note, fix = iface_("Cycles renders the node group ({why}): the same image as the OSL shader."), True
        if s.node_live_values > SVM_STACK - SVM_HEADROOM:
            note = iface_("Cycles renders the node group ({why}), but the part of it that reads the linked "
                          "inputs ({live}) is too large for it ({values} live values, Cycles holds about {holds}) "
                          "and renders black: unlink an input (baked values cost nothing), or use Cycles with OSL "
                          "on the CPU.")
            box.alert = True
        elif s.node_tables:
            note = iface_("Cycles renders the node group ({why}). What its linked inputs reach is too large for "
                          "Cycles to trace here, so it reads that from tables over their range: {tables} (a texture "
                          "value outside is clamped). Within about 1 % of the OSL shader, which traces them exactly; "
                          "narrow lobes (roughness near 0.1 under a rougher coat) can differ more.")
        elif s.live_params and s.node_live_values > SVM_UNSURE:
            note = iface_("Cycles renders the node group ({why}); the part of it that reads the linked inputs "
                          "({live}) is near what Cycles holds ({values} live values, about {holds} fit) and may "
                          "render black: check a render, and if it is black unlink an input (baked values cost "
                          "nothing) or use Cycles with OSL on the CPU.")
        note = note.format(**values)
    # which of its two shaders Cycles renders is said once the nodes are checked (``nodes``)
    elif sc.render.engine == "CYCLES" and nodes is not None and not nodes.script:
        note = iface_("Cycles renders the node group: a linked input ({live}) reaches the model's look-up tables, "
                      "which the node group carries inside the file and the OSL shader would read from files "
                      "outside it.").format(live=s.live_params)
    elif sc.render.engine == "CYCLES" and nodes is not None:
        note = iface_("Cycles renders the OSL shader. With Open Shading Language off it renders the node group "
                      "instead (the same image where nothing linked is too large for it), and every shader of the "
                      "scene renders faster.")
    elif sc.render.engine != "CYCLES" and sc.render.engine.startswith("BLENDER_EEVEE"):
        note = iface_("EEVEE renders the node group: anisotropic lobes are shown isotropic.")
        if BASE_KINDS[s.base.kind].transmits:
            note += " " + iface_("Glass refracts once, where light enters (Lamella's Thickness 0): the back of a "
                                 "solid object does not refract again. It shows the objects behind it only with "
                                 "the scene's Ray Tracing on, and only what is on screen; elsewhere the light "
                                 "probes (the world).")
        if s.node_tables:
            note += " " + iface_("It reads its linked inputs from tables over their range: {tables} (values outside "
                                 "are clamped).").format(tables=s.node_tables)
    elif sc.render.engine != "CYCLES":
        note, fix = iface_("Cycles and EEVEE render this material; this engine does not."), True
    if note:
        col = box.column()
        _wrapped(col, note, "INFO")
        if fix:
            col.operator("lamella.fix_render_settings", icon="SETTINGS")


def draw_presets(layout, mat) -> None:
    row = layout.row(align=True)
    row.menu("LAMELLA_MT_presets", text="Presets", icon="PRESET")
    row.operator("lamella.preset_save", text="", icon="ADD")
    row.menu("LAMELLA_MT_stack_files", text="", icon="DOWNARROW_HLT")


def draw_layers(layout, mat) -> None:
    s = mat.lamella
    row = layout.row()
    row.template_list("LAMELLA_UL_layers", "", s, "coats", s, "active_index", rows=4)
    col = row.column(align=True)
    col.menu("LAMELLA_MT_add_layer", icon="ADD", text="")
    i, n = s.active_index, len(s.coats)
    selected = 0 <= i < n
    for enabled, draw in ((selected, lambda c: c.operator("lamella.layer_remove", icon="REMOVE", text="")),
                          (None, lambda c: c.separator()),
                          (selected, lambda c: c.operator("lamella.layer_duplicate", icon="DUPLICATE", text="")),
                          (None, lambda c: c.separator()),
                          (selected and i > 0, lambda c: setattr(c.operator("lamella.layer_move", icon="TRIA_UP",
                                                                            text=""), "direction", "UP")),
                          (selected and i < n - 1, lambda c: setattr(c.operator("lamella.layer_move", icon="TRIA_DOWN",
                                                                                text=""), "direction", "DOWN"))):
        if enabled is None:
            draw(col)
            continue
        sub = col.row(align=True)  # greyed out where it cannot act, as Blender's list buttons are
        sub.enabled = enabled
        draw(sub)
    base = layout.row()
    kind = BASE_KINDS[s.base.kind]
    base.label(text=iface_("Base: {kind}").format(kind=iface_(_kind_label(kind))),
               icon=kind_layer_icon(kind, s.base.settings()), translate=False)


def _kind_label(kind) -> str:
    return kind.type.replace("_", " ").title()


def _is_anisotropic(kind, pg) -> bool:
    return any(getattr(pg, f"{f.name}_anisotropic") for f in kind.fields if f.type == ROUGHNESS)


def draw_fields(layout, kind, pg, panel_prefix: str, enabled_fields=None) -> None:
    """The kind's schema fields, property split; grouped fields in collapsible sections."""
    col = layout.column()
    col.use_property_split = True
    col.use_property_decorate = False
    groups: dict[str, list] = {}
    for f in kind.fields:
        if f.group:
            groups.setdefault(f.group, []).append(f)
            continue
        _draw_field(col, kind, pg, f, enabled_fields)
    for group, fields in groups.items():
        header, body = layout.panel(f"{panel_prefix}_{group.lower().replace(' ', '_')}", default_closed=True)
        header.label(text=group)
        if body is not None:
            bcol = body.column()
            bcol.use_property_split = True
            bcol.use_property_decorate = False
            for f in fields:
                _draw_field(bcol, kind, pg, f, enabled_fields)


def _draw_field(col, kind, pg, f, enabled_fields) -> None:
    sub = col
    if enabled_fields is not None and f.name not in enabled_fields:
        sub = col.column()
        sub.enabled = False
    if f.type == ROUGHNESS:
        aniso = getattr(pg, f"{f.name}_anisotropic")
        if aniso:
            sub.prop(pg, f.name, text=iface_("{label} X").format(label=iface_(f.ui_label)), translate=False)
        else:
            sub.prop(pg, f.name, text=f.ui_label)
        if aniso:
            sub.prop(pg, f"{f.name}_y")
        sub.prop(pg, f"{f.name}_anisotropic")
    elif f.type == ANGLE and f.name == "rotation":
        if _is_anisotropic(kind, pg):  # the rotation turns the anisotropy axes: nothing to turn otherwise
            sub.prop(pg, f.name)
    else:
        sub.prop(pg, f.name)


def _draw_kind(layout, kind, pg, panel_prefix: str) -> None:
    """One layer of ``kind`` held in ``pg``: its kind's own part (``kind_hooks``), then its schema
    fields (those the part leaves editable)."""
    draw_kind = hooks(kind.type).draw
    enabled = draw_kind(layout, pg) if draw_kind is not None else None
    draw_fields(layout, kind, pg, panel_prefix, enabled)


def draw_active_layer(layout, mat) -> None:
    s = mat.lamella
    item = s.active_layer()
    header, body = layout.panel("lamella_layer", default_closed=False)
    header.label(text=iface_("Layer: {name}").format(name=item.name) if item else iface_("Layer"), translate=False)
    if body is None:
        return
    if item is None:
        body.label(text="No coat: add one with +", icon="INFO")
        return
    body.prop(item, "name")
    _draw_kind(body, COAT_KINDS[item.kind], item.settings(), "lamella_layer")


def draw_base(layout, mat) -> None:
    b = mat.lamella.base
    header, body = layout.panel("lamella_base", default_closed=False)
    kind = BASE_KINDS[b.kind]
    header.label(text=iface_("Base: {kind}").format(kind=iface_(_kind_label(kind))), translate=False)
    if body is None:
        return
    body.row().prop(b, "kind", expand=True)
    _draw_kind(body, kind, b.settings(), "lamella_base")


def draw_model(layout, mat) -> None:
    s = mat.lamella
    header, body = layout.panel("lamella_model", default_closed=True)
    header.label(text=(iface_("Model: {model} (auto)") if s.model == "auto" else iface_("Model: {model}")).format(
        model=s.picked_model or s.model), translate=False)
    if body is None:
        return
    col = body.column()
    col.use_property_split = True
    col.use_property_decorate = False
    col.prop(s, "model")
    if s.model == "auto" and s.picked_model:
        col.label(text=iface_("Auto picked {model}").format(model=s.picked_model), icon="INFO", translate=False)
    col.prop(s, "lobe_budget")
    if s.lobes_all:
        col.label(text=iface_("{closures} closures for {lobes} lobes").format(closures=s.closures, lobes=s.lobes_all),
                  icon="SHADING_RENDERED", translate=False)
        if s.closures > MAX_CLOSURES:  # only lobes that cannot merge (of different kinds) pass the cap
            _wrapped(col, iface_("Cycles with OSL draws about {n} closures per point and drops the rest: unlink an "
                                 "input, or render with OSL off or in EEVEE.").format(n=MAX_CLOSURES + 1), "ERROR")
    col.label(text=iface_("Live: {params}").format(params=s.live_params) if s.live_params
              else iface_("Live: nothing (every value baked)"), translate=False,
              icon="LINKED" if s.live_params else "UNLINKED")
    body.operator("lamella.recompile", icon="FILE_REFRESH")


def draw_inspector(layout, mat) -> None:
    s = mat.lamella
    header, body = layout.panel("lamella_inspector", default_closed=True)
    header.label(text="Lobe Inspector")
    if body is None:
        return
    col = body.column()
    col.use_property_split = True
    col.use_property_decorate = False
    col.prop(s, "inspect_angle")
    if s.preview is not None and inspector.is_fresh(mat):
        body.template_icon(icon_value=s.preview.preview.icon_id if s.preview.preview else 0, scale=8.0)
        body.label(text="Slice in the plane of incidence (square-root scale); yellow: the view")
    grid = body.grid_flow(columns=4, even_columns=True, align=True)
    for text in ("Lobe", "Energy", "Roughness", "Anisotropy"):
        grid.label(text=text)
    for lobe in s.lobes:
        grid.label(text=lobe.kind)
        grid.prop(lobe, "weight", text="")
        grid.label(text="{:.3f}".format(lobe.roughness), translate=False)
        grid.label(text="{:+.2f}".format(lobe.anisotropy), translate=False)
    energy = [sum(lobe.weight[c] for lobe in s.lobes) for c in range(3)]
    body.label(text=iface_("Total energy: {energy}").format(energy=", ".join("{:.3f}".format(e) for e in energy)),
               translate=False)


def draw_material(layout, context, mat) -> None:
    """The whole panel for ``mat``."""
    if mat is None:
        layout.label(text="No material", icon="INFO")
        return
    s = mat.lamella
    if not s.enabled:
        layout.label(text="Not a Lamella material")
        row = layout.row()
        row.operator("lamella.enable", icon="MATERIAL")
        row.operator("lamella.material_new", icon="ADD")
        return
    if mat.library is not None:
        layout.label(text=iface_("Linked from {path}: read only").format(path=mat.library.filepath), icon="LINKED",
                     translate=False)
        layout.enabled = False
    draw_status(layout, context, mat)
    draw_presets(layout, mat)
    draw_layers(layout, mat)
    draw_active_layer(layout, mat)
    draw_base(layout, mat)
    draw_model(layout, mat)
    draw_inspector(layout, mat)


# ---------------------------------------------------------------- classes
class LAMELLA_UL_layers(bpy.types.UIList):
    """Coats top to bottom: kind icon, name, eye toggle."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0):
        row = layout.row(align=True)
        row.active = item.show
        row.prop(item, "name", text="", emboss=False, icon=layer_icon(item))
        row.prop(item, "show", text="", emboss=False, icon="HIDE_OFF" if item.show else "HIDE_ON")


class LAMELLA_MT_add_layer(bpy.types.Menu):
    """Coat templates to add above the active layer."""

    bl_label = "Add Layer"

    def draw(self, context):
        for ident, label, _desc, icon, _i in template_items():
            self.layout.operator("lamella.layer_add", text=label, icon=icon).template = ident


class LAMELLA_MT_presets(bpy.types.Menu):
    """Built-in presets, then the user's."""

    bl_label = "Presets"

    def draw(self, context):
        layout = self.layout
        builtin = True
        for ident, label, _desc, icon, _i in preset_items():
            if builtin and ident.startswith("user:"):
                builtin = False
                layout.separator()
                layout.label(text="User Presets")
            layout.operator("lamella.preset_apply", text=label, icon=icon).preset = ident
        for path, why in skipped_presets():
            layout.label(text=iface_("Skipped {file}: {why}").format(file=path.name, why=why)[:120], icon="ERROR",
                         translate=False)


class LAMELLA_MT_stack_files(bpy.types.Menu):
    """Stack files and shader export."""

    bl_label = "Stack"

    def draw(self, context):
        layout = self.layout
        layout.operator("lamella.stack_import", icon="IMPORT")
        layout.operator("lamella.stack_export", icon="EXPORT")
        layout.separator()
        layout.operator("lamella.export_osl", icon="SCRIPT")
        layout.separator()
        layout.operator_menu_enum("lamella.preset_remove", "preset", text="Remove User Preset", icon="TRASH")
        layout.operator("lamella.disable", icon="X")


class LamellaPanel:
    """Mixin: the Lamella panel, one poll and one draw wherever it is shown (as Cycles' panels
    share theirs between engines); a panel class says where it sits and which material it shows
    (``shown_material``)."""

    bl_label = "Lamella"

    @staticmethod
    def shown_material(context):
        raise NotImplementedError

    @classmethod
    def poll(cls, context):
        return cls.shown_material(context) is not None

    def draw(self, context):
        draw_material(self.layout, context, self.shown_material(context))


class LAMELLA_PT_material(LamellaPanel, bpy.types.Panel):
    """Lamella in Properties > Material."""

    bl_idname = "LAMELLA_PT_material"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"

    @staticmethod
    def shown_material(context):
        return getattr(context, "material", None)


class LAMELLA_PT_node_editor(LamellaPanel, bpy.types.Panel):
    """Lamella in the shader editor's sidebar."""

    bl_idname = "LAMELLA_PT_node_editor"
    bl_space_type = "NODE_EDITOR"
    bl_region_type = "UI"
    bl_category = "Lamella"

    @staticmethod
    def shown_material(context):
        """The material whose node tree the editor shows."""
        space = getattr(context, "space_data", None)
        if space is not None and getattr(space, "tree_type", "") == "ShaderNodeTree":
            mat = getattr(space, "id", None)
            return mat if isinstance(mat, bpy.types.Material) else None
        return None


classes = (LAMELLA_UL_layers, LAMELLA_MT_add_layer, LAMELLA_MT_presets, LAMELLA_MT_stack_files,
           LAMELLA_PT_material, LAMELLA_PT_node_editor)


register, unregister = bpy.utils.register_classes_factory(classes)


__all__ = ["draw_material", "context_material", "classes"]
