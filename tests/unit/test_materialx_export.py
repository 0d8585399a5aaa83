"""The MaterialX export (lamella.core.backends.materialx): the structure of both documents, what
the export reports, and validation by PyMaterialX for every preset, suite stack and example."""
import ast
import importlib.util
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from lamella.core import Stack
from lamella.core import presets
from lamella.core.backends import materialx as mtlx
from lamella_dev import suite

GOLD = {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603]}


def _stack(layers, base, name="t"):
    return Stack.from_dict({"name": name, "layers": layers, "base": base})


def _graph(export):
    root = ET.fromstring(export.text)
    (ng,) = root.findall("nodegraph")
    return root, {n.get("name"): n for n in ng if n.tag not in ("output", "input")}


def _inputs(node):
    return {i.get("name"): i for i in node.findall("input")}


def _layer_chain(nodes):
    """The BSDF nodes from the surface down: [(layer name, top node), ...], then the base node."""
    node = nodes[_inputs(nodes["surface"])["bsdf"].get("nodename")]
    chain = []
    while node.tag in ("layer", "multiply"):
        if node.tag == "layer":
            chain.append((node.get("name"), nodes[_inputs(node)["top"].get("nodename")]))
            node = nodes[_inputs(node)["base"].get("nodename")]
        else:
            node = nodes[_inputs(node)["in1"].get("nodename")]
    return chain, node


def _floats(text):
    return [float(x) for x in text.split(",")]


def _eval_vector(nodes, ref, env):
    """Evaluate the frame nodes (crossproduct, multiply, add, normalize) of a tangent reference,
    with the interface inputs in ``env``."""
    kind, name = ref
    if kind == "interfacename":
        return np.asarray(env[name], float)
    node = nodes[name]
    ins = _inputs(node)

    def arg(key):
        i = ins[key]
        if i.get("interfacename"):
            return np.asarray(env[i.get("interfacename")], float)
        if i.get("nodename"):
            return _eval_vector(nodes, ("nodename", i.get("nodename")), env)
        return float(i.get("value"))

    op = {"crossproduct": lambda: np.cross(arg("in1"), arg("in2")), "multiply": lambda: arg("in1") * arg("in2"),
          "add": lambda: arg("in1") + arg("in2"), "normalize": lambda: arg("in") / np.linalg.norm(arg("in"))}
    return op[node.tag]()


def _tangent_ref(node):
    t = _inputs(node)["tangent"]
    return ("interfacename", t.get("interfacename")) if t.get("interfacename") else ("nodename", t.get("nodename"))


def test_one_layer_per_coat_top_to_bottom_over_the_base_closure():
    s = _stack([{"ior": 1.4, "roughness": 0.1}, {"ior": 1.6, "roughness": [0.2, 0.05], "rotation": 0.3},
                {"ior": 1.3, "thickness": 0.5, "sigma_a": [0.1, 0.2, 0.3]}], {**GOLD, "roughness": 0.05})
    root, nodes = _graph(mtlx.layered_document(s))
    chain, base = _layer_chain(nodes)
    assert [name for name, _ in chain] == ["coat0_layer", "coat1_layer", "coat2_layer"]
    assert [top.tag for _, top in chain] == ["dielectric_bsdf"] * 3
    assert [_inputs(top)["scatter_mode"].get("value") for _, top in chain] == ["R"] * 3
    # each interface's index relative to the medium above it
    iors = [float(_inputs(top)["ior"].get("value")) for _, top in chain]
    assert iors == pytest.approx([1.4, 1.6 / 1.4, 1.6 / 1.3])  # 1.3 / 1.6 below 1: folded
    assert base.tag == "conductor_bsdf"
    assert _floats(_inputs(base)["ior"].get("value")) == pytest.approx([e / 1.3 for e in GOLD["eta"]])
    assert _floats(_inputs(base)["extinction"].get("value")) == pytest.approx([k / 1.3 for k in GOLD["k"]])
    # the material instances the stack's own node, which the nodegraph implements
    (nodedef,) = root.findall("nodedef")
    (mat,) = root.findall("surfacematerial")
    shader = root.find(nodedef.get("node"))
    assert _inputs(mat)["surfaceshader"].get("nodename") == shader.get("name")
    assert root.find("nodegraph").get("nodedef") == nodedef.get("name")


@pytest.mark.parametrize("base, tag", [({**GOLD, "roughness": 0.1}, "conductor_bsdf"),
                                       ({"type": "diffuse", "albedo": [0.5, 0.3, 0.15]}, "oren_nayar_diffuse_bsdf"),
                                       ({"type": "dielectric", "ior": 1.33, "roughness": 0.2}, "dielectric_bsdf")])
def test_the_base_closure_per_base_kind(base, tag):
    _, nodes = _graph(mtlx.layered_document(_stack([{"ior": 1.5}], base)))
    chain, node = _layer_chain(nodes)
    assert len(chain) == 1 and node.tag == tag and node.get("name") == "base_bsdf"
    ins = _inputs(node)
    if tag == "oren_nayar_diffuse_bsdf":  # roughness 0: Lambertian
        assert ins["roughness"].get("value") == "0" and _floats(ins["color"].get("value")) == [0.5, 0.3, 0.15]
    if tag == "dielectric_bsdf":
        assert ins["scatter_mode"].get("value") == "RT"
        assert float(ins["ior"].get("value")) == pytest.approx(1.5 / 1.33)  # folded: 1.33 / 1.5 < 1


def test_every_layer_has_its_own_normal_and_tangent():
    s = _stack([{"ior": 1.5, "roughness": [0.3, 0.02], "rotation": 0.7}, {"ior": 1.4, "roughness": 0.1}],
               {**GOLD, "roughness": [0.02, 0.2], "rotation": -1.1})
    root, nodes = _graph(mtlx.layered_document(s))
    decl = {i.get("name"): i for i in root.find("nodedef").findall("input")}
    for layer in ("coat0", "coat1", "base"):
        assert decl[f"{layer}_normal"].get("defaultgeomprop") == "Nworld"
        assert decl[f"{layer}_tangent"].get("defaultgeomprop") == "Tworld"
    chain, base = _layer_chain(nodes)
    for (layer, top) in [(f"coat{i}", top) for i, (_, top) in enumerate(chain)] + [("base", base)]:
        assert _inputs(top)["normal"].get("interfacename") == f"{layer}_normal"
        # the tangent depends on this layer's tangent and normal, no other layer's
        env = {f"{x}_{y}": (np.nan, np.nan, np.nan) for x in ("coat0", "coat1", "base") for y in ("normal", "tangent")}
        env[f"{layer}_normal"], env[f"{layer}_tangent"] = (0.0, 0.0, 1.0), (1.0, 0.0, 0.0)
        assert np.all(np.isfinite(_eval_vector(nodes, _tangent_ref(top), env)))


@pytest.mark.parametrize("rotation", [0.7, -1.1, 2.5])
def test_anisotropy_and_rotation_are_carried(rotation):
    """Roughness pairs as the closures' vector2 alpha (x along the tangent); the rotation turns the
    tangent counterclockwise about the normal, as Lamella's shaders do."""
    s = _stack([{"ior": 1.5, "roughness": [0.3, 0.02], "rotation": rotation}], {**GOLD, "roughness": [0.02, 0.2]})
    _, nodes = _graph(mtlx.layered_document(s))
    (_, top), = _layer_chain(nodes)[0]
    base = _layer_chain(nodes)[1]
    assert _floats(_inputs(top)["roughness"].get("value")) == [0.3, 0.02]
    assert _floats(_inputs(base)["roughness"].get("value")) == [0.02, 0.2]
    assert _inputs(base)["tangent"].get("interfacename") == "base_tangent"  # no rotation: the tangent itself
    # a frame whose normal is z and tangent x, and one tilted: the turned tangent stays in the
    # tangent plane at the rotation's angle, counterclockwise about the normal
    for n, t in (((0, 0, 1), (1, 0, 0)), ((0.0, -0.6, 0.8), (1.0, 0.0, 0.0))):
        n, t = np.asarray(n, float), np.asarray(t, float)
        got = _eval_vector(nodes, _tangent_ref(top), {"coat0_normal": n, "coat0_tangent": t})
        want = math.cos(rotation) * t + math.sin(rotation) * np.cross(n, t)
        assert got == pytest.approx(want, abs=1e-7)


def test_absorption_tints_the_layers_below_by_the_round_trip_along_the_normal():
    s = _stack([{"ior": 1.5}, {"ior": 1.5, "thickness": 0.5, "sigma_a": [0.1, 0.4, 1.2]}], {**GOLD, "roughness": 0.1})
    _, nodes = _graph(mtlx.layered_document(s))
    absorb = nodes["coat1_absorption"]
    assert absorb.tag == "multiply"
    want = [math.exp(-2 * 0.5 * x) for x in (0.1, 0.4, 1.2)]
    assert _floats(_inputs(absorb)["in2"].get("value")) == pytest.approx(want)
    assert _inputs(absorb)["in1"].get("nodename") == "base_bsdf"
    assert _inputs(nodes["coat1_layer"])["base"].get("nodename") == "coat1_absorption"
    assert "coat0_absorption" not in nodes


def test_warnings_name_the_layer_and_field_of_what_is_dropped_or_approximated():
    s = _stack([{"ior": 1.5, "roughness": 0.1},
                {"ior": 1.4, "thickness": 1.0, "sigma_a": [0.1, 0.2, 0.3], "sigma_s": 0.5, "g": 0.3}],
               {**GOLD, "roughness": 0.2})
    w = mtlx.layered_document(s).warnings
    assert w[0].startswith("stack: ") and "albedo scaling" in w[0]
    assert any(x.startswith("coat 1, fields 'sigma_s', 'g': ") and "dropped" in x for x in w)
    assert any(x.startswith("coat 1, fields 'sigma_a', 'thickness': ") for x in w)
    assert any(x.startswith("coat 1, field 'ior': ") and "relative" in x for x in w)
    assert any(x.startswith("coat 0, field 'roughness': ") for x in w)
    assert any(x.startswith("base, fields 'eta', 'k': ") for x in w)
    assert any(x.startswith("base, field 'roughness': ") and "single scattering" in x for x in w)
    assert not any(x.startswith("coat 0, field 'ior'") for x in w)  # the top coat's interface is against air
    # in stack order, and carried in the document too
    layers = [x.split(",")[0].split(":")[0] for x in w]
    assert layers == sorted(layers, key=lambda x: (x != "stack", x == "base", x))
    text = mtlx.layered_document(s).text
    assert "scattering media cannot be expressed" in text and "--" not in text.split("<!--", 1)[1].split("-->")[0]
    # nothing to report for what maps exactly: a bare Lambertian base
    assert mtlx.layered_document(_stack([], {"type": "diffuse"})).warnings == ()
    # a smooth clear coat over a diffuse base: the coupling of the layers, and its constant stand-in
    coupling, darkening = mtlx.layered_document(_stack([{"ior": 1.5}], {"type": "diffuse"})).warnings
    assert coupling.startswith("stack: ") and darkening.startswith("base, field 'albedo': darkened")


def test_a_lambertian_base_under_coats_is_darkened_by_the_interfaced_lambertian_factor():
    """(1 - K) / (1 - E_b K), K = 1 - (1 - E_F(n)) / n^2 (OpenPBR v1.1, "Darkening"); E_F(1.5) is
    the textbook 0.092 hemispherical albedo of a glass interface."""
    assert mtlx._hemispherical_fresnel(1.5) == pytest.approx(0.0918, abs=5e-4)
    k = 1.0 - (1.0 - mtlx._hemispherical_fresnel(1.5)) / 2.25
    white = mtlx.diffuse_darkening(_stack([{"ior": 1.5}], {"type": "diffuse", "albedo": [1.0, 0.5, 0.0]}))
    assert white == pytest.approx((1.0, (1 - k) / (1 - 0.5 * k), 1 - k))  # no light lost from a white base
    s = _stack([{"ior": 1.2}, {"ior": 1.5, "thickness": 0.5, "sigma_a": [0.2, 0.0, 0.0]}],
               {"type": "diffuse", "albedo": [1.0, 1.0, 1.0]})
    dark = mtlx.diffuse_darkening(s)  # the absorbing coat lowers E_b: darker in red only
    assert dark[0] < dark[1] == pytest.approx(1.0)
    _, nodes = _graph(mtlx.layered_document(s))
    assert _inputs(nodes["base_darkening"])["in1"].get("nodename") == "base_bsdf"
    assert _floats(_inputs(nodes["base_darkening"])["in2"].get("value")) == pytest.approx(dark, rel=1e-7)
    assert _layer_chain(nodes)[1].tag == "oren_nayar_diffuse_bsdf"
    for bare in (_stack([], {"type": "diffuse"}), _stack([{"ior": 1.5}], GOLD)):
        assert mtlx.diffuse_darkening(bare) is None
        assert "base_darkening" not in _graph(mtlx.layered_document(bare))[1]


def test_open_pbr_only_where_the_stack_fits():
    two = _stack([{"ior": 1.5}, {"ior": 1.4}], GOLD)
    assert "2 coats" in mtlx.open_pbr_fit(two)
    with pytest.raises(mtlx.OpenPBRMismatch, match="one coat over a base"):
        mtlx.open_pbr_document(two)
    for stack in (_stack([], GOLD), _stack([{"ior": 1.5}], GOLD)):
        assert mtlx.open_pbr_fit(stack) is None
        root = ET.fromstring(mtlx.open_pbr_document(stack).text)
        assert len(root.findall("open_pbr_surface")) == 1


def _open_pbr_inputs(stack):
    root = ET.fromstring(mtlx.open_pbr_document(stack).text)
    return {k: v.get("value") for k, v in _inputs(root.find("open_pbr_surface")).items()}, root


def _alphas(r, a):
    """OpenPBR v1.1's (roughness, anisotropy) -> (alpha_t, alpha_b)."""
    at = r * r * math.sqrt(2.0 / (1.0 + (1.0 - a) ** 2))
    return at, (1.0 - a) * at


def test_open_pbr_inputs_from_the_stack():
    coat = {"ior": 1.45, "roughness": [0.2, 0.05], "thickness": 0.3, "sigma_a": [0.2, 0.5, 1.0]}
    ins, root = _open_pbr_inputs(_stack([coat], {**GOLD, "roughness": [0.04, 0.16]}))
    assert ins["coat_weight"] == "1" and float(ins["coat_ior"]) == pytest.approx(1.45)
    assert _floats(ins["coat_color"]) == pytest.approx([math.exp(-2 * 0.3 * s) for s in coat["sigma_a"]])
    assert _alphas(float(ins["coat_roughness"]), float(ins["coat_roughness_anisotropy"])) == pytest.approx((0.2, 0.05))
    # the base's alpha_y is the larger: the same lobe along a tangent turned a quarter turn
    assert _alphas(float(ins["specular_roughness"]), float(ins["specular_roughness_anisotropy"])) == pytest.approx(
        (0.16, 0.04))
    outputs = {o.get("name"): o for o in root.find("nodegraph").findall("output")}
    assert set(outputs) == {"base_tangent"}
    assert ins["base_metalness"] == "1"
    n, k = np.array(GOLD["eta"]) / 1.45, np.array(GOLD["k"]) / 1.45
    assert _floats(ins["base_color"]) == pytest.approx(((n - 1) ** 2 + k ** 2) / ((n + 1) ** 2 + k ** 2), rel=1e-6)
    assert all(0.0 <= c <= 1.0 for c in _floats(ins["specular_color"]))

    ins, _ = _open_pbr_inputs(_stack([], {"type": "diffuse", "albedo": [0.5, 0.3, 0.15]}))
    assert ins["coat_weight"] == "0" and ins["base_metalness"] == "0" and ins["specular_weight"] == "0"
    assert _floats(ins["base_color"]) == [0.5, 0.3, 0.15]
    ins, _ = _open_pbr_inputs(_stack([{"ior": 1.5}], {"type": "dielectric", "ior": 1.33, "roughness": 0.1}))
    assert ins["transmission_weight"] == "1" and float(ins["specular_ior"]) == pytest.approx(1.33)
    assert _alphas(float(ins["specular_roughness"]), float(ins["specular_roughness_anisotropy"])) == pytest.approx(
        (0.1, 0.1))
    w = mtlx.open_pbr_document(_stack([{"ior": 1.5, "thickness": 1, "sigma_s": 0.5}], GOLD)).warnings
    assert any(x.startswith("coat 0, fields 'sigma_s', 'g': ") for x in w)


def test_names_are_valid_materialx_identifiers():
    for name, want in (("gold under lacquer", "gold_under_lacquer"), ("3 coats", "m_3_coats"), ("", "lamella_stack"),
                       ("été/noir", "t_noir")):
        assert mtlx.identifier(name) == want
    root = ET.fromstring(mtlx.layered_document(_stack([], GOLD, name="3 coats -- x")).text)
    assert root.find("surfacematerial").get("name") == "m_3_coats_x"
    # free text that XML cannot hold still makes a well-formed document
    for make in (mtlx.layered_document, mtlx.open_pbr_document):
        root = ET.fromstring(make(_stack([{"ior": 1.5}], GOLD, name="bell\x07 <&> --->")).text)
        assert root.find("surfacematerial").get("name") == "bell"


def test_the_shipped_module_needs_no_materialx_package():
    tree = ast.parse(Path(mtlx.__file__).read_text())
    imported = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    imported |= {n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert not any(m.split(".")[0] in ("MaterialX", "bpy", "lamella_dev") for m in imported), imported


def _every_stack():
    out = {f"preset {p.id}": p.load() for p in presets.builtin()}
    out.update({f"suite {n}": suite.load(n) for n in suite.names()})
    out.update({f"example {p.stem}": suite.example(p.stem) for p in sorted(suite.EXAMPLE_DIR.glob("*.json"))})
    return out


def test_every_preset_suite_stack_and_example_validates_in_materialx():
    pytest.importorskip("MaterialX")
    from lamella_dev.materialx_check import validate

    stacks = _every_stack()
    assert len(stacks) > 30
    failures = []
    for name, stack in stacks.items():
        docs = [mtlx.layered_document(stack)]
        if mtlx.open_pbr_fit(stack) is None:
            docs.append(mtlx.open_pbr_document(stack))
        for d in docs:
            ok, message = validate(d.text)
            if not ok:
                failures.append(f"{name} ({d.material}): {message}")
    assert not failures, "\n".join(failures)
    # the check itself sees a broken document
    text = mtlx.layered_document(suite.load("gold_coated")).text
    assert not validate(text.replace('name="roughness" type="vector2"', 'name="roughness" type="float"'))[0]
    assert not validate(text.replace("<conductor_bsdf ", "<conductor_bsdfx ").replace("</conductor_bsdf>",
                                                                                      "</conductor_bsdfx>"))[0]


def test_a_kind_the_export_does_not_map_is_refused_naming_the_layer():
    """The export knows each kind it writes; a kind registered later (an extension's) is refused
    with the layer named, not written as some other kind."""
    from . import extension_kinds

    extension_kinds.register()
    try:
        for stack, where in (({"layers": [{"type": "tinted_lacquer"}], "base": {"type": "conductor"}}, "coat 0"),
                             ({"layers": [{}], "base": {"type": "artist_metal"}}, "base")):
            for export in (mtlx.layered_document, mtlx.open_pbr_document):
                with pytest.raises(mtlx.MaterialXUnsupported, match=f"^{where}: no MaterialX form for"):
                    export(Stack.from_dict(stack))
    finally:
        extension_kinds.unregister()


def test_a_partly_covering_coat_is_a_mix_of_its_layer_and_what_is_under_it():
    """Coverage is a spatial mix: ``mix(fg = the coat's layer, bg = the layers under it)`` by a
    ``coatN_coverage`` input of the node (the stack's value; a mask connects there), and OpenPBR's
    coat weight. Both documents validate."""
    layers = [{"ior": 1.5, "roughness": 0.05, "coverage": 0.4, "thickness": 0.3, "sigma_a": [1, 1, 1]},
              {"ior": 1.3}]
    root, nodes = _graph(mtlx.layered_document(_stack(layers, GOLD)))
    (nodedef,) = root.findall("nodedef")
    cover = {i.get("name"): i for i in nodedef.findall("input")}["coat0_coverage"]
    assert float(cover.get("value")) == pytest.approx(0.4) and "coat1_coverage" not in nodes
    mix = _inputs(nodes["coat0_coverage"])
    assert mix["mix"].get("interfacename") == "coat0_coverage"
    assert mix["fg"].get("nodename") == "coat0_layer" and mix["bg"].get("nodename") == "coat1_layer"
    assert _inputs(nodes["surface"])["bsdf"].get("nodename") == "coat0_coverage"
    pbr = mtlx.open_pbr_document(_stack(layers[:1], GOLD))
    assert 'name="coat_weight" type="float" value="0.4"' in pbr.text
    if importlib.util.find_spec("MaterialX") is not None:
        from lamella_dev.materialx_check import validate

        for doc in (mtlx.layered_document(_stack(layers, GOLD)), pbr):
            ok, message = validate(doc.text)
            assert ok, message


def test_a_thin_film_is_the_closures_thinfilm_inputs_and_openpbrs_base_film():
    layers = [{"ior": 1.5, "roughness": 0.05, "film_thickness": 400, "film_ior": 1.33}]
    base = {**GOLD, "film_thickness": 250, "film_ior": 2.3}
    root, nodes = _graph(mtlx.layered_document(_stack(layers, base)))
    coat, metal = _inputs(nodes["coat0_bsdf"]), _inputs(nodes["base_bsdf"])
    assert float(coat["thinfilm_thickness"].get("value")) == 400 and float(coat["thinfilm_ior"].get("value")) == 1.33
    assert float(metal["thinfilm_thickness"].get("value")) == 250 and float(metal["thinfilm_ior"].get("value")) == 2.3
    pbr = mtlx.open_pbr_document(_stack(layers, base))
    assert 'name="thin_film_thickness" type="float" value="0.25"' in pbr.text
    assert any("no film on its coat" in w for w in pbr.warnings)
    if importlib.util.find_spec("MaterialX") is not None:
        from lamella_dev.materialx_check import validate

        for doc in (mtlx.layered_document(_stack(layers, base)), pbr):
            ok, message = validate(doc.text)
            assert ok, message
