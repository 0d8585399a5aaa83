"""The multiple-scattering microsurface (Heitz, Hanika, d'Eon and Dachsbacher 2016) against what it
must satisfy: a perfect conductor reflects all the energy it receives (white furnace), a lossless
dielectric reflects and transmits all of it from either side, its single-scattering part is the
height-correlated Smith BSDF, its next-event estimate integrates to what its sampling sends out,
and it is reciprocal."""
import math

import numpy as np
import pytest

from lamella_dev import microsurface as M

MIRROR = (np.ones(3), np.full(3, 1e6))  # F = 1 at every angle
GOLD = (np.array([0.143, 0.374, 1.442]), np.array([3.983, 2.385, 1.603]))
ROUGH = [(0.3, 0.3), (1.0, 1.0), (0.8, 0.2)]


def direction(theta, phi=0.3):
    return np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)])


def sphere(rng, k):
    v = rng.normal(size=(k, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def integral(q):
    """The integral over the sphere of a density estimated at uniform random directions: (mean, stderr)."""
    return q.mean(0) * 4 * math.pi, q.std(0) * 4 * math.pi / math.sqrt(q.shape[0])


@pytest.mark.parametrize("ax,ay", ROUGH)
@pytest.mark.parametrize("theta", [0.0, 1.0, 1.45])
def test_a_perfect_conductor_reflects_everything(ax, ay, theta):
    rng = np.random.default_rng(1)
    k = 100_000
    i = np.broadcast_to(direction(theta), (k, 3)).copy()
    mean, err = integral(M.walk(i, ax, ay, rng, conductor=MIRROR, target=sphere(rng, k)))
    assert abs(mean[0] - 1.0) <= 4.5 * err[0] + 1e-3, (mean, err)
    _, weight, left = M.walk(i, ax, ay, rng, conductor=MIRROR)
    assert left.all() and np.allclose(weight, 1.0)


@pytest.mark.parametrize("ax,ay", ROUGH)
@pytest.mark.parametrize("eta", [1.5, 1 / 1.5])
def test_a_lossless_dielectric_reflects_and_transmits_everything_from_either_side(ax, ay, eta):
    rng = np.random.default_rng(2)
    k = 100_000
    for theta in (0.2, 1.3):
        i = np.broadcast_to(direction(theta), (k, 3)).copy()
        e = np.full(k, eta)
        o, weight, left = M.walk(i, ax, ay, rng, eta=e)
        assert left.all() and np.all(weight == 1.0)  # every walk leaves, up or down
        sampled_r = (o[:, 2] > 0).mean()
        target = sphere(rng, k)
        q = M.walk(i, ax, ay, rng, eta=e, target=target)[:, 0]
        r, er = integral(q * (target[:, 2] > 0))
        t, et = integral(q * (target[:, 2] < 0))
        assert abs(r + t - 1.0) <= 4.5 * math.hypot(er, et) + 2e-3, (r, t, er, et)
        assert abs(r - sampled_r) <= 4.5 * er + 4.5 * math.sqrt(sampled_r * (1 - sampled_r) / k) + 1e-3


@pytest.mark.parametrize("ax,ay", ROUGH)
def test_single_scattering_is_the_height_correlated_smith_bsdf(ax, ay):
    """Order 1 of the walk: reflection F D G2 / (4 i.z), G2 = 1 / (1 + Lambda_i + Lambda_o);
    refraction Walter et al. 2007's with G2 = B(1 + Lambda_i, 1 + Lambda_o)."""
    rng = np.random.default_rng(3)
    eta = 1.5
    i0 = direction(0.7)
    outs = [direction(0.3, 2.0), direction(1.1, -0.5), -direction(0.4, 1.0), -direction(0.9, 2.5)]
    k = 200_000
    for o0 in outs:
        i, o = np.broadcast_to(i0, (k, 3)).copy(), np.broadcast_to(o0, (k, 3)).copy()
        q = M.walk(i, ax, ay, rng, eta=np.full(k, eta), target=o, orders={1})[:, 0]
        li, lo = M.smith_lambda(i[:1], ax, ay), M.smith_lambda(o[:1], ax, ay)
        if o0[2] > 0:
            h = (i0 + o0) / np.linalg.norm(i0 + o0)
            want = M._fresnel_dielectric(i0 @ h, eta) * M._ggx_d(h[None], ax, ay) / (4 * i0[2] * (1 + li + lo))
        else:
            h = -(i0 + eta * o0)
            h = h * np.sign(h[2]) / np.linalg.norm(h)
            ih, oh = i0 @ h, o0 @ h
            want = (abs(ih * oh) * eta ** 2 * (1 - M._fresnel_dielectric(ih, eta)) * M._ggx_d(h[None], ax, ay)
                    * M.g2_transmission(li, lo) / (i0[2] * (ih + eta * oh) ** 2))
        assert abs(q.mean() - want[0]) <= 4.5 * q.std() / math.sqrt(k) + 1e-9, (o0, q.mean(), want)


@pytest.mark.parametrize("ax,ay", ROUGH)
def test_the_estimate_integrates_to_what_sampling_sends_out(ax, ay):
    """A coloured conductor: the energy the sampled walks carry out equals the integral of the
    next-event estimate, per channel."""
    rng = np.random.default_rng(4)
    k = 100_000
    i = np.broadcast_to(direction(1.0), (k, 3)).copy()
    _, weight, _ = M.walk(i, ax, ay, rng, conductor=GOLD)
    mean, err = integral(M.walk(i, ax, ay, rng, conductor=GOLD, target=sphere(rng, k)))
    sent = weight.mean(0)
    assert np.all(np.abs(mean - sent) <= 4.5 * (err + weight.std(0) / math.sqrt(k)) + 1e-3), (mean, sent)


@pytest.mark.parametrize("conductor", [True, False])
def test_reciprocity(conductor):
    """f(i, o) = f(o, i) for reflection (Heitz et al. 2016, Sec. 5.3)."""
    rng = np.random.default_rng(5)
    ax, ay = 0.7, 0.3
    k = 200_000
    pairs = [(direction(0.3, 0.2), direction(1.2, 2.0)), (direction(0.9, -1.0), direction(0.5, 0.7))]
    for a, b in pairs:
        args = {"conductor": GOLD} if conductor else {"eta": np.full(k, 1.5)}
        q1 = M.walk(np.broadcast_to(a, (k, 3)).copy(), ax, ay, rng, target=np.broadcast_to(b, (k, 3)).copy(), **args)
        q2 = M.walk(np.broadcast_to(b, (k, 3)).copy(), ax, ay, rng, target=np.broadcast_to(a, (k, 3)).copy(), **args)
        f1, f2 = q1.mean(0) / b[2], q2.mean(0) / a[2]
        s = np.hypot(q1.std(0) / b[2], q2.std(0) / a[2]) / math.sqrt(k)
        assert np.all(np.abs(f1 - f2) <= 4.5 * s + 1e-6), (f1, f2, s)


def test_visible_normals_below_the_horizon_follow_their_distribution():
    """The spherical-cap sampler for a view below the horizon (an upward ray hitting the
    microsurface from below a peak): the mean of a test function under the samples equals its
    integral against D_i."""
    rng = np.random.default_rng(6)
    ax, ay = 0.6, 0.3
    i = direction(1.9, 0.4)  # 109 degrees from the normal
    k = 400_000
    m = M.sample_vndf_sphere(np.broadcast_to(i, (k, 3)).copy(), ax, ay, rng.random(k), rng.random(k))
    assert np.all(m @ i >= -1e-12)
    g = rng.normal(size=(k, 3))
    u = g / np.linalg.norm(g, axis=1, keepdims=True)
    u[:, 2] = np.abs(u[:, 2])  # uniform on the upper hemisphere, density 1 / (2 pi)
    dens = M.visible_ndf(np.broadcast_to(i, (k, 3)).copy(), u, ax, ay)
    for fn in (lambda v: v[:, 0], lambda v: v[:, 2] ** 2, lambda v: v[:, 1] * v[:, 0]):
        want = (fn(u) * dens).mean() * 2 * math.pi
        err = (fn(u) * dens).std() * 2 * math.pi / math.sqrt(k)
        assert abs(fn(m).mean() - want) <= 4.5 * err + 2e-3, (fn(m).mean(), want, err)
