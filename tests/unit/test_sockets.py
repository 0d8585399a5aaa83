"""The sockets a material shows speak the panel's units: roughness as Blender's r (alpha = r^2),
an RGB field as one colour, the rest as the stack stores them."""
import math

import pytest

from lamella_dev import suite
from lamella.core.backends.closures import trace_closures
from lamella.core.backends.sockets import by_param, params_of, sockets


def _params(case):
    t = trace_closures(suite.example(case) if case == "four_coats" else suite.load(case)).tracer
    return {k: float(t.defaults[k]) for k in t.params}


@pytest.mark.parametrize("case", ["gold_coated", "rotated_60", "varnished_wood", "fog_g09_d1", "four_coats"])
def test_every_parameter_has_one_socket_in_panel_units(case):
    params = _params(case)
    shown = sockets(params)
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
    assert all(by_param(params)[p][0].name in {sk.name for sk in shown} for p in params)


def test_a_coat_g_is_no_colour_channel():
    """``coat0_g`` (the phase asymmetry) ends like a green channel but has no red or blue twin."""
    params = _params("fog_g09_d1")
    assert "coat0_g" in params
    assert next(sk for sk in sockets(params) if sk.name == "coat0_g").convert == "identity"
    assert params_of(["coat0_sigma_s"], params) == ("coat0_sigma_s_b", "coat0_sigma_s_g", "coat0_sigma_s_r")
    with pytest.raises(KeyError):
        params_of(["coat0_sigma"], params)
