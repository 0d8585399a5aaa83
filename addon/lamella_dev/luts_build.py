"""The generation of the pre-integrated tables of ``lamella.core.luts`` (numerical integration over
the GGX visible normals, Heitz 2018's sampler, and the random walk on the microsurface of Heitz et
al. 2016): ``lamella luts`` writes what ``generate`` returns. Development only: the extension
ships the tables, not their generator."""
from __future__ import annotations

import math

import numpy as np

from lamella.core.luts import (N_ALPHA, N_FE_ALPHA, N_FE_ETA, N_FE_MU, N_HAT, N_HG_C, N_HG_G, N_HG_S, N_MS_ALPHA,
                               N_MS_ETA, N_MS_X, N_MU, N_TIR_ETA, N_TIR_U, REFRACT_ETA, _alpha_nodes, _g_nodes,
                               _ms_eta_nodes, _mu_nodes, _tir_eta_nodes, hat, ms_sine)

from .microsurface import sample_vndf, smith_lambda


def _stratified(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """n x n midpoint rule on the VNDF sample square, with u1 = 1 - (1 - t)^3 so the cells crowd
    into GGX's heavy tail (u1 -> 1), where total internal reflection and the horizon cut the
    integrand. Returns (u1, u2, weight); estimates are mean(weight * f)."""
    g = (np.arange(n) + 0.5) / n
    t1, u2 = np.meshgrid(g, g, indexing="ij")
    t1, u2 = t1.ravel(), u2.ravel()
    return 1.0 - (1.0 - t1) ** 3, u2, 3.0 * (1.0 - t1) ** 2


def _vndf_reflect(mu: np.ndarray, alpha: np.ndarray, u1: np.ndarray, u2: np.ndarray):
    """Isotropic GGX, wi = (sqrt(1 - mu^2), 0, mu): reflections of visible normals sampled with
    the reference's sampler (Heitz 2018). Returns (c = wi.h, wo, weight) where the albedo integral
    of F(c) is E[F(c) * weight], weight = G2(wi, wo) / G1(wi) for wo above the horizon
    (G2 = 1 / (1 + Lambda(wi) + Lambda(wo)), the convention of models/ggx.py). ``mu`` is a
    scalar array of shape (1, 1), ``alpha`` (A, 1), ``u1``/``u2`` (S,); results are (A, S)."""
    a = np.broadcast_to(alpha, (alpha.shape[0], u1.size)).ravel()
    m = float(np.asarray(mu).ravel()[0])
    wi = np.array([math.sqrt(max(1.0 - m * m, 0.0)), 0.0, m])
    wis = np.broadcast_to(wi, (a.size, 3))
    h = sample_vndf(wis, a, a, np.tile(u1, alpha.shape[0]), np.tile(u2, alpha.shape[0]))
    c = h @ wi
    wo = 2.0 * c[:, None] * h - wi
    lam_i = smith_lambda(wis, a, a)
    lam_o = smith_lambda(wo, a, a)
    weight = np.where(wo[:, 2] > 0, (1.0 + lam_i) / (1.0 + lam_i + lam_o), 0.0)
    shape = (alpha.shape[0], u1.size)
    return c.reshape(shape), tuple(wo[:, k].reshape(shape) for k in range(3)), weight.reshape(shape)


MU_FLOOR = 1e-4  # the mu = 0 nodes are integrated at this cosine (the limit is continuous)


def _hat_np(c: np.ndarray, j: int) -> np.ndarray:
    left, right = hat(c, j)
    one = np.ones_like(c)
    return np.clip(np.minimum(left if left is not None else one, right if right is not None else one), 0.0, 1.0)


def generate_ggx_albedo(n_samples: int = 160) -> dict[str, np.ndarray]:
    mu = np.maximum(_mu_nodes(N_MU), MU_FLOOR)
    alpha = np.maximum(_alpha_nodes(N_ALPHA), 1e-6)[:, None]
    u1, u2, wt = _stratified(n_samples)
    A = np.zeros((N_MU, N_ALPHA))
    H = np.zeros((N_MU, N_ALPHA, N_HAT))
    for i, m in enumerate(mu):
        c, _, w = _vndf_reflect(np.array([[m]]), alpha, u1, u2)
        w = w * wt
        c = np.clip(c, 0.0, 1.0)
        A[i] = w.mean(-1)
        for j in range(N_HAT):
            H[i, :, j] = (w * _hat_np(c, j)).mean(-1) - _hat_np(np.array(m), j)
    A[:, 0] = 1.0  # alpha = 0: a mirror, exactly
    H[:, 0, :] = 0.0
    return {"ggx_albedo": A, "fresnel_hat_delta": H}


def generate_tir(n_samples: int = 160) -> np.ndarray:
    u = np.linspace(0.0, 1.0, N_TIR_U)
    alpha = _alpha_nodes(N_ALPHA)
    etas = _tir_eta_nodes(N_TIR_ETA)
    us1, us2, wt = _stratified(n_samples)
    out = np.ones((N_TIR_U, N_ALPHA, N_TIR_ETA))
    for k, eta in enumerate(etas):
        sin_t = np.minimum(u * eta, 1.0)
        mu = np.maximum(np.sqrt(1.0 - sin_t * sin_t), MU_FLOOR)
        for i, m in enumerate(mu):
            _, (ox, oy, oz), w = _vndf_reflect(np.array([[m]]), np.maximum(alpha, 1e-6)[:, None], us1, us2)
            w = w * wt
            inside = (ox * ox + oy * oy) < eta * eta
            tot = w.sum(-1)
            out[i, :, k] = np.where(tot > 0, (w * inside).sum(-1) / np.maximum(tot, 1e-30), 1.0)
    out[:, 0, :] = 1.0  # a delta lobe along a refracted-in direction always escapes
    out[:, :, -1] = 1.0  # eta = 1: every upper-hemisphere direction escapes (exactly, not 1 - rounding)
    return out


def generate_refract_albedo(n_samples: int = 160, eta: float = REFRACT_ETA) -> np.ndarray:
    """What Cycles' refracting GGX closure (isotropic, no Fresnel) transmits at weight 1: its
    sampling weight E[(1 + Lambda_i) / (1 + Lambda_i + Lambda_o)] over visible normals, the
    refracted direction wo = refract(wi, h, 1 / eta) kept when it lies below the closure's normal
    (Cycles' ``bsdf_microfacet_sample``; Walter et al. 2007 Eq. 40 for the refraction)."""
    mu = np.maximum(_mu_nodes(N_MU), MU_FLOOR)
    alphas = np.maximum(_alpha_nodes(N_ALPHA), 1e-6)
    u1, u2, wt = _stratified(n_samples)
    out = np.ones((N_MU, N_ALPHA))
    for i, m in enumerate(mu):
        wi = np.array([math.sqrt(max(1.0 - m * m, 0.0)), 0.0, m])
        for j, a in enumerate(alphas):
            wis = np.broadcast_to(wi, (u1.size, 3))
            h = sample_vndf(wis, np.full(u1.size, a), np.full(u1.size, a), u1, u2)
            c = h @ wi
            e2 = eta * eta - (1.0 - c * c)
            wo = (c / eta - np.sqrt(np.maximum(e2, 0.0)) / eta)[:, None] * h - wi / eta
            lam_i = smith_lambda(wis, a, a)
            lam_o = smith_lambda(wo, a, a)
            w = np.where((e2 > 0) & (wo[:, 2] < 0), (1.0 + lam_i) / (1.0 + lam_i + lam_o), 0.0)
            out[i, j] = np.mean(w * wt)
    out[:, 0] = 1.0  # alpha = 0: a delta straight through
    return out


MS_WALKS, MS_SEED = 1 << 16, 7  # walks per cell of dielectric_rough_reflect, and their random numbers


def _over_ms_axes(cell, walks: int, seed: int) -> np.ndarray:
    """``cell(sine, alpha, eta, walks, seed)`` at every node of the (direction, alpha, eta) axes of
    the multiple-scattering tables."""
    out = np.zeros((N_MS_X, N_MS_ALPHA, N_MS_ETA))
    for i, c in enumerate(np.linspace(0.0, 1.0, N_MS_X)):
        for j, a in enumerate(_alpha_nodes(N_MS_ALPHA)):
            for k, eta in enumerate(_ms_eta_nodes(N_MS_ETA)):
                out[i, j, k] = cell(ms_sine(float(c), float(eta)), float(a), float(eta), walks, seed)
    return out


def dielectric_rough_reflect_cell(s: float, alpha: float, eta: float, walks: int = MS_WALKS,
                                  seed: int = MS_SEED) -> float:
    """One value of ``dielectric_rough_reflect`` at the direction of sine ``s``: the share of
    ``walks`` random walks on the microsurface (Heitz et al. 2016) that leave on the side they came
    from; at alpha = 0 the smooth interface's Fresnel factor."""
    from .microsurface import _fresnel_dielectric, walk

    s = min(s, 1.0)
    mu = max(math.sqrt(max(1.0 - s * s, 0.0)), MU_FLOOR)
    if alpha <= 0.0 or abs(eta - 1.0) < 1e-12:
        return float(_fresnel_dielectric(np.array([mu]), np.array([eta]))[0])
    wi = np.broadcast_to(np.array([math.sqrt(max(1.0 - mu * mu, 0.0)), 0.0, mu]), (walks, 3))
    o, _, left = walk(wi, alpha, alpha, np.random.default_rng(seed), eta=np.full(walks, eta))
    return float(np.mean(left & (o[:, 2] > 0)))


def generate_dielectric_rough_reflect(walks: int = MS_WALKS, seed: int = MS_SEED) -> np.ndarray:
    """The directional reflectance of an energy-conserving rough dielectric interface (Heitz,
    Hanika, d'Eon and Dachsbacher 2016, Sections 5-6: the random walk on the microsurface,
    reflecting and refracting at every facet) over (direction, alpha, eta), light
    arriving from the side of index n1 onto eta = n2 / n1 (``dielectric_rough_reflect_cell``).
    One minus it is the interface's transmittance, as the walk conserves energy. The models use it
    from the denser side, where single-scattering FGD falls short: the light one facet sends on
    meets others past their own critical angle (alpha 0.3, eta 1 / 1.5, 37 degrees: 0.13 more than
    single scattering), and FGD's Fresnel quadrature rounds the kink of the Fresnel curve at the
    critical angle off differently for every eta (errors up to 0.15 there). The direction axis puts
    that critical angle, and grazing, on nodes for every eta (``ms_x_to_coord``). The table holds the
    reflectance itself, which roughness makes smooth across the critical angle; the smooth
    interface's Fresnel factor jumps there, so the models hand over to it below alpha 0.02
    (``fgd.fgd_dielectric``). Every cell uses the same random numbers, so the table is smooth in its
    parameters. About 7 minutes."""
    return _over_ms_axes(dielectric_rough_reflect_cell, walks, seed)


def dielectric_trapped_escape_cell(s: float, alpha: float, eta: float, walks: int = MS_WALKS,
                                   seed: int = MS_SEED) -> float:
    """One value of ``dielectric_trapped_escape`` at the direction of sine ``s``: of the walks of
    ``dielectric_rough_reflect_cell`` (the same random numbers) that leave on the side they came
    from, sent back by a mirror parallel to the interface, the share that crosses the interface on
    their second arrival (a second walk). At alpha = 0 the reflected light comes back along the
    direction it came, and the value is the smooth interface's transmittance."""
    from .microsurface import _fresnel_dielectric, walk

    s = min(s, 1.0)
    mu = max(math.sqrt(max(1.0 - s * s, 0.0)), MU_FLOOR)
    smooth = 1.0 - float(_fresnel_dielectric(np.array([mu]), np.array([eta]))[0])
    if alpha <= 0.0 or abs(eta - 1.0) < 1e-12:
        return smooth
    wi = np.broadcast_to(np.array([math.sqrt(max(1.0 - mu * mu, 0.0)), 0.0, mu]), (walks, 3))
    o, _, left = walk(wi, alpha, alpha, np.random.default_rng(seed), eta=np.full(walks, eta))
    back = left & (o[:, 2] > 0)
    if not back.any():
        return smooth
    # the mirror sends a reflected direction o back as (o_x, o_y, -o_z): arriving along -i, i = (-o_x, -o_y, o_z)
    again = np.stack([-o[back, 0], -o[back, 1], o[back, 2]], 1)
    o2, _, left2 = walk(again, alpha, alpha, np.random.default_rng(seed + 1), eta=np.full(len(again), eta))
    return float(np.mean(left2 & (o2[:, 2] < 0)))


def generate_dielectric_trapped_escape(walks: int = MS_WALKS, seed: int = MS_SEED) -> np.ndarray:
    """How easily the light a rough dielectric interface reflects back comes through it on its next
    arrival, over the axes of ``dielectric_rough_reflect`` (``dielectric_trapped_escape_cell``; the
    energy-conserving interface of Heitz, Hanika, d'Eon and Dachsbacher 2016). From the denser
    side most of what a rough interface reflects has been turned past the critical angle by
    facets reflecting totally, and it stays trapped: for alpha 0.1, eta 1 / 1.5 and light going up
    at 35 degrees (60 degrees outside), 0.78 of the light crosses on its first arrival but only 0.26
    of what came back. The adding equations that take every round trip as the first overestimate
    what a coated conductor returns at oblique views (``models.adding_doubling``). About 9 minutes."""
    return _over_ms_axes(dielectric_trapped_escape_cell, walks, seed)


# The trapping tables: walks per cell, their random numbers (the same in every cell), the view
# cosine the grazing nodes stand for, the round trips of the equilibrium run and how many of the
# first ones it leaves out (after three the share per round trip no longer changes: 0.28, 0.28,
# 0.28, 0.29 for a coat of alpha 0.3 over a mirror, from 0.28 to 0.85 on the first one with the
# view)
FE_WALKS, FE_SEED = 1 << 14, 11
FE_MU_FLOOR = 0.01
FE_TRIPS, FE_SETTLE = 8, 3
# a conductor that reflects everything: the trapping tables are geometric, the models put the base's
# reflectance in per round trip
_PERFECT_REFLECTOR = (np.ones(3), np.full(3, 1e4))
_SMOOTH_ALPHA = 1e-4  # the walk's stand-in for a smooth interface


def _walk_alpha(a: float) -> float:
    return max(a, _SMOOTH_ALPHA)


def _on_base(down: np.ndarray, a_base: float, rng) -> np.ndarray:
    """The directions the base sends up rays arriving along ``down`` (a mirror at alpha 0, else the
    random walk on a perfectly reflecting microsurface, every order)."""
    from .microsurface import walk

    if a_base <= 0.0:
        return down * np.array([1.0, 1.0, -1.0])
    o, _, left = walk(-down, a_base, a_base, rng, conductor=_PERFECT_REFLECTOR)
    return o[left & (o[:, 2] > 0)]


def _up_through_coat(up: np.ndarray, a_coat: float, n: float, rng):
    """Rays going up along ``up`` inside a coat of index ``n`` meet its rough top interface (the
    walk from the denser side, in that side's frame): (which cross it, the directions of those it
    sends back down)."""
    from .microsurface import walk

    i = np.stack([-up[:, 0], -up[:, 1], up[:, 2]], 1)  # arriving along -i in the frame of the coat's side
    o, _, left = walk(i, _walk_alpha(a_coat), _walk_alpha(a_coat), rng, eta=np.full(len(up), 1.0 / n))
    back = o[left & (o[:, 2] > 0)]
    return left & (o[:, 2] < 0), back * np.array([1.0, 1.0, -1.0])


def _into_coat(mu: float, a_coat: float, n: float, walks: int, rng) -> np.ndarray:
    """The directions of the light a rough coat of index ``n`` refracts in from the view of cosine
    ``mu`` (the walks that cross it)."""
    from .microsurface import walk

    mu = max(mu, FE_MU_FLOOR)
    wi = np.broadcast_to(np.array([math.sqrt(1.0 - mu * mu), 0.0, mu]), (walks, 3))
    o, _, left = walk(wi, _walk_alpha(a_coat), _walk_alpha(a_coat), rng, eta=np.full(walks, n))
    return o[left & (o[:, 2] < 0)]


def coat_first_escape_cell(mu: float, a_coat: float, a_base: float, eta: float, walks: int = FE_WALKS,
                           seed: int = FE_SEED) -> float:
    """One value of ``coat_first_escape``: of ``walks`` rays from the view of cosine ``mu`` that
    a rough coat (index 1 / ``eta``) refracts in, reflected by the base, the share that crosses the
    coat on the first way up. With eta = 1 the coat is not there: all of it."""
    if eta >= 1.0 - 1e-9:
        return 1.0
    rng = np.random.default_rng(seed)
    n = 1.0 / eta
    down = _into_coat(mu, a_coat, n, walks, rng)
    if len(down) == 0:
        return 0.0
    crossed, _ = _up_through_coat(_on_base(down, a_base, rng), a_coat, n, rng)
    return float(crossed.sum() / len(down))


def coat_trapped_equilibrium_cell(a_coat: float, a_base: float, eta: float, walks: int = FE_WALKS,
                                  seed: int = FE_SEED) -> float:
    """One value of ``coat_trapped_equilibrium``: light refracted in at normal incidence goes
    between base and coat for ``FE_TRIPS`` round trips (the rays the coat sends back drawn again to
    ``walks`` when fewer are left, so the estimate keeps its precision); the share of the rays
    reaching the coat that cross it, over the round trips after the first ``FE_SETTLE``."""
    if eta >= 1.0 - 1e-9:
        return 1.0
    rng = np.random.default_rng(seed)
    n = 1.0 / eta
    down = _into_coat(1.0, a_coat, n, walks, rng)
    crossed_sum, arrived = 0, 0
    for trip in range(FE_TRIPS):
        up = _on_base(down, a_base, rng)
        if len(up) == 0:
            break
        crossed, down = _up_through_coat(up, a_coat, n, rng)
        if trip >= FE_SETTLE:
            crossed_sum += int(crossed.sum())
            arrived += len(up)
        if len(down) == 0:
            break
        if len(down) < walks // 2:
            down = down[rng.integers(0, len(down), walks)]
    return float(crossed_sum / arrived) if arrived else 1.0


def _trapping_cell(args):
    """One cell of either trapping table, ``("first" or "eq", the cell's arguments)`` (module level:
    what a process pool can send)."""
    kind, x = args
    return coat_first_escape_cell(*x) if kind == "first" else coat_trapped_equilibrium_cell(*x)


def generate_trapping(processes: int = 2) -> dict[str, np.ndarray]:
    """``coat_first_escape`` and ``coat_trapped_equilibrium`` (``coat_first_escape_cell``,
    ``coat_trapped_equilibrium_cell``: the random walks of Heitz, Hanika, d'Eon and Dachsbacher 2016
    on both microsurfaces). A coated conductor returns what its base reflects in round trips:
    the first escapes at a share that depends on the view (for a coat of alpha 0.3, index 1.5, over
    a mirror: 0.85 at normal incidence, 0.28 at 75 degrees), the later ones at a share that does not
    (0.28), because the trapped light has forgotten where it came from. About 7 minutes on two
    processes."""
    from multiprocessing import Pool

    from tqdm import tqdm

    mus = np.linspace(0.0, 1.0, N_FE_MU)
    alphas = _alpha_nodes(N_FE_ALPHA)
    etas = _tir_eta_nodes(N_FE_ETA)
    first = [("first", (float(m), float(ac), float(ab), float(e)))
             for m in mus for ac in alphas for e in etas for ab in alphas]
    eq = [("eq", (float(ac), float(ab), float(e))) for ac in alphas for ab in alphas for e in etas]
    jobs = first + eq
    with Pool(processes) as pool:
        values = list(tqdm(pool.imap(_trapping_cell, jobs, chunksize=16), total=len(jobs), desc="trapping tables"))
    fe = np.asarray(values[:len(first)]).reshape(N_FE_MU, N_FE_ALPHA, N_FE_ETA * N_FE_ALPHA)
    te = np.asarray(values[len(first):]).reshape(N_FE_ALPHA, N_FE_ALPHA, N_FE_ETA)
    return {"coat_first_escape": fe, "coat_trapped_equilibrium": te}


HG_G_LIMIT = 0.99  # the g = -1 and 1 nodes are integrated at this |g| (the half-lobes' limits are continuous)
HG_QUADRATURE = np.polynomial.legendre.leggauss(48)  # per piece of the scattering cosine's range


def backward_half_moments(g: float, s: float, cos_cone: float) -> tuple[float, float]:
    """The backward half (scattering cosine u < 0) of a HG phase function of asymmetry ``g`` about a
    primary going down at sine ``s``, d = (s, 0, -c): (its share inside the cone of cosine
    ``cos_cone`` about the normal, its mean |v_z|). A direction of scattering cosine u and azimuth
    phi about d has v_z = A + B cos(phi), A = -c u, B = s sqrt(1 - u^2); over the azimuth the share
    with v_z > k is arccos((k - A) / B) / pi and the mean |A + B cos(phi)| is (A (2 phi0 - pi) + 2 B
    sin(phi0)) / pi, phi0 = arccos(-A / B), where B > |A| (|A| otherwise). Over u the two have kinks
    (and at s = 0 steps) where A + B or A - B crosses k or 0, at the angles theta_k +- theta_t from
    the reversed primary (cos theta_k = k, sin theta_t = s): Gauss-Legendre on each piece between
    them, with the phase function's weight, normalised over the half."""
    c = math.sqrt(max(1.0 - s * s, 0.0))
    tilt = math.asin(min(max(s, 0.0), 1.0))
    cuts = {-1.0, 0.0}
    for theta in (math.acos(min(max(cos_cone, -1.0), 1.0)), 0.5 * math.pi):
        for t in (theta - tilt, theta + tilt):
            u = -math.cos(t)
            if -1.0 < u < 0.0:
                cuts.add(u)
    edges = sorted(cuts)
    x, w0 = HG_QUADRATURE
    us, ws = [], []
    for lo, hi in zip(edges[:-1], edges[1:]):
        us.append(lo + (hi - lo) * 0.5 * (x + 1.0))
        ws.append(0.5 * (hi - lo) * w0)
    u, w = np.concatenate(us), np.concatenate(ws)
    w = w * (1.0 - g * g) / (1.0 + g * g - 2.0 * g * u) ** 1.5
    w = w / w.sum()
    a = -c * u
    b = s * np.sqrt(np.maximum(1.0 - u * u, 0.0))
    tiny = b < 1e-12
    bs = np.where(tiny, 1.0, b)
    share = np.where(tiny, (a > cos_cone).astype(float), np.arccos(np.clip((cos_cone - a) / bs, -1.0, 1.0)) / np.pi)
    r = np.clip(-a / bs, -1.0, 1.0)
    phi0 = np.arccos(r)
    mixed = (a * (2.0 * phi0 - np.pi) + 2.0 * b * np.sqrt(1.0 - r * r)) / np.pi
    mean_abs = np.where(b > np.abs(a), mixed, np.abs(a))
    return float((w * share).sum()), float((w * mean_abs).sum())


def generate_backward_half() -> dict[str, np.ndarray]:
    """``hg_backward_escape`` and ``hg_backward_cosine`` (``backward_half_moments`` at every node; a
    few seconds)."""
    gs = np.clip(_g_nodes(N_HG_G), -HG_G_LIMIT, HG_G_LIMIT)
    ss = np.linspace(0.0, 1.0, N_HG_S)
    cs = np.linspace(0.0, 1.0, N_HG_C)
    esc = np.array([[[backward_half_moments(float(g), float(s), float(c))[0] for c in cs] for s in ss] for g in gs])
    cos = np.array([[backward_half_moments(float(g), float(s), 0.0)[1] for s in ss] for g in gs])
    return {"hg_backward_escape": esc, "hg_backward_cosine": cos}


GENERATORS = {
    "ggx_albedo": generate_ggx_albedo, "fresnel_hat_delta": generate_ggx_albedo, "tir": generate_tir,
    "ggx_refract_albedo": generate_refract_albedo,
    "dielectric_rough_reflect": generate_dielectric_rough_reflect,
    "dielectric_trapped_escape": generate_dielectric_trapped_escape,
    "coat_first_escape": generate_trapping, "coat_trapped_equilibrium": generate_trapping,
    "hg_backward_escape": generate_backward_half, "hg_backward_cosine": generate_backward_half,
}


def generate(names=None) -> dict[str, np.ndarray]:
    """The named tables (every table when None), each generator run once."""
    names = list(GENERATORS) if names is None else list(names)
    unknown = [n for n in names if n not in GENERATORS]
    if unknown:
        raise ValueError(f"no table {', '.join(unknown)} (tables: {', '.join(GENERATORS)})")
    tables: dict[str, np.ndarray] = {}
    for gen in dict.fromkeys(GENERATORS[n] for n in names):
        out = gen()
        if not isinstance(out, dict):
            out = {next(n for n in GENERATORS if GENERATORS[n] is gen): out}
        tables.update(out)
    return tables

