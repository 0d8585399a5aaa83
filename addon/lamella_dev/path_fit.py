"""The floor of a model's closures: its lobes with each one's energy and roughness fitted to a reference.

A model renders a stack as one closure per light path (``api.lobes``): a GGX reflection about
the mirror direction per path through rough interfaces, a Lambertian lobe per diffuse path. Its
error against a reference has two parts: the energies and roughnesses it gives those lobes, and
what no choice of them can express (a path whose true lobe is not a GGX lobe). ``fit_paths``
measures the second: it keeps every visible lobe of the model (kind, axes' rotation; smooth
paths, deltas that a pointwise comparison cannot see, are left out as ``api.evaluate(...,
deltas=False)`` leaves them) and fits each one's roughness (both axes of an anisotropic lobe) and
energy (per colour channel, non-negative) to the reference, minimising the relative L1 of f cos
over the reference's direction grid (``metrics.relative_l1``). What remains is the error of the
closures' shapes: a model that got every energy and roughness exactly right would still be that
far from the reference.

Each lobe's shape is normalised over the grid (unit integral of f cos), so the fitted energies
isolate shape from the grid's quadrature. The search is coordinate descent from the model's own
roughnesses (one lobe's roughness scanned while the others are held, energies solved for each
candidate by non-negative least squares to rank them, and for the best few of them by the linear
program that minimises the L1 metric itself, which decides). The result
is never above the model's own error: the model's lobes are the starting point and the fit keeps
the best configuration it has evaluated, the model's included.

The energies are free per lobe, so the floor may give one path's light to another path's lobe
(the surface reflection of a rough coat drawn narrow to carry the core of the base's light): it is
the floor of the closures, not of each path apart. Two partial fits tell the parts of the model's
error apart (``fit``): *roughness*, each lobe's energy held at the model's (its integral on the
grid) and only the roughnesses fitted, measures what the lobes' widths and shapes cost with every
path keeping its own light; *energies*, the model's roughnesses held and only the energies fitted.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.optimize import linprog, nnls

from lamella.core import api, lobe_kinds
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.models.types import Lobe
from .metrics import relative_l1

ALPHAS = np.geomspace(0.01, 1.0, 61)  # an isotropic lobe's roughness scan
ALPHAS_2D = np.geomspace(0.01, 1.0, 21)  # each axis of an anisotropic lobe
SWEEPS = 4  # coordinate-descent passes over the lobes at most (stops when one changes nothing)
SHORTLIST = 6  # per lobe and pass, the candidates (ranked with least-squares energies) given exact L1 energies
FITS = ("both", "roughness", "energies")  # what ``fit_paths`` fits: see the module


@dataclass
class PathFit:
    """``rel_l1``: the fitted lobes' relative L1 against the reference; ``rel_l1_model``: the
    model's own lobes' (what ``api.evaluate(..., deltas=False)`` gives); per fitted lobe its
    kind, model roughness, fitted roughness (alpha_x, alpha_y) and fitted energy (RGB, on the grid;
    where no fit beat the model's own lobes, their weights)."""

    rel_l1: float
    rel_l1_model: float
    kinds: tuple[str, ...]
    alphas_model: list[tuple[float, float]]
    alphas: list[tuple[float, float]]
    energies: list[list[float]]


def _visible(lb: api.Lobes, side: str) -> list[int]:
    """Indices of the lobes on ``side`` a pointwise comparison sees (deltas left out)."""
    out = []
    for k, name in enumerate(lb.kinds):
        kind = lobe_kinds.kind(name)
        if kind.side != side:
            continue
        if kind.rough and lb.alpha_x[0, k] == 0.0 and lb.alpha_y[0, k] == 0.0:
            continue
        out.append(k)
    return out


def direction_inputs(ops, wi: np.ndarray, wo: np.ndarray) -> tuple[tuple, tuple]:
    """(wi, wo) as the backend's inputs, wi (3,) broadcast against wo (N, 3)."""
    wib = np.broadcast_to(wi, wo.shape)
    return (tuple(ops.input(n, wib[:, j]) for j, n in enumerate(("wi_x", "wi_y", "wi_z"))),
            tuple(ops.input(n, wo[:, j]) for j, n in enumerate(("wo_x", "wo_y", "wo_z"))))


def _unit_lobe_cos(ops, wi_vals, wo_vals, w, kind, ax, ay, rotation) -> np.ndarray:
    """f cos of a lobe of ``kind`` and unit weight over the grid."""
    lobe = Lobe((1.0, 1.0, 1.0), ax, ay, rotation, kind)
    return np.broadcast_to(np.asarray(lobe_kinds.kind(kind).closure_cos(ops, lobe, wi_vals, wo_vals), float), w.shape)


def lobe_shape(ops, wi_vals, wo_vals, w, kind, ax, ay, rotation) -> np.ndarray:
    """f cos of a lobe of ``kind`` and unit energy over the grid (unit integral against ``w``)."""
    v = _unit_lobe_cos(ops, wi_vals, wo_vals, w, kind, ax, ay, rotation)
    total = float((v * w).sum())
    return v / total if total > 1e-12 else np.zeros_like(w)


def _energies_l2(shapes: np.ndarray, f_ref: np.ndarray, sw: np.ndarray) -> np.ndarray:
    """Non-negative energies (K, 3) minimising the w-weighted squared error, per channel."""
    a = shapes.T * sw[:, None]
    return np.stack([nnls(a, f_ref[:, c] * sw)[0] for c in range(f_ref.shape[1])], -1)


def _energies_l1(shapes: np.ndarray, f_ref: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Non-negative energies (K, 3) minimising the w-weighted L1 error per channel exactly: the
    linear program min sum_j w_j t_j over (e, t) with -t <= S^T e - f <= t, e >= 0."""
    k, n = shapes.shape
    a = sparse.csr_matrix(shapes.T)
    eye = sparse.identity(n, format="csr")
    a_ub = sparse.vstack([sparse.hstack([a, -eye]), sparse.hstack([-a, -eye])], format="csr")
    cost = np.concatenate([np.zeros(k), w])
    out = np.empty((k, f_ref.shape[1]))
    for c in range(f_ref.shape[1]):
        res = linprog(cost, A_ub=a_ub, b_ub=np.concatenate([f_ref[:, c], -f_ref[:, c]]),
                      bounds=(0.0, None), method="highs")
        if res.status != 0:
            raise RuntimeError(f"the L1 fit of the lobes' energies failed: {res.message}")
        out[:, c] = res.x[:k]
    return out


def _candidates(kind: str, ax: float, ay: float, plane: bool = False) -> list[tuple[float, float]]:
    if not lobe_kinds.kind(kind).rough:
        return [(ax, ay)]
    if ax == ay and not plane:
        return [(float(a), float(a)) for a in ALPHAS]
    return [(float(x), float(y)) for x in ALPHAS_2D for y in ALPHAS_2D]


def fit_paths(stack, wi: np.ndarray, wo: np.ndarray, w: np.ndarray, f_ref: np.ndarray,
              model="auto", side: str = "reflected", plane: bool = False, fit: str = "both") -> PathFit:
    """The model's visible lobes on ``side`` at incidence ``wi`` with energies and roughnesses
    fitted to ``f_ref`` (f cos at ``wo``, weights ``w``), as described in the module. ``plane``:
    a closure shape the models do not emit, measured for what it would buy: every isotropic rough
    lobe becomes anisotropic with its axes along and across the plane of incidence (turned to the
    view's azimuth), both roughnesses fitted. ``fit``: one of ``FITS``, what is fitted (the
    module)."""
    if fit not in FITS:
        raise ValueError(f"fit is one of {FITS}, got {fit!r}")
    ops = NumpyOps(np.float64)
    lb = api.lobes(stack, wi, model)
    ks = _visible(lb, side)
    f_model = api.evaluate(stack, wi, wo, model, deltas=False)
    err_model = relative_l1(f_model, f_ref, w)
    if not ks:
        return PathFit(err_model, err_model, (), [], [], [])
    wi_vals, wo_vals = direction_inputs(ops, wi, wo)
    kinds = tuple(lb.kinds[k] for k in ks)
    alphas_model = [(float(lb.alpha_x[0, k]), float(lb.alpha_y[0, k])) for k in ks]
    in_plane = [plane and lobe_kinds.kind(kinds[j]).rough and a[0] == a[1] for j, a in enumerate(alphas_model)]
    view_azimuth = float(np.arctan2(wi[1], wi[0]))
    rot = [view_azimuth if in_plane[j] else float(lb.rotation[0, k]) for j, k in enumerate(ks)]
    sw = np.sqrt(w)
    cache: dict = {}
    # the model's lobes' energies on the grid (what ``fit="roughness"`` holds): each lobe's weight
    # times its closure's integral on the grid
    held = np.stack([lb.weight[0, k] * float((_unit_lobe_cos(ops, wi_vals, wo_vals, w, kinds[j], *alphas_model[j],
                                                             float(lb.rotation[0, k])) * w).sum())
                     for j, k in enumerate(ks)])

    def shape(j, a):
        key = (j, a)
        if key not in cache:
            cache[key] = lobe_shape(ops, wi_vals, wo_vals, w, kinds[j], a[0], a[1], rot[j])
        return cache[key]

    def shapes_of(alphas):
        return np.stack([shape(j, a) for j, a in enumerate(alphas)])

    def rough_score(alphas):  # least-squares energies: ranks the candidates cheaply
        s = shapes_of(alphas)
        return relative_l1(s.T @ (held if fit == "roughness" else _energies_l2(s, f_ref, sw)), f_ref, w)

    def score(alphas):  # the energies that minimise the metric itself
        s = shapes_of(alphas)
        e = held if fit == "roughness" else _energies_l1(s, f_ref, w)
        return relative_l1(s.T @ e, f_ref, w), e

    alphas = list(alphas_model)
    best, energies = score(alphas)
    for _ in range(SWEEPS if fit != "energies" else 0):
        moved = False
        for j, kind in enumerate(kinds):
            trials = [alphas[:j] + [a] + alphas[j + 1:] for a in _candidates(kind, *alphas_model[j], in_plane[j])]
            ranked = sorted(trials, key=rough_score)[:SHORTLIST] if len(trials) > SHORTLIST else trials
            for trial in ranked:
                err, e = score(trial)
                if err < best - 1e-9:
                    best, energies, alphas, moved = err, e, trial, True
        if not moved:
            break
    if err_model < best:  # the model's own lobes are one of the configurations the fit may keep
        best, alphas = err_model, alphas_model
        energies = np.stack([lb.weight[0, k] for k in ks])
    return PathFit(float(best), float(err_model), kinds, alphas_model, alphas, np.asarray(energies).tolist())
