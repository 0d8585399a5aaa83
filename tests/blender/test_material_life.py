"""A Lamella material's life as a pipeline lives it, through the installed zip: made in one
session (a texture linked into the Lamella node, a copied material edited), saved with OSL on,
moved to another folder and rendered by a Blender that has neither the extension nor the checkout
(a render farm), in Cycles with OSL, Cycles without OSL and EEVEE
(``material_life_session.py``)."""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("bpy")
# one worker runs the whole module: its two sessions (about three minutes) run once
pytestmark = pytest.mark.xdist_group("material_life")

SESSION = Path(__file__).with_name("material_life_session.py")
ENGINES = ("cycles-osl", "cycles-nodes", "eevee")


def _run(args, tmp_path, user, session=SESSION):
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(user))
    r = subprocess.run([sys.executable, str(session), *map(str, args)], capture_output=True, text=True, env=env,
                       timeout=900, cwd=tmp_path)
    lines = [line for line in r.stdout.splitlines() if line.startswith("FOUND ")]
    assert lines, f"no result (exit {r.returncode}):\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    return json.loads(lines[-1][len("FOUND "):])


@pytest.fixture(scope="session")  # once, however xdist interleaves modules
def life(extension_zip, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("life")
    made, moved = tmp / "studio", tmp / "farm" / "shots"
    made.mkdir()
    moved.mkdir(parents=True)
    user = tmp / "studio_user"
    found = _run(["author", extension_zip, made / "shot.blend"], tmp, user)
    shutil.rmtree(user)  # the extension is gone with the studio's user folder
    shutil.move(made / "shot.blend", moved / "shot.blend")
    shutil.rmtree(made)
    found.update(_run(["farm", moved / "shot.blend"], tmp, tmp / "farm_user"))
    return found


def _rel(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return float(np.abs(a - b).sum() / b.sum())


def test_every_material_compiled(life):
    assert all(status == "OK" for status, _ in life["status"].values()), life["status"]


def test_the_farm_renders_what_the_studio_rendered(life):
    """Relative mean difference under 1 % for every sphere in every engine path, with no
    extension, no file outside the .blend and the file saved with OSL on (its Cycles without OSL
    render had rendered black)."""
    assert life["lamella_enabled"] == [] and life["missing_files"] == []
    for engine in ENGINES:
        for k, (farm, studio) in enumerate(zip(life["farm"][engine], life["author"][engine])):
            assert sum(farm) > 0.05, (engine, k, farm)
            assert _rel(farm, studio) < 0.01, (engine, k, farm, studio)


def test_the_farm_renders_the_panels_animation(life):
    """The base colour keyframed in the panel renders on frame 3 on the farm (the file was saved on
    frame 1) as it did in the studio: the keys travel on the Lamella node."""
    for engine in ENGINES:
        farm, studio, frame1 = life["farm_frame3"][engine][1], life["author_frame3"][engine][1], life["author"][engine][1]
        assert _rel(farm, studio) < 0.01, (engine, farm, studio)
        assert _rel(studio, frame1) > 0.2, (engine, "frame 3 must look unlike frame 1")


def test_the_engine_paths_agree(life):
    """Cycles without OSL renders the node group, which computes what the OSL shader does; EEVEE's
    own lighting differs (docs/extension.md), so it is held only to its measured offset."""
    for k in range(4):
        osl, nodes, eevee = (life["author"][e][k] for e in ENGINES)
        assert _rel(nodes, osl) < 0.02, (k, nodes, osl)
        assert _rel(eevee, osl) < 0.3, (k, eevee, osl)


def test_a_copy_renders_its_own_edit_and_leaves_the_original(life):
    """The copy (sphere 2) against a new material of its stack (sphere 3), the original (sphere 0)
    before and after the copy's edit. Cycles' noise at these samples moves a sphere's mean by up to
    about 1 % (the sun's highlight on the smooth gold falls on a few pixels): the same material on
    spheres 0 and 2 before the copy is the control of that."""
    for engine in ENGINES:
        noise = 0.02 if engine.startswith("cycles") else 0.002
        before, after = life["before_copy"][engine], life["author"][engine]
        assert _rel(before[2], before[0]) < noise, (engine, "the same material on two spheres", before[2], before[0])
        assert _rel(after[0], before[0]) < 1e-4, (engine, after[0], before[0])
        assert _rel(after[2], after[3]) < noise, (engine, after[2], after[3])
        assert _rel(after[2], after[0]) > 0.2, (engine, "the control must tell the copy from the original")
