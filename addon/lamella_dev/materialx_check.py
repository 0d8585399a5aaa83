"""The exported MaterialX documents checked with MaterialX's own tools, and rendered through them.

- ``validate``: the document read by PyMaterialX (the ``materialx`` package from PyPI), the
  standard data libraries imported (``loadLibraries`` from the package's ``libraries`` folder),
  ``Document.validate()``.
- ``generate_osl``: OSL source from MaterialX's OSL generator (``OslShaderGenerator``, target
  ``genosl``). MaterialX 1.39's genosl implementations call the MaterialX closures of the OSL
  specification (``dielectric_bsdf``, ``conductor_bsdf``, ``generalized_schlick_bsdf``,
  ``oren_nayar_diffuse_bsdf``, ``sheen_bsdf``, ``layer``), which Cycles implements
  (``intern/cycles/kernel/osl/closures_setup.h`` in Blender's sources; ``layer`` scales the base by
  one minus the top's directional albedo). The generated code includes MaterialX's headers
  (``libraries/stdlib/genosl/include``): they are inlined, so the source compiles anywhere and
  travels whole in a Script node; their ``#pragma once`` lines are dropped, because Blender 5.2's
  compiler crashes on a ``#pragma once`` in the main file. MaterialX's world tangent in genosl is
  ``normalize(dPdu)``, which Cycles gives per triangle; ``tangent="radial"`` puts the canonical
  scenes' tangent (radial about world z, docs/design.md) in its place, the one Lamella's own
  shader falls back to, so the two renders share a frame.
- ``assign``: a Script node running that source on the canonical sphere (bpy; Cycles with OSL).

PyMaterialX and Blender's bundled MaterialX coexist in one process here (checked with bpy 5.2.3 and
materialx 1.39.4 in either import order).
"""
from __future__ import annotations

import re
from pathlib import Path

from lamella.core.backends.materialx import MaterialXExport

TWORLD = "normalize(dPdu)"  # MaterialX 1.39 genosl: IM_tangent_vector3_genosl
RADIAL_TANGENT = "normalize(vector(-P[1], P[0], 0.0))"
OUTPUT = "out"  # the generated shader's closure output (the surfacematerial's)


def _mx():
    import MaterialX as mx

    return mx


def package_dir() -> Path:
    """The installed MaterialX package: its ``libraries`` folder is the standard data library."""
    return Path(_mx().__file__).resolve().parent


def include_dir() -> Path:
    return package_dir() / "libraries" / "stdlib" / "genosl" / "include"


_STDLIB = None


def standard_libraries():
    """The standard data libraries (stdlib, pbrlib, bxdf incl. open_pbr_surface, ...), loaded once."""
    global _STDLIB
    if _STDLIB is None:
        mx = _mx()
        lib = mx.createDocument()
        mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.FileSearchPath(str(package_dir())), lib)
        _STDLIB = lib
    return _STDLIB


def load(text: str):
    """The document of ``text`` with the standard libraries as its data library (referenced, not
    copied into it)."""
    mx = _mx()
    doc = mx.createDocument()
    mx.readFromXmlString(doc, text)
    doc.setDataLibrary(standard_libraries())
    return doc


def validate(text: str) -> tuple[bool, str]:
    """``Document.validate()`` of the document with the standard libraries, and every node
    resolved to a node definition (``validate`` lets a node of an unknown category pass):
    (valid, messages)."""
    mx = _mx()
    doc = load(text)
    ok, message = doc.validate()
    unknown = [f"No node definition for <{e.getCategory()} name=\"{e.getName()}\">" for e in doc.traverseTree()
               if e.isA(mx.Node) and e.getNodeDef() is None]
    return bool(ok) and not unknown, message + "".join(f"{u}\n" for u in unknown)


def inline_includes(source: str, folder: Path | None = None) -> str:
    """``source`` with every ``#include "X"`` found in ``folder`` (MaterialX's genosl headers)
    replaced by the file, recursively and once each; ``#pragma once`` dropped. Includes not found
    there (``stdosl.h``) stay."""
    folder = Path(folder or include_dir())
    seen: set[str] = set()

    def expand(text: str) -> str:
        def one(m):
            name = m.group(1)
            path = folder / name
            if not path.is_file():
                return m.group(0)
            if name in seen:
                return f"// {name}: inlined above"
            seen.add(name)
            body = re.sub(r"^\s*#pragma\s+once\s*$", "", path.read_text(), flags=re.M)
            return f"// ---- {name} (MaterialX {_mx().__version__}, inlined)\n{expand(body)}\n// ---- end of {name}"

        return re.sub(r'^[ \t]*#include\s+"([^"]+)"[ \t]*$', one, text, flags=re.M)

    return expand(source)


def generate_osl(export: MaterialXExport, tangent: str = "world") -> str:
    """OSL source of ``export``'s material from MaterialX's OSL generator, includes inlined.
    ``tangent="radial"`` replaces MaterialX's world tangent by the canonical scenes' radial one
    (module docstring). Raises ValueError if the document does not validate."""
    from MaterialX import PyMaterialXGenOsl as mx_osl
    from MaterialX import PyMaterialXGenShader as mx_gen

    mx = _mx()
    doc = load(export.text)
    ok, message = doc.validate()
    if not ok:
        raise ValueError(f"the MaterialX document of {export.material} does not validate: {message}")
    material = doc.getChild(export.material)
    if material is None:
        raise ValueError(f"no element {export.material!r} in the document")
    gen = mx_osl.OslShaderGenerator.create()
    context = mx_gen.GenContext(gen)
    context.registerSourceCodeSearchPath(mx.FileSearchPath(str(package_dir())))
    shader = gen.generate(export.material, material, context)
    source = inline_includes(shader.getSourceCode(mx_gen.PIXEL_STAGE))
    if tangent == "radial":
        if "geomprop_Tworld" in source:
            if TWORLD not in source:
                raise ValueError(f"the generated shader builds its world tangent without {TWORLD}: the radial "
                                 "substitution needs updating for this MaterialX")
            source = source.replace(TWORLD, RADIAL_TANGENT)
    elif tangent != "world":
        raise ValueError(f"tangent must be 'world' or 'radial', got {tangent!r}")
    return source


def assign(sphere, export: MaterialXExport, tangent: str = "radial"):
    """A material on ``sphere`` whose Script node runs MaterialX's OSL for ``export``
    (compiled by Blender's compiler, ``lamella.blender.osl_compile``); returns the material."""
    import bpy

    from lamella.blender.osl_compile import assign_script

    from .render import sphere_material

    mat, nt, out = sphere_material(sphere, f"materialx_{export.material}")
    node = nt.nodes.new("ShaderNodeScript")
    name = f"materialx_{export.material}.osl"
    assign_script(node, bpy.data.texts.new(name), generate_osl(export, tangent), name)
    if OUTPUT not in node.outputs:
        raise RuntimeError(f"the MaterialX shader of {export.material} has no {OUTPUT!r} output: "
                           f"{[s.name for s in node.outputs]}")
    nt.links.new(node.outputs[OUTPUT], out.inputs["Surface"])
    return mat


def render(stack, variant: str = "layered", scene: str = "sphere-env", res: int = 64, spp: int = 16, seed: int = 0):
    """Render ``stack`` through MaterialX (``variant`` "layered" or "openpbr") in a canonical scene:
    (RGBA float32, top row first; render seconds; the export)."""
    from lamella.core.backends.materialx import layered_document, open_pbr_document

    from .render import build_scene, render_scene

    export = {"layered": layered_document, "openpbr": open_pbr_document}[variant](stack)
    sc, sphere = build_scene(scene, res, spp, seed=seed)
    assign(sphere, export)
    px, seconds = render_scene(sc)
    return px, seconds, export
