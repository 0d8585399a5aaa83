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
  (``lobe_budget.merge``), the trade of run time against error.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .. import luts
from ..stack import Stack
from . import lobe_budget
from .closures import Closure, trace_closures
from .numpy_ops import NumpyOps
from .sockets import params_of, socket_names, sockets
from .trace import Expr, Tracer

N_MU = 64  # nodes along the view coordinate (bench/staging.md: <= 0.5 % relative L1 up to 85 degrees)
N_PHI = 16  # nodes along the azimuth (shading frame only), periodic
MU_MIN = 1e-4  # the grazing node is evaluated just above the horizon (the model's limit there)
VIEW_INPUTS = ("wi_x", "wi_y", "wi_z")
ENERGY_EPS = 1e-6  # lobes below this energy at a shading point add no closure (every emitter)


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

    @property
    def live_sockets(self) -> tuple:
        """The sockets (``sockets.sockets``: panel units) whose parameters are live, sorted."""
        live = set(self.live)
        return tuple(sk.name for sk in sockets(dict.fromkeys(self.interface, 0.0)) if live & set(sk.params))

    @property
    def columns(self) -> int:
        return self.table.shape[2]

    def structure_key(self) -> str:
        """What identifies the compiled shader apart from the table's values and the live
        parameters' values: the staged graph's shape, the closures, the table's size and the
        parameters (the sockets)."""
        import hashlib

        t = self.tracer
        outs = [x for c in self.closures for x in (*c.weight, *c.args.values())]
        names: dict[int, int] = {}
        parts = [self.frame, str(self.table.shape), ",".join(self.live), ",".join(self.interface)]
        for k, e in enumerate(t.live_nodes(outs)):
            names[id(e)] = k
            parts.append(e.op + "(" + ",".join(
                f"#{names[id(a)]}" if isinstance(a, Expr) else repr(a) for a in e.args) + ")")
        parts += [c.kind.name + ":" + ",".join(f"#{names[id(x)]}" if isinstance(x, Expr) else repr(x)
                                                for x in (*c.weight, *c.args.values())) for c in self.closures]
        return hashlib.sha256("\n".join(parts).encode()).hexdigest()


class StagedOps(NumpyOps):
    """``NumpyOps`` that can read the material table (``mtab``) of a staged graph."""

    def __init__(self, table: np.ndarray, dtype=np.float32):
        super().__init__(dtype)
        self.table = table

    def mtab(self, col, c, p):
        return lookup(self.table, int(col), c, p, self.dtype)


def isotropic(stack: Stack) -> bool:
    """Every interface isotropic: the stack's response is symmetric about the normal."""
    return all(r[0] == r[1] for r in (getattr(layer, "roughness", (0.0, 0.0)) for layer in (*stack.coats, stack.base)))


# ---------------------------------------------------------------- staging
def _live_set(t: Tracer, live) -> dict[int, bool]:
    out: dict[int, bool] = {}
    for e in t.nodes:
        out[id(e)] = (e.op == "param" and e.args[0] in live) or any(
            isinstance(a, Expr) and out[id(a)] for a in e.args)
    return out


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


def stage(stack, model: str = "auto", live=(), budget="auto", grid: ViewGrid | None = None,
          traced=None) -> Staged:
    """Stage ``stack`` (a Stack, dict or JSON) under ``model`` for a material whose parameters in
    ``live`` are linked (they stay shader inputs); every other parameter takes the stack's value.
    ``budget``: the lobe budget (``lobe_budget.BUDGETS``: "auto", "all" or 1 to 8 closures);
    ``grid``: the view grid (default: ``N_MU`` nodes, times ``N_PHI`` azimuths where the stack is
    anisotropic and its table varies with the azimuth, ``_without_azimuth``)."""
    stack = Stack.coerce(stack)
    budget = lobe_budget.parse(budget)
    if traced is None or traced.stack != stack:
        traced = trace_closures(stack, model)  # ``traced``: the caller's trace of this stack and model
    t = traced.tracer
    defaults = {k: float(t.defaults[k]) for k in t.params}
    unknown = sorted(n for n in live if n not in defaults and n not in socket_names(defaults))
    if unknown:
        raise ValueError(f"not an input of this shader: {', '.join(unknown)} "
                         f"(have: {', '.join(socket_names(defaults))})")
    live = params_of(live, defaults)
    frame = "view" if isotropic(stack) else "shading"
    default_grid = grid is None
    if grid is None:
        grid = ViewGrid(N_MU, 1 if frame == "view" else N_PHI)
    if frame == "view" and grid.n_phi != 1:
        raise ValueError("a stack staged in the view frame has one azimuth node")
    is_live = _live_set(t, set(live))
    dirs = grid.directions().reshape(-1, 3)
    values = dict(t.defaults)
    values.update({n: dirs[:, k] for k, n in enumerate(VIEW_INPUTS)})
    np_ops = NumpyOps(np.float64)
    grid_env: dict = {}  # one evaluation of the model on the grid, shared by every read of it

    def on_grid(exprs):
        with np.errstate(all="ignore"):
            vals = t.evaluate(list(exprs), np_ops, values, grid_env)
        return [np.broadcast_to(np.asarray(v, dtype=np.float64), (dirs.shape[0],)) for v in vals]

    def live_expr(x):
        return isinstance(x, Expr) and is_live[id(x)]

    fixed, moving = [], []
    for c in traced.closures:
        (moving if any(live_expr(x) for x in (*c.weight, *c.args.values())) else fixed).append(c)

    # the fully baked lobes, on the grid (every closure's values in one pass), merged to the budget
    on_grid([x for c in fixed for x in (*c.lobe.weight, *c.weight, *c.args.values())])
    samples = [lobe_budget.LobeSamples.of(c, on_grid, traced.closures.index(c)) for c in fixed]
    groups = lobe_budget.merge(samples, budget, np.asarray(dirs), len(moving))
    cols = _Columns((grid.n_mu, grid.n_phi))

    t2 = Tracer()
    wi2 = tuple(t2.input(n) for n in VIEW_INPUTS)
    if frame == "view":  # the view in its own azimuth frame: (sin theta, 0, cos theta)
        wi2 = (t2.sqrt(t2.max(1.0 - wi2[2] * wi2[2], 0.0)), 0.0, wi2[2])
    t2.set_scope("table")
    cc, pp = grid.coords(t2, wi2)

    def read(values_on_grid, key=None, fold=False):
        k = cols.add(np.reshape(values_on_grid, (grid.n_mu, grid.n_phi)), key, fold)
        return k if isinstance(k, float) else t2.node("mtab", str(k), cc, pp)

    reaches_param = _param_reach(t)

    closures = []
    merged = []
    for grp in groups:
        merged.append([s.index for s in grp.members])
        closures.append(_baked_closure(t2, wi2, grp.lobe, read, np.asarray(dirs), reaches_param))

    # the live lobes: their graph rebuilt in t2; view-only values they read come from the table
    env: dict[int, object] = {}
    boundary = []
    for e in t.live_nodes([x for c in moving for x in (*c.weight, *c.args.values())]):
        if is_live[id(e)]:
            boundary += [a for a in e.args if isinstance(a, Expr) and not is_live[id(a)]]
    for c in moving:
        boundary += [x for x in (*c.weight, *c.args.values()) if isinstance(x, Expr) and not is_live[id(x)]]
    boundary = list({id(e): e for e in boundary if e.op != "input"}.values())
    for e, v in zip(boundary, on_grid(boundary)):
        env[id(e)] = read(v, ("expr", id(e)), not reaches_param[id(e)])
    for name, x in zip(VIEW_INPUTS, wi2):
        if name in t.inputs:
            env[id(t.inputs[name])] = x
    t2.set_scope("live")

    def rebuild(x):
        return env[id(x)] if isinstance(x, Expr) else x

    for e in t.live_nodes([x for c in moving for x in (*c.weight, *c.args.values())]):
        if id(e) in env or not is_live[id(e)]:
            continue
        a = [a if isinstance(a, str) else rebuild(a) for a in e.args]
        if e.op == "param":
            env[id(e)] = t2.param(a[0], t.defaults[a[0]])
        elif e.op == "select":
            env[id(e)] = t2.select(*a)
        else:
            env[id(e)] = t2.node(e.op, *a)
    t2.set_scope("closures")
    for c in moving:
        merged.append([traced.closures.index(c)])
        closures.append(Closure(c.lobe, c.kind, tuple(rebuild(x) for x in c.weight),
                                {k: rebuild(x) for k, x in c.args.items()}, c.label))
    st = Staged(stack, traced.model, frame, grid, cols.table(), t2, wi2, closures, live,
                {k: float(t.defaults[k]) for k in live}, len(traced.closures), budget, merged, (cc, pp),
                tuple(sorted(t.params)), defaults)
    return _without_azimuth(st) if default_grid and grid.n_phi > 1 else st


def _without_azimuth(st: Staged) -> Staged:
    """``st`` with one azimuth node where no column of its table varies with the view's azimuth
    (float32-exact): a stack with anisotropic layers whose lobes' energies and roughness tensors
    depend on the elevation alone (the lobes' axes are fixed in the shading frame). The graph is
    rebuilt with the azimuth coordinate 0, so what computed it (atan2) drops out."""
    table = st.table
    if not np.all(table == table[:, :1, :]):
        return st
    _, pp = st.coords
    t2 = Tracer()
    env: dict[int, object] = {id(pp): 0.0} if isinstance(pp, Expr) else {}
    outs = [x for c in st.closures for x in (*c.weight, *c.args.values())]

    def rebuild(x):
        return env[id(x)] if isinstance(x, Expr) else x

    reached, todo = set(), [x for x in outs if isinstance(x, Expr)]
    while todo:  # what the closures read, not through the azimuth coordinate
        e = todo.pop()
        if id(e) not in reached and id(e) not in env:
            reached.add(id(e))
            todo += [a for a in e.args if isinstance(a, Expr)]
    for e in st.tracer.nodes:
        if id(e) not in reached:
            continue
        t2.set_scope(e.scope)
        a = [a if isinstance(a, str) else rebuild(a) for a in e.args]
        if e.op == "param":
            env[id(e)] = t2.param(a[0], st.tracer.defaults[a[0]])
        elif e.op == "input":
            env[id(e)] = t2.input(a[0])
        elif e.op == "select":
            env[id(e)] = t2.select(*a)
        else:
            env[id(e)] = t2.node(e.op, *a)
    wi2 = tuple(t2.input(n) for n in VIEW_INPUTS)
    closures = [Closure(c.lobe, c.kind, tuple(rebuild(x) for x in c.weight), {k: rebuild(x) for k, x in c.args.items()},
                        c.label) for c in st.closures]
    cc = rebuild(st.coords[0])
    return replace(st, grid=replace(st.grid, n_phi=1), table=np.ascontiguousarray(table[:, :1, :]), tracer=t2,
                   wi=wi2, closures=closures, coords=(cc, 0.0))


def _param_reach(t: Tracer) -> dict[int, bool]:
    """Whether a parameter reaches each node of ``t``."""
    out: dict[int, bool] = {}
    for e in t.nodes:
        out[id(e)] = e.op == "param" or any(isinstance(a, Expr) and out[id(a)] for a in e.args)
    return out


def _baked_closure(t2: Tracer, wi2, lobe: "lobe_budget.LobeSamples", read_column, dirs, reaches_param) -> Closure:
    """A closure of the staged graph from a baked (possibly merged) lobe: weights and arguments
    read from the table; a lobe whose axes turn with the view is read as its roughness tensor. A
    value of a lobe of the model itself that no parameter reaches and that is the same at every
    view folds to a literal; every other value is a column."""
    kind = lobe.kind
    exprs = lobe.exprs if len(lobe.members) == 1 else {}

    def read(values, field):
        e = exprs.get(field)
        fold = field in exprs and not (isinstance(e, Expr) and reaches_param[id(e)])
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


def _axes_of_tensor(ops, txx, tyy, txy) -> dict:
    """(ax, ay, cos, sin) of the lobe whose roughness tensor is [[txx, txy], [txy, tyy]]: its
    eigenvalues ax >= ay and the direction (cos, sin) of the first eigenvector, by the closed form
    of a symmetric 2x2 matrix (the half angle of atan2(2 txy, txx - tyy))."""
    m = (txx + tyy) * 0.5
    d = (txx - tyy) * 0.5
    r = ops.sqrt(d * d + txy * txy)
    c2 = ops.select(r > 1e-12, d / ops.max(r, 1e-12), 1.0)  # cos of twice the angle
    cs = ops.sqrt(ops.max((1.0 + c2) * 0.5, 0.0))
    sn = ops.sqrt(ops.max((1.0 - c2) * 0.5, 0.0))
    sn = ops.select(txy < 0.0, 0.0 - sn, sn)
    return {"ax": m + r, "ay": ops.max(m - r, 0.0), "cos": cs, "sin": sn}


def evaluate_staged(st: Staged, wi, wo, dtype=np.float32, values: dict | None = None) -> np.ndarray:
    """f(wi, wo) |wo.z| of the staged shader (numpy, ``dtype``) for directions in the shading
    frame (N, 3): what the emitted shaders compute, to hold them to the traced model."""
    wi = np.asarray(wi, dtype=np.float64).reshape(-1, 3)
    wo = np.asarray(wo, dtype=np.float64).reshape(-1, 3)
    wi = np.broadcast_to(wi, wo.shape)
    if st.frame == "view":
        wi, wo = to_view_frame(wi, wo)
    ops = StagedOps(st.table, dtype)
    dtype = ops.dtype.type
    vals = {n: wi[:, k].astype(dtype) for k, n in enumerate(VIEW_INPUTS)}
    vals.update(st.params)
    if values:
        vals.update(values)
    outs = [x for c in st.closures for x in (*c.weight, *c.args.values())]
    with np.errstate(all="ignore"):
        got = st.tracer.evaluate(outs, ops, vals)
    env = dict(zip(map(id, outs), got))
    wi_o = tuple(ops.input(n, wi[:, k]) for k, n in enumerate(VIEW_INPUTS))
    wo_o = tuple(ops.input(n, wo[:, k]) for k, n in enumerate(("wo_x", "wo_y", "wo_z")))
    total = np.zeros((wo.shape[0], 3), dtype=dtype)

    def v(x):
        return env[id(x)] if isinstance(x, Expr) else dtype(x)

    for c in st.closures:
        with np.errstate(all="ignore"):
            f = c.kind.cos_of_args(ops, {k: v(x) for k, x in c.args.items()}, wi_o, wo_o)
        w = np.stack([np.broadcast_to(v(x), (wo.shape[0],)) for x in c.weight], -1)
        on = w.max(-1) > ENERGY_EPS  # the emitters' test: a dark lobe adds no closure
        total += np.where(on[:, None], w * np.broadcast_to(f, (wo.shape[0],))[:, None], 0.0).astype(dtype)
    return total


def to_view_frame(wi, wo):
    """Directions turned about the normal so that wi's azimuth is 0 (wi in the x-z plane); at
    normal incidence the shading frame is kept."""
    s = np.hypot(wi[:, 0], wi[:, 1])
    ok = s > 1e-12
    cp = np.where(ok, wi[:, 0] / np.where(ok, s, 1.0), 1.0)
    sp = np.where(ok, wi[:, 1] / np.where(ok, s, 1.0), 0.0)

    def turn(w):
        return np.stack([cp * w[:, 0] + sp * w[:, 1], -sp * w[:, 0] + cp * w[:, 1], w[:, 2]], -1)

    return turn(wi), turn(wo)


__all__ = ["ViewGrid", "Staged", "StagedOps", "stage", "lookup", "evaluate_staged", "isotropic",
           "to_view_frame", "N_MU", "N_PHI"]
