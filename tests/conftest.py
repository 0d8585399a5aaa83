"""Shared test set-up: keep Blender (when a test imports bpy) out of the user's config folder."""
import os
import tempfile

# One folder per process: the xdist workers inherit the controller's environment, and two workers
# sharing the user folder would see each other's saved presets and caches mid-test.
_OWNER = os.environ.get("LAMELLA_TEST_RESOURCES_PID")  # the process that made the folder, if a test run did
if "BLENDER_USER_RESOURCES" not in os.environ or _OWNER not in (None, str(os.getpid())):
    os.environ["BLENDER_USER_RESOURCES"] = tempfile.mkdtemp(prefix="lamella-blender-")
    os.environ["LAMELLA_TEST_RESOURCES_PID"] = str(os.getpid())
