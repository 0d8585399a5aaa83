"""A normal per layer: each lobe knows the layer it leaves (``Lobe.normal``); a material that
links a layer's Normal input gives that layer's closures a frame of their own (the OSL shader a
``coat0_normal`` input and frame, the node plan a frame per BSDF, ``api.evaluate`` the same
closures), while the energies stay the stack's about the shading normal; lobes of different
frames never merge."""
import numpy as np
import pytest

from lamella.core import Stack, api
from lamella.core.backends.ir import staging
from lamella.core.backends.nodes.lower import emit_plan
from lamella.core.backends.osl.emit import osl_shader
from lamella_dev import suite

THREE = Stack.from_dict({"layers": [{"ior": 1.5, "roughness": 0.05}, {"ior": 1.4, "roughness": 0.2,
                                                                    "thickness": 0.5, "sigma_a": [0.5, 1, 2]}],
                         "base": {"type": "conductor", "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 2.2],
                                  "roughness": 0.3}})


@pytest.mark.parametrize("model", ["yamaguchi2019", "belcour2018", "tm6", "tm2"])
def test_every_lobe_names_the_layer_it_leaves(model):
    lb = api.lobes(THREE, suite.incident(30.0), model)
    from lamella.core.backends.numpy_ops import NumpyOps
    from lamella.core.models import run_model

    ops = NumpyOps()
    wi = tuple(ops.input(n, np.array([x])) for n, x in zip(("wi_x", "wi_y", "wi_z"), suite.incident(30.0)))
    normals = [lobe.normal for lobe in run_model(ops, THREE, wi, model)]
    assert len(normals) == len(lb.kinds)
    assert set(normals) <= {"coat0", "coat1", "base"} and normals[-1] == "base" and "coat0" in normals


def test_a_part_of_a_partly_covered_stack_names_its_layers_by_the_whole_stacks_indices():
    d = THREE.to_dict()
    d["layers"][0]["coverage"] = 0.5
    from lamella.core.backends.numpy_ops import NumpyOps
    from lamella.core.models import run_model

    ops = NumpyOps()
    wi = tuple(ops.input(n, np.array([x])) for n, x in zip(("wi_x", "wi_y", "wi_z"), suite.incident(30.0)))
    normals = [lobe.normal for lobe in run_model(ops, Stack.from_dict(d), wi, "auto")]
    assert "coat1" in normals and normals.count("coat0") >= 1  # the part without coat 0 still names coat 1


def test_a_stack_tilted_as_a_whole_tilts_every_reflected_lobe_alike():
    """Every layer given the same normal: each reflected lobe is about it (the prism weights of a
    lobe sum to 1), the whole response rotated."""
    from lamella.core.layer_normals import coats_above, tilts

    for layer in ("coat0", "coat1", "base"):
        w = tilts(THREE, layer, coats_above(THREE, layer), "reflection")
        assert sum(w.values()) == pytest.approx(1.0), (layer, w)
    assert tilts(THREE, "base", coats_above(THREE, "base"), "diffuse") == {"base": 1.0}


def test_z_normals_are_the_shading_normal_and_a_tilted_base_moves_its_lobe():
    wi = suite.incident(30.0)
    wo, _ = suite.wo_grid(wi)
    flat = api.evaluate(THREE, wi, wo)
    np.testing.assert_array_equal(api.evaluate(THREE, wi, wo, normals={"coat0": [0, 0, 1], "base": [0, 0, 1]}), flat)
    metal = Stack.from_dict({"layers": [], "base": {"type": "conductor", "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 2.2],
                                                    "roughness": 0.05}})
    t = np.radians(12.0)
    n = np.array([np.sin(t), 0.0, np.cos(t)])
    f = api.evaluate(metal, wi, wo, normals={"base": n}).mean(-1)
    peak = wo[np.argmax(f)]
    mirror = 2.0 * np.dot(wi, n) * n - wi
    assert np.degrees(np.arccos(np.clip(np.dot(peak, mirror), -1, 1))) < 4.0  # the grid's spacing


def test_a_linked_normal_gives_its_layers_closures_a_frame_in_every_backend():
    """A bumped top coat tilts its own lobe by its tilt, and every lobe below by the prism it makes
    (``layer_normals``: -(n - 1) of its tilt through a coat of index n); diffuse lobes keep theirs."""
    st = staging.stage(THREE, live=["coat0_normal"], budget="all")
    assert st.normals == ("coat0",) and "coat0_normal" in st.live_sockets
    frames = {c.normal: c.framed(st.normals) for c in st.closures if c.kind.name == "reflection"}
    assert frames["coat0"] == (("coat0", 1.0),) and frames["coat1"] == (("coat0", -0.5),)
    assert frames["base"] == (("coat0", -0.5),)
    assert st.structure_key() != staging.stage(THREE, budget="all").structure_key()
    src = osl_shader(THREE, live=("coat0_normal",)).source
    assert "normal coat0_normal = N" in src and 'microfacet("ggx", F0_N, F0_T' in src
    assert "vector F0_N = normalize(Normal + 1.0 * (N_coat0 - dot(N_coat0, Normal) * Normal));" in src
    plan = emit_plan(THREE, live=("coat0_normal",))
    assert plan.normals == ("coat0",) and None in {b.frame for b in plan.bsdfs}
    assert (("coat0", -0.5),) in {b.frame for b in plan.bsdfs}


def test_lobes_of_different_frames_never_merge():
    merged = staging.stage(THREE, budget=1)
    framed = staging.stage(THREE, live=["coat0_normal", "base_normal"], budget=1)
    assert len(framed.closures) > len(merged.closures)
    assert len({c.framed(framed.normals) for c in framed.closures}) > 1


def test_a_stack_traced_before_with_other_indices_weighs_its_own_tilts():
    """The trace is shared by stacks of one structure; the frames' weights are each stack's own."""
    a = Stack.from_dict({"layers": [{"ior": 1.5}], "base": {"type": "conductor", "roughness": 0.1}})
    b = Stack.from_dict({"layers": [{"ior": 1.3}], "base": {"type": "conductor", "roughness": 0.1}})
    for stack, n in ((a, 1.5), (b, 1.3), (a, 1.5)):
        st = staging.stage(stack, live=["coat0_normal"], budget="all")
        base = next(c for c in st.closures if c.normal == "base" and c.kind.name == "reflection")
        assert base.framed(st.normals) == (("coat0", pytest.approx(-(n - 1.0))),)
