"""Staging: the traced model partially evaluated for one material (docs/staging.md).

The traced graph (``closures.trace_closures``) is the compiler's IR. For a material, every
parameter that nothing links (no texture, attribute or driver) is a constant of the compile; the
parameters in ``live`` stay inputs. Every value that depends only on the view direction and on
constants is then evaluated here, in numpy, on a grid over the view (``ViewGrid``) and becomes a
column of the material's table; the renderer reads it back by interpolation. What depends on a
live parameter stays traced, reading the table where it needs a view-only value. With nothing
live a shader is: the local view, a few table reads, the closures.

The result (``Staged``) is a new traced graph over the same ops plus one, ``mtab`` (a column of the
material table at a table coordinate), and its closures: the emitters (OSL, node graph, numpy)
read that, never printed text.

- **Frame.** A stack whose every interface is isotropic is symmetric about the normal: its lobes
  in the frame of the view's azimuth (x along the view projected on the surface) do not depend on
  that azimuth. Such a stack is staged in that *view frame* on a one-dimensional table over
  cos(theta) (``frame == "view"``, the view direction is (sin theta, 0, cos theta) there); other
  stacks in the shading frame on a (cos theta, phi) table.
- **Grid.** The coordinate along the view is sqrt(cos theta) (the axis map of the model's own
  tables, ``luts.mu_to_coord``), which crowds the nodes toward grazing where Fresnel terms and the
  refracted cosines change fastest; phi is periodic. The grid sizes are chosen by the measured
  error of the baked against the traced model (``bench/staging.md``).
- **Axes of a lobe.** A lobe whose axes turn with the view is tabulated by its roughness tensor
  R diag(ax, ay) R^T, which is smooth where (ax, ay, rotation) jump (an axis swap, a rotation
  wrapping by pi), and the axes are recovered from its eigen-decomposition.
- **Lobe budget.** Lobes that are fully baked can be merged into fewer closures
  (``lobe_budget.merge``), the trade of run time against error; lobes that read a live parameter
  merge with each other as far as the renderers' closure cap requires, traced
  (``_merged_live_closure``).
- **Edits.** The model's evaluation on the grid is kept between stagings of one graph
  (``grid_values``): a value edit re-evaluates what the changed parameters reach.
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field, replace

import numpy as np

from ... import lobe_kinds, luts
from ...lobe_kinds import isotropic_fit
from ...stack import Stack
from ..numpy_ops import NumpyOps
from . import lobe_budget
from .closures import INSIDE_INPUT, Closure, trace_closures
from .live_axes import axis_nodes, axis_of, lookup_axes
from ...param_id import normal_socket, split_normals
from .sockets import params_of, socket_names, sockets
from .trace import Expr, Tracer

N_MU = 64  # nodes along the view coordinate (bench/staging.md: <= 0.5 % relative L1 up to 85 degrees)
N_PHI = 16  # nodes along the azimuth (shading frame only), periodic
MU_MIN = 1e-4  # the grazing node is evaluated just above the horizon (the model's limit there)
VIEW_INPUTS = ("wi_x", "wi_y", "wi_z")
ENERGY_EPS = 1e-6  # lobes below this energy at a shading point add no closure (every emitter)
STAND_INS = 3  # EEVEE's isotropic lobes per anisotropic one (bench/eevee_anisotropy_fit.md: K = 3 measured best)
ANISOTROPY_MIN = 1e-3  # a lobe whose axes differ by less (1 - min / max) at every view is drawn round anyway


# ---------------------------------------------------------------- the grid
@dataclass(frozen=True)
class ViewGrid:
    """Nodes over the view direction: ``n_mu`` along c = sqrt(cos theta) in [0, 1] (node k at
    c = k / (n_mu - 1)), ``n_phi`` along the azimuth phi in [0, 2 pi) (node j at 2 pi j / n_phi,
    periodic), or one azimuth node in the view frame."""

    n_mu: int = N_MU
    n_phi: int = 1
    warp: str = "both"

    def mu_of(self, c):
        if self.warp == "sqrt_mu":
            return c * c
        return 1.0 - c * c if self.warp == "sin_half" else (1.0 - c * c) ** 2

    def directions(self) -> np.ndarray:
        """(n_mu, n_phi, 3) view directions at the nodes."""
        c = np.linspace(0.0, 1.0, self.n_mu)
        mu = np.maximum(self.mu_of(c), MU_MIN)
        s = np.sqrt(1.0 - mu * mu)
        phi = 2.0 * np.pi * np.arange(self.n_phi) / self.n_phi
        return np.stack(np.broadcast_arrays(s[:, None] * np.cos(phi)[None, :], s[:, None] * np.sin(phi)[None, :],
                                            mu[:, None] + 0.0 * phi[None, :]), -1)

    def coords(self, ops, wi):
        """Table coordinates (c, p) of view direction ``wi`` (backend values): c = sqrt(cos
        theta), p = phi / (2 pi) in [0, 1) (0 in the view frame)."""
        if self.warp == "sqrt_mu":
            c = luts.mu_to_coord(ops, wi[2])
        elif self.warp == "sin_half":
            c = ops.sqrt(ops.clamp(1.0 - wi[2], 0.0, 1.0))
        else:
            c = ops.sqrt(ops.clamp(1.0 - ops.sqrt(ops.clamp(wi[2], 0.0, 1.0)), 0.0, 1.0))
        if self.n_phi == 1:
            return c, 0.0
        p = ops.atan2(wi[1], wi[0]) * (0.5 / math.pi)
        return c, ops.select(p < 0.0, p + 1.0, p)


def lookup(table: np.ndarray, col: int, c, p, dtype=np.float32):
    """Column ``col`` of ``table`` (n_mu, n_phi, columns) at coordinates (c, p): linear along c
    (clamped), linear and periodic along p; exactly the arithmetic the emitters print."""
    n_mu, n_phi = table.shape[:2]
    dtype = np.dtype(dtype).type
    c = np.asarray(c, dtype=dtype)
    x = np.clip(c, 0.0, 1.0) * dtype(n_mu - 1)
    i0 = np.minimum(np.floor(x), n_mu - 2).astype(np.int64)
    f = (x - i0).astype(dtype)
    t = table[..., col].astype(dtype)
    if n_phi == 1:
        a, b = t[i0, 0], t[i0 + 1, 0]
        return (a + (b - a) * f).astype(dtype)
    y = np.asarray(p, dtype=dtype) * dtype(n_phi)
    j0f = np.floor(y)
    g = (y - j0f).astype(dtype)
    j0 = j0f.astype(np.int64) % n_phi
    j1 = (j0 + 1) % n_phi
    a = t[i0, j0] + (t[i0 + 1, j0] - t[i0, j0]) * f
    b = t[i0, j1] + (t[i0 + 1, j1] - t[i0, j1]) * f
    return (a + (b - a) * g).astype(dtype)


# ---------------------------------------------------------------- the result
@dataclass(frozen=True)
class AxisTable:
    """Values of the model over the view and linked parameters: ``data`` (n_mu, n_1, ...,
    n_k, columns) float32 on the view grid's elevation nodes times the nodes of ``axes``
    (``live_axes.LiveAxis``), read by ``atab`` (``live_axes.lookup_axes``)."""

    axes: tuple
    data: np.ndarray

    @property
    def params(self) -> tuple:
        return tuple(a.param for a in self.axes)


@dataclass
class Staged:
    """A material's staged shader: ``tracer`` holds the staged graph (inputs ``wi_x``, ``wi_y``,
    ``wi_z`` in ``frame``; the live parameters; ``mtab`` reads of ``table``), ``closures`` its
    closures (``Closure``, weights and arguments in that graph). ``table`` is (n_mu, n_phi,
    columns) float32; ``lobes_all`` the number of lobes the model emits, ``budget`` what the lobe
    budget asked for and ``merged`` how the closures were merged (lists of the model's lobe
    indices, for the panel and the bench)."""

    stack: Stack
    model: str
    frame: str
    grid: ViewGrid
    table: np.ndarray
    tracer: Tracer
    wi: tuple
    closures: list
    live: tuple
    params: dict
    lobes_all: int
    budget: object
    merged: list = field(default_factory=list)
    coords: tuple = ()
    interface: tuple = ()  # every parameter of the model: the shader's sockets, live or baked
    defaults: dict = field(default_factory=dict)  # every parameter's value (the stack's)
    axis_tables: tuple = ()  # ``AxisTable``s: values over (view, linked parameters) (``atab`` reads)
    live_axes: int = 0  # the most linked parameters a tabulated value may depend on (``stage``)
    traced_params: tuple = ()  # the live parameters some traced arithmetic of the model reads
    ids: dict = field(default_factory=dict)  # every parameter's ``ParamId`` (what it is), by name
    normals: tuple = ()  # the layers whose own normal (an input) their closures take (``Closure.normal``)
    stand_ins: dict = field(default_factory=dict)  # closure index -> its EEVEE stand-ins (``stage``'s ``stand_ins``)

    @property
    def live_sockets(self) -> tuple:
        """The sockets (``sockets.sockets``: panel units) whose parameters are live, and the layers'
        own normals, sorted."""
        live = set(self.live)
        return tuple(sorted([sk.name for sk in sockets({k: self.ids[k] for k in self.interface}) if live & set(sk.params)]
                            + [normal_socket(n) for n in self.normals]))

    @property
    def columns(self) -> int:
        return self.table.shape[2]

    def structure_key(self) -> str:
        """What identifies the compiled shader apart from the table's values and the live
        parameters' values: the staged graph's shape, the closures, the table's size and the
        parameters (the sockets)."""
        t = self.tracer
        every = [*self.closures, *(c for k in sorted(self.stand_ins) for c in self.stand_ins[k])]
        outs = [x for c in every for x in (*c.weight, *c.args.values())]
        names: dict[int, int] = {}
        parts = [self.frame, str(self.table.shape), ",".join(self.live), ",".join(self.interface),
                 ",".join(self.normals), ",".join(str(c.framed(self.normals)) for c in self.closures),
                 *(f"{tab.params}{tab.data.shape}" for tab in self.axis_tables)]
        for k, e in enumerate(t.live_nodes(outs)):
            names[id(e)] = k
            parts.append(e.op + "(" + ",".join(
                f"#{names[id(a)]}" if isinstance(a, Expr) else repr(a) for a in e.args) + ")")
        parts += [c.kind.name + ":" + ",".join(f"#{names[id(x)]}" if isinstance(x, Expr) else repr(x)
                                                for x in (*c.weight, *c.args.values())) for c in every]
        parts.append("stand-ins:" + ",".join(f"{k}x{len(v)}" for k, v in sorted(self.stand_ins.items())))
        return hashlib.sha256("\n".join(parts).encode()).hexdigest()


class StagedOps(NumpyOps):
    """``NumpyOps`` that can read the material table (``mtab``) of a staged graph."""

    def __init__(self, table: np.ndarray, dtype=np.float32, axis_tables=()):
        super().__init__(dtype)
        self.table = table
        self.axis_tables = axis_tables

    def mtab(self, col, c, p):
        return lookup(self.table, int(col), c, p, self.dtype)

    def atab(self, k, col, c, *xs):
        return lookup_axes(self.axis_tables[int(k)].data, int(col), c, xs, self.dtype)


def isotropic(stack: Stack) -> bool:
    """Every interface isotropic: the stack's response is symmetric about the normal
    (``Stack.isotropic``)."""
    return stack.isotropic


# ---------------------------------------------------------------- staging
class _Columns:
    """The table under construction: float64 columns over the grid, one per distinct ``key`` (the
    value it stands for). A column the same at every node becomes a literal only where ``fold``
    says its value is structural (no parameter reaches it): the shader's structure then never
    depends on the parameters' values, so a value edit changes the table alone."""

    def __init__(self, shape):
        self.shape = shape
        self.data: list[np.ndarray] = []
        self._index: dict = {}

    def add(self, values, key=None, fold: bool = False) -> float | int:
        v = np.broadcast_to(np.asarray(values, dtype=np.float64), self.shape)
        if not np.all(np.isfinite(v)):
            raise FloatingPointError("the model is not finite on the view grid")
        v32 = v.astype(np.float32)
        if fold and np.all(v32 == v32.flat[0]):
            return float(v32.flat[0])
        if key is None:
            key = ("anonymous", len(self.data))
        if key not in self._index:
            self._index[key] = len(self.data)
            self.data.append(v32)
        return self._index[key]

    def table(self) -> np.ndarray:
        if not self.data:
            return np.zeros(self.shape + (1,), dtype=np.float32)
        return np.stack(self.data, -1).astype(np.float32)


class NotAnInput(ValueError):
    """Live parameters asked of a stack that has no such input (``names``; ``have``: the inputs it
    has): a texture linked into a layer or field the stack no longer holds."""

    def __init__(self, names, have):
        self.names, self.have = tuple(names), tuple(have)
        super().__init__(f"not an input of this shader: {', '.join(self.names)} (have: {', '.join(self.have)})")


def stage(stack, model: str = "auto", live=(), budget="auto", grid: ViewGrid | None = None,
          traced=None, live_axes: int = 0, partition=None, stand_ins: int = STAND_INS) -> Staged:
    """Stage ``stack`` (a Stack, dict or JSON) under ``model`` for a material whose parameters in
    ``live`` are linked (they stay shader inputs); every other parameter takes the stack's value.
    ``budget``: the lobe budget (``lobe_budget.BUDGETS``: "auto", "all" or 1 to 8 closures);
    ``grid``: the view grid (default: ``N_MU`` nodes, times ``N_PHI`` azimuths where the stack is
    anisotropic and what its table holds varies with the azimuth, ``_azimuth_free``).
    ``live_axes``: a value that depends on the view and on at most this many live parameters (each
    with an axis, ``live_axes.axis_of``) is baked on a table over (view, those parameters) instead
    of staying traced (0: every value a live parameter reaches stays traced). Only for a table with
    one azimuth node; otherwise the live part stays traced. ``partition``: the model's lobes grouped
    into closures as a previous staging of this structure grouped them (``Staged.merged``), kept
    instead of merging to ``budget`` again (a slider dragged: ``lobe_budget.merge``).
    ``stand_ins``: how many isotropic lobes stand in for each baked anisotropic one where the
    renderer draws every lobe round (EEVEE; ``Staged.stand_ins``; 0: none)."""
    stack = Stack.coerce(stack)
    grid_given = grid is not None
    budget = lobe_budget.parse(budget)
    if traced is None or traced.stack != stack:
        traced = trace_closures(stack, model, live)  # ``traced``: the caller's trace of this stack and model
    t = traced.tracer
    asked = tuple(live)
    live, normals = split_normals(live)  # the layers given a normal of their own: their closures' frames
    defaults = {k: float(t.defaults[k]) for k in t.params}
    unknown = sorted(n for n in live if n not in defaults and n not in socket_names(t.ids))
    if unknown:
        raise NotAnInput(unknown, socket_names(t.ids))
    live = params_of(live, t.ids)
    frame = "view" if isotropic(stack) else "shading"
    if grid is not None and frame == "view" and grid.n_phi != 1:
        raise ValueError("a stack staged in the view frame has one azimuth node")
    # the side of the mesh (``closures.INSIDE_INPUT``: a solid dielectric base's far side) weighs
    # its lobes as a linked coverage mask does: a live factor of their closures' weights
    sided = _reached_by_inputs(t, (INSIDE_INPUT,))
    live_ids = t.reached_by(live) | sided
    axes = {p: ax for p in live if live_axes > 0 and (ax := axis_of(stack, t.ids[p], defaults[p])) is not None}
    traced_ids = (_traced_part(t, live, axes, live_axes) | sided) if axes else live_ids

    def live_expr(x):
        return isinstance(x, Expr) and id(x) in live_ids

    # a closure's cover (the fraction of the surface its part of a partly covered stack is on,
    # ``models.coverage``) is a constant of the compile unless a mask is linked: then it stays a
    # live factor of the closure's weight, and lobes merge only with lobes of their own part
    source = [c if live_expr(c.cover) else cc for c, cc in zip(traced.closures, traced.covered)]
    live_covers = list({id(c.cover): c.cover for c in source if live_expr(c.cover)}.values())
    fixed, moving = [], []
    for c in source:
        (moving if any(live_expr(x) for x in (*c.weight, *c.args.values())) else fixed).append(c)
    # what the table holds: every value of the baked lobes, and the view-only values the live
    # lobes read (the boundary between what the table answers and what stays traced)
    baked = [x for c in fixed for x in (*c.lobe.weight, *c.weight, *c.args.values())]

    def boundary_of(outs):
        found = []
        for e in t.live_nodes(outs):
            if id(e) in traced_ids:
                found += [a for a in e.args if isinstance(a, Expr) and id(a) not in traced_ids]
        found += [x for x in outs if isinstance(x, Expr) and id(x) not in traced_ids]
        return list({id(e): e for e in found if e.op != "input"}.values())

    # a live lobe that merges reads its energy too (``_merged_live_closure``)
    boundary = boundary_of([x for c in moving for x in (*c.lobe.weight, *c.weight, *c.args.values())] + live_covers)

    # the model on the grid: each node once, shared by every read of it
    if grid is not None:
        on_grid = grid_values(t, grid.directions().reshape(-1, 3), [*baked, *boundary])
        turn = False
    elif frame == "view":
        grid = ViewGrid(N_MU, 1)
        on_grid = grid_values(t, grid.directions().reshape(-1, 3), [*baked, *boundary])
        turn = False
    else:  # the shading frame: one azimuth node where nothing the table holds depends on it
        grid = ViewGrid(N_MU, 1)
        on_grid = _azimuth_free(t, grid, [*baked, *boundary])
        turn = on_grid is not None
        if on_grid is None:
            if axes:  # tables over (view, parameters) are made on one azimuth node
                return stage(stack, model, asked, budget, None, traced, 0, partition)
            grid = ViewGrid(N_MU, N_PHI)
            on_grid = grid_values(t, grid.directions().reshape(-1, 3), [*baked, *boundary])
    dirs = grid.directions().reshape(-1, 3)

    # every lobe on the grid (a live one at its sockets' values), merged to the budget: baked lobes
    # with baked ones, live lobes with live ones
    def group(c):  # lobes merge only with lobes of their part and of their layer's own normal
        return (id(c.cover) if live_expr(c.cover) else None, c.framed(normals))

    samples = [lobe_budget.LobeSamples.of(c, on_grid, source.index(c), group=group(c)) for c in fixed]
    # a baked lobe of no energy at any view adds no closure (a family the stack never feeds, such as
    # the once-scattered forward light of a coat that refracts it: ``transfer_matrix``)
    samples = [s for s in samples if np.any(s.energy != 0.0)] or samples[:1]
    samples += [lobe_budget.LobeSamples.of(c, on_grid, source.index(c), live=True, group=group(c)) for c in moving]
    views = lobe_budget.check_views(dirs, turn)
    groups = lobe_budget.merge(samples, budget, np.asarray(dirs), views=views,
                               cap=lobe_budget.MAX_CLOSURES if not axes else max(len(samples), lobe_budget.MAX_CLOSURES),
                               partition=partition)
    live_groups = [g for g in groups if g.lobe.live]
    moving_outs = [x for g in live_groups for m in g.members for x in (
        *(source[m.index].lobe.weight if len(g.members) > 1 else ()),
        *source[m.index].weight, *source[m.index].args.values())] + live_covers
    # EEVEE draws every lobe round: a baked anisotropic lobe gets ``stand_ins`` isotropic lobes
    # about normals tilted along its long axis (``lobe_kinds.isotropic_fit``), which the node group
    # draws in EEVEE only. They depend on the view's azimuth about the lobe's axes: where nothing
    # else the table holds does (``_azimuth_free``), the table gets ``N_PHI`` azimuth nodes for them
    # alone, the other columns the same at each (the shaders read those along the elevation only).
    # A grid the caller fixed at one azimuth, or tables over linked parameters, keep the round lobe.
    baked_groups = [grp for grp in groups if not grp.lobe.live]
    anisotropic = [k for k, grp in enumerate(baked_groups) if stand_ins and _anisotropic(grp.lobe)]
    if anisotropic and grid.n_phi == 1:
        if grid_given or axes or frame == "view":
            anisotropic = []
        else:
            grid = ViewGrid(grid.n_mu, N_PHI)

    def on_table_grid(values):
        """Values over the grid the lobes were evaluated on, over the table's (the same, or
        repeated along the azimuth)."""
        return np.broadcast_to(np.reshape(values, (grid.n_mu, -1)), (grid.n_mu, grid.n_phi))

    cols = _Columns((grid.n_mu, grid.n_phi))

    t2 = Tracer()
    wi2 = tuple(t2.input(n) for n in VIEW_INPUTS)
    if frame == "view":  # the view in its own azimuth frame: (sin theta, 0, cos theta)
        wi2 = (t2.sqrt(t2.max(1.0 - wi2[2] * wi2[2], 0.0)), 0.0, wi2[2])
    t2.set_scope("table")
    cc, pp = grid.coords(t2, wi2)

    def read(values_on_grid, key=None, fold=False):
        k = cols.add(on_table_grid(values_on_grid), key, fold)
        return k if isinstance(k, float) else t2.node("mtab", str(k), cc, pp)

    reaches_param = t.reached_by()

    closures = []
    merged = []
    for grp in baked_groups:
        merged.append([s.index for s in grp.members])
        closures.append(_baked_closure(t2, wi2, grp.lobe, read, np.asarray(dirs), reaches_param))
    table_dirs = grid.directions().reshape(-1, 3)
    eevee = {k: _stand_in_closures(t2, baked_groups[k].lobe, read, table_dirs, stand_ins,
                                   lambda v: on_table_grid(v).reshape(-1)) for k in anisotropic}

    # the live lobes: their graph rebuilt in t2; view-only values they read come from the table
    env: dict[int, object] = {}
    boundary = boundary_of(moving_outs)
    on_axes: dict[tuple, list] = {}  # boundary values a live parameter reaches, by their parameters
    for e, v in zip(boundary, on_grid(boundary)):
        if id(e) in live_ids:
            on_axes.setdefault(tuple(p for p in live if id(e) in t.reached_by([p])), []).append(e)
        else:
            env[id(e)] = read(v, ("expr", id(e)), id(e) not in reaches_param)
    for name, x in zip(VIEW_INPUTS, wi2):
        if name in t.inputs:
            env[id(t.inputs[name])] = x
    if INSIDE_INPUT in t.inputs:
        env[id(t.inputs[INSIDE_INPUT])] = t2.input(INSIDE_INPUT)
    t2.set_scope("live")
    # a live lobe's roughness read from a table over a linked roughness: tabulated as its fourth
    # root, which the roughness axis spaces evenly near 0 (``live_axes``: alpha = sin^4 there), so
    # a glossy coat's own lobe is interpolated in the coordinate it is linear in
    roughness_args = {id(x) for c in moving if c.kind.rough for name, x in c.args.items()
                      if name in ROOTED and isinstance(x, Expr)}
    axis_tables = []
    coord_of: dict[str, object] = {}
    tables = {params: [replace(axes[p], n=axis_nodes(axes[p], len(params))) for p in params] for params in on_axes}
    data = _axis_tables(t, grid, tables, on_axes)
    for params, exprs in on_axes.items():
        for p in params:
            if p not in coord_of:
                coord_of[p] = axes[p].coord(t2, t2.param(t.ids[p], t.defaults[p]))
        k = len(axis_tables)
        rooted = np.array([id(e) in roughness_args for e in exprs], dtype=bool)
        values = data[params].copy()
        values[..., rooted] = np.sqrt(np.sqrt(np.maximum(values[..., rooted], 0.0)))
        axis_tables.append(AxisTable(tuple(tables[params]), values))
        t2.set_scope("table")
        for col, e in enumerate(exprs):
            read = t2.node("atab", str(k), str(col), cc, *(coord_of[p] for p in params))
            if rooted[col]:  # a lobe's roughness, read as its fourth root (``ROOTED``)
                read = read * read
                read = read * read
            env[id(e)] = read
        t2.set_scope("live")

    def rebuild(x):
        return env[id(x)] if isinstance(x, Expr) else x

    traced_params: set[str] = set()
    for e in t.live_nodes(moving_outs, known=env):
        if id(e) in env or id(e) not in traced_ids:
            continue
        if e.op != "param":
            traced_params.update(p for p in live if id(e) in t.reached_by([p]))
        a = [a if isinstance(a, str) else rebuild(a) for a in e.args]
        if e.op == "param":
            env[id(e)] = t2.param(t.ids[a[0]], t.defaults[a[0]])
        elif e.op == "select":
            env[id(e)] = t2.select(*a)
        else:
            env[id(e)] = t2.node(e.op, *a)
    t2.set_scope("closures")
    for grp in live_groups:
        members = [source[m.index] for m in grp.members]
        merged.append([m.index for m in grp.members])
        if len(members) == 1:
            c = members[0]
            closures.append(Closure(c.lobe, c.kind, tuple(rebuild(x) for x in c.weight),
                                    {k: rebuild(x) for k, x in c.args.items()}, c.label))
        else:
            closures.append(_merged_live_closure(t2, wi2, members, rebuild, grp.lobe.label))
    framed = []
    for k, (c, grp) in enumerate(zip(closures, baked_groups + live_groups)):
        src = source[grp.members[0].index]
        cover = rebuild(src.cover)
        framed.append(replace(_covered(c, cover), normal=src.normal, tilts=src.tilts))
        if k in eevee:  # the stand-ins take their lobe's cover and frame
            eevee[k] = [replace(_covered(s, cover), normal=src.normal, tilts=src.tilts) for s in eevee[k]]
    closures = framed
    st = Staged(stack, traced.model, frame, grid, cols.table(), t2, wi2, closures, live,
                {k: float(t.defaults[k]) for k in live}, len(traced.closures), budget, merged, (cc, pp),
                tuple(sorted(t.params)), defaults, tuple(axis_tables), live_axes if axes else 0,
                tuple(sorted(traced_params)), dict(t.ids), normals, eevee)
    return st


ROOTED = ("ax", "ay", "alpha")  # closure arguments that are a roughness (GGX alpha)


def _covered(c: Closure, cover) -> Closure:
    """``c`` with its weight times ``cover`` (a live part's fraction of the surface, rebuilt in
    the staged graph; 1.0: the weight already holds it)."""
    if isinstance(cover, float) and cover == 1.0:
        return c
    return Closure(c.lobe, c.kind, tuple(w * cover for w in c.weight), c.args, c.label)


def _traced_part(t: Tracer, live, axes: dict, max_axes: int) -> frozenset[int]:
    """The ids of the nodes that stay traced when values that depend on the view and on at most
    ``max_axes`` live parameters, each with an axis in ``axes``, are read from tables: every node a
    live parameter reaches except those. A node the view does not reach stays traced (the
    parameters' own conversions, such as alpha from r: a table would only approximate them)."""
    reach = {p: t.reached_by([p]) for p in live}
    view = _reached_by_view(t)
    angles = _reached_by_angles(t)
    out = set()
    for e in t.nodes:
        i = id(e)
        if not any(i in r for r in reach.values()):
            continue
        deps = [p for p in live if i in reach[p]]
        if (e.op == "param" or i not in view or i in angles or len(deps) > max_axes
                or any(p not in axes for p in deps)):
            out.add(i)
    return frozenset(out)


def _reached_by_angles(t: Tracer) -> frozenset[int]:
    """The ids of the angles the model computes (``atan2``) and of every node they reach. An
    angle jumps where it wraps, and the axes of a lobe's covariance turn by a right angle where its
    two variances cross (``variance.CovarianceVariance.to_lobe``: the lobe itself is continuous
    there); a table over a linked roughness would interpolate across the jump, so these stay
    traced from the angle's smooth arguments."""
    def build():
        out: set[int] = set()
        for e in t.nodes:
            if e.op == "atan2" or any(a.__class__ is Expr and id(a) in out for a in e.args):
                out.add(id(e))
        return frozenset(out)

    return t.memo(("reached_by_angles",), build)


def _reached_by_view(t: Tracer) -> frozenset[int]:
    """The ids of the nodes the view direction (``VIEW_INPUTS``) reaches."""
    return _reached_by_inputs(t, VIEW_INPUTS)


def _reached_by_inputs(t: Tracer, names) -> frozenset[int]:
    """The ids of the nodes the shading inputs ``names`` reach."""
    names = tuple(names)

    def build():
        out: set[int] = set()
        for e in t.nodes:
            if (e.op == "input" and e.args[0] in names) or any(
                    a.__class__ is Expr and id(a) in out for a in e.args):
                out.add(id(e))
        return frozenset(out)

    return t.memo(("reached_by_inputs", names), build)


def _axis_tables(t: Tracer, grid: ViewGrid, tables: dict, exprs_of: dict) -> dict:
    """For each parameter tuple of ``tables`` (its ``LiveAxis`` list), the values of
    ``exprs_of[params]`` (nodes of ``t`` that no other live parameter reaches) on the view grid's
    elevation nodes (azimuth 0) times the axes' nodes: (n_mu, n_1, ..., n_k, columns) float32.
    Tables whose axes have the same sizes and differ only in parameters no other table reads
    (a colour's three channels over the same roughness axes) are evaluated in one pass, each
    parameter set to its own axis at the same mesh positions: a value depends on its table's
    parameters alone, and the parts they share are computed once. The view and each axis are
    arrays along their own dimension of the table, so numpy evaluates a node on the dimensions
    of what it depends on alone (broadcasting): most of the model depends on the view and one
    or two parameters, and costs that, not the whole table."""
    count: dict[str, int] = {}
    for params in tables:
        for p in params:
            count[p] = count.get(p, 0) + 1
    passes: dict[tuple, list] = {}
    for params, axes in tables.items():
        key = tuple((a.n, a.param if count[a.param] > 1 else None) for a in axes)
        passes.setdefault(key, []).append(params)
    dirs = grid.directions()[:, 0, :]  # (n_mu, 3)
    out = {}
    for key, members in passes.items():
        shape = (grid.n_mu, *(n for n, _ in key))

        def along(values, dim):  # ``values`` along dimension ``dim`` of the table
            return np.reshape(values, tuple(-1 if d == dim else 1 for d in range(len(shape))))

        values = dict(t.defaults)
        for k, n in enumerate(VIEW_INPUTS):
            values[n] = along(dirs[:, k], 0)
        for params in members:
            for dim, a in enumerate(tables[params], 1):
                values[a.param] = along(a.values(), dim)
        exprs = [e for params in members for e in exprs_of[params]]
        with np.errstate(all="ignore"):
            got = t.evaluate(exprs, NumpyOps(np.float64), values)
        got = iter(np.broadcast_to(np.asarray(v, dtype=np.float64), shape) for v in got)
        for params in members:
            data = np.stack([next(got) for _ in exprs_of[params]], -1)
            if not np.all(np.isfinite(data)):
                raise FloatingPointError("the model is not finite on the table of its linked parameters")
            out[params] = data.astype(np.float32)
    return out


PROBE_AZIMUTHS = (0.0, 1.0, 2.6)  # radians: phi = 0 and two angles no symmetry of a layer maps to it


def grid_values(t: Tracer, dirs: np.ndarray, outputs, select=None):
    """``on_grid(exprs)``: the values of ``exprs`` (nodes of ``t``) at the view directions
    ``dirs`` (N, 3), float64, each (N,) (or ``select`` of the evaluated arrays). The model is
    evaluated for ``outputs`` at once; the evaluation is kept for the next staging of the same
    graph on the same directions (``_EVALUATED``), which re-evaluates only the nodes that the
    parameters whose values changed reach (a value edit)."""
    env, changed = _evaluation(t, dirs)
    np_ops = NumpyOps(np.float64)
    values = dict(t.defaults)
    values.update({n: dirs[:, k] for k, n in enumerate(VIEW_INPUTS)})
    # a value edit: the same parameters changed again (a slider dragged) run compiled code
    plan = ("grid", tuple(map(id, outputs)), changed) if changed else None
    with np.errstate(all="ignore"):
        t.evaluate(list(outputs), np_ops, values, env, plan)
    n = dirs.shape[0]

    def on_grid(exprs):
        with np.errstate(all="ignore"):
            vals = t.evaluate(list(exprs), np_ops, values, env)
        vals = [np.broadcast_to(np.asarray(v, dtype=np.float64), (n,)) for v in vals]
        return vals if select is None else [select(v) for v in vals]

    return on_grid


_EVALUATED: dict = {}  # the last grid evaluation: the graph's memo, directions, parameter values, values
KEEP_EVALUATION_VIEWS = 256  # kept only for grids this small (the azimuth probe, the view frame)


def _evaluation(t: Tracer, dirs: np.ndarray) -> tuple[dict, frozenset | None]:
    """The node values (id -> value) of the last evaluation of ``t``'s graph on ``dirs`` still
    valid for ``t.defaults`` (those no changed parameter reaches), and the names of the changed
    parameters; a fresh dict and None if there is none."""
    last = _EVALUATED
    same = last.get("memo") is t._memo and np.array_equal(last.get("dirs"), dirs) and last.get(
        "params", {}).keys() == t.defaults.keys()
    changed = None
    if not same:
        env: dict = {}
    else:
        env = last["env"]
        changed = frozenset(k for k, v in t.defaults.items() if not _same_value(last["params"][k], v))
        if changed:
            stale = t.reached_by(changed)
            for k in [k for k in env if k in stale]:
                del env[k]
    _EVALUATED.clear()
    if dirs.shape[0] <= KEEP_EVALUATION_VIEWS:
        _EVALUATED.update(memo=t._memo, dirs=dirs.copy(), params=dict(t.defaults), env=env)
    return env, changed


def _same_value(a, b) -> bool:
    return np.array_equal(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64))


def _azimuth_free(t: Tracer, grid: ViewGrid, outputs):
    """``on_grid`` over ``grid`` (one azimuth node, phi = 0) if no value in ``outputs`` depends on
    the view's azimuth, else None. The values are evaluated at ``PROBE_AZIMUTHS`` and must agree in
    float32 (what the table stores) at every elevation node. Whether they do follows from the
    model's form (lobes whose axes are fixed in the shading frame, normalisers of the elevation
    alone), not from the parameters' values: the answer is kept for the graph (``Tracer.memo``),
    and a value edit evaluates the one azimuth only."""
    base = grid.directions()[:, 0, :]  # (n_mu, 3) at phi = 0
    k = len(PROBE_AZIMUTHS)
    c, s = np.cos(PROBE_AZIMUTHS), np.sin(PROBE_AZIMUTHS)
    dirs = np.stack([base[:, None, 0] * c[None, :], base[:, None, 0] * s[None, :],
                     np.broadcast_to(base[:, None, 2], (base.shape[0], k))], -1).reshape(-1, 3)
    probed = []

    def free() -> bool:
        probed.append(grid_values(t, dirs, outputs))
        for v in probed[0](outputs):
            v32 = v.astype(np.float32).reshape(-1, k)
            if not np.array_equal(v32, np.broadcast_to(v32[:, :1], v32.shape)):
                return False
        return True

    if not t.memo(("azimuth_free", tuple(map(id, outputs))), free):
        return None
    if probed:  # evaluated just now at the probe's azimuths: keep the first (phi = 0, the same
        # inputs as ``base`` bit for bit), so the next value edit re-evaluates only what it reaches
        last = _EVALUATED
        if last.get("memo") is t._memo and last.get("dirs") is not None and last["dirs"].shape == dirs.shape:
            n = dirs.shape[0]
            last["env"] = {i: (v.reshape(-1, k)[:, 0] if isinstance(v, np.ndarray) and v.shape[:1] == (n,) else v)
                           for i, v in last["env"].items()}
            last["dirs"] = base.copy()
    return grid_values(t, base, outputs)


def _baked_closure(t2: Tracer, wi2, lobe: "lobe_budget.LobeSamples", read_column, dirs, reaches_param) -> Closure:
    """A closure of the staged graph from a baked (possibly merged) lobe: weights and arguments
    read from the table; a lobe whose axes turn with the view is read as its roughness tensor. A
    value of a lobe of the model itself that no parameter reaches and that is the same at every
    view folds to a literal; every other value is a column."""
    kind = lobe.kind
    exprs = lobe.exprs if len(lobe.members) == 1 else {}

    def read(values, field):
        e = exprs.get(field)
        fold = field in exprs and not (isinstance(e, Expr) and id(e) in reaches_param)
        return read_column(values, ("lobe", id(lobe), field) if e is None else ("expr", id(e)), fold)

    args = {}
    if kind.name == "reflection":
        ax, ay, cs, sn = (lobe.args[k] for k in ("ax", "ay", "cos", "sin"))
        turning = not (np.all(cs == cs[0]) and np.all(sn == sn[0]))
        if turning:
            # roughness tensor A = R diag(ax, ay) R^T, R the rotation by (cs, sn)
            txx = ax * cs * cs + ay * sn * sn
            tyy = ax * sn * sn + ay * cs * cs
            txy = (ax - ay) * cs * sn
            args.update(_axes_of_tensor(t2, read(txx, "txx"), read(tyy, "tyy"), read(txy, "txy")))
        else:
            args.update(ax=read(ax, "ax"), ay=read(ay, "ay"), cos=float(cs[0]), sin=float(sn[0]))
    else:
        args = {k: read(v, k) for k, v in lobe.args.items()}
    if kind.name == "transmission":  # interpolated, the closure normal is made unit again
        inv = 1.0 / t2.sqrt(t2.max(args["nx"] * args["nx"] + args["ny"] * args["ny"] + args["nz"] * args["nz"], 1e-30))
        args.update(nx=args["nx"] * inv, ny=args["ny"] * inv, nz=args["nz"] * inv)
    weight = tuple(read(w, f"weight{ch}") for ch, w in enumerate(lobe.closure_weight(dirs)))
    return Closure(lobe.lobe, kind, weight, args, lobe.label)


def same_at_every_azimuth(part: np.ndarray) -> bool:
    """Whether ``part`` of a material table (n_mu, n_phi, columns) is the same at every azimuth
    node: a table made over azimuths for the EEVEE stand-ins alone holds the other columns so, and
    the emitters read those along the elevation only."""
    return part.shape[1] == 1 or bool(np.array_equal(part, np.broadcast_to(part[:, :1], part.shape)))


def _anisotropic(lobe: "lobe_budget.LobeSamples") -> bool:
    """A reflection lobe whose axes differ by more than ``ANISOTROPY_MIN`` at some grid view."""
    if lobe.kind.name != "reflection" or lobe.is_delta:
        return False
    ax, ay = (np.asarray(lobe.args[k], dtype=np.float64) for k in ("ax", "ay"))
    top = np.maximum(np.maximum(ax, ay), 1e-30)
    return bool(np.any(1.0 - np.minimum(ax, ay) / top > ANISOTROPY_MIN))


def _stand_in_closures(t2: Tracer, lobe: "lobe_budget.LobeSamples", read_column, dirs, k: int, expand) -> list:
    """The ``k`` isotropic stand-ins of the baked anisotropic reflection ``lobe``
    (``isotropic_fit.fit`` at every grid view, in the lobe's axes): closures of the kind
    ``tilted_reflection``. The table holds the lobe's energy and long axis (shading frame) once,
    and each stand-in's roughness, tilt (signed, toward the long axis) and weight per unit of
    energy; its normal is (sin t L, cos t), unit at every interpolated view. ``dirs``: the table's
    views; ``expand``: the lobe's values (over the views it was evaluated on) over those."""
    ax, ay, cs, sn = (expand(np.broadcast_to(np.asarray(lobe.args[n], dtype=np.float64), lobe.energy.shape[:1]))
                      for n in ("ax", "ay", "cos", "sin"))
    energy = np.stack([expand(lobe.energy[:, ch]) for ch in range(3)], -1)
    wl = np.stack([cs * dirs[:, 0] + sn * dirs[:, 1], cs * dirs[:, 1] - sn * dirs[:, 0], dirs[:, 2]], -1)
    fit = isotropic_fit.fit(ax, ay, wl, k)

    def read(values, field):
        return read_column(values, ("stand-in", id(lobe), field))

    lx, ly = fit.long_axis[:, 0], fit.long_axis[:, 1]
    long_x, long_y = read(cs * lx - sn * ly, "long_x"), read(sn * lx + cs * ly, "long_y")
    energy = [read(energy[:, ch], f"energy{ch}") for ch in range(3)]
    kind = lobe_kinds.kind("tilted_reflection")
    out = []
    for j in range(k):
        tilt = read(fit.tilt[:, j], f"tilt{j}")
        scale = read(fit.scale[:, j], f"scale{j}")
        s = t2.sin(tilt)
        args = {"alpha": read(fit.alpha[:, j], f"alpha{j}"), "nx": s * long_x, "ny": s * long_y, "nz": t2.cos(tilt)}
        out.append(Closure(lobe.lobe, kind, tuple(e * scale for e in energy), args,
                           f"{lobe.label}: EEVEE stand-in {j + 1} of {k}"))
    return out


def _merged_live_closure(t2: Tracer, wi2, members: list, rebuild, label: str) -> Closure:
    """One closure standing for live lobes of one kind (``members``, closures of the traced
    model; ``rebuild`` maps their values into ``t2``), traced, by the rule ``lobe_budget.combine``
    applies to baked lobes: the energies summed, the roughness tensor the energy-weighted
    log-Euclidean mean of the members' (each member's from its own axes, so no eigen-decomposition
    until the mean's), the weight that sum times the kind's normaliser at the merged arguments."""
    kind = members[0].kind
    energies = [tuple(rebuild(x) for x in c.lobe.weight) for c in members]
    energy = tuple(sum(e[ch] for e in energies) for ch in range(3))
    if not kind.rough:
        args = {k: rebuild(x) for k, x in members[0].args.items()}
    else:
        weights = [(e[0] + e[1] + e[2]) * (1.0 / 3.0) for e in energies]
        total = t2.max(sum(weights), 1e-30)

        def log(x):
            return t2.log(t2.max(x, lobe_budget.LOG_FLOOR))

        if kind.name == "backscatter":
            mean = sum(w * log(rebuild(c.args["alpha"])) for w, c in zip(weights, members)) / total
            args = {"alpha": t2.exp(mean)}
        else:
            xx = yy = xy = 0.0
            for w, c in zip(weights, members):
                ax, ay, cs, sn = (rebuild(c.args[k]) for k in ("ax", "ay", "cos", "sin"))
                lx, ly = log(ax), log(ay)
                xx = xx + w * (lx * cs * cs + ly * sn * sn)
                yy = yy + w * (lx * sn * sn + ly * cs * cs)
                xy = xy + w * ((lx - ly) * cs * sn)
            axes = _eigen_of_tensor(t2, xx / total, yy / total, xy / total)
            args = {"ax": t2.exp(axes["big"]), "ay": t2.exp(axes["small"]), "cos": axes["cos"], "sin": axes["sin"]}
    scale = kind.scale_of_args(t2, args, wi2)
    return Closure(members[0].lobe, kind, tuple(e * scale for e in energy), args, label)


def _eigen_of_tensor(ops, txx, tyy, txy) -> dict:
    """The eigenvalues (``big`` >= ``small``, any sign) of the symmetric 2x2 matrix
    [[txx, txy], [txy, tyy]] and the direction (``cos``, ``sin``) of the first eigenvector, by the
    closed form (the half angle of atan2(2 txy, txx - tyy))."""
    m = (txx + tyy) * 0.5
    d = (txx - tyy) * 0.5
    r = ops.sqrt(d * d + txy * txy)
    c2 = ops.select(r > 1e-12, d / ops.max(r, 1e-12), 1.0)  # cos of twice the angle
    cs = ops.sqrt(ops.max((1.0 + c2) * 0.5, 0.0))
    sn = ops.sqrt(ops.max((1.0 - c2) * 0.5, 0.0))
    sn = ops.select(txy < 0.0, 0.0 - sn, sn)
    return {"big": m + r, "small": m - r, "cos": cs, "sin": sn}


def _axes_of_tensor(ops, txx, tyy, txy) -> dict:
    """(ax, ay, cos, sin) of the lobe whose roughness tensor is [[txx, txy], [txy, tyy]]: its
    eigenvalues ax >= ay (``_eigen_of_tensor``, the smaller clipped at 0) and the direction
    (cos, sin) of the first eigenvector."""
    e = _eigen_of_tensor(ops, txx, tyy, txy)
    return {"ax": e["big"], "ay": ops.max(e["small"], 0.0), "cos": e["cos"], "sin": e["sin"]}


__all__ = ["NotAnInput", "ViewGrid", "Staged", "StagedOps", "stage", "grid_values", "lookup", "isotropic", "N_MU", "N_PHI"]
