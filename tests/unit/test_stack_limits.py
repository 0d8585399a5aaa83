"""The stack contract at its edges: every number within the schema's hard limits (all finite in
float32, the precision shaders and Blender properties hold), out-of-range values rejected with a
message naming layer and field (never clamped), malformed input of any shape or size turned into a
``StackError``, and numpy scalars from a pipeline accepted."""
import json

import numpy as np
import pytest

from lamella.core import Stack, StackError
from lamella.core.layers import BASE_KINDS, COAT_KINDS
from lamella.core.layers.schema import BOOL, FLOAT32_MAX
from lamella.core.stack import MAX_JSON, MAX_NAME


def _coat(**kw):
    return {"layers": [kw], "base": {"type": "conductor"}}


@pytest.mark.parametrize("d, layer, field", [
    (_coat(thickness=1e300, sigma_s=1), "coat 0", "thickness"),
    (_coat(ior=1e300), "coat 0", "ior"),
    ({"base": {"type": "conductor", "eta": 1e300}}, "base", "eta"),
    (_coat(thickness=1.0, sigma_a=3e38), "coat 0", "sigma_a"),
    (_coat(thickness=FLOAT32_MAX), "coat 0", "thickness"),
    ({"base": {"type": "conductor", "k": 1e30}}, "base", "k"),
    (_coat(ior=10 ** 400), "coat 0", "ior"),
    (_coat(rotation=1e30), "coat 0", "rotation"),
    (_coat(ior=1e-6), "coat 0", "ior"),
    (_coat(g=0.9999999, thickness=1.0, sigma_s=1.0), "coat 0", "g"),
    ({"base": {"type": ["conductor"]}}, "base", "type"),
    ({"base": {"type": {"a": 1}}}, "base", "type"),
    ({"name": "x" * (MAX_NAME + 1), "base": {"type": "conductor"}}, "stack", "name"),
    (_coat(ior=np.bool_(True)), "coat 0", "ior"),
    (_coat(roughness=np.zeros((2, 2))), "coat 0", "roughness"),
])
def test_out_of_range_and_malformed_values_name_layer_and_field(d, layer, field):
    with pytest.raises(StackError) as e:
        Stack.from_dict(d)
    assert (e.value.layer, e.value.field) == (layer, field)
    assert len(str(e.value)) < 300  # a message, not the input echoed back


def test_every_field_has_float32_limits_the_parser_enforces_exactly():
    """Each field's hard limits are accepted as given and a step beyond them is rejected: what the
    parser accepts is what a Blender property (same min and max) stores."""
    for kinds in (COAT_KINDS, BASE_KINDS):
        for kind in kinds.values():
            for f in kind.fields:
                assert -FLOAT32_MAX < f.lo <= f.hi < FLOAT32_MAX
                if f.type == BOOL:  # a choice: true or false, and nothing a number could stand for
                    for x in (False, True):
                        assert getattr(kind.parse("t", {f.name: x}), f.name) is x
                    for x in (0, 1, 0.0, "true", None):
                        with pytest.raises(StackError, match=f.name):
                            kind.parse("t", {f.name: x})
                    continue
                for x in (f.lo, f.hi):
                    assert kind.parse("t", {f.name: x}) is not None
                for x in (f.lo - max(1e-3, abs(f.lo) * 1e-3), f.hi + max(1e-3, abs(f.hi) * 1e-3)):
                    with pytest.raises(StackError, match=f.name):
                        kind.parse("t", {f.name: x})


def test_json_too_deep_or_too_large_is_a_stack_error():
    deep = '{"layers": ' + "[" * 50000 + "]" * 50000 + ', "base": {"type": "conductor"}}'  # past every Python's limit
    with pytest.raises(StackError, match="nested too deeply"):
        Stack.from_json(deep)
    with pytest.raises(StackError, match="characters of JSON"):
        Stack.from_json(" " * (MAX_JSON + 1))
    with pytest.raises(StackError, match="expected JSON text"):
        Stack.from_json(12)


def test_numpy_scalars_and_arrays_from_a_pipeline_are_numbers():
    s = Stack.from_dict({"layers": [{"ior": np.float32(1.25), "roughness": np.float64(0.25), "thickness": np.int64(2),
                                     "sigma_a": np.array([0.5, 0.25, 0.0], dtype=np.float32)}],
                         "base": {"type": "conductor", "roughness": np.array([0.5, 0.25]), "k": np.float32(3.0)}})
    c = s.coats[0]
    assert (c.ior, c.roughness, c.thickness, c.sigma_a) == (1.25, (0.25, 0.25), 2.0, (0.5, 0.25, 0.0))
    assert s.base.roughness == (0.5, 0.25) and s.base.k == (3.0, 3.0, 3.0)
    assert json.loads(s.to_json())["layers"][0]["ior"] == 1.25  # plain floats out: JSON serialisable


# ---------------------------------------------------------------- fuzzing the parser
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

_scalars = st.one_of(st.none(), st.booleans(), st.integers(-10 ** 500, 10 ** 500), st.floats(allow_nan=True),
                     st.text(max_size=20), st.sampled_from([0.0, 1.0, 0.25, 4.0, 1e6, -1e-300, 3.5e38]))
_json = st.recursive(_scalars, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(
    st.text(max_size=10), inner, max_size=4), max_leaves=20)
_keys = st.sampled_from(["type", "ior", "roughness", "rotation", "thickness", "sigma_a", "sigma_s", "g", "eta", "k",
                         "albedo", "name", "layers", "base", "bogus"])
_layer = st.dictionaries(_keys, st.one_of(_json, st.sampled_from(["coat", "conductor", "diffuse", "dielectric"])),
                         max_size=6)
_stack = st.one_of(_json, st.fixed_dictionaries({}, optional={"name": _json, "layers": st.lists(_layer, max_size=9) | _json,
                                                              "base": _layer | _json}))


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(d=_stack)
def test_any_json_value_is_a_stack_or_a_stack_error(d):
    """Whatever a file or a pipeline hands the parser, it returns a Stack or raises StackError
    with a short message (never another exception)."""
    try:
        s = Stack.from_dict(d)
    except StackError as e:
        assert e.layer and len(str(e)) < 400
    else:
        assert Stack.from_json(s.to_json()) == s


@settings(max_examples=200, deadline=None)
@given(text=st.text(max_size=200) | _stack.map(lambda d: json.dumps(d, default=str)))
def test_any_text_is_a_stack_or_a_stack_error(text):
    try:
        Stack.from_json(text)
    except StackError:
        pass
