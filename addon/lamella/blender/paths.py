"""Where the extension reads and writes: its own data inside the package (read only) and the
user's folder for caches and user presets (``bpy.utils.extension_path_user``), never the
extension's folder."""
from __future__ import annotations

import os
from pathlib import Path

import bpy


def extension_package() -> str | None:
    """``bl_ext.<repo>.<id>`` when running as an installed extension, else None (a development
    install imported as ``lamella``)."""
    parts = (__package__ or "").split(".")
    return ".".join(parts[:3]) if parts[0] == "bl_ext" and len(parts) >= 3 else None


def user_dir() -> Path:
    """The extension's user folder (created): Blender's per-extension folder when installed, a
    ``lamella`` folder in Blender's user configuration otherwise."""
    ext = extension_package()
    if ext is not None:
        return Path(bpy.utils.extension_path_user(ext, create=True))
    config = bpy.utils.user_resource("CONFIG", path="lamella", create=True)
    if config:
        return Path(config)
    # Blender run as a module without a user configuration folder: the user's cache folder
    d = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "lamella"
    d.mkdir(parents=True, exist_ok=True)
    return d


def user_presets_dir() -> Path | None:
    """The folder of the user's presets, or None where it cannot be made (a read-only user
    folder: the built-in presets are all there is, and saving one says why)."""
    try:
        d = user_dir() / "presets"
        d.mkdir(parents=True, exist_ok=True)
        return d
    except (OSError, RuntimeError):
        return None


def cache_dir() -> Path | None:
    """The shader cache's folder in the user folder, or None where the user folder cannot be
    made (the compiler then falls back on a temporary folder: ``osl_compile.cache_dir``)."""
    try:
        return user_dir() / "cache"
    except (OSError, RuntimeError):
        return None
