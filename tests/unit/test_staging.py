"""The staged shader (float32 table, linear reads, every lobe) against the traced model it bakes:
relative L1 (RGB averaged) on the hemisphere grid, at incidence up to 85 degrees (and several
azimuths for anisotropic stacks), below 0.5 % (bench/staging.md: worst 0.41 % over the suite);
a value edit changes the table, not the structure; linked parameters stay live."""
import json

import numpy as np
import pytest

from lamella.core import Stack, api, suite
from lamella.core.backends import lobe_budget, staging
from lamella.bench.staging import baked_error

CASES = ["gold_coated", "rotated_60", "three_coats", "fog_g09_d1", "rough_glass_plate", "varnished_wood",
         "green_scatter_d6", "endf_thin_gold"]


@pytest.mark.parametrize("case", CASES)
def test_the_baked_shader_equals_the_traced_model(case):
    stack = suite.load(case)
    worst, where = baked_error(stack, staging.stage(stack, budget="all"))
    assert worst < 0.005, (worst, where)


def test_a_value_edit_changes_the_table_and_not_the_structure():
    d = suite.load("tinted_varnish").to_dict()
    a = staging.stage(Stack.from_dict(d))
    d["layers"][0]["ior"] = 1.7
    d["layers"][0]["roughness"] = 0.2
    b = staging.stage(Stack.from_dict(d))
    assert a.structure_key() == b.structure_key()
    assert not np.array_equal(a.table, b.table)


def test_a_linked_parameter_stays_live_and_reads_its_socket():
    stack = suite.load("gold_coated")
    st = staging.stage(stack, live=["coat0_alpha"], budget="all")
    assert st.live == ("coat0_alpha",) and "coat0_alpha" in st.tracer.params
    wi = suite.incident(40.0)
    wo, _ = suite.wo_grid(wi)
    d = stack.to_dict()
    d["layers"][0]["roughness"] = 0.3
    want = api.evaluate(Stack.from_dict(d), wi, wo)
    got = staging.evaluate_staged(st, wi, wo, values={"coat0_alpha": np.float32(0.3)})
    assert np.abs(got - want).sum() / want.sum() < 0.005
    with pytest.raises(ValueError, match="not an input"):
        staging.stage(stack, live=["coat7_alpha"])


def test_live_inputs_are_named_by_socket_or_parameter():
    """A material links sockets (the panel's units: roughness r, one colour socket per RGB field);
    linking one makes the parameters it feeds live, the same as naming them."""
    stack = suite.load("gold_coated")
    by_socket = staging.stage(stack, live=["coat0_roughness", "base_eta"])
    by_param = staging.stage(stack, live=["coat0_alpha", "base_eta_r", "base_eta_g", "base_eta_b"])
    assert by_socket.live == by_param.live == ("base_eta_b", "base_eta_g", "base_eta_r", "coat0_alpha")
    assert by_socket.live_sockets == ("base_eta", "coat0_roughness")
    assert by_socket.structure_key() == by_param.structure_key()


def test_budgets():
    stack = suite.load("fog_g09_d1")
    assert len(staging.stage(stack, budget="all").closures) == 6
    assert len(staging.stage(stack, budget=4).closures) <= 4
    assert lobe_budget.parse("3") == 3
    with pytest.raises(ValueError):
        lobe_budget.parse(9)


@pytest.mark.parametrize("case", ["rotated_60", "opposing_anisotropy"])
def test_an_azimuth_the_table_does_not_vary_with_is_dropped(case):
    """Anisotropic stacks whose lobe energies and roughness tensors depend on the elevation alone
    get a one-azimuth table; the shader equals the one staged on the full (elevation, azimuth) grid."""
    stack = suite.load(case)
    st = staging.stage(stack, budget="all")
    full = staging.stage(stack, budget="all", grid=staging.ViewGrid(staging.N_MU, staging.N_PHI))
    assert st.frame == full.frame == "shading"
    assert st.table.shape[1] == 1 and full.table.shape[1] == staging.N_PHI
    assert "atan2" not in {e.op for e in st.tracer.nodes}
    for theta, phi in ((0.0, 0.0), (35.0, 0.7), (70.0, 2.9)):
        wi = suite.incident(theta, phi)
        wo, _ = suite.wo_grid(wi)
        a = staging.evaluate_staged(st, wi, wo, dtype=np.float64)
        b = staging.evaluate_staged(full, wi, wo, dtype=np.float64)
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("case", ["gold_coated", "rotated_60", "fog_g09_d1", "varnished_wood", "rough_glass_plate"])
def test_a_value_edit_reuses_the_trace_and_stages_as_a_fresh_trace(case):
    """Stacks of one structure share their traced graph (``closures.structure_of``): a value edit
    does not trace again, and what it stages is what a fresh trace stages."""
    from lamella.core.backends import closures
    from lamella.core.backends.osl import emit_osl

    d = suite.load(case).to_dict()
    edited = json.loads(json.dumps(d))
    edited["layers"][0]["ior"] = 1.37
    edited["base"] = {**edited["base"], **{k: [0.9 * x for x in v] for k, v in edited["base"].items()
                                            if k in ("eta", "albedo")}}
    closures._TRACES.clear()
    first = closures.trace_closures(Stack.from_dict(d))
    again = closures.trace_closures(Stack.from_dict(edited))
    assert again.closures is first.closures and again.tracer.defaults != first.tracer.defaults
    cached = emit_osl(Stack.from_dict(edited))
    closures._TRACES.clear()
    assert emit_osl(Stack.from_dict(edited)) == cached
    r = edited["layers"][0]["roughness"]
    flipped = [0.1, 0.1] if r[0] != r[1] else [0.1, 0.2]  # isotropic <-> anisotropic: another structure
    other = dict(edited, layers=[dict(edited["layers"][0], roughness=flipped)] + edited["layers"][1:])
    assert closures.structure_of(Stack.from_dict(other)) != closures.structure_of(Stack.from_dict(edited))
