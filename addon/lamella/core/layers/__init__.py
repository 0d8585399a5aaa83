"""Layer kinds, one module each (coat, conductor, diffuse, dielectric), and their registry.

A new kind is one module declaring its ``FIELDS`` (the schema the parser, ``to_dict`` and the
Blender properties read), its ``params`` (what the models read, as backend values) and, for a
base, its ``response`` (its energies), plus one line below.
"""
from __future__ import annotations

from . import coat, conductor, dielectric, diffuse
from .params import BaseResponse
from .schema import ANGLE, FLOAT, RGB, ROUGHNESS, Field, LayerKind, StackError

COAT_KINDS: dict[str, LayerKind] = {k.type: k for k in (coat.KIND,)}
BASE_KINDS: dict[str, LayerKind] = {k.type: k for k in (conductor.KIND, diffuse.KIND, dielectric.KIND)}

Coat = coat.Coat
Conductor = conductor.Conductor
Diffuse = diffuse.Diffuse
Dielectric = dielectric.Dielectric

__all__ = ["COAT_KINDS", "BASE_KINDS", "LayerKind", "Field", "BaseResponse", "StackError", "Coat", "Conductor",
           "Diffuse", "Dielectric", "FLOAT", "RGB", "ROUGHNESS", "ANGLE"]
