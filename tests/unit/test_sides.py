"""Both faces of a dielectric base (``models.sides``): a solid substrate seen from inside, a thin sheet.

The exact limits: a bare smooth interface seen from inside reflects Fresnel's reflectance of index 1 / n
(total internal reflection past the critical angle); a smooth stack's energies are the same whichever
side the light crosses from, at the angles Snell's law pairs (a lossless stack transmits alike both
ways); a thin-walled base is the sheet it stands for."""
import numpy as np
import pytest

from lamella.core import api
from lamella.core.backends.evaluate import evaluate_staged
from lamella.core.backends.ir.closures import INSIDE_INPUT, trace_closures
from lamella.core.backends.ir.sockets import socket_names
from lamella.core.backends.ir.staging import stage
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.models import sides
from lamella.core.models.fresnel import fresnel_dielectric
from lamella.core.stack import Stack


def _fresnel(c: float, n: float) -> float:
    """Unpolarised Fresnel reflectance at cosine ``c`` onto relative index ``n`` (1 past the critical
    angle): ``models.fresnel``'s (``test_models.test_fresnel_edges`` holds its exact edges)."""
    return float(fresnel_dielectric(NumpyOps(np.float64), np.float64(c), n))


def _dirs(deg):
    t = np.radians(np.asarray(deg, dtype=np.float64))
    return np.stack([np.sin(t), 0.0 * t, np.cos(t)], -1)


GLASS = {"layers": [], "base": {"type": "dielectric", "ior": 1.5, "roughness": 0.0}}
DEGREES = [0.0, 20.0, 35.0, 41.0, 41.9, 45.0, 60.0, 85.0]


def test_a_bare_interface_seen_from_inside_reflects_as_fresnel_with_total_internal_reflection():
    lb = api.lobes(GLASS, _dirs(DEGREES), seen_from="inside")
    assert lb.kinds == ("reflection", "transmission")
    for k, deg in enumerate(DEGREES):
        r = _fresnel(np.cos(np.radians(deg)), 1.0 / 1.5)
        assert lb.weight[k, 0, 0] == pytest.approx(r, abs=1e-6), deg
        assert lb.weight[k, 1, 0] == pytest.approx(1.0 - r, abs=1e-6), deg
    past = np.degrees(np.arcsin(1.0 / 1.5)) + 0.5
    lb = api.lobes(GLASS, _dirs([past, 70.0, 89.0]), seen_from="inside")
    assert np.all(lb.weight[:, 1] == 0.0) and np.allclose(lb.weight[:, 0], 1.0)


def test_the_outside_view_is_the_stack_as_drawn():
    out = api.lobes(GLASS, _dirs(DEGREES))
    for k, deg in enumerate(DEGREES):
        assert out.weight[k, 0, 0] == pytest.approx(_fresnel(np.cos(np.radians(deg)), 1.5), abs=1e-6)


@pytest.mark.parametrize("coat_ior", [1.3, 1.5, 1.8])
def test_a_smooth_coated_glass_transmits_alike_from_both_sides(coat_ior):
    """Light crossing a lossless smooth stack from the air at theta and from the glass at the angle
    Snell's law pairs with it is transmitted alike (Stokes' relations)."""
    d = {"layers": [{"ior": coat_ior, "roughness": 0.0}], "base": {"type": "dielectric", "ior": 1.5, "roughness": 0.0}}
    for deg in (0.0, 20.0, 40.0, 60.0, 75.0):
        outside = api.albedo(d, _dirs([deg]), side="transmitted")[0]
        t = np.degrees(np.arcsin(np.sin(np.radians(deg)) / 1.5))
        inside = api.albedo(d, _dirs([t]), side="transmitted", seen_from="inside")[0]
        assert inside == pytest.approx(outside, abs=2e-3), (coat_ior, deg)


def test_the_inside_view_reverses_the_layers_and_keeps_the_parameters():
    d = Stack.from_dict({"layers": [{"ior": 1.4, "roughness": 0.1, "film_thickness": 300.0},
                                    {"ior": 1.6, "roughness": 0.2, "thickness": 0.5, "sigma_a": [1.0, 0.5, 0.2]}],
                         "base": {"type": "dielectric", "ior": 1.5, "roughness": 0.3}})
    v = sides.inside_view(d)
    # coat 0 of the view: the lower coat's interior (its medium, its index over the glass's) under the
    # base's interface; coat 1: the top coat's interior under the lower coat's interface
    assert v.coats[0].ior == pytest.approx(1.6 / 1.5) and v.coats[0].roughness == (0.3, 0.3)
    assert v.coats[0].has_absorption and v.coats[0].film_thickness == 0.0
    assert v.coats[1].ior == pytest.approx(1.4 / 1.5) and v.coats[1].roughness == (0.2, 0.2)
    # the air below, under the top coat's interface and its film (optical thickness kept)
    assert v.base.ior == pytest.approx(1.0 / 1.5) and v.base.roughness == (0.1, 0.1)
    assert v.base.film_thickness == pytest.approx(450.0) and v.base.film_ior == pytest.approx(1.33 / 1.5)
    # one shader: the same parameters (the node's sockets), both sides drawn
    t = trace_closures(d).tracer
    assert INSIDE_INPUT in t.inputs
    assert set(socket_names(t.ids)) == set(socket_names(trace_closures(dict(d.to_dict(), base=dict(
        d.to_dict()["base"], thin_walled=True))).tracer.ids))


def test_an_opaque_base_looks_the_same_from_both_sides():
    d = {"layers": [{"ior": 1.5, "roughness": 0.1}], "base": {"type": "conductor", "roughness": 0.2}}
    a = api.lobes(d, _dirs(DEGREES))
    b = api.lobes(d, _dirs(DEGREES), seen_from="inside")
    assert np.array_equal(a.weight, b.weight)
    assert INSIDE_INPUT not in trace_closures(d).tracer.inputs


def test_a_thin_walled_base_is_the_sheet_it_stands_for():
    thin = {"layers": [{"ior": 1.3, "roughness": 0.05}],
            "base": {"type": "dielectric", "ior": 1.5, "roughness": 0.1, "film_thickness": 400.0, "thin_walled": True}}
    sheet = {"layers": [{"ior": 1.3, "roughness": 0.05},
                        {"ior": 1.5, "roughness": 0.1, "film_thickness": 400.0, "film_ior": 1.33}],
             "base": {"type": "dielectric", "ior": 1.0, "roughness": 0.1}}
    wi = _dirs(DEGREES)
    for seen_from in sides.SIDES:
        a = api.lobes(thin, wi, seen_from=seen_from)
        b = api.lobes(sheet, wi)
        assert a.kinds == b.kinds
        np.testing.assert_allclose(a.weight, b.weight, rtol=1e-12, atol=1e-15)
    # its light leaves in the direction it came
    lb = api.lobes(thin, wi)
    assert lb.kinds[-1] == "transmission"
    assert INSIDE_INPUT not in trace_closures(thin).tracer.inputs


def test_the_staged_shader_draws_each_side_where_it_is_seen():
    """The shaders' tables and closures give the outside view on front faces and the inside view on
    back faces (``evaluate_staged``'s ``seen_from``: the shaders' backfacing test)."""
    d = {"layers": [{"ior": 1.3, "roughness": 0.2}], "base": {"type": "dielectric", "ior": 1.5, "roughness": 0.3}}
    st = stage(d)
    wi = np.broadcast_to(_dirs([30.0]), (64, 3))
    rng = np.random.default_rng(3)
    wo = rng.normal(size=(64, 3))
    wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
    for seen_from in sides.SIDES:
        got = evaluate_staged(st, wi, wo, np.float64, seen_from=seen_from)
        want = api.evaluate(d, wi, wo, seen_from=seen_from)
        assert np.abs(got - want).max() <= 2e-2 * np.abs(want).max(), seen_from
    front = evaluate_staged(st, wi, wo, np.float64)
    back = evaluate_staged(st, wi, wo, np.float64, seen_from="inside")
    assert np.abs(front - back).max() > 0.1 * np.abs(front).max()
