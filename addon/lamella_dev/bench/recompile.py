"""`lamella bench recompile`: how long an artist waits between an edit in the panel and the
updated material, per stack size.

For each stack the extension's own path is timed in one Blender session: value edits (the top
coat's roughness, REPEATS times in a row like a dragged slider), each followed by the flush the
edit timer runs (stage: the model re-evaluated where the edit reaches, the table re-baked, the
lobes merged again; the shader with its new table compiled; the node group's table image and
sockets set), then the lobe inspector's refresh a tick later; and structure edits (a coat
duplicated and removed again through the operators) in EEVEE and in Cycles with OSL. The latency
an artist sees is the debounce interval plus the flush.
"""
from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

from .. import suite
from lamella.core.stack import MAX_COATS
from .paths import BENCH_DIR
from .page import write_page
from .registry import Bench, register

REPEATS = 8
STACKS = (("1 coat", "gold_coated"), ("4 coats", "four_coats"), ("4 coats + medium", None), ("8 coats + media", None))


def _stack(label, case):
    from lamella.core.stack import Stack

    if case == "gold_coated":
        return suite.load(case)
    if case == "four_coats":
        return suite.example(case)
    d = suite.example("four_coats").to_dict()
    dust = {"type": "coat", "ior": 1.0, "thickness": 0.3, "sigma_a": [0.1, 0.11, 0.13], "sigma_s": [1.5, 1.5, 1.5],
            "g": 0.3}
    if label.startswith("4"):
        d["layers"] = [dust] + d["layers"][:3]
    else:
        d["layers"] = [dust] + [dict(c, thickness=0.5, sigma_a=[0.1, 0.2, 0.3]) for c in d["layers"]] + d["layers"][:3]
    return Stack.from_dict(d)


def _use(scene, setting: str) -> None:
    """EEVEE, or Cycles with OSL on the CPU."""
    if setting == "eevee":
        from ..render import use_eevee

        use_eevee(scene)
    else:
        scene.render.engine = "CYCLES"
        scene.cycles.device = "CPU"
        scene.cycles.shading_system = True


def run(out_dir: Path = BENCH_DIR) -> Path:
    import bpy

    from lamella.blender import api, recompile, register
    from lamella.core.backends.ir import closures, staging
    from lamella.blender import osl_compile

    register()
    osl_compile.set_cache_root(Path(tempfile.mkdtemp(prefix="lamella-bench-")))
    rows = []
    for label, case in STACKS:
        stack = _stack(label, case)
        mat = bpy.data.materials.new(label)
        api.apply_stack(mat, stack)
        value, inspect, lines = [], [], 0
        for k in range(REPEATS):
            mat.lamella.coats[0].coat.roughness = 0.1 + 0.01 * k  # a value edit: a new shader each time
            t0 = time.perf_counter()
            recompile.flush(defer_inspector=True, drag=True)  # what the edit timer runs: the material first
            value.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            recompile.flush()  # then, a tick later, the lobe inspector
            inspect.append(time.perf_counter() - t0)
            lines = len(mat.node_tree.nodes["Lamella Shader"].script.as_string().splitlines())
        t0 = time.perf_counter()
        recompile.settle()  # the drag over: its lobes merged anew
        settled = time.perf_counter() - t0
        full = len(mat.lamella.coats) == MAX_COATS  # make room for the duplicate first
        mat.lamella.active_index = len(mat.lamella.coats) - 1  # the bottom coat: the medium on top stays
        structure = {}
        for setting in ("eevee", "cycles-osl"):
            _use(bpy.context.scene, setting)
            times = structure[setting] = []
            closures._TRACES.clear()  # the first duplicate of each setting traces its new structure
            for k in range(REPEATS):
                if full:
                    bpy.ops.lamella.layer_remove(material=mat.name)
                    recompile.flush_groups()
                t0 = time.perf_counter()
                bpy.ops.lamella.layer_duplicate(material=mat.name)  # a structure change
                times.append(time.perf_counter() - t0)
                recompile.flush_groups()  # a group left waiting is built before the next edit
                if not full:
                    bpy.ops.lamella.layer_remove(material=mat.name)
                    recompile.flush_groups()
        from lamella.core.backends.osl.emit import emit_osl

        closures._TRACES.clear()  # from scratch: nothing traced or evaluated before
        staging._EVALUATED.clear()
        t0 = time.perf_counter()
        emit_osl(stack)
        trace = time.perf_counter() - t0
        rows.append((label, len(stack.coats), mat.lamella.picked_model, lines, trace, statistics.median(value),
                     max(value), settled, statistics.median(inspect), structure["eevee"], structure["cycles-osl"]))
    md = [
        "# Edit-to-updated-material latency",
        "",
        "`lamella bench recompile` (this machine, one Blender session, empty shader cache at the start). *Value "
        f"edit*: {REPEATS} edits of the top coat's roughness in a row (a slider dragged), each followed by the flush the "
        "edit timer runs: the stage (the model re-evaluated on the view grid only where the changed value reaches it, "
        "as compiled straight-line code from the second edit of the same value on; the table re-baked, the lobes "
        "merged again in the grouping of the drag's first edit), the shader with its new table compiled, the node "
        "group's table image and sockets set (its nodes stay); median and slowest. *Settle*: once the edits pause, "
        f"the material compiled again with its lobes merged anew by the lobe budget ({recompile.SETTLE_DELAY * 1e3:.0f} ms "
        "after the last edit, or before a render or save). *Lobe inspector*: the panel's lobe table and BRDF slice, refreshed a tick "
        "after the material. *Trace*: tracing and staging a stack of the structure from scratch. *Structure edit*: "
        "duplicating a coat through the operator and removing it again (the first duplicate traces a new structure, "
        "later ones reuse the traces of both structures), in a scene that renders the node group (EEVEE: the OSL shader and the "
        "group, whose nested groups are rebuilt only where their content changed, at once) and in one that renders "
        "the OSL shader (Cycles with OSL on the CPU: the group waits until something renders it, half a second "
        "without edits, a render or a save). An artist waits the debounce interval "
        f"({recompile.DEBOUNCE * 1e3:.0f} ms) plus the value-edit time.",
        "",
        "| stack | coats | model | shader lines | trace (ms) | value edit (ms) | slowest value edit (ms) | settle (ms) | "
        "lobe inspector (ms) | structure edit, EEVEE: median, first (ms) | structure edit, Cycles OSL: median, first (ms) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for label, n, model, lines, trace, v, v_max, settled, insp, s_eevee, s_osl in rows:
        md.append(f"| {label} | {n} | {model} | {lines} | {trace * 1e3:.0f} | {v * 1e3:.0f} | {v_max * 1e3:.0f} | "
                  f"{settled * 1e3:.0f} | "
                  f"{insp * 1e3:.0f} | {statistics.median(s_eevee) * 1e3:.0f}, {s_eevee[0] * 1e3:.0f} | "
                  f"{statistics.median(s_osl) * 1e3:.0f}, {s_osl[0] * 1e3:.0f} |")
    return write_page(out_dir, "recompile", "\n".join(md))


BENCH = register(Bench("recompile", "edit-to-updated-material latency of the extension, per stack size",
                       lambda out_dir, args: run(out_dir)))
