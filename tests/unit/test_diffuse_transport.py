"""Light a Lambertian base sends up through smooth coats: an exact limit of the stochastic
reference (smooth interfaces and absorbing interiors are exact in the walk, and only the base
scatters), so the models' albedo must match it. Absorbing coats are where the per-direction sum
of ``diffuse_transport.DiffuseUp`` matters: the light inside the escape cone leaves along short
paths, the light beyond it is returned along long ones."""
import numpy as np
import pytest

from lamella.core import api
from lamella_dev import reference, suite
from lamella.core.stack import Stack

STACKS = {
    "clear coat": {"layers": [{"type": "coat", "ior": 1.5, "roughness": 0.0}],
                   "base": {"type": "diffuse", "albedo": [0.8, 0.5, 0.2]}},
    "absorbing coat": {"layers": [{"type": "coat", "ior": 1.339, "roughness": 0.0, "thickness": 0.76,
                                   "sigma_a": [1.385, 0.74, 1.427]}],
                       "base": {"type": "diffuse", "albedo": [0.183, 0.791, 0.88]}},
    "thick coat": {"layers": [{"type": "coat", "ior": 1.6, "roughness": 0.0, "thickness": 2.0,
                               "sigma_a": [0.3, 0.6, 1.2]}],
                   "base": {"type": "diffuse", "albedo": [0.9, 0.6, 0.9]}},
    "low index under high": {"layers": [{"type": "coat", "ior": 1.5, "roughness": 0.0, "thickness": 0.3,
                                         "sigma_a": [0.2, 0.5, 1.0]},
                                        {"type": "coat", "ior": 1.3, "roughness": 0.0, "thickness": 0.5,
                                         "sigma_a": [1.0, 0.3, 0.1]}],
                             "base": {"type": "diffuse", "albedo": [0.9, 0.9, 0.9]}},
}
WALKERS = 200_000


@pytest.mark.parametrize("name", sorted(STACKS))
@pytest.mark.parametrize("model", ["yamaguchi2019", "tm6"])
def test_diffuse_base_under_smooth_coats_matches_the_walk(name, model):
    stack = Stack.from_dict(STACKS[name])
    for deg in (0.0, 60.0):
        wi = suite.incident(deg)
        got = api.albedo(stack, wi, model)[0]
        want, err = reference.albedo(stack, wi, spp=WALKERS, seed=3)
        # within 1 % of the albedo or 4 standard errors of the walk, whichever is larger
        np.testing.assert_array_less(np.abs(got - want[0]), np.maximum(0.01 * want[0], 4.0 * err[0]),
                                     err_msg=f"{name}, {model}, {deg} degrees: {got} against {want[0]}")
