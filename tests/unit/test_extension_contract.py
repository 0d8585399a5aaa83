"""The extension contract: a new coat kind, base kind, lobe kind or traced operation is one module
(``extension_kinds``), and registering it is all the parser, the schema page, every model and
every backend (numpy, the traced graph, the OSL printer, the node plan) need. The Blender side
(properties, panel, compile and render) is ``tests/blender/test_extension_contract.py``.

The new layer kinds are built to equal built-in stacks, so the checks are exact: a tinted lacquer
of colour c is the coat of thickness 1 and absorption -ln c, an artist metal the conductor of
Gulbrandsen 2014's eta and k (``lamella.core.metals.artistic_to_complex``). Every model routes on
what a kind can do; a model that branched on type names would give the new kinds nothing (or
fail) and these tests would show it."""
import dataclasses
import json
import math

import numpy as np
import pytest

import lamella.core as lc
from lamella.core import lobe_kinds, metals, models
from lamella.core.backends.ir import lobe_budget, traced_ops
from lamella.core.backends.nodes.lower import emit_plan
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.backends.osl.emit import emit_osl
from lamella.core.backends.ir.trace import Tracer
from lamella.core.layers import BASE_KINDS, COAT_KINDS, StackError
from lamella.core.layers.schema import FLOAT, Field, layer_kind
from lamella.core.models import MODELS, UnsupportedStack
from lamella.core.param_id import ParamId

from lamella_dev import suite
from lamella_dev.bench import BENCHES, Bench
from lamella_dev.bench import register as register_bench
from lamella_dev.bench import unregister as unregister_bench

from . import extension_kinds
from .extension_kinds import coat_count
from .test_node_graph import _closure_pairs, _directions
from .test_tracing import assert_graph_is_numpy, random_dirs, trace

COLOR = [0.9, 0.5, 0.2]
REFLECTIVITY, EDGE_TINT = [0.95, 0.64, 0.54], [1.0, 0.9, 0.7]  # copper-like


def lacquer(roughness=(0.15, 0.05), rotation=0.4):
    return {"type": "tinted_lacquer", "ior": 1.4, "roughness": list(roughness), "rotation": rotation, "color": COLOR}


def lacquer_as_coat(roughness=(0.15, 0.05), rotation=0.4):
    return {"ior": 1.4, "roughness": list(roughness), "rotation": rotation, "thickness": 1.0,
            "sigma_a": [-math.log(c) for c in COLOR]}


def artist_metal(roughness=0.2):
    return {"type": "artist_metal", "reflectivity": REFLECTIVITY, "edge_tint": EDGE_TINT, "roughness": roughness}


def artist_metal_as_conductor(roughness=0.2):
    eta, k = metals.artistic_to_complex(REFLECTIVITY, EDGE_TINT)
    return {"type": "conductor", "eta": list(eta), "k": list(k), "roughness": roughness}


# (new kinds, the same stack in built-in kinds)
PAIRS = {
    "lacquer over artist metal": (
        {"layers": [lacquer()], "base": artist_metal()},
        {"layers": [lacquer_as_coat()], "base": artist_metal_as_conductor()}),
    "isotropic lacquer over artist metal": (
        {"layers": [lacquer((0.1, 0.1), 0.0)], "base": artist_metal(0.1)},
        {"layers": [lacquer_as_coat((0.1, 0.1), 0.0)], "base": artist_metal_as_conductor(0.1)}),
    "lacquer among coats over glass": (
        {"layers": [{"ior": 1.3, "roughness": 0.05}, lacquer(), {"ior": 1.6, "thickness": 0.5, "sigma_s": 1.0}],
         "base": {"type": "dielectric", "ior": 1.5, "roughness": 0.1}},
        {"layers": [{"ior": 1.3, "roughness": 0.05}, lacquer_as_coat(), {"ior": 1.6, "thickness": 0.5, "sigma_s": 1.0}],
         "base": {"type": "dielectric", "ior": 1.5, "roughness": 0.1}}),
    "artist metal alone": ({"layers": [], "base": artist_metal([0.3, 0.1])},
                           {"layers": [], "base": artist_metal_as_conductor([0.3, 0.1])}),
}


@pytest.fixture(scope="module", autouse=True)
def extension():
    extension_kinds.register()
    yield
    extension_kinds.unregister()


# ---------------------------------------------------------------- layer kinds
def test_registering_adds_the_kinds_and_unregistering_removes_them():
    assert "tinted_lacquer" in COAT_KINDS and "artist_metal" in BASE_KINDS
    assert "translucent" in lobe_kinds.KINDS and "absorbance" in traced_ops.OPS and "split_diffuse" in MODELS
    assert "coat-count" in BENCHES
    extension_kinds.unregister()
    try:
        assert "tinted_lacquer" not in COAT_KINDS and "artist_metal" not in BASE_KINDS
        assert "translucent" not in lobe_kinds.KINDS and "absorbance" not in traced_ops.OPS
        assert "split_diffuse" not in MODELS and "coat-count" not in BENCHES
        assert not hasattr(Tracer(), "absorbance")
        with pytest.raises(StackError, match="tinted_lacquer"):
            lc.Stack.from_dict(PAIRS["lacquer over artist metal"][0])
    finally:
        extension_kinds.register()


def test_parsing_round_trips_and_bad_values_name_the_layer_and_field():
    new, _ = PAIRS["lacquer over artist metal"]
    s = lc.Stack.from_dict(new)
    assert s.coats[0].type == "tinted_lacquer" and s.base.type == "artist_metal"
    assert lc.Stack.from_dict(s.to_dict()) == s
    assert lc.Stack.from_json(s.to_json()) == s
    with pytest.raises(StackError) as e:
        lc.Stack.from_dict({"layers": [dict(lacquer(), color=[0.5, 0.0, 0.5])], "base": artist_metal()})
    assert (e.value.layer, e.value.field) == ("coat 0", "color")
    with pytest.raises(StackError) as e:
        lc.Stack.from_dict({"layers": [], "base": dict(artist_metal(), reflectivity=1.0)})
    assert (e.value.layer, e.value.field) == ("base", "reflectivity")
    with pytest.raises(StackError, match="unknown key"):
        lc.Stack.from_dict({"layers": [dict(lacquer(), sigma_a=1.0)], "base": artist_metal()})


def test_the_stack_format_page_documents_the_new_kinds():
    from lamella_dev import stack_format_page

    page = stack_format_page.render()
    assert "`tinted_lacquer`" in page and "`artist_metal`" in page
    assert "colour of white light after one pass through the lacquer" in page
    assert "colour toward grazing angles" in page


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("model", [m for m in MODELS if m != "split_diffuse"])
@pytest.mark.parametrize("pair", list(PAIRS))
def test_every_model_renders_the_new_kinds_as_their_built_in_equals(pair, model, dtype):
    new, built_in = PAIRS[pair]
    wi = random_dirs(24, 1)
    try:
        want = lc.lobes(built_in, wi, model, dtype=dtype)
    except UnsupportedStack:
        with pytest.raises(UnsupportedStack):
            lc.lobes(new, wi, model, dtype=dtype)
        pytest.skip(f"{model} does not represent {pair}")
    got = lc.lobes(new, wi, model, dtype=dtype)
    assert got.kinds == want.kinds
    # the lacquer's absorption is -ln c computed in the shader's precision, the metal's eta and k
    # from the colours there: the same stack up to the rounding of those parameters
    tol = 2e-4 if dtype == np.float32 else 1e-9
    for name in ("weight", "alpha_x", "alpha_y"):
        np.testing.assert_allclose(getattr(got, name), getattr(want, name), rtol=tol, atol=tol, err_msg=name)
    wo = random_dirs(24, 2)
    np.testing.assert_allclose(lc.evaluate(new, wi, wo, model, dtype=dtype),
                               lc.evaluate(built_in, wi, wo, model, dtype=dtype), rtol=10 * tol, atol=10 * tol)


@pytest.mark.parametrize("model", [m for m in MODELS if m != "split_diffuse"])
@pytest.mark.parametrize("pair", list(PAIRS))
def test_the_new_kinds_trace_to_numpy_bit_for_bit(pair, model):
    new, _ = PAIRS[pair]
    try:
        t, wi, wo, lobes, outputs = trace(new, model)
    except UnsupportedStack:
        pytest.skip(f"{model} does not represent {pair}")
    lacquers = [i for i, c in enumerate(new["layers"]) if c.get("type") == "tinted_lacquer"]
    assert all(f"coat{i}_color_r" in t.params for i in lacquers)  # the colour is a shader input
    assert_graph_is_numpy(t, outputs, new, model, random_dirs(32, 3), random_dirs(32, 4))


def test_the_osl_shader_reads_the_new_fields_and_prints_the_operation():
    new, _ = PAIRS["lacquer over artist metal"]
    traced = emit_osl(new, staged=False)
    for name in ("coat0_color_r", "base_reflectivity_g", "base_edge_tint_b"):
        assert f"float {name} = " in traced
    assert "(-log(" in traced  # the absorbance, printed by its own table entry
    staged = emit_osl(new)  # the staged shader: every field is a socket of the schema's type
    assert "    color coat0_color = color(0.9, 0.5, 0.2)," in staged
    assert "    color base_edge_tint = color(1.0, 0.9, 0.7)," in staged


@pytest.mark.parametrize("staged", [True, False], ids=["staged", "traced"])
@pytest.mark.parametrize("pair", list(PAIRS))
def test_the_node_plan_of_the_new_kinds_equals_the_traced_model(pair, staged):
    new, _ = PAIRS[pair]
    plan = emit_plan(lc.Stack.from_dict(new), staged=staged)
    values = dict(_directions(grazing=False), **plan.params)
    for _, color, args in _closure_pairs(plan, values):
        for want, got in (*color, *args):
            assert np.abs(got - want).max() <= 1e-4 * max(1.0, np.abs(want).max())
    if not staged and new["layers"] and new["layers"][0].get("type") == "tinted_lacquer":
        # the absorbance lowered to its own nodes: LOGARITHM then a multiplication by -1
        assert any(n.props.get("operation") == "LOGARITHM" for n in plan.nodes)


# ---------------------------------------------------------------- a lobe kind
DIFFUSER = {"layers": [{"ior": 1.5, "roughness": 0.1}], "base": {"type": "diffuse", "albedo": [0.8, 0.6, 0.4]}}


def test_a_model_emitting_the_new_lobe_kind_is_evaluated_through_its_table():
    wi = random_dirs(8, 5)
    lobes = lc.lobes(DIFFUSER, wi, "split_diffuse")
    k = lobes.kinds.index("translucent")
    assert lobes.kinds[k - 1] == "diffuse"
    np.testing.assert_array_equal(lobes.weight[:, k], lobes.weight[:, k - 1])
    below = random_dirs(8, 6) * np.array([1.0, 1.0, -1.0])
    f = lc.evaluate(DIFFUSER, wi, below, "split_diffuse")
    np.testing.assert_allclose(f, lobes.weight[:, k] * (-below[:, 2:3] / math.pi), rtol=1e-12)
    # the reflected side lost exactly that half
    above = random_dirs(8, 7)
    np.testing.assert_allclose(lc.evaluate(DIFFUSER, wi, above, "yamaguchi2019")
                               - lc.evaluate(DIFFUSER, wi, above, "split_diffuse"),
                               lobes.weight[:, k] * (above[:, 2:3] / math.pi), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(lc.albedo(DIFFUSER, wi, "split_diffuse", side="transmitted"), lobes.weight[:, k],
                               rtol=1e-9)


def test_the_new_lobe_kind_prints_builds_and_is_never_merged():
    osl = emit_osl(DIFFUSER, "split_diffuse", budget=1)
    assert "translucent(Normal)" in osl and "diffuse(Normal)" in osl  # one closure each, even at budget 1
    plan = emit_plan(lc.Stack.from_dict(DIFFUSER), "split_diffuse")
    assert sorted(b.bl_idname for b in plan.bsdfs if b.bl_idname != "ShaderNodeBsdfAnisotropic") == [
        "ShaderNodeBsdfDiffuse", "ShaderNodeBsdfTranslucent"]
    assert "translucent" not in lobe_budget.MERGEABLE


# ---------------------------------------------------------------- a traced operation
def test_the_traced_operation_folds_keeps_the_precision_and_prints():
    t = Tracer()
    assert t.absorbance(0.25) == pytest.approx(math.log(4.0), rel=1e-15)  # numbers fold at trace time
    assert t.absorbance(0.0).op == "absorbance"  # not finite: the node stays for the backends
    x = np.array([0.5, 1e-4, 1.0], np.float32)
    ops = NumpyOps(np.float32)
    y = ops.absorbance(x)
    assert y.dtype == np.float32
    np.testing.assert_array_equal(y, -np.log(x))
    p = t.param(ParamId(0, "p"), 0.5)
    e = t.absorbance(p)
    assert t.evaluate([e], NumpyOps(), {"coat0_p": np.array([0.25, 0.5])})[0].tolist() == pytest.approx(
        [math.log(4.0), math.log(2.0)], rel=1e-15)  # numpy's log against libm's
    with pytest.raises(TypeError, match="ParamId"):
        t.param("coat0_p", 0.5)  # a parameter says what it is


def _no(*args):
    return None


def test_registries_refuse_clashes_and_incomplete_kinds():
    with pytest.raises(ValueError, match="registered already"):
        lc.layers.register(COAT_KINDS["tinted_lacquer"])
    with pytest.raises(ValueError, match="registered already"):
        lc.layers.register(dataclasses.replace(COAT_KINDS["tinted_lacquer"], role="base"))  # one name, both roles
    with pytest.raises(ValueError, match="registered already"):
        traced_ops.register(traced_ops.OPS["sqrt"])
    with pytest.raises(ValueError, match="NumpyOps, Tracer has a method"):
        traced_ops.register(traced_ops.TracedOp("clamp", 3, _no, _no, "clamp", _no, "a method of the ops"))
    with pytest.raises(TypeError, match="lacks fold"):
        traced_ops.register(traced_ops.TracedOp("half", 1, _no, None, "{0} * 0.5", _no, "no folding"))
    with pytest.raises(ValueError, match="registered already"):
        lobe_kinds.register(lobe_kinds.KINDS["diffuse"])
    with pytest.raises(TypeError, match="lacks node"):
        lobe_kinds.register(dataclasses.replace(lobe_kinds.KINDS["diffuse"], name="unbuilt", node=None))
    with pytest.raises(ValueError, match="registered already"):
        models.register(MODELS["tm6"])
    with pytest.raises(TypeError, match="lacks run"):
        models.register(type("Runless", (), {"name": "runless"})())
    with pytest.raises(ValueError, match="'auto'"):
        models.register(type("Auto", (), {"name": "auto", "run": _no})())
    assert not {"half", "clamp"} & set(traced_ops.OPS) and not {"runless", "auto"} & set(MODELS)
    f = Field("ior", FLOAT, 1.5, "index", lo=1.0, hi=2.0)
    with pytest.raises(ValueError, match="'roughness' and 'rotation'"):
        layer_kind("no_interface_coat", "coat", "C", (f,), "doc", lambda *a: {})
    with pytest.raises(ValueError, match="needs a response"):
        layer_kind("mute_base", "base", "B", (f,), "doc", lambda *a: {}, interface=False)
    with pytest.raises(ValueError, match="transmitting"):
        layer_kind("leaky_base", "base", "B", (f,), "doc", lambda *a: {}, lambda *a: None, interface=False,
                   transmits=True)


def test_the_stochastic_reference_refuses_kinds_it_has_no_walk_for():
    """The reference judges the models, so it knows each kind's physics itself instead of reading
    the kinds' responses: a new kind has no reference until its walk is written, and says so."""
    from lamella_dev import reference

    wi = random_dirs(2, 8)
    with pytest.raises(ValueError, match="coat 0: the stochastic reference has no walk for 'tinted_lacquer'"):
        reference.albedo(PAIRS["lacquer over artist metal"][0], wi, spp=16)
    with pytest.raises(ValueError, match="base: the stochastic reference has no walk for 'artist_metal'"):
        reference.albedo(PAIRS["artist metal alone"][0], wi, spp=16)
    assert reference.albedo(PAIRS["artist metal alone"][1], wi, spp=16)[0].shape == (2, 3)


# ---------------------------------------------------------------- benchmarks
def test_a_new_bench_is_a_lamella_bench_command_and_writes_its_page(tmp_path, capsys):
    """``coat_count`` registered: ``lamella bench`` lists it with its description and runs it with its
    own option; its page and data come out of ``write_page``; unregistered, the command is gone."""
    from lamella_dev.cli import main

    assert BENCHES["coat-count"] is coat_count.BENCH
    with pytest.raises(SystemExit) as e:
        main(["bench", "--help"])
    assert e.value.code == 0 and "coat-count" in capsys.readouterr().out
    assert main(["bench", "list"]) == 0
    listed = {line.split()[0]: line.split(None, 1)[1] for line in capsys.readouterr().out.splitlines()}
    assert listed["coat-count"] == coat_count.BENCH.description

    cases = ["gold_coated", "three_coats", "fog_g09_d1"]
    out = tmp_path / "pages"
    assert main(["bench", "coat-count", "--cases", ",".join(cases), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    page, data = out / "coat_count.md", out / "coat_count.json"
    text = page.read_text(encoding="utf-8")
    assert text.startswith("# Coats per suite stack\n") and text.endswith("|\n")  # one newline at the end
    assert text in printed and f"wrote {page} and {data}" in printed
    stacks = {n: suite.load(n) for n in cases}
    assert json.loads(data.read_text()) == {"stacks": {
        n: {"coats": len(s.coats), "scattering": sum(max(c.sigma_s) > 0 for c in s.coats)} for n, s in stacks.items()}}
    assert f"| three_coats | {len(stacks['three_coats'].coats)} | 0 |" in text

    coat_count.unregister()
    try:
        assert "coat-count" not in BENCHES
        with pytest.raises(SystemExit) as e:
            main(["bench", "coat-count", "--out", str(out)])
        assert e.value.code == 2 and "invalid choice: 'coat-count'" in capsys.readouterr().err
        assert main(["bench", "list"]) == 0 and "coat-count" not in capsys.readouterr().out
    finally:
        coat_count.register()


def test_the_bench_registry_refuses_clashes_and_incomplete_benches():
    def run(out_dir, args):
        return out_dir

    with pytest.raises(ValueError, match="'energy' is registered already"):
        register_bench(Bench("energy", "another energy bench", run))
    with pytest.raises(ValueError, match="'coat-count' is registered already"):
        coat_count.register()
    for bench, message in [(Bench("", "a bench", run), "needs a name"),
                           (Bench("two words", "a bench", run), "one word"),
                           (Bench("--out", "a bench", run), "one word"),
                           (Bench("list", "a bench", run), "the command's own"),
                           (Bench("mute", "", run), "one line"),
                           (Bench("wordy", "two\nlines", run), "one line"),
                           (Bench("idle", "a bench", None), "run is a function"),
                           (Bench("odd", "a bench", run, arguments="--fast"), "arguments is a function")]:
        with pytest.raises(ValueError, match=message):
            register_bench(bench)
        assert bench.name not in BENCHES
    with pytest.raises(ValueError, match="takes a Bench"):
        register_bench(("energy2", "a tuple", run))
    energy = BENCHES["energy"]
    unregister_bench(Bench("energy", "another energy bench", run))  # not the one registered: it stays
    unregister_bench("no-such-bench")
    assert BENCHES["energy"] is energy
    with pytest.raises(TypeError):
        BENCHES["energy"] = Bench("energy", "around the checks", run)  # read only: benches join by register
