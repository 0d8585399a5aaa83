"""A traced operation: the absorbance -ln(x), the optical depth of a transmittance x
(Beer-Lambert). One ``TracedOp`` says how numpy, constant folding, OSL and Blender's Math nodes
compute it."""
import math

import numpy as np

from lamella.core.backends.ir import traced_ops


def _numpy(ops, x):
    return -np.log(x)


def _fold(x):
    return -math.log(x) if x > 0.0 else None


OP = traced_ops.TracedOp(
    "absorbance", 1, _numpy, _fold, "-log({0})",
    lambda math_node, x: math_node("MULTIPLY", math_node("LOGARITHM", x, math.e), -1.0),
    "optical depth -ln(x) of a transmittance x")


def register():
    traced_ops.register(OP)


def unregister():
    traced_ops.unregister(OP)
