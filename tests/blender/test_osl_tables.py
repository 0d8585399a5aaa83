"""OSL shaders read the look-up tables in this Blender as numpy does.

An exported shader whose live part reads Lamella's look-up tables does so through OSL's
``texture()`` on the EXR files (``lamella/data/osl/lamella_luts.h``); a Script node's shader in a
.blend reads them from constant arrays in its source (``lamella/data/osl/lamella_arrays.h``), checked
the same way. Blender up to 5.0 read those through OpenImageIO, t = 0 at a
file's first row; from 5.1 Cycles reads them through its own image cache, t = 0 at the last row.
The files hold each atlas above its mirror image so that both give the same values
(``luts.to_file``). A probe shader reads every table, each in its own cell of the image at
coordinates from the shading point's place in the cell, and writes the value and that place into
the pixel (emission, one sample per pixel, a pixel filter narrower than a pixel); numpy's
multilinear read of the same table at those coordinates must agree to the float32 arithmetic of
the reads and the coordinates (``TOLERANCE``: measured at most 2.9e-5 in Blender 5.2, on
coat_first_escape from the files and the arrays alike; read with the two first coordinates
swapped, every table is off by 0.26 to 0.95). Before the layout changed, Blender 5.2 read 0.962
where numpy reads 0.901."""
import numpy as np
import pytest

pytest.importorskip("bpy")

from lamella.core import luts  # noqa: E402
from lamella.core.backends.numpy_ops import _multilinear  # noqa: E402
from lamella.core.backends.osl.emit import ARRAY_HEADER, LUT_HEADER, OSL_DIR, _float32_literals, table_array  # noqa: E402

RES = 24
PROBE_RES = 160  # every table's cell a few hundred pixels
TOLERANCE = 1e-4  # absolute, every table's values are within [-1, 1]

# (table, OSL expression of the value; c0, c1 come from the shading point, c2 from both)
READS = {
    "ggx_albedo": 'lamella_lut2(concat(dir, "/ggx_albedo.exr"), c0, c1, {n0}, {n1})',
    "ggx_refract_albedo": 'lamella_lut2(concat(dir, "/ggx_refract_albedo.exr"), c0, c1, {n0}, {n1})',
    "tir": 'lamella_lut3(concat(dir, "/tir.exr"), c0, c1, c2, {n0}, {n1}, {n2})',
    "fresnel_hat_delta": 'lamella_lut3(concat(dir, "/fresnel_hat_delta.exr"), c0, c1, c2, {n0}, {n1}, {n2})',
    "dielectric_rough_reflect": 'lamella_lut3(concat(dir, "/dielectric_rough_reflect.exr"), c0, c1, c2, {n0}, {n1}, {n2})',
    "dielectric_trapped_escape": 'lamella_lut3(concat(dir, "/dielectric_trapped_escape.exr"), c0, c1, c2, {n0}, {n1}, {n2})',
    "coat_first_escape": 'lamella_lut3(concat(dir, "/coat_first_escape.exr"), c0, c1, c2, {n0}, {n1}, {n2})',
    "coat_trapped_equilibrium": 'lamella_lut3(concat(dir, "/coat_trapped_equilibrium.exr"), c0, c1, c2, {n0}, {n1}, {n2})',
    "hg_backward_escape": 'lamella_lut3(concat(dir, "/hg_backward_escape.exr"), c0, c1, c2, {n0}, {n1}, {n2})',
    "hg_backward_cosine": 'lamella_lut2(concat(dir, "/hg_backward_cosine.exr"), c0, c1, {n0}, {n1})',
}


# Every table is read in one render per source: the middle square of the sphere's image (|x|, |z|
# below SQUARE, inside its disc) is cut into GRID x GRID cells, table k of ``TABLES`` read in cell
# k over its whole coordinate range (c0, c1 from the position within the cell, c2 from both). A
# pixel's colour is (value, su, sv), (su, sv) the position in the square: the cell and the
# coordinates follow from it exactly (GRID is a power of two, so su * GRID is exact in float32 as
# in numpy).
TABLES = sorted(READS)
GRID = 4
SQUARE = 0.68
CELL_COORDS = f"""
    float su = 0.5 + 0.5 * P[0] / {SQUARE};
    float sv = 0.5 + 0.5 * P[2] / {SQUARE};
    int i = (int)min(floor(su * {GRID}), {GRID - 1}.0);
    int j = (int)min(floor(sv * {GRID}), {GRID - 1}.0);
    int cell = j * {GRID} + i;
    float c0 = clamp(su * {GRID} - i, 0.0, 1.0);
    float c1 = clamp(sv * {GRID} - j, 0.0, 1.0);
    float c2 = clamp(0.5 + 0.45 * sin(9.0 * c0 + 5.0 * c1), 0.0, 1.0);
    float value = 0.0;
"""
assert len(READS) <= GRID * GRID


def _probe_source() -> str:
    """Every table through ``texture()`` on its EXR file (an exported shader's reads)."""
    reads = "".join(f"    if (cell == {k}) value = "
                    + READS[name].format(**{f"n{a}": n for a, n in enumerate(luts.SPECS[name].shape)}) + ";\n"
                    for k, name in enumerate(TABLES))
    return (OSL_DIR / LUT_HEADER).read_text() + f"""
shader probe(string dir = "", output closure color BSDF = 0)
{{{CELL_COORDS}{reads}    BSDF = color(value, su, sv) * emission();
}}
"""


def _array_source() -> str:
    """Every table as the constant array a Script node's shader holds (``lamella_arrays.h``)."""
    arrays, reads = [], []
    for k, name in enumerate(TABLES):
        shape = luts.SPECS[name].shape
        values = table_array(name)
        dims = ", ".join(map(str, shape))
        arrays.append(f"    float T{k}[{values.size}] = {{{', '.join(_float32_literals(values))}}};\n")
        reads.append(f"    if (cell == {k}) value = "
                     + (f"lamella_arr2(T{k}, 0, c0, c1, {dims})" if len(shape) == 2
                        else f"lamella_arr3(T{k}, c0, c1, c2, {dims})") + ";\n")
    return (OSL_DIR / ARRAY_HEADER).read_text() + f"""
shader probe(string dir = "", output closure color BSDF = 0)
{{
{"".join(arrays)}{CELL_COORDS}{"".join(reads)}    BSDF = color(value, su, sv) * emission();
}}
"""


def _packed_source() -> str:
    """Slice k of fresnel_hat_delta through its RGBA-packed file (``lamella_tex4``), k from c1."""
    n0, n1, n2 = luts.SPECS["fresnel_hat_delta"].shape
    f = luts.PACKED["fresnel_hat_delta"]
    header = (OSL_DIR / LUT_HEADER).read_text()
    return header + f"""
shader probe(string dir = "", output closure color BSDF = 0)
{{
    float c0 = clamp(0.5 + 0.5 * P[0], 0.0, 1.0);
    float c1 = clamp(0.5 + 0.5 * P[2], 0.0, 1.0);
    int k = int(clamp(floor(c1 * {n2 // 4}), 0, {n2 // 4 - 1}));
    float a = 0.0;
    color rgb = lamella_tex4(concat(dir, "/{f}"), c0, c0, {n0}, {n1}, k * {n0}.0, {n0 * n2 // 4}, a);
    BSDF = color(rgb[1] + a, c0, c1) * emission();
}}
"""


def _render_probe(source: str, res: int = RES):
    import bpy

    from lamella.blender.osl_compile import assign_script
    from lamella_dev.render import build_scene, render_scene, sphere_material

    sc, sphere = build_scene("sphere-env", res, 1)
    sc.cycles.filter_width = 0.01
    sc.cycles.shading_system = True
    sc.render.film_transparent = True  # the sphere's pixels alone are opaque
    mat, nt, out = sphere_material(sphere, "lut probe")
    node = nt.nodes.new("ShaderNodeScript")
    assign_script(node, bpy.data.texts.new("lut_probe"), source, "lut_probe", {"dir": str(luts.DATA_DIR)})
    nt.links.new(node.outputs["BSDF"], out.inputs["Surface"])
    px, _ = render_scene(sc)
    on = px[..., 3] > 0.999
    return px[on, :3].astype(np.float64)


def _c2(c0, c1):
    return np.clip(0.5 + 0.45 * np.sin(9.0 * c0 + 5.0 * c1), 0.0, 1.0)


@pytest.mark.parametrize("source", ["files", "inline"])
def test_osl_table_reads_equal_numpy(addon, source):
    """Through ``texture()`` on the EXR files (an exported shader) and from the constant arrays a
    Script node's shader carries in its source (a textured material in a .blend): every table, each
    over its whole coordinate range in its own cell of the image."""
    got = _render_probe(_probe_source() if source == "files" else _array_source(), res=PROBE_RES)
    u, v = got[:, 1], got[:, 2]
    inside = (u > 0.0) & (u < 1.0) & (v > 0.0) & (v < 1.0)
    got, u, v = got[inside], u[inside], v[inside]
    i = np.minimum(np.floor(u * GRID), GRID - 1)
    j = np.minimum(np.floor(v * GRID), GRID - 1)
    cell = (j * GRID + i).astype(int)
    c0, c1 = u * GRID - i, v * GRID - j
    worst = {}
    for k, name in enumerate(TABLES):
        on = cell == k
        assert on.sum() > 100, (name, on.sum())
        shape = luts.SPECS[name].shape
        coords = [c0[on], c1[on]] if len(shape) == 2 else [c0[on], c1[on], _c2(c0[on], c1[on])]
        want = _multilinear(luts.table(name).astype(np.float64), coords, np.float64)
        worst[name] = float(np.abs(got[on, 0] - want).max())
    assert max(worst.values()) < TOLERANCE, (source, worst)


def test_osl_reads_of_the_packed_table_equal_numpy(addon):
    """``lamella_tex4`` reads four slices at once from the RGBA file; channels G and A here."""
    n0, n1, n2 = luts.SPECS["fresnel_hat_delta"].shape
    got = _render_probe(_packed_source())
    c0, c1 = got[:, 1], got[:, 2]
    k = np.clip(np.floor(c1 * (n2 // 4)), 0, n2 // 4 - 1).astype(int)
    t = luts.table("fresnel_hat_delta").astype(np.float64)
    want = np.array([_multilinear(t[:, :, 4 * kk + 1], [a, a], np.float64) +
                     _multilinear(t[:, :, 4 * kk + 3], [a, a], np.float64) for a, kk in zip(c0, k)])
    err = np.abs(got[:, 0] - want)
    assert err.max() < TOLERANCE, (err.max(), got[np.argmax(err)], want[np.argmax(err)])


def test_a_material_saved_before_the_layout_is_repaired_at_the_next_render(addon, scene):
    """A .blend saved by a Lamella whose node group read the tables' earlier layout (the atlas
    alone, read at t) would read wrong rows now: it is reported and rebuilt at the next render, as
    other damage is. (The OSL shader inside a .blend reads no table file: a textured material's
    shader carries the tables its live part reads in its source.)"""
    from lamella.blender import material_nodes, recompile
    from lamella_dev import suite
    from lamella.blender import api

    from .addon_helpers import new_material

    sc, sphere = scene
    m = new_material(sphere, "saved before the layout")
    api.apply_stack(m, suite.load("gold_coated"))
    value = m.node_tree.nodes.new("ShaderNodeValue")
    value.outputs[0].default_value = 0.3
    m.node_tree.links.new(value.outputs[0], api.input_socket(m, 0, "roughness"))
    recompile.compile_material(m)
    assert m.lamella.live_params == "coat0_roughness" and material_nodes.broken(m) is None
    source = material_nodes.shader_source(m)
    assert "lut_dir" not in source and "texture(" not in source, "no Script node reading files outside the .blend"
    assert "float LUT_" in source
    tree = material_nodes.inner_nodes(m)[2].node_tree
    assert material_nodes.reads_old_tables("lamella_tex(x) // lamella LUT layout 1")
    tree[material_nodes.STRUCTURE_KEY] = tree[material_nodes.STRUCTURE_KEY].split(":", 1)[1]
    assert "older Lamella" in material_nodes.broken(m)
    recompile._before_render(sc)
    recompile.flush_groups()
    assert material_nodes.broken(m) is None
    assert material_nodes.inner_nodes(m)[2].node_tree[material_nodes.STRUCTURE_KEY].startswith(f"luts{luts.LAYOUT}:")
