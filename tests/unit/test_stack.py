"""The stack contract: defaults, normalisation, exact round trip, and clear rejection messages."""
import json
import math

import pytest

from lamella.core import MAX_COATS, Stack, StackError

from .stacks import coat, gold, stack


def test_defaults_and_normalisation():
    s = Stack.from_dict({"layers": [{"ior": 1.4, "roughness": 0.2}], "base": {"type": "diffuse"}})
    c = s.coats[0]
    assert c.roughness == (0.2, 0.2)
    assert (c.rotation, c.thickness, c.sigma_a, c.sigma_s, c.g) == (0.0, 0.0, (0, 0, 0), (0, 0, 0), 0.0)
    assert s.base.albedo == (0.8, 0.8, 0.8)
    assert Stack.from_dict({"base": {"type": "conductor"}}).base.roughness == (0.0, 0.0)


@pytest.mark.parametrize("d", [
    stack(coat(1.5, 0.1), coat(1.3, [0.2, 0.01], rotation=0.7, thickness=2.0, sigma_a=(0.1, 0.2, 0.3)),
          base=gold([0.1, 0.05], 0.3)),
    {"name": "glass", "layers": [], "base": {"type": "dielectric", "ior": 1.33, "roughness": [0.3, 0.1]}},
    {"layers": [{"ior": 1.0, "thickness": 1.0, "sigma_s": [1, 2, 3], "g": -0.5}],
     "base": {"type": "diffuse", "albedo": [0.1, 0.5, 0.9]}},
])
def test_round_trip_is_exact(d):
    s = Stack.from_dict(d)
    assert Stack.from_dict(s.to_dict()) == s
    assert Stack.from_json(s.to_json()) == s
    assert json.loads(s.to_json()) == s.to_dict()


BAD = [
    ({"layers": [], "base": {"type": "conductor"}, "colour": 1}, "stack", "colour"),
    ({"layers": [{"ior": 1.5, "rougness": 0.1}], "base": {"type": "diffuse"}}, "coat 0", "rougness"),
    ({"layers": [{"ior": "1.5"}], "base": {"type": "diffuse"}}, "coat 0", "ior"),
    ({"layers": [{"ior": math.nan}], "base": {"type": "diffuse"}}, "coat 0", "ior"),
    ({"layers": [{"ior": 0.0}], "base": {"type": "diffuse"}}, "coat 0", "ior"),
    ({"layers": [{}, {"thickness": -1}], "base": {"type": "diffuse"}}, "coat 1", "thickness"),
    ({"layers": [{"sigma_a": [0, -1, 0]}], "base": {"type": "diffuse"}}, "coat 0", "sigma_a"),
    ({"layers": [{"sigma_s": [0, math.inf, 0]}], "base": {"type": "diffuse"}}, "coat 0", "sigma_s"),
    ({"layers": [{"sigma_s": [0, 1]}], "base": {"type": "diffuse"}}, "coat 0", "sigma_s"),
    ({"layers": [{"roughness": 1.5}], "base": {"type": "diffuse"}}, "coat 0", "roughness"),
    ({"layers": [{"roughness": [0.1, -0.1]}], "base": {"type": "diffuse"}}, "coat 0", "roughness"),
    ({"layers": [{"g": 1.0}], "base": {"type": "diffuse"}}, "coat 0", "g"),
    ({"layers": [{"g": True}], "base": {"type": "diffuse"}}, "coat 0", "g"),
    ({"layers": [{"type": "base"}], "base": {"type": "diffuse"}}, "coat 0", "type"),
    ({"layers": []}, "base", None),
    ({"layers": [], "base": {}}, "base", None),
    ({"layers": [], "base": {"type": "plastic"}}, "base", "type"),
    ({"layers": [], "base": {"type": "conductor", "k": [1, 1, -1]}}, "base", "k"),
    ({"layers": [], "base": {"type": "conductor", "eta": [0, 1, 1]}}, "base", "eta"),
    ({"layers": [], "base": {"type": "diffuse", "albedo": [0.5, 1.2, 0.5]}}, "base", "albedo"),
    ({"layers": [], "base": {"type": "dielectric", "ior": -1.5}}, "base", "ior"),
    ({"layers": [], "base": {"type": "dielectric", "eta": 1.5}}, "base", "eta"),
    ({"layers": [{}] * (MAX_COATS + 1), "base": {"type": "diffuse"}}, "stack", "layers"),
    ({"layers": {"ior": 1.5}, "base": {"type": "diffuse"}}, "stack", "layers"),
    ([1, 2], "stack", None),
]


@pytest.mark.parametrize("d,layer,field", BAD)
def test_bad_input_names_layer_and_field(d, layer, field):
    with pytest.raises(StackError) as e:
        Stack.from_dict(d)
    assert e.value.layer == layer and e.value.field == field
    assert str(e.value).startswith(layer)
    if field:
        assert f"'{field}'" in str(e.value)


def test_bad_json_is_a_stack_error():
    with pytest.raises(StackError, match="not valid JSON"):
        Stack.from_json("{layers: ]")


def test_eight_coats_are_accepted():
    assert len(Stack.from_dict({"layers": [{}] * MAX_COATS, "base": {"type": "conductor"}}).coats) == 8
