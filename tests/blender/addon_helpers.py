"""Shared pieces of the extension's tests: registering it, a material on the canonical sphere,
and a stand-in for Blender's UI layout (panel ``draw`` never runs headless)."""
from __future__ import annotations

import math

import numpy as np


def register():
    import lamella.blender

    lamella.blender.register()


def unregister():
    import lamella.blender

    lamella.blender.unregister()


def sphere_scene(res=48, spp=8, scene="sphere-env"):
    """The canonical scene (docs/design.md) with no material yet: (scene, sphere)."""
    from lamella_dev.render import build_scene

    return build_scene(scene, res, spp)


def engine_scene(engine: str, res=48, spp=8):
    """``sphere_scene`` rendered by ``engine``: "osl" (Cycles with OSL), "svm" (Cycles without OSL)
    or "eevee"."""
    from lamella_dev.render import use_eevee

    sc, sphere = sphere_scene(res, spp)
    if engine == "svm":
        sc.cycles.shading_system = False
    elif engine == "eevee":
        use_eevee(sc)
    return sc, sphere


def sphere_grid(sc, sphere, count: int) -> list:
    """``count`` spheres in a square grid filling the canonical scene's view (its orthographic
    camera sees x and z in [-1.1, 1.1]), ``sphere`` the first, the others copies with their own
    mesh (so each holds its own material): [(object, (row, column) of its centre's pixel, top row
    first, radius in pixels)]. One render of many materials costs little more than one of a single
    material (the render's set-up is most of a small render's time)."""
    n = max(1, math.ceil(math.sqrt(count)))
    res = sc.render.resolution_x
    cell = 2.2 / n
    out = []
    for k in range(count):
        ob = sphere
        if k:
            ob = sphere.copy()
            ob.data = sphere.data.copy()
            sc.collection.objects.link(ob)
        i, j = k % n, k // n
        x, z = -1.1 + (i + 0.5) * cell, 1.1 - (j + 0.5) * cell
        ob.location = (x, 0.0, z)
        ob.scale = (0.45 * cell,) * 3
        out.append((ob, ((1.1 - z) / 2.2 * res, (x + 1.1) / 2.2 * res), 0.45 * cell / 2.2 * res))
    return out


def grid_pixels(px: np.ndarray, centre, radius: float, part: float = 0.5) -> np.ndarray:
    """The RGBA pixels of ``px`` (top row first) within ``part`` of ``radius`` of ``centre`` (a
    ``sphere_grid`` entry's): by default well inside that sphere's disc."""
    rows, cols = np.mgrid[0:px.shape[0], 0:px.shape[1]]
    near = (rows + 0.5 - centre[0]) ** 2 + (cols + 0.5 - centre[1]) ** 2 <= (part * radius) ** 2
    return px[near]


def render(sc) -> np.ndarray:
    from lamella_dev.render import render_scene

    return render_scene(sc)[0]


def new_material(sphere, name="lamella_test"):
    import bpy

    mat = bpy.data.materials.new(name)
    sphere.data.materials.clear()
    sphere.data.materials.append(mat)
    return mat


class RecordingLayout:
    """Stands in for ``bpy.types.UILayout``: records every property (data, name), operator id,
    menu id and list template a draw function asks for, and hands out sub-layouts that record into
    the same lists. Sub-panels are drawn open, so every branch of a panel is visited."""

    def __init__(self, root=None):
        self.root = root or self
        if root is None:
            self.props, self.operators, self.menus, self.lists, self.labels = [], [], [], [], []
            self._operator_calls = []
        self.use_property_split = False
        self.use_property_decorate = True
        self.enabled = True
        self.active = True
        self.alert = False

    # containers
    def _sub(self, *args, **kwargs):
        return RecordingLayout(self.root)

    row = column = box = split = grid_flow = column_flow = _sub

    def panel(self, idname, default_closed=False):
        return RecordingLayout(self.root), RecordingLayout(self.root)

    # content
    def prop(self, data, prop, **kwargs):
        self.root.props.append((data, prop))

    def prop_enum(self, data, prop, value, **kwargs):
        self.root.props.append((data, prop))

    def label(self, text="", **kwargs):
        self.root.labels.append(text)

    def separator(self, **kwargs):
        pass

    def operator(self, idname, **kwargs):
        self.root.operators.append(idname)
        props = _OperatorProperties()
        self.root._operator_calls.append((idname, props, self.enabled))
        return props

    @property
    def enabled_operators(self) -> list:
        """(operator id, its ``direction`` property or None, whether its layout was enabled)."""
        return [(idname, getattr(props, "direction", None), on) for idname, props, on in self.root._operator_calls]

    def operator_menu_enum(self, idname, prop, **kwargs):
        self.root.operators.append(idname)

    def menu(self, idname, **kwargs):
        self.root.menus.append(idname)

    def template_list(self, listtype, list_id, dataptr, propname, active_dataptr, active_propname, **kwargs):
        self.root.lists.append(listtype)
        self.root.props.append((dataptr, propname))
        self.root.props.append((active_dataptr, active_propname))

    def template_icon(self, icon_value=0, scale=1.0):
        pass


class _OperatorProperties:
    """What ``layout.operator`` returns: attribute assignments are accepted."""

    def __setattr__(self, name, value):
        object.__setattr__(self, name, value)
