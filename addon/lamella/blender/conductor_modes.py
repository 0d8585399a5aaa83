"""The conductor base's colour modes in Blender (its per-kind hooks, ``kind_hooks``): a measured
metal (published complex indices, ``lamella.core.metals``), artist colours (Gulbrandsen 2014's
reflectivity and edge tint, stored as eta/k) or eta + i k itself. The stack holds eta and k only;
the mode and its inputs are properties of the panel."""
from __future__ import annotations

from bpy.props import EnumProperty, FloatVectorProperty

from ..core import metals

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


def written(pg) -> None:
    """A stack written into the panel holds eta and k as given: the Custom mode shows them."""
    pg.mode = "CUSTOM"
