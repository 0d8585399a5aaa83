"""Lamella: physically based layered materials for Blender (see docs/design.md).

``lamella.core`` is pure numpy and imports without bpy; ``lamella.blender`` holds everything bpy.
"""
__version__ = "0.1.0"
