"""Reflectivity / edge tint <-> eta/k (Gulbrandsen 2014): the artist mode of the conductor base."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from lamella.core import metals

unit = st.floats(0.0, 1.0, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(st.tuples(st.floats(0.01, 0.98), st.floats(0.01, 0.98), st.floats(0.01, 0.98)),
       st.tuples(unit, unit, unit))
def test_round_trip_reproduces_reflectivity_and_tint(r, g):
    eta, k = metals.artistic_to_complex(r, g)
    assert all(np.isfinite(eta)) and all(np.isfinite(k)) and min(eta) > 0 and min(k) >= 0
    r2, g2 = metals.complex_to_artistic(eta, k)
    np.testing.assert_allclose(r2, r, atol=1e-9)
    np.testing.assert_allclose(g2, g, atol=1e-6)


def test_reflectivity_is_the_normal_incidence_fresnel():
    eta, k = metals.artistic_to_complex((0.9, 0.6, 0.3), (0.5, 0.5, 0.5))
    f0 = [metals.normal_reflectance(n, kk) for n, kk in zip(eta, k)]
    np.testing.assert_allclose(f0, (0.9, 0.6, 0.3), atol=1e-12)


@pytest.mark.parametrize("r", [0.0, 1.0, 1.5, -0.2])
def test_extremes_stay_finite(r):
    eta, k = metals.artistic_to_complex((r, r, r), (0.0, 1.0, 0.5))
    assert all(np.isfinite(eta)) and all(np.isfinite(k)) and min(eta) > 0
