"""OSL backend: print the traced model as a straight-line Cycles OSL shader (docs/design.md "One model,
three backends").

The model is traced once with ``Tracer`` (layer loops unrolled, structure resolved, constants
folded, sub-expressions shared); every graph node becomes one ``float``/``int`` temporary, every
per-layer parameter a shader input (so the Script node shows it as a socket), and every lobe the
closure its kind names in the lobe-kind table (``lamella.core.lobe_kinds``), weighted by its energy
times the kind's normaliser (for GGX, 1 / GD: Randrianandrasana et al. 2021 Eq. 37; Cycles' single-scattering GGX
closure reflects GD(wi, alpha), so weight e / GD makes the lobe reflect e). Table look-ups call
the helpers of ``lamella/data/osl/lamella_luts.h``, inlined here so the shader is standalone apart from the EXR
tables in ``lut_dir``.

The view direction is the one line that depends on the renderer (``view``, one of VIEW_TARGETS):
Cycles' ``I`` points from the surface toward the viewer, whereas the OSL specification (Gritz et
al., OSL Language Specification) defines ``I`` as the incident ray direction, pointing toward the
surface; "osl-spec" negates it. ``lamella.core.backends.osl.bundle`` writes the shader together
with its tables and a README for use outside Blender.
"""
from __future__ import annotations

import hashlib
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ... import luts
from ..ir.closures import INSIDE_INPUT, trace_closures
from ...lobe_kinds.kind import FRAME_KEYS
from ...param_id import normal_socket, split_normals
from ..ir.sockets import by_param, sockets
from ..ir.staging import same_at_every_azimuth, stage
from ..ir.trace import Expr, Tracer
from ..ir.traced_ops import OPS

OSL_DIR = Path(__file__).resolve().parents[3] / "data" / "osl"  # inside the package: every install emits OSL
LUT_HEADER = "lamella_luts.h"  # the tables read from EXR files in ``lut_dir``
ARRAY_HEADER = "lamella_arrays.h"  # the tables read from constant arrays in the source
TABLE_SOURCES = ("files", "inline")  # where a shader's model tables come from (``osl_shader``)
ENERGY_EPS = 1e-6  # lobes below this energy at a shading point add no closure

# How each target renderer defines the global ``I``, and the line that turns it into V, the unit
# vector from the shading point toward the viewer (what the traced model calls wi).
VIEW_TARGETS = ("cycles", "osl-spec")
VIEW_LINES = {
    "cycles": "    vector V = normalize(I);  // Cycles' I points toward the viewer",
    "osl-spec": "    vector V = -normalize(I);  // OSL specification: I points toward the surface",
}

_BIN = {"add": "+", "sub": "-", "mul": "*", "div": "/", "lt": "<", "le": "<=", "gt": ">", "ge": ">="}
_CMP = {"lt", "le", "gt", "ge"}


def _literal(x: float) -> str:
    if not math.isfinite(x):
        raise ValueError(f"non-finite literal {x!r} in the traced model")
    r = repr(float(x))
    return r if ("." in r or "e" in r) else r + ".0"


IDENTIFIER_MAX = 64  # characters of a shader name derived from a stack's name


def _read_columns(t, outputs) -> list[int]:
    """The columns of the staged table the shader's graph reads (the node group's EEVEE stand-ins
    have columns of their own, ``staging.Staged.stand_ins``)."""
    return sorted({int(e.args[0]) for e in t.live_nodes(outputs) if e.op == "mtab"})


def _shader_table(t, outputs, table: np.ndarray) -> np.ndarray:
    """The part of the staged ``table`` the shader reads: its columns (``_read_columns``), over
    one azimuth node where none of them varies with the azimuth (a table made over azimuths for
    the stand-ins alone)."""
    cols = _read_columns(t, outputs)
    part = table[:, :, cols] if cols else table[:, :, :1]
    if same_at_every_azimuth(part):
        part = part[:, :1]
    return np.ascontiguousarray(part)


def _identifier(name: str) -> str:
    """An OSL identifier from free text (a stack's name, any language): ASCII letters, digits and
    underscores, starting with a letter, at most ``IDENTIFIER_MAX`` characters. Text that had to
    lose characters (non-ASCII, or cut) keeps a short hash of the original, so two names stay two
    identifiers."""
    out = "".join(ch if ch.isascii() and ch.isalnum() else "_" for ch in name)
    out = out if out[:1].isalpha() else "s_" + out
    if not name.isascii() or len(out) > IDENTIFIER_MAX:
        digest = hashlib.sha1(name.encode("utf-8", "surrogatepass")).hexdigest()[:8]
        out = out[: IDENTIFIER_MAX - 9].rstrip("_") + "_" + digest
    return out


class _Printer:
    def __init__(self, tracer: Tracer):
        self.t = tracer
        self.names: dict[int, str] = {}
        self.lines: list[str] = []
        self._packed: dict[tuple, str] = {}
        self.table_shape = (0, 0, 0)
        self.table_columns: dict[int, int] = {}  # a column of the staged table -> its column in MT
        self.files: set[str] = set()  # the EXR tables (in lut_dir) the printed code reads
        self.inline = False  # tables as constant arrays in the source instead of files
        self.arrays: set[str] = set()  # the tables (``luts.SPECS`` names) read from those arrays

    def ref(self, a) -> str:
        if isinstance(a, Expr):
            return self.names[id(a)]
        return _literal(a)

    def _reachable(self, outputs) -> list:
        """The live nodes of ``outputs``; with a table of one azimuth node, without the azimuth
        coordinate the table reads are given (they read along the elevation alone)."""
        nodes = self.t.live_nodes(outputs)
        if self.table_shape[1] != 1:
            return nodes
        seen: set[int] = set()
        stack = [o for o in outputs if isinstance(o, Expr)]
        while stack:
            e = stack.pop()
            if id(e) in seen:
                continue
            seen.add(id(e))
            stack.extend(a for a in (e.args[:2] if e.op == "mtab" else e.args) if isinstance(a, Expr))
        return [e for e in nodes if id(e) in seen]

    def emit(self, outputs, sections: dict[str, str] | None = None) -> None:
        """One statement per live node, each temporary named after the part of the model that
        made it (``coat0_12``, ``base_40``), with a comment line where that part begins."""
        scope = None
        for n, e in enumerate(self._reachable(outputs)):
            if e.op == "param":
                self.names[id(e)] = _identifier(e.args[0])
                continue
            if e.op == "input":
                self.names[id(e)] = e.args[0]
                continue
            if e.scope != scope:
                scope = e.scope
                self.lines.append(f"    // ---- {(sections or {}).get(scope, scope)}")
            name = f"{_identifier(scope)}_{n}"
            self.names[id(e)] = name
            a = e.args
            if e.op in _BIN:
                rhs = f"{self.ref(a[0])} {_BIN[e.op]} {self.ref(a[1])}"
            elif e.op == "select":
                rhs = f"{self.ref(a[0])} ? {self.ref(a[1])} : {self.ref(a[2])}"
            elif e.op == "lut" and self.inline:
                rhs = self._array_read(a[0], [self.ref(c) for c in a[1:]], a[1:])
            elif e.op == "lut":
                rhs = self._packed_read(a)
                if rhs is None:
                    rhs = self._lut(a[0], [self.ref(c) for c in a[1:]], a[1:])
                    self.files.add(luts.SPECS[a[0]].file)
            elif e.op == "mtab":
                rhs = self._mtab(int(a[0]), self.ref(a[1]), self.ref(a[2]) if self.table_shape[1] > 1 else "")
            elif e.op == "atab":
                raise NotImplementedError("tables over linked parameters (staging's live_axes) are the node "
                                          "group's; an OSL shader traces what its linked inputs reach")
            else:
                rhs = OPS[e.op].osl_expression([self.ref(x) for x in a])
            self.lines.append(f"    {'int' if e.op in _CMP else 'float'} {name} = {rhs};")

    def _mtab(self, col: int, c: str, p: str) -> str:
        """Column ``col`` of the material table ``MT`` (``staging.lookup``: linear along c,
        linear and periodic along p): the node indices and weights are computed once per
        coordinate pair and shared by every column read there."""
        n_mu, n_phi, cols = self.table_shape
        key = ("mtab", c, p)
        var = self._packed.get(key)
        if var is None:
            var = self._packed[key] = f"mt{len(self._packed)}"
            self.lines += [
                f"    float {var}_x = clamp({c}, 0.0, 1.0) * {float(n_mu - 1)!r};",
                f"    int {var}_i = min((int)floor({var}_x), {n_mu - 2});",
                f"    float {var}_f = {var}_x - {var}_i;",
            ]
            if n_phi == 1:
                self.lines += [f"    int {var}_a = {var}_i * {cols};", f"    int {var}_b = {var}_a + {cols};"]
            else:
                self.lines += [
                    f"    float {var}_y = {p} * {float(n_phi)!r};",
                    f"    int {var}_j = min((int)floor({var}_y), {n_phi - 1});",
                    f"    float {var}_g = {var}_y - {var}_j;",
                    f"    int {var}_k = {var}_j + 1 == {n_phi} ? 0 : {var}_j + 1;",
                    f"    int {var}_a = ({var}_i * {n_phi} + {var}_j) * {cols};",
                    f"    int {var}_b = {var}_a + {n_phi * cols};",
                    f"    int {var}_c = ({var}_i * {n_phi} + {var}_k) * {cols};",
                    f"    int {var}_d = {var}_c + {n_phi * cols};",
                ]
        f = f"{var}_f"
        col = self.table_columns.get(col, col)
        lerp = lambda a, b: f"(MT[{a} + {col}] + (MT[{b} + {col}] - MT[{a} + {col}]) * {f})"  # noqa: E731
        if n_phi == 1:
            return lerp(f"{var}_a", f"{var}_b")
        return f"mix({lerp(f'{var}_a', f'{var}_b')}, {lerp(f'{var}_c', f'{var}_d')}, {var}_g)"

    def _packed_read(self, a) -> str | None:
        """A read of one slice of a table that has an RGBA-packed atlas (luts.PACKED), at a slice
        index that is a literal: the four slices of its texel are read once per (c0, c1) and
        shared by every node that needs one of them."""
        name, c0, c1, c2 = a[0], a[1], a[2], a[3] if len(a) > 3 else None
        if name not in luts.PACKED or not isinstance(c2, float):
            return None
        n0, n1, n2 = luts.SPECS[name].shape
        k = c2 * (n2 - 1)
        if abs(k - round(k)) > 1e-9 or not 0 <= round(k) < n2:
            return None
        group, channel = divmod(round(k), 4)
        key = (name, self.ref(c0), self.ref(c1), group)
        var = self._packed.get(key)
        if var is None:
            var = self._packed[key] = f"q{len(self._packed)}"
            self.files.add(luts.PACKED[name])
            f = f'concat(lut_dir, "/{luts.PACKED[name]}")'
            self.lines.append(f"    float {var}_a;")
            self.lines.append(f"    color {var} = lamella_tex4({f}, {key[1]}, {key[2]}, {n0}, {n1}, "
                              f"{group * n0}.0, {n2 // 4 * n0}, {var}_a);")
        return f"{var}_a" if channel == 3 else f"{var}[{channel}]"

    def _array_read(self, name: str, coords: list[str], raw=()) -> str:
        """A read of the named table from its constant array (``table_array``, ``lamella_arrays.h``);
        a 3D table at a literal last coordinate on one of its nodes reads that slice alone."""
        self.arrays.add(name)
        arr, shape = array_name(name), luts.SPECS[name].shape
        if len(shape) == 2:
            return f"lamella_arr2({arr}, 0, {coords[0]}, {coords[1]}, {shape[0]}, {shape[1]})"
        n0, n1, n2 = shape
        if len(raw) == 3 and isinstance(raw[2], float) and 0.0 <= raw[2] <= 1.0:
            k = raw[2] * (n2 - 1)
            if abs(k - round(k)) < 1e-9:
                return f"lamella_arr2({arr}, {round(k) * n0 * n1}, {coords[0]}, {coords[1]}, {n0}, {n1})"
        return f"lamella_arr3({arr}, {coords[0]}, {coords[1]}, {coords[2]}, {n0}, {n1}, {n2})"

    @staticmethod
    def _lut(name: str, coords: list[str], raw=()) -> str:
        spec = luts.SPECS[name]
        f = f'concat(lut_dir, "/{spec.file}")'
        if len(spec.shape) == 2:
            return f"lamella_lut2({f}, {coords[0]}, {coords[1]}, {spec.shape[0]}, {spec.shape[1]})"
        n0, n1, n2 = spec.shape
        if len(raw) == 3 and isinstance(raw[2], float) and 0.0 <= raw[2] <= 1.0:
            k = raw[2] * (n2 - 1)
            if abs(k - round(k)) < 1e-9:
                # the last coordinate is a literal on a table node (the Fresnel quadrature's
                # slices): one texture read of that slice instead of interpolating two
                return f"lamella_tex({f}, {coords[0]}, {coords[1]}, {n0}, {n1}, {round(k) * n0}.0, {n0 * n2})"
        return (f"lamella_lut3({f}, {coords[0]}, {coords[1]}, {coords[2]}, "
                f"{spec.shape[0]}, {spec.shape[1]}, {spec.shape[2]})")


# oslc's parser holds a statement list on its stack, which overflows ("Syntax error: memory
# exhausted") near 10000 statements in one block: longer bodies declare their temporaries first and
# run their statements in blocks of at most BLOCK_STATEMENTS (a deep stack of media and coats).
MAX_FLAT_STATEMENTS = 6000
BLOCK_STATEMENTS = 4000
_DECLARATION = re.compile(r"^    (float|int|color) (\w+)(?: = (.*))?;$")


def array_name(name: str) -> str:
    """The OSL name of the constant array that holds the table ``name`` in a shader."""
    return f"LUT_{_identifier(name)}"


def table_array(name: str) -> np.ndarray:
    """The table ``name`` in the order ``lamella_arrays.h`` reads it: a 2D table row by row, a 3D
    one as its slices along the last axis, one after the other (float32, flat)."""
    t = luts.table(name)
    return np.ascontiguousarray(t if t.ndim == 2 else np.moveaxis(t, 2, 0)).ravel()


def _blocked(lines: list[str]) -> list[str]:
    """``lines`` as they are when short enough for oslc's parser; otherwise the temporaries'
    declarations first (a few hundred names per statement), then the statements as assignments
    inside ``{ }`` blocks of at most BLOCK_STATEMENTS."""
    statements = sum(1 for ln in lines if not ln.lstrip().startswith("//"))
    if statements <= MAX_FLAT_STATEMENTS:
        return lines
    names: dict[str, list[str]] = {}
    body: list[str] = []
    for ln in lines:
        m = _DECLARATION.match(ln)
        if m is None:
            body.append(ln)
            continue
        names.setdefault(m.group(1), []).append(m.group(2))
        if m.group(3) is not None:
            body.append(f"    {m.group(2)} = {m.group(3)};")
    out = []
    for typ, ns in names.items():
        out += [f"    {typ} {', '.join(ns[k:k + 200])};" for k in range(0, len(ns), 200)]
    block, count = ["    {"], 0
    for ln in body:
        block.append(ln)
        count += not ln.lstrip().startswith("//")
        if count >= BLOCK_STATEMENTS:
            out += block + ["    }"]
            block, count = ["    {"], 0
    return out + block + ["    }"]


@dataclass
class OslShader:
    """A generated shader and what the Blender side needs to know of it, straight from the IR:
    ``source``; ``params`` the value of every shader parameter by name (the Script node's
    sockets); ``live`` the parameters the shader reads (the rest are baked into its table);
    ``staged`` the staged shader (None for the fully traced one); ``structure_key`` what
    identifies its structure apart from values; ``model`` the model that ran."""

    source: str
    params: dict
    live: tuple
    model: str
    staged: object = None
    uses_tables: bool = True
    name: str = ""
    declared: tuple = ()  # ShaderParam of every declared parameter, in order
    tables: tuple = ()  # the EXR files (relative to lut_dir) the shader reads, sorted
    closures: tuple = ()  # ShaderClosure of every closure, in order
    ids: dict = field(default_factory=dict)  # every parameter's ``ParamId`` (what it is), by name

    @property
    def socket_values(self) -> dict:
        """Socket name -> its value in panel units (a float, or an RGB tuple for a colour)."""
        return {sk.name: sk.value for sk in self.sockets}

    @property
    def live_sockets(self) -> tuple:
        """The sockets the shader reads (sorted): the linked ones of a staged shader, every one of
        a fully traced shader."""
        return self.staged.live_sockets if self.staged is not None else tuple(sk.name for sk in self.sockets)

    @property
    def sockets(self) -> list:
        """Every parameter's socket (``sockets.Socket``: panel units, what it is), sorted by name."""
        return sockets(self.ids, self.params)


ENGINE_SWITCH = "lamella_osl"  # the output a Blender shader sets to 1 (``osl_shader``'s ``engine_switch``)


@dataclass(frozen=True)
class ShaderParam:
    """One parameter of a generated shader's declaration: its OSL type, its default as printed;
    ``socket``: the layer input it declares (``sockets.Socket``), None for the others."""

    name: str
    type: str  # OSL type, e.g. "float", "normal", "closure color"
    default: str
    output: bool = False
    socket: object = None


@dataclass(frozen=True)
class ShaderClosure:
    """One closure of a generated shader: its label (which lobes of the model it carries), its lobe
    kind and the OSL closure function it calls."""

    label: str
    kind: str
    function: str


def emit_osl(stack, model: str = "auto", name: str | None = None, lut_dir: str | Path | None = None,
             view: str = "cycles", live=(), budget="auto", staged: bool = True, declare: str = "all",
             tables: str = "files") -> str:
    """The OSL source of a shader for ``stack`` (a Stack, dict or JSON) under ``model``
    (``osl_shader``)."""
    return osl_shader(stack, model, name, lut_dir, view, live, budget, staged, declare, tables=tables).source


def osl_shader(stack, model: str = "auto", name: str | None = None, lut_dir: str | Path | None = None,
               view: str = "cycles", live=(), budget="auto", staged: bool = True, declare: str = "all",
               partition=None, engine_switch: bool = False, tables: str = "files") -> OslShader:
    """The shader for ``stack`` (a Stack, dict or JSON) under ``model``.

    ``staged`` (default): the model staged for a material whose parameters ``live`` are linked
    (``lamella.core.backends.ir.staging``): the view-only part is a constant table inside the shader,
    lobes merged to ``budget``; every parameter of the model is still a shader parameter (a socket
    to link a texture into), read only where live. ``staged=False``: the whole model traced, every
    parameter read (the shader before staging, kept for comparison).
    ``name``: the shader's name (default ``lamella_<stack name>``); ``lut_dir``: the default of
    the shader's ``lut_dir`` parameter, the folder of the EXR tables the traced model reads
    (default: the package's data folder, as an absolute path; a relative path is kept as given, to
    be resolved by the renderer); a staged shader with nothing live reads no file and has no
    ``lut_dir``. ``view``: the renderer's convention for ``I`` (VIEW_TARGETS), which sets the one
    line computing the view direction. ``declare``: "all" declares every parameter of the model
    (Blender's Script node, whose sockets are where a texture is linked), "live" only those the
    shader reads (an exported shader: no input that changes nothing). ``partition``: the lobes'
    grouping into closures to keep (``staging.stage``). ``engine_switch``: the shader also writes
    1 to the output ``ENGINE_SWITCH`` (declared 0): a Mix Shader whose factor it drives picks the
    shader where Cycles runs OSL, and its own factor (0) where a renderer drops the Script node
    (Cycles without OSL, EEVEE), with no add-on code at render time. ``tables``: where the model's
    look-up tables a live part reads come from: "files" (the EXR files in ``lut_dir``: an exported
    shader, a few kB of source) or "inline" (constant arrays in the source, only the tables read:
    a shader that renders with nothing beside it, as Blender's Script node in a .blend; up to about
    60,000 values when a live input reaches every table)."""
    if tables not in TABLE_SOURCES:
        raise ValueError(f"tables must be one of {', '.join(TABLE_SOURCES)}, got {tables!r}")
    if declare not in ("all", "live"):
        raise ValueError(f"declare must be 'all' or 'live', got {declare!r}")
    if view not in VIEW_LINES:
        raise ValueError(f"unknown view target {view!r}: expected one of {', '.join(VIEW_TARGETS)}")
    traced = trace_closures(stack, model, live)
    all_params = {k: float(traced.tracer.defaults[k]) for k in traced.tracer.params}
    if staged:
        st = stage(traced.stack, model, live, budget, traced=traced, partition=partition)
        t, closures, frame, table = st.tracer, st.closures, st.frame, st.table
    else:
        st = None
        t, closures, frame, table = traced.tracer, traced.covered, "shading", None
    stack = traced.stack
    outputs = [x for c in closures for x in (*c.weight, *c.args.values())]
    p = _Printer(t)
    p.inline = tables == "inline"
    if table is not None:
        table = _shader_table(t, outputs, table)
        p.table_shape = table.shape
        p.table_columns = {k: j for j, k in enumerate(_read_columns(t, outputs))}
    sections = {"setup": "incident direction", "lobes": "lobes (energies, roughness, axes)",
                "closures": "closure weights: energy x the lobe kind's normaliser (1 / GD for GGX)",
                "base": f"base: {stack.base.type} and the adding of the stack above it",
                "table": "the material table at this view (baked lobes)",
                "live": "the model's part that reads linked parameters"}
    for i, c in enumerate(stack.coats):
        sections[f"coat{i}"] = (f"coat {i}: interface from above, refraction into it"
                                + (", absorption" if c.has_absorption else ""))
    p.emit(outputs, sections)
    uses_tables = bool(p.files)  # a shader that reads EXR files (in ``lut_dir``)

    shader = _identifier(name or f"lamella_{stack.name or 'stack'}")
    live_names = tuple(st.live) if st is not None else tuple(sorted(all_params))
    lut_path = str(Path(lut_dir) if lut_dir else luts.DATA_DIR)
    declared = [_socket_param(sk) for sk in sockets(traced.tracer.ids, all_params)
                if declare == "all" or any(k in live_names for k in sk.params)]
    declared += [ShaderParam("Normal", "normal", "N"), ShaderParam("Tangent", "vector", "vector(0.0, 0.0, 0.0)")]
    # the layers given a normal of their own (a bump on the coat, flakes on the base): an input each,
    # a frame each, which the closures of that layer are about (``Closure.normal``)
    normals = st.normals if st is not None else split_normals(live)[1]
    declared += [ShaderParam(normal_socket(n), "normal", "N") for n in normals]
    if uses_tables:
        declared.append(ShaderParam("lut_dir", "string", _string_literal(lut_path)))
    if engine_switch:
        declared.append(ShaderParam(ENGINE_SWITCH, "float", "0.0", output=True))
    declared.append(ShaderParam("BSDF", "closure color", "0", output=True))
    if frame == "view":
        frame_lines = [
            "    // local shading frame: z = N, x = the view's azimuth (an isotropic stack's table is",
            "    // baked in that frame); at normal incidence the shading tangent",
            VIEW_LINES[view],
            "    vector Tn = V - dot(V, Normal) * Normal;",
            "    if (length(Tn) < 1e-6) Tn = Tangent - dot(Tangent, Normal) * Normal;",
        ]
    else:
        frame_lines = [
            "    // local shading frame: z = N, x = the shading tangent (default: radial about world z)",
            "    vector Tn = Tangent - dot(Tangent, Normal) * Normal;",
        ]
    body = ([f"    {ENGINE_SWITCH} = 1.0;  // this shader runs: Cycles with OSL"] if engine_switch else []) + frame_lines + [
        "    if (length(Tn) < 1e-8) Tn = vector(-P[1], P[0], 0.0) - dot(vector(-P[1], P[0], 0.0), Normal) * Normal;",
        "    if (length(Tn) < 1e-8) Tn = cross(Normal, vector(0.0, 1.0, 0.0));",
        "    if (length(Tn) < 1e-8) Tn = cross(Normal, vector(1.0, 0.0, 0.0));",
        "    Tn = normalize(Tn);",
        "    vector Bn = cross(Normal, Tn);",
        *([] if frame == "view" else [VIEW_LINES[view]]),
        "    float wi_x = dot(V, Tn);",
        "    float wi_y = dot(V, Bn);",
        "    float wi_z = dot(V, Normal);",
    ]
    if INSIDE_INPUT in t.inputs:  # a solid dielectric base: its far side is seen from inside it
        body.append(f"    float {INSIDE_INPUT} = backfacing() ? 1.0 : 0.0;")
    conv = by_param(traced.tracer.ids)
    read = {e.args[0] for e in t.live_nodes(outputs) if e.op == "param" and conv[e.args[0]][0].convert != "identity"}
    if read:
        body.append("    // the live parameters, from their sockets (roughness r: alpha = r * r)")
    for k in sorted(read):
        sk, ch = conv[k]
        rhs = {"square": f"{sk.name} * {sk.name}", "identity": sk.name, "channels": f"{sk.name}[{ch}]"}[sk.convert]
        body.append(f"    float {_identifier(k)} = {rhs};")
    if table is not None and any(e.op == "mtab" for e in t.nodes):
        values = ", ".join(_float32_literals(table))
        body += [f"    // the material table: {table.shape[0]} views along sqrt(1 - sqrt(cos theta))"
                 + (f" x {table.shape[1]} azimuths" if table.shape[1] > 1 else "") + f", {table.shape[2]} columns",
                 f"    float MT[{table.size}] = {{{values}}};"]
    for name_ in sorted(p.arrays):
        spec = luts.SPECS[name_]
        values = table_array(name_)
        body += [f"    // the model's table {name_} ({' x '.join(map(str, spec.shape))}, ``lamella.core.luts``)",
                 f"    float {array_name(name_)}[{values.size}] = {{{', '.join(_float32_literals(values))}}};"]
    for n in normals:  # each layer's own normal (the shading normal where its input is zero)
        sock = normal_socket(n)
        body.append(f"    vector N_{n} = length({sock}) > 1e-8 ? normalize({sock}) : Normal;")
    frames = {}  # a closure's frame (``layer_normals``): the shading normal tilted by the layers' tilts
    for c in closures:
        key = c.framed(normals)
        if key is None or key in frames:
            continue
        f = frames[key] = f"F{len(frames)}"
        tilt = " + ".join(f"{_literal(w)} * (N_{n} - dot(N_{n}, Normal) * Normal)" for n, w in key)
        body += [f"    // frame {f}: " + ", ".join(f"{n} x {w:g}" for n, w in key),
                 f"    vector {f}_N = normalize(Normal + {tilt});",
                 f"    vector {f}_T = Tn - dot(Tn, {f}_N) * {f}_N;",
                 f"    if (length({f}_T) < 1e-6) {f}_T = Bn - dot(Bn, {f}_N) * {f}_N;",
                 f"    {f}_T = normalize({f}_T);",
                 f"    vector {f}_B = cross({f}_N, {f}_T);"]
    body += [*_blocked(p.lines), "    BSDF = 0;"]
    called = []
    for c in closures:
        r, g, b = (p.ref(x) for x in c.weight)
        key = c.framed(normals)
        where = {} if key is None else dict(zip(FRAME_KEYS, (f"{frames[key]}_{a}" for a in "NTB")))
        closure = c.kind.osl({**{name: p.ref(x) for name, x in c.args.items()}, **where})
        called.append(ShaderClosure(c.label, c.kind.name, closure.split("(", 1)[0].strip()))
        body += [
            f"    // {c.label}",
            f"    if (max({r}, max({g}, {b})) > {_literal(ENERGY_EPS)})",
            f"        BSDF += color({r}, {g}, {b}) * {closure};",
        ]
    header = "\n".join((OSL_DIR / h).read_text() for h, used in ((LUT_HEADER, uses_tables), (ARRAY_HEADER, p.arrays))
                       if used)
    desc = stack.to_json(indent=None)
    how = (f"staged: {len(closures)} closures for {st.lobes_all} lobes, live: {', '.join(st.live) or 'nothing'}"
           if st is not None else "fully traced")
    source = "\n".join([
        f"// Generated by Lamella (model {traced.model}; {how}) -- do not edit; regenerate with `lamella export-osl`.",
        f"// stack: {desc}",
        "#include \"stdosl.h\"",
        "",
        *([header.rstrip(), ""] if header else []),
        f"shader {shader}(",
        *[f"    {'output ' if d.output else ''}{d.type} {d.name} = {d.default}{')' if k == len(declared) - 1 else ','}"
          for k, d in enumerate(declared)],
        "{",
        *body,
        "}",
        "",
    ])
    return OslShader(source, all_params, live_names, traced.model, st, uses_tables, shader, tuple(declared),
                     tuple(sorted(p.files)), tuple(called), dict(traced.tracer.ids))


def _string_literal(text: str) -> str:
    """``text`` as an OSL string literal (a folder may hold quotes and backslashes)."""
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _socket_param(sk) -> ShaderParam:
    """The declaration of a socket (``sockets.Socket``) as a shader parameter."""
    if sk.kind == "color":
        return ShaderParam(_identifier(sk.name), "color", f"color({', '.join(_literal(v) for v in sk.value)})",
                           socket=sk)
    return ShaderParam(_identifier(sk.name), "float", _literal(sk.value), socket=sk)


def _float32_literals(values) -> list[str]:
    """The shortest literals that read back as the float32 ``values`` (an array of finite
    numbers), in order: numpy's own float32 repr, vectorised (a value edit prints the material
    table again; one call per value cost several milliseconds). numpy's print options decide that
    repr, and colour-science sets them to numpy 1.13's (six digits) when it is imported: the
    shader's text would depend on what the process imported before."""
    with np.printoptions(legacy=False):
        return np.asarray(values, dtype=np.float32).reshape(-1).astype(str).tolist()


def _float32_literal(x) -> str:
    """The shortest literal that reads back as the float32 ``x``."""
    r = np.format_float_positional(np.float32(x), unique=True, trim="0")
    return r if not r.endswith(".") else r + "0"
