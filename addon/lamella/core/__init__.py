"""Pure-numpy core: the stack and its layer kinds, the models, the backends, the look-up tables and
the Python API. No bpy here. (``lamella.core.reference`` is the contract's name for the development
package's stochastic reference; the metrics are the development package's too.)"""
from .stack import Stack, StackError, Coat, Conductor, Diffuse, Dielectric, MAX_COATS

__all__ = ["Stack", "StackError", "Coat", "Conductor", "Diffuse", "Dielectric", "MAX_COATS"]
from .api import MODELS, Lobes, lobes, evaluate, albedo, UnsupportedStack

__all__ += ["MODELS", "Lobes", "lobes", "evaluate", "albedo", "UnsupportedStack"]
