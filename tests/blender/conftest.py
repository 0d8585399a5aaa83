"""Fixtures of the Blender tests: the extension registered once per test process, in its own
user folder (presets, shader cache), and a fresh canonical scene."""
import pytest


@pytest.fixture(scope="session")
def addon(tmp_path_factory):
    bpy = pytest.importorskip("bpy")
    from . import addon_helpers

    addon_helpers.register()
    yield bpy
    addon_helpers.unregister()


@pytest.fixture
def scene(addon):
    """(scene, sphere) of the canonical sphere-env scene at a test size, no material yet."""
    from . import addon_helpers

    return addon_helpers.sphere_scene()


@pytest.fixture(scope="session")
def extension_zip(tmp_path_factory):
    """The extension built and validated by Blender's own tool (tools/build_extension.py)."""
    pytest.importorskip("bpy")
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
    import build_extension

    return build_extension.build(tmp_path_factory.mktemp("dist"))
