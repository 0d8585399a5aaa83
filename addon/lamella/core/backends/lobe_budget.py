"""The lobe budget: a material's baked lobes merged into at most K closures (docs/staging.md).

Closures, not arithmetic, set the run time of a staged shader, and stacks with media emit many
lobes (27 for eight coats with media) that mostly share a centre (the mirror direction, or the
view for back-scatter) and differ in roughness. At compile time, with every lobe tabulated over
the view grid, lobes of one kind are merged:

- **which**: greedily, the pair whose roughness tensors are closest in log space, weighted by the
  smaller lobe's energy, summed over the grid (a merge costs nothing where one lobe is dark);
  mirror lobes (zero roughness) merge only with each other, which changes nothing;
- **how**: the merged lobe carries the sum of the energies, and its roughness tensor is the
  energy-weighted power mean of the members' (``RULES``: p = 1 the mean of alpha, p = 2 of alpha
  squared, p = 0 the geometric mean), measured against the full lobe sum in ``bench/staging.md``;
- **how many**: ``"all"`` keeps every lobe, an integer K keeps at most K closures, ``"auto"`` the
  fewest closures whose BRDF stays within ``AUTO_TOLERANCE`` (relative L1 against every lobe, at
  every grid view up to ``AUTO_MAX_DEGREES``); never more than ``MAX_CLOSURES``, what every
  renderer draws: Cycles with OSL silently drops every closure of a shading point after the 17th
  (measured in a white furnace with N GGX closures of 1/N each and distinct roughness: 17 render
  0.802, 18 render 0.699, 27 render 0.413, while SVM and EEVEE render all 27), so "all" means
  every lobe up to that cap, and a stack with more lobes is merged down to it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import lobe_kinds
from .numpy_ops import NumpyOps

BUDGETS = ("auto", "all", 1, 2, 3, 4, 5, 6, 7, 8)
AUTO_TOLERANCE = 0.01  # relative L1 of the merged BRDF against every lobe, at each view
AUTO_MAX_DEGREES = 75.0
RULES = {"alpha": 1.0, "alpha2": 2.0, "geometric": 0.0}
DEFAULT_RULE = "geometric"  # measured best at every budget (bench/staging.md)
MERGEABLE = ("reflection", "backscatter", "diffuse")
MAX_CLOSURES = 16  # Cycles' OSL renders 17 closures per shading point and drops the rest (see above)
DELTA_ALPHA = 1e-3  # a lobe this sharp everywhere is a mirror
LOG_FLOOR = 1e-4


def parse(budget):
    """A budget as given by the panel or a stack's render options: "auto", "all", or 1 to 8
    (an int or its text)."""
    if isinstance(budget, str) and budget.strip().isdigit():
        budget = int(budget)
    if isinstance(budget, bool) or budget not in BUDGETS:
        raise ValueError(f"lobe budget must be 'auto', 'all' or a whole number from 1 to 8, got {budget!r}")
    return budget


@dataclass
class LobeSamples:
    """One lobe of the model on the view grid (G views): ``energy`` (G, 3), its closure
    arguments (each (G,)), its closure weight (G, 3) where it is a lobe of the model itself
    (merged lobes compute theirs), and the indices of the model's lobes it stands for."""

    kind: lobe_kinds.LobeKind
    energy: np.ndarray
    args: dict
    label: str
    lobe: object
    members: list = field(default_factory=list)
    weight: np.ndarray | None = None
    index: int = -1
    log_tensor: np.ndarray | None = field(default=None, repr=False)
    exprs: dict = field(default_factory=dict, repr=False)  # traced values of a model's own lobe
    row_brdf: dict = field(default_factory=dict, repr=False)  # grid row -> f cos on its wo grid (brdf_error)
    _delta: bool | None = field(default=None, repr=False)

    @classmethod
    def of(cls, closure, on_grid, index: int = -1) -> "LobeSamples":
        vals = on_grid([*closure.lobe.weight, *closure.weight, *closure.args.values()])
        energy = np.stack(vals[0:3], -1)
        weight = np.stack(vals[3:6], -1)
        args = dict(zip(closure.args, vals[6:]))
        s = cls(closure.kind, energy, args, closure.label, closure.lobe, weight=weight, index=index,
                exprs={**closure.args, **{f"weight{ch}": w for ch, w in enumerate(closure.weight)}})
        s.members = [s]
        return s

    def closure_weight(self, dirs) -> list:
        """The closure's weight (three arrays over the grid): its energy times the kind's
        normaliser at its arguments."""
        if self.weight is None:
            ops = NumpyOps(np.float64)
            wi = tuple(dirs[:, k] for k in range(3))
            with np.errstate(all="ignore"):
                s = np.broadcast_to(self.kind.scale_of_args(ops, self.args, wi), (dirs.shape[0],))
            self.weight = self.energy * s[:, None]
        return [self.weight[:, ch] for ch in range(3)]

    @property
    def is_delta(self) -> bool:
        if self._delta is None:
            a = [self.args[k] for k in ("ax", "ay", "alpha") if k in self.args]
            self._delta = bool(self.kind.rough and all(np.all(np.abs(x) < DELTA_ALPHA) for x in a))
        return self._delta


# ---------------------------------------------------------------- roughness tensors
def _tensor(s: LobeSamples) -> np.ndarray:
    """(G, 2, 2) roughness tensors R diag(ax, ay) R^T of a GGX lobe (isotropic: alpha I)."""
    a = s.args
    if "ax" in a:
        ax, ay, c, sn = (np.broadcast_to(a[k], s.energy.shape[:1]) for k in ("ax", "ay", "cos", "sin"))
    else:
        ax = ay = np.broadcast_to(a["alpha"], s.energy.shape[:1])
        c, sn = np.ones_like(ax), np.zeros_like(ax)
    r = np.stack([np.stack([c, -sn], -1), np.stack([sn, c], -1)], -2)
    d = np.zeros(r.shape)
    d[:, 0, 0], d[:, 1, 1] = ax, ay
    return r @ d @ np.swapaxes(r, -1, -2)


def _tensor_fn(t: np.ndarray, fn) -> np.ndarray:
    w, v = np.linalg.eigh(t)
    return v @ (fn(np.maximum(w, 0.0))[..., None] * np.swapaxes(v, -1, -2))


def _power_mean(tensors, weights, p: float) -> np.ndarray:
    """Energy-weighted power mean of roughness tensors: (sum w A^p / sum w)^(1/p), the
    log-Euclidean mean at p = 0."""
    total = np.maximum(sum(weights), 1e-30)[:, None, None]
    if p == 0.0:
        acc = sum(w[:, None, None] * _tensor_fn(t, lambda x: np.log(np.maximum(x, LOG_FLOOR)))
                  for t, w in zip(tensors, weights))
        w, v = np.linalg.eigh(acc / total)  # the exponential of a symmetric matrix (any sign)
        return v @ (np.exp(w)[..., None] * np.swapaxes(v, -1, -2))
    acc = sum(w[:, None, None] * _tensor_fn(t, lambda x: x ** p) for t, w in zip(tensors, weights))
    return _tensor_fn(acc / total, lambda x: x ** (1.0 / p))


def _args_of_tensor(kind, t: np.ndarray) -> dict:
    """The closure arguments of a merged lobe of ``kind`` from its roughness tensor."""
    w, v = np.linalg.eigh(t)  # ascending eigenvalues
    if kind.name == "backscatter":
        return {"alpha": np.sqrt(np.maximum(w[:, 0], 0.0) * np.maximum(w[:, 1], 0.0))}
    ax, ay = np.maximum(w[:, 1], 0.0), np.maximum(w[:, 0], 0.0)
    c, s = v[:, 0, 1], v[:, 1, 1]  # the eigenvector of the larger eigenvalue
    flip = c < 0.0
    c, s = np.where(flip, -c, c), np.where(flip, -s, s)
    iso = np.abs(ax - ay) <= 1e-9 * np.maximum(ax, 1e-30)
    return {"ax": ax, "ay": np.where(iso, ax, ay), "cos": np.where(iso, 1.0, c), "sin": np.where(iso, 0.0, s)}


def _log_tensor(s: LobeSamples) -> np.ndarray:
    if s.log_tensor is None:
        s.log_tensor = _tensor_fn(_tensor(s), lambda x: np.log(np.maximum(x, LOG_FLOOR)))
    return s.log_tensor


def _log_distance(a: LobeSamples, b: LobeSamples) -> np.ndarray:
    return np.sqrt(((_log_tensor(a) - _log_tensor(b)) ** 2).sum((-1, -2)))


def combine(group: list[LobeSamples], rule: str = DEFAULT_RULE) -> LobeSamples:
    """One lobe standing for ``group`` (lobes of one kind): the energies summed, the roughness
    tensor their energy-weighted power mean (``RULES``)."""
    if len(group) == 1:
        return group[0]
    kind = group[0].kind
    energy = sum(g.energy for g in group)
    members = [m for g in group for m in g.members]
    label = f"lobes {', '.join(str(m.index) for m in members)} merged ({kind.name})"
    if not kind.rough:
        args = dict(group[0].args)
    else:
        weights = [g.energy.mean(-1) for g in group]
        args = _args_of_tensor(kind, _power_mean([_tensor(g) for g in group], weights, RULES[rule]))
    return LobeSamples(kind, energy, args, label, group[0].lobe, members)


# ---------------------------------------------------------------- which lobes merge
def _can_merge(a: LobeSamples, b: LobeSamples) -> bool:
    return a.kind is b.kind and a.kind.name in MERGEABLE and a.is_delta == b.is_delta


def _cost(a: LobeSamples, b: LobeSamples) -> float:
    if a.is_delta or not a.kind.rough:
        return 0.0
    w = np.minimum(a.energy.mean(-1), b.energy.mean(-1))
    return float((w * _log_distance(a, b) ** 2).sum())


def merge_order(samples: list[LobeSamples], rule: str = DEFAULT_RULE) -> list[list[LobeSamples]]:
    """The partitions of ``samples`` from every lobe alone down to the fewest closures merging
    allows: element k has len(samples) - k groups, each merged greedily from the previous."""
    current = [[s] for s in samples]
    merged = list(samples)
    out = [list(merged)]
    costs: dict = {}  # (id, id) of two lobes -> their merge cost (None: they cannot merge)

    def cost(a, b):
        key = (id(a), id(b))
        if key not in costs:
            costs[key] = _cost(a, b) if _can_merge(a, b) else None
        return costs[key]

    while True:
        best = None
        for i in range(len(merged)):
            for j in range(i + 1, len(merged)):
                c = cost(merged[i], merged[j])
                if c is not None and (best is None or c < best[0]):
                    best = (c, i, j)
        if best is None:
            return out
        _, i, j = best
        current[i] = current[i] + current[j]
        del current[j]
        merged[i] = combine(current[i], rule)
        del merged[j]
        out.append(list(merged))


def brdf_error(full: list[LobeSamples], merged: list[LobeSamples], dirs: np.ndarray,
               max_degrees: float = AUTO_MAX_DEGREES) -> float:
    """The largest relative L1 (RGB averaged) of the merged lobes' BRDF against every lobe's, over
    the upper hemisphere (``suite.wo_grid``), at the grid views up to ``max_degrees``. Mirror lobes
    are left out of both (they merge only with each other, exactly)."""
    from ..suite import wo_grid

    rows = check_rows(dirs, max_degrees)
    worst = 0.0
    ops = NumpyOps(np.float64)
    for r in rows:
        wi = dirs[r]
        wo, _ = wo_grid(wi, 12, 16)
        wi_t = tuple(np.full(len(wo), wi[k]) for k in range(3))
        wo_t = tuple(wo[:, k] for k in range(3))

        def lobe_brdf(s):
            # a lobe's f cos at this view, once per lobe and view: the bisection of the automatic
            # budget compares many partitions that share most of their (merged) lobes
            f = s.row_brdf.get(r)
            if f is None:
                a = {k: np.asarray(v)[r] for k, v in s.args.items()}
                with np.errstate(all="ignore"):
                    cos = np.broadcast_to(s.kind.cos_of_args(ops, a, wi_t, wo_t), (len(wo),))
                w = np.array([c[r] for c in s.closure_weight(dirs)])
                f = s.row_brdf[r] = cos[:, None] * w[None, :]
            return f

        def brdf(lobes):
            f = np.zeros((len(wo), 3))
            for s in lobes:
                if not s.is_delta:
                    f += lobe_brdf(s)
            return f

        ref = brdf(full)
        denom = np.abs(ref).sum(0)
        if np.all(denom <= 1e-12):
            continue
        err = np.abs(brdf(merged) - ref).sum(0) / np.maximum(denom, 1e-12)
        worst = max(worst, float(err[denom > 1e-12].mean()))
    return worst


CHECK_DEGREES = (0.0, 30.0, 45.0, 60.0, 75.0)  # views the automatic budget checks (and 4 azimuths)


def check_rows(dirs: np.ndarray, max_degrees: float = AUTO_MAX_DEGREES) -> list[int]:
    """The grid views nearest to CHECK_DEGREES (up to ``max_degrees``) at four azimuths."""
    theta = np.degrees(np.arccos(np.clip(dirs[:, 2], -1.0, 1.0)))
    phi = np.arctan2(dirs[:, 1], dirs[:, 0])
    rows = set()
    for t in CHECK_DEGREES:
        if t > max_degrees:
            continue
        near = np.abs(theta - theta[np.argmin(np.abs(theta - t))]) < 1e-9
        for p in (0.0, 0.5 * math.pi, 0.25 * math.pi, -0.6 * math.pi):
            cand = np.nonzero(near)[0]
            rows.add(int(cand[np.argmin(np.abs(np.angle(np.exp(1j * (phi[cand] - p)))))]))
    return sorted(rows)


@dataclass
class Group:
    """A closure of the staged shader: the merged lobe and the model's lobes it stands for."""

    lobe: LobeSamples
    members: list


def merge(samples: list[LobeSamples], budget, dirs: np.ndarray, n_live: int = 0,
          rule: str = DEFAULT_RULE) -> list[Group]:
    """The closures for ``samples`` (the baked lobes) under ``budget`` (``parse``); ``n_live``
    closures of live lobes come on top and count against an integer budget and against
    ``MAX_CLOSURES``, which no budget exceeds."""
    for k, s in enumerate(samples):
        if s.index < 0:
            s.index = k
    cap = max(MAX_CLOSURES - n_live, 1)
    if len(samples) <= 1 or (budget == "all" and len(samples) <= cap):
        return [Group(s, [s]) for s in samples]
    order = merge_order(samples, rule)
    if budget == "all":
        pick = next((level for level in order if len(level) <= cap), order[-1])
    elif budget == "auto":
        # the fewest closures within tolerance: the error grows with merging, so bisect
        lo, hi = 0, len(order) - 1  # order[lo] is within tolerance (every lobe: no error)
        if brdf_error(samples, order[hi], dirs) <= AUTO_TOLERANCE:
            lo = hi
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if brdf_error(samples, order[mid], dirs) <= AUTO_TOLERANCE:
                lo = mid
            else:
                hi = mid
        pick = order[lo]
        if len(pick) > cap:
            pick = next((level for level in order if len(level) <= cap), order[-1])
    else:
        want = max(budget - n_live, 1)
        pick = next((level for level in order if len(level) <= want), order[-1])
    return [Group(s, s.members) for s in pick]
