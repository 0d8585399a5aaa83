"""Compiling generated OSL (lamella.blender.osl_compile): errors quote the offending line, and a
source is compiled once (cache by hash)."""
import pytest

pytest.importorskip("bpy")
import bpy  # noqa: E402

from lamella.blender import osl_compile  # noqa: E402
from lamella_dev import suite  # noqa: E402
from lamella.core.backends.osl.emit import emit_osl  # noqa: E402

BROKEN = """shader broken(output closure color BSDF = 0)
{
    float x = 1.0
    BSDF = x * diffuse(N);
}
"""


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("LAMELLA_CACHE", str(tmp_path / "cache"))


def test_compile_error_names_the_offending_line():
    with pytest.raises(osl_compile.OSLCompileError) as e:
        osl_compile.compile_source(BROKEN, "broken")
    msg = str(e.value)
    assert "broken" in msg and "error" in msg.lower()
    assert "float x = 1.0" in msg  # the source around the reported line is quoted
    assert ">" in msg


def test_generated_shader_is_compiled_once(monkeypatch):
    import _cycles

    calls = []
    real = _cycles.osl_compile
    monkeypatch.setattr(_cycles, "osl_compile", lambda *a: calls.append(a) or real(*a))
    src = emit_osl(suite.load("gold_coated"))
    first = osl_compile.compile_source(src, "gold")
    second = osl_compile.compile_source(src, "gold")
    assert first == second and first.stat().st_size > 0
    assert len(calls) == 1
    osl_compile.compile_source(src.replace("// Generated", "// (edited) Generated"), "gold")
    assert len(calls) == 2


def test_script_node_gets_sockets_and_keeps_the_source():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.scene.render.engine = "CYCLES"
    mat = bpy.data.materials.new("m")
    node = mat.node_tree.nodes.new("ShaderNodeScript")
    src = emit_osl(suite.load("rotated_30"))
    text = bpy.data.texts.new("lamella.osl")
    osl_compile.assign_script(node, text, src, "rotated_30")
    assert node.mode == "INTERNAL" and node.script.as_string().rstrip() == src.rstrip()
    assert node.bytecode and node.bytecode_hash
    assert {"coat0_ior", "coat0_roughness_x", "coat0_rotation", "base_eta", "Tangent"} <= set(node.inputs.keys())
    assert "BSDF" in node.outputs
    with pytest.raises(osl_compile.OSLCompileError):
        osl_compile.assign_script(node, text, BROKEN, "broken")
    assert node.script.as_string().rstrip() == src.rstrip()  # a failed compile leaves the node as it was


@pytest.mark.parametrize("case", ["varnished_wood", "fog_g03", "rough_glass_plate"])
def test_new_lobe_kinds_compile(case):
    """A diffuse base (diffuse closure), a scattering medium over a metal (tm6: every scattered
    family a GGX lobe about the mirror direction; what the metal scatters more than once a diffuse
    closure) and a glass plate (a refracting closure) trace to shaders Cycles compiles, with those
    closures in them."""
    src = emit_osl(suite.load(case))
    assert ("diffuse(Normal)" in src) == (case != "rough_glass_plate")
    assert 'microfacet("ggx", V,' not in src  # no model emits the lobe about the view direction
    if case == "fog_g03":
        assert 'microfacet("ggx", Normal,' in src
    assert (", 100.0, 1)" in src) == (case == "rough_glass_plate")
    osl_compile.compile_source(src, f"lamella_{case}")


def test_a_table_folder_with_quotes_and_backslashes_compiles():
    """The tables' folder is a string literal of the shader: any path a user has compiles."""
    src = emit_osl(suite.load("gold_coated"), live=("coat0_roughness",), lut_dir='/tmp/a "quoted" \\ folder')
    assert 'string lut_dir = "/tmp/a \\"quoted\\" \\\\ folder"' in src
    osl_compile.compile_source(src, "quoted")
