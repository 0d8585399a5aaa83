"""`lamella export-osl`: the generated shader compiles with Blender's bundled OSL compiler; it is
staged (the view-only part a table inside it) and exposes as inputs exactly the parameters asked
to stay live (`--live`, or every one with `--live all`); the export is a bundle (shader, the
tables it reads, a README listing every parameter) for either view convention (Cycles' I toward
the viewer, the OSL specification's I toward the surface)."""
import os
import re
import subprocess
import sys

import pytest

from lamella.core import luts
from lamella_dev import suite
from lamella.core.backends.osl.emit import VIEW_LINES, VIEW_TARGETS, emit_osl
from lamella.core.backends.osl.bundle import README, TABLES_DIR, write_bundle

bpy = pytest.importorskip("bpy")  # the wheel is part of `make test`'s set-up
import _cycles  # noqa: E402  (Cycles' Python module, available once bpy is imported)
import oslquery  # noqa: E402  (bundled with the wheel; the .pth of tools/install_bpy_pth.py)

# one stack per structure: conductor, anisotropic and rotated, scattering medium, absorbing coat
# over a diffuse base, transmissive dielectric base
BUNDLE_CASES = ["gold_coated", "rotated_60", "fog_g09_d1", "varnished_wood", "rough_glass_plate"]
LUT_READ = re.compile(r'concat\(lut_dir, "/([^"]+)"\)')
README_ROW = re.compile(r"^\| `(\w+)` \| ([^|]+) \| `([^`]*)` \| ([^|]+) \|$", re.M)


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "lamella_dev.cli", "export-osl", *args], capture_output=True, text=True)


def _compile(osl, oso):
    assert _cycles.osl_compile(str(osl), str(oso)), f"OSL compile of {osl} failed (see stderr)"
    assert os.path.getsize(oso) > 0
    return list(oslquery.OSLQuery(str(oso)).parameters)


def _roughness_inputs(prefix, roughness):
    """An isotropic layer has one roughness input and no rotation; an anisotropic one has three."""
    if roughness[0] == roughness[1]:
        return {f"{prefix}_roughness"}
    return {f"{prefix}_roughness_x", f"{prefix}_roughness_y", f"{prefix}_rotation"}


@pytest.mark.parametrize("case", ["gold_coated", "rotated_60", "three_coats", "tinted_varnish", "four_coats"])
def test_exported_shader_compiles(tmp_path, case):
    osl = tmp_path / f"{case}.osl"
    r = _cli(case, "-o", str(osl), "--live", "all")
    assert r.returncode == 0, r.stderr
    assert osl.exists() and (tmp_path / README).exists()  # -o FILE.osl: the bundle goes beside it
    names = {p.name for p in _compile(osl, tmp_path / f"{case}.oso")}
    stack = suite.example(case) if case == "four_coats" else suite.load(case)
    for i, c in enumerate(stack.coats):
        assert f"coat{i}_ior" in names
        assert _roughness_inputs(f"coat{i}", c.roughness) <= names
        assert (f"coat{i}_thickness" in names) == c.has_absorption
    assert {"base_eta", "base_k", "Tangent", "lut_dir", "BSDF"} <= names
    assert _roughness_inputs("base", stack.base.roughness) <= names


def test_a_default_export_is_staged_and_its_inputs_are_what_stays_live(tmp_path):
    """Nothing live: no layer input, no table file (the shader carries its table); one live
    parameter: that input alone, and it changes the shader's response."""
    baked = tmp_path / "baked" / "s.osl"
    r = _cli("gold_coated", "-o", str(baked))
    assert r.returncode == 0, r.stderr
    names = {p.name for p in _compile(baked, tmp_path / "baked.oso")}
    assert names == {"Normal", "Tangent", "BSDF"}
    assert not (baked.parent / TABLES_DIR).exists()
    assert "float MT[" in baked.read_text() and "baked into the shader's table" in (baked.parent / README).read_text()
    live = tmp_path / "live" / "s.osl"
    r = _cli("gold_coated", "-o", str(live), "--live", "coat0_roughness", "--budget", "all")
    assert r.returncode == 0, r.stderr
    names = {p.name for p in _compile(live, tmp_path / "live.oso")}
    assert {"coat0_roughness", "Normal", "Tangent", "BSDF"} <= names and "coat0_ior" not in names
    r = _cli("gold_coated", "-o", str(tmp_path / "bad"), "--live", "coat7_roughness")
    assert r.returncode == 2 and "coat7_roughness" in r.stderr


@pytest.mark.parametrize("target", VIEW_TARGETS)
@pytest.mark.parametrize("case", BUNDLE_CASES)
def test_bundle_compiles_and_readme_lists_every_parameter(tmp_path, case, target):
    shader = write_bundle(suite.load(case), tmp_path, target=target, live="all")
    assert shader == tmp_path / f"lamella_{case}.osl"
    src = shader.read_text()
    assert VIEW_LINES[target] in src.splitlines()
    assert '    string lut_dir = "luts",' in src.splitlines()
    params = _compile(shader, tmp_path / f"lamella_{case}.oso")
    rows = {m.group(1): m.groups()[1:] for m in README_ROW.finditer((tmp_path / README).read_text())}
    assert set(rows) == {p.name for p in params}
    for p in params:
        typ, default, description = rows[p.name]
        assert typ.split()[-1] == ("color" if p.isclosure else str(p.type)), p.name
        assert description.strip() and "shader input" not in description, p.name
        if str(p.type) == "float":
            assert float(default) == pytest.approx(p.value), p.name
    for name, (_, _, description) in rows.items():
        if "_alpha" in name:
            assert "roughness squared" in description


@pytest.mark.parametrize("case", BUNDLE_CASES)
def test_targets_differ_only_in_the_view_line(case):
    stack = suite.load(case)
    cycles = emit_osl(stack, view="cycles").splitlines()
    spec = emit_osl(stack, view="osl-spec").splitlines()
    assert len(cycles) == len(spec)
    diff = [i for i, (a, b) in enumerate(zip(cycles, spec)) if a != b]
    assert len(diff) == 1
    a, b = cycles[diff[0]], spec[diff[0]]
    assert a == VIEW_LINES["cycles"] and b == VIEW_LINES["osl-spec"]
    code_a, code_b = a.split("//")[0].strip(), b.split("//")[0].strip()
    assert code_a == "vector V = normalize(I);"
    assert code_b == code_a.replace("= normalize(I)", "= -normalize(I)")  # the sign, nothing else
    assert emit_osl(stack) == "\n".join(cycles) + "\n"  # cycles is the default
    # the traced shader reads the package's tables by absolute path by default; a staged shader
    # with nothing live reads no file and has no lut_dir
    assert f'string lut_dir = "{luts.DATA_DIR}"' in emit_osl(stack, staged=False)
    assert "lut_dir" not in emit_osl(stack)


@pytest.mark.parametrize("case", BUNDLE_CASES)
def test_bundle_holds_exactly_the_tables_the_shader_reads(tmp_path, case):
    shader = write_bundle(suite.load(case), tmp_path / "bundle", live="all")
    read = set(LUT_READ.findall(shader.read_text()))
    assert read and read <= {s.file for s in luts.SPECS.values()} | set(luts.PACKED.values())
    written = {p.relative_to(shader.parent).as_posix() for p in shader.parent.rglob("*") if p.is_file()}
    assert written == {shader.name, README} | {f"{TABLES_DIR}/{f}" for f in read}
    for f in read:
        assert (shader.parent / TABLES_DIR / f).read_bytes() == (luts.DATA_DIR / f).read_bytes()
    text = (shader.parent / README).read_text()
    for f in read:
        assert f"`{TABLES_DIR}/{f}`" in text
    assert suite.load(case).name in text and "relative to" in text  # the stack, the lut_dir caveat


def test_export_into_a_folder_with_target_and_lut_dir(tmp_path):
    out = tmp_path / "bundle"
    r = _cli("suite:varnished_wood", "-o", str(out), "--target", "osl-spec", "--lut-dir", "/opt/lamella/luts",
             "--live", "all")
    assert r.returncode == 0, r.stderr
    shader = out / "lamella_varnished_wood.osl"
    assert str(shader) in r.stdout and str(out / README) in r.stdout
    lines = shader.read_text().splitlines()
    assert VIEW_LINES["osl-spec"] in lines and VIEW_LINES["cycles"] not in lines
    assert '    string lut_dir = "/opt/lamella/luts",' in lines
    assert "osl-spec" in (out / README).read_text()


def test_unknown_target_is_refused(tmp_path):
    out = tmp_path / "bundle"
    r = _cli("gold_coated", "-o", str(out), "--target", "renderman")
    assert r.returncode == 2
    assert "--target" in r.stderr and "'renderman'" in r.stderr and "cycles, osl-spec" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not out.exists()
    with pytest.raises(ValueError, match="cycles, osl-spec"):
        emit_osl(suite.load("gold_coated"), view="renderman")
    with pytest.raises(ValueError, match="cycles, osl-spec"):
        write_bundle(suite.load("gold_coated"), out, target="renderman")
    assert not out.exists()
