"""The sockets a material shows speak the panel's units: roughness as Blender's r (alpha = r^2),
an RGB field as one colour, the rest as the stack stores them."""
import math

import pytest

from lamella_dev import suite
from lamella.core.backends.ir.closures import trace_closures
from lamella.core.backends.ir.sockets import by_param, params_of, sockets


def _traced(case):
    t = trace_closures(suite.example(case) if case == "four_coats" else suite.load(case)).tracer
    return {k: float(t.defaults[k]) for k in t.params}, t.ids


@pytest.mark.parametrize("case", ["gold_coated", "rotated_60", "varnished_wood", "fog_g09_d1", "four_coats"])
def test_every_parameter_has_one_socket_in_panel_units(case):
    params, ids = _traced(case)
    shown = sockets(ids, params)
    fed = [p for sk in shown for p in sk.params]
    assert sorted(fed) == sorted(params), "every parameter fed once"
    for sk in shown:
        assert not sk.name.endswith(("_alpha", "_alpha_x", "_alpha_y", "_r", "_b")), sk.name
        if sk.convert == "square":
            (p,) = sk.params
            assert sk.name.replace("roughness", "alpha") == p
            assert math.isclose(sk.value ** 2, params[p], rel_tol=1e-12)
        elif sk.convert == "channels":
            assert sk.kind == "color" and sk.value == tuple(params[p] for p in sk.params)
            assert [p[-2:] for p in sk.params] == ["_r", "_g", "_b"]
        else:
            assert sk.params == (sk.name,) and sk.value == params[sk.name]
        for p in sk.params:  # what the socket is, is what its parameters are
            assert (ids[p].layer, ids[p].field) == (sk.layer, sk.field)
    assert all(by_param(ids)[p][0].name in {sk.name for sk in shown} for p in params)


def test_a_coat_g_is_no_colour_channel():
    """``coat0_g`` (the phase asymmetry) ends like a green channel but has no red or blue twin."""
    params, ids = _traced("fog_g09_d1")
    assert "coat0_g" in params
    assert next(sk for sk in sockets(ids, params) if sk.name == "coat0_g").convert == "identity"
    assert params_of(["coat0_sigma_s"], ids) == ("coat0_sigma_s_b", "coat0_sigma_s_g", "coat0_sigma_s_r")
    with pytest.raises(KeyError):
        params_of(["coat0_sigma"], ids)


def test_identity_is_data_not_names():
    """A parameter's layer, field, channel and unit come with it (``ParamId``); a field whose name
    reads like a channel or a roughness (``g``, ``alpha``) is told apart by what it is."""
    from lamella.core.param_id import ALPHA, ParamId

    params, ids = _traced("rotated_60")
    rough = [pid for pid in ids.values() if pid.is_roughness]
    assert rough and all(pid.unit == ALPHA and pid.field == "roughness" for pid in rough)
    assert {pid.name for pid in ids.values()} == set(params)
    # a kind with a field named like a channel: its sockets follow the identity, not the suffix
    odd = {"coat0_g": ParamId(0, "g", "", ""), "coat0_alpha": ParamId(0, "alpha", "", "1/length"),
           "base_tint_r": ParamId(None, "tint", "r"), "base_tint_g": ParamId(None, "tint", "g"),
           "base_tint_b": ParamId(None, "tint", "b")}
    by_name = {sk.name: sk for sk in sockets(odd)}
    assert by_name["coat0_alpha"].convert == "identity"  # a field named alpha is no roughness
    assert by_name["base_tint"].params == ("base_tint_r", "base_tint_g", "base_tint_b")
    with pytest.raises(ValueError, match="base, field 'tint'"):
        sockets({"base_tint_r": ParamId(None, "tint", "r")})
