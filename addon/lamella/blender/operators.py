"""Operators (``bpy.ops.lamella.*``): layers, presets, import/export, compile, render settings.

Every operator acts on the context's material (the Properties editor's, else the active
object's) or on the material named by its ``material`` property, so that each one works from a
script in background mode. All are undoable, have a description and a poll, report problems
through ``self.report`` and never raise into Blender's interface; a failed action leaves the
material as it was.
"""
from __future__ import annotations

import os
from pathlib import Path

import bpy
from bpy.props import EnumProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper

from ..core import presets
from ..core.backends.osl.bundle import write_bundle
from ..core.layers import COAT_KINDS
from ..core.stack import MAX_COATS, Stack, StackError
from . import api, material_nodes, paths, recompile
from .animation import following_layers
from .i18n import rpt_
from .stack_props import copy_layer, new_uid, unique_label, write_kind


def context_material(context):
    mat = getattr(context, "material", None)
    if mat is None:
        ob = getattr(context, "object", None)
        mat = getattr(ob, "active_material", None) if ob is not None else None
    return mat


class _MaterialOperator:
    """Mixin: the target material, and errors turned into reports."""

    bl_options = {"REGISTER", "UNDO"}
    needs_lamella = True  # the material must already be a Lamella material

    material: StringProperty(name="Material", description="Material to act on (default: the context's)",
                             options={"SKIP_SAVE"})

    @classmethod
    def poll(cls, context):
        """The context's material qualifies, or (a script naming its material with material=,
        e.g. in background mode) some material in the file does."""
        mat = context_material(context)
        if mat is not None and cls._qualifies(mat):
            return True
        if any(cls._qualifies(m) for m in bpy.data.materials):
            return True
        cls.poll_message_set("No editable Lamella material" if cls.needs_lamella else "No editable material")
        return False

    @classmethod
    def _qualifies(cls, mat) -> bool:
        return mat.library is None and (mat.lamella.enabled or not cls.needs_lamella)

    def target(self, context):
        if self.material:
            mat = bpy.data.materials.get(self.material)
            if mat is None:
                raise LookupError(rpt_("no material named {name!r}").format(name=self.material))
        else:
            mat = context_material(context)
            if mat is None:
                raise LookupError(rpt_("no material: select an object with a material, or name one with material="))
        if mat.library is not None:
            raise LookupError(rpt_("material {name!r} is linked from another file and cannot be edited").format(name=mat.name))
        if self.needs_lamella and not mat.lamella.enabled:
            raise LookupError(rpt_("material {name!r} is not a Lamella material (use Lamella > Enable)").format(
                name=mat.name))
        return mat

    def execute(self, context):
        try:
            mat = self.target(context)
            result = self.run(context, mat)
        except (StackError, LookupError, ValueError, OSError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        except Exception as e:  # never raise into the interface; say what happened
            self.report({"ERROR"}, "{}: {}".format(type(e).__name__, e))
            return {"CANCELLED"}
        return result or {"FINISHED"}

    def compiled(self, mat) -> None:
        """Compile now and report an error the compile met (the material keeps its last shader);
        the node group waits where no scene renders it (``recompile.flush_groups``), the lobe
        inspector refreshes a tick later (``recompile.schedule_inspector``)."""
        if recompile.compile_material(mat, defer_group=not recompile.groups_needed(), inspect=False):
            recompile.schedule_inspector(mat)
        else:
            self.report({"WARNING"}, "{}: {}".format(mat.name, mat.lamella.status_message))


# ---------------------------------------------------------------- material
class LAMELLA_OT_material_new(_MaterialOperator, bpy.types.Operator):
    """Create a new Lamella material from a preset, on the active object if there is one"""

    bl_idname = "lamella.material_new"
    bl_label = "New Lamella Material"
    needs_lamella = False

    name: StringProperty(name="Name", default="Lamella")
    preset: StringProperty(name="Preset", default="lacquered_gold", description="Preset to start from")

    @classmethod
    def poll(cls, context):
        return True

    def target(self, context):
        return None

    def run(self, context, _mat):
        stack = presets.find(self.preset, paths.user_presets_dir()).load()
        mat = bpy.data.materials.new(self.name)
        try:
            api.apply_stack(mat, stack)
        except Exception:
            bpy.data.materials.remove(mat)
            raise
        ob = getattr(context, "object", None)
        if ob is not None and getattr(ob, "data", None) is not None and hasattr(ob.data, "materials"):
            if ob.material_slots and ob.active_material is None:
                ob.active_material = mat
            else:
                ob.data.materials.append(mat)
                ob.active_material_index = len(ob.material_slots) - 1
        self.report({"INFO"}, rpt_("created {material}").format(material=mat.name))


class LAMELLA_OT_enable(_MaterialOperator, bpy.types.Operator):
    """Make this material a Lamella material (its own nodes stay; the Lamella node feeds its output)"""

    bl_idname = "lamella.enable"
    bl_label = "Use Lamella"
    needs_lamella = False

    def run(self, context, mat):
        if mat.lamella.enabled:
            self.report({"INFO"}, rpt_("{material} already is a Lamella material").format(material=mat.name))
            return
        api.apply_stack(mat, Stack.from_dict({"layers": [{}], "base": {"type": "conductor"}}), "auto")


class LAMELLA_OT_disable(_MaterialOperator, bpy.types.Operator):
    """Stop building this material with Lamella: remove its Lamella nodes (the layer stack is kept)"""

    bl_idname = "lamella.disable"
    bl_label = "Remove Lamella Nodes"

    def run(self, context, mat):
        for node in material_nodes.lamella_nodes(mat):
            mat.node_tree.nodes.remove(node)
        mat.lamella.enabled = False
        mat.lamella.status = "NONE"


class LAMELLA_OT_recompile(_MaterialOperator, bpy.types.Operator):
    """Rebuild the shader from the layer stack now"""

    bl_idname = "lamella.recompile"
    bl_label = "Recompile"

    def run(self, context, mat):
        if not recompile.compile_material(mat):
            self.report({"ERROR"}, "{}: {}".format(mat.name, mat.lamella.status_message))
            return {"CANCELLED"}
        self.report({"INFO"}, rpt_("{material}: compiled ({model}, {ms:.0f} ms)").format(
            material=mat.name, model=mat.lamella.picked_model, ms=mat.lamella.compile_ms))


# ---------------------------------------------------------------- layers
_TEMPLATE_ITEMS: list = []


def template_items(self=None, context=None):
    if not _TEMPLATE_ITEMS:
        _TEMPLATE_ITEMS.extend((t["id"], t["label"], t["description"], t.get("icon", "NONE"), i)
                               for i, t in enumerate(presets.layer_templates()))
    return _TEMPLATE_ITEMS


class LAMELLA_OT_layer_add(_MaterialOperator, bpy.types.Operator):
    """Add a coat above the active layer"""

    bl_idname = "lamella.layer_add"
    bl_label = "Add Layer"

    template: EnumProperty(name="Layer", description="What kind of coat to add", items=template_items)

    def run(self, context, mat):
        s = mat.lamella
        if len(s.coats) >= MAX_COATS:
            raise ValueError(rpt_("a stack holds at most {n} coats").format(n=MAX_COATS))
        t = next(t for t in presets.layer_templates() if t["id"] == self.template)
        kind = COAT_KINDS[t["layer"].get("type", "coat")]
        layer = kind.parse(f"template {t['id']}", t["layer"])
        at = min(s.active_index, len(s.coats)) if len(s.coats) else 0
        with recompile.suspended(), following_layers(mat):
            item = s.coats.add()
            item.kind = kind.type
            item.uid = new_uid()
            item.name = unique_label(t["label"], [c.name for c in s.coats][:-1])
            write_kind(kind, item.settings(), layer)
            s.coats.move(len(s.coats) - 1, at)
            s.active_index = at
        self.compiled(mat)


class LAMELLA_OT_layer_remove(_MaterialOperator, bpy.types.Operator):
    """Remove the active layer"""

    bl_idname = "lamella.layer_remove"
    bl_label = "Remove Layer"

    def run(self, context, mat):
        s = mat.lamella
        if not s.coats:
            raise ValueError(rpt_("there is no coat to remove (the base stays)"))
        if not 0 <= s.active_index < len(s.coats):
            raise ValueError(rpt_("select a coat to remove (the active index {index} is no coat; there are {n})").format(
                index=s.active_index, n=len(s.coats)))
        with recompile.suspended(), following_layers(mat):
            s.coats.remove(s.active_index)
            s.active_index = max(0, min(s.active_index, len(s.coats) - 1))
        self.compiled(mat)


class LAMELLA_OT_layer_move(_MaterialOperator, bpy.types.Operator):
    """Move the active layer up (toward the top) or down (toward the base)"""

    bl_idname = "lamella.layer_move"
    bl_label = "Move Layer"

    direction: EnumProperty(items=(("UP", "Up", "Toward the top"), ("DOWN", "Down", "Toward the base")))

    def run(self, context, mat):
        s = mat.lamella
        i = s.active_index
        j = i - 1 if self.direction == "UP" else i + 1
        if not 0 <= i < len(s.coats):
            raise ValueError(rpt_("select a coat to move"))
        if not 0 <= j < len(s.coats):
            raise ValueError((rpt_("coat {i} is already the top coat") if self.direction == "UP"
                              else rpt_("coat {i} is already the lowest coat")).format(i=i))
        with recompile.suspended(), following_layers(mat):
            s.coats.move(i, j)
            s.active_index = j
        self.compiled(mat)


class LAMELLA_OT_layer_duplicate(_MaterialOperator, bpy.types.Operator):
    """Duplicate the active layer (the copy goes right above it)"""

    bl_idname = "lamella.layer_duplicate"
    bl_label = "Duplicate Layer"

    def run(self, context, mat):
        s = mat.lamella
        if not 0 <= s.active_index < len(s.coats):
            raise ValueError(rpt_("select a coat to duplicate"))
        if len(s.coats) >= MAX_COATS:
            raise ValueError(rpt_("a stack holds at most {n} coats").format(n=MAX_COATS))
        with recompile.suspended(), following_layers(mat):
            src = s.active_index
            item = s.coats.add()
            copy_layer(s.coats[src], item)
            item.name = unique_label(item.name, [c.name for c in s.coats][:-1])
            s.coats.move(len(s.coats) - 1, src)
            s.active_index = src
        self.compiled(mat)


# ---------------------------------------------------------------- presets and files
_PRESET_ITEMS: list = []
_SKIPPED_PRESETS: list = []  # (path, why) of the user's preset files that do not load
_BUILTIN_PRESETS: list = []
_preset_folder = None  # what the user's preset folder held when the items were made (``_folder_state``)


def _folder_state(folder) -> tuple:
    """The user's preset folder and each preset file's name, size and time: what says whether the
    files must be read again."""
    if folder is None:
        return (None,)
    try:
        with os.scandir(folder) as it:
            files = sorted((e.name, e.stat().st_size, e.stat().st_mtime_ns) for e in it if e.name.endswith(".json"))
    except OSError:
        files = []
    return (str(folder), *files)


def preset_items(self=None, context=None):
    """Built-in presets, then the user's (the list object is kept alive, as Blender requires). The
    files are read only when the user's folder changed (the built-in ones once), so the menus that
    list them read nothing else while they draw; the user's files that do not load are
    ``skipped_presets``."""
    global _preset_folder
    folder = paths.user_presets_dir()
    state = _folder_state(folder)
    if state != _preset_folder:
        if not _BUILTIN_PRESETS:
            _BUILTIN_PRESETS.extend(presets.builtin())
        user, skipped = presets.scan_user(folder)
        _PRESET_ITEMS[:] = [(p.id, p.label, p.description, "USER" if not p.builtin else "MATERIAL", i)
                            for i, p in enumerate(_BUILTIN_PRESETS + user)]
        _SKIPPED_PRESETS[:] = skipped
        _preset_folder = state
    return _PRESET_ITEMS


def skipped_presets() -> list:
    """(path, why) of the user's preset files that do not load, as ``preset_items`` last read them."""
    return _SKIPPED_PRESETS


def _apply_file_stack(op, mat, stack) -> None:
    api.apply_stack(mat, stack)
    op.report({"INFO"}, rpt_("{material}: {stack} applied ({model})").format(
        material=mat.name, stack=stack.name or rpt_("stack"), model=mat.lamella.picked_model))


class LAMELLA_OT_preset_apply(_MaterialOperator, bpy.types.Operator):
    """Replace the material's stack by a preset (undo brings the previous stack back)"""

    bl_idname = "lamella.preset_apply"
    bl_label = "Apply Preset"
    needs_lamella = False

    preset: EnumProperty(name="Preset", items=preset_items)

    def run(self, context, mat):
        api.apply_preset(mat, self.preset)  # the stack, and the nodes of the preset's procedural inputs
        self.report({"INFO"}, rpt_("{material}: {stack} applied ({model})").format(
            material=mat.name, stack=mat.lamella.stack_name or rpt_("stack"), model=mat.lamella.picked_model))


class LAMELLA_OT_preset_save(_MaterialOperator, bpy.types.Operator):
    """Save the material's stack as a user preset"""

    bl_idname = "lamella.preset_save"
    bl_label = "Save Preset"
    bl_options = {"REGISTER"}

    name: StringProperty(name="Name", description="Preset name", default="My Stack")

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def run(self, context, mat):
        if not self.name.strip():
            raise ValueError(rpt_("give the preset a name"))
        folder = paths.user_presets_dir()
        if folder is None:
            raise OSError(rpt_("the extension's user folder cannot be written: presets cannot be saved"))
        path = presets.save_user(folder, self.name.strip(), Stack.from_dict(api.read_stack(mat)))
        self.report({"INFO"}, rpt_("saved preset {name!r} to {path}").format(name=self.name, path=path))


class LAMELLA_OT_preset_remove(_MaterialOperator, bpy.types.Operator):
    """Delete a user preset (built-in presets cannot be removed)"""

    bl_idname = "lamella.preset_remove"
    bl_label = "Remove Preset"
    bl_options = {"REGISTER"}
    needs_lamella = False

    preset: EnumProperty(name="Preset", items=preset_items)

    def target(self, context):
        return None

    def run(self, context, _mat):
        p = presets.find(self.preset, paths.user_presets_dir())
        if p.builtin:
            raise ValueError(rpt_("{name!r} is a built-in preset").format(name=p.label))
        p.path.unlink()
        self.report({"INFO"}, rpt_("removed preset {name!r}").format(name=p.label))


class LAMELLA_OT_stack_import(_MaterialOperator, bpy.types.Operator, ImportHelper):
    """Replace the material's stack by one read from a JSON file"""

    bl_idname = "lamella.stack_import"
    bl_label = "Import Stack"
    needs_lamella = False
    filename_ext = ".json"

    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})

    def run(self, context, mat):
        try:
            text = open(self.filepath, encoding="utf-8").read()
        except OSError as e:
            raise OSError(rpt_("cannot read {path}: {why}").format(path=self.filepath, why=e.strerror)) from None
        _apply_file_stack(self, mat, Stack.from_json(text))


class LAMELLA_OT_stack_export(_MaterialOperator, bpy.types.Operator, ExportHelper):
    """Write the material's stack to a JSON file"""

    bl_idname = "lamella.stack_export"
    bl_label = "Export Stack"
    bl_options = {"REGISTER"}
    filename_ext = ".json"

    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})

    def run(self, context, mat):
        text = api.read_stack_json(mat)
        with open(self.filepath, "w", encoding="utf-8") as f:
            f.write(text + "\n")
        self.report({"INFO"}, rpt_("wrote {path}").format(path=self.filepath))


class LAMELLA_OT_export_osl(_MaterialOperator, bpy.types.Operator, ExportHelper):
    """Export the material's shader as a self-contained OSL bundle (shader, tables, README) for
    another renderer"""

    bl_idname = "lamella.export_osl"
    bl_label = "Export OSL"
    bl_options = {"REGISTER"}
    filename_ext = ".osl"

    filter_glob: StringProperty(default="*.osl", options={"HIDDEN"})
    target_convention: EnumProperty(
        name="View Convention",
        items=(("cycles", "Cycles", "I points toward the viewer (Cycles)"),
               ("osl-spec", "OSL Specification", "I points toward the surface (the OSL specification)")))

    def run(self, context, mat):
        out = Path(self.filepath)
        shader = write_bundle(Stack.from_dict(api.read_stack(mat)), out.parent, model=mat.lamella.model,
                              target=self.target_convention, file_name=out.name,
                              live=material_nodes.linked_sockets(mat), budget=mat.lamella.lobe_budget)
        self.report({"INFO"}, rpt_("wrote {shader} and its tables").format(shader=shader))


# ---------------------------------------------------------------- render settings
class LAMELLA_OT_fix_render_settings(bpy.types.Operator):
    """Set the scene up so Lamella's OSL shader renders: Cycles, Open Shading Language on, CPU device"""

    bl_idname = "lamella.fix_render_settings"
    bl_label = "Use Cycles with OSL on the CPU"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return getattr(context, "scene", None) is not None

    def execute(self, context):
        sc = context.scene
        sc.render.engine = "CYCLES"
        sc.cycles.shading_system = True
        sc.cycles.device = "CPU"
        self.report({"INFO"}, rpt_("Cycles with Open Shading Language on the CPU"))
        return {"FINISHED"}


classes = (
    LAMELLA_OT_material_new, LAMELLA_OT_enable, LAMELLA_OT_disable, LAMELLA_OT_recompile,
    LAMELLA_OT_layer_add, LAMELLA_OT_layer_remove, LAMELLA_OT_layer_move, LAMELLA_OT_layer_duplicate,
    LAMELLA_OT_preset_apply, LAMELLA_OT_preset_save, LAMELLA_OT_preset_remove,
    LAMELLA_OT_stack_import, LAMELLA_OT_stack_export, LAMELLA_OT_export_osl, LAMELLA_OT_fix_render_settings,
)


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(classes)


def register():
    _register_classes()
    template_items()  # the menus' items read now, not while a menu draws
    preset_items()


def unregister():
    global _preset_folder
    _unregister_classes()
    _preset_folder = None
