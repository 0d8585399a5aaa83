"""Coverage: a coat on a fraction c of the surface is the mix c (stack with it) + (1 - c) (stack
without it), for every model, in ``evaluate`` and ``albedo``, to float precision; several partly
covering coats cover independently; the shaders follow a linked mask; the reference mixes its
walks the same way; older stacks read as covering everything."""
import itertools
import math

import numpy as np
import pytest

from lamella.core import Stack, StackError, api, stack_format
from lamella.core.backends.evaluate import evaluate_staged
from lamella.core.backends.ir import staging
from lamella.core.backends.ir.staging import StagedOps
from lamella.core.models import MODELS, coverage
from lamella_dev import reference, suite

GOLD = {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603], "roughness": 0.2}
GLASS = {"type": "dielectric", "ior": 1.5, "roughness": 0.1}
WOOD = {"type": "diffuse", "albedo": [0.5, 0.3, 0.15]}
TINT = {"ior": 1.5, "roughness": 0.05, "thickness": 0.5, "sigma_a": [0.2, 0.8, 2.0]}
DUST = {"ior": 1.0, "roughness": 0.0, "thickness": 0.3, "sigma_s": [4.0, 4.0, 4.0], "g": 0.3}
CLEAR = {"ior": 1.5, "roughness": 0.1}

CASES = {
    "tint over gold": ([TINT], GOLD),
    "clear over glass": ([CLEAR], GLASS),
    "dust over varnish over wood": ([DUST, TINT], WOOD),
    "clear, tint, clear over gold": ([CLEAR, TINT, {"ior": 1.3, "roughness": [0.3, 0.05], "rotation": 0.4}], GOLD),
}


def _dirs(n, seed, lower=False):
    rng = np.random.default_rng(seed)
    w = rng.normal(size=(n, 3))
    w[:, 2] = np.abs(w[:, 2]) * (-1 if lower else 1)
    return w / np.linalg.norm(w, axis=1)[:, None]


def _with(coats, base, cover: dict):
    return {"layers": [{**c, "coverage": cover.get(i, 1.0)} for i, c in enumerate(coats)], "base": base}


def _without(coats, base, absent):
    return {"layers": [c for i, c in enumerate(coats) if i not in absent], "base": base}


def _evaluate(d, wi, wo, model, **kw):
    """``model``, or ``auto`` on a stack it cannot represent (a part of a stack: models.coverage)."""
    try:
        return api.evaluate(d, wi, wo, model, **kw)
    except api.UnsupportedStack:
        return api.evaluate(d, wi, wo, "auto", **kw)


def _albedo(d, wi, model, side):
    """``model``'s albedo, or ``auto``'s on a stack it cannot represent (as ``_evaluate``)."""
    try:
        return api.albedo(d, wi, model, side)
    except api.UnsupportedStack:
        return api.albedo(d, wi, "auto", side)


@pytest.mark.parametrize("model", api.MODELS)
@pytest.mark.parametrize("case", CASES)
def test_one_partly_covering_coat_is_the_mix_of_the_stacks_with_and_without_it(case, model):
    coats, base = CASES[case]
    wi, wo = _dirs(64, 1), _dirs(64, 2)
    if base is GLASS:
        wo = np.concatenate([wo, _dirs(64, 3, lower=True)])
        wi = np.concatenate([wi, wi])
    sides = ("reflected", "transmitted")
    f_full = _evaluate(_with(coats, base, {}), wi, wo, model)
    a_full = {side: _albedo(_with(coats, base, {}), wi, model, side) for side in sides}
    for i in range(len(coats)):
        f_without = _evaluate(_without(coats, base, {i}), wi, wo, model)
        a_without = {side: _albedo(_without(coats, base, {i}), wi, model, side) for side in sides}
        for c in (0.0, 0.37, 1.0):
            try:
                got = api.evaluate(_with(coats, base, {i: c}), wi, wo, model)
            except api.UnsupportedStack:
                continue  # the model does not run this stack at all
            np.testing.assert_allclose(got, c * f_full + (1 - c) * f_without, rtol=1e-12, atol=1e-300,
                                       err_msg=f"coat {i}, coverage {c}")
            for side in sides:
                try:
                    a = api.albedo(_with(coats, base, {i: c}), wi, model, side)
                except api.UnsupportedStack:
                    continue
                np.testing.assert_allclose(a, c * a_full[side] + (1 - c) * a_without[side], rtol=1e-12, atol=1e-300)


def test_float32_mixes_to_float32_precision():
    coats, base = CASES["tint over gold"]
    wi, wo = _dirs(64, 4), _dirs(64, 5)
    got = api.evaluate(_with(coats, base, {0: 0.6}), wi, wo, dtype=np.float32)
    want = 0.6 * api.evaluate(_with(coats, base, {}), wi, wo, dtype=np.float32) \
        + 0.4 * api.evaluate(_without(coats, base, {0}), wi, wo, dtype=np.float32)
    assert got.dtype == np.float32
    np.testing.assert_allclose(got, want, rtol=2e-6, atol=1e-30)


def test_coverage_one_and_zero_are_exactly_the_whole_coat_and_no_coat():
    coats, base = CASES["clear, tint, clear over gold"]
    wi, wo = _dirs(32, 6), _dirs(32, 7)
    whole = api.evaluate(_with(coats, base, {}), wi, wo)
    assert np.array_equal(api.evaluate(_with(coats, base, {1: 1.0}), wi, wo), whole)
    for i in range(3):
        np.testing.assert_array_equal(api.evaluate(_with(coats, base, {i: 0.0}), wi, wo),
                                      api.evaluate(_without(coats, base, {i}), wi, wo))


@pytest.mark.parametrize("model", ["auto", "yamaguchi2019", "tm6"])
def test_several_partly_covering_coats_cover_independently(model):
    coats, base = CASES["clear, tint, clear over gold"]
    cover = {0: 0.3, 2: 0.8}
    wi, wo = _dirs(48, 8), _dirs(48, 9)
    got = api.evaluate(_with(coats, base, cover), wi, wo, model)
    want = 0.0
    for here in itertools.product((True, False), repeat=2):
        w = np.prod([cover[i] if h else 1 - cover[i] for i, h in zip(cover, here)])
        want = want + w * api.evaluate(_without(coats, base, {i for i, h in zip(cover, here) if not h}), wi, wo, model)
    np.testing.assert_allclose(got, want, rtol=1e-12)


def test_more_partly_covering_coats_than_the_shaders_mix_is_refused_naming_the_coat():
    d = {"layers": [{**CLEAR, "coverage": 0.5}] * (coverage.MAX_PARTIAL + 1), "base": GOLD}
    with pytest.raises(StackError, match=f"coat {coverage.MAX_PARTIAL}, field 'coverage'"):
        api.evaluate(d, _dirs(2, 0), _dirs(2, 1))


def test_a_named_model_runs_auto_on_a_part_it_cannot_represent():
    """endf has exactly one coat: the bare glass where the coat is absent runs auto."""
    coats, base = CASES["clear over glass"]
    wi, wo = _dirs(16, 10), _dirs(16, 11)
    got = api.evaluate(_with(coats, base, {0: 0.5}), wi, wo, "endf")
    want = 0.5 * api.evaluate(_with(coats, base, {}), wi, wo, "endf") + 0.5 * api.evaluate(
        _without(coats, base, {0}), wi, wo, "auto")
    np.testing.assert_allclose(got, want, rtol=1e-12)
    assert "endf" in MODELS


def test_a_format_1_stack_reads_as_covering_everything_and_writes_the_current_format():
    s = Stack.from_dict({"format": 1, "layers": [CLEAR], "base": GOLD})
    assert s.coats[0].coverage == 1.0
    d = s.to_dict()
    assert d["format"] == stack_format.FORMAT and d["layers"][0]["coverage"] == 1.0
    for bad in (-0.1, 1.5, float("nan"), "half"):
        with pytest.raises(StackError, match="coat 0, field 'coverage'"):
            Stack.from_dict({"layers": [{**CLEAR, "coverage": bad}], "base": GOLD})


@pytest.mark.parametrize("case", ["tint over gold", "dust over varnish over wood"])
def test_a_linked_mask_stays_live_and_the_staged_shader_follows_it(case):
    coats, base = CASES[case]
    stack = Stack.from_dict(_with(coats, base, {}))  # coverage 1 in the panel, a mask linked
    st = staging.stage(stack, live=["coat0_coverage"], budget="auto")
    assert "coat0_coverage" in st.live
    wi = suite.incident(40.0)
    wo, _ = suite.wo_grid(wi)
    for c in (0.0, 0.25, 1.0):
        want = api.evaluate(_with(coats, base, {0: c}), wi, wo)
        got = evaluate_staged(st, wi, wo, np.float64, values={"coat0_coverage": c})
        assert np.abs(got - want).sum() / want.sum() < 0.01, c


def test_where_a_mask_is_zero_or_one_the_other_part_weighs_nothing():
    """The shader keeps each part's lobes apart (they merge only within their part), so at a mask of
    0 or 1 every closure of the absent part has weight exactly 0 (and the renderer skips it)."""
    coats, base = CASES["tint over gold"]
    st = staging.stage(Stack.from_dict(_with(coats, base, {0: 0.5})), live=["coat0_coverage"], budget=2)
    assert len(st.closures) >= 2
    ops = StagedOps(st.table, np.float64, st.axis_tables)
    wi = suite.incident(30.0)
    for c in (0.0, 1.0):
        values = {**st.params, "coat0_coverage": c, "wi_x": np.array([math.hypot(wi[0], wi[1])]), "wi_y": np.zeros(1),
                  "wi_z": wi[None, 2]}
        weights = [np.stack(np.broadcast_arrays(*st.tracer.evaluate(list(cl.weight), ops, values))) for cl in st.closures]
        zero = [bool(np.all(w == 0.0)) for w in weights]
        assert any(zero) and not all(zero), (c, weights)


def test_the_reference_mixes_the_walks_of_each_part():
    coats, base = CASES["tint over gold"]
    parts = reference.covered_parts(Stack.from_dict(_with(coats, base, {0: 0.3})))
    assert [w for w, _ in parts] == pytest.approx([0.7, 0.3])
    assert [len(p.coats) for _, p in parts] == [0, 1] and parts[1][1].coats[0].coverage == 1.0
    wi = suite.incident(30.0)
    m, e = reference.albedo(_with(coats, base, {0: 0.3}), wi, 4000, seed=3)
    a, ea = reference.albedo(_with(coats, base, {}), wi, 4000, seed=3)
    b, eb = reference.albedo(_without(coats, base, {0}), wi, 4000, seed=3)
    np.testing.assert_allclose(m, 0.3 * a + 0.7 * b, rtol=1e-12)
    np.testing.assert_allclose(e, np.hypot(0.3 * ea, 0.7 * eb), rtol=1e-12)
