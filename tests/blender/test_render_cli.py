"""`lamella render` (docs/design.md contract): canonical scenes to a linear float EXR, time printed."""
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("bpy")


@pytest.mark.parametrize("engine", ["cycles-osl", "principled"])
def test_render_env_writes_a_linear_exr(tmp_path, engine):
    import OpenEXR

    out = tmp_path / "r.exr"
    r = subprocess.run([sys.executable, "-m", "lamella_dev.cli", "render", "gold_coated", "--scene", "sphere-env",
                        "--res", "32", "--spp", "4", "--engine", engine, "--out", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "render time" in r.stdout
    with OpenEXR.File(str(out)) as f:
        px = np.asarray(f.channels()["RGBA"].pixels)
    assert px.shape == (32, 32, 4)
    assert np.isfinite(px).all() and (px >= 0).all()
    assert px[16, 16, :3].min() > 0.01  # the sphere is lit by the HDRI, not black


def test_demo_renders_spheres_and_a_contact_sheet(tmp_path):
    """`make demo` (the main job): EXR + PNG per stack and a contact sheet."""
    import matplotlib.image as mpimg

    r = subprocess.run([sys.executable, "-m", "lamella_dev.cli", "demo", "--cases", "gold_coated,four_coats",
                        "--res", "32", "--render-spp", "4", "--out", str(tmp_path)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    for name in ("gold_coated", "four_coats"):
        assert (tmp_path / f"{name}.exr").stat().st_size > 0
        png = mpimg.imread(tmp_path / f"{name}.png")
        assert png.shape[:2] == (32, 32) and png[..., :3].max() > 0.1
    sheet = mpimg.imread(tmp_path / "contact_sheet.png")
    assert sheet.shape[0] > 100 and sheet.shape[1] > 100
