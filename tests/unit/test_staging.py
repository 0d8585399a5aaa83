"""The staged shader (float32 table, linear reads, every lobe) against the traced model it bakes:
relative L1 (RGB averaged) on the hemisphere grid, at incidence up to 85 degrees (and several
azimuths for anisotropic stacks), below 0.5 % (bench/staging.md has the worst over the suite);
a value edit changes the table, not the structure; linked parameters stay live."""
import json

import numpy as np
import pytest

from lamella.core import Stack, api
from lamella_dev import suite
from lamella.core.backends.ir import lobe_budget, staging
from lamella.core.backends.evaluate import evaluate_staged
from lamella_dev.bench.staging import baked_error

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
    got = evaluate_staged(st, wi, wo, values={"coat0_alpha": np.float32(0.3)})
    assert np.abs(got - want).sum() / want.sum() < 0.005
    with pytest.raises(ValueError, match="not an input"):
        staging.stage(stack, live=["coat7_alpha"])


def test_a_live_shader_carries_the_tables_it_reads_in_its_source_or_reads_their_files():
    """A Script node's shader (tables="inline") holds, as constant arrays, exactly the look-up
    tables its live part reads, in the order ``lamella_arrays.h`` reads them, and reads no file; an
    exported one (tables="files") reads the same tables from EXR files in lut_dir."""
    import re

    from lamella.core import luts
    from lamella.core.backends.osl.emit import osl_shader, table_array

    stack = suite.load("gold_coated")
    files = osl_shader(stack, live=["coat0_roughness"])
    inline = osl_shader(stack, live=["coat0_roughness"], tables="inline")
    assert files.tables and "lut_dir" in files.source and "texture(" in files.source
    assert not inline.tables and "lut_dir" not in inline.source and "texture(" not in inline.source
    read = {name for name, spec in luts.SPECS.items()
            if spec.file in files.tables or luts.PACKED.get(name) in files.tables}
    arrays = dict(re.findall(r"float LUT_(\w+)\[\d+\] = \{([^}]*)\}", inline.source))
    assert set(arrays) == read
    for name, values in arrays.items():
        np.testing.assert_array_equal(np.array(values.split(", "), dtype=np.float32), table_array(name))
    t = luts.table("tir")  # slices along the last axis, one after the other
    assert table_array("tir")[t.shape[0] * t.shape[1] + 3] == t[0, 3, 1]
    nothing_live = osl_shader(stack, tables="inline")
    assert "LUT_" not in nothing_live.source and "lamella_arr" not in nothing_live.source
    with pytest.raises(ValueError, match="tables must be"):
        osl_shader(stack, tables="textures")


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
    # every lobe that carries light: the light no medium scattered (yamaguchi_refined's lobes: the
    # base's and its multiple scattering), the scattered families (forward, backward, forward
    # scattered once) and the medium's back-scattered one, the scattered light broader than a GGX
    # lobe; the fog's interface (index 1) reflects nothing, and a lobe of no energy at any view
    # adds no closure
    lobes = staging.stage(stack, budget="all")
    assert len(lobes.closures) == 8 and lobes.lobes_all == 10
    assert len(staging.stage(stack, budget=4).closures) <= 4
    assert lobe_budget.parse("3") == 3
    with pytest.raises(ValueError):
        lobe_budget.parse(9)


@pytest.mark.parametrize("case", ["rotated_60", "opposing_anisotropy"])
def test_an_azimuth_the_table_does_not_vary_with_is_dropped(case):
    """Anisotropic stacks whose lobe energies and roughness tensors depend on the elevation alone
    get a one-azimuth table; the shader equals the one staged on the full (elevation, azimuth) grid.
    (The EEVEE stand-ins depend on the azimuth: with them the table has azimuths and the shaders
    read the rest along the elevation alone, ``test_eevee_stand_ins.py``.)"""
    stack = suite.load(case)
    st = staging.stage(stack, budget="all", stand_ins=0)
    full = staging.stage(stack, budget="all", grid=staging.ViewGrid(staging.N_MU, staging.N_PHI))
    assert st.frame == full.frame == "shading"
    assert st.table.shape[1] == 1 and full.table.shape[1] == staging.N_PHI
    assert "atan2" not in {e.op for e in st.tracer.nodes}
    for theta, phi in ((0.0, 0.0), (35.0, 0.7), (70.0, 2.9)):
        wi = suite.incident(theta, phi)
        wo, _ = suite.wo_grid(wi)
        a = evaluate_staged(st, wi, wo, dtype=np.float64)
        b = evaluate_staged(full, wi, wo, dtype=np.float64)
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("case", ["gold_coated", "rotated_60", "fog_g09_d1", "varnished_wood", "rough_glass_plate"])
def test_a_value_edit_reuses_the_trace_and_stages_as_a_fresh_trace(case):
    """Stacks of one structure share their traced graph (``closures.structure_of``): a value edit
    does not trace again, and what it stages is what a fresh trace stages."""
    from lamella.core.backends.ir import closures
    from lamella.core.backends.osl.emit import emit_osl

    d = suite.load(case).to_dict()
    edited = json.loads(json.dumps(d))
    edited["layers"][0]["ior"] = 1.37
    edited["base"] = {**edited["base"], **{k: [0.9 * x for x in v] for k, v in edited["base"].items()
                                            if k in ("eta", "albedo")}}
    closures._TRACES.clear()
    first = closures.trace_closures(Stack.from_dict(d))
    again = closures.trace_closures(Stack.from_dict(edited))
    assert all(a.weight is b.weight and a.args is b.args for a, b in zip(again.closures, first.closures))
    assert len(again.closures) == len(first.closures) and again.tracer.defaults != first.tracer.defaults
    cached = emit_osl(Stack.from_dict(edited))
    closures._TRACES.clear()
    assert emit_osl(Stack.from_dict(edited)) == cached
    r = edited["layers"][0]["roughness"]
    flipped = [0.1, 0.1] if r[0] != r[1] else [0.1, 0.2]  # isotropic <-> anisotropic: another structure
    other = dict(edited, layers=[dict(edited["layers"][0], roughness=flipped)] + edited["layers"][1:])
    assert closures.structure_of(Stack.from_dict(other)) != closures.structure_of(Stack.from_dict(edited))


@pytest.mark.parametrize("case, field", [("gold_coated", "roughness"), ("rotated_60", "roughness"), ("fog_g09_d1", "g")])
def test_a_value_edit_re_evaluates_what_it_reaches_and_stages_as_from_scratch(case, field):
    """Staging keeps the last evaluation of the model on the grid: an edit re-evaluates only the
    nodes the changed parameter reaches (from the second edit of that parameter on, as compiled
    code). Each table of a slider drag equals the one staged from nothing."""
    from lamella.core.backends.ir.closures import trace_closures

    d = suite.load(case).to_dict()
    r = d["layers"][0][field]
    staging._EVALUATED.clear()
    # another test may have dragged the same structure already: start from its first edit
    trace_closures(Stack.from_dict(d)).tracer.memo("plans", dict).clear()
    staging.stage(Stack.from_dict(d))
    for k in range(4):  # a field of the top coat dragged (both values of an anisotropic roughness)
        f = 0.9 - 0.1 * k
        d["layers"][0][field] = [x * f for x in r] if isinstance(r, list) else r * f
        stack = Stack.from_dict(d)
        kept = staging._EVALUATED["env"]
        edited = staging.stage(stack)
        assert staging._EVALUATED["env"] is kept  # reused, not evaluated afresh
        plans = trace_closures(stack).tracer.memo("plans", dict)
        assert any(p.get("code") is not None for p in plans.values()) == (k >= 1)
        staging._EVALUATED.clear()
        fresh = staging.stage(stack)
        assert edited.merged == fresh.merged
        np.testing.assert_array_equal(edited.table, fresh.table)


def test_the_azimuth_probe_keeps_what_varies_with_the_azimuth():
    """``_azimuth_free`` drops the azimuth only where no value depends on it."""
    from lamella.core.backends.ir.trace import Tracer

    t = Tracer()
    x, y, z = (t.input(n) for n in staging.VIEW_INPUTS)
    grid = staging.ViewGrid(staging.N_MU, 1)
    assert staging._azimuth_free(t, grid, [x * 2.0]) is None
    assert staging._azimuth_free(t, grid, [z * 2.0, x * 0.0 + 1.0]) is not None
    on_grid = staging._azimuth_free(t, grid, [z * 3.0])
    np.testing.assert_array_equal(on_grid([z * 3.0])[0], grid.directions()[:, 0, 2] * 3.0)


def test_every_lobe_normaliser_depends_on_the_view_elevation_alone():
    """A baked lobe's closure weight is its energy times its kind's normaliser at the view
    (``scale_of_args``); where the table drops the azimuth that normaliser is taken at phi = 0,
    so no lobe kind's may depend on the view's azimuth."""
    from lamella.core import lobe_kinds
    from lamella.core.backends.numpy_ops import NumpyOps

    ops = NumpyOps(np.float64)
    rng = np.random.default_rng(7)
    theta = rng.uniform(0.0, 1.4, 64)
    for kind in lobe_kinds.KINDS.values():
        args = {"ax": rng.uniform(0.05, 0.8, 64), "ay": rng.uniform(0.05, 0.8, 64), "alpha": rng.uniform(0.05, 0.8, 64),
                "cos": np.ones(64), "sin": np.zeros(64), "nx": np.zeros(64), "ny": np.zeros(64), "nz": -np.ones(64),
                "eta": np.full(64, 1.5), "albedo": rng.uniform(0.5, 1.0, 64)}
        values = []
        for phi in (0.0, 1.0, 2.6):
            wi = (np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta))
            values.append(np.broadcast_to(kind.scale_of_args(ops, args, wi), theta.shape))
        np.testing.assert_allclose(values[1], values[0], rtol=1e-12, err_msg=kind.name)
        np.testing.assert_allclose(values[2], values[0], rtol=1e-12, err_msg=kind.name)


def test_roughness_tensor_functions_in_closed_form_match_an_eigen_solver():
    """The lobe budget's symmetric 2 x 2 tensors (xx, xy, yy) are decomposed in closed form;
    the log, power and exponential of a tensor match numpy's eigen-solver."""
    rng = np.random.default_rng(11)
    ax, ay = rng.uniform(1e-3, 1.0, 200), rng.uniform(1e-3, 1.0, 200)
    ang = rng.uniform(-np.pi, np.pi, 200)
    c, s = np.cos(ang), np.sin(ang)
    t = (ax * c * c + ay * s * s, (ax - ay) * c * s, ax * s * s + ay * c * c)
    m = np.stack([np.stack([t[0], t[1]], -1), np.stack([t[1], t[2]], -1)], -2)
    w, v = np.linalg.eigh(m)
    for fn in (np.log, np.sqrt, np.exp):
        want = v @ (fn(w)[..., None] * np.swapaxes(v, -1, -2))
        got = lobe_budget._tensor_fn(t, fn)
        np.testing.assert_allclose(got[0], want[:, 0, 0], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(got[1], want[:, 0, 1], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(got[2], want[:, 1, 1], rtol=1e-9, atol=1e-12)
    from lamella.core import lobe_kinds

    args = lobe_budget._args_of_tensor(lobe_kinds.KINDS["reflection"], t)
    np.testing.assert_allclose(args["ax"], np.maximum(ax, ay), rtol=1e-9)
    np.testing.assert_allclose(args["ay"], np.minimum(ax, ay), rtol=1e-9)


def _eight_coats_with_media() -> Stack:
    d = suite.example("four_coats").to_dict()
    dust = {"type": "coat", "ior": 1.0, "thickness": 0.3, "sigma_a": [0.1, 0.11, 0.13], "sigma_s": [1.5, 1.5, 1.5],
            "g": 0.3}
    d["layers"] = [dust] + [dict(c, thickness=0.5, sigma_a=[0.1, 0.2, 0.3]) for c in d["layers"]] + d["layers"][:3]
    return Stack.from_dict(d)


def test_live_lobes_merge_as_far_as_the_closure_cap_requires_and_follow_their_inputs():
    """38 lobes that read linked inputs (two coat roughnesses and the base colour) merge, traced,
    into at most MAX_CLOSURES closures; the shader follows its inputs: at other input values it
    equals the model of the stack with those values (relative L1 < 1 %). Fewer live lobes than
    the cap stay unmerged."""
    stack = _eight_coats_with_media()
    live = ["coat0_roughness", "coat1_roughness_x", "base_eta"]
    st = staging.stage(stack, live=live)
    assert st.lobes_all == 38 and len(st.closures) <= lobe_budget.MAX_CLOSURES
    assert any(len(m) > 1 for m in st.merged)
    d = stack.to_dict()
    d["layers"][1]["roughness"] = [d["layers"][1]["roughness"][0] * 2.5, d["layers"][1]["roughness"][1]]
    d["base"]["eta"] = [x * 0.7 for x in d["base"]["eta"]]
    edited = Stack.from_dict(d)
    values = staging.stage(edited, live=live, budget="all").params
    for theta in (0.0, 40.0, 70.0):
        wi = suite.incident(theta)
        wo, _ = suite.wo_grid(wi)
        want = api.evaluate(edited, wi, wo)
        got = evaluate_staged(st, wi, wo, np.float64, values=values)
        assert np.abs(got - want).sum() / np.abs(want).sum() < 0.01, theta
    few = staging.stage(suite.example("four_coats"), live=["coat0_roughness_x", "coat1_roughness", "base_eta"])
    assert few.lobes_all == len(few.closures)


def test_a_kept_grouping_is_the_merge_of_the_same_lobes_and_is_dropped_where_it_does_not_fit():
    """``stage(partition=...)``, what a dragged slider's edits use: the same grouping merged at
    the lobes' new values, equal to the automatic budget's shader where that grouping is what the
    budget picks; a grouping that does not fit the stack's lobes is ignored."""
    stack = suite.load("green_scatter_d6")
    st = staging.stage(stack)
    kept = staging.stage(stack, partition=st.merged)
    assert kept.merged == st.merged and kept.structure_key() == st.structure_key()
    np.testing.assert_array_equal(kept.table, st.table)
    d = stack.to_dict()
    d["layers"][0]["roughness"] = 0.015625
    other = staging.stage(Stack.from_dict(d)).merged
    assert other != st.merged
    assert staging.stage(stack, partition=other).merged == other  # kept, though the budget would regroup
    for wrong in ([[0, 1]], [[0, 0, 1, 2, 3, 4, 5]], [[i] for i in range(st.lobes_all + 1)]):
        assert staging.stage(stack, partition=wrong).merged == st.merged
