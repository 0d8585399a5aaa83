"""Textures linked into a large stack, rendered by Cycles without OSL (SVM, what a GPU runs).

Traced whole, what the linked inputs of four coats with a medium reach overflows SVM's stack and
the material renders black. The node group then reads that part from tables over (view, linked
parameters) (``live_axes``): it renders, and follows the textures as the OSL shader (which traces
the linked part exactly) does. Measured in `sphere-sun` with one ray per pixel and real textures
(a gradient across the sphere on two coat roughnesses, a checker on the base colour) linked into
the Script node and the group alike: relative L1 0.43 % against OSL (the tables' interpolation;
bench/linked_tables.md), and nothing of Cycles' "out of SVM stack space"."""
import functools

import numpy as np
import pytest

pytest.importorskip("bpy")
from lamella_dev.bench.node_cost import _render, textured_sockets  # noqa: E402
from lamella_dev.bench.recompile import _stack  # noqa: E402
from lamella_dev.render import assign_material, build_scene  # noqa: E402
from lamella.core.backends.ir.live_axes import MAX_AXES  # noqa: E402
from lamella.core.backends.nodes.lower import emit_plan  # noqa: E402

from .test_osl_exactness import SUN  # noqa: E402

# the OSL render both tests compare with (a shader of about a megabyte to compile) is made once
pytestmark = pytest.mark.xdist_group("linked_tables")


def _link_textures(mat, sockets):
    """Textures into ``sockets`` of whichever Lamella node the material has (Script node or group)."""
    node = next(n for n in mat.node_tree.nodes if n.bl_idname in ("ShaderNodeScript", "ShaderNodeGroup"))
    _link_textures_into(mat, sockets, [node])


def _link_textures_into(mat, sockets, nodes):
    """A gradient across the sphere into the roughness sockets (r from 0.15 to 0.7) and a checker
    into the colour socket of each of ``nodes``."""
    nt = mat.node_tree
    coords = nt.nodes.new("ShaderNodeTexCoord")
    grad = nt.nodes.new("ShaderNodeTexGradient")
    nt.links.new(coords.outputs["Object"], grad.inputs["Vector"])
    span = nt.nodes.new("ShaderNodeMapRange")
    span.inputs["To Min"].default_value, span.inputs["To Max"].default_value = 0.15, 0.7
    nt.links.new(grad.outputs["Fac"], span.inputs["Value"])
    checker = nt.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = 3.0
    checker.inputs["Color1"].default_value = (0.2, 0.5, 1.3, 1.0)
    checker.inputs["Color2"].default_value = (1.1, 0.9, 0.3, 1.0)
    nt.links.new(coords.outputs["Object"], checker.inputs["Vector"])
    for node in nodes:
        for name in sockets:
            src = checker.outputs["Color"] if node.inputs[name].type in ("RGBA", "VECTOR") else span.outputs["Result"]
            nt.links.new(src, node.inputs[name])


def _render_linked(stack, live, engine, live_axes="auto"):
    sc, sphere = build_scene("sphere-sun", 48, 1, SUN)
    sc.cycles.filter_width = 0.01
    _link_textures(assign_material(sphere, stack, engine, live=live, live_axes=live_axes), live)
    px, _, errors = _render(sc)
    return px[..., :3], errors


@functools.cache
def _osl_render():
    """Four coats with a medium, every textured input linked: the OSL shader (the linked part
    traced exactly) rendered, with Cycles' errors."""
    stack = _stack("4 coats + medium", None)
    return _render_linked(stack, textured_sockets(stack), "cycles-osl")


def test_a_textured_stack_too_large_for_svm_renders_from_its_tables_like_osl():
    stack = _stack("4 coats + medium", None)
    live = textured_sockets(stack)
    assert emit_plan(stack, live=live).staged.live_axes == MAX_AXES
    a, errors = _osl_render()
    assert not errors, errors
    b, errors = _render_linked(stack, live, "cycles-nodes")
    assert not errors, errors
    assert np.isfinite(b).all() and (b >= 0).all()
    l1 = np.abs(b - a).sum() / a.sum()
    print("relative L1", l1, "means", a.mean(), b.mean())
    assert a.mean() > 0.01 and l1 < 0.01


@pytest.mark.slow
def test_the_same_group_with_the_linked_part_traced_overflows_svm():
    """The control (in `make test-long`: a second SVM graph of that size to build and render): the
    same group with the linked part traced overflows SVM and renders dark (a renderer fact: a
    Cycles with a larger stack would let the tables wait for bigger stacks)."""
    stack = _stack("4 coats + medium", None)
    a, _ = _osl_render()
    traced, errors = _render_linked(stack, textured_sockets(stack), "cycles-nodes", live_axes=0)
    assert "out of SVM stack space" in errors and traced.mean() < 0.5 * a.mean()


def test_the_extension_falls_back_to_tables_and_says_so(addon):
    """Through the add-on as an artist works: the stack applied, textures linked into the Lamella
    node, the material recompiled (a link is a structure edit). With OSL off the node group
    renders like the OSL shader that traces the linked part exactly, and the panel's data names the
    tables."""
    from lamella.blender import api, material_nodes, recompile

    from .addon_helpers import new_material, render, sphere_scene

    stack = _stack("4 coats + medium", None)
    live = textured_sockets(stack)
    osl, _ = _osl_render()
    sc, sphere = sphere_scene(res=48, spp=1, scene="sphere-sun")
    sc.cycles.filter_width = 0.01
    mat = new_material(sphere)
    api.apply_stack(mat, stack)

    class Face:  # the Lamella node's inputs by the model sockets they feed
        inputs = {name: material_nodes.input_for_model(mat, name) for name in live}

    _link_textures_into(mat, live, [Face])
    recompile.compile_material(mat)
    assert mat.lamella.live_params == ", ".join(sorted(live))
    sc.cycles.shading_system = False
    nodes = render(sc)[..., :3]
    assert "coat0_roughness 0 to 1" in mat.lamella.node_tables and "base_eta" in mat.lamella.node_tables
    l1 = np.abs(nodes - osl).sum() / osl.sum()
    print("relative L1", l1)
    assert osl.mean() > 0.01 and l1 < 0.01
    sc.cycles.shading_system = True
