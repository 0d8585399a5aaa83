"""`lamella render` (DESIGN.md contract): canonical scenes to a linear float EXR, time printed."""
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("bpy")


@pytest.mark.parametrize("engine", ["cycles-osl", "principled"])
def test_render_env_writes_a_linear_exr(tmp_path, engine):
    import OpenEXR

    out = tmp_path / "r.exr"
    r = subprocess.run([sys.executable, "-m", "lamella.cli", "render", "gold_coated", "--scene", "sphere-env",
                        "--res", "32", "--spp", "4", "--engine", engine, "--out", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "render time" in r.stdout
    with OpenEXR.File(str(out)) as f:
        px = np.asarray(f.channels()["RGBA"].pixels)
    assert px.shape == (32, 32, 4)
    assert np.isfinite(px).all() and (px >= 0).all()
    assert px[16, 16, :3].min() > 0.01  # the sphere is lit by the HDRI, not black
