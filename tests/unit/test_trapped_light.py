"""Light trapped under a rough coat over a smooth metal. What the coat reflects back down from
below has mostly been turned past the critical angle by facets reflecting totally; the mirror-like
base returns it along the same steep directions, and it comes up through the coat far less easily
than the first time. The adding equations count every round trip as the first, and a rough coat
over gold returned up to 12 % too much green light at 60 degrees against the energy-conserving walk
(``lamella_dev.reference``, interfaces="multiple"). The adding family now counts the later round
trips with the table ``dielectric_trapped_escape`` (``adding_doubling._adding_energies``)."""
import numpy as np
import pytest

from lamella.core import api
from lamella_dev import reference, suite
from lamella.core.stack import Stack

GOLD = {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603], "roughness": 0.01}
WALKERS = 40_000


@pytest.mark.parametrize("alpha", [0.1, 0.2, 0.3])
@pytest.mark.parametrize("model", ["yamaguchi2019", "weier2020"])
def test_rough_coat_over_smooth_gold_returns_what_the_walk_returns(alpha, model):
    stack = Stack.from_dict({"layers": [{"type": "coat", "ior": 1.5, "roughness": alpha}], "base": GOLD})
    # measured: 60 degrees, green: 0.123 / 0.114 / 0.051 too much with every round trip as the
    # first, 0.069 / 0.024 / -0.035 now; normal incidence within 0.025 either way
    for deg, tolerance in ((0.0, 0.02), (60.0, 0.08)):
        wi = suite.incident(deg)
        got = api.albedo(stack, wi, model)[0]
        want, err = reference.albedo(stack, wi, spp=WALKERS, seed=5, interfaces="multiple")
        np.testing.assert_array_less(np.abs(got / want[0] - 1.0), tolerance + 4.0 * err[0] / want[0],
                                     err_msg=f"alpha {alpha}, {model}, {deg} degrees: {got} against {want[0]}")
