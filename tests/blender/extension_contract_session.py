"""Run in a fresh process by test_extension_contract: the extension kinds of
``tests/unit/extension_kinds`` register before the extension does (as an extension's own
``register`` would run first), then a material of the new kinds is made, drawn, rendered in Cycles
with OSL, Cycles without OSL and EEVEE beside the same stack in built-in kinds, saved and opened
again. Prints one JSON line of findings (the test asserts on them).

Usage: python extension_contract_session.py OUT_DIR"""
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent / "unit"), str(HERE.parent)]

import numpy as np  # noqa: E402

import extension_kinds  # noqa: E402

extension_kinds.register()

import bpy  # noqa: E402

from blender import addon_helpers  # noqa: E402
from unit.test_extension_contract import DIFFUSER, PAIRS  # noqa: E402

out = Path(sys.argv[1])
addon_helpers.register()
from lamella.blender import api, ui  # noqa: E402
from lamella.blender.kind_hooks import layer_icon  # noqa: E402
from lamella.core.layers import BASE_KINDS, COAT_KINDS  # noqa: E402
from lamella.core.stack import Stack  # noqa: E402

found = {}
new, built_in = PAIRS["lacquer over artist metal"]
other = json.loads(json.dumps(new))
other["layers"][0]["color"] = [0.5, 0.9, 0.9]  # a control: another colour must render otherwise

# the properties: one group per kind, the kind menus list the new kinds
from lamella.blender import properties  # noqa: E402

found["coat kinds"] = [i.identifier for i in properties.LAMELLA_PG_layer.bl_rna.properties["kind"].enum_items]
found["base kinds"] = [i.identifier for i in properties.LAMELLA_PG_base.bl_rna.properties["kind"].enum_items]
found["models"] = [i.identifier for i in properties.LAMELLA_PG_material.bl_rna.properties["model"].enum_items]

sc, sphere = addon_helpers.sphere_scene(res=48, spp=16)
mats = {}
for key, stack, model in (("new", new, None), ("built_in", built_in, None), ("other", other, None),
                          ("diffuser", DIFFUSER, "split_diffuse"), ("diffuser_yamaguchi", DIFFUSER, "yamaguchi2019")):
    mats[key] = bpy.data.materials.new(key)
    mats[key].use_fake_user = True  # kept in the saved file though no object shows it
    api.apply_stack(mats[key], stack, model)
m = mats["new"]
found["status"] = m.lamella.status
found["read back"] = api.read_stack(m) == Stack.from_dict(new).to_dict()
found["stored kinds"] = [m.lamella.coats[0].kind, m.lamella.base.kind]


class _Context:
    scene = sc


layout = addon_helpers.RecordingLayout()
ui.draw_material(layout, _Context(), m)
found["drawn"] = sorted({name for data, name in layout.props if name in {"color", "reflectivity", "edge_tint"}})
found["drawn resolve"] = all(name in data.bl_rna.properties for data, name in layout.props)
found["icons"] = [layer_icon(COAT_KINDS["tinted_lacquer"], m.lamella.coats[0].settings()),
                  layer_icon(BASE_KINDS["artist_metal"], m.lamella.base.settings())]
# an edit in the panel recompiles through the kind's own properties
m.lamella.coats[0].settings().color = (0.5, 0.9, 0.9)
from lamella.blender import recompile  # noqa: E402

recompile.flush()
found["edited"] = [json.loads(m.lamella.compiled_json)["layers"][0]["color"], m.lamella.status]
api.apply_stack(m, new)


def render(key, engine):
    sphere.data.materials.clear()
    sphere.data.materials.append(mats[key])
    sc.render.engine = "CYCLES"
    sc.cycles.shading_system = engine == "cycles-osl"
    if engine == "eevee":
        from lamella_dev.render import use_eevee

        use_eevee(sc)
    return addon_helpers.render(sc)[..., :3].astype(np.float64)


images = {}
for engine in ("cycles-osl", "cycles-nodes", "eevee"):
    for key in ("new", "built_in", "other"):
        images[engine, key] = render(key, engine)
    a, b, c = images[engine, "new"], images[engine, "built_in"], images[engine, "other"]
    found[engine] = {"finite": bool(np.isfinite(a).all()), "mean": float(a.mean()),
                     "diff_built_in": float(np.abs(a - b).mean()), "p99_built_in": float(np.percentile(np.abs(a - b), 99)),
                     "diff_other_colour": float(np.abs(a - c).mean())}
for engine in ("cycles-osl", "cycles-nodes"):
    d, y = render("diffuser", engine), render("diffuser_yamaguchi", engine)
    found[engine]["diffuser"] = {"finite": bool(np.isfinite(d).all()), "mean": float(d.mean()),
                                 "mean_yamaguchi": float(y.mean())}
found["diffuser osl vs nodes"] = float(np.abs(render("diffuser", "cycles-osl") - render("diffuser", "cycles-nodes")).mean())

# saved and opened again: the new kinds' data is in the file
path = out / "extension_kinds.blend"
bpy.ops.wm.save_as_mainfile(filepath=str(path))
bpy.ops.wm.open_mainfile(filepath=str(path))
m2 = bpy.data.materials["new"]
found["reopened"] = api.read_stack(m2)
found["expected"] = Stack.from_dict(new).to_dict()
print("FINDINGS " + json.dumps(found))
from lamella.blender import exit_process  # noqa: E402

exit_process(0)
