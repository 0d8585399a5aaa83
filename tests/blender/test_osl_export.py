"""`lamella export-osl`: the generated shader compiles with Blender's bundled OSL compiler and
exposes every per-layer parameter as an input (first step of issue 3; rendering checks follow)."""
import os
import subprocess
import sys

import pytest

from lamella.core import suite

bpy = pytest.importorskip("bpy")  # the wheel is part of `make test`'s set-up
import _cycles  # noqa: E402  (Cycles' Python module, available once bpy is imported)
import oslquery  # noqa: E402  (bundled with the wheel; the .pth of tools/install_bpy_pth.py)


def _roughness_inputs(prefix, roughness):
    """An isotropic layer has one roughness input and no rotation; an anisotropic one has three."""
    if roughness[0] == roughness[1]:
        return {f"{prefix}_alpha"}
    return {f"{prefix}_alpha_x", f"{prefix}_alpha_y", f"{prefix}_rotation"}


@pytest.mark.parametrize("case", ["gold_coated", "rotated_60", "three_coats", "tinted_varnish", "four_coats"])
def test_exported_shader_compiles(tmp_path, case):
    osl = tmp_path / f"{case}.osl"
    r = subprocess.run([sys.executable, "-m", "lamella.cli", "export-osl", case, "-o", str(osl)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    oso = tmp_path / f"{case}.oso"
    assert _cycles.osl_compile(str(osl), str(oso)), "OSL compile failed (see stderr)"
    names = {p.name for p in oslquery.OSLQuery(str(oso)).parameters}
    stack = suite.example(case) if case == "four_coats" else suite.load(case)
    for i, c in enumerate(stack.coats):
        assert f"coat{i}_ior" in names
        assert _roughness_inputs(f"coat{i}", c.roughness) <= names
        assert (f"coat{i}_thickness" in names) == c.has_absorption
    assert {"base_eta_r", "base_k_b", "Tangent", "lut_dir", "BSDF"} <= names
    assert _roughness_inputs("base", stack.base.roughness) <= names
    assert os.path.getsize(oso) > 0
