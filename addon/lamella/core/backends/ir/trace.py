"""A tracing backend: runs the one model on symbolic values and records an expression graph.

This is the front half of the OSL and node-graph emitters (docs/design.md "One model, three
backends"): values are ``Expr`` nodes; arithmetic between plain numbers is folded at trace time,
identical sub-expressions are shared (hash-consing), and the result is a finite DAG whose
leaves are literals, shader parameters (``param``) and shading inputs (``input``). Evaluating the
graph with numpy (``evaluate``) must reproduce the numpy backend, which is how tests prove the
model never escapes the ops it is handed.
"""
from __future__ import annotations

import math
import operator
from typing import Any

from ...param_id import ParamId
from .traced_ops import OPS, Ops, TracedOp

_BINARY = {
    "add": operator.add, "sub": operator.sub, "mul": operator.mul, "div": operator.truediv,
    "lt": operator.lt, "le": operator.le, "gt": operator.gt, "ge": operator.ge,
}


class Expr:
    """A node of the traced graph. Build only through ``Tracer``; never branch on one."""

    __slots__ = ("tracer", "op", "args", "key", "scope", "__weakref__")

    def __init__(self, tracer: "Tracer", op: str, args: tuple, key):
        self.tracer, self.op, self.args, self.key = tracer, op, args, key
        self.scope = tracer.scope

    def _bin(self, op, other, swap=False):
        if not (_is_num(other) or isinstance(other, Expr)):
            return NotImplemented  # e.g. an RGB triple: let its reflected operator broadcast
        a, b = (other, self) if swap else (self, other)
        return self.tracer.node(op, a, b)

    def __add__(self, o): return self._bin("add", o)
    def __radd__(self, o): return self._bin("add", o, True)
    def __sub__(self, o): return self._bin("sub", o)
    def __rsub__(self, o): return self._bin("sub", o, True)
    def __mul__(self, o): return self._bin("mul", o)
    def __rmul__(self, o): return self._bin("mul", o, True)
    def __truediv__(self, o): return self._bin("div", o)
    def __rtruediv__(self, o): return self._bin("div", o, True)
    def __neg__(self): return self.tracer.node("sub", 0.0, self)
    def __lt__(self, o): return self._bin("lt", o)
    def __le__(self, o): return self._bin("le", o)
    def __gt__(self, o): return self._bin("gt", o)
    def __ge__(self, o): return self._bin("ge", o)

    def __bool__(self):
        raise TypeError("a traced value has no truth value: model code must use ops.select, "
                        "not Python control flow, on traced values")

    __hash__ = object.__hash__

    def __repr__(self):
        return f"Expr({self.op})"


def _is_num(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


class Tracer(Ops):
    """The ops of the tracing backend. ``nodes`` lists the graph's nodes in creation order
    (a topological order); ``params`` and ``inputs`` the leaves by name."""

    name = "trace"

    def __init__(self):
        self.nodes: list[Expr] = []
        self.params: dict[str, Expr] = {}
        self.ids: dict[str, ParamId] = {}  # parameter name -> what it is (layer, field, channel, unit)
        self.defaults: dict[str, Any] = {}
        self.inputs: dict[str, Expr] = {}
        self._cache: dict[tuple, Expr] = {}
        self._memo: dict = {}  # what ``nodes`` alone determines (shared by copies: see ``memo``)
        self.scope = "setup"  # the part of the model that creates the next nodes (for readable output)

    def set_scope(self, name: str) -> None:
        """Label the nodes created from now on (e.g. "coat0", "base"): emitters name temporaries
        and section the generated code by it. A node shared by several parts keeps its first label."""
        self.scope = name

    # ---------------------------------------------------------------- graph building
    def node(self, op: str, *args) -> Expr | float:
        # one pass over the operands: numbers become floats, the hash-consing key is built
        norm, key, numbers = [], [op], True
        for a in args:
            t = type(a)
            if t is Expr:
                numbers = False
                key.append(("e", id(a)))
            elif t is float or (t is not bool and isinstance(a, (int, float))):
                a = float(a)
                key.append(("n", a))
            elif isinstance(a, str):
                numbers = False
                key.append(a)
            elif isinstance(a, Expr):
                numbers = False
                key.append(("e", id(a)))
            else:
                raise TypeError(f"cannot trace operand {a!r} of type {type(a).__name__}")
            norm.append(a)
        args = tuple(norm)
        if numbers:
            fold = _FOLD.get(op)
            if fold is None and op in OPS:
                fold = OPS[op].fold
            folded = fold(*args) if fold is not None else None
            if folded is not None:
                return folded
        simplified = _simplify(op, args)
        if simplified is not None:
            return simplified
        key = tuple(key)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        e = Expr(self, op, args, key)
        self._cache[key] = e
        self.nodes.append(e)
        return e

    def apply(self, op: TracedOp, *xs):
        """A registered traced operation (``traced_ops``): a node, folded on numbers."""
        return self.node(op.name, *xs)

    def const(self, x):
        return float(x)

    def param(self, pid: ParamId, value):
        """A layer's parameter (``ParamId``: what it is); the graph names it by ``pid.name``."""
        if not isinstance(pid, ParamId):
            raise TypeError(f"a parameter is declared by its ParamId (layers.params.field_param), not {pid!r}")
        e = self.node("param", pid.name)
        self.params[pid.name] = e
        self.ids[pid.name] = pid
        self.defaults[pid.name] = value
        return e

    def input(self, name, value=None):
        e = self.node("input", name)
        self.inputs[name] = e
        return e

    # ---------------------------------------------------------------- ops
    # sqrt, exp, log, pow, abs, min, max, cos, sin, atan2, floor and any registered function: ``traced_ops``
    def clamp(self, x, lo, hi): return self.node("min", self.node("max", x, lo), hi)

    def select(self, cond, a, b):
        if isinstance(cond, bool):
            return a if cond else b
        return self.node("select", cond, a, b)

    def lut(self, name, *coords):
        return self.node("lut", name, *coords)

    # ---------------------------------------------------------------- inspection
    def memo(self, key, build):
        """``build()`` once per graph: structural facts (reach of parameters, node order) that
        copies of this tracer with other defaults (``closures.trace_closures``) share. Valid
        while no node is added, so the memo is dropped when the graph grows."""
        if self._memo.get("_size") != len(self.nodes):
            self._memo.clear()
            self._memo["_size"] = len(self.nodes)
        if key not in self._memo:
            self._memo[key] = build()
        return self._memo[key]

    def _position(self) -> dict[int, int]:
        return self.memo("position", lambda: {id(e): k for k, e in enumerate(self.nodes)})

    def reached_by(self, names=None) -> frozenset[int]:
        """The ids of the nodes that the parameters ``names`` (every parameter: None) reach."""
        if names is not None and not names:
            return frozenset()
        key = ("reached_by", None if names is None else frozenset(names))

        def build():
            out: set[int] = set()
            for e in self.nodes:
                if e.op == "param":
                    if names is None or e.args[0] in names:
                        out.add(id(e))
                    continue
                for a in e.args:
                    if a.__class__ is Expr and id(a) in out:
                        out.add(id(e))
                        break
            return frozenset(out)

        return self.memo(key, build)

    def live_nodes(self, outputs, known=()) -> list[Expr]:
        """Nodes reachable from ``outputs`` (values or Expr) without passing through a node whose
        id is in ``known``, in topological order."""
        seen: dict[int, Expr] = {}
        stack = [o for o in outputs if isinstance(o, Expr)]
        while stack:
            e = stack.pop()
            if id(e) in seen or id(e) in known:
                continue
            seen[id(e)] = e
            stack.extend(a for a in e.args if isinstance(a, Expr))
        pos = self._position()
        return [seen[k] for k in sorted(seen, key=pos.__getitem__)]

    def evaluate(self, outputs, ops, values: dict[str, Any], env: dict | None = None, plan=None):
        """Evaluate the graph on another backend (e.g. ``NumpyOps``) with leaf values by name.
        ``env`` (node id -> value) carries values between calls with the same ops and values: a
        node evaluated once is not evaluated again. ``plan``: a hashable name for the shape of
        this call (which outputs, which values ``env`` lacks); from the second call of a plan on,
        the nodes it evaluates run as compiled straight-line code (``_compile``), the graph is not
        walked again."""
        env = {} if env is None else env

        def val(a):
            return env[id(a)] if isinstance(a, Expr) else a

        missing = [o for o in outputs if isinstance(o, Expr) and id(o) not in env]
        entry = self._plan(plan) if plan is not None and missing else None
        if entry is not None and entry.get("code") is not None:
            try:
                entry["code"](ops, values, env)
            except KeyError:  # env lacks a value the plan took as known: walk the graph for it
                pass
            missing = [o for o in missing if id(o) not in env]
        if missing:
            nodes = self.live_nodes(missing, env)
            if entry is not None and entry.get("code") is None:
                entry["runs"] = entry.get("runs", 0) + 1
                if entry["runs"] >= 2:
                    entry["code"] = _compile(nodes, {id(e) for e in nodes})
                    _keep_compiled(entry)
                    entry["code"](ops, values, env)
                    nodes = ()
            for e in nodes:
                a = [val(x) for x in e.args]
                if e.op in ("param", "input"):
                    v = ops.param(self.ids[a[0]], values[a[0]]) if e.op == "param" else ops.input(a[0], values[a[0]])
                elif e.op in _BINARY:
                    v = _BINARY[e.op](a[0], a[1])
                elif e.op == "select":
                    v = ops.select(*a)
                elif e.op == "lut":
                    v = ops.lut(a[0], *a[1:])
                else:
                    v = getattr(ops, e.op)(*a)
                env[id(e)] = v
        return [val(o) for o in outputs]

    PLANS_KEPT = 8  # compiled plans per graph (and ``COMPILED_KEPT`` over every graph)

    def _plan(self, plan) -> dict:
        plans = self.memo("plans", dict)
        if plan not in plans:
            compiled = [k for k, v in plans.items() if v.get("code") is not None]
            if len(compiled) >= self.PLANS_KEPT:
                del plans[compiled[0]]
            plans[plan] = {}
        return plans[plan]


COMPILED_KEPT = 16  # compiled plans kept over every graph (one of a whole graph of eight coats with media: 4 MB)
_COMPILED: list = []  # the plans' entries that hold code, oldest first


def _keep_compiled(entry: dict) -> None:
    """Note that ``entry`` now holds compiled code; past ``COMPILED_KEPT`` the oldest plan's code
    is dropped (it compiles again if it runs twice more)."""
    _COMPILED.append(entry)
    while len(_COMPILED) > COMPILED_KEPT:
        old = _COMPILED.pop(0)
        old["code"], old["runs"] = None, 0


_SYMBOL = {"add": "+", "sub": "-", "mul": "*", "div": "/", "lt": "<", "le": "<=", "gt": ">", "ge": ">="}


def _compile(nodes: list[Expr], own: set[int]):
    """Straight-line Python for evaluating ``nodes`` (in order) on an ops backend: a function
    ``(ops, values, env)`` that stores each node's value in ``env`` and reads the values of
    arguments outside ``nodes`` from it (KeyError if absent), as ``Tracer.evaluate`` would."""
    names = {id(e): f"v{k}" for k, e in enumerate(nodes)}
    fns = sorted({e.op for e in nodes if e.op not in _SYMBOL and e.op not in ("param", "input")})
    lines = ["def _evaluate(ops, values, env):"] + [f"    _{f} = ops.{f}" for f in fns]

    def arg(a):
        if isinstance(a, Expr):
            return names[id(a)] if id(a) in own else f"env[{id(a)}]"
        return repr(a) if not isinstance(a, float) or math.isfinite(a) else f"float({repr(a)!r})"

    for e in nodes:
        if e.op in ("param", "input"):
            rhs = f"ops.{e.op}({e.args[0]!r}, values[{e.args[0]!r}])"
        elif e.op in _SYMBOL:
            rhs = f"{arg(e.args[0])} {_SYMBOL[e.op]} {arg(e.args[1])}"
        else:
            rhs = f"_{e.op}({', '.join(arg(a) for a in e.args)})"
        lines.append(f"    {names[id(e)]} = env[{id(e)}] = {rhs}")
    namespace: dict = {}
    exec(compile("\n".join(lines + ["    return env"]), "<traced graph>", "exec"), namespace)
    return namespace["_evaluate"]


_FOLD = dict(_BINARY)  # the value of an operation on numbers; the functions' is their ``TracedOp.fold``
_FOLD["select"] = lambda c, a, b: a if c else b


def _simplify(op, args):
    """Algebraic identities with a literal operand (x + 0, x * 1, x * 0 with x finite by
    construction, x / 1), select on equal branches, x - x = 0 (x finite by construction) and
    min/max of a value with itself. With hash-consing these let structure the stack does not have
    vanish: an isotropic layer's x and y statistics are one node, so their difference, the
    covariance and the lobe rotation fold to 0. (``Tracer.node`` hands numbers in as floats.)"""
    if op == "mul":
        a, b = args
        if a.__class__ is float:
            if a == 1.0:
                return b
            if a == 0.0:
                return 0.0
        if b.__class__ is float:
            if b == 1.0:
                return a
            if b == 0.0:
                return 0.0
        return None
    if op == "add":
        a, b = args
        if b.__class__ is float and b == 0.0:
            return a
        if a.__class__ is float and a == 0.0:
            return b
        return None
    if op == "sub":
        a, b = args
        if b.__class__ is float and b == 0.0:
            return a
        if a is b and a.__class__ is not float:
            return 0.0
        return None
    if op == "div":
        return args[0] if args[1].__class__ is float and args[1] == 1.0 else None
    if op == "select":
        return args[1] if args[1] is args[2] else None
    if op in ("min", "max"):
        return args[0] if args[0] is args[1] else None
    return None
