"""`lamella bench nodes`: what the node group costs, per stack class (1, 4 coats, 4 coats + a
medium, 8 coats + media): its size (plan nodes, nested groups), the time to build it (from
nothing, and again when every nested group already exists, as after a value edit elsewhere), and
render times at equal samples in the same session: Cycles running the node group (SVM, what a GPU
runs) against the OSL shader, and EEVEE against a Principled BSDF with coat. EEVEE's first render
of a material includes compiling its shader (Mesa's on-disk shader cache off); the second is the
frame time. Renderer errors (out of SVM stack, uniform block too big) are captured from stderr and
reported."""
from __future__ import annotations

import re
import time
from pathlib import Path

from .paths import BENCH_DIR
from .page import write_page
from .recompile import STACKS, _stack
from .registry import Bench, register

RES, SPP = 64, 16
_ERRORS = re.compile(r"(out of SVM stack space|Uniform block \w+ too big \(\d+/\d+\))")


def _render(sc):
    from lamella.blender.osl_compile import capture_stderr
    from ..render import render_scene

    (px, seconds), err = capture_stderr(lambda: render_scene(sc), fds=(1, 2))
    return px, seconds, sorted(set(m.group(1) for m in _ERRORS.finditer(err)))


def _scene_with(stack, engine):
    from ..render import assign_material, build_scene

    sc, sphere = build_scene("sphere-env", RES, SPP)
    assign_material(sphere, stack, engine)
    return sc


def measure() -> list[dict]:
    import os

    # Mesa (EEVEE's OpenGL here) keeps compiled shaders on disk: without this a stack measured
    # before would show no compile time in its first EEVEE render
    os.environ["MESA_SHADER_CACHE_DISABLE"] = "true"
    import bpy

    from lamella.core.backends.nodes.lower import emit_plan
    from lamella.core.backends.nodes.partition import partition
    from lamella.blender.node_group import build_group

    rows = []
    for label, case in STACKS:
        stack = _stack(label, case)
        row = {"stack": label, "coats": len(stack.coats)}
        plan = emit_plan(stack)
        sections = partition(plan)
        row.update(nodes=len(plan.nodes), chunks=sum(len(s.parts) for s in sections), sections=len(sections),
                   lobes=len(plan.bsdfs), model=plan.model)
        for g in list(bpy.data.node_groups):
            bpy.data.node_groups.remove(g)
        t0 = time.perf_counter()
        build_group(plan, "bench")
        row["build_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        build_group(plan, "bench")
        row["rebuild_s"] = time.perf_counter() - t0
        for engine in ("cycles-osl", "cycles-nodes", "eevee", "eevee-principled"):
            sc = _scene_with(stack, engine)
            _, first, err1 = _render(sc)
            _, second, err2 = _render(sc)
            row[engine] = {"first_s": first, "frame_s": second, "errors": sorted(set(err1 + err2))}
        rows.append(row)
    return rows


def textured_sockets(stack) -> list[str]:
    """Textures on two coat roughnesses (the first two coats) and the base colour: the sockets a
    material with such links reads live."""
    from lamella.core.backends.ir.closures import trace_closures
    from lamella.core.backends.ir.sockets import sockets

    shown = sockets(trace_closures(stack).tracer.ids)
    out = [next(sk.name for sk in shown if sk.layer == i and sk.field == "roughness")
           for i in range(min(2, len(stack.coats)))]
    out.append(next(sk.name for sk in shown if sk.layer is None and sk.field in ("albedo", "eta")))
    return out


def linked_rows() -> list[dict]:
    """Per stack class, textures on two coat roughnesses and the base colour: what stays live, the
    node group's size and live values (Cycles' SVM holds about ``SVM_STACK - SVM_HEADROOM``), and
    the mean radiance of the group in Cycles without OSL against the OSL shader (same links)."""
    import numpy as np

    from lamella.core.backends.nodes.lower import emit_plan
    from lamella.core.backends.nodes.svm import live_values
    from ..render import assign_material, build_scene

    rows = []
    for label, case in STACKS:
        stack = _stack(label, case)
        live = textured_sockets(stack)
        plan = emit_plan(stack, live=live)
        row = {"stack": label, "live": live, "nodes": len(plan.nodes), "closures": len(plan.bsdfs),
               "linked_part": "tables" if plan.staged.axis_tables else "traced",
               "lobes": plan.staged.lobes_all, "live_values": live_values(plan)}
        for engine in ("cycles-osl", "cycles-nodes"):
            sc, sphere = build_scene("sphere-env", RES, SPP)
            assign_material(sphere, stack, engine, live=live)
            px, _, errors = _render(sc)
            on = px[..., 3] > 0.999
            row[engine] = float(np.mean(px[on, :3]))
            row[f"{engine} errors"] = errors
        rows.append(row)
    return rows


def run(out_dir: Path = BENCH_DIR) -> Path:
    rows = measure()
    linked = linked_rows()

    def err(r, e):
        return "; ".join(r[e]["errors"]) or "ok"

    md = [
        "# The node group: size, build time and render cost",
        "",
        f"`lamella bench nodes` (this machine, 2 cores, one Blender session; sphere-env {RES}×{RES}, {SPP} samples). "
        "*Build*: the group from nothing; *rebuild*: again with every nested group already there (a structure "
        "edit rebuilds only the nested groups whose content changed). Render times are seconds in the same "
        "session: compare the ratios. EEVEE's *first* render of a material includes compiling its shader "
        "(Mesa's on-disk shader cache off); *frame* is the second.",
        "",
        "| stack | model | plan nodes | nested groups (chunks / sections) | lobes | build s | rebuild s |",
        "|---|---|---:|---|---:|---:|---:|",
    ]
    for r in rows:
        md.append(f"| {r['stack']} | {r['model']} | {r['nodes']} | {r['chunks']} / {r['sections']} | {r['lobes']} | "
                  f"{r['build_s']:.2f} | {r['rebuild_s']:.2f} |")
    md += ["", "| stack | Cycles OSL frame s | Cycles nodes frame s | nodes / OSL | Cycles nodes | EEVEE first s | "
               "EEVEE frame s | Principled+coat EEVEE first / frame s | EEVEE / Principled frame | EEVEE |",
           "|---|---:|---:|---:|---|---:|---:|---:|---:|---|"]
    for r in rows:
        osl, svm, ev, pr = (r[e] for e in ("cycles-osl", "cycles-nodes", "eevee", "eevee-principled"))
        md.append(f"| {r['stack']} | {osl['frame_s']:.2f} | {svm['frame_s']:.2f} | {svm['frame_s'] / osl['frame_s']:.2f} | "
                  f"{err(r, 'cycles-nodes')} | {ev['first_s']:.1f} | {ev['frame_s']:.2f} | "
                  f"{pr['first_s']:.1f} / {pr['frame_s']:.2f} | {ev['frame_s'] / pr['frame_s']:.2f} | {err(r, 'eevee')} |")
    md += ["", "## With textures linked", "",
           "Textures on two coat roughnesses and the base colour: those sockets are read live (the rest is baked). "
           "*Linked part*: what the model they reach becomes in the group: traced, or, where that is more than "
           "Cycles' SVM surely holds, read from tables over (view, linked parameters) (`live_axes`; "
           "bench/linked_tables.md). *Live values*: what the group keeps alive at once in Cycles without OSL "
           "(`svm.live_values`, an estimate; SVM holds about 215). Mean radiance of the sphere, same "
           "links, in Cycles with OSL (which traces the linked part) and without (SVM).", "",
           "| stack | live sockets | linked part | plan nodes | closures / lobes | live values | SVM render | mean, OSL | mean, SVM |",
           "|---|---|---|---:|---:|---:|---|---:|---:|"]
    for r in linked:
        md.append(f"| {r['stack']} | {', '.join(r['live'])} | {r['linked_part']} | {r['nodes']} | {r['closures']} / {r['lobes']} | "
                  f"{r['live_values']} | {'; '.join(r['cycles-nodes errors']) or 'ok'} | {r['cycles-osl']:.4f} | "
                  f"{r['cycles-nodes']:.4f} |")
    return write_page(out_dir, "nodes", "\n".join(md))


BENCH = register(Bench("nodes", "node group size, build time, Cycles-without-OSL and EEVEE render cost",
                       lambda out_dir, args: run(out_dir)))
