"""The one-model rule: model code uses only the ops it is handed, so it traces into a finite
expression graph for every stack kind, and that graph reproduces the numpy backend bit for bit."""
import ast
from pathlib import Path

import numpy as np
import pytest

import lamella.core as lc
import lamella.core.models as models_pkg
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.backends.ir.trace import Expr, Tracer
from lamella.core.lobe_kinds import eval_lobes_cos
from lamella.core.models import run_model

from .stacks import coat, gold, stack

MODELS = list(models_pkg.VARIANTS)  # the adding-doubling family, as registered


def test_model_modules_never_import_numpy():
    for path in Path(models_pkg.__file__).parent.glob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            else:
                continue
            assert not any(n.split(".")[0] in ("numpy", "scipy") for n in names), f"{path.name} imports {names}"


KINDS = {
    "conductor only": stack(base=gold([0.1, 0.05], 0.3)),
    "smooth coat": stack(coat(1.5)),
    "rough coat": stack(coat(1.5, 0.1), base=gold(0.1)),
    "absorbing coat": stack(coat(1.5, 0.2, thickness=1.0, sigma_a=(0.1, 0.5, 0.9)), base=gold(0.05)),
    "rotated anisotropic": stack(coat(1.49, [0.1, 0.01], rotation=0.5), base=gold([0.01, 0.05], 1.0)),
    "index below 1": stack(coat(1.4, 0.1), coat(1.0, 0.01), coat(0.9, 0.1), base=gold(0.0)),
    "eight coats": stack(*[coat(1.2 + 0.05 * i, 0.02 * i, thickness=0.1 * i, sigma_a=(0.1, 0.0, 0.2))
                            for i in range(8)], base=gold(0.2)),
}


def trace(d, model):
    t = Tracer()
    wi = tuple(t.input(n) for n in ("wi_x", "wi_y", "wi_z"))
    wo = tuple(t.input(n) for n in ("wo_x", "wo_y", "wo_z"))
    lobes = run_model(t, lc.Stack.from_dict(d), wi, model)
    return t, wi, wo, lobes, list(eval_lobes_cos(t, lobes, wi, wo))


def random_dirs(n, seed):
    w = np.random.default_rng(seed).normal(size=(n, 3))
    w[:, 2] = np.abs(w[:, 2])
    return w / np.linalg.norm(w, axis=1, keepdims=True)


def assert_graph_is_numpy(t, outputs, d, model, wi, wo):
    """The traced graph evaluated on numpy at its parameters' defaults equals ``lc.evaluate`` bit
    for bit at the directions ``wi``, ``wo`` (N, 3)."""
    values = dict(t.defaults)
    values.update({f"wi_{c}": wi[:, k] for k, c in enumerate("xyz")})
    values.update({f"wo_{c}": wo[:, k] for k, c in enumerate("xyz")})
    got = np.stack(t.evaluate(outputs, NumpyOps(), values), -1)
    np.testing.assert_array_equal(got, lc.evaluate(d, wi, wo, model))


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("kind", list(KINDS))
def test_traces_to_a_finite_graph_equal_to_numpy(kind, model):
    d = KINDS[kind]
    t, wi, wo, lobes, outputs = trace(d, model)
    assert all(isinstance(o, Expr) for o in outputs)
    live = t.live_nodes(outputs)
    assert 0 < len(live) < 20000
    assert set(t.inputs) == {"wi_x", "wi_y", "wi_z", "wo_x", "wo_y", "wo_z"}
    n_coats = len(d["layers"])
    assert len(lobes) == n_coats + 2  # one per interface, and what the conductor scatters more than once
    assert lobes[-1].kind == "diffuse"
    # every per-layer parameter is a graph input, not a literal
    assert {f"coat{i}_ior" for i in range(n_coats)} <= set(t.params)
    assert {"base_eta_r", "base_k_b"} <= set(t.params)
    ax, ay = lc.Stack.from_dict(d).base.roughness
    expected = {"base_alpha"} if ax == ay else {"base_alpha_x", "base_alpha_y", "base_rotation"}
    assert {p for p in t.params if p.startswith("base_") and "alpha" in p or p == "base_rotation"} == expected
    absorbing = {i for i, c in enumerate(d["layers"]) if c["thickness"] > 0 and max(c["sigma_a"]) > 0}
    assert {int(p[4]) for p in t.params if p.endswith("_thickness")} == absorbing
    assert_graph_is_numpy(t, outputs, d, model, random_dirs(64, 1), random_dirs(64, 2))


OTHER_BASES = {
    "scattering coat over diffuse": stack(dict(coat(1.4, 0.2, thickness=0.5), sigma_s=[1.0, 2.0, 3.0], g=0.3),
                                          base={"type": "diffuse", "albedo": [0.6, 0.4, 0.2]}),
    "coat over glass": stack(coat(1.5, 0.1), base={"type": "dielectric", "ior": 1.3, "roughness": 0.2}),
}


@pytest.mark.parametrize("model", list(lc.MODELS))
@pytest.mark.parametrize("kind", [*KINDS, *OTHER_BASES])
def test_every_registered_model_traces_to_numpy_bit_for_bit(kind, model):
    """The one-model rule for every model in the registry (a new one is checked by being
    registered), on every stack kind it represents."""
    d = {**KINDS, **OTHER_BASES}[kind]
    try:
        t, wi, wo, lobes, outputs = trace(d, model)
    except lc.UnsupportedStack as e:
        pytest.skip(str(e))
    assert_graph_is_numpy(t, outputs, d, model, random_dirs(32, 3), random_dirs(32, 4))


def test_unused_features_cost_nothing():
    """A clear isotropic one-coat stack traces to a smaller graph than the same stack with
    absorption, anisotropy and more coats: structure that is absent emits no code."""
    sizes = {}
    for name, d in [("clear", stack(coat(1.5, 0.1), base=gold(0.1))),
                    ("absorbing", stack(coat(1.5, 0.1, thickness=1.0, sigma_a=(0.1, 0.2, 0.3)), base=gold(0.1))),
                    ("four coats", stack(*[coat(1.5, 0.1)] * 4, base=gold(0.1)))]:
        t, *_, outputs = trace(d, "yamaguchi2019")
        sizes[name] = len(t.live_nodes(outputs))
    assert sizes["clear"] < sizes["absorbing"] < sizes["four coats"]
    t, *_, outputs = trace(stack(coat(1.5, 0.1), base=gold(0.1)), "yamaguchi2019")
    assert not any(p.endswith("thickness") or "sigma_a" in p for p in t.params)


def test_traced_values_refuse_python_control_flow():
    t = Tracer()
    x = t.input("x")
    with pytest.raises(TypeError, match="ops.select"):
        if x > 0.0:
            pass


def test_constants_fold_and_subexpressions_are_shared():
    t = Tracer()
    x = t.input("x")
    assert t.sqrt(4.0) == 2.0
    assert (x * 1.0) is x and (x + 0.0) is x
    a = t.sqrt(x * x + 1.0)
    b = t.sqrt(x * x + 1.0)
    assert a is b
    assert len(t.live_nodes([a])) == 4  # input, mul, add, sqrt


@pytest.mark.parametrize("model", ["weier2020", "yamaguchi2019"])
def test_isotropic_stack_traces_without_anisotropy_code(model):
    """Skip what the stack does not need: isotropic layers become one roughness input, and no
    rotation, covariance or eigen-decomposition survives in the graph (they fold away)."""
    t, wi, wo, lobes, outputs = trace(KINDS["absorbing coat"], model)
    live = t.live_nodes(outputs)
    assert not [n for n in live if n.op in ("atan2", "cos", "sin")]
    assert not [p for p in t.params if "rotation" in p or p.endswith(("_alpha_x", "_alpha_y"))]
    for lobe in lobes:
        assert lobe.alpha_x is lobe.alpha_y
        assert lobe.rotation == 0.0
    # the anisotropic stack keeps them
    t, wi, wo, lobes, outputs = trace(KINDS["rotated anisotropic"], model)
    assert [n for n in t.live_nodes(outputs) if n.op in ("cos", "sin")]


@pytest.mark.parametrize("case,model", [("fog_g03", "tm6"), ("milky_coat_d2", "tm6"), ("varnished_wood", "auto"),
                                        ("varnished_wood", "tm2"), ("rough_glass_plate", "auto"),
                                        ("rough_glass_plate", "tm2"), ("gold_coated", "endf"),
                                        ("rough_glass_plate", "endf")])
def test_media_and_new_bases_trace_equal_to_numpy(case, model):
    """The transfer-matrix and ENDF models, the diffuse base and the transmission lobe trace like the rest:
    a finite graph, equal to the numpy backend (lower-hemisphere wo for the glass base)."""
    from lamella_dev import suite
    from lamella.core.models import resolve

    st = suite.load(case)
    t = Tracer()
    wi = tuple(t.input(n) for n in ("wi_x", "wi_y", "wi_z"))
    wo = tuple(t.input(n) for n in ("wo_x", "wo_y", "wo_z"))
    lobes = resolve(model, st).run(t, st, wi)
    outputs = list(eval_lobes_cos(t, lobes, wi, wo))
    assert all(isinstance(o, Expr) for o in outputs)
    wi_np, wo_np = random_dirs(64, 3), random_dirs(64, 4)
    if st.base.type == "dielectric":
        wo_np[::2, 2] *= -1.0
    values = dict(t.defaults)
    values.update({f"wi_{c}": wi_np[:, k] for k, c in enumerate("xyz")})
    values.update({f"wo_{c}": wo_np[:, k] for k, c in enumerate("xyz")})
    got = np.stack(t.evaluate(outputs, NumpyOps(), values), -1)
    np.testing.assert_array_equal(got, lc.evaluate(st, wi_np, wo_np, model))


def test_a_compiled_plan_evaluates_as_the_graph_walk():
    """``Tracer.evaluate`` with a plan runs compiled straight-line code from the plan's second
    call on: equal to walking the graph, and where the values it took as known are missing it
    walks the graph for them."""
    from lamella_dev import suite
    from lamella.core.backends.ir.closures import trace_closures

    traced = trace_closures(suite.load("fog_g09_d1"))
    t = traced.tracer
    outs = [x for c in traced.closures for x in (*c.weight, *c.args.values())]
    wi = suite.incident(50.0)
    values = dict(t.defaults)
    values.update({n: np.full(3, wi[k]) for k, n in enumerate(("wi_x", "wi_y", "wi_z"))})
    ops = NumpyOps(np.float64)
    with np.errstate(all="ignore"):
        want = t.evaluate(outs, ops, values)
        base: dict = {}
        t.evaluate(outs, ops, values, base)
        stale = t.reached_by(["coat0_ior"])
        for run in range(3):
            env = {k: v for k, v in base.items() if k not in stale}
            got = t.evaluate(outs, ops, values, env, plan=("test", True))
            for a, b in zip(got, want):
                np.testing.assert_array_equal(a, b)
        assert t.memo("plans", dict)[("test", True)].get("code") is not None
        # a value the plan takes as known (an argument of a node it evaluates) missing
        known = next(id(a) for e in t.nodes if id(e) in stale for a in e.args
                     if isinstance(a, Expr) and id(a) not in stale and id(a) in base)
        partial = {k: v for k, v in base.items() if k not in stale and k != known}
        got = t.evaluate(outs, ops, values, partial, plan=("test", True))
        for a, b in zip(got, want):
            np.testing.assert_array_equal(a, b)


def test_compiled_plans_are_capped_over_every_graph(monkeypatch):
    """At most ``COMPILED_KEPT`` plans hold compiled code at once; the oldest gives its code up."""
    from lamella.core.backends.ir import trace

    monkeypatch.setattr(trace, "COMPILED_KEPT", 2)
    monkeypatch.setattr(trace, "_COMPILED", [])
    t = Tracer()
    x = t.input("x")
    outs = [x * float(k) + 1.0 for k in range(2, 6)]
    ops = NumpyOps(np.float64)
    for k, o in enumerate(outs[:3]):
        for _ in range(2):
            assert t.evaluate([o], ops, {"x": np.arange(3.0)}, {}, plan=k)[0].tolist() == [1.0, k + 3.0, 2 * k + 5.0]
    plans = t.memo("plans", dict)
    assert [plans[k].get("code") is not None for k in range(3)] == [False, True, True]
