"""A self-contained OSL bundle of one stack, for taking the shader to another renderer.

``write_bundle`` writes into one folder:

* ``<shader>.osl``: the generated shader (``lamella.core.backends.osl.emit``), staged as Blender
  renders it (the view-only part a constant table inside the shader, lobes merged to the lobe
  budget) with the parameters named ``live`` left as inputs (``"all"``: every parameter) and no
  other input; with the view line of the target renderer (``osl.VIEW_TARGETS``: Cycles' ``I``
  points toward the viewer, the OSL specification's toward the surface); its ``lut_dir``
  parameter, present when a live part reads the global tables, defaults to ``"luts"``;
* ``luts/``: copies of exactly the EXR tables that shader reads (as the emitter records them, so a
  table the shader does not need is not copied);
* ``README.md``: what the shader is (model, stack), the view convention, the tables, the closures
  and a table of every shader parameter, described from the layer-kind schema
  (``lamella.core.layers``), so the descriptions are the ones the stack format documents.

Pure Python (no bpy): usable from the ``lamella`` command anywhere the package runs.
"""
from __future__ import annotations

import json
import shutil
from pathlib import Path

from ... import lobe_kinds, luts
from ...layers.schema import RGB, ROUGHNESS
from ...models import resolve
from ...stack import Stack
from ..ir.closures import trace_closures
from .emit import (
    VIEW_LINES,
    VIEW_TARGETS,
    OslShader,
    ShaderParam,
    _identifier,
    osl_shader,
)

TABLES_DIR = "luts"  # the bundle's table folder, and the shader's default lut_dir
README = "README.md"


# One line per table for the README (what the shader uses it for); the full account of each
# table, its axes and its generation is the docstring of lamella.core.luts.
_TABLE_ROLES = {
    "ggx_albedo": "GD, the directional albedo of a GGX lobe with F = 1: the lobe normaliser "
                  "(Randrianandrasana et al. 2021 Eq. 38)",
    "fresnel_hat_delta": "FGD of any Fresnel curve as a quadrature over Fresnel samples "
                         "(Randrianandrasana et al. 2021 Eq. 8), for conductors and dielectrics",
    "tir": "total-internal-reflection correction of a lobe refracted into a coat (Belcour 2018)",
    "ggx_refract_albedo": "directional albedo of the refracting GGX closure, the normaliser of the "
                          "transmission lobe",
    "dielectric_rough_reflect": "what a rough dielectric interface reflects after scattering more than once "
                             "on its microsurface (Heitz et al. 2016): the reflectance from inside a coat",
    "dielectric_trapped_escape": "how easily the light a rough interface reflects back into a coat comes "
                                 "through it again (Heitz et al. 2016's walk): light trapped under a coat",
    "coat_first_escape": "how much of the light a base reflects under one rough coat crosses it on its first "
                         "way up, for the view (random walks on both microsurfaces)",
    "coat_trapped_equilibrium": "how much of the light trapped between one rough coat and its base crosses it "
                                "per later round trip",
    "hg_backward_escape": "how much of the light a medium back-scatters once leaves through a coat's escape "
                          "cone, for the primary's tilt (the backward half of a Henyey-Greenstein lobe)",
    "hg_backward_cosine": "how steeply that back-scattered light goes up: the depth it crosses per unit path",
}


# ---------------------------------------------------------------- describing parameters
def _short(f) -> str:
    """A field's description; for a roughness, without the part after its colon, which describes
    the JSON form ("a number or [alpha_x, alpha_y]") rather than a shader input."""
    return f.description.split(":", 1)[0].strip() if f.type == ROUGHNESS else f.description


def _with_unit(text: str, unit: str) -> str:
    return f"{text} [{unit}]" if unit else text


def describe_parameter(param: ShaderParam, stack: Stack) -> str:
    """What a shader input is: for a layer input, its layer, the field's description in its layer
    kind's schema (the stack format's own words) and its unit (a colour is one input for the three
    channels; a roughness is Blender's r: ``core.backends.sockets``), read from what the input is
    (``ShaderParam.socket``), not from its name."""
    fixed = {
        "Normal": "shading normal (default: the renderer's N)",
        "Tangent": "x axis of the anisotropic layers' roughness and rotation, projected onto the "
                   "normal's plane; zero (default) uses the direction of a turn about the z axis "
                   "through P, i.e. vector(-P[1], P[0], 0)",
        "lut_dir": "folder of the EXR look-up tables, read with texture() (see Look-up tables)",
        "BSDF": "output: the layered material's closure, a sum of weighted lobes (see Closures)",
    }
    sk = param.socket
    if sk is None:
        return fixed.get(param.name, "shader input")
    if sk.layer is None:
        layer, where = stack.base, f"base ({stack.base.type})"
    else:
        layer, where = stack.coats[sk.layer], f"coat {sk.layer}" + (" (top)" if sk.layer == 0 else "")
    f = next(f for f in layer.kind.fields if f.name == sk.field)
    if f.type == ROUGHNESS:
        text = _short(f).replace("GGX alpha", "roughness")
        text += {"": ", isotropic", "x": " along the tangent (x)", "y": " along the bitangent (y)"}[sk.axis]
        return f"{where}: {text} [Blender roughness r; GGX alpha = r * r]"
    colour = ", a colour (one input for the red, green and blue channels)" if f.type == RGB else ""
    return f"{where}: {_with_unit(_short(f), f.unit)}{colour}"


# ---------------------------------------------------------------- the README
def _stack_json(stack: Stack) -> str:
    """The stack as JSON that ``lamella`` reads back, one layer per line."""
    d = stack.to_dict()
    layers = ",\n".join(f"    {json.dumps(layer)}" for layer in d["layers"])
    return "\n".join(["{", f'  "name": {json.dumps(d["name"])},',
                       '  "layers": [' + (f"\n{layers}\n  ]," if layers else "],"),
                       f'  "base": {json.dumps(d["base"])}', "}"])


def _layer_order(param: ShaderParam) -> tuple[int, int]:
    """Coats from the top, then the base, then the inputs every shader has (stable within)."""
    sk = param.socket
    if sk is None:
        return (2, 0)
    return (1, 0) if sk.layer is None else (0, sk.layer)


def _view_section(target: str) -> list[str]:
    line = VIEW_LINES[target].strip()
    if target == "cycles":
        why = ("Blender's Cycles convention: the global `I` points from the shading point toward the "
               "viewer, so the shader uses it as it is. Use this target in Blender's Script node (or "
               "any renderer with the same convention).")
    else:
        why = ("The OSL specification's convention: `I` is the incident ray direction, pointing toward "
               "the surface, so the shader negates it. Use this target in renderers that follow the "
               "specification.")
    return [
        "## View convention",
        "",
        f"Target `{target}`: `{line}`",
        "",
        why,
        "",
        "`V` is the unit vector toward the viewer; it is the only line that differs between the "
        f"targets ({', '.join(f'`{t}`' for t in VIEW_TARGETS)}). If the material renders black or "
        "inside-out, the renderer uses the other convention: export again with "
        "`lamella export-osl ... --target <other>`.",
        "",
    ]


def _tables_section(files: list[str], lut_default: str) -> list[str]:
    if not files:
        return ["## Look-up tables", "",
                "The shader reads no file: what it needs of Lamella's look-up tables is baked into its own table "
                "(the constant array `MT`, read by the view's elevation).", ""]
    by_file = {s.file: (s.name, s.shape, f"one channel ({s.channel})") for s in luts.SPECS.values()}
    for name, f in luts.PACKED.items():
        by_file[f] = (name, luts.SPECS[name].shape, "RGBA: four slices of the last axis per texel")
    out = [
        "## Look-up tables",
        "",
        f"The shader reads {len(files)} float EXR table{'s' if len(files) != 1 else ''} with `texture()`, "
        f"at `lut_dir + \"/<file>\"`; the parameter `lut_dir` defaults to `\"{lut_default}\"`.",
        "",
    ]
    if not Path(lut_default).is_absolute():
        out += [
            "OSL texture paths are resolved by the renderer, typically relative to its working directory or "
            "its texture search path, not to the shader file. When in doubt, set `lut_dir` to the absolute "
            f"path of the `{TABLES_DIR}/` folder of this bundle.",
            "",
        ]
    out += ["Each file holds its atlas twice, mirrored top to bottom in its lower half, and the shader reads "
            "an atlas row at half its `t`: the same texel whether the renderer counts `t` from the file's "
            "first row (OpenImageIO's texture system, Blender up to 5.0) or from its last (Cycles from "
            "Blender 5.1).", ""]
    out += ["| file | table | shape | layout | used for |", "|---|---|---|---|---|"]
    for f in files:
        name, shape, layout = by_file.get(f, (f, (), ""))
        layout += ", slices stacked vertically" if len(shape) == 3 else ""
        role = _TABLE_ROLES.get(name, "see lamella.core.luts")
        out.append(f"| `{TABLES_DIR}/{f}` | `{name}` | {' x '.join(map(str, shape))} | {layout} | {role} |")
    out += ["", "Tables are node-centred and read with linear interpolation, clamped at the edges "
            "(`lamella/data/osl/lamella_luts.h`, inlined in the shader).", ""]
    return out


def _closures_section(shader: OslShader) -> list[str]:
    closures = sorted({c.function for c in shader.closures})
    st = shader.staged
    merged = (f" The model emits {st.lobes_all} lobes; the lobe budget (`{st.budget}`) merged them into "
              f"{len(st.closures)} closures." if st is not None else "")
    out = ["## Closures", "",
           "`BSDF` is a sum of closures, each a standard-library closure with a colour weight, skipped where "
           f"its weight is zero.{merged}", ""]
    for k, c in enumerate(shader.closures):
        out.append(f"- closure {k}, `{c.kind}` ({c.label}): {lobe_kinds.kind(c.kind).description}")
    out += [
        "",
        f"Closures called: {', '.join(f'`{c}`' for c in closures)} (as declared in `stdosl.h`). A lobe's "
        "weight is its energy times the closure's normaliser; for GGX that is 1 / GD, the directional "
        "albedo of a single-scattering GGX closure with height-correlated Smith masking (Heitz 2014; "
        "Randrianandrasana et al. 2021 Eq. 37), which is what Cycles' `microfacet(\"ggx\", ...)` reflects. "
        "A renderer whose GGX closure adds multiple-scattering energy, or uses another masking term, "
        "renders the lobes slightly brighter or darker.",
        "",
    ]
    return out


def readme(stack, shader: OslShader, model_name: str, target: str, shader_file: str, picked: bool = False) -> str:
    """The README of a bundle: ``shader`` (as written to ``shader_file``) of ``stack`` under the
    model ``model_name`` (``picked``: chosen by "auto"), for the view ``target``."""
    stack = Stack.coerce(stack)
    name = shader.name
    params = list(shader.declared)
    lut_default = next((p.default.strip('"') for p in params if p.name == "lut_dir"), TABLES_DIR)
    n = len(stack.coats)
    layers = f"{n} coat{'s' if n != 1 else ''} over a {stack.base.type} base"
    lines = [
        f"# `{name}`: Lamella layered material as an OSL shader",
        "",
        f"`{shader_file}` renders the layered stack `{stack.name or 'stack'}` ({layers}) with Lamella's "
        f"`{model_name}` model{' (picked by `auto` for this structure)' if picked else ''}, as one straight-line OSL "
        "surface shader. It was "
        "generated by `lamella export-osl`: regenerate it rather than editing it.",
        "",
        "Compile with `oslc " + shader_file + "` (it includes `stdosl.h`, which `oslc` supplies); connect "
        "the output `BSDF` as the surface closure.",
        "",
        "Stack (coats top to bottom; `lamella` reads this JSON back):",
        "",
        "```json",
        _stack_json(stack),
        "```",
        "",
        *_view_section(target),
        *_tables_section(list(shader.tables), lut_default),
        *_closures_section(shader),
        "## Parameters",
        "",
        "Every input and the output of the shader, layer by layer from the top coat. Defaults are the "
        "stack's values; the layer "
        "parameters are the fields of the stack format (coat 0 is the top coat), in the units of Blender's "
        "own BSDFs: roughness inputs (`*_roughness`, `*_roughness_x`, `*_roughness_y`) are Blender's "
        "roughness r (GGX alpha = r * r), an RGB field is one `color` input, rotations are in radians. Whether a layer is anisotropic, absorbing or scattering is part of "
        "the shader's structure. " + _live_note(shader),
        "",
        "| name | type | default | description |",
        "|---|---|---|---|",
    ]
    for p in sorted(params, key=_layer_order):
        t = f"output {p.type}" if p.output else p.type
        lines.append(f"| `{p.name}` | {t} | `{p.default}` | {describe_parameter(p, stack)} |")
    lines.append("")
    return "\n".join(lines)


def _live_note(shader: OslShader) -> str:
    every = [sk.name for sk in shader.sockets]
    baked = sorted(set(every) - set(shader.live_sockets))
    if not baked:
        return "Every layer input is a shader input (none is baked)."
    return (f"{len(baked)} of the {len(every)} layer inputs are baked into the shader's table "
            "(their values are the stack's above); to make one an input, export again with "
            "`lamella export-osl ... --live NAME` (or `--live all`).")


# ---------------------------------------------------------------- the bundle
def write_bundle(stack, out_dir, model: str = "auto", target: str = "cycles", *, file_name: str | None = None,
                 lut_dir: str | Path | None = None, live=(), budget="auto") -> Path:
    """Write the bundle of ``stack`` into ``out_dir`` (created) and return the shader's path.

    ``target``: the view convention (``osl.VIEW_TARGETS``); ``file_name``: the shader file's name
    (default ``lamella_<stack name>.osl``); the shader is named after its stem, as ``oslc`` names
    the compiled ``.oso`` after the shader; ``live``: the parameters that stay inputs (names, or
    ``"all"``), the others baked into the shader's table; ``budget``: the lobe budget
    (``lobe_budget.BUDGETS``); ``lut_dir``: the default of the shader's ``lut_dir`` parameter
    (default ``"luts"``, the bundle's own table folder, relative). The tables the shader reads are
    copied into ``out_dir/luts`` whatever ``lut_dir`` is. Files already in ``out_dir`` that the
    bundle does not write are left alone."""
    if target not in VIEW_TARGETS:
        raise ValueError(f"unknown target {target!r}: expected one of {', '.join(VIEW_TARGETS)}")
    stack = Stack.coerce(stack)
    out_dir = Path(out_dir)
    if file_name is None:
        name = _identifier(f"lamella_{stack.name or 'stack'}")
        file_name = f"{name}.osl"
    else:
        name = _identifier(Path(file_name).stem)
    model_name = resolve(model, stack).name
    if live == "all":
        live = tuple(trace_closures(stack, model).tracer.params)  # every parameter, so every socket
    shader = osl_shader(stack, model, name, lut_dir if lut_dir else TABLES_DIR, target, tuple(live), budget,
                        declare="live")
    missing = [f for f in shader.tables if not (luts.DATA_DIR / f).exists()]
    if missing:
        raise FileNotFoundError(f"look-up tables {', '.join(missing)} are missing from {luts.DATA_DIR}: "
                                "run `lamella luts` to generate them")
    if shader.tables:
        (out_dir / TABLES_DIR).mkdir(parents=True, exist_ok=True)
    out_dir.mkdir(parents=True, exist_ok=True)
    for f in shader.tables:
        shutil.copyfile(luts.DATA_DIR / f, out_dir / TABLES_DIR / f)
    shader_path = out_dir / file_name
    shader_path.write_text(shader.source)
    (out_dir / README).write_text(readme(stack, shader, model_name, target, file_name, picked=model == "auto"))
    return shader_path


def bundle_files(shader_path: Path) -> list[Path]:
    """The files of the bundle whose shader is ``shader_path``: the shader, the README and the
    tables beside it."""
    shader_path = Path(shader_path)
    tables = sorted((shader_path.parent / TABLES_DIR).glob("*.exr"))
    return [shader_path, shader_path.parent / README] + tables


__all__ = ["write_bundle", "bundle_files", "readme", "describe_parameter", "ShaderParam", "TABLES_DIR", "README",
           "VIEW_TARGETS"]
