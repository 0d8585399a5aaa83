"""The ENDF thin-layer model: its vMF algebra (A3 and its inverse in float32 and float64), the
joint-spherical-warping spreads checked against sampled light paths through the layer, its limits,
its refusals and its numerical stability."""
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import lamella.core as lc
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.models import UnsupportedStack
from lamella.core.models import endf as E
from lamella.core.stack import Stack


def _a3_exact(kappa):
    return 1.0 / math.tanh(kappa) - 1.0 / kappa


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_one_minus_a3_is_accurate_at_every_concentration(dtype):
    """1 - A3(kappa) to float precision from kappa = 1e-4 (where coth - 1/kappa loses every digit
    in float32) to 1e6, across the switch to the series."""
    ops = NumpyOps(dtype)
    for kappa in [1e-4, 1e-2, 0.3, 0.4999, 0.5001, 1.0, 3.0, 30.0, 1e3, 1e6]:
        exact = 1.0 - _a3_exact(kappa) if kappa > 1e-3 else 1.0 - kappa / 3.0
        got = float(E.one_minus_a3(ops, dtype(1.0 / kappa)))
        tol = 3e-6 if dtype == np.float32 else 1e-7
        assert abs(got - exact) <= tol * max(exact, 1e-3 if kappa < 1e3 else exact / tol * 1e-6), (kappa, got, exact)
    assert float(E.one_minus_a3(ops, dtype(0.0))) == 0.0  # a delta lobe


@pytest.mark.parametrize("kappa", [2.5, 10.0, 100.0, 1e4])
def test_inverse_recovers_the_concentration(kappa):
    ops = NumpyOps()
    u = E.one_minus_a3(ops, 1.0 / kappa)
    assert abs(float(E.v_from_one_minus_a3(ops, u)) * kappa - 1.0) < 2e-3


def _sample_vmf(rng, kappa, n):
    """Wood 1994's sampler of a vMF about +z."""
    u = rng.random(n)
    w = 1.0 + np.log(u + (1.0 - u) * np.exp(-2.0 * kappa)) / kappa
    phi = 2.0 * np.pi * rng.random(n)
    s = np.sqrt(np.maximum(1.0 - w * w, 0.0))
    return np.stack([s * np.cos(phi), s * np.sin(phi), w], -1)


def _refract(d, m, eta):
    """Refract the travelling direction d at a facet of normal m (m . d < 0) into relative index eta."""
    c = -(d * m).sum(-1, keepdims=True)
    k = 1.0 - (1.0 - c * c) / (eta * eta)
    return d / eta + (c / eta - np.sqrt(np.maximum(k, 0.0))) * m


def _reflect(d, m):
    return d - 2.0 * (d * m).sum(-1, keepdims=True) * m


def _spread(dirs):
    """sqrt(det) of the covariance of the directions projected on the plane normal to their mean:
    a vMF's 1 / kappa for a narrow lobe, and what a Jacobian determinant scales (at oblique
    incidence the warped lobe is elliptic; the model's isotropic vMF keeps its solid angle)."""
    mean = dirs.mean(0)
    z = mean / np.linalg.norm(mean)
    x = np.cross([0.0, 1.0, 0.0], z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    p = np.stack([dirs @ x, dirs @ y], -1)
    return float(np.sqrt(np.linalg.det(np.cov(p.T))))


@pytest.mark.parametrize("alpha1,alpha2,degrees,tol", [
    (0.06, 0.0, 0.0, 0.03), (0.06, 0.0, 40.0, 0.03), (0.0, 0.05, 0.0, 0.03), (0.0, 0.05, 40.0, 0.03),
    (0.06, 0.05, 0.0, 0.03),
    # off normal, each warped NDF is an ellipse of its own eccentricity: their sum spreads more than
    # the isotropic vMFs of the same solid angle that Eq. 18 convolves (measured 3.5 %)
    (0.06, 0.05, 40.0, 0.05)])
def test_one_bounce_spread_matches_sampled_paths(alpha1, alpha2, degrees, tol):
    """Eq. 26 against the light paths it summarises: facet normals drawn from the two vMF NDFs,
    the specular path in, off the base and out traced exactly; the exit directions spread as the
    model's convolution says, within 3 % (narrow lobes, where the mean-direction Jacobians hold)."""
    ops = NumpyOps()
    eta, n = 1.5, 400_000
    rng = np.random.default_rng(7)
    th = math.radians(degrees)
    o = np.array([math.sin(th), 0.0, math.cos(th)])
    k1, k2 = 1.0 / E.alpha_to_v(ops, max(alpha1, 1e-9)), 1.0 / E.alpha_to_v(ops, max(alpha2, 1e-9))
    m1, m2, m3 = _sample_vmf(rng, k1, n), _sample_vmf(rng, k2, n), _sample_vmf(rng, k1, n)
    t1 = _refract(np.broadcast_to(-o, (n, 3)), m1, eta)
    t2 = _reflect(t1, m2)
    out = _refract(t2, -m3, 1.0 / eta)
    ok = out[:, 2] > 0
    sampled = _spread(out[ok])
    mu = math.cos(th)
    c = math.sqrt(1.0 - (1.0 - mu * mu) / eta ** 2)
    v1, v2 = E.alpha_to_v(ops, alpha1), E.alpha_to_v(ops, alpha2)
    d = mu - eta * c
    model = E.convolve(ops, v1 * d * d / mu, v2 * 4 * eta * eta * c * c / mu, v1 * d * d / mu)
    assert abs(model / sampled - 1.0) < tol, (model, sampled)


@pytest.mark.parametrize("degrees", [0.0, 40.0])
def test_transmitted_spread_matches_sampled_paths(degrees):
    """Eqs. 23-24 (a coat of index 1.4 over glass of index 1.5) against traced paths."""
    ops = NumpyOps()
    n1, n2, a1, a2, n = 1.4, 1.5, 0.08, 0.1, 400_000
    rng = np.random.default_rng(3)
    th = math.radians(degrees)
    o = np.array([math.sin(th), 0.0, math.cos(th)])
    m1 = _sample_vmf(rng, 1.0 / E.alpha_to_v(ops, a1), n)
    m2 = _sample_vmf(rng, 1.0 / E.alpha_to_v(ops, a2), n)
    t = _refract(_refract(np.broadcast_to(-o, (n, 3)), m1, n1), m2, n2 / n1)
    sampled = _spread(t)
    mu = math.cos(th)
    c = math.sqrt(1.0 - (1.0 - mu * mu) / n1 ** 2)
    e12 = n2 / n1
    cs = math.sqrt(1.0 - (1.0 - c * c) / e12 ** 2)
    model = E.convolve(ops, E.alpha_to_v(ops, a1) * (mu - n1 * c) ** 2 / (n2 * n2 * cs),
                       E.alpha_to_v(ops, a2) * (c - e12 * cs) ** 2 / (e12 * e12 * cs))
    assert abs(model / sampled - 1.0) < 0.03, (model, sampled)


@pytest.mark.parametrize("degrees", [0.0, 30.0, 45.0, 60.0])
def test_one_bounce_paths_are_round_in_half_vector_space(degrees):
    """The one-bounce path alone (Eq. 26's paths, traced exactly) spreads its half vectors alike
    along and across the plane of incidence, as Eq. 19's round NDF says, while its exit directions
    spread 1 / mu times more along the plane than across it: what widens the model's lobe across
    the plane is the light that met the base more than once (``endf`` module docstring)."""
    eta, n, a = 1.5, 400_000, 0.05
    ops = NumpyOps()
    rng = np.random.default_rng(11)
    th = math.radians(degrees)
    o = np.array([math.sin(th), 0.0, math.cos(th)])
    kappa = 1.0 / E.alpha_to_v(ops, a)
    m1, m2, m3 = (_sample_vmf(rng, kappa, n) for _ in range(3))
    out = _refract(_reflect(_refract(np.broadcast_to(-o, (n, 3)), m1, eta), m2), -m3, 1.0 / eta)
    out = out[out[:, 2] > 0]
    h = out + o
    ratio = np.std(h[:, 1] / h[:, 2]) / np.std(h[:, 0] / h[:, 2])
    assert 0.9 < ratio < 1.15, ratio
    mean = out.mean(0) / np.linalg.norm(out.mean(0))
    x = np.cross([0.0, 1.0, 0.0], mean)
    x /= np.linalg.norm(x)
    exit_ratio = np.std(out @ x) / np.std(out @ np.cross(mean, x))
    assert exit_ratio == pytest.approx(1.0 / math.cos(th), rel=0.1)


@pytest.mark.parametrize("degrees", [0.0, 30.0, 60.0, 75.0])
def test_the_subsurface_lobe_has_round_exit_directions(degrees):
    """The printed lobe over a dielectric base: round at normal incidence, and for a narrow lobe
    across the plane 1 / mu times its roughness along it, with Eq. 19's solid angle (their
    geometric mean); its axes turn with the view's azimuth."""
    ops = NumpyOps()
    mu = math.cos(math.radians(degrees))
    v = E.alpha_to_v(ops, 0.002)
    along, across = E.round_exit_alphas(ops, v, mu)
    round_alpha = E.v_to_alpha(ops, v / (4.0 * mu))
    assert across / along == pytest.approx(1.0 / mu, rel=0.01)
    assert math.sqrt(along * across) == pytest.approx(round_alpha, rel=0.01)
    s = _stack(0.05, 0.08, base="dielectric")
    azimuth = 0.7
    sin_t = math.sin(math.radians(degrees))
    lb = lc.lobes(s, np.array([[sin_t * math.cos(azimuth), sin_t * math.sin(azimuth), mu]]), "endf")
    assert lb.alpha_y[0, 1] >= lb.alpha_x[0, 1]
    if degrees > 0.0:
        assert lb.rotation[0, 1] == pytest.approx(azimuth)
        # broad lobes narrow across toward grazing, where the horizon cuts them (ROUND_EXIT_SATURATION)
        assert lb.alpha_y[0, 1] / lb.alpha_x[0, 1] > 1.0 + 0.5 * (min(1.0 / mu, 2.0) - 1.0)
    else:
        assert lb.alpha_y[0, 1] == pytest.approx(lb.alpha_x[0, 1])
    # over a conductor the subsurface lobe stays Eq. 19's round NDF
    over_metal = lc.lobes(_stack(0.05, 0.08), np.array([[sin_t, 0.0, mu]]), "endf")
    assert over_metal.alpha_y[0, 1] == over_metal.alpha_x[0, 1]


def _stack(a1=0.05, a2=0.08, base="conductor", **coat):
    b = {"type": "conductor", "roughness": a2} if base == "conductor" else {"type": "dielectric", "ior": 1.5,
                                                                            "roughness": a2}
    return Stack.from_dict({"layers": [{"ior": 1.5, "roughness": a1, **coat}], "base": b})


def test_energies_are_the_adding_equations_and_the_top_lobe_is_the_interface():
    wi = np.array([[0.3, 0.1, math.sqrt(1 - 0.1)]])
    for base in ("conductor", "dielectric"):
        s = _stack(base=base, thickness=0.5, sigma_a=[0.2, 0.8, 0.8])
        e, b = lc.lobes(s, wi, "endf"), lc.lobes(s, wi, "belcour2018")
        np.testing.assert_allclose(e.weight, b.weight, rtol=1e-12)
        assert e.kinds == b.kinds
        assert e.alpha_x[0, 0] == pytest.approx(0.05)


def test_smooth_layer_gives_delta_lobes():
    lb = lc.lobes(_stack(0.0, 0.0, base="dielectric"), np.array([[0.5, 0.0, math.sqrt(0.75)]]), "endf")
    assert (lb.alpha_x == 0.0).all()


def test_base_roughness_seen_through_the_coat_at_normal_incidence():
    """A smooth coat of index 1.5 over a rough mirror: the base's reflected lobe spreads 2 alpha_2
    inside, the exit refraction magnifies angles by 1.5 (3 alpha_2 outside), and an NDF is half
    its reflected lobe's spread: the subsurface ENDF has roughness 1.5 alpha_2."""
    lb = lc.lobes(_stack(0.0, 0.04), np.array([[0.0, 0.0, 1.0]]), "endf")
    assert lb.alpha_x[0, 1] == pytest.approx(1.5 * 0.04, rel=1e-3)


@pytest.mark.parametrize("stack,field", [
    ({"layers": [], "base": {"type": "conductor"}}, "exactly one coat"),
    ({"layers": [{"ior": 1.5}, {"ior": 1.3}], "base": {"type": "conductor"}}, "exactly one coat"),
    ({"layers": [{"ior": 1.5, "roughness": [0.1, 0.2]}], "base": {"type": "conductor"}}, "coat 0 has anisotropic"),
    ({"layers": [{"ior": 1.5}], "base": {"type": "conductor", "roughness": [0.1, 0.2]}}, "the base has anisotropic"),
    ({"layers": [{"ior": 1.5, "thickness": 1, "sigma_s": [1, 1, 1]}], "base": {"type": "conductor"}}, "coat 0 scatters"),
    ({"layers": [{"ior": 1.5}], "base": {"type": "diffuse"}}, r"the base \(diffuse\) has no interface"),
])
def test_refusals_say_what_and_where(stack, field):
    with pytest.raises(UnsupportedStack, match=field):
        lc.lobes(stack, np.array([[0.0, 0.0, 1.0]]), "endf")


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(a1=st.sampled_from([0.0, 1e-7, 1e-3, 0.5, 1.0]) | st.floats(0.0, 1.0),
       a2=st.sampled_from([0.0, 1e-7, 1e-3, 0.5, 1.0]) | st.floats(0.0, 1.0),
       ior=st.sampled_from([1.0, 1.0 + 1e-7, 0.25, 0.3, 1.5, 4.0]) | st.floats(0.25, 4.0),  # the schema limits
       base_ior=st.sampled_from([1.0, 0.5, 1.5, 4.0]) | st.floats(0.25, 4.0),
       dielectric=st.booleans(), sigma=st.sampled_from([0.0, 1e-6, 1.0, 1e3]))
def test_every_output_is_finite_and_passive(dtype, a1, a2, ior, base_ior, dielectric, sigma):
    base = ({"type": "dielectric", "ior": base_ior, "roughness": a2} if dielectric
            else {"type": "conductor", "roughness": a2})
    s = {"layers": [{"ior": ior, "roughness": a1, "thickness": 1.0, "sigma_a": [sigma, 0.0, 1.0]}], "base": base}
    cos = np.array([0.0, 1e-7, 1e-3, 0.2, 0.5, 0.9, 1.0 - 1e-7, 1.0])
    phi = np.linspace(0.0, 2 * np.pi, len(cos), endpoint=False) + 0.3
    wi = np.stack([np.sqrt(1 - cos ** 2) * np.cos(phi), np.sqrt(1 - cos ** 2) * np.sin(phi), cos], -1)
    wo = wi[::-1] * np.array([1.0, 1.0, -1.0 if dielectric else 1.0])
    lb = lc.lobes(s, wi, "endf", dtype=dtype)
    for a in (lb.weight, lb.alpha_x, lb.alpha_y):
        assert a.dtype == dtype and np.isfinite(a).all()
    assert (lb.weight >= 0).all() and ((lb.alpha_x >= 0) & (lb.alpha_x <= 1)).all()
    f = lc.evaluate(s, wi, wo, "endf", dtype=dtype)
    assert np.isfinite(f).all() and (f >= 0).all()
