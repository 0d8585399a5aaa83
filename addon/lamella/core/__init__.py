"""Pure-numpy core: stack, models, backends, reference, look-up tables, metrics. No bpy here."""
from .stack import Stack, StackError, Coat, Conductor, Diffuse, Dielectric, MAX_COATS

__all__ = ["Stack", "StackError", "Coat", "Conductor", "Diffuse", "Dielectric", "MAX_COATS"]
from .api import MODELS, Lobes, lobes, evaluate, albedo, UnsupportedStack

__all__ += ["MODELS", "Lobes", "lobes", "evaluate", "albedo", "UnsupportedStack"]
