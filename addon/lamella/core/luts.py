"""Pre-integrated look-up tables of the statistical models, their generation and loading.

Tables (all GGX with height-correlated Smith masking, the convention of ``models/ggx.py``):

``ggx_albedo`` (2D, cos_i x alpha): GD, the directional albedo with F = 1 (the lobe normaliser
  of Randrianandrasana et al. 2021 Eq. 38).
``fresnel_hat_delta`` (3D, cos_i x alpha x node j): FGD (Randrianandrasana et al. 2021
  Eq. 8) of *any* Fresnel curve as a quadrature over Fresnel samples. Writing the curve as its piecewise-linear interpolant over the
  cosine nodes c_j (hat functions h_j), FGD(mu, alpha) ~ sum_j F(c_j) W_j(mu, alpha), W_j the
  albedo integral of h_j(wi.h). The table stores W_j(mu, alpha) - h_j(mu) (zero at alpha = 0, smooth
  in mu). ``models/fgd.py`` adds back the exact smooth value, so conductors (complex index given at
  run time) and dielectrics (either side, with TIR) share one small table. Measured against
  direct integration it beats both an F82/Schlick basis (7 % off for gold's blue at 60 deg) and a
  3D (cos, alpha, eta) dielectric table (errors up to 0.9 near eta = 1): see ``bench/luts.md``.
``ggx_refract_albedo`` (2D, cos_i x alpha): the directional albedo of Cycles' refracting GGX closure
  (``microfacet("ggx", N, alpha, REFRACT_ETA, 1)``: Walter 2007's BTDF without Fresnel) at the
  large index REFRACT_ETA, the normaliser of the transmission lobe kind (``lobe_kinds``). With
  such an index a refraction barely bends, so the closure is a GGX lobe about -N whatever the
  view: aimed by its normal at any transmitted direction.
``tir`` (3D, u x alpha x eta): Belcour 2018's total-internal-reflection correction: the fraction
  of a GGX reflection lobe of roughness alpha, whose mirror direction makes sin(theta) = u * eta
  with the normal, that lies inside the escape cone sin(theta) < eta (eta = n_outside / n_inside
  <= 1). u = 1 is the mean direction of light refracted in at grazing incidence.
``dielectric_rough_reflect`` (3D, direction x alpha x eta): the whole reflectance of an
  energy-conserving rough dielectric interface (the random walk on its microsurface, Heitz et al.
  2016), light arriving from the side of index n1 onto eta = n2 / n1: the coats' reflectance from
  below (``generate_dielectric_rough_reflect``).
``dielectric_trapped_escape`` (3D, the same axes): of the light that interface reflects back, the
  share that crosses it on its next arrival after a mirror sends it back: how easily light trapped
  under a rough coat escapes (``generate_dielectric_trapped_escape``).

Axes are normalised to [0, 1] for look-ups; the node positions are given by the axis maps below.
Tables are written as ZIP-compressed float32 EXR in ``lamella/data/luts`` (3D tables as an atlas of
slices of the last axis stacked vertically) by ``lamella luts``: the files the OSL shaders read.
Each file holds its atlas twice: as it is in the top half and mirrored top to bottom in the bottom
half (``to_file``). OSL's ``texture()`` puts t = 0 at a file's first row in OpenImageIO and in
Blender up to 5.0; from Blender 5.1 Cycles reads OSL textures through its own image cache, with
t = 0 at the last row (Blender's image convention). A read at t / 2 of the atlas's own coordinate
t lands on the same value under either convention (``LAYOUT``; ``osl/lamella_luts.h``).
The same float32 values go into ``tables.npz`` beside them, which is what the numpy backend loads:
inside Blender only numpy is certain to be there (no OpenEXR package), and an ``.npz`` needs nothing
else.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .microsurface import sample_vndf, smith_lambda

DATA_DIR = Path(__file__).resolve().parent.parent / "data" / "luts"

TIR_ETA_MIN = 0.2  # escape-cone range of the TIR table (inside index up to 5)
REFRACT_ETA = 100.0  # the index of the transmission lobe's refracting closure (see ggx_refract_albedo)


# ---------------------------------------------------------------- axis maps (model side)
# These take and return backend values: they are used both by the generator (numpy) and by
# the traced model code (any ops), so the look-up coordinates and the node positions agree.
def mu_to_coord(ops, mu):
    return ops.sqrt(ops.clamp(mu, 0.0, 1.0))


def alpha_to_coord(ops, alpha):
    return ops.sqrt(ops.clamp(alpha, 0.0, 1.0))


def tir_eta_to_coord(ops, eta):
    return (ops.clamp(eta, TIR_ETA_MIN, 1.0) - TIR_ETA_MIN) * (1.0 / (1.0 - TIR_ETA_MIN))


# The index-ratio axis of the multiple-scattering table: log-spaced from 1 / MS_ETA_MAX to MS_ETA_MAX
# (eta = 1, an index-matched interface, is the middle node).
MS_ETA_MAX = 3.0


def ms_eta_to_coord(ops, eta):
    return ops.clamp(0.5 + ops.log(ops.max(eta, 1e-6)) * (0.5 / math.log(MS_ETA_MAX)), 0.0, 1.0)


def _ms_eta_nodes(n):
    return MS_ETA_MAX ** np.linspace(-1.0, 1.0, n)


# The direction axis of the rough-dielectric reflectance table, in the sine s of the direction:
# up to the critical angle of the denser side (s = eta < 1), or up to grazing (s = 1, eta >= 1), at
# coordinates 0 to MS_KNEE (MS_KNEE (r + r^2) / 2 of r = s / min(eta, 1): nodes three times as dense
# toward its end, where the reflectance turns fastest); past the
# critical angle up to grazing at MS_KNEE to 1, crowded toward the critical angle. Both ends of the
# first part fall on nodes for every eta.
MS_KNEE = 0.6


def ms_x_to_coord(ops, mu, eta):
    s = ops.sqrt(ops.max(1.0 - mu * mu, 0.0))
    sc = ops.min(eta, 1.0)
    r = ops.min(s / ops.max(sc, 1e-6), 1.0)
    v = ops.max(s - eta, 0.0) / ops.max(1.0 - eta, 1e-6)
    return ops.clamp(MS_KNEE * 0.5 * (r + r * r) + (1.0 - MS_KNEE) * ops.sqrt(ops.min(v, 1.0)), 0.0, 1.0)


def ms_sine(c: float, eta: float) -> float:
    """The sine of the direction at coordinate ``c`` of that axis for ``eta`` (the inverse of
    ``ms_x_to_coord``; coordinates past grazing, c > MS_KNEE with eta >= 1, give grazing)."""
    if c <= MS_KNEE:
        return 0.5 * (math.sqrt(1.0 + 8.0 * c / MS_KNEE) - 1.0) * min(eta, 1.0)
    if eta >= 1.0:
        return 1.0
    v = ((c - MS_KNEE) / (1.0 - MS_KNEE)) ** 2
    return eta + v * (1.0 - eta)


def _mu_nodes(n):
    return np.linspace(0.0, 1.0, n) ** 2


def _alpha_nodes(n):
    return np.linspace(0.0, 1.0, n) ** 2


def _tir_eta_nodes(n):
    return np.linspace(TIR_ETA_MIN, 1.0, n)


@dataclass(frozen=True)
class TableSpec:
    name: str
    file: str
    channel: str
    shape: tuple[int, ...]


N_MU, N_ALPHA, N_TIR_U, N_TIR_ETA, N_HAT = 32, 32, 32, 17, 24
N_MS_X, N_MS_ALPHA, N_MS_ETA = 41, 16, 13  # 41: MS_KNEE = 0.6 is node 24
# Cosine nodes of the Fresnel quadrature, denser toward grazing where Fresnel curves bend
# (24 nodes at t^1.5 measured best among 12/24/32 nodes and exponents 2/1.5/1.3).
FRESNEL_NODES = tuple(float(x) for x in np.linspace(0.0, 1.0, N_HAT) ** 1.5)
SPECS = {
    "ggx_albedo": TableSpec("ggx_albedo", "ggx_albedo.exr", "Y", (N_MU, N_ALPHA)),
    "fresnel_hat_delta": TableSpec("fresnel_hat_delta", "fresnel_hat_delta.exr", "Y", (N_MU, N_ALPHA, N_HAT)),
    "tir": TableSpec("tir", "tir.exr", "Y", (N_TIR_U, N_ALPHA, N_TIR_ETA)),
    "ggx_refract_albedo": TableSpec("ggx_refract_albedo", "ggx_refract_albedo.exr", "Y", (N_MU, N_ALPHA)),
    "dielectric_rough_reflect": TableSpec("dielectric_rough_reflect", "dielectric_rough_reflect.exr", "Y",
                                       (N_MS_X, N_MS_ALPHA, N_MS_ETA)),
    "dielectric_trapped_escape": TableSpec("dielectric_trapped_escape", "dielectric_trapped_escape.exr", "Y",
                                           (N_MS_X, N_MS_ALPHA, N_MS_ETA)),
}

# 3D tables also written with four consecutive slices of the last axis per RGBA texel, for OSL:
# a quadrature that reads every slice at the same (c0, c1) then needs a quarter of the texture
# reads (lamella.core.backends.osl). Same float32 values as the one-channel atlas.
PACKED = {"fresnel_hat_delta": "fresnel_hat_delta_rgba.exr"}
PACKED_CHANNELS = ("R", "G", "B", "A")

NPZ_FILE = "tables.npz"  # every table of SPECS, float32, what table() loads

_cache: dict[str, np.ndarray] = {}


def table(name: str) -> np.ndarray:
    """The named table as a float32 array of its spec's shape (loaded once, from ``tables.npz``)."""
    if name not in _cache:
        path = DATA_DIR / NPZ_FILE
        if not path.exists():
            raise FileNotFoundError(f"look-up tables {path} are missing: run `lamella luts` to generate them")
        with np.load(path) as npz:
            if name not in npz.files or npz[name].size != math.prod(SPECS[name].shape):
                raise ValueError(f"look-up table {name} in {path} is missing or of another shape than "
                                 f"{SPECS[name].shape}: run `lamella luts` to generate the tables again")
            _cache[name] = np.ascontiguousarray(npz[name], dtype=np.float32).reshape(SPECS[name].shape)
    return _cache[name]


def read_exr_table(name: str, directory: Path = DATA_DIR) -> np.ndarray:
    """The named table as stored in its EXR file (what the OSL shaders read; needs OpenEXR)."""
    spec = SPECS[name]
    return _read_table(directory / spec.file, spec.channel, spec.shape)


def _read_table(path: Path, channel: str, shape) -> np.ndarray:
    import OpenEXR

    if not path.exists():
        raise FileNotFoundError(f"look-up table {path} is missing: run `lamella luts` to generate it")
    with OpenEXR.File(str(path)) as f:
        px = np.asarray(f.channels()[channel].pixels, dtype=np.float32)
    return _from_atlas(from_file(px, path), shape)


LAYOUT = 2  # the files' layout: 2 = each atlas above its mirror image (1: the atlas alone)
LAYOUT_MARK = f"lamella LUT layout {LAYOUT}"  # in osl/lamella_luts.h: shaders that read this layout


def to_file(atlas: np.ndarray) -> np.ndarray:
    """The rows an atlas is stored as: the atlas, then the atlas mirrored top to bottom. Row i of
    the atlas (from the top) sits at t = (i + 0.5) / (2 rows) from the top and at the same t from
    the bottom, so a texture read gives it whichever end a renderer counts t from."""
    return np.ascontiguousarray(np.concatenate([atlas, atlas[::-1]], axis=0))


def from_file(px: np.ndarray, path="") -> np.ndarray:
    """The atlas stored in ``px`` (``to_file``'s rows); raises ValueError if they are not."""
    rows = px.shape[0] // 2
    top, bottom = px[:rows], px[rows:]
    if px.shape[0] % 2 or not np.array_equal(top, bottom[::-1]):
        raise ValueError(f"look-up table {path} is not in layout {LAYOUT} (its atlas above its mirror image): "
                         "run `lamella luts` to write it again")
    return np.ascontiguousarray(top)


def _to_atlas(a: np.ndarray) -> np.ndarray:
    if a.ndim == 2:
        return a
    n0, n1, n2 = a.shape
    return np.ascontiguousarray(np.transpose(a, (2, 0, 1)).reshape(n2 * n0, n1))


def _from_atlas(px: np.ndarray, shape) -> np.ndarray:
    if len(shape) == 2:
        return px.reshape(shape)
    n0, n1, n2 = shape
    return np.ascontiguousarray(px.reshape(n2, n0, n1).transpose(1, 2, 0))


def packed_atlas(a: np.ndarray) -> dict[str, np.ndarray]:
    """RGBA atlas of a 3D table (n0, n1, n2), n2 a multiple of 4: group g of slices
    4g..4g+3 occupies rows g*n0 .. (g+1)*n0 - 1, slice 4g+c in channel c (the atlas; a file
    holds ``to_file`` of it)."""
    n0, n1, n2 = a.shape
    if n2 % 4:
        raise ValueError(f"cannot pack {n2} slices by four")
    g = a.reshape(n0, n1, n2 // 4, 4).transpose(2, 0, 1, 3).reshape(n2 // 4 * n0, n1, 4)
    return {ch: np.ascontiguousarray(g[..., c], dtype=np.float32) for c, ch in enumerate(PACKED_CHANNELS)}


def write_packed(out_dir: Path = DATA_DIR, tables: dict[str, np.ndarray] | None = None) -> list[Path]:
    import OpenEXR

    written = []
    for name, fname in PACKED.items():
        arr = tables[name] if tables and name in tables else table(name)
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
                  "lamella_shape": ",".join(map(str, arr.shape)), "lamella_packing": "rgba slices",
                  "lamella_layout": str(LAYOUT)}
        channels = {ch: to_file(px) for ch, px in packed_atlas(arr).items()}
        with OpenEXR.File(header, channels) as f:
            f.write(str(out_dir / fname))
        written.append(out_dir / fname)
    return written


def write_exr(tables: dict[str, np.ndarray], out_dir: Path = DATA_DIR) -> list[Path]:
    """The EXR files the OSL shaders read (every table of ``SPECS`` in ``tables``, and the packed
    copies), in layout ``LAYOUT``."""
    import OpenEXR

    out_dir.mkdir(parents=True, exist_ok=True)
    files: dict[str, dict[str, np.ndarray]] = {}
    for name, arr in tables.items():
        spec = SPECS[name]
        assert arr.shape == spec.shape, (name, arr.shape, spec.shape)
        files.setdefault(spec.file, {})[spec.channel] = to_file(_to_atlas(arr.astype(np.float32)))
    written = []
    for fname, channels in files.items():
        shape = next(SPECS[n].shape for n in SPECS if SPECS[n].file == fname)
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
                  "lamella_shape": ",".join(map(str, shape)), "lamella_layout": str(LAYOUT)}
        with OpenEXR.File(header, channels) as f:
            f.write(str(out_dir / fname))
        written.append(out_dir / fname)
    return written + write_packed(out_dir, {k: v.astype(np.float32) for k, v in tables.items()})


def write_tables(tables: dict[str, np.ndarray], out_dir: Path = DATA_DIR) -> list[Path]:
    """Every table: the EXR files (``write_exr``) and ``tables.npz``."""
    written = write_exr(tables, out_dir)
    np.savez_compressed(out_dir / NPZ_FILE, **{k: v.astype(np.float32) for k, v in tables.items()})
    _cache.clear()
    return written + [out_dir / NPZ_FILE]


# ---------------------------------------------------------------- numerical integration
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


def hat(c, j: int, nodes=FRESNEL_NODES):
    """Piecewise-linear hat function of node j over ``nodes`` (numpy or traced values)."""
    left = (c - nodes[j - 1]) * (1.0 / (nodes[j] - nodes[j - 1])) if j > 0 else None
    right = (nodes[j + 1] - c) * (1.0 / (nodes[j + 1] - nodes[j])) if j + 1 < len(nodes) else None
    return left, right


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


def generate_all() -> dict[str, np.ndarray]:
    tables = generate_ggx_albedo()
    tables["tir"] = generate_tir()
    tables["ggx_refract_albedo"] = generate_refract_albedo()
    tables["dielectric_rough_reflect"] = generate_dielectric_rough_reflect()
    tables["dielectric_trapped_escape"] = generate_dielectric_trapped_escape()
    return tables
