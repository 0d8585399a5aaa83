"""The stack a Lamella material holds: PropertyGroups generated from the layer-kind schema
(``lamella.core.layers``), so names, descriptions, units, limits and defaults are written once.

``Material.lamella`` (:class:`LAMELLA_PG_material`) holds the coats (a collection, top to bottom),
the base, the model choice and the compile status. Every layer kind gets one PropertyGroup of its
fields (``LAMELLA_PG_kind_<type>``); a layer item points to one of each kind of its role and its
``kind`` says which is live, so switching a base from conductor to diffuse and back loses nothing.

Field types map to properties as follows (Blender's conventions at the UI boundary):

- ``float``: a FloatProperty with the hard limits as min/max (the parser's, closed) and the
  soft range as the slider range;
- ``angle``: the same with the ANGLE subtype (stored in radians, shown in degrees);
- ``rgb``: a 3-vector, COLOR subtype for reflectances (``Field.color``);
- ``bool``: a BoolProperty (a choice of the layer's structure, such as a thin-walled base: never
  a socket of the Lamella node);
- ``roughness`` (GGX alpha in the stack): Blender's roughness r with alpha = r^2, as a value along
  the tangent ``<name>``, an ``<name>_anisotropic`` switch and ``<name>_y`` across it.

Every edit schedules a debounced recompile (``recompile.schedule``), never compiling in the
update callback itself.
"""
from __future__ import annotations

import math

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, FloatVectorProperty,
                       IntProperty, PointerProperty, StringProperty)

from ..core.models import MODELS
from ..core.layers import ANGLE, BASE_KINDS, BOOL, COAT_KINDS, FLOAT, RGB, ROUGHNESS
from ..core.param_id import r_from_alpha
from . import kind_hooks, recompile
from .stack_props import unique_label
from .tooltips import field_tooltip, roughness_tooltip

def _on_edit(self, context):
    recompile.schedule(self.id_data)


_naming = False


def _on_name(self, context):
    """A layer renamed: its label, made unique in its material ("Clear Coat 2"), names its inputs
    on the Lamella node at the compile the edit schedules."""
    global _naming
    if not _naming:
        others = [c.name for c in self.id_data.lamella.coats if c.as_pointer() != self.as_pointer()]
        label = unique_label(self.name, others)
        if label != self.name:
            _naming = True
            try:
                self.name = label
            finally:
                _naming = False
    _on_edit(self, context)


def _on_inspect(self, context):
    recompile.schedule_inspector(self.id_data)


def _limits(f) -> dict:
    """The schema's hard limits (the parser's, so nothing it accepts is clamped) and soft range."""
    kw = {"min": f.lo, "max": f.hi}
    if f.soft is not None:
        kw["soft_min"] = max(f.soft[0], kw.get("min", -math.inf))
        kw["soft_max"] = min(f.soft[1], kw.get("max", math.inf))
    return kw


def field_properties(f, update=_on_edit) -> dict:
    """The Blender properties (name -> property definition) that hold schema field ``f``."""
    label, desc = f.ui_label, field_tooltip(f)
    if f.type in (FLOAT, ANGLE):
        return {f.name: FloatProperty(name=label, description=desc, default=float(f.default),
                                      subtype="ANGLE" if f.type == ANGLE else "NONE", update=update, **_limits(f))}
    if f.type == BOOL:
        return {f.name: BoolProperty(name=label, description=desc, default=bool(f.default), update=update)}
    if f.type == RGB:
        return {f.name: FloatVectorProperty(name=label, description=desc, size=3, default=tuple(f.default),
                                            subtype="COLOR" if f.color else "NONE", update=update, **_limits(f))}
    if f.type == ROUGHNESS:
        ax, ay = f.default if isinstance(f.default, (list, tuple)) else (f.default, f.default)
        return {
            f.name: FloatProperty(name=label, description=roughness_tooltip(f),
                                  default=r_from_alpha(ax), min=0.0, max=1.0, subtype="FACTOR", update=update),
            f"{f.name}_anisotropic": BoolProperty(
                name="Anisotropic", description="Different roughness along and across the tangent (brushed)",
                default=ax != ay, update=update),
            f"{f.name}_y": FloatProperty(name=f"{label} Y", description=roughness_tooltip(f, across=True),
                                         default=r_from_alpha(ay), min=0.0, max=1.0, subtype="FACTOR", update=update),
        }
    raise TypeError(f"no Blender property for field type {f.type!r}")


def _kind_group(kind) -> type:
    """The PropertyGroup of a layer kind: its schema fields and its Blender hooks' properties."""
    ann = {}
    for f in kind.fields:
        ann.update(field_properties(f))
    extra = kind_hooks.hooks(kind.type).properties
    if extra is not None:
        ann.update(extra())
    return type(f"LAMELLA_PG_kind_{kind.type}", (bpy.types.PropertyGroup,),
                {"__annotations__": ann, "__doc__": kind.description.splitlines()[0]})


def _kind_items(kinds):
    return [(k.type, k.type.replace("_", " ").title(), k.description.splitlines()[0], k.icon, i)
            for i, k in enumerate(kinds.values())]


class LAMELLA_PG_layer(bpy.types.PropertyGroup):
    """One coat of the stack; ``name`` is what the list shows."""

    __annotations__ = {}  # the registered coat kinds' (``build_classes``)

    def settings(self):
        """The PropertyGroup of this layer's live kind."""
        return getattr(self, self.kind)


class LAMELLA_PG_base(bpy.types.PropertyGroup):
    """The base closing the stack."""

    __annotations__ = {}  # the registered base kinds' (``build_classes``)

    def settings(self):
        return getattr(self, self.kind)


class LAMELLA_PG_lobe(bpy.types.PropertyGroup):
    """One row of the lobe inspector (read-only, written by the inspector)."""

    kind: StringProperty(name="Kind")
    weight: FloatVectorProperty(name="Weight", size=3, subtype="COLOR", min=0.0,
                                description="Energy of the lobe (RGB directional albedo)")
    roughness: FloatProperty(name="Roughness", description="Blender roughness of the lobe along its axes' mean")
    anisotropy: FloatProperty(name="Anisotropy", description="(alpha_x - alpha_y) / (alpha_x + alpha_y)")
    rotation: FloatProperty(name="Rotation", subtype="ANGLE")


STATUS = (
    ("NONE", "Not Compiled", "The stack has not been compiled yet"),
    ("PENDING", "Pending", "An edit is waiting to be compiled"),
    ("OK", "Compiled", "The shader matches the stack"),
    ("ERROR", "Error", "The last edit could not be compiled; the material keeps its last working shader"),
)


class LAMELLA_PG_material(bpy.types.PropertyGroup):
    """The Lamella stack of a material."""

    enabled: BoolProperty(name="Lamella", description="This material is built by Lamella from its layer stack")
    format: IntProperty(name="Stack Format", default=0, min=0,
                        description="Version of the stack format this material's Lamella data is stored in "
                                    "(0: saved before versions were recorded, read as 1)")
    stack_name: StringProperty(name="Stack Name", description="Name of the stack (kept in exported JSON)",
                               update=_on_edit)
    coats: CollectionProperty(type=LAMELLA_PG_layer, name="Coats", description="Coats, top to bottom")
    active_index: IntProperty(name="Active Layer", default=0, min=0)
    base: PointerProperty(type=LAMELLA_PG_base)
    # model: the registered models' (``build_classes``)
    picked_model: StringProperty(name="Picked Model", description="The model the last compile ran")
    lobe_budget: EnumProperty(
        name="Lobe Budget",
        description="Closures the shader may use: the model's lobes are merged down to this many "
                    "(fewer closures render faster; Auto keeps the BRDF within 1 % of all lobes)",
        items=[("auto", "Auto", "The fewest closures within 1 % of every lobe (relative L1)", 0),
               ("all", "All", "Every lobe of the model", 1)]
              + [(str(k), str(k), f"At most {k} closure{'s' if k > 1 else ''}", k + 1) for k in range(1, 9)],
        default="auto", update=_on_edit)
    closures: IntProperty(name="Closures", description="Closures the compiled shader uses")
    lobes_all: IntProperty(name="Lobes", description="Lobes the model emits for this stack")
    live_params: StringProperty(name="Live Parameters",
                                description="Inputs linked to a texture: read by the shader, not baked")
    status: EnumProperty(name="Status", items=STATUS, default="NONE")
    status_message: StringProperty(name="Message")
    compile_ms: FloatProperty(name="Compile Time", description="Milliseconds the last compile took")
    node_live_values: IntProperty(
        name="Node Group Live Values",
        description="Values the node group keeps alive at once in Cycles without OSL (SVM holds about 215)")
    node_tables: StringProperty(
        name="Node Group Tables",
        description="Linked inputs the node group reads from tables over a range (values outside are clamped), "
                    "where what they reach is too large for Cycles without OSL")
    compiled_json: StringProperty(name="Compiled Stack", description="The stack of the shader in place (JSON)")
    inspect_angle: FloatProperty(name="View Angle", description="Angle between the view and the normal",
                                 subtype="ANGLE", default=math.radians(30.0), min=0.0,
                                 max=math.radians(89.0), update=_on_inspect)
    lobes: CollectionProperty(type=LAMELLA_PG_lobe)
    inspected_json: StringProperty(description="The stack and angle the inspector shows")
    preview: PointerProperty(type=bpy.types.Image, name="BRDF Preview")

    def active_layer(self):
        if 0 <= self.active_index < len(self.coats):
            return self.coats[self.active_index]
        return None


KIND_GROUPS: dict[str, type] = {}  # kind type -> its PropertyGroup, as last registered
classes: tuple = ()


def build_classes() -> tuple:
    """The extension's PropertyGroups for the layer kinds and models registered now: one group per
    kind, a pointer to each from the coat item (coat kinds) or the base (base kinds), and the kind
    and model menus. Built at ``register`` so a kind an extension module registered before is
    part of the panel, the stored data and every file saved."""
    KIND_GROUPS.clear()
    KIND_GROUPS.update({k.type: _kind_group(k) for k in (*COAT_KINDS.values(), *BASE_KINDS.values())})
    LAMELLA_PG_layer.__annotations__ = {
        "kind": EnumProperty(name="Kind", items=_kind_items(COAT_KINDS), update=_on_edit),
        "name": StringProperty(name="Name", description="The layer's label, its own in the material: the list's, "
                                                        "and its inputs' on the material's Lamella node "
                                                        "(\"<label>: <field>\")", update=_on_name),
        "show": BoolProperty(name="Show", description="Include this layer in the material (mute it to compare)",
                             default=True, update=_on_edit),
        "uid": StringProperty(name="Identity", options={"HIDDEN"},
                              description="What keeps this layer's inputs on the material's node (textures, "
                                          "keyframes) with it when other layers are added, moved or removed"),
        **{k: PointerProperty(type=KIND_GROUPS[k]) for k in COAT_KINDS},
    }
    LAMELLA_PG_base.__annotations__ = {
        "kind": EnumProperty(name="Base", items=_kind_items(BASE_KINDS), update=_on_edit),
        **{k: PointerProperty(type=KIND_GROUPS[k]) for k in BASE_KINDS},
    }
    LAMELLA_PG_material.__annotations__["model"] = EnumProperty(
        name="Model", description="Layered model the shader is built from",
        items=[(m, m if m != "auto" else "Auto", "The best model for this stack's structure" if m == "auto"
                else f"Force the {m} model", i) for i, m in enumerate(("auto", *MODELS))],
        default="auto", update=_on_edit)
    return (*KIND_GROUPS.values(), LAMELLA_PG_layer, LAMELLA_PG_base, LAMELLA_PG_lobe, LAMELLA_PG_material)


def register():
    global classes
    classes = build_classes()
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Material.lamella = PointerProperty(type=LAMELLA_PG_material, name="Lamella")


def unregister():
    del bpy.types.Material.lamella
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
