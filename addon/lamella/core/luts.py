"""Pre-integrated look-up tables of the statistical models: their axes, files and loading (their
generation, by numerical integration and random walks, is ``lamella_dev.luts_build``).

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
  below (``lamella_dev.luts_build``).
``dielectric_trapped_escape`` (3D, the same axes): of the light that interface reflects back, the
  share that crosses it on its next arrival after a mirror sends it back: how easily light trapped
  under a rough coat escapes (``lamella_dev.luts_build``).
``coat_first_escape`` (4D, stored folded as 3D: view cosine x coat alpha x (base alpha, eta)): of
  the light refracted into one rough coat and reflected by a rough base below it (a perfect
  reflector: the share is geometric), the share that crosses the coat on its first way up; eta =
  1 / n of the coat (the ``tir`` table's axis). The base axis runs fastest within the folded last
  axis, one block of ``N_FE_ALPHA`` nodes per eta node; a look-up reads the two eta blocks around it
  and blends them (``models.fgd.coat_first_escape``).
``coat_trapped_equilibrium`` (3D, coat alpha x base alpha x eta): of the light trapped between
  that coat and base after some round trips, the share that crosses the coat per round trip (it
  has forgotten the view; ``lamella_dev.luts_build``).
``hg_backward_escape`` (3D, g x sine x escape-cone cosine): of the backward half of a
  Henyey-Greenstein phase function of asymmetry g about a primary going down at that sine (the
  light a medium back-scatters once), the share inside the escape cone about the normal (what
  leaves a coat through a smooth top; by numerical integration, ``lamella_dev.luts_build``).
``hg_backward_cosine`` (2D, g x sine): the mean |cosine to the normal| of that half-lobe, the
  depth it crosses per unit path (``models.homogeneous_medium.backward_lengthening``).

Axes are normalised to [0, 1] for look-ups; the node positions are given by the axis maps below.
Tables are written as ZIP-compressed float32 EXR in ``lamella/data/luts`` (3D tables as an atlas of
slices of the last axis stacked vertically) by ``lamella luts``: the files the OSL shaders read.
Each file holds its atlas twice: as it is in the top half and mirrored top to bottom in the bottom
half (``to_file``). OSL's ``texture()`` puts t = 0 at a file's first row in OpenImageIO and in
Blender up to 5.0; from Blender 5.1 Cycles reads OSL textures through its own image cache, with
t = 0 at the last row (Blender's image convention). A read at t / 2 of the atlas's own coordinate
t lands on the same value under either convention (``LAYOUT``; ``lamella/data/osl/lamella_luts.h``).
The same float32 values go into ``tables.npz`` beside them, which is what the numpy backend loads:
inside Blender only numpy is certain to be there (no OpenEXR package), and an ``.npz`` needs nothing
else.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

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


def g_to_coord(ops, g):
    """The asymmetry axis of the half-lobe tables: g from -1 to 1, linear."""
    return ops.clamp(0.5 + 0.5 * g, 0.0, 1.0)


def _g_nodes(n):
    return np.linspace(-1.0, 1.0, n)


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
# the trapping tables: view cosine (linear), coat and base alpha (alpha_to_coord), eta = 1 / n
# (tir_eta_to_coord: n from 1 to 5, 1.5 on a node)
N_FE_MU, N_FE_ALPHA, N_FE_ETA = 16, 10, 13
# the half-lobe tables: g (g_to_coord), the primary's sine and the escape cone's cosine, all linear.
# 21 x 33 x 17 nodes measured no different by the keep rule (suite mean 0.16564 against 0.16561) at
# seven times the size; the extension's zip has a size bound (tests/blender/test_extension_package.py)
N_HG_G, N_HG_S, N_HG_C = 11, 17, 9
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
    "coat_first_escape": TableSpec("coat_first_escape", "coat_first_escape.exr", "Y",
                                   (N_FE_MU, N_FE_ALPHA, N_FE_ALPHA * N_FE_ETA)),
    "coat_trapped_equilibrium": TableSpec("coat_trapped_equilibrium", "coat_trapped_equilibrium.exr", "Y",
                                          (N_FE_ALPHA, N_FE_ALPHA, N_FE_ETA)),
    "hg_backward_escape": TableSpec("hg_backward_escape", "hg_backward_escape.exr", "Y", (N_HG_G, N_HG_S, N_HG_C)),
    "hg_backward_cosine": TableSpec("hg_backward_cosine", "hg_backward_cosine.exr", "Y", (N_HG_G, N_HG_S)),
}

# 3D tables also written with four consecutive slices of the last axis per RGBA texel, for OSL:
# a quadrature that reads every slice at the same (c0, c1) then needs a quarter of the texture
# reads (lamella.core.backends.osl.emit). Same float32 values as the one-channel atlas.
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
LAYOUT_MARK = f"lamella LUT layout {LAYOUT}"  # in lamella/data/osl/lamella_luts.h: shaders that read this layout


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
    """The EXR files of ``tables`` (``write_exr``) and ``tables.npz`` with every table of ``SPECS``:
    those of ``tables``, the others as ``out_dir``'s ``tables.npz`` holds them (a table generated
    again alone)."""
    written = write_exr(tables, out_dir)
    kept = {}
    if set(SPECS) - set(tables):
        with np.load(out_dir / NPZ_FILE) as npz:
            kept = {k: np.asarray(npz[k]) for k in SPECS if k not in tables}
    np.savez_compressed(out_dir / NPZ_FILE, **{k: np.asarray(v, dtype=np.float32)
                                               for k, v in {**kept, **tables}.items()})
    _cache.clear()
    return written + [out_dir / NPZ_FILE]


def hat(c, j: int, nodes=FRESNEL_NODES):
    """Piecewise-linear hat function of node j over ``nodes`` (numpy or traced values)."""
    left = (c - nodes[j - 1]) * (1.0 / (nodes[j] - nodes[j - 1])) if j > 0 else None
    right = (nodes[j + 1] - c) * (1.0 / (nodes[j + 1] - nodes[j])) if j + 1 < len(nodes) else None
    return left, right
