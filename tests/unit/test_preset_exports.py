"""The generated folders ``osl/`` and ``node_groups/`` (``lamella_dev.preset_exports``) are what the
current presets and code make: a preset, the shader generator or the node-group compiler changed
without ``make exports`` fails here, naming the presets, on any processor: the structure compares
exactly, the computed numbers within ``golden.TOLERANCE`` (float noise made on purpose, and real
older processors' kernels, pass; real changes do not). OSL only (a few seconds): the .blend is
judged by its manifest, and compiled and rendered by tests/blender/test_preset_exports.py."""
import functools
import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from lamella.core import Stack, presets
from lamella.core.backends.osl.emit import VIEW_TARGETS
from lamella_dev import golden, preset_exports as pe


def test_the_osl_folder_is_what_the_presets_export_now():
    changes = pe.osl_changes(pe.OSL_DIR)
    assert not changes, (f"osl/ is stale; run `{pe.REGENERATE}` (or `lamella export-presets --only osl`) and "
                         "commit it:\n  " + "\n  ".join(changes))


def test_the_osl_folder_has_every_preset_for_every_target():
    for target in VIEW_TARGETS:
        have = sorted(p.name for p in (pe.OSL_DIR / target).iterdir())
        assert have == sorted(p.id for p in presets.builtin()), target
        for p in presets.builtin():
            assert (pe.OSL_DIR / target / p.id / pe.shader_file(p)).is_file()


def test_the_node_groups_were_built_from_the_current_presets_and_compiler():
    changes = pe.node_group_changes(pe.NODE_GROUPS_DIR)
    assert not changes, (f"node_groups/ is stale; run `{pe.REGENERATE}` (or `lamella export-presets --only "
                         "node-groups`, which needs the bpy of Blender 4.2) and commit it:\n  " + "\n  ".join(changes))


def test_a_changed_preset_is_named():
    """The manifest check fails on the preset that changed, and only on it."""
    stored = json.loads((pe.NODE_GROUPS_DIR / pe.MANIFEST).read_text())
    first = presets.builtin()[0]
    entry = pe.manifest_entry(first)
    assert entry == next(e for e in stored["presets"] if e["id"] == first.id)
    stack = first.load().to_dict()
    stack["base"]["roughness"] = 0.5
    changed = Stack.from_dict(stack)
    assert pe.stack_digest(changed) != entry["stack_sha256"]

    def compile_changed(s, inputs):
        return pe.compiled(changed, inputs) if s.name == first.load().name else _cached(s, inputs)

    changes = pe.node_group_changes(compile=compile_changed)
    assert len(changes) == 1 and changes[0].startswith(f"{first.id}: ") and "image table:" in changes[0], changes


# ---------------------------------------------------------------- goldens that hold on any processor
@functools.cache
def _compiled_now() -> dict:
    """Every preset's ``compiled``, by its stack's name, computed once for the tests that alter it."""
    return {p.load().name: pe.compiled(p.load(), p.inputs) for p in presets.builtin()}


def _cached(stack, inputs) -> pe.Compiled:
    return _compiled_now()[stack.name]


def _nudged(built: pe.Compiled, ulps: int, seed: int) -> pe.Compiled:
    """``built`` with every computed number moved by up to ``ulps`` float32 ulps."""
    rng = np.random.default_rng(seed)
    return pe.Compiled(built.structure, {part: golden.nudge(v, ulps, rng) for part, v in built.numbers.items()})


def test_the_node_groups_stay_current_when_every_computed_float_moves_a_few_ulps():
    """Another processor computes other last bits (numpy's SIMD kernels, BLAS, libm): every number
    of every preset's compile moved by up to 4 float32 ulps (about 5e-7 relative, a thousand
    float64 ulps) is no change; and the stored numbers are not bit-equal to the nudged ones, so the
    check really ran on numbers that differ."""
    seen = []

    def compile_nudged(stack, inputs):
        built = _nudged(_cached(stack, inputs), 4, len(seen))
        seen.append(built)
        return built

    assert pe.node_group_changes(compile=compile_nudged) == []
    with np.load(pe.NODE_GROUPS_DIR / pe.NUMBERS) as npz:
        table = npz[pe.numbers_key(presets.builtin()[0].id, "image table")]
    assert len(seen) == len(presets.builtin())
    assert not np.array_equal(seen[0].numbers["image table"], table)


def test_the_node_groups_stay_current_when_numpys_kernels_round_otherwise():
    """The compile itself run as on another processor: numpy's processor-dependent functions
    returning other last bits (``golden.numpy_of_another_processor``: up to 4 ulps, a function of
    the value, whole numbers exact, as a real kernel), so the noise passes through the whole
    compiler (the fitted EEVEE stand-ins, the staged tables, constant folding, the lobe budget's
    merges) as it would: every preset is still current, none flips a branch; and the noise did
    reach the compile (brushed steel's numbers are not bit-equal)."""
    moved = []

    def compile_noisy(stack, inputs):
        with golden.numpy_of_another_processor():
            built = pe.compiled(stack, inputs)
        moved.append(built)
        return built

    assert pe.node_group_changes(compile=compile_noisy) == []
    clean = _compiled_now()[presets.builtin()[2].load().name]
    assert any(not np.array_equal(moved[2].numbers[k], clean.numbers[k]) for k in clean.numbers), (
        "the perturbation did not reach the compile")


def test_a_real_change_to_the_compile_is_caught():
    """What the tolerance lets through is float noise, not a change: a table's two columns swapped,
    one pixel moved by 1e-4, a table of another layout (shape), a node more are each reported,
    naming the preset and the part."""
    target = presets.builtin()[1]

    def compile_with(change):
        def compile(stack, inputs):
            built = _cached(stack, inputs)
            return change(built) if stack.name == target.load().name else built
        return compile

    def swap_columns(b):
        px = b.numbers["image table"].reshape(64, -1, 4).copy()
        px[:, [0, 1]] = px[:, [1, 0]]
        return pe.Compiled(b.structure, {**b.numbers, "image table": px.reshape(-1)})

    def one_pixel(b):
        px = b.numbers["image table"].copy()
        px[int(np.argmax(px))] += np.float32(1e-4)
        return pe.Compiled(b.structure, {**b.numbers, "image table": px})

    def layout(b):
        return pe.Compiled(golden.digest(b.structure, "a table of another shape"), b.numbers)

    def node_more(b):
        return pe.Compiled(b.structure, {**b.numbers, "nodes": np.append(b.numbers["nodes"], 0.5)})

    for change, says in ((swap_columns, "image table: "), (one_pixel, "image table: 1 of"),
                         (layout, "structure_digest changed"), (node_more, "nodes: ")):
        changes = pe.node_group_changes(compile=compile_with(change))
        assert len(changes) == 1 and changes[0].startswith(f"{target.id}: ") and says in changes[0], (change, changes)


def test_the_osl_folder_stays_current_when_its_printed_floats_move(tmp_path):
    """``osl/`` regenerated with every float literal of every shader and README moved by up to 4
    float32 ulps (printed again) is current; one literal moved by 1e-3 of its value is not."""
    pe.write_osl(tmp_path)
    rng = np.random.default_rng(3)
    texts = sorted(p for p in tmp_path.rglob("*") if p.suffix in pe.TEXT_SUFFIXES)
    for p in texts:
        p.write_text(golden.nudge_text(p.read_text(), 4, rng))
    assert pe.tree_changes(tmp_path, pe.OSL_DIR) == []
    shader = tmp_path / "cycles" / "lacquered_gold" / "lamella_lacquered_gold.osl"
    text = shader.read_text()
    literal = re.search(r"float MT\[\d+\] = \{([^,]+),", text).group(1)
    shader.write_text(text.replace(literal, repr(float(literal) * 1.001), 1))
    changes = pe.tree_changes(tmp_path, pe.OSL_DIR)
    assert len(changes) == 1 and changes[0].startswith("lacquered_gold (cycles): lamella_lacquered_gold.osl changed (1 of")


def test_the_catalogs_are_the_material_librarys():
    """Same catalog paths and UUIDs as the presets' material asset library, so Blender shows one tree."""
    materials = (presets.DATA_DIR / "assets" / "blender_assets.cats.txt").read_text()
    ours = (pe.NODE_GROUPS_DIR / pe.CATALOG_FILE).read_text()

    def entries(text):
        return {line for line in text.splitlines() if line.count(":") == 2}

    assert entries(ours) == entries(materials) == entries(pe.catalog_file())


def test_the_node_groups_readme_is_the_manifests():
    manifest = json.loads((pe.NODE_GROUPS_DIR / pe.MANIFEST).read_text())
    assert (pe.NODE_GROUPS_DIR / pe.README).read_text() == pe.node_groups_readme(manifest), (
        f"node_groups/README.md is stale: run `{pe.REGENERATE}`")


# ---------------------------------------------------------------- on other processors, for real
# numpy picks its SIMD kernels at start-up from what the processor has, unless told to leave some
# out (NPY_DISABLE_CPU_FEATURES); OpenBLAS its kernel (OPENBLAS_CORETYPE); glibc its libm variant
# (GLIBC_TUNABLES): set so, this processor computes as an older one does.
_PROBE = ("import hashlib, numpy as np; x = np.linspace(0.01, 3.0, 4099); a = np.cos(np.outer(x[:200], x[:200]));"
          "print(hashlib.sha256(np.concatenate([np.exp(x), np.log(x), np.sin(x), np.arctan(x), (a @ a).ravel()])"
          ".tobytes()).hexdigest()[:16])")
_CHECK = ("import json; from lamella_dev import preset_exports as pe;"
          "print(json.dumps([pe.node_group_changes(), pe.osl_changes()]))")


def _older_processor(kind: str) -> dict:
    from numpy._core import _multiarray_umath as umath  # numpy 2: the running kernels' features

    present = [f for f in umath.__cpu_dispatch__ if umath.__cpu_features__.get(f)]
    left_out = [f for f in present if f.startswith("AVX512")] if kind == "avx2" else present
    env = dict(os.environ, NPY_DISABLE_CPU_FEATURES=" ".join(left_out),
               OPENBLAS_CORETYPE="Haswell" if kind == "avx2" else "Nehalem")
    if kind == "sse3":
        env["GLIBC_TUNABLES"] = "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX512F,-AVX"
    return env


def _python(code: str, env: dict) -> str:
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    return r.stdout.strip().splitlines()[-1]


@pytest.mark.parametrize("kind", ["avx2", "sse3"])
def test_the_generated_folders_are_current_on_an_older_processor(kind):
    """The staleness checks run in a Python whose numpy kernels, BLAS kernel and libm are an AVX2
    (or an SSE3) machine's: osl/ and node_groups/ are current there too. Where this processor
    has AVX-512 the older kernels compute other last bits (the probe), so the check ran on
    numbers that differ."""
    from numpy._core import _multiarray_umath as umath

    env = _older_processor(kind)
    assert json.loads(_python(_CHECK, env)) == [[], []]
    if kind == "sse3" and umath.__cpu_features__.get("AVX512F"):
        assert _python(_PROBE, env) != _python(_PROBE, dict(os.environ)), "the older kernels computed the same bits"
