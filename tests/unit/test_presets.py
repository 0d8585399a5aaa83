"""The built-in presets: each loads, the procedural inputs a preset links name sockets of its own
stack, and the presets look like what their names promise (Dusty Copper is copper under a thin
dust, not dust)."""
import numpy as np
import pytest

from lamella.core import StackError, api, presets
from lamella_dev import suite


def test_every_preset_loads_and_its_inputs_name_its_own_sockets():
    for p in presets.builtin():
        p.load()
        presets.check_inputs(p)
    masked = {p.id: dict(p.inputs) for p in presets.builtin() if p.inputs}
    assert masked["worn_lacquer_on_wood"] == {"coat0_coverage": "worn"}
    assert masked["dust_on_upward_faces"] == {"coat0_coverage": "upward"}


def test_an_input_that_names_no_socket_of_the_stack_is_refused():
    p = presets.find("worn_lacquer_on_wood")
    for socket, why in (("coat3_coverage", "names no layer"), ("coat0_albedo", "has no field"),
                        ("base_coverage", "has no field")):
        bad = presets.Preset(p.id, p.label, p.description, p.path, True, ((socket, "worn"),), p.layer_labels)
        with pytest.raises(StackError, match=why):
            presets.check_inputs(bad)


def test_every_built_in_preset_labels_each_coat_once():
    """The panel and the Lamella node call a preset's coats what they are ("Clear Coat", "Red
    Paint"), each by a label of its own; a preset that labels too few coats, or two alike, is
    refused."""
    labels = {p.id: p.layer_labels for p in presets.builtin()}
    assert labels["car_paint"] == ("Clear Coat", "Red Paint")
    p = presets.find("dust_on_upward_faces")
    for wrong, why in ((("Dust",), "1 layer labels for 2 coats"), (("Dust", "Dust"), "must differ"),
                       (("Dust", "Base"), "must differ")):
        bad = presets.Preset(p.id, p.label, p.description, p.path, True, p.inputs, wrong)
        with pytest.raises(StackError, match=why):
            presets.check_inputs(bad)


def test_dusty_copper_reads_as_copper_under_a_thin_dust():
    """At 0 and 45 degrees the copper's own sharp reflection carries at least three quarters of
    what the material reflects (the dust's scattered light the rest); toward grazing the dust
    shows. The earlier preset (optical depth 0.45) kept 0.39 and 0.27: a matte, pale pink."""
    stack = presets.find("dusty_copper").load()
    sharp = {}
    for deg in (0.0, 45.0, 75.0):
        lb = api.lobes(stack, suite.incident(deg))
        w = lb.weight[0].mean(-1)
        copper = (np.abs(lb.alpha_x[0] - stack.base.roughness[0]) < 1e-3) & (np.array(lb.kinds) == "reflection")
        sharp[deg] = w[copper].sum() / w.sum()
    assert sharp[0.0] > 0.75 and sharp[45.0] > 0.75 and sharp[75.0] < sharp[45.0], sharp
