"""`lamella stress`, the Blender part, quick: extreme stacks rendered in Cycles with OSL, Cycles
without OSL and EEVEE give no NaN, Inf, negative or over-bright pixel and conserve energy in the
white furnace; a short soak of random edits with saves and reloads leaves the file's texts, images
and node groups flat and the material showing the last valid stack."""
import pytest

pytest.importorskip("bpy")
from lamella_dev.bench import stress  # noqa: E402


def test_render_grid_of_extreme_stacks(addon):
    rows = stress.render_grid(24, 4, progress=False, cases=["huge_extinction_mirror", "dense_thick_medium"])
    assert len(rows) == 2 * len(stress.ENGINES) * 2
    bad = [r for r in rows if not stress.grid_ok(r)]
    assert not bad, bad
    mirror = [r for r in rows if r["case"] == "huge_extinction_mirror" and r["scene"] == "white-furnace"]
    assert all(r["mean"] > 0.9 for r in mirror), mirror  # a huge extinction is a mirror, not black


def test_soak_of_random_edits_saves_and_reloads(addon, tmp_path):
    result = stress.soak(60, 20, seed=3, folder=tmp_path, progress=False)
    assert result["rejected"] > 0, "invalid edits were tried and refused"
    assert stress.soak_ok(result), result
