"""The node-graph backend without Blender: the plan of nodes, evaluated with Blender's node
semantics (safe division, square root and logarithm, Mix for select, Linear image reads of the
EXR tables at texel centres) in float32, equals the traced model run by numpy in float32.

Tolerances: the weights of the lobes agree to 1e-4 of the largest weight (measured: below 3e-5;
what differs is the bilinear image read against numpy's multilinear look-up in float32), and
every closure argument of a lobe that carries energy (weight > 1e-4) to 1e-4 relative. Where a
lobe has no energy its arguments may differ (a ratio of two vanishing quantities), which no
render can show."""
import math

import numpy as np
import pytest

from lamella.core import Stack
from lamella_dev import suite
from lamella.core.backends import evaluate
from lamella.core.backends.ir import staging
from lamella.core.backends.evaluate import evaluate_plan
from lamella.core.backends.nodes.lower import emit_plan
from lamella.core.backends.nodes.partition import CHUNK_NODES, SECTION_CHUNKS, own_nodes, partition
from lamella.core.backends.nodes.plan import INSIDE_INPUT, Out, texel_range
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.backends.ir.staging import StagedOps
from lamella.core.lobe_kinds.bsdf_node import blender_anisotropy

CASES = suite.names()


def _directions(grazing=True):
    theta = np.radians(np.r_[np.linspace(0.0, 88.0, 23), [89.9, 90.0]] if grazing else np.linspace(0.0, 85.0, 18))
    phi = np.radians(np.linspace(0.0, 330.0, 12))
    t, p = np.meshgrid(theta, phi)
    # every other azimuth seen from behind: a solid dielectric base's far side (``models.sides``)
    inside = (np.arange(phi.size)[:, None] % 2 + 0.0 * t).astype(np.float64)
    return {"wi_x": np.sin(t) * np.cos(p), "wi_y": np.sin(t) * np.sin(p), "wi_z": np.cos(t), INSIDE_INPUT: inside}


def _compare(plan, values):
    tracer, exprs, refs = plan.traced
    ops = StagedOps(plan.staged.table, np.float32) if plan.staged is not None else NumpyOps(np.float32)
    want = tracer.evaluate(exprs, ops, values)
    got = evaluate_plan(plan, values, np.float32)
    shape = values["wi_z"].shape
    pairs = [(np.broadcast_to(np.asarray(w, np.float64), shape), np.broadcast_to(np.asarray(got(r), np.float64), shape))
             for w, r in zip(want, refs)]
    return pairs


@pytest.mark.parametrize("staged", [True, False, "azimuths"], ids=["staged", "traced", "azimuth-table"])
@pytest.mark.parametrize("case", CASES)
def test_plan_equals_the_traced_model(case, staged):
    """The plan of the staged shader (table reads: Closest texels blended by Mix nodes), of the
    same on an (elevation, azimuth) table (for anisotropic stacks) and of the whole traced model."""
    grid = None
    if staged == "azimuths":
        if staging.isotropic(suite.load(case)):
            pytest.skip("an isotropic stack is staged in the view frame: one azimuth")
        grid = staging.ViewGrid(staging.N_MU, staging.N_PHI)
    plan = emit_plan(suite.load(case), staged=bool(staged), grid=grid)
    values = dict(_directions(grazing=False), **plan.params)
    lobes = _closure_pairs(plan, values)
    top = max(np.abs(w).max() for _, color, _ in lobes for w, _ in color)
    for b, color, args in lobes:
        for w, g in color:
            assert np.abs(g - w).max() <= 1e-4 * top, f"{b.label}: weight"
        live = np.maximum.reduce([np.abs(w) for w, _ in color]) > 1e-4
        for w, g in args:
            err = np.abs(g - w) / np.maximum(np.abs(w), 1e-3)
            assert err[live].max(initial=0.0) < 1e-4, f"{b.label}: argument"


def _closure_pairs(plan, values) -> list:
    """Per closure of ``plan``: (its BSDF, (want, got) of its colour's channels, (want, got) of its
    arguments as ``_closure_arguments`` compares them)."""
    pairs = iter(_compare(plan, values))
    lobes = []
    for b in plan.bsdfs:
        color = [next(pairs) for _ in range(3)]
        args = {name: next(pairs) for name in b.floats}
        args.update({f"{name}{i}": next(pairs) for name, v in b.vectors.items() if v is not None for i in range(3)})
        lobes.append((b, color, _closure_arguments(args)))
    return lobes


def _closure_arguments(args: dict) -> list:
    """(want, got) pairs of what the closure renders: an anisotropic Glossy's Roughness,
    Anisotropy and Tangent as the components of its roughness tensor alpha_x t t^T + alpha_y b b^T
    (the axes and the anisotropy of a nearly round lobe are ill-conditioned in float32, the lobe
    is not), every other argument as it is."""
    axes = ("Roughness", "Anisotropy", "Tangent0", "Tangent1", "Tangent2")
    if not {"Anisotropy", "Tangent0"} <= set(args):
        return list(args.values())
    tensors = []
    for k in range(2):  # want, got
        r, a = args["Roughness"][k], args["Anisotropy"][k]
        n = np.hypot(args["Tangent0"][k], args["Tangent1"][k])
        tx, ty = args["Tangent0"][k] / n, args["Tangent1"][k] / n
        alpha = r * r
        ax = np.where(a >= 0.0, alpha * (1.0 - a), alpha / (1.0 + a))
        ay = np.where(a >= 0.0, alpha / (1.0 - a), alpha * (1.0 + a))
        tensors.append((ax * tx * tx + ay * ty * ty, (ax - ay) * tx * ty, ax * ty * ty + ay * tx * tx))
    return [v for name, v in args.items() if name not in axes] + list(zip(*tensors))


@pytest.mark.parametrize("staged", [True, False], ids=["staged", "traced"])
@pytest.mark.parametrize("case", CASES)
def test_plan_is_finite_at_every_angle_in_float32(case, staged):
    plan = emit_plan(suite.load(case), staged=staged)
    values = dict(_directions(grazing=True), **plan.params)
    value_of = evaluate_plan(plan, values, np.float32)
    for o in plan.outputs:
        assert np.isfinite(value_of(o)).all()
    for b in plan.bsdfs:
        for c in b.color:
            assert (np.asarray(value_of(c)) >= 0).all(), f"{b.label}: negative weight"


def test_blender_anisotropy_gives_back_the_lobe_axes():
    """Cycles' Glossy BSDF: alpha = r^2, a >= 0: (alpha (1 - a), alpha / (1 - a)); a < 0:
    (alpha / (1 + a), alpha (1 + a))."""
    ops = NumpyOps(np.float64)
    ax = np.array([0.01, 0.3, 0.2, 0.5, 0.04, 0.0])
    ay = np.array([0.1, 0.03, 0.2, 0.5, 0.9, 0.0])
    r, a = blender_anisotropy(ops, ax, ay)
    alpha = r * r
    bx = np.where(a < 0, alpha / (1 + a), alpha * (1 - a))
    by = np.where(a < 0, alpha * (1 + a), alpha / (1 - a))
    assert np.allclose(bx, ax, rtol=1e-6, atol=1e-9) and np.allclose(by, ay, rtol=1e-6, atol=1e-9)
    assert a[2] == 0.0 and a[3] == 0.0 and a[5] == 0.0, "isotropic lobes have no anisotropy"


@pytest.mark.parametrize("live", [(), ("coat1_roughness", "base_eta")])
def test_partition_covers_every_node_once_in_bounded_groups(live):
    plan = emit_plan(suite.example("four_coats"), live=live)
    items = partition(plan)
    sections = [s for s in items if not s.own]
    chunks = [c for s in sections for c in s.parts]
    own = [i for s in items if s.own for i in s.nodes]
    assert own and set(own) == own_nodes(plan)  # the material's table reads
    seen = [i for c in chunks for i in c.nodes] + own
    assert sorted(seen) == list(range(len(plan.nodes)))
    assert max(len(c.nodes) for c in chunks) <= CHUNK_NODES
    assert max(len(s.parts) for s in sections) <= SECTION_CHUNKS
    assert all(len({plan.nodes[i].scope for i in c.nodes}) == 1 for c in chunks)
    # built in order, each reads only leaves and what was built before it
    built: set = set()
    for item in items:
        for part in (item.parts or [item]):
            reads = part.inputs if not part.own else [v for i in part.nodes for v in plan.nodes[i].inputs.values()
                                                      if isinstance(v, Out)]
            assert all(v.node < 0 or v.node in built or v.node in part.nodes for v in reads)
            built.update(part.nodes)
    # no nested group reads the material's table: every material of this structure shares them
    assert not any(plan.nodes[i].props.get("image") in plan.images for c in chunks for i in c.nodes)


def test_a_value_edit_keeps_every_nested_group_and_a_structure_edit_keeps_the_rest():
    """Parameters are group inputs, so new values make the same nested groups; a changed coat
    rebuilds its own sections and leaves the sections before it alone."""
    d = suite.example("four_coats").to_dict()
    base = {s.digest for s in partition(emit_plan(Stack.from_dict(d), staged=False))}
    d2 = suite.example("four_coats").to_dict()
    d2["layers"][0]["ior"] = 1.7
    d2["layers"][1]["ior"] = 1.33
    assert {s.digest for s in partition(emit_plan(Stack.from_dict(d2), staged=False))} == base
    d3 = suite.example("four_coats").to_dict()
    d3["layers"][-1]["sigma_a"] = [0.5, 0.2, 0.1] if "sigma_a" not in d3["layers"][-1] else [0.0, 0.0, 0.0]
    changed = {s.digest for s in partition(emit_plan(Stack.from_dict(d3), staged=False))}
    assert changed != base and len(changed & base) > 0


def test_table_reads_hit_texel_centres():
    """A table look-up at a node of the table reads that texel exactly (the lowering's texture
    coordinates, and v = t / 2 in a file that holds the atlas above its mirror image, Blender's
    rows bottom-up)."""
    from lamella.core import luts

    n0, n1 = luts.SPECS["ggx_albedo"].shape
    table = luts.table("ggx_albedo")
    img = evaluate.table_pixels("ggx_albedo.exr")
    (s0, s1), (t0, t1) = texel_range(n1), texel_range(n0)
    for i, j in [(0, 0), (3, 7), (n0 - 1, n1 - 1), (10, 0)]:
        s = s0 + j / (n1 - 1) * (s1 - s0)
        t = t0 + i / (n0 - 1) * (t1 - t0)
        got = evaluate.bilinear(img, np.array([s]), np.array([0.5 * t]))[0, 0]
        assert math.isclose(got, table[i, j], rel_tol=1e-6, abs_tol=1e-7)


def test_live_values_say_which_stacks_fit_cycles_svm():
    """Measured in Cycles 5.0 (bench/nodes.md): traced whole, every suite stack without a medium
    and four coats render without OSL; four coats with a medium run out of SVM stack. The estimate
    separates them. A scattering coat traced whole is over it too since tm6 carries the forward
    light scattered once as a family of its own (252 live values against 198 before): a material
    with most of such a stack linked renders its node group from tables over the linked values
    (``live_axes``). Staged, every one of them fits, eight coats with media too."""
    from lamella_dev.bench.recompile import _stack
    from lamella.core.backends.nodes.svm import fits_svm

    media = {n for n in CASES if suite.load(n).has_scattering}
    assert media and all(fits_svm(emit_plan(suite.load(n), staged=False)) for n in CASES if n not in media)
    assert all(fits_svm(emit_plan(suite.load(n))) for n in media)
    assert all(fits_svm(emit_plan(suite.load(n), live=["coat0_roughness"])) for n in media)
    assert fits_svm(emit_plan(_stack("4 coats", "four_coats"), staged=False))
    assert not fits_svm(emit_plan(_stack("4 coats + medium", None), staged=False))
    for label in ("4 coats + medium", "8 coats + media"):
        assert fits_svm(emit_plan(_stack(label, None)))
