"""The stochastic reference against exact results: analytic single interfaces (Walter et al. 2007),
closed-form smooth stacks, Beer-Lambert, reciprocity, energy bounds, and the consistency of its
two estimators (the hemispherical integral of eval_brdf_cos equals the non-delta albedo), which
is what catches a missed or double-counted path in the next-event estimation."""
import numpy as np
import pytest

from lamella_dev import reference as R
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.models.fresnel import fresnel_conductor, fresnel_dielectric
from lamella.core.models.ggx import ggx_d

from .stacks import GOLD, coat, gold, stack
from .test_models import SMOOTH, closed_form_smooth, directions

OPS = NumpyOps()


def unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def lam(w, ax, ay):
    return 0.5 * (np.sqrt(1.0 + (ax ** 2 * w[:, 0] ** 2 + ay ** 2 * w[:, 1] ** 2) / w[:, 2] ** 2) - 1.0)


def rotate(w, r):
    c, s = np.cos(r), np.sin(r)
    return np.stack([w[:, 0] * c + w[:, 1] * s, -w[:, 0] * s + w[:, 1] * c, w[:, 2]], -1)


def walter(wi, wo, ax, ay, rot, eta):
    """Walter et al. 2007 Eqs. (20)-(21) times |wo.z|, light from index 1 onto index eta,
    G2 = 1 / (1 + Lambda(i) + Lambda(o)); independent of the reference's code."""
    i, o = rotate(wi, rot), rotate(wo, rot)
    g2 = 1.0 / (1.0 + lam(i, ax, ay) + lam(o, ax, ay))
    refl = o[:, 2] > 0
    h = np.where(refl[:, None], unit(i + o), unit(-(i + eta * o)))
    h *= np.sign(h[:, 2])[:, None]
    ih, oh = (i * h).sum(1), (o * h).sum(1)
    D = ggx_d(OPS, h[:, 0], h[:, 1], h[:, 2], ax, ay)
    F = fresnel_dielectric(OPS, ih, eta)
    fr = F * D * g2 / (4 * i[:, 2])
    ft = np.abs(ih * oh) * eta ** 2 * (1 - F) * D * g2 / (i[:, 2] * (ih + eta * oh) ** 2)
    return np.where(refl, fr, np.where((ih > 0) & (oh < 0), ft, 0.0))


def test_single_rough_conductor_is_the_analytic_brdf():
    d = stack(base=gold([0.3, 0.1], 0.4))
    wi = directions([40.0])[0]
    wo = directions([5.0, 30.0, 50.0, 70.0, 85.0], phi=2.0)
    mean, err = R.eval_brdf_cos(d, wi, wo, spp=64, seed=1)
    i, o = rotate(np.broadcast_to(wi, wo.shape), 0.4), rotate(wo, 0.4)
    h = unit(i + o)
    g2 = 1.0 / (1.0 + lam(i, 0.3, 0.1) + lam(o, 0.3, 0.1))
    D = ggx_d(OPS, h[:, 0], h[:, 1], h[:, 2], 0.3, 0.1)
    F = np.stack([fresnel_conductor(OPS, (i * h).sum(1), e, k) for e, k in zip(GOLD["eta"], GOLD["k"])], -1)
    exact = F * (D * g2 / (4 * i[:, 2]))[:, None]
    np.testing.assert_allclose(mean, exact, rtol=1e-10)  # one event: NEE is exact


@pytest.mark.parametrize("rot,ior", [(0.0, 1.5), (0.7, 1.5), (0.3, 1.0 / 1.5)])
def test_single_rough_dielectric_is_walter_2007(rot, ior):
    """Both sides of an interface: ior 1/1.5 is light leaving glass (total internal reflection)."""
    d = {"layers": [], "base": {"type": "dielectric", "ior": ior, "roughness": [0.3, 0.15], "rotation": rot}}
    wi = directions([35.0])[0]
    wo = np.concatenate([directions([10.0, 40.0, 70.0], phi=3.0), directions([10.0, 30.0, 60.0], phi=0.5) * [1, 1, -1]])
    mean, _ = R.eval_brdf_cos(d, wi, wo, spp=16, seed=2)
    assert mean.max() > 0
    exact = walter(np.broadcast_to(wi, wo.shape), wo, 0.3, 0.15, rot, ior)
    np.testing.assert_allclose(mean, np.repeat(exact[:, None], 3, 1), rtol=1e-9)


@pytest.mark.parametrize("d", SMOOTH)
def test_smooth_stacks_match_the_closed_form_series(d):
    wi = directions([0.0, 45.0, 80.0])
    mean, err = R.albedo(d, wi, spp=100_000, seed=3)
    want = closed_form_smooth(d, wi[:, 2])
    assert (np.abs(mean - want) <= 4.5 * err + 1e-6).all(), (mean, want, err)


def test_beer_lambert_is_exact():
    """An index-matched smooth absorbing coat over a smooth conductor: every path is
    deterministic, so the estimate equals F exp(-2 sigma_a d / mu) to rounding."""
    sig = np.array([0.3, 1.0, 2.0])
    d = stack(coat(1.0, thickness=0.7, sigma_a=sig), base=gold(0.0))
    wi = directions([0.0, 50.0, 75.0])
    mean, err = R.albedo(d, wi, spp=1000, seed=4)
    mu = wi[:, 2:3]
    F = np.stack([fresnel_conductor(OPS, wi[:, 2], e, k) for e, k in zip(GOLD["eta"], GOLD["k"])], -1)
    np.testing.assert_allclose(mean, F * np.exp(-2 * sig * 0.7 / mu), rtol=1e-12)
    assert (err < 1e-8).all()  # zero up to the rounding of E[x^2] - E[x]^2


def upper(n):
    """Equal-area grid (z uniform) of the upper hemisphere and its solid-angle weight."""
    z = (np.arange(n) + 0.5) / n
    ph = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * np.pi
    Z, P = np.meshgrid(z, ph, indexing="ij")
    r = np.sqrt(1 - Z ** 2)
    w = np.stack([r * np.cos(P), r * np.sin(P), Z], -1).reshape(-1, 3)
    return w, 2 * np.pi / len(w)


CONSISTENCY = {
    "smooth coat over rough conductor": stack(coat(1.5), base=gold(0.3)),
    "rough coat over smooth conductor": stack(coat(1.5, 0.3), base=gold(0.0)),
    "two smooth coats over rough conductor": stack(coat(1.5), coat(1.2, thickness=0.5, sigma_a=(0.2, 0.5, 1.0)), base=gold(0.4)),
    "scattering coat between smooth top and smooth conductor":
        {"layers": [{"ior": 1.3, "thickness": 1.0, "sigma_s": [0.5, 1, 2], "sigma_a": [0.1, 0.1, 0.1], "g": 0.5}], "base": gold(0.0)},
    "smooth coat over diffuse": stack(coat(1.5), base={"type": "diffuse", "albedo": [0.2, 0.5, 0.8]}),
    "rough coats, rotated": stack(coat(1.4, 0.3), coat(1.8, [0.4, 0.2], rotation=1.0), base=gold(0.3)),
}


@pytest.mark.parametrize("interfaces", R.INTERFACES)
@pytest.mark.parametrize("name", list(CONSISTENCY))
def test_eval_integrates_to_the_albedo(name, interfaces):
    d = CONSISTENCY[name]
    wo, dw = upper(24)
    wi = np.array([np.sin(0.6), 0.0, np.cos(0.6)])
    mean, err = R.eval_brdf_cos(d, wi, wo, spp=128, seed=5, interfaces=interfaces)
    integral, ierr = (mean * dw).sum(0), np.sqrt(((err * dw) ** 2).sum(0))
    alb, aerr = R.albedo(d, wi, spp=100_000, seed=6, exclude_delta=True, interfaces=interfaces)
    tol = 4.5 * np.sqrt(ierr ** 2 + aerr[0] ** 2) + 0.004  # + grid quadrature of lobes alpha >= 0.3
    assert (np.abs(integral - alb[0]) <= tol).all(), (integral, alb[0], tol)


def test_transmission_integrates_to_the_transmitted_albedo():
    d = stack(coat(1.3, 0.3), base={"type": "dielectric", "ior": 1.6, "roughness": 0.35})
    wo, dw = upper(24)
    wo = wo * [1, 1, -1]
    wi = np.array([np.sin(0.5), 0.0, np.cos(0.5)])
    mean, err = R.eval_brdf_cos(d, wi, wo, spp=128, seed=7)
    integral, ierr = (mean * dw).sum(0), np.sqrt(((err * dw) ** 2).sum(0))
    alb, aerr = R.albedo(d, wi, spp=100_000, seed=8, side="transmitted", exclude_delta=True)
    assert (np.abs(integral - alb[0]) <= 4.5 * np.sqrt(ierr ** 2 + aerr[0] ** 2) + 0.006).all()


@pytest.mark.parametrize("interfaces", R.INTERFACES)
def test_reciprocity(interfaces):
    d = stack(coat(1.5, 0.2), coat(1.3, [0.3, 0.1], rotation=0.5, thickness=0.3, sigma_a=(0.3, 0.1, 0.5)), base=gold(0.25))
    a = unit([[0.3, 0.2, 0.93], [0.5, -0.4, 0.77]])
    b = unit([[-0.5, 0.1, 0.86], [0.1, 0.6, 0.79]])
    m1, e1 = R.eval_brdf_cos(d, a, b, spp=60_000, seed=9, interfaces=interfaces)
    m2, e2 = R.eval_brdf_cos(d, b, a, spp=60_000, seed=10, interfaces=interfaces)
    f1, f2 = m1 / b[:, 2:3], m2 / a[:, 2:3]
    s = np.sqrt((e1 / b[:, 2:3]) ** 2 + (e2 / a[:, 2:3]) ** 2)
    assert (np.abs(f1 - f2) <= 4.5 * s).all(), (f1, f2, s)


def test_lossless_stack_never_exceeds_one():
    d = stack(coat(1.4, 0.2), coat(1.7, 0.1), base={"type": "dielectric", "ior": 1.5, "roughness": 0.3})
    wi = directions([0.0, 60.0, 85.0])
    r, er = R.albedo(d, wi, spp=100_000, seed=11)
    t, et = R.albedo(d, wi, spp=100_000, seed=11, side="transmitted")
    total = r + t  # same seed: the same packets, so this is one estimate of R + T
    assert (total <= 1.0 + 4.5 * (er + et)).all()
    # single-scattering microfacets lose energy (most at grazing: 0.81 at 85 deg), little at normal incidence
    assert total[0, 0] >= 0.95
    assert (r >= 0).all() and (t >= 0).all()


def test_determinism_and_shapes():
    d = stack(coat(1.5, 0.1), base=gold(0.2))
    wo = directions([10.0, 20.0, 30.0], phi=2.5)
    a = R.eval_brdf_cos(d, directions([30.0])[0], wo, spp=64, seed=3)
    b = R.eval_brdf_cos(d, np.broadcast_to(directions([30.0])[0], wo.shape), wo, spp=64, seed=3)
    assert a[0].shape == (3, 3) and a[1].shape == (3, 3)
    np.testing.assert_array_equal(a[0], b[0])
    m, e = R.albedo(d, directions([0.0, 40.0]), spp=1000, seed=1)
    assert m.shape == (2, 3) and e.shape == (2, 3)
    with pytest.raises(ValueError, match="side"):
        R.albedo(d, directions([0.0]), spp=10, side="up")


MIRROR = {"type": "conductor", "eta": [1.0, 1.0, 1.0], "k": [1e6, 1e6, 1e6]}


def test_multiple_scattering_interfaces_conserve_energy():
    """Rough coats over a rough perfect mirror, and a rough glass stack, lossless: with
    multiple-scattering interfaces all the energy leaves (R = 1; R + T = 1), where single
    scattering loses up to 57 % of it (a mirror of alpha 0.8 at normal incidence reflects 0.43)."""
    mirror = stack(coat(1.5, 0.5), coat(1.3, [0.6, 0.2], rotation=0.8), base=dict(MIRROR, roughness=[0.8, 0.4]))
    glass = stack(coat(1.4, 0.4), base={"type": "dielectric", "ior": 1.5, "roughness": 0.6})
    wi = directions([0.0, 60.0, 85.0])
    r, er = R.albedo(mirror, wi, spp=50_000, seed=12, interfaces="multiple")
    assert np.all(np.abs(r - 1.0) <= 4.5 * er + 1e-3), (r, er)
    single, _ = R.albedo(mirror, wi, spp=50_000, seed=12)
    assert single.max() < 0.8
    r, er = R.albedo(glass, wi, spp=50_000, seed=13, interfaces="multiple")
    t, et = R.albedo(glass, wi, spp=50_000, seed=13, side="transmitted", interfaces="multiple")
    assert np.all(np.abs(r + t - 1.0) <= 4.5 * (er + et) + 1e-3), (r + t, er + et)


def test_interfaces_change_nothing_on_smooth_stacks():
    """Only rough interfaces walk on their microsurface: a smooth stack's estimates are the same
    numbers under both settings."""
    d = stack(coat(1.5, thickness=0.4, sigma_a=(0.2, 0.4, 0.8)), coat(1.2), base=gold(0.0))
    wi = directions([0.0, 50.0])
    a = R.albedo(d, wi, spp=20_000, seed=14)
    b = R.albedo(d, wi, spp=20_000, seed=14, interfaces="multiple")
    np.testing.assert_array_equal(a[0], b[0])
    with pytest.raises(ValueError, match="interfaces"):
        R.albedo(d, wi, spp=10, interfaces="double")


def test_reflected_paths_split_a_smooth_plate_into_its_series():
    """A smooth glass plate at 30 degrees: the light that never met the lower face is the top's
    Fresnel reflectance, the light that met it k times T^2 R_b^k R_t^(k-1) (R_t the top's from
    inside), every packet leaves along the mirror direction, and the split sums to the albedo."""
    from lamella.core.stack import Stack
    plate = Stack.from_dict({"layers": [coat(1.5)], "base": {"type": "dielectric", "ior": 1.0, "roughness": 0.0}})
    wi = np.array([np.sin(np.radians(30.0)), 0.0, np.cos(np.radians(30.0))])
    spp = 1 << 17
    up, energy, meetings = R.reflected_paths(plate, wi, spp, seed=3)
    assert np.allclose(up, [-wi[0], 0.0, wi[2]], atol=1e-9)
    r_top = float(fresnel_dielectric(OPS, wi[2], 1.5))
    c_in = np.sqrt(1.0 - (1.0 - wi[2] ** 2) / 1.5 ** 2)
    r_in = float(fresnel_dielectric(OPS, c_in, 1.0 / 1.5))  # the lower face and the top, from inside alike
    t = 1.0 - r_top
    want = [r_top] + [t * t * r_in ** k * r_in ** (k - 1) for k in (1, 2)]
    got = [energy[meetings == k, 0].sum() / spp for k in range(3)]
    for k in range(3):
        stderr = np.sqrt(want[k] / spp)
        assert abs(got[k] - want[k]) < 5.0 * stderr + 1e-6, (k, got[k], want[k])
    albedo, _ = R.albedo(plate, wi, spp, seed=3)
    assert abs(energy[:, 0].sum() / spp - albedo[0, 0]) < 0.01 * albedo[0, 0]


def test_the_spread_measure_reads_one_rough_interface_as_its_roughness():
    """The glass-plate bench's GGX-equivalent roughness of one rough glass surface's reflected
    light (no coat), at the plate's roughness: its own alpha along and across the plane of
    incidence at 0 and 45 degrees. (It reads the reflected light, whose half vectors are the
    visible normals the masking lets out: at alpha 0.3 it reads 0.265 at normal incidence.)"""
    from lamella.core.stack import Stack
    from lamella_dev.bench.glass_plate_paths import spread
    glass = Stack.from_dict({"layers": [], "base": {"type": "dielectric", "ior": 1.5, "roughness": 0.1}})
    for deg in (0.0, 45.0):
        wi = np.array([np.sin(np.radians(deg)), 0.0, np.cos(np.radians(deg))])
        up, energy, meetings = R.reflected_paths(glass, wi, 1 << 16, seed=4)
        assert np.all(meetings >= 1)  # the base is the only interface
        s = spread(wi, up, energy.mean(1))
        alpha = glass.base.roughness[0]
        assert abs(s["alpha_along"] / alpha - 1.0) < 0.05 and abs(s["alpha_across"] / alpha - 1.0) < 0.05, (deg, s)
        assert abs(s["centre"]) < 0.05 * alpha
