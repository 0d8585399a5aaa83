"""What fills EEVEE's 64 KiB uniform block: a chain of Math ADD nodes in nested groups of 100,
rendered once in EEVEE; prints the block size EEVEE reports when it overflows, else "compiles".

    .venv/bin/python tools/eevee_uniform_block.py literal:100 linked:200 group:100 hidden:200

Modes (N groups of 100 nodes, x_{k+1} = x_k + y):
- ``literal``: y a literal in the node's second input (shown), third input unused (shown);
- ``linked``: y linked (the chain value itself), third input unused (shown);
- ``group``: y a group input fed by one Value node per group;
- ``hidden``: as ``linked`` with the unused input's value hidden (what the node group does).
Measured in Blender 5.0.1 (docs/node_groups.md): 10 000 nodes need 80 032 bytes as ``literal``
and as ``group`` (8 bytes a node), 20 000 need 80 032 as ``linked`` (4 bytes a node: the unused
input), 20 000 ``hidden`` compile. (20 000 ``literal`` nodes crash EEVEE's compiler here.)
"""
from __future__ import annotations

import os
import re
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "addon"))
os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="lamella-ubo-"))

import bpy  # noqa: E402

from lamella.blender.osl_compile import capture_stderr  # noqa: E402
from lamella_dev.render import build_scene, node_tree, render_scene, use_eevee  # noqa: E402

SIZE = 100
OVERFLOW = re.compile(r"Uniform block \w+ too big \((\d+)/\d+\)")


def _chunk(mode: str, idx: int):
    t = bpy.data.node_groups.new(f"chain{idx}", "ShaderNodeTree")
    t.interface.new_socket(name="x", in_out="INPUT", socket_type="NodeSocketFloat")
    if mode == "group":
        t.interface.new_socket(name="y", in_out="INPUT", socket_type="NodeSocketFloat")
    t.interface.new_socket(name="out", in_out="OUTPUT", socket_type="NodeSocketFloat")
    gin, gout = t.nodes.new("NodeGroupInput"), t.nodes.new("NodeGroupOutput")
    prev = gin.outputs[0]
    for j in range(SIZE):
        m = t.nodes.new("ShaderNodeMath")
        m.operation = "ADD"
        t.links.new(prev, m.inputs[0])
        if mode == "literal":
            m.inputs[1].default_value = 1e-4 * (idx * SIZE + j)
        elif mode == "group":
            t.links.new(gin.outputs[1], m.inputs[1])
        else:
            t.links.new(prev, m.inputs[1])
        if mode == "hidden":
            m.inputs[2].hide_value = True
        prev = m.outputs[0]
    t.links.new(prev, gout.inputs[0])
    return t


def probe(mode: str, groups: int) -> str:
    sc, sphere = build_scene("sphere-env", 16, 1)
    use_eevee(sc)
    mat = bpy.data.materials.new("chain")
    sphere.data.materials.append(mat)
    nt = node_tree(mat)
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    sep = nt.nodes.new("ShaderNodeSeparateXYZ")
    nt.links.new(nt.nodes.new("ShaderNodeNewGeometry").outputs["Incoming"], sep.inputs[0])
    prev = sep.outputs[0]
    for c in range(groups):
        g = nt.nodes.new("ShaderNodeGroup")
        g.node_tree = _chunk(mode, c)
        nt.links.new(prev, g.inputs[0])
        if mode == "group":
            v = nt.nodes.new("ShaderNodeValue")
            v.outputs[0].default_value = 1e-3 * c
            nt.links.new(v.outputs[0], g.inputs[1])
        prev = g.outputs[0]
    diffuse = nt.nodes.new("ShaderNodeBsdfDiffuse")
    color = nt.nodes.new("ShaderNodeCombineColor")
    nt.links.new(prev, color.inputs[0])
    nt.links.new(color.outputs[0], diffuse.inputs["Color"])
    nt.links.new(diffuse.outputs[0], out.inputs["Surface"])
    _, err = capture_stderr(lambda: render_scene(sc), fds=(1, 2))
    m = OVERFLOW.search(err)
    return f"uniform block {m.group(1)} bytes (overflow)" if m else "compiles"


if __name__ == "__main__":
    for spec in sys.argv[1:] or ["literal:100", "linked:200", "group:100", "hidden:200"]:
        mode, n = spec.split(":")
        print(f"{mode} {int(n) * SIZE} nodes: {probe(mode, int(n))}", flush=True)
