"""A textured input renders alike in every engine: the oil film on wet stone preset (its film
thickness swirling, 150-650 nm) in Cycles without OSL as with OSL. The node group reads that
thickness from a table over it (the film's traced part is too large for SVM: 10,308 nodes, 426 live
values); with 17 nodes in the square-root warp over 0-1500 nm the table interpolated across the film's
interference cycles and Cycles without OSL was 7.3 % off the OSL shader here (the issue measured 9.3 %
on a real mesh). The film's axis now has a node every 10 nm (``Field.axis_step``).

The control: the same preset with its film untextured (the panel's 350 nm), whose node group traces
the film as the OSL shader does."""
import functools

import numpy as np
import pytest

pytest.importorskip("bpy")
from lamella_dev.render import build_scene, render_scene, use_eevee  # noqa: E402

pytestmark = pytest.mark.xdist_group("textured_inputs")

RES, SPP = 64, 32


@functools.lru_cache(maxsize=None)  # the OSL renders serve both engines' comparisons
def _render(textured: bool, engine: str):
    import bpy
    from lamella.blender import api

    sc, sphere = build_scene("sphere-env", RES, SPP)
    mat = bpy.data.materials.new("oil film")
    sphere.data.materials.append(mat)
    api.apply_preset(mat, "oil_film_on_wet_stone")
    if not textured:  # the recipe's nodes unlinked from the node: the panel's thickness renders
        from lamella.blender.material_nodes import face_node

        node = face_node(mat)
        for sock in node.inputs:
            for link in list(sock.links):
                if sock.name.endswith("Film Thickness"):
                    mat.node_tree.links.remove(link)
    sc.cycles.shading_system = engine == "osl"
    if engine == "eevee":
        use_eevee(sc)
    px = render_scene(sc)[0]
    assert np.isfinite(px).all() and (px >= 0).all()
    return px


def _disc():
    c = (np.arange(RES) + 0.5) / RES * 2.2 - 1.1
    xx, zz = np.meshgrid(c, -c)
    return xx ** 2 + zz ** 2 < 0.95 ** 2


def _rel(a, b) -> float:
    d = _disc()
    return float(np.abs(a[d, :3] - b[d, :3]).mean() / b[d, :3].mean())


@pytest.mark.parametrize("engine", ["svm", "eevee"])
def test_a_textured_film_renders_in_every_engine_as_with_osl(addon, engine):
    """The texture adds at most 1 % to what the engine differs from the OSL shader by on the
    untextured preset. Measured: Cycles without OSL 0.0016 off the OSL shader (untextured 0.0008;
    0.073 with the earlier axis), EEVEE 0.192 (untextured 0.189, its own lighting; 0.211 before)."""
    floor = _rel(_render(False, engine), _render(False, "osl"))  # the untextured preset
    got = _rel(_render(True, engine), _render(True, "osl"))
    assert got <= floor + 0.01, (got, floor)
