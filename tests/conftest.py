"""Shared test set-up: keep Blender (when a test imports bpy) out of the user's config folder."""
import os
import tempfile

os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="lamella-blender-"))
