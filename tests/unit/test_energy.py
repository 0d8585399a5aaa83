"""Energy given is energy delivered: for every suite stack and angle, the integral of `evaluate`
over the upper hemisphere equals the weights of the rough reflected lobes (what `albedo` reports
and the closures are normalised to) within 2 % (`lamella bench energy`, `bench/energy.md`).

The stacks with scattering media fail it today: their back-scatter lobe (a GGX reflection about
the view) reaches below the horizon at oblique views and its normaliser (1 / GD at normal
incidence in its own frame) does not account for the cut (fog_g05_d4 at 75 degrees delivers 0.67
of its weight). Normalising it over the part above the surface closes the gap to 0.1 % but makes
the lobe's shape, already too wide toward grazing, worse against the reference in every media
case: the shape must change with it. They are expected to fail (strict: a fix shows)."""
import numpy as np
import pytest

from lamella.bench import energy
from lamella.core import suite

BACKSCATTER_CUT = {"fog_g09_d1", "fog_g09_d4", "fog_g0", "fog_g03", "fog_g07", "fog_g05_d4", "milky_coat_d01",
                   "milky_coat_d2", "green_scatter_d1", "green_scatter_d6"}
# the brushed base under a coat at 75 degrees delivers 2.6 % more than its weight: the anisotropic
# lobe's normaliser is 1 / GD at its RMS roughness
ANISOTROPIC_GD = {"coat_over_brushed"}


@pytest.mark.parametrize("name", suite.names())
def test_albedo_is_the_integral_of_evaluate(name, request):
    if name in BACKSCATTER_CUT | ANISOTROPIC_GD:
        request.applymarker(pytest.mark.xfail(strict=True, reason="bench/energy.md: "
                                              + ("back-scatter lobe cut by the horizon" if name in BACKSCATTER_CUT
                                                 else "anisotropic GD at the RMS roughness")))
    stack = suite.load(name)
    for deg in energy.ANGLES:
        w, i = energy.delivered(stack, suite.incident(deg))
        assert abs(i.mean() / w.mean() - 1.0) <= energy.TOLERANCE, (deg, w, i)
