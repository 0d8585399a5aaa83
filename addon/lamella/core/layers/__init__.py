"""Layer kinds, one module each (coat, conductor, diffuse, dielectric), and their registry.

A new kind is one module declaring its ``FIELDS`` (the schema the parser, ``to_dict``, the
Blender properties and panel read), its ``params`` (what the models read, as backend values), for
a base its ``response`` (its energies), and what it can do (``interface``, ``transmits``; see
``LayerKind``), which is what the models and backends route on. It joins the registry with
:func:`register` (the built-in kinds below; an extension's module calls it on import, before the
Blender properties are registered).
"""
from __future__ import annotations

from ..registry import Registry
from . import coat, conductor, dielectric, diffuse
from .params import BaseResponse
from .schema import ANGLE, BOOL, FLOAT, RGB, ROUGHNESS, Field, LayerKind, StackError

COAT_KINDS: Registry[LayerKind] = Registry("coat kind", key=lambda kind: kind.type)
BASE_KINDS: Registry[LayerKind] = Registry("base kind", key=lambda kind: kind.type, shares_names_with=(COAT_KINDS,))


def _registry(kind: LayerKind) -> Registry[LayerKind]:
    if not isinstance(kind, LayerKind):
        raise TypeError(f"a layer kind is declared with schema.layer_kind, got {type(kind).__name__}")
    return COAT_KINDS if kind.role == "coat" else BASE_KINDS


def register(kind: LayerKind) -> LayerKind:
    """Add ``kind`` to the registry of its role (the parser, the schema page, the Blender
    properties and every backend then know it). Its ``type`` must be new to both roles; what its
    role needs is checked where it is declared (``schema.layer_kind``)."""
    return _registry(kind).register(kind)


def unregister(kind: LayerKind) -> None:
    """Remove ``kind`` (a registered extension kind) from the registry."""
    _registry(kind).unregister(kind)


for _kind in (coat.KIND, conductor.KIND, diffuse.KIND, dielectric.KIND):
    register(_kind)

Coat = coat.Coat
Conductor = conductor.Conductor
Diffuse = diffuse.Diffuse
Dielectric = dielectric.Dielectric

__all__ = ["COAT_KINDS", "BASE_KINDS", "LayerKind", "Field", "BaseResponse", "StackError", "Coat", "Conductor",
           "Diffuse", "Dielectric", "FLOAT", "RGB", "ROUGHNESS", "ANGLE", "BOOL", "register", "unregister"]
