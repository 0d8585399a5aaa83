"""`lamella bench coat-darkening`: a smooth clear coat over a Lambertian base against the classical
internal-reflection sum, an exact limit of a smooth stack (the series of round trips between the base
and the interface, Fresnel at the view and the interface's diffuse reflectance from inside)."""
import numpy as np
import pytest

from lamella.core import api
from lamella_dev.bench import coat_darkening as cd
from lamella_dev import suite


def test_the_internal_reflectance_of_glass_seen_from_inside():
    # 1 - (1 - F_e) / n^2 with the external diffuse reflectance F_e = 0.0918 at index 1.5
    assert cd.internal_reflectance(1.5) == pytest.approx(1.0 - (1.0 - 0.0918) / 2.25, abs=1e-3)


@pytest.mark.parametrize("deg", [0.0, 45.0, 70.0])
def test_the_sum_is_the_fresnel_reflection_over_black_and_everything_over_white(deg):
    f = float(cd.fresnel(np.cos(np.radians(deg)), 1.5))
    assert cd.classical(0.0, deg) == pytest.approx(f, abs=1e-12)
    assert cd.classical(1.0, deg) == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("albedo", [0.1, 0.5, 0.8, 0.95])
@pytest.mark.parametrize("deg", [0.0, 45.0, 70.0])
def test_the_model_follows_the_internal_reflection_sum(albedo, deg):
    model = float(api.albedo(cd.stack(albedo), suite.incident(deg)[None])[0, 0])
    assert model == pytest.approx(cd.classical(albedo, deg), rel=2e-3)
