"""EEVEE's stand-ins for anisotropic lobes (``staging.Staged.stand_ins``): each baked anisotropic
lobe gets three isotropic GGX lobes about normals tilted along its long axis, drawn by the node
group in EEVEE only. What Cycles draws (the closures, the OSL shader's table, the node group's
Cycles branch) is unchanged; the stand-ins carry the lobe's energy and are closer to its shape than
the round lobe EEVEE made of the anisotropic Glossy BSDF."""
import math
import re
from dataclasses import replace

import numpy as np
import pytest

from lamella.core import lobe_kinds
from lamella.core.backends.evaluate import evaluate_staged
from lamella.core.backends.ir import staging
from lamella.core.backends.nodes.lower import emit_plan
from lamella.core.backends.osl.emit import osl_shader
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.lobe_kinds import isotropic_fit
from lamella_dev import suite

CASES = ["coat_over_brushed", "rotated_30", "rotated_90", "opposing_anisotropy"]
VIEWS = [(0.0, 0.0), (30.0, 0.8), (45.0, 2.0), (60.0, 4.0)]


def _wo(n=40000):
    wo = np.random.default_rng(3).normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wo[:, 2] = np.abs(wo[:, 2])
    return wo


@pytest.mark.parametrize("case", CASES)
def test_cycles_draws_what_it_drew_and_eevee_the_stand_ins(case):
    stack = suite.load(case)
    st, bare = staging.stage(stack), staging.stage(stack, stand_ins=0)
    assert st.stand_ins and not bare.stand_ins
    assert all(len(v) == staging.STAND_INS for v in st.stand_ins.values())
    assert all(st.closures[k].kind.name == "reflection" for k in st.stand_ins)
    wo = _wo()
    for th, ph in VIEWS:
        wi = suite.incident(th, ph)
        cycles = evaluate_staged(st, wi, wo, np.float32)
        np.testing.assert_array_equal(cycles, evaluate_staged(bare, wi, wo, np.float32))
        eevee = evaluate_staged(st, wi, wo, np.float64, target="eevee")
        assert np.isfinite(eevee).all() and eevee.min() >= 0.0
        # the stand-ins carry the lobe's energy: the hemisphere means agree within a few percent
        assert abs(eevee.mean() / cycles.mean() - 1.0) < 0.04, (th, ph)


@pytest.mark.parametrize("case", CASES)
def test_the_stand_ins_are_closer_to_the_lobes_than_the_round_lobe(case):
    """Relative L1 of f cos against the anisotropic closures (what Cycles draws), mean over views:
    the stand-ins against one lobe of alpha sqrt(ax ay) per anisotropic lobe (EEVEE's own reading
    of the Glossy BSDF), both in numpy (``bench/eevee_anisotropy_fit.md`` has the table)."""
    st = staging.stage(suite.load(case))
    ops = NumpyOps(np.float64)
    reflection = lobe_kinds.kind("reflection")
    wo = _wo()
    ours, round_ = [], []
    for th, ph in VIEWS:
        wi = suite.incident(th, ph)
        cycles = evaluate_staged(st, wi, wo, np.float64)
        eevee = evaluate_staged(st, wi, wo, np.float64, target="eevee")
        rounded = cycles.copy()
        for k in st.stand_ins:  # the anisotropic closure swapped for the round one of its energy
            one = replace(st, closures=[st.closures[k]], stand_ins={})
            rounded -= evaluate_staged(one, wi, wo, np.float64)
            vals = {n: np.full(1, v) for n, v in zip(staging.VIEW_INPUTS, wi)}
            env = dict(zip(map(id, (ex := [*st.closures[k].weight, *st.closures[k].args.values()])),
                           st.tracer.evaluate(ex, staging.StagedOps(st.table, np.float64), {**vals, **st.params})))
            v = {n: float(np.asarray(env[id(x)] if not isinstance(x, float) else x).ravel()[0])
                 for n, x in st.closures[k].args.items()}
            w = np.array([float(np.asarray(env[id(x)] if not isinstance(x, float) else x).ravel()[0])
                          for x in st.closures[k].weight])
            a = math.sqrt(v["ax"] * v["ay"])
            iso = {"ax": a, "ay": a, "cos": 1.0, "sin": 0.0}
            wi_t = tuple(np.full(len(wo), c) for c in wi)
            energy = w / reflection.scale_of_args(ops, {**v}, tuple(np.array([c]) for c in wi))[0]
            rounded += energy[None, :] * (reflection.cos_of_args(ops, iso, wi_t, tuple(wo.T))
                                          * reflection.scale_of_args(ops, iso, wi_t))[:, None]
        ours.append(np.abs(eevee - cycles).sum() / cycles.sum())
        round_.append(np.abs(rounded - cycles).sum() / cycles.sum())
    assert np.mean(ours) < 0.85 * np.mean(round_), (np.mean(ours), np.mean(round_))


def test_isotropic_stacks_have_no_stand_ins():
    for case in ("gold_coated", "varnished_wood", "rough_glass_plate"):
        st = staging.stage(suite.load(case))
        assert st.stand_ins == {} and st.table.shape[1] == 1


@pytest.mark.parametrize("case", ["coat_over_brushed", "rotated_60"])
def test_the_osl_shader_keeps_its_one_azimuth_table(case):
    """A table made over azimuths for the stand-ins alone: the OSL shader prints the columns it
    reads, along the elevation only, as without the stand-ins."""
    stack = suite.load(case)
    st, bare = staging.stage(stack), staging.stage(stack, stand_ins=0)
    assert st.table.shape[1] == staging.N_PHI and bare.table.shape[1] == 1
    size = int(re.search(r"float MT\[(\d+)\]", osl_shader(stack).source).group(1))
    assert size == bare.table.shape[0] * bare.table.shape[2]


def test_the_node_plan_draws_each_lobe_in_cycles_and_its_stand_ins_in_eevee():
    stack = suite.load("rotated_30")
    plan, bare = emit_plan(stack), emit_plan(stack, stand_ins=0)
    targets = [b.target for b in plan.bsdfs]
    assert targets.count("cycles") == 2 and targets.count("eevee") == 2 * staging.STAND_INS
    assert [b.kind for b in plan.bsdfs if b.target != "eevee"] == [b.kind for b in bare.bsdfs]
    assert all(b.target == "all" for b in bare.bsdfs)
    for b in plan.bsdfs:
        if b.target == "eevee":
            assert b.kind == "tilted_reflection" and b.vectors["Normal"] is not None
            assert b.floats["Anisotropy"] == 0.0


def test_the_tilted_closure_is_the_fit_s():
    """The lobe kind evaluates what ``isotropic_fit.tilted_cos`` (the fit's own closure) does."""
    kind = lobe_kinds.kind("tilted_reflection")
    rng = np.random.default_rng(1)
    wi = rng.normal(size=(2000, 3))
    wi[:, 2] = np.abs(wi[:, 2])
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo = rng.normal(size=(2000, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    n = isotropic_fit.tilted_normal(rng.uniform(-0.6, 0.6, 2000), np.stack([np.cos(a := rng.uniform(0, 6.3, 2000)),
                                                                            np.sin(a)], -1))
    alpha = rng.uniform(0.02, 0.8, 2000)
    got = kind.cos_of_args(NumpyOps(np.float64), {"alpha": alpha, "nx": n[:, 0], "ny": n[:, 1], "nz": n[:, 2]},
                           tuple(wi.T), tuple(wo.T))
    np.testing.assert_allclose(got, isotropic_fit.tilted_cos(wi, wo, alpha, n), rtol=1e-12, atol=1e-14)


def test_the_stand_ins_follow_a_linked_coverage_mask():
    """A partly covering coat over a brushed metal, its coverage linked: the base's anisotropic lobe
    is in both parts (with and without the coat), each part's stand-ins weighted by its cover like
    the lobe itself, so EEVEE's energy follows Cycles' at every mask value."""
    d = suite.load("coat_over_brushed").to_dict()
    d["format"] = 2
    d["layers"][0]["coverage"] = 0.5
    st = staging.stage(d, live=("coat0_coverage",))
    assert len(st.stand_ins) >= 2
    wo = _wo()
    for mask in (0.0, 0.3, 1.0):
        for th, ph in VIEWS[:3]:
            wi = suite.incident(th, ph)
            cycles = evaluate_staged(st, wi, wo, np.float64, values={"coat0_coverage": mask})
            eevee = evaluate_staged(st, wi, wo, np.float64, values={"coat0_coverage": mask}, target="eevee")
            assert abs(eevee.mean() / cycles.mean() - 1.0) < 0.04, (mask, th, ph)
