"""A slider dragged keeps the lobes' grouping into closures; once edits pause, and before every
render and save, the material is compiled again with its lobes merged anew, so what renders and
what is saved never depends on the drag (``recompile`` module docstring)."""
import numpy as np
import pytest

from lamella.core import Stack
from lamella_dev import suite

pytest.importorskip("bpy")
from lamella.blender import api, material_nodes, recompile  # noqa: E402
from lamella.core.backends.ir import staging  # noqa: E402

from .addon_helpers import new_material, render, sphere_scene  # noqa: E402


def _source(mat) -> str:
    return material_nodes.shader_source(mat)


def _stack(r: float) -> Stack:
    """green_scatter_d6 with its top coat's roughness r (the panel's: alpha = r^2, exact in
    float32 for these r): the automatic budget groups its lobes [[0], [1, 5, 2, 3, 4], [6, 7]] up to
    r = 0.125 and [[0, 3], [1, 5, 2, 4], [6, 7]] from r = 0.1875 to 0.625."""
    d = suite.load("green_scatter_d6").to_dict()
    d["layers"][0]["roughness"] = r * r
    return Stack.from_dict(d)


def _fresh_source(r: float) -> str:
    from lamella.core import luts
    from lamella.core.backends.osl.emit import osl_shader

    return osl_shader(_stack(r), lut_dir=str(luts.DATA_DIR), engine_switch=True).source


def test_a_drag_keeps_the_grouping_and_settles_to_the_automatic_budget(addon):
    sc, sphere = sphere_scene(res=16, spp=1)
    mat = new_material(sphere, "drag")
    api.apply_stack(mat, _stack(0.125))
    before = staging.stage(_stack(0.125)).merged
    after = staging.stage(_stack(0.5)).merged
    assert before != after  # the test needs an edit that regroups
    # dragged: each edit compiled by the edit timer's flush; the first merges anew (no compile of
    # the drag before it) and keeps 0.125's grouping, the later ones keep it
    for r in (0.0625, 0.25, 0.375, 0.5):
        mat.lamella.coats[0].coat.roughness = r
        recompile.flush(defer_inspector=True, drag=True)
    assert mat.name_full in recompile._unsettled
    assert _source(mat) != _fresh_source(0.5)  # the drag's grouping
    assert staging.stage(_stack(0.5), partition=before).merged == before
    recompile.settle()
    assert mat.name_full not in recompile._unsettled
    assert _source(mat) == _fresh_source(0.5) and mat.lamella.closures == len(after)

    # a render settles first: the image is the one of the material compiled from scratch
    mat.lamella.coats[0].coat.roughness = 0.125
    recompile.flush(defer_inspector=True, drag=True)
    assert mat.name_full in recompile._unsettled
    dragged = render(sc)
    assert mat.name_full not in recompile._unsettled and _source(mat) == _fresh_source(0.125)
    assert np.array_equal(dragged, render(sc))


def test_edits_apart_are_not_a_drag(addon):
    """An edit later than ``DRAG_WINDOW`` after the last compile, or one without ``drag`` (a
    render's or a script's flush), merges anew."""
    sc, sphere = sphere_scene(res=16, spp=1)
    mat = new_material(sphere, "apart")
    api.apply_stack(mat, _stack(0.125))
    mat.lamella.coats[0].coat.roughness = 0.5
    recompile.flush()
    assert mat.name_full not in recompile._unsettled and _source(mat) == _fresh_source(0.5)
    recompile._last_compile[mat.name_full] = (0.0, recompile._last_compile[mat.name_full][1])  # long ago
    mat.lamella.coats[0].coat.roughness = 0.125
    recompile.flush(defer_inspector=True, drag=True)
    assert mat.name_full not in recompile._unsettled and _source(mat) == _fresh_source(0.125)
