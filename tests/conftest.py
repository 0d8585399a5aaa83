"""Shared test set-up: keep Blender (when a test imports bpy) out of the user's config folder."""
import os
import tempfile

if "BLENDER_USER_RESOURCES" not in os.environ:
    os.environ["BLENDER_USER_RESOURCES"] = tempfile.mkdtemp(prefix="lamella-blender-")
