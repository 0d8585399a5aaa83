"""`lamella bench live-osl`: what a textured material costs per render in Cycles with OSL.

A material whose inputs are linked (a texture, a keyframe, a driver) keeps part of the model live.
In Cycles with OSL it can render either its Script node (the staged shader, the live part traced
exactly, the model's look-up tables it reads carried as constant arrays in its source) or its node
group, which Cycles then compiles as OSL, node by node. For each stack the extension compiles the
material (a Value node linked into the inputs named, standing for a texture), then renders in one
Blender session, in order: Cycles with OSL (the Script node, as the extension leaves the material),
the same with the Script node removed (the node group compiled by OSL: what a textured material
rendered before its shader carried its tables), Cycles without OSL (the node group in SVM), and a
Principled BSDF with the same kind of link under OSL and SVM as the control for what OSL itself
costs. Each render in Cycles (background) compiles its shaders again, so every render pays the
compile: times are medians of ``REPEATS`` renders, compared as ratios within the run.
"""
from __future__ import annotations

import re
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from .. import suite
from .page import write_page
from .paths import BENCH_DIR
from .registry import Bench, register

RES = 32
SPP = 16
REPEATS = 3
LUT_ARRAY = re.compile(r"float LUT_\w+\[(\d+)\]")  # a look-up table the shader carries (``emit.array_name``)
# (label, suite case, the inputs of coat 0 a Value node is linked into, their values)
STACKS = (
    ("1 coat, roughness linked", "gold_coated", (("roughness", 0.3),)),
    ("1 coat, roughness and IOR linked", "gold_coated", (("roughness", 0.3), ("ior", 1.45))),
    ("scattering coat, roughness linked", "milky_coat_d2", (("roughness", 0.3),)),
)


def _timed(sc, osl: bool) -> tuple[float, np.ndarray]:
    from ..render import render_scene

    sc.cycles.shading_system = osl
    times, px = [], None
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        px, _ = render_scene(sc)
        times.append(time.perf_counter() - t0)
    return statistics.median(times), px[..., :3].astype(np.float64)


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).mean() / max(b.mean(), 1e-12))


def _linked(mat, sockets) -> None:
    nt = mat.node_tree
    for sock, value in sockets:
        v = nt.nodes.new("ShaderNodeValue")
        v.outputs[0].default_value = value
        nt.links.new(v.outputs[0], sock)


def run(out_dir: Path = BENCH_DIR) -> Path:
    import bpy

    from lamella.blender import api, material_nodes, osl_compile, recompile, register
    from ..render import build_scene, sphere_material

    register()
    osl_compile.set_cache_root(Path(tempfile.mkdtemp(prefix="lamella-bench-")))
    rows = []
    for label, case, inputs in STACKS:
        sc, sphere = build_scene("sphere-env", RES, SPP)
        mat = sphere_material(sphere, label)[0]
        api.apply_stack(mat, suite.load(case).to_dict())
        _linked(mat, [(api.input_socket(mat, 0, name), value) for name, value in inputs])
        recompile.compile_material(mat)
        recompile.flush_groups()
        source = material_nodes.shader_source(mat)
        script_s, script_px = _timed(sc, True)
        svm_s, svm_px = _timed(sc, False)
        node, script, group = material_nodes.inner_nodes(mat)
        bytecode = len(script.bytecode.encode())
        blend_mb = _saved_mb()
        node.node_tree.nodes.remove(script)  # the node group alone, compiled by OSL
        group_s, group_px = _timed(sc, True)
        blend_mb_group = _saved_mb()
        nodes = sum(1 for _ in _group_nodes(group.node_tree))

        p_mat, nt, out = sphere_material(sphere, f"{label} principled")
        p = nt.nodes.new("ShaderNodeBsdfPrincipled")
        p.inputs["Coat Weight"].default_value = 1.0
        p.inputs["Metallic"].default_value = 1.0
        _linked(p_mat, [(p.inputs["Coat Roughness"], 0.3)])
        nt.links.new(p.outputs[0], out.inputs["Surface"])
        p_osl, _ = _timed(sc, True)
        p_svm, _ = _timed(sc, False)
        rows.append({"stack": label, "case": case, "live": mat.lamella.live_params,
                     "shader_lines": len(source.splitlines()), "shader_kB": len(source.encode()) / 1024,
                     "bytecode_kB": bytecode / 1024, "blend_MB": blend_mb, "blend_MB_group": blend_mb_group,
                     "table_values": sum(int(n) for n in LUT_ARRAY.findall(source)),
                     "group_nodes": nodes, "script_osl_s": script_s, "group_osl_s": group_s, "group_svm_s": svm_s,
                     "principled_osl_s": p_osl, "principled_svm_s": p_svm,
                     "script_vs_group_osl": _rel(script_px, group_px), "script_vs_svm": _rel(script_px, svm_px)})
        for m in (mat, p_mat):
            bpy.data.materials.remove(m)
    data = {"res": RES, "spp": SPP, "repeats": REPEATS, "rows": rows}
    return write_page(out_dir, "live_osl", lambda: _markdown(data), data)


def _saved_mb() -> float:
    """The size of the session saved as an uncompressed .blend (MB): what the material adds to a file."""
    import bpy

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "live.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=False, copy=True)
        return path.stat().st_size / 1e6


def _group_nodes(tree):
    """Every node of ``tree`` and of the groups inside it (what Cycles compiles)."""
    for n in tree.nodes:
        yield n
        if n.bl_idname == "ShaderNodeGroup" and n.node_tree is not None:
            yield from _group_nodes(n.node_tree)


def _markdown(data) -> str:
    md = [
        "# Textured materials in Cycles with OSL",
        "",
        f"`lamella bench live-osl` (this machine, one Blender session, sphere-env at {data['res']} px, "
        f"{data['spp']} spp, median of {data['repeats']} renders each; every Cycles render compiles its shaders "
        "again, so a render's time is mostly its compile at this size). A Value node linked into coat 0's "
        "inputs stands for a texture. *Script node*: Cycles with OSL rendering the material as the extension "
        "compiles it (the live part traced, the look-up tables it reads as constant arrays in the shader's "
        "source). *Group, OSL*: the same material with its Script node removed, so Cycles with OSL compiles "
        "the node group (what a textured material rendered when its shader would have read table files). "
        "*Group, SVM*: Cycles without OSL. *Principled*: a coated metal Principled BSDF with a Value node in "
        "its coat roughness, the control for what OSL itself costs. *Script vs group*: mean relative "
        "difference of the two OSL renders (the node group reads tables over the linked values, the shader "
        "traces them: `bench/linked_tables.md`). *.blend MB*: the session saved uncompressed, with the "
        "Script node / without it (one material of this stack in the file; the node group's packed tables are "
        "in both).",
        "",
        "| stack | live | shader lines | shader kB | bytecode kB | table values in it | .blend MB, with / without the shader | group nodes | Script node, OSL (s) | "
        "group, OSL (s) | group, SVM (s) | Principled OSL / SVM (s) | group OSL / Script | Script / Principled OSL | "
        "Script vs group (OSL) | Script vs SVM |",
        "|---|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---|---:|---:|---:|---:|",
    ]
    for r in data["rows"]:
        md.append(f"| {r['stack']} | {r['live']} | {r['shader_lines']} | {r['shader_kB']:.0f} | {r['bytecode_kB']:.0f} | "
                  f"{r['table_values']} | {r['blend_MB']:.1f} / {r['blend_MB_group']:.1f} | "
                  f"{r['group_nodes']} | {r['script_osl_s']:.2f} | {r['group_osl_s']:.2f} | {r['group_svm_s']:.2f} | "
                  f"{r['principled_osl_s']:.2f} / {r['principled_svm_s']:.2f} | "
                  f"{r['group_osl_s'] / r['script_osl_s']:.1f}x | {r['script_osl_s'] / r['principled_osl_s']:.2f}x | "
                  f"{r['script_vs_group_osl']:.4f} | {r['script_vs_svm']:.4f} |")
    return "\n".join(md)


BENCH = register(Bench("live-osl", "what a textured material costs per render in Cycles with OSL: its Script "
                       "node against its node group compiled by OSL", lambda out_dir, args: run(out_dir)))
