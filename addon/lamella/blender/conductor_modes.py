"""The conductor base's colour modes in Blender (its per-kind hooks, ``kind_hooks``): a measured
metal (published complex indices, ``lamella.core.metals``), artist colours (Gulbrandsen 2014's
reflectivity and edge tint, stored as eta/k) or eta + i k itself. The stack holds eta and k only;
the mode and its inputs are properties of the panel."""
from __future__ import annotations

from dataclasses import replace

from bpy.props import EnumProperty, FloatVectorProperty

from ..core import metals
from .face import FaceInput
from .kind_hooks import KindHooks

METAL_MODES = (
    ("MEASURED", "Measured", "A measured metal: published complex index of refraction"),
    ("ARTIST", "Artist", "Reflectivity and edge tint colours (Gulbrandsen 2014), stored as eta/k"),
    ("CUSTOM", "Custom", "The complex index of refraction eta + i k itself"),
)
_METAL_ITEMS: list = []
_syncing = False


def metal_items(self=None, context=None):
    if not _METAL_ITEMS:
        _METAL_ITEMS.extend((key, m["label"], f"{m['label']}: {metals.citation(m)}")
                            for key, m in metals.measured().items())
    return _METAL_ITEMS


def _apply_metal(self, context):
    if self.mode == "MEASURED":
        m = metals.measured()[self.metal]
        _write_conductor(self, m["eta"], m["k"])


def _apply_artist(self, context):
    if self.mode == "ARTIST" and not _syncing:
        eta, k = metals.artistic_to_complex(self.reflectivity, self.edge_tint)
        _write_conductor(self, eta, k)


def _on_mode(self, context):
    """Entering a mode shows the current metal in its terms: the artist colours are derived from
    eta/k; the measured mode applies the picked metal."""
    global _syncing
    if self.mode == "ARTIST":
        r, g = metals.complex_to_artistic(self.eta, self.k)
        _syncing = True
        try:
            self.reflectivity, self.edge_tint = r, g
        finally:
            _syncing = False
        _apply_artist(self, context)
    elif self.mode == "MEASURED":
        _apply_metal(self, context)


def _write_conductor(pg, eta, k):
    pg.eta = tuple(eta)
    pg.k = tuple(k)


def properties() -> dict:
    """The mode and its inputs, beside the schema's fields on the conductor's PropertyGroup."""
    return {
        "mode": EnumProperty(name="Metal", description="How the metal's complex index is chosen",
                             items=METAL_MODES, default="CUSTOM", update=_on_mode),
        "metal": EnumProperty(name="Measured Metal", description="Published measurement to use",
                              items=metal_items(), update=_apply_metal),
        "reflectivity": FloatVectorProperty(name="Reflectivity", description="Colour at normal incidence",
                                            size=3, subtype="COLOR", min=0.0, max=1.0,
                                            default=(0.944, 0.776, 0.373), update=_apply_artist),
        "edge_tint": FloatVectorProperty(name="Edge Tint", description="Colour toward grazing angles",
                                         size=3, subtype="COLOR", min=0.0, max=1.0,
                                         default=(0.998, 0.981, 0.751), update=_apply_artist),
    }


def draw(layout, pg):
    """The mode switch and its inputs; eta and k are greyed out unless the mode is Custom."""
    layout.row().prop(pg, "mode", expand=True)
    col = layout.column()
    col.use_property_split = True
    col.use_property_decorate = False
    if pg.mode == "MEASURED":
        col.prop(pg, "metal")
        return {"roughness", "rotation"}
    if pg.mode == "ARTIST":
        col.prop(pg, "reflectivity")
        col.prop(pg, "edge_tint")
        return {"roughness", "rotation"}
    return None


def _measured_metal(eta, k) -> str | None:
    """The measured metal whose complex index ``eta``, ``k`` is (as float32 stores it), or None."""
    def same(a, b):
        return all(abs(x - y) <= 1e-6 * max(abs(y), 1.0) for x, y in zip(a, b))

    return next((key for key, m in metals.measured().items() if same(eta, m["eta"]) and same(k, m["k"])), None)


def written(pg) -> None:
    """A stack written into the panel holds eta and k as given: a measured metal's shows as that
    metal (the Measured mode, whose node shows its reflectivity and edge tint), any other in the
    Custom mode."""
    key = _measured_metal(pg.eta, pg.k)
    if key is None:
        pg.mode = "CUSTOM"
        return
    eta, k = tuple(pg.eta), tuple(pg.k)
    pg.metal = key
    pg.mode = "MEASURED"  # writes the measurement: the same numbers, put back exactly as given
    _write_conductor(pg, eta, k)


def _artist_colours(pg) -> tuple:
    """The reflectivity and edge tint the node shows: the artist mode's own, else the metal's
    (a measured metal's eta and k in Gulbrandsen 2014's terms)."""
    if pg.mode == "ARTIST":
        return tuple(pg.reflectivity), tuple(pg.edge_tint)
    r, g = metals.complex_to_artistic(pg.eta, pg.k)
    return tuple(float(x) for x in r), tuple(float(x) for x in g)


def face_inputs(pg, inputs: list, uid: str, label: str) -> list:
    """A measured metal and the artist mode show the reflectivity and edge tint on the Lamella
    node (the measured metal's in Gulbrandsen 2014's terms), made into eta and k inside it
    (``gulbrandsen_nodes``), so a texture on the colours drives the metal; unlinked, the metal's own
    eta and k render. The Custom mode shows eta and k themselves."""
    if pg.mode == "CUSTOM":
        return inputs
    out = []
    k_model = next(i.model for i in inputs if i.field == "k")
    reflectivity, edge_tint = _artist_colours(pg)
    for i in inputs:
        if i.field == "eta":
            keys = (f"{uid}/reflectivity", f"{uid}/edge_tint")
            derived = () if i.model is None else (
                ((i.model, k_model), keys, lambda nt, s: gulbrandsen_nodes(nt, *s)),)
            out.append(FaceInput(keys[0], f"{label}: Reflectivity", "NodeSocketColor", "NONE",
                                 reflectivity, 0.0, 1.0, None, derived, field="reflectivity",
                                 description="Colour of the metal at normal incidence (Gulbrandsen 2014), made "
                                             "into its complex index inside the node. Accepted: [0, 1]"))
            out.append(FaceInput(keys[1], f"{label}: Edge Tint", "NodeSocketColor", "NONE",
                                 edge_tint, 0.0, 1.0, None, field="edge_tint",
                                 description="Colour of the metal toward grazing angles (Gulbrandsen 2014). "
                                             "Accepted: [0, 1]"))
        elif i.field != "k":
            out.append(replace(i))
    return out


def face_value(pg, field: str, value) -> bool:
    """A reflectivity or edge tint typed on the node: the metal becomes the artist mode's with
    that colour (a measured metal is no longer the measurement). Returns whether it was one."""
    if field not in ("reflectivity", "edge_tint"):
        return False
    if pg.mode != "ARTIST":
        pg.mode = "ARTIST"  # the current metal in the artist's terms (``_on_mode``)
    setattr(pg, field, tuple(value[:3]))
    return True


def gulbrandsen_nodes(nt, r, g):
    """(eta, k) sockets from reflectivity ``r`` and edge tint ``g`` colour sockets, channel-wise:
    Gulbrandsen 2014, Section 3 (``metals.artistic_to_complex``, the same formulas in nodes)."""
    x = [1200.0, -900.0]

    def vm(op, a, b=None):
        n = nt.nodes.new("ShaderNodeVectorMath")
        n.operation, n.hide, n.location = op, True, tuple(x)
        x[1] -= 30.0
        for sock, v in zip(n.inputs, (a, b)):
            if v is None:
                continue
            if isinstance(v, (int, float)):
                sock.default_value = (v, v, v)
            else:
                nt.links.new(v, sock)
        return n.outputs[0]

    def sqrt(v):
        sep = nt.nodes.new("ShaderNodeSeparateXYZ")
        sep.hide, sep.location = True, tuple(x)
        nt.links.new(v, sep.inputs[0])
        comb = nt.nodes.new("ShaderNodeCombineXYZ")
        comb.hide, comb.location = True, (x[0] + 300.0, x[1])
        for k in range(3):
            m = nt.nodes.new("ShaderNodeMath")
            m.operation, m.hide, m.location = "SQRT", True, (x[0] + 150.0, x[1] - 30.0 * k)
            nt.links.new(sep.outputs[k], m.inputs[0])
            nt.links.new(m.outputs[0], comb.inputs[k])
        x[1] -= 100.0
        return comb.outputs[0]

    r = vm("MINIMUM", r, metals.R_MAX)
    sr = sqrt(r)
    one_minus_r = vm("SUBTRACT", 1.0, r)
    n = vm("ADD", vm("MULTIPLY", g, vm("DIVIDE", one_minus_r, vm("ADD", r, 1.0))),
           vm("MULTIPLY", vm("SUBTRACT", 1.0, g), vm("DIVIDE", vm("ADD", sr, 1.0), vm("SUBTRACT", 1.0, sr))))
    np1, nm1 = vm("ADD", n, 1.0), vm("SUBTRACT", n, 1.0)
    k2 = vm("DIVIDE", vm("SUBTRACT", vm("MULTIPLY", r, vm("MULTIPLY", np1, np1)), vm("MULTIPLY", nm1, nm1)),
            one_minus_r)
    k = sqrt(vm("MAXIMUM", k2, 0.0))
    return n, k


HOOKS = KindHooks("conductor", properties=properties, draw=draw, written=written, face_inputs=face_inputs,
                  face_value=face_value)
