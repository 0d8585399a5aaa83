"""Isotropic GGX lobes about tilted normals standing in for an anisotropic GGX lobe, for renderers
that draw every lobe round (EEVEE ignores the Glossy BSDF's anisotropy, ``bench/eevee_anisotropy.md``).

An anisotropic GGX lobe's microfacet slopes are the isotropic distribution's stretched by alpha_x
and alpha_y (Heitz 2014, "Understanding the masking-shadowing function", Eq. 85): its reflection
is a streak along the axis of the larger alpha, the long axis. A few isotropic lobes whose normals
are tilted along that axis cover the streak where one round lobe cannot. A renderer draws such a
stand-in as the Glossy BSDF with its Normal socket set to the tilted normal n (``tilted_cos``):
GGX (``models.ggx.ggx_lobe_cos``, alpha_x = alpha_y) with wi and wo measured from n, nothing where
wi or wo is below n's horizon or wo below the surface's.

- **Structure** (``_template``): one lobe (K = 1, the best single lobe), a symmetric pair at
  tilts +/- t (K = 2), or that pair and a central lobe (K = 3), with equal shares.
- **Shape** (``fit_shape``): the roughnesses and tilt that minimise the relative L1 of f cos over
  the hemisphere against the lobe (least squares is an option; ``bench/eevee_anisotropy_fit.md``
  compares them), fitted at normal incidence, where the reflected lobe is the slope distribution
  itself and a view only moves and masks it. In slope units (alpha / alpha_long, tan t /
  alpha_long) the fit depends on the axis ratio alone up to alpha_long ~ 0.3 (the stretch is exact
  in slope space; a tilt is a rotation, not a shear, which tells for rough lobes), so a table over
  (ratio, alpha_long) holds it.
- **Shift** (``fit_shift``): toward grazing along the long axis the lobe's visible normals lean
  toward the view (masking along that axis acts with alpha_long, on a stand-in with its own
  smaller alpha), so the stand-ins' tilts shift together along the axis: a second table over
  (ratio, alpha_long, the view's elevation and azimuth from the long axis).
- **Weights** (``_weights``): each stand-in is GD-normalised about its own normal
  (Randrianandrasana et al. 2021 Eqs. 37-38) and carries its share of the microfacet normals
  times wi . n_k: the lobe reflects D(h) G / (4 wi.z) and a stand-in's closure is
  D_k(h) G / (4 wi . n_k), so normals facing the view catch more light. The stand-ins' energies
  sum to the lobe's (docs/design.md "Conventions": a lobe's weight is its energy).

``fit`` reads the tables for any number of lobes and views at once (staging: a few milliseconds
for five lobes on a 64 x 16 view grid) and returns each stand-in's roughness, normal in the lobe's
frame and closure weight per unit of the lobe's energy. The tables (``TABLE_PATH``) are made by
``write_table`` (about ten minutes). Numpy only, no bpy.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..backends.numpy_ops import NumpyOps
from ..luts import DATA_DIR
from ..models.fgd import gd
from ..models.ggx import ggx_lobe_cos
from ..models.variance import rms_alpha

STRUCTURES = {1: "one lobe", 2: "a symmetric pair", 3: "a symmetric pair and a central lobe"}
RATIO_MIN = 0.02  # axis ratios below are fitted as this one (Blender's Anisotropy of 0.99 is 1e-4)
ALPHA_MIN = 1e-4  # models.ggx.ALPHA_EVAL_MIN
COS_MIN = 1e-4  # a stand-in whose normal makes a smaller cosine with the view is dropped
WEIGHTING = "ndf"  # how the stand-ins share the energy at a view (``_weights``)
TABLE_PATH = DATA_DIR / "isotropic_fit.npz"  # the fit tables (``write_table``)

_OPS = NumpyOps(np.float64)


# ---------------------------------------------------------------- the two lobes, as a renderer draws them
def anisotropic_cos(wi, wo, ax, ay):
    """f(wi, wo) |wo.z| of the GD-normalised anisotropic GGX lobe of unit energy on its own axes
    (x along alpha_x): the reflection lobe kind's closure times its normaliser
    (``lobe_kinds.reflection``). ``wi``, ``wo``: (..., 3) in the lobe's frame."""
    wi, wo = np.broadcast_arrays(np.asarray(wi, dtype=np.float64), np.asarray(wo, dtype=np.float64))
    ax, ay = np.asarray(ax, dtype=np.float64), np.asarray(ay, dtype=np.float64)
    f = ggx_lobe_cos(_OPS, _split(wi), _split(wo), ax, ay, 1.0, 0.0)
    return f / np.maximum(gd(_OPS, np.clip(wi[..., 2], 0.0, 1.0), rms_alpha(_OPS, ax, ay)), 1e-6)


def tilted_normal(tilt, long_axis):
    """The unit normal tilted by ``tilt`` (radians) from the surface normal toward the tangent
    direction ``long_axis`` ((..., 2) unit vectors in the tangent plane): (..., 3)."""
    tilt = np.asarray(tilt, dtype=np.float64)
    long_axis = np.asarray(long_axis, dtype=np.float64)
    s, c = np.sin(tilt), np.cos(tilt)
    return np.stack(np.broadcast_arrays(s * long_axis[..., 0], s * long_axis[..., 1], c), -1)


def tilted_cos(wi, wo, alpha, normal):
    """f(wi, wo) |wo.n| of the isotropic GGX closure of weight 1 about ``normal`` (the Glossy BSDF
    with its Normal socket set to it): ``models.ggx.ggx_lobe_cos`` with the directions measured
    from ``normal``; 0 where wi or wo is below its horizon or wo below the surface's."""
    wi, wo, n = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (wi, wo, normal)))
    # an orthonormal frame about n (the closure is isotropic: any tangent will do)
    t = np.cross(n, np.array([0.0, 1.0, 0.0]))
    t_len = np.linalg.norm(t, axis=-1, keepdims=True)
    t = np.where(t_len > 1e-8, t / np.maximum(t_len, 1e-30), np.array([1.0, 0.0, 0.0]))
    b = np.cross(n, t)

    def local(v):
        return ((v * t).sum(-1), (v * b).sum(-1), (v * n).sum(-1))

    li, lo = local(wi), local(wo)
    f = ggx_lobe_cos(_OPS, li, lo, np.asarray(alpha, dtype=np.float64), np.asarray(alpha, dtype=np.float64), 1.0, 0.0)
    return np.where((li[2] > 0.0) & (wo[..., 2] > 0.0), f, 0.0)


def _split(v):
    return tuple(v[..., k] for k in range(3))


# ---------------------------------------------------------------- the integration grid
def h_grid(ax: float, ay: float, n_r: int = 48, n_psi: int = 96):
    """Microfacet normals h (N, 3) in the lobe's frame and their solid angles (N,): a polar grid in
    the lobe's stretched slope space (slopes (alpha_x u, alpha_y v), u = r cos psi, v = r sin psi),
    so its cells crowd where the lobe is, with r = tan(pi s / 2) m(s, psi) at midpoints s: m
    grows from 1 at the centre to 1 / e(psi) at the rim (e the stretch along psi relative to the
    long axis), so the outer rings reach the same slopes in every direction, toward the horizon
    (rounder stand-ins have their tails there). The area of a cell is r dr/ds ds dpsi, and
    d omega_h = d slope / (1 + |slope|^2)^(3/2)."""
    big = max(ax, ay)
    s = (np.arange(n_r) + 0.5) / n_r
    psi = (np.arange(n_psi) + 0.5) / n_psi * 2.0 * math.pi
    S, P = np.meshgrid(s, psi, indexing="ij")
    e = np.sqrt((ax * np.cos(P)) ** 2 + (ay * np.sin(P)) ** 2) / big
    t = np.tan(0.5 * math.pi * S)
    dt = 0.5 * math.pi / np.cos(0.5 * math.pi * S) ** 2
    m = 1.0 + (1.0 / e - 1.0) * S ** 4
    dm = 4.0 * (1.0 / e - 1.0) * S ** 3
    R, dR = t * m, dt * m + t * dm
    px, py = ax * R * np.cos(P), ay * R * np.sin(P)
    q = 1.0 + px * px + py * py
    h = np.stack([-px, -py, np.ones_like(px)], -1) / np.sqrt(q)[..., None]
    d_omega = ax * ay * R * dR * (1.0 / n_r) * (2.0 * math.pi / n_psi) / q ** 1.5
    return h.reshape(-1, 3), d_omega.ravel()


def wo_of_h(wi, h, d_omega_h):
    """The reflections wo of the view ``wi`` (3,) about ``h`` and their solid angles
    (d omega_o = 4 (wi . h) d omega_h), the cells whose wo is below the surface dropped."""
    c = h @ np.asarray(wi, dtype=np.float64)
    wo = 2.0 * c[:, None] * h - wi
    keep = (c > 0.0) & (wo[:, 2] > 1e-9)
    return wo[keep], (4.0 * c * d_omega_h)[keep]


# ---------------------------------------------------------------- the stand-ins' weights
def _template(k: int):
    """(shares, which roughness each stand-in takes (0 the pair's, 1 the centre's), tilt sign) of
    structure K: one lobe, a symmetric pair, a symmetric pair and a central lobe; equal shares
    (fitted free by L1 with the energy kept, the shares of K = 3 came out at 0.32 to 0.34 on
    lobes of 10:1 and 4:1 at alpha_long 0.1 to 0.4)."""
    if k == 1:
        return np.array([1.0]), np.array([0]), np.array([0.0])
    if k == 2:
        return np.array([0.5, 0.5]), np.array([0, 0]), np.array([-1.0, 1.0])
    if k == 3:
        return np.full(3, 1.0 / 3.0), np.array([0, 1, 0]), np.array([-1.0, 0.0, 1.0])
    raise ValueError(f"K is 1, 2 or 3 stand-ins ({'; '.join(f'{n}: {d}' for n, d in STRUCTURES.items())}), got {k!r}")


def _weights(share, alpha, cos_i, weighting: str = WEIGHTING):
    """(energy fractions, closure scales) of stand-ins (last axis) of the given shares and
    roughnesses whose normals make the cosines ``cos_i`` with the view, for a lobe of unit energy.
    ``weighting`` "energy": stand-in k carries the share s_k of the energy, scale s_k / GD(wi . n_k,
    alpha_k). "ndf": s_k is its share of the microfacet normals: the anisotropic lobe reflects
    D(h) G / (4 wi.z) and a stand-in's closure is D_k(h) G / (4 wi . n_k), so the mixture
    sum_k s_k D_k reflects sum_k s_k (wi . n_k / wi.z) closure_k: normals turned toward the view
    catch more light. The scales s_k (wi . n_k) c, c making the stand-ins' energies (scale times
    GD(wi . n_k, alpha_k)) sum to 1. A stand-in whose normal makes a cosine below ``COS_MIN``
    with the view gets nothing."""
    cos_i = np.asarray(cos_i, dtype=np.float64)
    seen = cos_i > COS_MIN
    g = np.maximum(gd(_OPS, np.clip(cos_i, 0.0, 1.0), np.asarray(alpha, dtype=np.float64)), 1e-6)
    if weighting == "energy":
        f = np.where(seen, share, 0.0)
        f = f / np.maximum(f.sum(-1, keepdims=True), 1e-30)
        return f, np.where(seen, f / g, 0.0)
    if weighting != "ndf":
        raise ValueError(f"weighting is 'ndf' or 'energy', got {weighting!r}")
    w = np.where(seen, share * np.maximum(cos_i, 0.0), 0.0)
    e = w * g
    total = np.maximum(e.sum(-1, keepdims=True), 1e-30)
    return e / total, w / total


# ---------------------------------------------------------------- the fit
@dataclass(frozen=True)
class Shape:
    """K stand-ins of a lobe (``fit_shape``): ``share`` (K,) of the microfacet normals (or of the
    energy, by the weighting), ``alpha`` (K,) GGX roughness, ``tilt`` (K,) signed angle (radians)
    of the normal toward the lobe's long axis; ``error`` the relative L1 of f cos at the view it
    was fitted for."""

    share: np.ndarray
    alpha: np.ndarray
    tilt: np.ndarray
    error: float = float("nan")

    def shifted(self, shift: float) -> "Shape":
        """Every tilt moved by ``shift`` (radians) along the long axis."""
        return Shape(self.share, self.alpha, self.tilt + shift, self.error)


def _turned(ax: float, ay: float):
    """(alpha_long, ratio, long axis (2,)) of the lobe (``ax``, ``ay``)."""
    big, small = max(ax, ay), min(ax, ay)
    rho = min(max(small / big, RATIO_MIN), 1.0) if big > 0.0 else 1.0
    return max(big, ALPHA_MIN), rho, (np.array([1.0, 0.0]) if ax >= ay else np.array([0.0, 1.0]))


def fit_shape(ax: float, ay: float, k: int = 3, metric: str = "l1", weighting: str = WEIGHTING, wi=None,
              offset: bool = False, n_r: int = 40, n_psi: int = 96, rounds: int = 4) -> Shape:
    """The K stand-ins of the lobe (``ax``, ``ay``) by a zooming grid search over their roughnesses
    (log of alpha / alpha_long, from half the ratio to 2) and tilt (tan t / alpha_long, 0 to 2), the
    shares fixed (``_template``), weighted as ``stand_ins`` weights them; ``metric``: "l1" (relative
    L1 of f cos, the bench's metric) or "l2" (least squares of f cos), both on the hemisphere of wo
    (``h_grid``) against the lobe of unit energy. ``wi``: the view in the lobe's frame (default:
    normal incidence, the view-independent shape the tables hold); ``offset``: the tilts may also
    shift together along the long axis (tan of the shift / alpha_long, -1 to 1), the shift the
    second table holds (``fit_shift``) fitted with the rest: the structure's best at that view."""
    if k not in STRUCTURES:
        _template(k)
    if metric not in ("l1", "l2"):
        raise ValueError(f"metric is 'l1' or 'l2', got {metric!r}")
    big, rho, long_axis = _turned(float(ax), float(ay))
    share, which, sign = _template(k)
    wi = np.array([0.0, 0.0, 1.0]) if wi is None else np.asarray(wi, dtype=np.float64)
    # the fit in the lobe turned so that x is its long axis (the view turned with it)
    wi_t = wi if long_axis[0] == 1.0 else np.array([wi[1], -wi[0], wi[2]])
    h, dh = h_grid(big, big * rho, n_r, n_psi)
    wo, dwo = wo_of_h(wi_t, h, dh)
    target = anisotropic_cos(wi_t, wo, big, big * rho)
    norm = float((target * dwo).sum())
    n_alpha = 1 if k == 1 else 2
    lo = [math.log(0.5 * rho)] * n_alpha + ([0.0] if k > 1 else []) + ([-1.0] if offset else [])
    hi = [math.log(2.0)] * n_alpha + ([2.0] if k > 1 else []) + ([1.0] if offset else [])
    lo, hi = np.array(lo), np.array(hi)
    cache: dict = {}

    def params(p):
        alphas = big * np.exp(np.array([p[0], p[n_alpha - 1]])[which])
        spread = p[n_alpha] if k > 1 else 0.0
        tilts = np.arctan(big * sign * spread) + (math.atan(big * p[-1]) if offset else 0.0)
        return alphas, tilts

    def model(p):
        alphas, tilts = params(p)
        normals = tilted_normal(tilts, np.array([1.0, 0.0]))
        cols = []
        for a, t, n in zip(alphas, tilts, normals):
            key = (round(float(a), 12), round(float(t), 12))
            if key not in cache:
                cache[key] = tilted_cos(wi_t, wo, a, n)
            cols.append(cache[key])
        _, scale = _weights(share, alphas, normals @ wi_t, weighting)
        return sum(s * c for s, c in zip(scale, cols))

    def loss(p):
        d = model(p) - target
        return float((np.abs(d) * dwo).sum() / norm) if metric == "l1" else float((d * d * dwo).sum())

    best_p, best = None, math.inf
    centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    steps = 9 if len(lo) <= 3 else 7
    for _ in range(rounds):
        axes = [np.clip(centre[i] + half[i] * np.linspace(-1.0, 1.0, steps), lo[i], hi[i]) for i in range(len(lo))]
        for p in np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, len(lo)):
            v = loss(p)
            if v < best:
                best, best_p = v, p
        centre, half = best_p, half * (0.3 if steps == 9 else 0.4)
    alphas, tilts = params(best_p)
    err = float((np.abs(model(best_p) - target) * dwo).sum() / norm)
    return Shape(share.copy(), alphas, tilts, err)


def stand_ins(shape: Shape, ax: float, ay: float, wi, weighting: str = WEIGHTING):
    """The stand-ins of ``shape`` (of the lobe ``ax``, ``ay``) at the view ``wi`` (3,) in the lobe's
    frame: (energy fractions (K,), alphas (K,), normals (K, 3) in the lobe's frame, scales (K,):
    a stand-in's closure weight per unit of the lobe's energy) (``_weights``)."""
    _, _, long_axis = _turned(float(ax), float(ay))
    normals = tilted_normal(shape.tilt, long_axis)
    f, scale = _weights(shape.share, shape.alpha, normals @ np.asarray(wi, dtype=np.float64), weighting)
    return f, shape.alpha, normals, scale


def stand_ins_cos(shape: Shape, ax: float, ay: float, wi, wo, weighting: str = WEIGHTING):
    """f(wi, wo) |wo.z| of the stand-ins of ``shape`` at the view ``wi`` for a lobe of unit energy."""
    _, alphas, normals, scales = stand_ins(shape, ax, ay, wi, weighting)
    return sum(s * tilted_cos(wi, wo, a, n) for a, n, s in zip(alphas, normals, scales) if s > 0.0)


def fit_shift(shape: Shape, ax: float, ay: float, wi, weighting: str = WEIGHTING, n_r: int = 24, n_psi: int = 48,
              rounds: int = 3) -> float:
    """The shift (radians) of all of ``shape``'s tilts along the long axis that minimises the
    relative L1 of f cos at the view ``wi`` (lobe frame). A view toward grazing along the long axis
    sees the lobe's normals tilted toward it (masking along the long axis acts with alpha_long,
    on the stand-ins with their own, smaller roughness), so the stand-ins follow: up to 16
    degrees for alpha_long 0.6 at 75 degrees."""
    ax, ay = float(ax), float(ay)
    wi = np.asarray(wi, dtype=np.float64)
    h, dh = h_grid(ax, ay, n_r, n_psi)
    wo, dwo = wo_of_h(wi, h, dh)
    target = anisotropic_cos(wi, wo, ax, ay)
    norm = float((target * dwo).sum())
    big = max(ax, ay)

    def loss(u):  # u: tan(shift) in units of alpha_long
        m = stand_ins_cos(shape.shifted(math.atan(big * u)), ax, ay, wi, wo, weighting)
        return float((np.abs(m - target) * dwo).sum() / norm)

    centre, half, best, best_u = 0.0, 1.0, math.inf, 0.0
    for _ in range(rounds):
        for u in centre + half * np.linspace(-1.0, 1.0, 9):
            v = loss(u)
            if v < best:
                best, best_u = v, u
        centre, half = best_u, half * 0.3
    return math.atan(big * best_u)


# ---------------------------------------------------------------- the tables
RATIO_NODES = (0.02, 0.04, 0.07, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0)
ALPHA_NODES = (0.02, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0)
SHIFT_RATIO_NODES = (0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 1.0)
SHIFT_ALPHA_NODES = (0.02, 0.15, 0.3, 0.5, 0.75, 1.0)
SHIFT_THETA_NODES = (0.0, 30.0, 45.0, 55.0, 65.0, 72.0, 78.0, 84.0, 89.0)  # degrees
SHIFT_PHI_NODES = (0.0, 22.5, 45.0, 67.5, 90.0)  # degrees from the long axis


def _ratio_coord(rho):
    return np.log(np.clip(rho, RATIO_MIN, 1.0))


def _index(x, nodes):
    """Fractional node index of ``x`` on the increasing ``nodes`` (clamped)."""
    return np.interp(x, nodes, np.arange(len(nodes), dtype=np.float64))


def _interp(table: np.ndarray, idx) -> np.ndarray:
    """Multilinear interpolation of ``table`` (its leading axes indexed by the fractional indices
    ``idx``, arrays of one shape; trailing axes are values) at those indices."""
    idx = np.broadcast_arrays(*(np.asarray(i, dtype=np.float64) for i in idx))
    out = 0.0
    lows = [np.minimum(np.floor(i).astype(np.int64), n - 2) for i, n in zip(idx, table.shape)]
    fracs = [i - lo for i, lo in zip(idx, lows)]
    d = len(idx)
    for corner in range(1 << d):
        sel, w = [], 1.0
        for a in range(d):
            bit = (corner >> a) & 1
            sel.append(lows[a] + bit)
            w = w * (fracs[a] if bit else 1.0 - fracs[a])
        out = out + np.asarray(w)[(...,) + (None,) * (table.ndim - d)] * table[tuple(sel)]
    return out


def _shape_of_row(row: np.ndarray, big: float, k: int) -> Shape:
    share, which, sign = _template(k)
    alphas = big * np.array([row[0], row[1]])[which]
    return Shape(share.copy(), alphas, np.arctan(big * sign * row[2]))


def build_table(ks=(1, 2, 3), progress=None) -> dict:
    """The fit tables (minutes): ``shape{K}`` (ratio x alpha_long nodes x 3: the pair's and the
    centre's alpha / alpha_long, tan(tilt) / alpha_long) of ``fit_shape`` and ``shift{K}`` (ratio x
    alpha_long x view elevation x view azimuth from the long axis: ``fit_shift`` in radians, of
    the shape the first table gives there) for each K."""
    out = {}
    for k in ks:
        shape = np.zeros((len(RATIO_NODES), len(ALPHA_NODES), 3))
        for i, rho in enumerate(RATIO_NODES):
            for j, big in enumerate(ALPHA_NODES):
                s = fit_shape(big, big * rho, k)
                _, which, sign = _template(k)
                pair = s.alpha[which == 0][0] / big
                centre = s.alpha[which == 1][0] / big if k == 3 else pair
                shape[i, j] = (pair, centre, np.tan(np.max(s.tilt)) / big)
                if progress:
                    progress(f"shape K={k} ratio {rho} alpha {big}: L1 {s.error:.3f}")
        out[f"shape{k}"] = shape
        table = {f"shape{k}": shape}
        shift = np.zeros((len(SHIFT_RATIO_NODES), len(SHIFT_ALPHA_NODES), len(SHIFT_THETA_NODES), len(SHIFT_PHI_NODES)))
        for i, rho in enumerate(SHIFT_RATIO_NODES):
            for j, big in enumerate(SHIFT_ALPHA_NODES):
                s = _shape_at(table, k, big, big * rho)
                for a, th in enumerate(SHIFT_THETA_NODES):
                    for b, ph in enumerate(SHIFT_PHI_NODES):
                        if th == 0.0 or ph == 90.0 or rho == 1.0:
                            continue  # no shift by symmetry
                        t, p = math.radians(th), math.radians(ph)
                        wi = np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])
                        shift[i, j, a, b] = fit_shift(s, big, big * rho, wi)
                if progress:
                    progress(f"shift K={k} ratio {rho} alpha {big}")
        out[f"shift{k}"] = shift
    return out


def _shape_at(table: dict, k: int, ax: float, ay: float) -> Shape:
    big, rho, _ = _turned(ax, ay)
    row = _interp(table[f"shape{k}"], (_index(_ratio_coord(rho), _ratio_coord(np.array(RATIO_NODES))),
                                       _index(big, ALPHA_NODES)))
    return _shape_of_row(row, big, k)


def write_table(path: Path | None = None, progress=None) -> Path:
    """Build the tables and write them (float32) to ``path`` (default ``TABLE_PATH``)."""
    path = Path(path) if path is not None else TABLE_PATH
    tables = build_table(progress=progress)
    np.savez_compressed(path, **{k: v.astype(np.float32) for k, v in tables.items()})
    _TABLES.clear()
    return path


_TABLES: dict = {}


def load_table() -> dict:
    """The tables of ``TABLE_PATH`` (loaded once)."""
    if not _TABLES:
        with np.load(TABLE_PATH) as npz:
            _TABLES.update({k: np.asarray(npz[k], dtype=np.float64) for k in npz.files})
    return _TABLES


def shape_of(ax: float, ay: float, k: int = 3, table: dict | None = None) -> Shape:
    """The view-independent shape of the lobe (``ax``, ``ay``) from the table (``fit_shape``
    interpolated)."""
    return _shape_at(table or load_table(), k, float(ax), float(ay))


# ---------------------------------------------------------------- the stand-ins at staging time
@dataclass(frozen=True)
class StandIns:
    """K isotropic GGX lobes standing in for each of N anisotropic ones at N views (``fit``):
    ``fraction`` (N, K) of the lobe's energy each carries, ``alpha`` (N, K), ``tilt`` (N, K) the
    signed angle (radians) of its normal from the surface normal toward the lobe's long axis,
    ``normal`` (N, K, 3) that normal in the lobe's frame, ``scale`` (N, K) its closure weight per
    unit of the lobe's energy (the Glossy BSDF of roughness sqrt(alpha) with that Normal and Color
    = the lobe's energy times the scale), ``long_axis`` (N, 2) the long axis in the lobe's frame."""

    fraction: np.ndarray
    alpha: np.ndarray
    tilt: np.ndarray
    normal: np.ndarray
    scale: np.ndarray
    long_axis: np.ndarray


def fit(ax, ay, wi, k: int = 3, shift: bool = True, weighting: str = WEIGHTING, table: dict | None = None) -> StandIns:
    """The K stand-ins (``STRUCTURES``) of anisotropic GGX lobes of roughness ``ax``, ``ay`` (N,)
    on their own axes at the views ``wi`` (N, 3) in those axes: the shape from the table over
    (axis ratio, alpha_long), shifted along the long axis by the table over (ratio, alpha_long,
    the view's elevation and azimuth from the long axis) where ``shift``, weighted at the view
    (``_weights``). Vectorised: microseconds a view. An isotropic lobe gets K copies of itself
    (tilt 0), together that lobe."""
    table = table or load_table()
    ax, ay = np.broadcast_arrays(np.asarray(ax, dtype=np.float64), np.asarray(ay, dtype=np.float64))
    ax, ay = ax.reshape(-1), ay.reshape(-1)
    wi = np.broadcast_to(np.asarray(wi, dtype=np.float64), ax.shape + (3,))
    top = np.maximum(ax, ay)
    big = np.maximum(top, ALPHA_MIN)
    ratio = np.where(top > 0.0, np.minimum(ax, ay) / np.maximum(top, 1e-30), 1.0)  # a delta lobe is round
    rho = np.clip(ratio, RATIO_MIN, 1.0)
    x_long = ax >= ay
    long_axis = np.where(x_long[:, None], np.array([1.0, 0.0]), np.array([0.0, 1.0]))
    w_long = np.where(x_long, wi[:, 0], wi[:, 1])
    w_short = np.where(x_long, wi[:, 1], wi[:, 0])
    r = _index(_ratio_coord(rho), _ratio_coord(np.array(RATIO_NODES)))
    rows = _interp(table[f"shape{k}"], (r, _index(big, ALPHA_NODES)))  # (N, 3)
    share, which, sign = _template(k)
    alpha = big[:, None] * np.stack([rows[:, 0], rows[:, 1]], -1)[:, which]
    tilt = np.arctan(big[:, None] * sign[None, :] * rows[:, 2:3])
    if shift:
        theta = np.degrees(np.arccos(np.clip(wi[:, 2], -1.0, 1.0)))
        phi = np.degrees(np.arctan2(np.abs(w_short), np.abs(w_long)))
        s = _interp(table[f"shift{k}"], (_index(_ratio_coord(rho), _ratio_coord(np.array(SHIFT_RATIO_NODES))),
                                         _index(big, SHIFT_ALPHA_NODES), _index(theta, SHIFT_THETA_NODES),
                                         _index(phi, SHIFT_PHI_NODES)))
        tilt = tilt + np.where(w_long < 0.0, -s, s)[:, None]
    iso = ratio >= 1.0
    alpha = np.where(iso[:, None], big[:, None], alpha)
    tilt = np.where(iso[:, None], 0.0, tilt)
    normal = tilted_normal(tilt, long_axis[:, None, :])
    fraction, scale = _weights(share[None, :], alpha, (normal * wi[:, None, :]).sum(-1), weighting)
    return StandIns(fraction, alpha, tilt, normal, scale, long_axis)


def fit_cos(stand: StandIns, n: int, wi, wo) -> np.ndarray:
    """f(wi, wo) |wo.z| of the stand-ins of view ``n`` of ``stand`` (a lobe of unit energy), at the
    directions ``wo`` (M, 3) (lobe frame), as the renderer draws them (``tilted_cos``)."""
    total = 0.0
    for a, nrm, s in zip(stand.alpha[n], stand.normal[n], stand.scale[n]):
        if s > 0.0:
            total = total + s * tilted_cos(wi, wo, a, nrm)
    return total
