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

from ... import lobe_kinds
from ...hemisphere import wo_grid
from ..numpy_ops import NumpyOps

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
    tensor: tuple | None = field(default=None, repr=False)  # roughness tensor (xx, xy, yy) over the grid
    log_tensor: tuple | None = field(default=None, repr=False)
    log_stack: np.ndarray | None = field(default=None, repr=False)
    exprs: dict = field(default_factory=dict, repr=False)  # traced values of a model's own lobe
    live: bool = False  # it reads a linked input (merges only with lobes that do too, traced)
    group: object = None  # the live cover it is weighted by (``models.coverage``): merges only within it
    row_brdf: dict = field(default_factory=dict, repr=False)  # CheckViews -> f cos at its directions (brdf_error)
    _delta: bool | None = field(default=None, repr=False)
    _mean_energy: np.ndarray | None = field(default=None, repr=False)

    @classmethod
    def of(cls, closure, on_grid, index: int = -1, live: bool = False, group=None) -> "LobeSamples":
        vals = on_grid([*closure.lobe.weight, *closure.weight, *closure.args.values()])
        energy = np.stack(vals[0:3], -1)
        weight = np.stack(vals[3:6], -1)
        args = dict(zip(closure.args, vals[6:]))
        s = cls(closure.kind, energy, args, closure.label, closure.lobe, weight=weight, index=index,
                exprs={**closure.args, **{f"weight{ch}": w for ch, w in enumerate(closure.weight)}}, live=live,
                group=group)
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
    def mean_energy(self) -> np.ndarray:
        """The energy averaged over the colour channels, at each grid view."""
        if self._mean_energy is None:
            self._mean_energy = self.energy.mean(-1)
        return self._mean_energy

    @property
    def is_delta(self) -> bool:
        if self._delta is None:
            a = [self.args[k] for k in ("ax", "ay", "alpha") if k in self.args]
            self._delta = bool(self.kind.rough and all(np.all(np.abs(x) < DELTA_ALPHA) for x in a))
        return self._delta


# ---------------------------------------------------------------- roughness tensors
# A roughness tensor R diag(ax, ay) R^T is symmetric 2 x 2: it is kept as its three entries
# (xx, xy, yy), each an array over the grid, and its eigen-decomposition is the closed form.
def _tensor(s: LobeSamples) -> tuple:
    """The roughness tensors (xx, xy, yy) of a GGX lobe over the grid (isotropic: alpha I)."""
    if s.tensor is None:
        a, g = s.args, s.energy.shape[:1]
        if "ax" in a:
            ax, ay, c, sn = (np.broadcast_to(np.asarray(a[k], dtype=np.float64), g) for k in ("ax", "ay", "cos", "sin"))
            s.tensor = (ax * c * c + ay * sn * sn, (ax - ay) * c * sn, ax * sn * sn + ay * c * c)
        else:
            alpha = np.broadcast_to(np.asarray(a["alpha"], dtype=np.float64), g)
            s.tensor = (alpha, np.zeros(g), alpha)
    return s.tensor


def _eig(t) -> tuple:
    """(smaller eigenvalue, larger eigenvalue, cos, sin of the larger's eigenvector) of the
    symmetric tensors ``t``: the eigenvector at half the angle atan2(2 xy, xx - yy)."""
    xx, xy, yy = t
    m, h = 0.5 * (xx + yy), 0.5 * (xx - yy)
    r = np.hypot(h, xy)
    angle = 0.5 * np.arctan2(xy, h)
    return m - r, m + r, np.cos(angle), np.sin(angle)


def _tensor_fn(t, fn, clip: bool = True) -> tuple:
    """``fn`` of the symmetric tensors ``t`` (applied to their eigenvalues, clipped at 0 with
    ``clip``)."""
    small, big, c, s = _eig(t)
    if clip:
        small, big = np.maximum(small, 0.0), np.maximum(big, 0.0)
    f_small, f_big = fn(small), fn(big)
    return f_big * c * c + f_small * s * s, (f_big - f_small) * c * s, f_big * s * s + f_small * c * c


def _power_mean(tensors, weights, p: float) -> tuple:
    """Energy-weighted power mean of roughness tensors: (sum w A^p / sum w)^(1/p), the
    log-Euclidean mean at p = 0 (``tensors`` then already their logarithms, ``_log_tensor``)."""
    total = np.maximum(sum(weights), 1e-30)

    def mean(ts):
        return tuple(sum(w * t[k] for t, w in zip(ts, weights)) / total for k in range(3))

    if p == 0.0:
        return _tensor_fn(mean(tensors), np.exp, clip=False)  # the exponential of a symmetric matrix (any sign)
    return _tensor_fn(mean([_tensor_fn(t, lambda x: x ** p) for t in tensors]), lambda x: x ** (1.0 / p))


def _args_of_tensor(kind, t) -> dict:
    """The closure arguments of a merged lobe of ``kind`` from its roughness tensor."""
    small, big, c, s = _eig(t)
    ax, ay = np.maximum(big, 0.0), np.maximum(small, 0.0)
    if kind.name == "backscatter":
        return {"alpha": np.sqrt(ax * ay)}
    flip = c < 0.0
    c, s = np.where(flip, -c, c), np.where(flip, -s, s)
    iso = np.abs(ax - ay) <= 1e-9 * np.maximum(ax, 1e-30)
    return {"ax": ax, "ay": np.where(iso, ax, ay), "cos": np.where(iso, 1.0, c), "sin": np.where(iso, 0.0, s)}


def _log_tensor(s: LobeSamples) -> tuple:
    if s.log_tensor is None:
        s.log_tensor = _tensor_fn(_tensor(s), lambda x: np.log(np.maximum(x, LOG_FLOOR)))
    return s.log_tensor


def _log_stack(s: LobeSamples) -> np.ndarray:
    """The log roughness tensor's entries as one (3, G) array."""
    if s.log_stack is None:
        s.log_stack = np.stack(_log_tensor(s))
    return s.log_stack


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
        weights = [g.mean_energy for g in group]
        p = RULES[rule]
        args = _args_of_tensor(kind, _power_mean([_log_tensor(g) if p == 0.0 else _tensor(g) for g in group], weights, p))
    return LobeSamples(kind, energy, args, label, group[0].lobe, members, live=group[0].live, group=group[0].group)


# ---------------------------------------------------------------- which lobes merge
def _can_merge(a: LobeSamples, b: LobeSamples) -> bool:
    return (a.kind is b.kind and a.kind.name in MERGEABLE and a.is_delta == b.is_delta and a.live == b.live
            and a.group == b.group)


def _costs(i: int, lobes: list[LobeSamples]) -> np.ndarray:
    """The cost of merging ``lobes[i]`` with each lobe (inf where they cannot merge): the
    squared distance of their log roughness tensors weighted by the smaller lobe's energy, summed
    over the grid (zero for mirror and smooth lobes, which merge exactly)."""
    a = lobes[i]
    out = np.full(len(lobes), np.inf)
    js = [j for j, b in enumerate(lobes) if j != i and _can_merge(a, b)]
    if not js:
        return out
    if a.is_delta or not a.kind.rough:
        out[js] = 0.0
        return out
    d = np.stack([_log_stack(lobes[j]) for j in js]) - _log_stack(a)  # (J, 3, G)
    d2 = d[:, 0] ** 2 + 2.0 * d[:, 1] ** 2 + d[:, 2] ** 2
    w = np.minimum(a.mean_energy, np.stack([lobes[j].mean_energy for j in js]))
    out[js] = (w * d2).sum(-1)
    return out


def merge_order(samples: list[LobeSamples], rule: str = DEFAULT_RULE) -> list[list[LobeSamples]]:
    """The partitions of ``samples`` from every lobe alone down to the fewest closures merging
    allows: element k has len(samples) - k groups, each merged greedily from the previous (the
    cheapest pair, the first in order among equals)."""
    current = [[s] for s in samples]
    merged = list(samples)
    out = [list(merged)]
    n = len(merged)
    cost = np.full((n, n), np.inf)  # cost[i, j], i < j: merging lobes i and j (inf: they cannot)
    for i in range(n):
        cost[i, i + 1:] = _costs(i, merged)[i + 1:]
    while len(merged) > 1:
        m = len(merged)
        k = int(np.argmin(cost))  # row-major: the first pair among equal costs
        i, j = divmod(k, m)
        if not np.isfinite(cost[i, j]):
            break
        current[i] = current[i] + current[j]
        del current[j]
        merged[i] = combine(current[i], rule)
        del merged[j]
        cost = np.delete(np.delete(cost, j, 0), j, 1)
        row = _costs(i, merged)
        cost[i, i + 1:] = row[i + 1:]
        cost[:i, i] = row[:i]
        out.append(list(merged))
    return out


CHECK_DEGREES = (0.0, 30.0, 45.0, 60.0, 75.0)  # views the automatic budget checks
CHECK_AZIMUTHS = (0.0, 0.5 * math.pi, 0.25 * math.pi, -0.6 * math.pi)  # at these azimuths, in the shading frame


class CheckViews:
    """The views at which merged lobes are held to every lobe: grid rows (where the lobes'
    values are read), the view direction at each (the row's own, or the row's turned about the
    normal where the grid has one azimuth node in the shading frame) and, for each view, the
    outgoing directions of ``suite.wo_grid`` (concatenated; ``seg`` says whose). ``dirs``: the
    grid's views (N, 3)."""

    def __init__(self, dirs, rows, wi):
        self.dirs = dirs
        self.rows = np.asarray(rows, dtype=np.int64)
        self.wi = np.asarray(wi, dtype=np.float64).reshape(-1, 3)
        wos = [wo_grid(w, 12, 16)[0] for w in self.wi]
        self.seg = np.repeat(np.arange(len(wos)), [len(w) for w in wos])
        self.wo = np.concatenate(wos) if wos else np.zeros((0, 3))

    def __len__(self) -> int:
        return len(self.rows)


def check_views(dirs: np.ndarray, turn: bool = False, max_degrees: float = AUTO_MAX_DEGREES) -> CheckViews:
    """The grid views nearest to CHECK_DEGREES (up to ``max_degrees``), at CHECK_AZIMUTHS: the
    grid's nearest azimuth nodes, or with ``turn`` (a grid at phi = 0 whose values do not depend
    on the azimuth) each row's view turned to those azimuths."""
    key = (dirs.shape, dirs.tobytes(), bool(turn), max_degrees)
    if key not in _VIEWS:
        if len(_VIEWS) >= 8:
            _VIEWS.pop(next(iter(_VIEWS)))
        _VIEWS[key] = _check_views(dirs, turn, max_degrees)
    return _VIEWS[key]


_VIEWS: dict = {}  # check_views of the grids staged lately (the same grid at every edit)


def _check_views(dirs: np.ndarray, turn: bool, max_degrees: float) -> CheckViews:
    rows = check_rows(dirs, max_degrees)
    if not turn:
        return CheckViews(dirs, rows, dirs[rows])
    out_rows, wi = [], []
    for r in rows:
        for p in CHECK_AZIMUTHS:
            c, s = math.cos(p), math.sin(p)
            x, y, z = dirs[r]
            out_rows.append(r)
            wi.append((c * x - s * y, s * x + c * y, z))
    return CheckViews(dirs, out_rows, wi)


def brdf_error(full: list[LobeSamples], merged: list[LobeSamples], views: CheckViews) -> float:
    """The largest relative L1 (RGB averaged) of the merged lobes' BRDF against every lobe's, over
    the upper hemisphere (``suite.wo_grid``), at ``views`` (``check_views``). Mirror lobes are left
    out of both (they merge only with each other, exactly)."""
    if not len(views):
        return 0.0
    at = views.rows[views.seg]  # the grid row of each outgoing direction

    def brdf(lobes):
        _fill_brdf([s for s in lobes if not s.is_delta and views not in s.row_brdf], views)
        f = np.zeros((len(at), 3))
        for s in lobes:
            if not s.is_delta:
                f += s.row_brdf[views]
        return f

    def per_view(x):  # (M, 3) -> (V, 3) sums over each view's directions
        return np.stack([np.bincount(views.seg, x[:, ch], len(views)) for ch in range(3)], -1)

    ref = brdf(full)
    denom = per_view(np.abs(ref))
    err = per_view(np.abs(brdf(merged) - ref)) / np.maximum(denom, 1e-12)
    worst = 0.0
    for v in range(len(views)):
        ok = denom[v] > 1e-12
        if ok.any():
            worst = max(worst, float(err[v][ok].mean()))
    return worst


def _fill_brdf(lobes: list[LobeSamples], views: CheckViews) -> None:
    """Each lobe's f cos at every direction of ``views``, kept on the lobe (the bisection of the
    automatic budget compares partitions that share most of their lobes): the lobes of one kind
    are evaluated in one call, their arguments side by side."""
    ops = NumpyOps(np.float64)
    at = views.rows[views.seg]
    m = len(at)
    by_kind: dict = {}
    for s in lobes:
        by_kind.setdefault(s.kind.name, []).append(s)
    for group in by_kind.values():
        kind, n = group[0].kind, len(group)
        args = {k: np.concatenate([np.broadcast_to(np.asarray(s.args[k], dtype=np.float64), s.energy.shape[:1])[at]
                                   for s in group]) for k in group[0].args}
        wi = tuple(np.tile(views.wi[views.seg, k], n) for k in range(3))
        wo = tuple(np.tile(views.wo[:, k], n) for k in range(3))
        with np.errstate(all="ignore"):
            cos = np.broadcast_to(kind.cos_of_args(ops, args, wi, wo), (n * m,)).reshape(n, m)
        for s, c in zip(group, cos):
            s.row_brdf[views] = c[:, None] * np.stack(s.closure_weight(views.dirs), -1)[at]


def check_rows(dirs: np.ndarray, max_degrees: float = AUTO_MAX_DEGREES) -> list[int]:
    """The grid views nearest to CHECK_DEGREES (up to ``max_degrees``) at the azimuth nodes
    nearest to CHECK_AZIMUTHS."""
    theta = np.degrees(np.arccos(np.clip(dirs[:, 2], -1.0, 1.0)))
    phi = np.arctan2(dirs[:, 1], dirs[:, 0])
    rows = set()
    for t in CHECK_DEGREES:
        if t > max_degrees:
            continue
        near = np.abs(theta - theta[np.argmin(np.abs(theta - t))]) < 1e-9
        for p in CHECK_AZIMUTHS:
            cand = np.nonzero(near)[0]
            rows.add(int(cand[np.argmin(np.abs(np.angle(np.exp(1j * (phi[cand] - p)))))]))
    return sorted(rows)


@dataclass
class Group:
    """A closure of the staged shader: the merged lobe and the model's lobes it stands for."""

    lobe: LobeSamples
    members: list


def merge(samples: list[LobeSamples], budget, dirs: np.ndarray, rule: str = DEFAULT_RULE,
          views: CheckViews | None = None, cap: int = MAX_CLOSURES, partition=None) -> list[Group]:
    """The closures for ``samples`` (every lobe, on the grid views ``dirs``) under ``budget``
    (``parse``), never more than ``cap`` closures (``MAX_CLOSURES``: what Cycles' OSL draws; a
    renderer that draws every closure, Cycles' SVM and EEVEE, may take more). Lobes that read a linked input
    (``LobeSamples.live``, valued at their sockets' values) count against an integer budget and
    the cap; they merge (with each other only, traced by ``staging``) only as far as the cap
    requires, since a merged live closure keeps its members' energies alive until they are summed,
    which costs Cycles' SVM stack (four coats with three textured inputs: its five live lobes
    render in SVM, merged to two they overflow it). ``views``: where the automatic budget checks
    its error (default ``check_views(dirs)``). ``partition`` (lists of lobe indices, a previous
    merge's grouping, ``Staged.merged``): kept as it is where it still fits ``samples`` (the same
    lobes, each group of one kind, baked and live apart, within ``cap``), with no bisection and
    no greedy order; the energies and tensors are merged anew at the lobes' new values. The
    extension keeps a dragged slider's grouping this way and merges anew once edits pause."""
    baked = [s for s in samples if not s.live]
    live = [s for s in samples if s.live]
    for k, s in enumerate(samples):
        if s.index < 0:
            s.index = k
    kept = _kept_partition(samples, partition, cap, rule) if partition is not None else None
    if kept is not None:
        return kept
    groups = _merge_baked(baked, budget, dirs, len(live), rule, views, cap)
    room = max(cap - len(groups), 1)
    if len(live) <= room:
        return groups + [Group(s, [s]) for s in live]
    order = merge_order(live, rule)
    pick = next((level for level in order if len(level) <= room), order[-1])
    return groups + [Group(s, s.members) for s in pick]


def _kept_partition(samples: list[LobeSamples], partition, cap: int, rule: str) -> list[Group] | None:
    """``partition``'s groups of ``samples`` (by ``LobeSamples.index``), or None where it does not
    fit them: every lobe in exactly one group, the lobes of a group of one mergeable kind and all
    baked or all live, at most ``cap`` groups."""
    by_index = {s.index: s for s in samples}
    seen = [i for group in partition for i in group]
    if sorted(seen) != sorted(by_index) or len(partition) > cap or not all(partition):
        return None
    groups = []
    for group in partition:
        lobes = [by_index[i] for i in group]
        if len(lobes) > 1 and any(s.kind is not lobes[0].kind or s.live != lobes[0].live
                                  or s.group != lobes[0].group or s.kind.name not in MERGEABLE for s in lobes):
            return None
        merged = combine(lobes, rule)
        groups.append(Group(merged, merged.members))
    return groups


def _merge_baked(samples: list[LobeSamples], budget, dirs: np.ndarray, n_live: int, rule: str,
                 views: CheckViews | None, closures: int = MAX_CLOSURES) -> list[Group]:
    """``merge`` of the baked lobes, ``n_live`` closures of live lobes on top, ``closures`` in all."""
    cap = max(closures - n_live, 1)
    if len(samples) <= 1 or (budget == "all" and len(samples) <= cap):
        return [Group(s, [s]) for s in samples]
    order = merge_order(samples, rule)
    if budget == "all":
        pick = next((level for level in order if len(level) <= cap), order[-1])
    elif budget == "auto":
        # the fewest closures within tolerance: the error grows with merging, so bisect
        views = check_views(dirs) if views is None else views
        lo, hi = 0, len(order) - 1  # order[lo] is within tolerance (every lobe: no error)
        if brdf_error(samples, order[hi], views) <= AUTO_TOLERANCE:
            lo = hi
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if brdf_error(samples, order[mid], views) <= AUTO_TOLERANCE:
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
