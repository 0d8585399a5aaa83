"""The emitted shaders evaluated in numpy, to hold them to the traced model without a renderer:
``evaluate_staged`` computes what a staged shader (``ir.staging.Staged``: tables plus the traced
part) gives for directions in the shading frame, as the OSL shader and the node group compute it;
``evaluate_plan`` runs a node plan (``nodes.plan.Plan``) with Blender's node semantics (division by
zero gives 0, the square root and logarithm of a non-positive number give 0, a negative base to a
non-integer power gives 0) and Blender's image reads (``bilinear``, ``closest``, texel centres at
(i + 0.5) / size). The tests and benches import them; nothing shipped calls them."""
from __future__ import annotations

import numpy as np

from .. import luts
from ..models.sides import INSIDE, OUTSIDE, SIDES
from .ir.closures import INSIDE_INPUT
from .ir.staging import ENERGY_EPS, VIEW_INPUTS, Staged, StagedOps
from .ir.trace import Expr
from .nodes.plan import MATH_IN, Out, Plan


# ---------------------------------------------------------------- staged shaders
def evaluate_staged(st: Staged, wi, wo, dtype=np.float32, values: dict | None = None,
                    target: str = "cycles", seen_from: str = OUTSIDE) -> np.ndarray:
    """f(wi, wo) |wo.z| of the staged shader (numpy, ``dtype``) for directions in the shading
    frame (N, 3): what the emitted shaders compute, to hold them to the traced model. ``target``
    "eevee": each anisotropic lobe as the isotropic stand-ins the node group draws in EEVEE
    (``Staged.stand_ins``), the closures as EEVEE's Glossy BSDF would read them otherwise being
    EEVEE's business. ``seen_from``: the side of the surface the view is on (``models.sides``:
    "inside", where the shaders see a back face, draws a solid dielectric base from within)."""
    wi = np.asarray(wi, dtype=np.float64).reshape(-1, 3)
    wo = np.asarray(wo, dtype=np.float64).reshape(-1, 3)
    wi = np.broadcast_to(wi, wo.shape)
    if st.frame == "view":
        wi, wo = to_view_frame(wi, wo)
    ops = StagedOps(st.table, dtype, st.axis_tables)
    dtype = ops.dtype.type
    vals = {n: wi[:, k].astype(dtype) for k, n in enumerate(VIEW_INPUTS)}
    if seen_from not in SIDES:
        raise ValueError(f"seen_from must be one of {', '.join(SIDES)}, got {seen_from!r}")
    vals[INSIDE_INPUT] = dtype(seen_from == INSIDE)
    vals.update(st.params)
    if values:
        vals.update(values)
    if target not in ("cycles", "eevee"):
        raise ValueError(f"target is 'cycles' or 'eevee', got {target!r}")
    closures = st.closures if target == "cycles" else [
        s for k, c in enumerate(st.closures) for s in st.stand_ins.get(k, [c])]
    outs = [x for c in closures for x in (*c.weight, *c.args.values())]
    with np.errstate(all="ignore"):
        got = st.tracer.evaluate(outs, ops, vals)
    env = dict(zip(map(id, outs), got))
    wi_o = tuple(ops.input(n, wi[:, k]) for k, n in enumerate(VIEW_INPUTS))
    wo_o = tuple(ops.input(n, wo[:, k]) for k, n in enumerate(("wo_x", "wo_y", "wo_z")))
    total = np.zeros((wo.shape[0], 3), dtype=dtype)

    def v(x):
        return env[id(x)] if isinstance(x, Expr) else dtype(x)

    for c in closures:
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


# ---------------------------------------------------------------- node plans
def _safe_div(a, b):
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(b != 0, a / np.where(b != 0, b, 1), 0).astype(a.dtype)


def _safe_sqrt(a):
    return np.where(a > 0, np.sqrt(np.maximum(a, 0)), 0).astype(a.dtype)


def _safe_log(a, b):
    ok = (a > 0) & (b > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(ok, np.log(np.where(ok, a, 1)) / np.log(np.where(ok, b, 2)), 0).astype(a.dtype)


def _safe_pow(a, b):
    """Blender's safe power: a negative base with a non-integer exponent gives 0."""
    bad = (a < 0) & (b != np.floor(b))
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return np.where(bad, 0, np.power(np.where(bad, 1, a), b)).astype(a.dtype)


_NP_MATH = {
    "ADD": np.add, "SUBTRACT": np.subtract, "MULTIPLY": np.multiply, "DIVIDE": _safe_div,
    "LESS_THAN": lambda a, b: (a < b).astype(a.dtype), "GREATER_THAN": lambda a, b: (a > b).astype(a.dtype),
    "SQRT": _safe_sqrt, "EXPONENT": np.exp, "POWER": _safe_pow, "ABSOLUTE": np.abs, "MINIMUM": np.minimum,
    "MAXIMUM": np.maximum, "COSINE": np.cos, "SINE": np.sin, "ARCTAN2": np.arctan2, "LOGARITHM": _safe_log,
    "FLOOR": np.floor, "MULTIPLY_ADD": lambda a, b, c: a * b + c, "MODULO": np.fmod,
}


def table_pixels(file: str, dtype=np.float32) -> np.ndarray:
    """The image as Blender holds it: rows bottom first, RGBA (a one-channel table in R, G, B)."""
    for name, spec in luts.SPECS.items():
        if spec.file == file:
            atlas = luts.to_file(luts._to_atlas(luts.table(name)))
            rgba = np.stack([atlas, atlas, atlas, np.ones_like(atlas)], axis=-1)
            return rgba[::-1].astype(dtype)
    for name, packed in luts.PACKED.items():
        if packed == file:
            n0, n1, n2 = luts.SPECS[name].shape
            a = luts.table(name)
            rgba = np.stack([luts.to_file(luts._to_atlas(a[:, :, c::4])) for c in range(4)], axis=-1)
            return rgba[::-1].astype(dtype)
    raise KeyError(file)


def bilinear(img: np.ndarray, u, v):
    """Linear, Extend image texture look-up (texel centres at (i + 0.5) / size)."""
    h, w = img.shape[:2]
    x = np.asarray(u) * w - 0.5
    y = np.asarray(v) * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    xi0, yi0 = np.clip(x0, 0, w - 1).astype(int), np.clip(y0, 0, h - 1).astype(int)
    xi1, yi1 = np.clip(x0 + 1, 0, w - 1).astype(int), np.clip(y0 + 1, 0, h - 1).astype(int)
    top = img[yi0, xi0] * (1 - fx) + img[yi0, xi1] * fx
    bottom = img[yi1, xi0] * (1 - fx) + img[yi1, xi1] * fx
    return (top * (1 - fy) + bottom * fy).astype(img.dtype)


def closest(img: np.ndarray, u, v):
    """Closest, Extend image texture look-up."""
    h, w = img.shape[:2]
    xi = np.clip(np.floor(np.asarray(u) * w), 0, w - 1).astype(int)
    yi = np.clip(np.floor(np.asarray(v) * h), 0, h - 1).astype(int)
    return img[yi, xi]


def evaluate_plan(plan: Plan, values: dict, dtype=np.float32):
    """Run the plan on leaf ``values`` (by name, broadcastable arrays) with Blender's node
    semantics in ``dtype``. Returns ``value_of(ref)``: the value of an ``Out`` (or a literal)."""
    dtype = np.dtype(dtype)
    leaves = [np.asarray(values[name], dtype=dtype) for name in plan.leaves]
    env: dict[int, dict] = {}
    images: dict[str, np.ndarray] = {}

    def get(v):
        if not isinstance(v, Out):
            return dtype.type(v)
        return leaves[-1 - v.node] if v.node < 0 else env[v.node][v.socket]

    with np.errstate(over="ignore", invalid="ignore"):
        for i, n in enumerate(plan.nodes):
            x = {k: get(v) for k, v in n.inputs.items()}
            if n.bl_idname == "ShaderNodeMath":
                args = [np.asarray(x[k], dtype=dtype) for k in MATH_IN if k in x]
                r = np.asarray(_NP_MATH[n.props["operation"]](*args), dtype=dtype)
                env[i] = {"Value": np.clip(r, 0, 1).astype(dtype) if n.props.get("use_clamp") else r}
            elif n.bl_idname == "ShaderNodeCombineXYZ":
                env[i] = {"Vector": np.broadcast_arrays(*(np.asarray(x[k], dtype=dtype) for k in "XYZ"))}
            elif n.bl_idname == "ShaderNodeTexImage":
                f = n.props["image"]
                if f not in images:
                    images[f] = plan.images[f].astype(dtype) if f in plan.images else table_pixels(f, dtype)
                u, v, _ = x["Vector"]
                read = closest if n.props.get("interpolation") == "Closest" else bilinear
                rgba = read(images[f], u, v)
                env[i] = {"Color": rgba[..., :3], "Alpha": rgba[..., 3]}
            elif n.bl_idname == "ShaderNodeMix":
                a, b = np.asarray(x["A_Vector"], dtype=dtype), np.asarray(x["B_Vector"], dtype=dtype)
                f = np.asarray(x["Factor_Float"], dtype=dtype)[..., None]
                env[i] = {"Result_Vector": (a + (b - a) * f).astype(dtype)}
            elif n.bl_idname == "ShaderNodeSeparateXYZ":
                c = x["Vector"]
                env[i] = {"X": c[..., 0], "Y": c[..., 1], "Z": c[..., 2]}
            else:
                raise NotImplementedError(n.bl_idname)
    return get
