"""The traced model lowered to Blender shader nodes (docs/design.md "One model, three backends"),
for EEVEE and for Cycles without OSL (SVM, GPU).

The model is traced once with ``Tracer`` exactly as for OSL; this module lowers the traced graph
to a plan of Blender nodes, pure data without bpy (``lamella.blender.node_group`` instantiates it):

- every arithmetic node becomes a Math node (``_MATH``), a comparison a Math node giving 0 or 1,
  ``select`` c a + (1 - c) b, ``log`` a Math LOGARITHM to base e: Math nodes only (one
  node type, evaluated by ``backends.evaluate.evaluate_plan`` with Blender's semantics);
- a table look-up becomes Image Texture reads (Linear interpolation, Extend) of the same EXR
  tables the OSL shader reads, at the texel centres of the table's nodes (``_Lowering.lut``), the
  read the OSL helpers ``lamella_tex`` / ``lamella_lut3`` make;
- every lobe becomes the Blender BSDF node its kind names in the lobe-kind table
  (``LobeKind.node``), weighted by its energy times the kind's normaliser, as in the OSL shader.

Math nodes keep Blender's semantics, which differ from the model's ops only where the model
guards anyway: division by zero gives 0, the square root and logarithm of a non-positive number
give 0. ``backends.evaluate.evaluate_plan`` evaluates a plan with those semantics in numpy
(float32 by default), so tests check the lowering without Blender. ``nodes.partition`` cuts the plan
into nested groups; ``nodes.svm`` says whether Cycles' SVM holds it.
"""
from __future__ import annotations

import math

import numpy as np

from ... import luts
from ..ir.closures import trace_closures
from ...param_id import normal_socket, split_normals
from ..ir.live_axes import MAX_AXES
from ..ir.staging import STAND_INS, same_at_every_azimuth, stage
from ..ir.trace import Expr, Tracer
from ..ir.traced_ops import OPS
from .plan import (
    MATH_IN,
    TABLE_IMAGE,
    TABLE_SIZE,
    Bsdf,
    Out,
    Plan,
    PlanNode,
    texel_range,
)
from .svm import SVM_UNSURE, live_values

ENERGY_EPS = 1e-6
_MATH = {"add": "ADD", "sub": "SUBTRACT", "mul": "MULTIPLY", "div": "DIVIDE", "lt": "LESS_THAN",
         "gt": "GREATER_THAN"}  # arithmetic; the functions build their own nodes (``traced_ops``)


def _rgb_block(values: np.ndarray) -> np.ndarray:
    """(rows, cells, columns) -> (rows, cells * G, 3): texel j * G + g of a row holds columns
    3 g .. 3 g + 2 of cell j (zero-padded to G = ceil(columns / 3) groups)."""
    rows, cells, cols = values.shape
    groups = -(-cols // 3)
    padded = np.zeros((rows, cells, groups * 3), dtype=np.float32)
    padded[..., :cols] = values
    return padded.reshape(rows, cells * groups, 3)


class _Lowering:
    """Traced graph -> plan nodes, sharing identical nodes."""

    def __init__(self, tracer: Tracer, table=None, image: str = "", axis_tables=()):
        self.t = tracer
        self.table = table  # the material table of a staged graph (``mtab`` reads)
        self.axis_tables = axis_tables  # its tables over linked parameters (``atab`` reads)
        self.image = image
        self.pixels = None
        self._coords: dict = {}
        self._layout_cache = None
        self.nodes: list[PlanNode] = []
        self.leaves: list[str] = []
        self.env: dict[int, object] = {}
        self._cache: dict = {}
        self.scope = "setup"

    # ------------------------------------------------------------ plan building
    def add(self, bl_idname, props, inputs, outputs=("Value",)):
        n = PlanNode(bl_idname, dict(props), dict(inputs), self.scope, tuple(outputs))
        k = n.key()
        hit = self._cache.get(k)
        if hit is None:
            self.nodes.append(n)
            hit = self._cache[k] = len(self.nodes) - 1
        return hit

    def math(self, op, *args):
        if all(not isinstance(a, Out) for a in args) and op in _FOLD_MATH:
            return _FOLD_MATH[op](*(float(a) for a in args))
        i = self.add("ShaderNodeMath", {"operation": op}, dict(zip(MATH_IN, args)))
        return Out(i, "Value")

    def leaf(self, name):
        if name not in self.leaves:
            self.leaves.append(name)
        return Out(-1 - self.leaves.index(name), "Value")

    def ref(self, a):
        return self.env[id(a)] if isinstance(a, Expr) else float(a)

    # ------------------------------------------------------------ lowering
    def lower(self, exprs):
        for e in self.t.live_nodes(exprs):
            self.scope = e.scope
            a = [x if isinstance(x, str) else self.ref(x) for x in e.args]
            if e.op in ("param", "input"):
                v = self.leaf(a[0])
            elif e.op in _MATH:
                v = self.math(_MATH[e.op], *a)
            elif e.op == "le":  # a <= b is not (a > b)
                v = self.math("SUBTRACT", 1.0, self.math("GREATER_THAN", a[0], a[1]))
            elif e.op == "ge":
                v = self.math("SUBTRACT", 1.0, self.math("LESS_THAN", a[0], a[1]))
            elif e.op in OPS:
                v = OPS[e.op].nodes(self.math, *a)
            elif e.op == "select":
                v = self.select(*a)
            elif e.op == "lut":
                v = self.lut(a[0], *a[1:])
            elif e.op == "mtab":
                v = self.mtab(int(a[0]), a[1], a[2])
            elif e.op == "atab":
                v = self.atab(int(a[0]), int(a[1]), a[2], a[3:])
            else:
                raise NotImplementedError(f"no node for traced op {e.op!r}")
            self.env[id(e)] = v

    def select(self, cond, a, b):
        """a where cond is 1, b where it is 0: a c + b (1 - c), exact for c in {0, 1}."""
        if not isinstance(cond, Out):
            return a if cond else b
        return self.math("MULTIPLY_ADD", b, self.math("SUBTRACT", 1.0, cond), self.math("MULTIPLY", a, cond))

    def _texel(self, c, n, offset=0.0, rows=None):
        """``texel_coord`` of a traced or literal coordinate."""
        lo, hi = texel_range(n, offset, rows)
        if not isinstance(c, Out):
            return lo + min(max(c, 0.0), 1.0) * (hi - lo)
        # clamp(c, 0, 1) as c + 0 with the Math node's clamp, then c (hi - lo) + lo
        clamped = Out(self.add("ShaderNodeMath", {"operation": "ADD", "use_clamp": True},
                               {"Value": c, "Value_001": 0.0}), "Value")
        return self.math("MULTIPLY_ADD", clamped, hi - lo, lo)

    def _read(self, file, s, t, channels=("X",)):
        """Texture read at (s, t) of a look-up table's atlas, t = 0 at the atlas's first row. The
        file holds the atlas above its mirror image (``luts.to_file``) and Blender's v counts from
        the last row, which holds the atlas's first: v = t / 2."""
        v = self.math("MULTIPLY", t, 0.5)
        xyz = self.add("ShaderNodeCombineXYZ", {}, {"X": s, "Y": v, "Z": 0.0}, ("Vector",))
        tex = self.add("ShaderNodeTexImage", {"image": file, "interpolation": "Linear", "extension": "EXTEND"},
                       {"Vector": Out(xyz, "Vector")}, ("Color", "Alpha"))
        sep = self.add("ShaderNodeSeparateXYZ", {}, {"Vector": Out(tex, "Color")}, ("X", "Y", "Z"))
        return [Out(tex, "Alpha") if ch == "A" else Out(sep, ch) for ch in channels]

    # the material table: three columns a texel, read at texel centres with Closest interpolation
    # and blended here (Linear reads use mipmaps in EEVEE, chosen by the screen-space derivative
    # of the coordinate, which for a coordinate computed from the view is meaningless)
    def material_pixels(self) -> np.ndarray:
        """The material table and its tables over linked parameters as one RGBA image (rows
        bottom first, ``_layout``): a table's cell j (an azimuth node, or a node of its parameter
        axes) holds columns 3 g .. 3 g + 2 in texel ((j mod J) G + g, row0 + (j div J) n_mu + i)
        at view node i, with G = ceil(columns / 3) groups and J cells to a band of rows."""
        width, height, blocks = self._layout()
        img = np.zeros((height, width, 3), dtype=np.float32)
        tables = [self.table.reshape(self.table.shape[0], -1, self.table.shape[2])]
        tables += [tab.data.reshape(tab.data.shape[0], -1, tab.data.shape[-1]) for tab in self.axis_tables]
        for values, (row0, per_band, groups) in zip(tables, blocks):
            n_mu, cells, _ = values.shape
            rgb = _rgb_block(values).reshape(n_mu, cells, groups, 3)
            for j in range(cells):
                band, k = divmod(j, per_band)
                img[row0 + band * n_mu: row0 + (band + 1) * n_mu, k * groups: (k + 1) * groups] = rgb[:, j]
        return np.concatenate([img, np.ones(img.shape[:2] + (1,), dtype=np.float32)], -1)

    def _layout(self) -> tuple[int, int, list]:
        """The image's width and height and, for each table (the material table, then each axis
        table), (its first row, its cells to a band of ``n_mu`` rows, its texel groups). A table
        wider than the image wraps into bands (the material table never: its azimuth reads
        assume one); the width is the one that gives the image the fewest texels with neither
        side above ``TABLE_SIZE`` (the material table alone: its own width)."""
        if self._layout_cache is None:
            n_mu = self.table.shape[0]
            shapes = [(self.table.shape[1], -(-self.table.shape[2] // 3))]
            shapes += [(int(np.prod(tab.data.shape[1:-1])), -(-tab.data.shape[-1] // 3)) for tab in self.axis_tables]
            narrowest = max(max(groups for _, groups in shapes), shapes[0][0] * shapes[0][1])  # the material table: one band

            def bands(width):
                return [-(-cells // (width // groups)) for cells, groups in shapes]

            widest = min(max(cells * groups for cells, groups in shapes), TABLE_SIZE)
            fits = [w for w in range(narrowest, widest + 1) if sum(bands(w)) * n_mu <= TABLE_SIZE]
            if not fits:
                raise ValueError(f"the material's tables do not fit an image of {TABLE_SIZE} x {TABLE_SIZE} texels")
            width = min(fits, key=lambda w: (w * sum(bands(w)), w))
            blocks, row = [], 0
            for (cells, groups), n in zip(shapes, bands(width)):
                blocks.append((row, width // groups, groups))
                row += n * n_mu
            self._layout_cache = (width, row, blocks)
        return self._layout_cache

    def _mcoords(self, c, p):
        key = (c if not isinstance(c, Out) else (c.node, c.socket), p if not isinstance(p, Out) else (p.node, p.socket))
        hit = self._coords.get(key)
        if hit is not None:
            return hit
        n_mu, n_phi, cols = self.table.shape
        groups = -(-cols // 3)
        width, height, _ = self._layout()
        if isinstance(c, Out):
            c = Out(self.add("ShaderNodeMath", {"operation": "ADD", "use_clamp": True}, {"Value": c, "Value_001": 0.0}), "Value")
        x = self.math("MULTIPLY", c, float(n_mu - 1))
        i0 = self.math("MINIMUM", self.math("FLOOR", x), float(n_mu - 2))
        f = self.math("SUBTRACT", x, i0)
        v0 = self.math("DIVIDE", self.math("ADD", i0, 0.5), float(height))
        v1 = self.math("ADD", v0, 1.0 / height)
        if n_phi == 1:
            us, g = [0.5 / width], None
        else:
            y = self.math("MULTIPLY", p, float(n_phi))
            j0 = self.math("MINIMUM", self.math("FLOOR", y), float(n_phi - 1))
            g = self.math("SUBTRACT", y, j0)
            j1 = self.math("MODULO", self.math("ADD", j0, 1.0), float(n_phi))
            us = [self.math("DIVIDE", self.math("ADD", self.math("MULTIPLY", j, float(groups)), 0.5), float(width))
                  for j in (j0, j1)]
        hit = self._coords[key] = (us, (v0, v1), f, g, width, {})
        return hit

    def _flat(self, group: int) -> bool:
        """Whether the texel group (three columns) is the same at every azimuth node: read at the
        first, along the view only (a table made over azimuths for some columns, the EEVEE
        stand-ins', reads the others as a table of one azimuth would)."""
        return same_at_every_azimuth(self.table[:, :, 3 * group:3 * group + 3])

    def mtab(self, col: int, c, p):
        us, vs, f, g, width, reads = self._mcoords(c, p)
        group, channel = divmod(col, 3)
        if g is not None and self._flat(group):
            us, g = [0.5 / width], None
            reads = reads.setdefault("flat", {})
        sep = reads.get(group)
        if sep is None:
            blended = []
            for u in us:
                u = self.math("ADD", u, group / width) if group else u
                texels = []
                for v in vs:
                    xyz = self.add("ShaderNodeCombineXYZ", {}, {"X": u, "Y": v, "Z": 0.0}, ("Vector",))
                    tex = self.add("ShaderNodeTexImage", {"image": self.image, "interpolation": "Closest",
                                                          "extension": "EXTEND"},
                                   {"Vector": Out(xyz, "Vector")}, ("Color", "Alpha"))
                    texels.append(Out(tex, "Color"))
                blended.append(self._mix(texels[0], texels[1], f))
            if g is not None:
                blended = [self._mix(blended[0], blended[1], g)]
            sep = reads[group] = self.add("ShaderNodeSeparateXYZ", {}, {"Vector": blended[0]}, ("X", "Y", "Z"))
        return Out(sep, "XYZ"[channel])

    def atab(self, k: int, col: int, c, xs):
        """Column ``col`` of axis table ``k`` at view coordinate ``c`` and parameter coordinates
        ``xs`` (``live_axes.lookup_axes``): for each corner of the parameters' cell, the two view
        rows blended, then the corners blended from the last parameter axis to the first."""
        tab = self.axis_tables[k]
        _, vs, f, _, width, _ = self._mcoords(c, 0.0)
        sizes = tab.data.shape[1:-1]
        _, height, blocks = self._layout()
        row0, per_band, groups = blocks[1 + k]
        n_mu = self.table.shape[0]
        banded = int(np.prod(sizes)) > per_band
        key = ("atab", k, tuple(x if not isinstance(x, Out) else (x.node, x.socket) for x in xs),
               c if not isinstance(c, Out) else (c.node, c.socket))
        cells = self._coords.get(key)
        if cells is None:
            cells = []
            for x, n in zip(xs, sizes):
                if isinstance(x, Out):
                    x = Out(self.add("ShaderNodeMath", {"operation": "ADD", "use_clamp": True},
                                     {"Value": x, "Value_001": 0.0}), "Value")
                y = self.math("MULTIPLY", x, float(n - 1))
                j0 = self.math("MINIMUM", self.math("FLOOR", y), float(n - 2))
                cells.append((j0, self.math("SUBTRACT", y, j0)))
            cells = self._coords[key] = (cells, {})
        cells, reads = cells
        group, channel = divmod(col, 3)
        sep = reads.get(group)
        if sep is None:
            strides = [int(np.prod(sizes[i + 1:])) for i in range(len(sizes))]

            def corner(idx):  # this corner's cell: its texel column (u) and rows (v), the view rows blended
                cell = 0.0
                for (j0, _), d, stride in zip(cells, idx, strides):
                    cell = self.math("ADD", cell, self.math("MULTIPLY", self.math("ADD", j0, float(d)), float(stride)))
                if banded:
                    band = self.math("FLOOR", self.math("DIVIDE", self.math("ADD", cell, 0.5), float(per_band)))
                    cell = self.math("SUBTRACT", cell, self.math("MULTIPLY", band, float(per_band)))
                    rows = self.math("DIVIDE", self.math("MULTIPLY_ADD", band, float(n_mu), float(row0)), float(height))
                else:
                    rows = row0 / height
                u = self.math("DIVIDE", self.math("MULTIPLY_ADD", cell, float(groups), group + 0.5), float(width))
                texels = []
                for v in (self.math("ADD", v, rows) for v in vs):
                    xyz = self.add("ShaderNodeCombineXYZ", {}, {"X": u, "Y": v, "Z": 0.0}, ("Vector",))
                    tex = self.add("ShaderNodeTexImage", {"image": self.image, "interpolation": "Closest",
                                                          "extension": "EXTEND"},
                                   {"Vector": Out(xyz, "Vector")}, ("Color", "Alpha"))
                    texels.append(Out(tex, "Color"))
                return self._mix(texels[0], texels[1], f)

            def over(idx):
                if len(idx) == len(sizes):
                    return corner(idx)
                return self._mix(over(idx + (0,)), over(idx + (1,)), cells[len(idx)][1])

            sep = reads[group] = self.add("ShaderNodeSeparateXYZ", {}, {"Vector": over(())}, ("X", "Y", "Z"))
        return Out(sep, "XYZ"[channel])

    def _mix(self, a, b, f):
        """a + (b - a) f on three channels: a vector Mix node."""
        i = self.add("ShaderNodeMix", {"data_type": "VECTOR", "clamp_factor": False},
                     {"Factor_Float": f, "A_Vector": a, "B_Vector": b}, ("Result_Vector",))
        return Out(i, "Result_Vector")

    def lut(self, name, *c):
        spec = luts.SPECS[name]
        if len(spec.shape) == 2:
            n0, n1 = spec.shape
            return self._read(spec.file, self._texel(c[1], n1), self._texel(c[0], n0))[0]
        n0, n1, n2 = spec.shape
        s = self._texel(c[1], n1)
        if not isinstance(c[2], Out):
            x = min(max(c[2], 0.0), 1.0) * (n2 - 1)
            k = min(math.floor(x), n2 - 2)
            f = x - k
            if f < 1e-9 and name in luts.PACKED:
                group, channel = divmod(k, 4)
                t = self._texel(c[0], n0, group * n0, n2 // 4 * n0)
                return self._read(luts.PACKED[name], s, t, ("X", "Y", "Z", "A"))[channel]
            if f < 1e-9:
                return self._read(spec.file, s, self._texel(c[0], n0, k * n0, n0 * n2))[0]
            a = self._read(spec.file, s, self._texel(c[0], n0, k * n0, n0 * n2))[0]
            b = self._read(spec.file, s, self._texel(c[0], n0, (k + 1) * n0, n0 * n2))[0]
            return self.math("ADD", a, self.math("MULTIPLY", self.math("SUBTRACT", b, a), f))
        # a traced slice coordinate: the two slices around it, blended (lamella_lut3)
        x = self.math("MULTIPLY", self.math("MINIMUM", self.math("MAXIMUM", c[2], 0.0), 1.0), float(n2 - 1))
        k = self.math("MINIMUM", self.math("FLOOR", x), float(n2 - 2))
        f = self.math("SUBTRACT", x, k)
        t0 = self._texel(c[0], n0)  # rows of slice 0; slice k starts k * n0 rows further
        row = self.math("DIVIDE", self.math("MULTIPLY", k, float(n0)), float(n0 * n2))
        scale = n0 / float(n0 * n2)
        t_a = self.math("ADD", self.math("MULTIPLY", t0, scale), row)
        t_b = self.math("ADD", t_a, scale)
        a = self._read(spec.file, s, t_a)[0]
        b = self._read(spec.file, s, t_b)[0]
        return self.math("ADD", a, self.math("MULTIPLY", self.math("SUBTRACT", b, a), f))


_FOLD_MATH = {
    "ADD": lambda a, b: a + b, "SUBTRACT": lambda a, b: a - b, "MULTIPLY": lambda a, b: a * b,
    "DIVIDE": lambda a, b: a / b if b != 0.0 else 0.0, "MINIMUM": min, "MAXIMUM": max,
    "FLOOR": math.floor, "MULTIPLY_ADD": lambda a, b, c: a * b + c,
}


def emit_plan(stack, model: str = "auto", live=(), budget="auto", staged: bool = True,
              image: str = TABLE_IMAGE, grid=None, staged_ir=None, live_axes="auto", stand_ins: int = STAND_INS) -> Plan:
    """The node plan of ``stack`` under ``model``: in Cycles the closures of the OSL shader,
    anisotropy included; EEVEE renders the same nodes with its own limits (``LobeKind.bsdf``).
    ``staged`` (default): the model staged for a material whose parameters ``live`` are linked,
    lobes merged to ``budget`` (``staging.stage``), the table read from the image ``image``
    (``Plan.images``) on ``grid`` (``staging.ViewGrid``; default: staging's); ``staged=False``: the
    whole model as nodes. ``staged_ir``: the ``staging.Staged`` of this stack already made (the OSL
    shader's, so a material is staged once), used instead of staging again.
    ``live_axes``: what of the model the linked parameters reach is read from tables over (view,
    parameters) (``staging.stage``'s ``live_axes``); "auto": none, unless the traced part is more
    than Cycles' SVM surely holds (``live_values`` above ``SVM_UNSURE``), then up to
    ``live_axes.MAX_AXES`` parameters per table. ``stand_ins``: the isotropic lobes EEVEE draws for
    each anisotropic one (``staging.stage``; 0: EEVEE draws the anisotropic lobe round)."""
    if staged and staged_ir is not None and live_axes in ("auto", staged_ir.live_axes):
        st = staged_ir
    elif staged:
        st = stage(stack, model, live, budget, grid, live_axes=0 if live_axes == "auto" else live_axes,
                   stand_ins=stand_ins)
    else:
        st = None
    if st is not None and live_axes == "auto" and st.live and st.live_axes == 0:
        key = st.structure_key()
        if key not in _TOO_LARGE:
            plan = _plan(stack, model, st, image)
            _TOO_LARGE[key] = live_values(plan) > SVM_UNSURE
            if len(_TOO_LARGE) > 64:
                del _TOO_LARGE[next(iter(_TOO_LARGE))]
            if not _TOO_LARGE[key]:
                return plan
        if _TOO_LARGE[key]:
            st = stage(st.stack, st.model, (*st.live, *(normal_socket(n) for n in st.normals)), budget, grid,
                       live_axes=MAX_AXES, stand_ins=stand_ins)
    return _plan(stack, model, st, image, live)


_TOO_LARGE: dict = {}  # structure key of a staged shader -> whether its traced part is too large for SVM


def _plan(stack, model: str, st, image: str, live=()) -> Plan:
    """The plan of the staged shader ``st``, or of the whole model of ``stack`` (``st`` None, every
    parameter an input; the layers' normals in ``live`` inputs too)."""
    if st is not None:
        stack, model_name, params, ids = st.stack, st.model, dict(st.defaults), dict(st.ids)
        t, closures, wi, frame, table = st.tracer, st.closures, st.wi, st.frame, st.table
        normals = st.normals
    else:
        normals = split_normals(live)[1]
        traced = trace_closures(stack, model, live)
        stack, model_name = traced.stack, traced.model
        params = {k: float(traced.tracer.defaults[k]) for k in traced.tracer.params}
        ids = dict(traced.tracer.ids)
        t, closures, wi, frame, table = traced.tracer, traced.covered, traced.wi, "shading", None
    # a closure with EEVEE stand-ins (``Staged.stand_ins``) is drawn in Cycles, its stand-ins in
    # EEVEE; a closure whose kind gives EEVEE a node of its own (``LobeKind.eevee``) too
    stand_ins = st.stand_ins if st is not None else {}
    specs = []
    for k, c in enumerate(closures):
        own = c.kind.eevee(t, c.args, wi) if c.kind.eevee is not None and k not in stand_ins else None
        specs.append((c, c.weight, c.kind.node(t, c.args, wi), "cycles" if k in stand_ins or own else "all"))
        specs += [(s, s.weight, s.kind.node(t, s.args, wi), "eevee") for s in stand_ins.get(k, ())]
        if own is not None:
            node, factor = own
            specs.append((c, tuple(w * factor for w in c.weight), node, "eevee"))
    exprs = []
    for _, color, b, _ in specs:
        exprs += [*color, *b.floats.values()]
        exprs += [x for vec in b.vectors.values() if vec is not None for x in vec]
    low = _Lowering(t, table, image, st.axis_tables if st is not None else ())
    low.lower(exprs)
    bsdfs = []
    for c, color, b, target in specs:
        bsdfs.append(Bsdf(c.kind.name, b.bl_idname, dict(b.props), tuple(low.ref(c) for c in color),
                          {s: low.ref(x) for s, x in b.floats.items()},
                          {s: (None if vec is None else tuple(low.ref(x) for x in vec)) for s, vec in b.vectors.items()},
                          c.label, c.framed(normals), target))
    sections = {"setup": "incident direction", "lobes": "lobes", "closures": "closure weights",
                "base": f"base: {stack.base.type}", "table": "the material table", "live": "linked parameters"}
    for i, c in enumerate(stack.coats):
        sections[f"coat{i}"] = f"coat {i}" + (" (medium)" if c.has_scattering else "")
    images = {image: low.material_pixels()} if any(n.props.get("image") == image for n in low.nodes) else {}
    return Plan(low.nodes, low.leaves, params, bsdfs, sections, model_name, stack.to_json(indent=None),
                (t, exprs, [low.ref(e) for e in exprs]), frame, images, st, ids, normals)
