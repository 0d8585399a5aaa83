"""`lamella stress`: numerical stability at scale.

**Random stacks.** Stacks drawn over the whole range the stack contract accepts (the schema's
hard limits), weighted toward the edges: every field takes one of its edge values with
probability ``EDGE_P`` (ior 0.01, 1 and 3 and 100, roughness 0 and 1, |g| up to 0.999999, sigma
up to 1e6, thickness 0 and 1e4, k up to 1e6, ...), else a value from its usual range. Each stack
is evaluated at random view directions, grazing and below the horizon included, under every
model that runs it, in float32 (and a sample in float64):

- every lobe energy, closure weight and closure argument finite, no energy negative;
- the lobes' energies summed (what ``albedo`` reports: reflected plus transmitted) at most
  ``1 + ALBEDO_SLACK[dtype]`` (rounding only: every stack here is passive);
- f cos at a random outgoing direction finite and not negative.

Stacks that share a structure (``closures.structure_of``: coats, base kind, which layers are
anisotropic, absorbing, scattering, partly covering or filmed) trace to one graph, so a batch of them is evaluated at once
with its parameters as arrays: the graph is exactly what a single stack's evaluation runs. A
sample of stacks also goes through the baked path (``staging.stage`` and ``evaluate_staged``, the
shaders' table and closures, float32). A failing stack is shrunk (coats removed, fields set back
to their defaults while it still fails) and written to ``tests/unit/stress_regressions.json``,
which ``tests/unit/test_stress.py`` replays.

**Render grid.** Extreme stacks rendered in Cycles with OSL, Cycles without OSL and EEVEE in
``sphere-env`` and ``white-furnace``: no NaN, Inf or negative pixel; no pixel above the
brightest texel of the environment times 1 + ``PIXEL_BOUND`` / sqrt(samples) (a passive material
reflects at most what it receives; the margin is the sampling noise of a pixel's few samples, so
a firefly still shows); the white furnace's mean at most 1 plus three standard errors.

**Soak.** One material, ``SOAK_EDITS`` random edits (valid and invalid values, layers added,
removed and moved, presets applied) with an undo or redo among them where the session has an
undo stack, saved and reloaded every ``SOAK_SAVE_EVERY``: the counts of texts and images stay
flat, no node group is left that the material does not use (their number follows the stack's
structure), memory stays flat, and the material shows the last valid stack.

Results go to ``bench/stress.md`` (and ``stress.json``); ``--quick`` (what ``make test`` runs
through ``tests/unit/test_stress.py`` and ``tests/blender/test_stress_blender.py``) is a few
thousand stacks, a small grid and a short soak.
"""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from lamella.core import api as core_api
from lamella.core.backends.ir.closures import INSIDE_INPUT, declared_params, structure_of, trace_closures
from lamella.core.backends.numpy_ops import NumpyOps
from lamella.core.layers import BASE_KINDS
from lamella.core.layers.film import FILM_IOR_MAX, FILM_IOR_MIN, FILM_THICKNESS_MAX
from lamella.core.models.coverage import MAX_PARTIAL
from lamella.core.layers.schema import ANGLE_MAX, G_MAX, IOR_MAX, IOR_MIN, SIGMA_MAX, THICKNESS_MAX
from lamella.core.models import UnsupportedStack
from lamella.core.models.sides import SIDES, is_solid
from lamella.core.stack import MAX_COATS, Stack
from .paths import BENCH_DIR
from .page import write_page

EDGE_P = 0.3  # probability that a field takes one of its edge values
# Rounding: an energy is a chain of up to ~50 operations over values near 1, which the inter-
# reflection sums (I - R R')^-1 of light trapped between layers amplify by the number of bounces (up
# to ~n^2 = 16 at the largest index ratio between two layers, 4 / 0.25), compounded over up to
# eight adding steps, and up to 27 lobes are summed: with unit roundoffs of 6e-8 (float32) and
# 1.1e-16 (float64), 2e-3 and 1e-10. Measured over a million stacks: at most 1.3e-3 and 1.0e-12,
# both in the six-flux model of eight coats (the other models: 1.1e-4 and 6e-14); the largest
# excess is reported per model (``bench/stress.md``).
ALBEDO_SLACK = {np.float32: 2e-3, np.float64: 1e-10}
MAX_SHRUNK = 5  # failing stacks shrunk per run (each shrink evaluates the stack many times)
DIRECTIONS = 4  # view directions per stack
REGRESSIONS = Path(__file__).resolve().parents[3] / "tests" / "unit" / "stress_regressions.json"
PIXEL_BOUND = 4.0  # a pixel of N samples may exceed the light's peak by PIXEL_BOUND / sqrt(N) (noise)
SOAK_EDITS, SOAK_SAVE_EVERY = 1000, 100
MODELS = tuple(m for m in core_api.MODELS if m != "auto")
QUICK_STACKS = 1000


# ---------------------------------------------------------------- drawing stacks
def _pick(rng, edges, usual):
    return float(rng.choice(edges)) if rng.random() < EDGE_P else float(usual())


def _log_uniform(rng, lo, hi):
    return lambda: math.exp(rng.uniform(math.log(lo), math.log(hi)))


def _roughness(rng, anisotropic: bool):
    one = lambda: _pick(rng, [0.0, 1e-7, 1e-3, 1.0 - 1e-7, 1.0], rng.random)  # noqa: E731
    if not anisotropic:
        return one()
    ax, ay = one(), one()
    while ax == ay:
        ay = rng.random()
    return [ax, ay]


def _rotation(rng):
    return _pick(rng, [0.0, math.pi / 2, -math.pi / 2, ANGLE_MAX, -ANGLE_MAX], lambda: rng.uniform(-math.pi, math.pi))


def _ior(rng):
    return _pick(rng, [IOR_MIN, 0.5, 1.0, 1.0 + 1e-7, 1.0 - 1e-7, 3.0, IOR_MAX],
                 lambda: rng.uniform(1.0, 3.0) if rng.random() < 0.8 else _log_uniform(rng, IOR_MIN, IOR_MAX)())


def _positive_rgb(rng, edges, usual):
    """An RGB coefficient with at least one channel above zero."""
    v = [_pick(rng, edges, usual) for _ in range(3)]
    if max(v) <= 0.0:
        v[int(rng.integers(3))] = float(usual())
    return v


def draw_structure(rng) -> dict:
    """A structure: the number of coats, the base kind, and per layer whether it is anisotropic,
    absorbing, scattering."""
    n = int(rng.choice([0, 1, 2, MAX_COATS])) if rng.random() < 0.5 else int(rng.integers(0, MAX_COATS + 1))
    coats = [{"aniso": rng.random() < 0.3, "absorbing": rng.random() < 0.35, "scattering": rng.random() < 0.3,
              "partial": False, "film": rng.random() < 0.2} for _ in range(n)]
    for i in rng.permutation(n)[:int(rng.integers(0, MAX_PARTIAL + 1))] if n else ():
        coats[int(i)]["partial"] = rng.random() < 0.5  # a coat on part of the surface (models.coverage)
    base = str(rng.choice(list(BASE_KINDS)))
    return {"coats": coats, "base": base, "aniso": rng.random() < 0.3, "film": rng.random() < 0.2,
            "thin_walled": base == "dielectric" and rng.random() < 0.3}


def draw_stack(rng, structure: dict) -> dict:
    """A stack of ``structure`` with values drawn over the schema's range, edges weighted."""
    layers = []
    sigma_edges = [1e-7, 1.0, 1e4, SIGMA_MAX]
    sigma_usual = _log_uniform(rng, 1e-4, 1e4)
    for c in structure["coats"]:
        d = {"ior": _ior(rng), "roughness": _roughness(rng, c["aniso"]), "rotation": _rotation(rng)}
        if c["absorbing"] or c["scattering"]:
            d["thickness"] = _pick(rng, [1e-7, 1.0, 1e3, THICKNESS_MAX], _log_uniform(rng, 1e-4, 1e3))
        if c["absorbing"]:
            d["sigma_a"] = _positive_rgb(rng, [0.0] + sigma_edges, sigma_usual)
        if c["scattering"]:
            d["sigma_s"] = _positive_rgb(rng, [0.0] + sigma_edges, sigma_usual)
            d["g"] = _pick(rng, [0.0, 0.999, -0.999, G_MAX, -G_MAX], lambda: rng.uniform(-0.99, 0.99))
        if c.get("partial"):
            d["coverage"] = _pick(rng, [0.0, 1e-7, 0.5, 1.0 - 1e-7], rng.random)
        if c.get("film"):
            d.update(_film(rng))
        layers.append(d)
    kind = structure["base"]
    base = {"type": kind}
    if kind == "conductor":
        base["eta"] = [_pick(rng, [1e-4, 0.01, 1.0, 3.0, 1e3], _log_uniform(rng, 0.05, 5.0)) for _ in range(3)]
        base["k"] = [_pick(rng, [0.0, 1e-6, 10.0, 1e6], lambda: rng.uniform(0.0, 10.0)) for _ in range(3)]
    elif kind == "dielectric":
        base["ior"] = _ior(rng)
        base["thin_walled"] = bool(structure.get("thin_walled"))
    else:
        base["albedo"] = [_pick(rng, [0.0, 1.0], rng.random) for _ in range(3)]
    if kind != "diffuse":
        base["roughness"] = _roughness(rng, structure["aniso"])
        base["rotation"] = _rotation(rng)
        if structure.get("film"):
            base.update(_film(rng))
    return {"layers": layers, "base": base}


def _film(rng) -> dict:
    """A thin film (``layers.film``): its thickness from a fraction of a nanometre (the fade-in) to
    the limit, its index over the schema's range."""
    return {"film_thickness": _pick(rng, [1e-7, 0.5, 1.0, 1e3, FILM_THICKNESS_MAX], lambda: rng.uniform(1.0, 2000.0)),
            "film_ior": _pick(rng, [FILM_IOR_MIN, 1.0 + 1e-7, 1.33, FILM_IOR_MAX], lambda: rng.uniform(1.0, 2.5))}


def directions(rng, n: int) -> np.ndarray:
    """(n, 3) unit vectors: cos theta from the edges (0, 1e-7, 1, just below the horizon) or
    uniform in [-0.2, 1], any azimuth."""
    cos = np.where(rng.random(n) < EDGE_P, rng.choice([0.0, 1e-7, 1.0, -1e-3, -0.2], n), rng.uniform(-0.2, 1.0, n))
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    sin = np.sqrt(np.maximum(1.0 - cos * cos, 0.0))
    return np.stack([sin * np.cos(phi), sin * np.sin(phi), cos], -1)


# ---------------------------------------------------------------- checking
def check_batch(stacks: list, model: str, dtype, wi: np.ndarray, wo: np.ndarray) -> tuple[np.ndarray, float]:
    """Whether each of ``stacks`` (one structure) fails under ``model`` in ``dtype``: a bool per
    stack (any of its directions), and the largest albedo above 1 among the finite ones. ``wi``, ``wo``: (len(stacks), D, 3). Raises UnsupportedStack
    where the model cannot run the structure."""
    traced = trace_closures(stacks[0], model)
    t = traced.tracer
    n, d = wi.shape[:2]
    values = {}
    per_stack = [declared_params(s) for s in stacks]
    for name in t.params:
        col = np.array([p[name] for p in per_stack], dtype=np.float64)
        values[name] = np.repeat(col, d).astype(dtype)
    for k, name in enumerate(("wi_x", "wi_y", "wi_z")):
        values[name] = wi[..., k].reshape(-1).astype(dtype)
    ops = NumpyOps(dtype)
    outs = []
    for c in traced.covered:  # weights times the fraction of the surface each is on (models.coverage)
        outs += [*c.lobe.weight, *c.weight, *c.args.values()]
    bad = np.zeros(n * d, dtype=bool)
    worst = np.zeros(n * d, dtype=np.float64)
    # a solid dielectric base is seen from inside on a mesh's far side (``models.sides``)
    for inside in ((0.0, 1.0) if INSIDE_INPUT in t.inputs else (0.0,)):
        values[INSIDE_INPUT] = dtype(inside)
        side_bad, total = _check_side(traced, t, ops, outs, values, wo, n, d, dtype)
        bad |= side_bad | ~(total <= 1.0 + ALBEDO_SLACK[dtype]).all(-1)
        finite = np.isfinite(total).all(-1)
        worst = np.maximum(worst, np.where(finite, total.max(-1) - 1.0, 0.0))
    return bad.reshape(n, d).any(1), float(max(worst.max(initial=0.0), 0.0))


def _check_side(traced, t, ops, outs, values, wo, n, d, dtype):
    """(whether each direction fails, the total energy there) for one side of the surface."""
    with np.errstate(all="ignore"):
        got = t.evaluate(outs, ops, values)
    env = {id(x): np.broadcast_to(np.asarray(v, dtype=dtype), (n * d,)) for x, v in zip(outs, got)}

    def v(x):
        return env[id(x)] if id(x) in env else np.full(n * d, x, dtype=dtype)

    bad = np.zeros(n * d, dtype=bool)
    total = np.zeros((n * d, 3), dtype=np.float64)
    wi_o = tuple(values[k] for k in ("wi_x", "wi_y", "wi_z"))
    wo_o = tuple(wo[..., k].reshape(-1).astype(dtype) for k in range(3))
    for c in traced.covered:
        energy = np.stack([v(x) for x in c.lobe.weight], -1)
        weight = np.stack([v(x) for x in c.weight], -1)
        args = {k: v(x) for k, x in c.args.items()}
        bad |= ~np.isfinite(energy).all(-1) | (energy < 0).any(-1) | ~np.isfinite(weight).all(-1) | (weight < 0).any(-1)
        for a in args.values():
            bad |= ~np.isfinite(a)
        total += energy.astype(np.float64)
        with np.errstate(all="ignore"):
            f = np.broadcast_to(np.asarray(c.kind.cos_of_args(ops, args, wi_o, wo_o)), (n * d,))
        on = weight.max(-1) > 0
        bad |= on & (~np.isfinite(f) | (f < 0))
    return bad, total


def check_stack(stack, model: str, dtype, wi: np.ndarray, wo: np.ndarray) -> bool:
    """Whether one stack fails (``check_batch`` of one)."""
    return bool(check_batch([Stack.coerce(stack)], model, dtype, wi[None], wo[None])[0][0])


def check_staged(stack, wi: np.ndarray, wo: np.ndarray) -> bool:
    """Whether the baked path of ``stack`` (auto model, automatic lobe budget) fails: the staged
    shader's f cos at (wi, wo), float32, not finite or negative, or staging raises."""
    from lamella.core.backends.evaluate import evaluate_staged
    from lamella.core.backends.ir.staging import stage

    try:
        st = stage(stack)
        fs = [evaluate_staged(st, wi, wo, np.float32, seen_from=side)
              for side in (SIDES if is_solid(Stack.coerce(stack)) else SIDES[:1])]
    except FloatingPointError:
        return True
    return not all(np.isfinite(f).all() and (f >= 0).all() for f in fs)


def shrink(stack: dict, fails, budget: int = 80) -> dict:
    """A smaller stack that still ``fails``: coats removed, then fields set to their defaults, one
    at a time, kept while the failure stays (at most ``budget`` trials: each may trace a new
    structure)."""
    d = json.loads(json.dumps(stack))
    trials = [0]

    def still_fails(x):  # the caller's test, within the budget
        trials[0] += 1
        return trials[0] <= budget and fails(x)

    changed = True
    while changed and trials[0] < budget:
        changed = False
        for i in range(len(d["layers"])):
            trial = dict(d, layers=d["layers"][:i] + d["layers"][i + 1:])
            if still_fails(trial):
                d, changed = trial, True
                break
        for layer in [*d["layers"], d["base"]]:
            for key in [k for k in layer if k != "type"]:
                trial_layer = {k: x for k, x in layer.items() if k != key}
                saved = dict(layer)
                layer.clear()
                layer.update(trial_layer)
                if still_fails(d):
                    changed = True
                else:
                    layer.clear()
                    layer.update(saved)
    return d


def random_stacks(n_stacks: int, per_structure: int, seed: int = 0, float64_every: int = 10,
                  staged_every: int = 500, progress: bool = True) -> dict:
    """The random-stack run: ``n_stacks`` stacks in batches of ``per_structure`` per structure.
    Returns counts per model and dtype and the failing stacks (shrunk)."""
    from tqdm import tqdm

    rng = np.random.default_rng(seed)
    stats = {m: {"float32": [0, 0, 0.0], "float64": [0, 0, 0.0]} for m in MODELS}
    staged = [0, 0]
    failures, errors = [], []
    t0 = time.perf_counter()
    done = 0
    with tqdm(total=n_stacks, desc="random stacks", unit="stack", disable=not progress) as bar:
        while done < n_stacks:
            structure = draw_structure(rng)
            m = min(per_structure, n_stacks - done)
            stacks = [Stack.from_dict(draw_stack(rng, structure)) for _ in range(m)]
            assert len({structure_of(s) for s in stacks}) == 1, "a batch shares one structure"
            wi = directions(rng, m * DIRECTIONS).reshape(m, DIRECTIONS, 3)
            wo = directions(rng, m * DIRECTIONS).reshape(m, DIRECTIONS, 3)
            wo[..., 2] = np.abs(wo[..., 2])  # outgoing: the upper hemisphere (transmission lobes evaluate below)
            for model in MODELS:
                for dtype, name, sub in ((np.float32, "float32", slice(None)),
                                         (np.float64, "float64", slice(None, None, float64_every))):
                    part = stacks[sub]
                    if not part:
                        continue
                    try:
                        bad, excess = check_batch(part, model, dtype, wi[sub], wo[sub])
                    except UnsupportedStack:
                        break
                    except Exception as e:  # noqa: BLE001 - a model that raises on a valid stack fails it
                        bad = np.array([_fails(s.to_dict(), model, dtype, a, b)
                                        for s, a, b in zip(part, wi[sub], wo[sub])])
                        excess = 0.0
                        errors.append(f"{model} {name}: {type(e).__name__}: {str(e)[:200]}")
                    stats[model][name][0] += len(part)
                    stats[model][name][1] += int(bad.sum())
                    stats[model][name][2] = max(stats[model][name][2], excess)
                    for k in np.flatnonzero(bad)[:max(0, MAX_SHRUNK - len(failures))]:
                        s, a, b = part[int(k)], wi[sub][int(k)], wo[sub][int(k)]
                        small = shrink(s.to_dict(), lambda d, a=a, b=b, model=model, dtype=dtype: _fails(d, model, dtype, a, b))
                        failures.append({"model": model, "dtype": name, "stack": small, "wi": a.tolist(), "wo": b.tolist()})
            for k in range(0, m, staged_every):
                staged[0] += 1
                if check_staged(stacks[k], wi[k], wo[k]):
                    staged[1] += 1
                    if len(failures) >= MAX_SHRUNK:
                        continue
                    failures.append({"model": "staged", "dtype": "float32", "stack": stacks[k].to_dict(),
                                     "wi": wi[k].tolist(), "wo": wo[k].tolist()})
            done += m
            bar.update(m)
    return {"stacks": n_stacks, "per_structure": per_structure, "seed": seed, "directions": DIRECTIONS,
            "seconds": time.perf_counter() - t0, "models": stats, "staged": staged, "failures": failures,
            "errors": errors}


def _fails(d, model, dtype, wi, wo) -> bool:
    try:
        return check_stack(Stack.from_dict(d), model, dtype, wi, wo)
    except UnsupportedStack:
        return False
    except Exception:  # noqa: BLE001 - raising on a valid stack is failing it
        return True


# ---------------------------------------------------------------- the render grid
def extreme_stacks() -> dict:
    """Stacks at the edges of the schema, one behaviour each."""
    mirror = {"type": "conductor", "eta": [1e-4] * 3, "k": [1e6] * 3, "roughness": 0.0}
    return {
        "huge_extinction_mirror": {"layers": [], "base": mirror},
        "dense_thick_medium": {"layers": [{"ior": 1.5, "roughness": 0.2, "thickness": THICKNESS_MAX,
                                           "sigma_a": [SIGMA_MAX, 1.0, 0.0], "sigma_s": [1.0, SIGMA_MAX, 1e-3],
                                           "g": G_MAX}], "base": {"type": "diffuse", "albedo": [1.0, 1.0, 1.0]}},
        "backward_scattering_fog": {"layers": [{"ior": 1.0, "roughness": 0.0, "thickness": 1e3, "sigma_s": [1e4] * 3,
                                                "g": -G_MAX}], "base": {"type": "diffuse", "albedo": [1.0, 1.0, 1.0]}},
        "extreme_iors": {"layers": [{"ior": IOR_MAX, "roughness": 1.0}, {"ior": IOR_MIN, "roughness": 1e-7}],
                         "base": {"type": "dielectric", "ior": IOR_MAX, "roughness": 1.0}},
        "eight_rough_anisotropic": {"layers": [{"ior": 1.0 + 0.25 * i, "roughness": [1.0, 1e-3], "rotation": ANGLE_MAX}
                                               for i in range(MAX_COATS)],
                                    "base": {"type": "conductor", "roughness": [1e-7, 1.0], "rotation": -ANGLE_MAX}},
        "white_lambert_under_clear": {"layers": [{"ior": 3.0, "roughness": 0.0}],
                                      "base": {"type": "diffuse", "albedo": [1.0, 1.0, 1.0]}},
    }


ENGINES = ("cycles-osl", "cycles-nodes", "eevee")


def render_grid(res: int = 48, spp: int = 16, progress: bool = True, cases=None) -> list[dict]:
    """Every extreme stack in every engine in ``sphere-env`` and ``white-furnace``: the pixel
    checks (see the module's docstring)."""
    from tqdm import tqdm

    from ..render import assign_material, build_scene, render_scene

    stacks = extreme_stacks()
    rows = []
    jobs = [(c, e, s) for c in (cases or stacks) for e in ENGINES for s in ("sphere-env", "white-furnace")]
    for case, engine, scene in tqdm(jobs, desc="render grid", disable=not progress):
        sc, sphere = build_scene(scene, res, spp)
        assign_material(sphere, Stack.from_dict(dict(stacks[case], name=case)), engine)
        px = render_scene(sc)[0]
        on = px[..., 3] > 0.999
        rgb = px[on, :3]
        bound = _environment_peak(sc) * (1.0 + PIXEL_BOUND / math.sqrt(spp))
        mean = float(rgb.mean()) if rgb.size else 0.0
        sem = float(rgb.mean(-1).std() / math.sqrt(max(rgb.shape[0], 1))) if rgb.size else 0.0
        rows.append({"case": case, "engine": engine, "scene": scene, "nan": int(np.isnan(px).sum()),
                     "inf": int(np.isinf(px).sum()), "negative": int((px < 0).sum()), "max": float(np.nanmax(rgb)),
                     "bound": bound, "over": int((rgb > bound).sum()), "mean": mean, "sem": sem})
    return rows


def _environment_peak(sc) -> float:
    """The brightest radiance the scene's world gives: the environment image's brightest texel
    times the Background strength, or the Background colour times strength (white furnace)."""
    world = sc.world
    bg = next(n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeBackground")
    strength = float(bg.inputs["Strength"].default_value)
    env = next((n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeTexEnvironment"), None)
    if env is None or env.image is None:
        return strength * max(bg.inputs["Color"].default_value[:3])
    px = np.empty(len(env.image.pixels), dtype=np.float32)
    env.image.pixels.foreach_get(px)
    return strength * float(px.reshape(-1, 4)[:, :3].max())


def grid_ok(row: dict) -> bool:
    furnace = row["scene"] != "white-furnace" or row["mean"] <= 1.0 + 3.0 * row["sem"] + 1e-3
    return row["nan"] == row["inf"] == row["negative"] == row["over"] == 0 and furnace


# ---------------------------------------------------------------- the soak
def soak(edits: int = SOAK_EDITS, save_every: int = SOAK_SAVE_EVERY, seed: int = 0, folder=None,
         progress: bool = True) -> dict:
    """Random edits on one material (see the module's docstring); returns the counts and memory
    at every save and whether the material shows the last valid stack."""
    import tempfile

    import bpy
    from tqdm import tqdm

    from lamella.blender import api, recompile
    from lamella.core import presets
    from .. import suite

    rng = np.random.default_rng(seed)
    folder = Path(folder or tempfile.mkdtemp())
    path = folder / "soak.blend"
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mat = bpy.data.materials.new("soak")
    mat.use_fake_user = True
    api.apply_stack(mat, suite.load("gold_coated"))
    last_valid = api.read_stack(mat)
    can_undo = bpy.ops.ed.undo.poll()
    samples, rejected, undone = [], 0, 0
    builtin = [p.id for p in presets.builtin()]
    for i in tqdm(range(1, edits + 1), desc="soak", disable=not progress):
        mat = bpy.data.materials["soak"]
        r = rng.random()
        try:
            if r < 0.1:
                api.apply_stack(mat, presets.find(str(rng.choice(builtin))).load())
            elif r < 0.2:
                d = draw_stack(rng, draw_structure(rng))
                if rng.random() < 0.3:  # an invalid value: refused, the material unchanged
                    d["base"]["roughness" if d["base"]["type"] != "diffuse" else "albedo"] = float(
                        rng.choice([-1.0, 2.0, math.nan, 1e300]))
                api.apply_stack(mat, d)
            elif r < 0.25 and can_undo:
                (bpy.ops.ed.undo if rng.random() < 0.5 else bpy.ops.ed.redo)()
                undone += 1
                mat = bpy.data.materials["soak"]
            else:
                s = mat.lamella
                if s.coats:
                    c = s.coats[int(rng.integers(len(s.coats)))].coat
                    field = str(rng.choice(["ior", "roughness", "thickness", "g"]))
                    value = {"ior": rng.uniform(1.0, 2.5), "roughness": rng.random(), "thickness": rng.uniform(0, 3),
                             "g": rng.uniform(-0.9, 0.9)}[field]
                    setattr(c, field, float(value))
                recompile.flush()
                recompile.flush_groups()
        except Exception as e:  # noqa: BLE001 - StackError expected for invalid input
            from lamella.core.stack import StackError

            if not isinstance(e, StackError):
                raise
            rejected += 1
        mat = bpy.data.materials["soak"]
        if mat.lamella.status == "OK":
            last_valid = api.read_stack(mat)
        if i % save_every == 0:
            recompile.flush()
            recompile.flush_groups()
            bpy.ops.wm.save_as_mainfile(filepath=str(path))
            bpy.ops.wm.open_mainfile(filepath=str(path))
            mat = bpy.data.materials["soak"]
            samples.append({"edit": i, "texts": len(bpy.data.texts), "images": len(bpy.data.images),
                            "node_groups": len(bpy.data.node_groups),
                            "unused_groups": len(bpy.data.node_groups) - len(_groups_used(mat.node_tree)),
                            "rss_mb": _rss_mb(),
                            "file_mb": path.stat().st_size / 2 ** 20})
    mat = bpy.data.materials["soak"]
    return {"edits": edits, "rejected": rejected, "undo_redo": undone, "undo_available": can_undo,
            "samples": samples, "shows_last_valid": api.read_stack(mat) == last_valid}


def _rss_mb() -> float:
    """The process's resident memory now (Linux), else its peak."""
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
        import os

        return pages * os.sysconf("SC_PAGE_SIZE") / 2 ** 20
    except (OSError, ValueError, IndexError):
        import resource

        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _groups_used(tree, found=None) -> set:
    """The node groups ``tree`` uses, nested ones included."""
    found = set() if found is None else found
    for n in tree.nodes:
        if n.bl_idname == "ShaderNodeGroup" and n.node_tree is not None and n.node_tree.name not in found:
            found.add(n.node_tree.name)
            _groups_used(n.node_tree, found)
    return found


def soak_ok(result: dict) -> bool:
    s = result["samples"]
    if not s:
        return result["shows_last_valid"]
    flat = all(x[k] == s[0][k] for x in s for k in ("texts", "images")) and all(x["unused_groups"] == 0 for x in s)
    late = [x["rss_mb"] for x in s[len(s) // 2:]]
    return flat and result["shows_last_valid"] and (max(late) - min(late) <= 0.1 * max(late))


# ---------------------------------------------------------------- the report
def write_report(out: Path, stacks: dict, grid: list | None, soaked: dict | None, command: str) -> Path:
    return write_page(out, "stress", lambda: _markdown(stacks, grid, soaked, command),
                      {"stacks": stacks, "grid": grid, "soak": soaked})


def _markdown(stacks: dict, grid: list | None, soaked: dict | None, command: str) -> str:
    lines = ["# Numerical stress", "", f"`{command}` (this machine). See `lamella_dev/bench/stress.py` for what is checked.", "",
             "## Random stacks", "",
             f"{stacks['stacks']:,} stacks over the schema's whole range, edges weighted ({EDGE_P:.0%} of fields at an "
             f"edge), batches of {stacks['per_structure']} per structure, {stacks['directions']} view directions each "
             f"(grazing and below the horizon included), seed {stacks['seed']}, {stacks['seconds']:.0f} s. A stack fails "
             "if any lobe energy, closure weight or argument is not finite, any energy or f cos is negative, or the "
             f"energies sum above 1 + {ALBEDO_SLACK[np.float32]:g} (float32) / 1 + {ALBEDO_SLACK[np.float64]:g} (float64).",
             "", "| model | float32 stacks | failing | largest albedo - 1 | float64 stacks | failing | largest albedo - 1 |",
             "|---|---|---|---|---|---|---|"]
    for m, s in stacks["models"].items():
        if not s["float32"][0]:
            lines.append(f"| {m} | 0 | - | - | 0 | - | - |  ")
            continue
        lines.append(f"| {m} | {s['float32'][0]:,} | {s['float32'][1]} | {s['float32'][2]:.1e} | {s['float64'][0]:,} | "
                     f"{s['float64'][1]} | {s['float64'][2]:.1e} |")
    lines += ["", f"Baked path (staged shader, float32): {stacks['staged'][0]:,} stacks, {stacks['staged'][1]} failing.",
              "", f"Failing stacks, shrunk: {len(stacks['failures'])} (kept in `tests/unit/stress_regressions.json`)."]
    if grid is not None:
        lines += ["", "## Render grid", "",
                  f"Extreme stacks (`stress.extreme_stacks`) in every engine; bound = brightest environment texel x "
                  f"(1 + {PIXEL_BOUND:g} / sqrt(samples)); white furnace: mean <= 1 + 3 standard errors.", "",
                  "| stack | engine | scene | NaN | Inf | negative | max | bound | over | mean | ok |",
                  "|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in grid:
            lines.append(f"| {r['case']} | {r['engine']} | {r['scene']} | {r['nan']} | {r['inf']} | {r['negative']} | "
                         f"{r['max']:.3f} | {r['bound']:.3f} | {r['over']} | {r['mean']:.4f} | {'yes' if grid_ok(r) else 'NO'} |")
    if soaked is not None:
        lines += ["", "## Soak", "",
                  f"{soaked['edits']} random edits on one material ({soaked['rejected']} invalid and refused, "
                  f"{soaked['undo_redo']} undo/redo{'' if soaked['undo_available'] else ': no undo stack in this session'}), "
                  f"saved and reloaded every {SOAK_SAVE_EVERY}. Shows the last valid stack: "
                  f"{'yes' if soaked['shows_last_valid'] else 'NO'}.", "",
                  "| after edit | texts | images | node groups (unused) | resident memory (MB) | file (MB) |",
                  "|---|---|---|---|---|---|"]
        for x in soaked["samples"]:
            lines.append(f"| {x['edit']} | {x['texts']} | {x['images']} | {x['node_groups']} ({x['unused_groups']}) | "
                         f"{x['rss_mb']:.0f} | {x['file_mb']:.2f} |")
    return "\n".join(lines)


def run(out=BENCH_DIR, quick: bool = False, stacks: int | None = None, blender: bool = True, progress: bool = True):
    """The whole stress run; returns (report path, whether everything passed)."""
    n = stacks or (QUICK_STACKS if quick else 1_000_000)
    per = 100 if quick else 5000
    result = random_stacks(n, per, progress=progress)
    grid = soaked = None
    if blender:
        grid = render_grid(32 if quick else 48, 8 if quick else 16, progress,
                           cases=["huge_extinction_mirror", "dense_thick_medium"] if quick else None)
        soaked = soak(100 if quick else SOAK_EDITS, 50 if quick else SOAK_SAVE_EVERY, progress=progress)
    cmd = "lamella stress" + (" --quick" if quick else "") + (f" --stacks {stacks}" if stacks else "")
    md = write_report(out, result, grid, soaked, cmd)
    if result["failures"]:
        _keep_regressions(result["failures"])
    ok = not result["failures"] and (grid is None or all(map(grid_ok, grid))) and (soaked is None or soak_ok(soaked))
    return md, ok


def _keep_regressions(failures: list) -> None:
    old = json.loads(REGRESSIONS.read_text()) if REGRESSIONS.exists() else []
    seen = {json.dumps(f["stack"], sort_keys=True) + f["model"] for f in old}
    for f in failures:
        key = json.dumps(f["stack"], sort_keys=True) + f["model"]
        if key not in seen:
            old.append(f)
            seen.add(key)
    REGRESSIONS.write_text(json.dumps(old, indent=1) + "\n")


__all__ = ["run", "random_stacks", "check_batch", "check_stack", "check_staged", "shrink", "render_grid", "soak",
           "extreme_stacks", "draw_stack", "draw_structure"]
