"""The `lamella` command (docs/design.md): lobes, plot, luts, references, bench, demo, render, export-osl,
export-presets, export-mtlx, apply, stack-format, stacks.

Every stack argument is a JSON file, a suite case, an example or a preset id (``lamella stacks``);
a bad stack prints the StackError (which names the layer and field) and exits with status 2.
Every option is checked as it is parsed (``arguments``), before any work: a mistake is one line
on stderr naming the option and what it allows, and exit status 2.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

from . import arguments as checked


class Parser(argparse.ArgumentParser):
    """argparse's parser (its subcommands' too), answering a mistake with one line,
    ``lamella <sub>: error: argument --x: what is allowed``, and exit status 2 (no usage)."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())}\n")


def _fail(message: str) -> SystemExit:
    print(f"lamella: {' '.join(message.split())}", file=sys.stderr)
    return SystemExit(2)


MAX_RESOLUTION = 16384  # pixels a side: Blender's own limit for a render's resolution


BLEND_MAGIC = (b"BLENDER", b"\x28\xb5\x2f\xfd", b"\x1f\x8b")  # a .blend as written, zstd- or gzip-compressed


def _is_blend(p: Path) -> bool:
    try:
        with open(p, "rb") as f:
            head = f.read(7)
    except OSError:
        return False
    return head.startswith(BLEND_MAGIC)


def _is_file(p: Path) -> bool:
    try:
        return p.is_file()
    except (OSError, ValueError):  # not a path at all (too long, a NUL)
        return False


def _model_names() -> list[str]:
    from lamella.core.models import MODELS

    return ["auto", *MODELS]


def _view_targets():
    from lamella.core.backends.osl.emit import VIEW_TARGETS

    return VIEW_TARGETS


def _budgets() -> list[str]:
    from lamella.core.backends.ir.lobe_budget import BUDGETS

    return [str(b) for b in BUDGETS]


def _table_names():
    from .luts_build import GENERATORS

    return GENERATORS


def _reference_cases() -> list[str]:
    """The stacks ``references`` and ``image-references`` compute: the suite and its pending cases."""
    from . import suite

    return suite.names() + list(suite.pending_descriptions())


def _reference_angles() -> tuple[float, ...]:
    from . import suite

    return suite.REFERENCE_ANGLES


def _stack_sources() -> dict:
    """Where a stack named on the command line comes from, in the order ``_load_stack`` looks:
    source -> {name: a function loading it}."""
    from lamella.core.presets import builtin
    from . import suite

    return {
        "suite": {name: (lambda name=name: suite.load(name)) for name in _reference_cases()},
        "example": {p.stem: (lambda stem=p.stem: suite.example(stem)) for p in sorted(suite.EXAMPLE_DIR.glob("*.json"))},
        "preset": {preset.id: preset.load for preset in builtin()},
    }


SOURCE_LABELS = {"suite": "suite case", "example": "example", "preset": "preset"}


def _stack_names() -> dict[str, str]:
    """Every stack a command takes by name (besides a JSON file's path), with where it comes from;
    a name two sources hold as different stacks is listed with its prefix (``preset:NAME``)."""
    sources = _stack_sources()
    held: dict[str, list[str]] = {}
    for source, names in sources.items():
        for name in names:
            held.setdefault(name, []).append(source)
    out = {}
    for name, where in held.items():
        stacks = [sources[source][name]().to_dict() for source in where] if len(where) > 1 else []
        if any(s != stacks[0] for s in stacks[1:]):
            out.update({f"{source}:{name}": SOURCE_LABELS[source] for source in where})
        else:
            out[name] = SOURCE_LABELS[where[0]]
    return out


def _load_stack(arg: str):
    """The stack ``arg`` names: a JSON file's path, else a suite case, an example or a preset id
    (``suite:``, ``example:`` or ``preset:`` before the name says which, where two of them hold
    different stacks of one name)."""
    from lamella.core import Stack, StackError

    p = Path(arg)
    try:
        if _is_file(p):
            try:
                text = p.read_text(encoding="utf-8")
            except (OSError, UnicodeDecodeError) as e:
                raise _fail(f"{p}: cannot read it ({e})") from None
            return Stack.from_json(text)
        sources = _stack_sources()
        source, _, name = arg.partition(":")
        if name and source in sources:
            if name in sources[source]:
                return sources[source][name]()
        else:
            found = {source: names[arg]() for source, names in sources.items() if arg in names}
            stacks = list(found.values())
            if stacks and all(s.to_dict() == stacks[0].to_dict() for s in stacks[1:]):
                return stacks[0]
            if stacks:
                which = " and ".join(f"the {SOURCE_LABELS[s]}" for s in found)
                raise _fail(f"{arg!r} names two different stacks, {which}: say "
                            + " or ".join(f"{s}:{arg}" for s in found))
    except StackError as e:
        raise _fail(f"{p}: {e}") from None
    shown = arg if len(arg) <= 80 else arg[:77] + "..."
    close = checked.close_names(arg, _stack_names())
    hint = f" (did you mean {' or '.join(map(repr, close))}?)" if close else ""
    raise _fail(f"no stack {shown!r}{hint}: a stack is a JSON file's path, a suite case, an example or a preset id; "
                "`lamella stacks` lists the names")


def cmd_stacks(a) -> int:
    """``lamella stacks``: every stack name the commands take, with where it comes from."""
    names = _stack_names()
    width = max(map(len, names))
    for name, where in names.items():
        print(f"{name:<{width}}  {where}")
    return 0


def cmd_lobes(a) -> int:
    from lamella.core import api
    from lamella.core.models import UnsupportedStack

    stack = _load_stack(a.stack)
    t, p = math.radians(a.wi), math.radians(a.phi)
    wi = np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])
    print(f"stack {stack.name or a.stack}: {len(stack.coats)} coat(s) over a {stack.base.type}; "
          f"wi = {a.wi:g} deg (azimuth {a.phi:g} deg)")
    for m in a.model or _model_names():
        try:
            lb = api.lobes(stack, wi, m)
        except UnsupportedStack as e:
            print(f"\n{m}\n  unsupported: {e}")
            continue
        print(f"\n{m}" + (f" (picked {lb.model} for this stack)" if m == "auto" else ""))
        print(f"  {'lobe':>4} {'kind':<12} {'weight R':>9} {'G':>8} {'B':>8} {'alpha_x':>8} {'alpha_y':>8} {'rot(deg)':>9}")
        for k in range(lb.weight.shape[1]):
            w = lb.weight[0, k]
            print(f"  {k:>4} {lb.kinds[k]:<12} {w[0]:9.5f} {w[1]:8.5f} {w[2]:8.5f} "
                  f"{lb.alpha_x[0, k]:8.5f} {lb.alpha_y[0, k]:8.5f} {math.degrees(lb.rotation[0, k]):9.2f}")
        tot = lb.weight[0].sum(0)
        print(f"  {'sum':>4} {'':<12} {tot[0]:9.5f} {tot[1]:8.5f} {tot[2]:8.5f}")
    return 0


def cmd_plot(a) -> int:
    from .plots import plot_stack

    stack = _load_stack(a.stack)
    out = a.out or Path(f"out/{stack.name or Path(a.stack).stem}_slices.png")
    t0 = time.time()
    plot_stack(stack, out, spp=a.spp, thetas=a.wi)
    print(f"wrote {out} ({time.time() - t0:.1f} s)")
    return 0


def cmd_luts(a) -> int:
    from lamella.core import luts

    from .luts_build import GENERATORS, generate

    out = a.out or luts.DATA_DIR
    if a.only:
        generators = {GENERATORS[n] for n in a.only}
        made = {n for n in GENERATORS if GENERATORS[n] in generators}  # a generator may make several tables
        if set(luts.SPECS) - made and not _is_file(out / luts.NPZ_FILE):
            raise _fail(f"luts: --only keeps the other tables from {out / luts.NPZ_FILE}, which does not exist; "
                        "leave --only out to generate every table there")
    t0 = time.time()
    for p in luts.write_tables(generate(a.only), out):
        print(f"wrote {p}")
    print(f"{time.time() - t0:.1f} s")
    return 0


def cmd_references(a) -> int:
    from .bench import accuracy

    cases = ",".join(a.cases or ())
    command = ("lamella references" + (f" --cases {cases}" if cases else "") + f" --spp {a.spp}"
               + f" --interfaces {a.interfaces}" + (f" --wi {','.join(f'{x:g}' for x in a.wi)}" if a.wi else ""))
    accuracy.compute_references(a.cases, spp=a.spp, out_dir=a.out, command=command, interfaces=a.interfaces,
                                angles=a.wi)
    return 0


def cmd_stress(a) -> int:
    from .bench import BENCH_DIR, stress

    if not a.no_blender:
        from lamella.blender import register

        register()
    md, ok = stress.run(a.out or BENCH_DIR, quick=a.quick, stacks=a.stacks, blender=not a.no_blender)
    print(md.read_text())
    print(f"wrote {md}")
    return 0 if ok else 1


def cmd_bench(a) -> int:
    """``lamella bench <name>``: the registered bench of that name (``lamella_dev.bench.registry``)
    writes its page into ``--out`` (default bench/); the page is printed."""
    from .bench import BENCH_DIR, BENCHES

    page = BENCHES[a.what].run(a.out or BENCH_DIR, a)
    print(page.read_text(encoding="utf-8"))
    data = page.with_suffix(".json")
    print(f"wrote {page}" + (f" and {data}" if data.is_file() else ""))
    return 0


def cmd_bench_list(a) -> int:
    """``lamella bench list``: every registered bench, one line each."""
    from .bench import BENCHES

    width = max(map(len, BENCHES), default=0)
    for name in sorted(BENCHES):
        print(f"{name:<{width}}  {BENCHES[name].description}")
    return 0


def _bench_parsers(p: argparse.ArgumentParser) -> None:
    """One subcommand per registered bench: its description as the help, ``--out``, and the
    options the bench declares (``Bench.arguments``)."""
    from .bench import BENCHES

    benches = p.add_subparsers(dest="what", required=True, metavar="NAME",
                               title="benchmarks (`lamella bench NAME --help`: its options)")
    q = benches.add_parser("list", help="every benchmark, one line each")
    q.set_defaults(fn=cmd_bench_list)
    for name in sorted(BENCHES):
        bench = BENCHES[name]
        text = bench.description.replace("%", "%%")  # argparse formats help text with %
        q = benches.add_parser(name, help=text, description=text)
        q.add_argument("--out", type=checked.output_dir(), help="the folder to write the page into (default: bench/)")
        if bench.arguments is not None:
            bench.arguments(q)
        q.set_defaults(fn=cmd_bench)


def cmd_export_osl(a) -> int:
    """Write the OSL bundle of a stack: the shader, the look-up tables it reads (``luts/``) and a
    README. An ``-o`` ending in ``.osl`` names the shader file (the bundle goes beside it);
    anything else is the bundle folder."""
    from lamella.core.backends.osl.bundle import bundle_files, write_bundle
    from lamella.core.models import UnsupportedStack, resolve

    stack = _load_stack(a.stack)
    try:
        resolve(a.model, stack)
    except ValueError as e:
        raise _fail(f"export-osl: {e}") from None
    out = a.out
    out_dir, file_name = (out.parent, out.name) if out.suffix.lower() == ".osl" else (out, None)
    live = [n for names in a.live for n in names]
    try:
        live = "all" if live == ["all"] else tuple(live)
        shader = write_bundle(stack, out_dir, model=a.model, target=a.target, file_name=file_name,
                              lut_dir=a.lut_dir, live=live, budget=a.budget)
    except (UnsupportedStack, ValueError) as e:
        raise _fail(f"export-osl: {e}") from None
    files = bundle_files(shader)
    lut_note = ("reads no table file" if len(files) == 2 else
                f"lut_dir defaults to {a.lut_dir!r}" if a.lut_dir else "lut_dir defaults to 'luts', relative")
    print(f"wrote {shader} ({len(shader.read_text().splitlines())} lines; view target {a.target}; {lut_note})")
    for f in files[1:]:
        print(f"wrote {f}")
    return 0


def cmd_export_presets(a) -> int:
    """Write the repository's generated folders from the built-in presets: ``osl/`` (every preset's
    OSL bundle for both view targets) and ``node_groups/`` (every preset's Lamella node as a node
    group in an asset library that renders without the extension, built by the oldest supported
    Blender's bpy: ``--blender-python``); ``--only`` one of them (``lamella_dev.preset_exports``)."""
    from . import preset_exports

    if a.only in (None, "osl"):
        shaders = preset_exports.write_osl(a.osl_out or preset_exports.OSL_DIR)
        print(f"wrote {len(shaders)} shaders and their READMEs into {shaders[0].parents[2]}")
    if a.only in (None, "node-groups"):
        out = a.node_groups_out or preset_exports.NODE_GROUPS_DIR
        try:
            path = preset_exports.write_node_groups(out, a.blender_python, previews=not a.no_previews)
        except (FileNotFoundError, RuntimeError) as e:
            raise _fail(f"export-presets: {e}") from None
        print(f"wrote {path} ({path.stat().st_size // 1024} kB) and its catalogs, manifest and README")
    return 0


def cmd_export_mtlx(a) -> int:
    """Write a stack as a MaterialX document: nested layers of standard closures, or with
    ``--openpbr`` one OpenPBR Surface (stacks of at most one coat); print what the export
    approximated or dropped (docs/materialx.md). Without ``-o`` the document goes to stdout and
    the warnings to stderr."""
    from lamella.core.backends.materialx import MaterialXUnsupported, layered_document, open_pbr_document

    stack = _load_stack(a.stack)
    try:
        export = open_pbr_document(stack) if a.openpbr else layered_document(stack)
    except MaterialXUnsupported as e:
        raise _fail(f"export-mtlx: {e}") from None
    note = sys.stdout
    if a.out:
        out = a.out
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(export.text, encoding="utf-8")
        print(f"wrote {out} (material {export.material!r}, {'OpenPBR Surface' if a.openpbr else 'MaterialX layers'})")
    else:
        sys.stdout.write(export.text)
        note = sys.stderr
    if export.warnings:
        print(f"{len(export.warnings)} approximated or dropped:", file=note)
        for w in export.warnings:
            print(f"  {w}", file=note)
    return 0


def cmd_apply(a) -> int:
    """Pipelines without a script: open a .blend, make one material show a stack (created if the
    file has no material of that name), save. The extension's own code does the work, exactly
    as ``apply_stack`` inside Blender."""
    stack = _load_stack(a.stack)
    import bpy

    from lamella.blender import api, register

    bpy.ops.wm.open_mainfile(filepath=str(a.blend))
    register()
    mat = bpy.data.materials.get(a.material)
    created = mat is None
    if created:
        mat = bpy.data.materials.new(a.material)
    try:
        api.apply_stack(mat, stack, model=a.model)
    except Exception as e:  # StackError, UnsupportedStack, a linked material: the message says which
        raise _fail(f"apply: {a.material}: {e}") from None
    out = a.out
    out.parent.mkdir(parents=True, exist_ok=True)
    if created:
        mat.use_fake_user = True  # a new material no object uses yet must survive the save
    bpy.ops.wm.save_as_mainfile(filepath=str(out.resolve()), copy=True)
    print(f"{'created' if created else 'updated'} material {mat.name!r} ({mat.lamella.picked_model}, "
          f"{len(stack.coats)} coat(s) over a {stack.base.type}) -> {out}")
    return 0


def cmd_render(a) -> int:
    from .render import render_stack

    stack = _load_stack(a.stack)
    out = a.out or Path(f"out/{stack.name or Path(a.stack).stem}_{a.scene}_{a.engine}.exr")
    out.parent.mkdir(parents=True, exist_ok=True)
    _, seconds = render_stack(stack, a.scene, sun_dir=a.sun_dir, res=a.res, spp=a.spp, engine=a.engine, out=out,
                              interfaces=a.interfaces)
    print(f"render time {seconds:.2f} s -> {out}")
    return 0


def cmd_image_references(a) -> int:
    from .bench import image_references as ir
    from . import suite

    if a.thickness is not None:
        for name in a.cases or suite.names():
            coats = len(suite.load(name).coats)
            if a.thickness * coats >= 0.5:
                raise _fail(f"image-references: --thickness {a.thickness:g} x {coats} coats of {name} must stay "
                            "below half the sphere's radius (0.5)")
    cases = ",".join(a.cases or ())
    command = "lamella image-references" + (f" --cases {cases}" if cases else "") + f" --spp {a.spp} --res {a.res}"
    if a.thickness is not None:
        command += f" --thickness {a.thickness}"
    if a.interfaces != "single":
        command += f" --interfaces {a.interfaces}"
    default = ir.IMAGE_REFERENCE_DIR_MULTIPLE if a.interfaces == "multiple" else ir.IMAGE_REFERENCE_DIR
    out = a.out or default
    if a.add:
        command = ir.load_index(out).get("command", command) + f"; refined by {command} --add"
    ir.compute(a.cases, res=a.res, spp=a.spp, out_dir=out, thickness=a.thickness, command=command, add=a.add,
               interfaces=a.interfaces)
    return 0


def cmd_demo(a) -> int:
    """The main job: render the demo stacks (the accuracy suite and the examples) with their
    generated OSL shaders in the canonical sphere-env scene, as EXR and PNG, plus a contact sheet;
    ``--plots`` adds BRDF slice plots against the stochastic reference."""
    from .render import render_stack
    from lamella.core.exr import write_rgba
    from . import suite
    from .image_metrics import display_srgb
    from .plots import contact_sheet, plot_stack

    out = a.out
    out.mkdir(parents=True, exist_ok=True)
    names = a.cases or ([f"suite:{n}" for n in suite.names()]
                        + sorted(f"example:{p.stem}" for p in suite.EXAMPLE_DIR.glob("*.json")))
    images, captions = {}, {}
    for qualified in names:
        stack = _load_stack(qualified)
        name = qualified.partition(":")[2] if qualified.startswith(("suite:", "example:", "preset:")) else qualified
        img, seconds = render_stack(stack, "sphere-env", res=a.res, spp=a.render_spp, engine="cycles-osl")
        write_rgba(out / f"{name}.exr", img)
        _write_png(out / f"{name}.png", display_srgb(img))
        images[name] = img
        captions[name] = f"{len(stack.coats)} coat(s), {seconds:.1f} s"
        print(f"wrote {out / name}.exr and .png ({seconds:.1f} s render)", flush=True)
        if a.plots:
            t0 = time.time()
            desc = suite.descriptions().get(name, name)
            p = plot_stack(stack, out / f"{name}_slices.png", spp=a.spp, title=f"{name}: {desc}")
            print(f"wrote {p} ({time.time() - t0:.1f} s)")
    sheet = contact_sheet(images, out / "contact_sheet.png", captions,
                          title=f"Lamella demo stacks, cycles-osl, sphere-env, {a.res} px, {a.render_spp} spp")
    print(f"wrote {sheet}")
    return 0


def _write_png(path: Path, rgb01: np.ndarray) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.imsave(path, np.ascontiguousarray(rgb01, dtype=np.float64))


def cmd_stack_format(args) -> int:
    from .stack_format_page import render, write

    if args.out:
        write(args.out)
        print(f"wrote {args.out}")
    else:
        print(render(), end="")
    return 0


def build_parser() -> argparse.ArgumentParser:
    ap = Parser(prog="lamella", description="Lamella layered materials: models, references, benchmarks")
    sub = ap.add_subparsers(dest="cmd", required=True)
    stack_help = "stack JSON file, suite case, example or preset id (`lamella stacks`)"
    model = checked.name("model", _model_names)

    p = sub.add_parser("lobes", help="print each model's lobe table for one incident direction")
    p.add_argument("stack", help=stack_help)
    p.add_argument("--wi", type=checked.angle(0.0, 90.0), required=True, help="incident zenith angle, degrees")
    p.add_argument("--phi", type=checked.angle(-360.0, 360.0), default=0.0,
                   help="incident azimuth from the tangent, degrees")
    p.add_argument("--model", type=model, action="append", help="model name (repeatable); default: all")
    p.set_defaults(fn=cmd_lobes)

    p = sub.add_parser("plot", help="PNG of BRDF slices of every model against the reference")
    p.add_argument("stack", help=stack_help)
    p.add_argument("-o", "--out", type=checked.output_file((".png", ".pdf", ".svg"), "a figure"),
                   help="the figure to write, .png, .pdf or .svg (default: out/<stack>_slices.png)")
    p.add_argument("--spp", type=checked.count(), default=512, help="reference walkers per direction")
    p.add_argument("--wi", type=checked.angles(0.0, 90.0), default="0,30,60,75", help="incident zenith angles, degrees")
    p.set_defaults(fn=cmd_plot)

    p = sub.add_parser("luts", help="regenerate the pre-integrated tables (EXR)")
    p.add_argument("--out", type=checked.output_dir(), help="output folder (default: the package's data/luts)")
    p.add_argument("--only", type=checked.names("table", _table_names),
                   help="comma-separated tables to generate again (the others kept from the folder's tables.npz)")
    p.set_defaults(fn=cmd_luts)

    p = sub.add_parser("references", help="compute and store the BRDF references of the accuracy suite")
    p.add_argument("--cases", type=checked.names("suite case", _reference_cases),
                   help="comma-separated suite cases (default: all)")
    p.add_argument("--spp", type=checked.count(), default=2048)
    p.add_argument("--wi", type=checked.angles(0.0, 90.0, only=_reference_angles()),
                   help="incidences in degrees (default: the suite's); others are added to the stored "
                        "references (45 is the one defined besides them)")
    p.add_argument("--interfaces", choices=("single", "multiple"), default="single",
                   help="rough interfaces scatter once (pbrt-v4) or on their microsurface until they leave "
                        "(Heitz et al. 2016; stored in tests/references/brdf_multiple)")
    p.add_argument("--out", type=checked.output_dir())
    p.set_defaults(fn=cmd_references)

    p = sub.add_parser("bench", help="benchmarks: each writes its page under bench/ (`lamella bench list`)")
    _bench_parsers(p)

    p = sub.add_parser("stress", help="numerical stress: a million random stacks, a render grid of extreme stacks, "
                                      "a soak of random edits (bench/stress.md)")
    p.add_argument("--quick", action="store_true", help="a thousand stacks, a small grid, a short soak")
    p.add_argument("--stacks", type=checked.count(),
                   help="how many random stacks (default: 1,000,000; --quick: 1,000)")
    p.add_argument("--no-blender", action="store_true", help="the random stacks only (no render grid, no soak)")
    p.add_argument("--out", type=checked.output_dir(), help="the folder to write stress.md into (default: bench/)")
    p.set_defaults(fn=cmd_stress)

    p = sub.add_parser("export-osl", help="write a self-contained OSL bundle for a stack: shader, tables, README")
    p.add_argument("stack", help=stack_help)
    p.add_argument("-o", "--out", required=True, type=checked.output_file_or_dir((".osl",), "the shader"),
                   help="FILE.osl (the bundle goes into its folder) or a bundle folder (created)")
    p.add_argument("--model", type=model, default="auto")
    p.add_argument("--target", type=checked.name("view target", _view_targets), default="cycles",
                   help="the renderer's convention for I: cycles (default; I points toward the viewer) or "
                        "osl-spec (the OSL specification: I points toward the surface)")
    p.add_argument("--lut-dir", type=checked.path_text("the tables' folder on the rendering machine"),
                   help="absolute folder of the EXR tables baked in as the shader's lut_dir "
                        "(default: 'luts', the bundle's copy, relative)")
    p.add_argument("--live", type=checked.identifiers("shader inputs"), action="append", default=[],
                   metavar="NAME[,NAME...]",
                   help="a shader input that stays an input (e.g. coat0_roughness, for a texture); 'all' for "
                        "every parameter; the others are baked into the shader's table (default: none)")
    p.add_argument("--budget", type=checked.name("lobe budget", _budgets), default="auto",
                   help="lobe budget: auto (default), all, or 1 to 8 closures")
    p.set_defaults(fn=cmd_export_osl)

    p = sub.add_parser("export-presets", help="write osl/ (every preset's OSL bundle, both targets) and node_groups/ "
                                              "(every preset's node group, an asset library that needs no extension)")
    p.add_argument("--only", choices=("osl", "node-groups"), help="write one of the two folders")
    p.add_argument("--osl-out", type=checked.output_dir(), help="the osl/ folder to write (default: the repository's)")
    p.add_argument("--node-groups-out", type=checked.output_dir(),
                   help="the node_groups/ folder to write (default: the repository's)")
    p.add_argument("--blender-python", type=checked.program("a Python with bpy"),
                   help="a Python whose bpy is the oldest supported Blender's, which saves the .blend "
                        "(default: the repository's .venv-bpy-4.2.23/bin/python, made by `make exports`)")
    p.add_argument("--no-previews", action="store_true", help="node groups without asset previews (faster)")
    p.set_defaults(fn=cmd_export_presets)

    p = sub.add_parser("export-mtlx", help="write a stack as a MaterialX document (nested layers of standard "
                                           "closures, or OpenPBR Surface) and print what it could not express")
    p.add_argument("stack", help=stack_help)
    p.add_argument("-o", "--out", type=checked.output_file((".mtlx",), "a MaterialX document"),
                   help="the .mtlx file to write (default: the document to stdout)")
    p.add_argument("--openpbr", action="store_true",
                   help="one open_pbr_surface instead of nested layers (stacks of at most one coat)")
    p.set_defaults(fn=cmd_export_mtlx)

    p = sub.add_parser("apply", help="make a material of a .blend show a stack and save the file (pipelines)")
    p.add_argument("stack", help=stack_help)
    p.add_argument("--blend", required=True, type=checked.input_file("a .blend file", _is_blend),
                   help="the .blend file to read")
    p.add_argument("--material", required=True, type=checked.text("a material's name"),
                   help="material name (created if the file has none of that name)")
    p.add_argument("-o", "--out", required=True, type=checked.output_file((".blend",), "a .blend file"),
                   help="the .blend file to write (may be the input)")
    p.add_argument("--model", type=model, default=None, help="force a model (default: the material's setting, auto)")
    p.set_defaults(fn=cmd_apply)

    p = sub.add_parser("render", help="render a stack into a canonical sphere scene (linear float EXR)")
    p.add_argument("stack", help=stack_help)
    p.add_argument("--scene", choices=["sphere-env", "sphere-sun", "white-furnace"], default="sphere-env",
                   help="white-furnace: uniform white world, each pixel shows the directional albedo")
    p.add_argument("--sun-dir", type=checked.direction(), default="0,-1,1",
                   help="world direction from the surface toward the sun, x,y,z")
    p.add_argument("--res", type=checked.count(MAX_RESOLUTION), default=96)
    p.add_argument("--spp", type=checked.count(), default=32)
    p.add_argument("--engine", choices=["cycles-osl", "cycles-nodes", "eevee", "principled", "eevee-principled",
                                        "reference"],
                   default="cycles-osl",
                   help="cycles-osl: the OSL shader; cycles-nodes: the node group in Cycles without OSL (as on a "
                        "GPU); eevee: the node group in EEVEE; principled: the closest Principled BSDF (eevee-principled: in "
                        "EEVEE); reference: "
                        "the stack as nested interface spheres, path traced (slow)")
    p.add_argument("--interfaces", choices=["single", "multiple"], default="single",
                   help="reference engine: rough interfaces scatter once, or keep the energy their microsurface "
                        "scatters again (Cycles' multiscatter GGX)")
    p.add_argument("--out", type=checked.output_file((".exr",), "a linear float EXR"),
                   help="the .exr file to write (default: out/<stack>_<scene>_<engine>.exr)")
    p.set_defaults(fn=cmd_render)

    p = sub.add_parser("image-references",
                       help="render and store the brute-force image references (nested interface spheres)")
    p.add_argument("--cases", type=checked.names("suite case", _reference_cases),
                   help="comma-separated suite cases (default: all)")
    p.add_argument("--spp", type=checked.count(), default=2048, help="total samples per pixel (two seeds of half each)")
    p.add_argument("--res", type=checked.count(MAX_RESOLUTION), default=128)
    p.add_argument("--thickness", type=checked.number(0.0, 0.5, lo_open=True, hi_open=True),
                   help="shell thickness per coat, a fraction of the radius (default 0.004)")
    p.add_argument("--out", type=checked.output_dir(), help="output folder (default: tests/references/images)")
    p.add_argument("--add", action="store_true", help="refine the stored references by --spp more samples")
    p.add_argument("--interfaces", choices=["single", "multiple"], default="single",
                   help="rough interfaces scatter once, or keep the energy their microsurface scatters again "
                        "(Cycles' multiscatter GGX; stored in tests/references/images_multiple)")
    p.set_defaults(fn=cmd_image_references)

    p = sub.add_parser("demo", help="the main job: render the demo stacks (EXR, PNG, contact sheet) into a folder")
    p.add_argument("--out", type=checked.output_dir(), default="out")
    p.add_argument("--cases", type=checked.names("stack", _stack_names),
                   help="comma-separated stacks (default: the suite and the examples)")
    p.add_argument("--res", type=checked.count(MAX_RESOLUTION), default=128)
    p.add_argument("--render-spp", type=checked.count(), default=64)
    p.add_argument("--plots", action="store_true", help="also write BRDF slice plots against the reference")
    p.add_argument("--spp", type=checked.count(), default=256, help="reference walkers per direction of the slice plots")
    p.set_defaults(fn=cmd_demo)

    p = sub.add_parser("stack-format", help="write the stack format's reference page (generated from the layer "
                                            "schema; docs/stack-format.md in the repository)")
    p.add_argument("-o", "--out", type=checked.output_file((".md",), "a Markdown page"),
                   help="the page to write (default: print it)")
    p.set_defaults(fn=cmd_stack_format)

    p = sub.add_parser("stacks", help="every stack name the commands take: suite cases, examples, preset ids")
    p.set_defaults(fn=cmd_stacks)
    return ap


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    return args.fn(args)


def run() -> None:
    """The ``lamella`` command: ``main``, then the process ends; as Blender ends when a command
    ran Blender (``lamella.blender.exit_process``)."""
    code = main()
    if "bpy" in sys.modules:
        from lamella.blender import exit_process

        exit_process(code)
    sys.exit(code)


if __name__ == "__main__":
    run()
