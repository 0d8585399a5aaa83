"""MaterialX export of a stack: a layered document of standard closures, and an OpenPBR Surface
where the stack fits that model.

Two documents, both MaterialX 1.39 XML written with the standard library (the shipped extension
needs no MaterialX package; ``lamella_dev.materialx_check`` validates them with PyMaterialX):

``layered_document(stack)``
    A shading node of the stack's own (a ``nodedef`` with a ``nodegraph`` implementation, output
    ``surfaceshader``), instanced by a ``surfacematerial``. Inside, every coat is one vertical
    ``layer`` (MaterialX Physically Based Shading Nodes specification v1.39, "layer"): its top a
    reflection-only ``dielectric_bsdf`` (ibid., "dielectric_bsdf"), its base everything below it.
    The base is a ``conductor_bsdf`` (complex index), an ``oren_nayar_diffuse_bsdf`` of roughness 0
    (Lambertian, ibid.) or a reflecting and transmitting ``dielectric_bsdf``. Every layer has a
    normal and a tangent input of its own on the node (``coat0_normal``, ``coat0_tangent``, ...,
    ``base_normal``, ``base_tangent``; default the world normal and tangent), so a normal map or a
    flow map reaches one layer only. GGX alphas go to the closures' ``roughness`` vector2 as they
    are (x along the tangent); a layer's ``rotation`` turns its tangent about its normal,
    ``cos(r) T + sin(r) (N x T)``, built from ``crossproduct``/``multiply``/``add``/``normalize``
    (counterclockwise about the normal, as Lamella's shaders turn it). A coat on part of the
    surface (``coverage`` below 1) is a ``mix`` (ibid., "mix") of its layer and what is under it,
    by a ``coat0_coverage`` input on the node (its value the stack's; a mask connects there):
    the spatial mix Lamella's coverage is, exact because ``layer`` is linear in its base. A layer's
    thin film is its closure's ``thinfilm_thickness`` (nm) and ``thinfilm_ior`` (ibid.), evaluated
    under the medium outside the surface.

``open_pbr_document(stack)``
    One ``open_pbr_surface`` (OpenPBR Surface specification v1.1) for a stack of at most one coat:
    ``coat_*`` from the coat (``coat_color`` is the square of the coat's normal-incidence
    transmittance, ibid. "Coat"), the base as metal (F0 and the F82 tint of the "F82-tint" model,
    Kutz et al. 2021, from the exact Fresnel of the metal under the coat), Lambertian diffuse
    (``specular_weight`` 0) or transmission (``transmission_weight`` 1). Roughness pairs map to
    ``roughness`` and ``roughness_anisotropy`` by the specification's alpha_t = r^2
    sqrt(2 / (1 + (1 - a)^2)), alpha_b = (1 - a) alpha_t ("Microfacet model"); an alpha_y above
    alpha_x turns the tangent by a quarter turn. ``open_pbr_fit`` says why a stack does not fit.

What the export approximates (each occurrence is reported in ``warnings``, naming the layer and
the field, as ``StackError`` names them):

- the indices: MaterialX gives an interface one index, relative to the medium above the surface,
  and evaluates every layer with the outside directions. A coat under another gets its index
  relative to the coat above (``ior / n_above``), a conductor base ``(eta + i k) / n_above``; a
  relative index below 1 over a coat of absolute index >= 1 is exported as its reciprocal (the
  same normal-incidence reflectance), because at unrefracted directions it would reflect
  everything past a critical angle that no light arriving from above reaches;
- the light coats send back to a Lambertian base (internal reflection, total internal
  reflection): the base is multiplied by the constant ``diffuse_darkening`` (OpenPBR's coat
  darkening, computed at export), not followed;
- absorption (``sigma_a``, ``thickness``): the layers below a coat are multiplied by its round
  trip along the normal, exp(-2 sigma_a thickness) (OpenPBR's ``coat_color``); the longer path at
  oblique incidence is lost (a view-dependent tint would need the view direction, whose OSL
  implementation reads ``I``, which Cycles points the other way).

What MaterialX cannot express (dropped, and reported):

- scattering media between layers (``sigma_s``, ``g``): the VDF a ``layer`` may hold is the
  interior of a closed object, without a thickness; a scattering slab between two interfaces has
  no node;
- the energy of multiple scattering on a rough metal's microsurface: the closures' one
  distribution is single-scattering ``ggx`` (Cycles' ``multi_ggx`` is not a MaterialX value),
  while Lamella keeps it (Turquin 2019's compensation);
- the statistical coupling of the layers: ``layer`` is albedo scaling (the base times one minus
  the top's directional albedo, MaterialX PBS specification v1.39, "layer"); no refraction of
  directions into a coat, no inter-reflection or total internal reflection between interfaces,
  no widening of a lower lobe by a rough coat above it (the adding-doubling statistics of
  Belcour 2018 and Weier and Belcour 2020 that Lamella's models compute). OpenPBR approximates
  two of these for its one coat (base roughening and coat darkening, OpenPBR v1.1 "Coat").
"""
from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass

from ..models import fresnel
from ..param_id import layer_label, layer_prefix
from ..stack import Stack
from .numpy_ops import NumpyOps

_OPS = NumpyOps()  # float64, for the few values the export computes

MATERIALX_VERSION = "1.39"
COLORSPACE = "lin_rec709"  # Lamella's RGB triples are linear Rec.709 (Blender's scene linear)
OPEN_PBR_EDGE_MU = 1.0 / 7.0  # the F82-tint model's edge cosine (OpenPBR v1.1, "Metal")


class MaterialXUnsupported(ValueError):
    """The stack holds something the export has no MaterialX form for (the message names the
    layer)."""


class OpenPBRMismatch(MaterialXUnsupported):
    """The stack has a structure OpenPBR Surface cannot hold (more than one coat)."""


# The layer kinds the export maps, each by its own physics (like the stochastic reference, the
# export knows every kind it writes; a kind registered later is refused, not guessed at).
MAPPED_KINDS = {"coat": ("coat",), "base": ("conductor", "diffuse", "dielectric")}


def check_kinds(stack: Stack) -> None:
    """Raise ``MaterialXUnsupported`` naming the first layer of a kind the export does not map."""
    for where, role, layer in [*((f"coat {i}", "coat", c) for i, c in enumerate(stack.coats)),
                               ("base", "base", stack.base)]:
        if layer.type not in MAPPED_KINDS[role]:
            raise MaterialXUnsupported(f"{where}: no MaterialX form for {layer.type!r} layers (the export maps "
                                       f"{', '.join(MAPPED_KINDS[role])})")


@dataclass(frozen=True)
class MaterialXExport:
    """A MaterialX document (``text``, XML) and what the export approximated or dropped
    (``warnings``: "coat 1, field 'sigma_s': ..."). ``material`` names its surfacematerial."""

    text: str
    warnings: tuple[str, ...]
    material: str


# ----------------------------------------------------------------------------- values and names
def _num(x: float) -> str:
    x = float(x)
    if x == 0.0:
        return "0"
    return f"{x:.9g}"


def _vals(*xs) -> str:
    return ", ".join(_num(x) for x in xs)


def identifier(name: str, default: str = "lamella_stack") -> str:
    """A valid MaterialX element name from a stack name (letters, digits and underscores, not
    starting with a digit)."""
    s = re.sub(r"[^A-Za-z0-9_]", "_", name or "")
    s = re.sub(r"_+", "_", s).strip("_")[:64]
    if not s:
        return default
    return s if not s[0].isdigit() else f"m_{s}"


def _xml_text(text: str) -> str:
    """``text`` without the characters XML 1.0 cannot hold (control characters, lone surrogates):
    a stack's name is free text."""
    return "".join(ch if (ch in "\t\n\r" or 0x20 <= ord(ch) < 0xD800 or 0xE000 <= ord(ch) < 0xFFFE
                          or ord(ch) >= 0x10000) else "?" for ch in text)


def _comment_text(text: str) -> str:
    """``text`` safe inside an XML comment (no ``--``)."""
    text = _xml_text(text)
    while "--" in text:
        text = text.replace("--", "- -")
    return text.rstrip("-")


class _Graph:
    """Child elements of one MaterialX scope (a nodegraph or the document)."""

    def __init__(self, parent: ET.Element):
        self.parent = parent

    def node(self, category: str, name: str, type_: str, **inputs) -> str:
        """A node ``category`` named ``name`` of output ``type_``; each input is
        (type, value) or (type, ("node", nodename)) or (type, ("interface", interfacename))."""
        el = ET.SubElement(self.parent, category, {"name": name, "type": type_})
        for key, (t, v) in inputs.items():
            attrs = {"name": key, "type": t}
            if isinstance(v, tuple) and len(v) == 2 and v[0] in ("node", "interface"):
                attrs["nodename" if v[0] == "node" else "interfacename"] = v[1]
            else:
                attrs["value"] = v
            ET.SubElement(el, "input", attrs)
        return name


def _document(comment_lines) -> ET.Element:
    root = ET.Element("materialx", {"version": MATERIALX_VERSION, "colorspace": COLORSPACE})
    root.append(ET.Comment(_comment_text("\n  " + "\n  ".join(comment_lines) + "\n")))
    return root


def _text(root: ET.Element) -> str:
    ET.indent(root, space="  ")
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


# ----------------------------------------------------------------------------- physics helpers
def _relative_index(n_layer: float, n_above: float) -> tuple[float, bool]:
    """The index of an interface as MaterialX takes it (relative to the medium above), and
    whether it was folded to its reciprocal (see the module docstring)."""
    eta = n_layer / n_above
    if eta < 1.0 and n_layer >= 1.0:
        return 1.0 / eta, True
    return eta, False


def _round_trip(coat) -> tuple[float, float, float]:
    """Transmittance of a coat's medium down and up along the normal: exp(-2 sigma_a d)."""
    return tuple(math.exp(-2.0 * s * coat.thickness) for s in coat.sigma_a)


def _fresnel_conductor(mu: float, eta: float, k: float) -> float:
    """Unpolarised Fresnel reflectance of relative complex index eta + i k at incidence cosine
    ``mu``: the models' own (``models.fresnel``), evaluated in float64."""
    return float(fresnel.fresnel_conductor(_OPS, mu, eta, k))


def _fresnel_dielectric(mu: float, eta: float) -> float:
    """Unpolarised Fresnel reflectance at incidence cosine ``mu`` into relative index ``eta``."""
    return float(fresnel.fresnel_dielectric(_OPS, mu, eta))


def _hemispherical_fresnel(eta: float, steps: int = 512) -> float:
    """E_F(eta) = 2 integral of F(mu, eta) mu dmu over [0, 1] (midpoint rule): the albedo of a
    smooth interface under uniform light from outside."""
    h = 1.0 / steps
    return 2.0 * h * sum(_fresnel_dielectric((j + 0.5) * h, eta) * (j + 0.5) * h for j in range(steps))


def diffuse_darkening(stack: Stack) -> tuple[float, float, float] | None:
    """The constant a Lambertian base under coats is darkened by, the light the coats send back to
    it: the interfaced-Lambertian factor (1 - K) / (1 - E_b K), K = 1 - (1 - E_F(n)) / n^2, with n
    the index of the medium on the base (light escapes to air through parallel interfaces only
    inside its cone) and E_b the albedo times the coats' round-trip transmittance (OpenPBR v1.1,
    "Coat: Darkening", after Elias 2001 and d'Eon 2021). None for other bases or no coats."""
    if stack.base.type != "diffuse" or not stack.coats:
        return None
    n = stack.coats[-1].ior
    if n <= 1.0:
        return None  # no trapped light under an optically thinner medium: nothing to darken
    k = 1.0 - (1.0 - _hemispherical_fresnel(n)) / (n * n)
    tint = [1.0, 1.0, 1.0]
    for c in stack.coats:
        if c.has_absorption:
            tint = [a * b for a, b in zip(tint, _round_trip(c))]
    return tuple((1.0 - k) / (1.0 - a * t * k) for a, t in zip(stack.base.albedo, tint))


def _schlick(mu: float, f0: float) -> float:
    return f0 + (1.0 - f0) * (1.0 - mu) ** 5


def _open_pbr_roughness(alpha) -> tuple[float, float, bool]:
    """OpenPBR (roughness r, anisotropy a) of a GGX alpha pair, and whether the tangent must turn a
    quarter turn (alpha_y > alpha_x). Inverts alpha_t = r^2 sqrt(2 / (1 + (1 - a)^2)),
    alpha_b = (1 - a) alpha_t (OpenPBR v1.1, "Microfacet model")."""
    ax, ay = float(alpha[0]), float(alpha[1])
    swap = ay > ax
    at, ab = (ay, ax) if swap else (ax, ay)
    if at <= 0.0:
        return 0.0, 0.0, False
    one_minus_a = ab / at
    r2 = at / math.sqrt(2.0 / (1.0 + one_minus_a * one_minus_a))
    return math.sqrt(r2), 1.0 - one_minus_a, swap


# ----------------------------------------------------------------------------- the layered document
def _frame(g: _Graph, prefix: str, rotation: float, normal, tangent):
    """The tangent of one layer: its tangent turned by ``rotation`` about its normal (or as it is
    when the rotation is 0). ``normal``/``tangent`` are ("interface"|"node", name) references."""
    if rotation == 0.0:
        return tangent
    c, s = math.cos(rotation), math.sin(rotation)
    b = g.node("crossproduct", f"{prefix}_bitangent", "vector3", in1=("vector3", normal), in2=("vector3", tangent))
    tc = g.node("multiply", f"{prefix}_tangent_cos", "vector3", in1=("vector3", tangent), in2=("float", _num(c)))
    bs = g.node("multiply", f"{prefix}_bitangent_sin", "vector3", in1=("vector3", ("node", b)), in2=("float", _num(s)))
    t = g.node("add", f"{prefix}_tangent_turned", "vector3", in1=("vector3", ("node", tc)), in2=("vector3", ("node", bs)))
    return ("node", g.node("normalize", f"{prefix}_tangent_rotated", "vector3", **{"in": ("vector3", ("node", t))}))


def _film(layer) -> dict:
    """The ``thinfilm_thickness`` (nm) and ``thinfilm_ior`` inputs of a layer's closure, where it
    has a film (MaterialX PBS specification v1.39, "dielectric_bsdf", "conductor_bsdf")."""
    if getattr(layer, "film_thickness", 0.0) <= 0.0:
        return {}
    return {"thinfilm_thickness": ("float", _num(layer.film_thickness)), "thinfilm_ior": ("float", _num(layer.film_ior))}


def _film_warnings(stack: Stack, warn) -> None:
    n_above = 1.0
    for i, c in enumerate(stack.coats):
        if c.film_thickness > 0.0 and n_above != 1.0:
            warn(i, ("film_thickness", "film_ior"), f"MaterialX evaluates the film as if under the medium outside "
                 f"the surface, not under coat {i - 1} (index {n_above:g})")
        n_above = c.ior
    base = stack.base
    if getattr(base, "film_thickness", 0.0) > 0.0 and n_above != 1.0:
        warn("base", ("film_thickness", "film_ior"), f"MaterialX evaluates the film as if under the medium outside "
             f"the surface, not under coat {len(stack.coats) - 1} (index {n_above:g})")


def _single_scattering_warning(stack: Stack, warn) -> None:
    if stack.base.type == "conductor" and stack.base.roughness != (0.0, 0.0):
        warn("base", "roughness", "MaterialX's microfacet distribution is 'ggx', single scattering: the light a "
             "rough metal reflects after more than one bounce on its microsurface, which Lamella keeps, is lost "
             "(the rougher, the darker)")


def _coupling_warnings(stack: Stack, warn) -> None:
    if stack.coats:
        warn("stack", None, "MaterialX's layer is albedo scaling (each layer below scaled by one minus the "
             "directional albedo of the one above): the light between the layers is not followed, so no "
             "refraction into the coats, no inter-reflection or total internal reflection between "
             "interfaces, no adding-doubling statistics; the look of the Lamella models is approximated")
    for i, c in enumerate(stack.coats):
        if c.roughness != (0.0, 0.0):
            warn(i, "roughness", "the lobes below are not widened by this rough interface (MaterialX "
                 "keeps each closure's own roughness)")
        if c.has_scattering:
            warn(i, ("sigma_s", "g"), "scattering media cannot be expressed in MaterialX (a layer's VDF "
                 "is a closed object's interior, with no thickness); dropped")


def _warner():
    """A list of warnings and the ``warn(layer, field, message)`` that adds to it: ``layer`` is
    "stack", a coat's index (0 = top) or "base"; ``field`` a field name, a tuple of them or None."""
    warnings: list[tuple[int, str]] = []

    def warn(layer, field, message):
        order, where = ((0, "stack") if layer == "stack" else (1000, "base") if layer == "base"
                        else (1 + layer, layer_label(layer)))
        if field is None:
            warnings.append((order, f"{where}: {message}"))
        elif isinstance(field, tuple):
            warnings.append((order, f"{where}, fields {', '.join(repr(f) for f in field)}: {message}"))
        else:
            warnings.append((order, f"{where}, field {field!r}: {message}"))

    return warnings, warn


def _by_layer(warnings: list[tuple[int, str]]) -> tuple[str, ...]:
    """The warnings' texts in stack order: the stack's, the coats' top to bottom, the base's."""
    return tuple(text for _, text in sorted(warnings, key=lambda w: w[0]))


def _index_warnings(stack: Stack, warn) -> list[tuple[float, float]]:
    """(n_above, exported relative index) of every coat, with the warnings the indices need."""
    out = []
    n_above = 1.0
    for i, c in enumerate(stack.coats):
        ior, folded = _relative_index(c.ior, n_above)
        if n_above != 1.0:
            warn(i, "ior", f"MaterialX's interface is against the medium above the surface, not coat "
                 f"{i - 1}: exported the relative index {c.ior:g} / {n_above:g}")
        if folded:
            warn(i, "ior", f"relative index {c.ior / n_above:.4g} below 1: exported its reciprocal "
                 f"{ior:.4g} (the same normal-incidence reflectance), since MaterialX evaluates the layer at "
                 "the unrefracted direction, where it would reflect everything past a critical angle no "
                 "light from above reaches")
        out.append((n_above, ior))
        n_above = c.ior
    return out


def layered_document(stack: Stack) -> MaterialXExport:
    """The stack as nested ``layer`` nodes of standard closures (module docstring)."""
    stack = Stack.coerce(stack)
    check_kinds(stack)
    warnings, warn = _warner()
    name = identifier(stack.name)
    node = f"lamella_{name}"
    _coupling_warnings(stack, warn)
    _single_scattering_warning(stack, warn)
    _film_warnings(stack, warn)
    indices = _index_warnings(stack, warn)
    n_bottom = stack.coats[-1].ior if stack.coats else 1.0

    base = stack.base
    for i, c in enumerate(stack.coats):
        if c.has_absorption:
            t = _round_trip(c)
            warn(i, ("sigma_a", "thickness"), "approximated: the layers below are tinted by the round "
                 f"trip along the normal, exp(-2 sigma_a thickness) = ({_vals(*t)}); the longer path at oblique "
                 "incidence is lost")
    if base.type == "conductor" and n_bottom != 1.0:
        warn("base", ("eta", "k"), f"exported relative to coat {len(stack.coats) - 1} above it, "
             f"(eta + i k) / {n_bottom:g}")
    dark = diffuse_darkening(stack)
    if dark is not None:
        warn("base", "albedo", f"darkened by the constant ({_vals(*dark)}) for the light the coats send back "
             "to it (the interfaced-Lambertian factor of OpenPBR's coat darkening), in place of Lamella's "
             "internal reflections")
        for i, c in enumerate(stack.coats):
            if c.coverage < 1.0:
                warn(i, "coverage", "where the coat is absent the diffuse base keeps the darkening of the whole "
                     "stack")
    base_ior = None
    if base.type == "dielectric":
        base_ior, folded = _relative_index(base.ior, n_bottom)
        if n_bottom != 1.0:
            warn("base", "ior", f"exported the index relative to coat {len(stack.coats) - 1}, {base.ior:g} / "
                 f"{n_bottom:g}; MaterialX's dielectric_bsdf refracts with that index too, while light "
                 f"leaving the stack downward follows the absolute index {base.ior:g}")
        if folded:
            warn("base", "ior", f"relative index {base.ior / n_bottom:.4g} below 1: exported its reciprocal "
                 f"{base_ior:.4g} (the same normal-incidence reflectance)")

    warnings = list(_by_layer(warnings))
    layers = [layer_prefix(i) for i in range(len(stack.coats))] + [layer_prefix(None)]
    root = _document([
        f"Lamella stack {stack.name!r} ({len(stack.coats)} coat(s) over a {base.type} base), as nested MaterialX layers.",
        "Written by `lamella export-mtlx`. What the export approximated or dropped:",
        *(f"- {w}" for w in warnings),
    ])
    nodedef = ET.SubElement(root, "nodedef", {"name": f"ND_{node}", "node": node, "nodegroup": "pbr",
                                              "doc": _xml_text(f"Lamella stack {stack.name or name}: "
                                                               f"{len(stack.coats)} coat(s) over a {base.type} base")})
    for layer in layers:
        ET.SubElement(nodedef, "input", {"name": f"{layer}_normal", "type": "vector3", "defaultgeomprop": "Nworld",
                                         "doc": f"shading normal of {layer}"})
        ET.SubElement(nodedef, "input", {"name": f"{layer}_tangent", "type": "vector3", "defaultgeomprop": "Tworld",
                                         "doc": f"tangent of {layer} (its anisotropy axis x before its rotation)"})
    for i, c in enumerate(stack.coats):
        if c.coverage < 1.0:
            ET.SubElement(nodedef, "input", {"name": f"{layer_prefix(i)}_coverage", "type": "float",
                                             "value": _num(c.coverage), "uimin": "0", "uimax": "1",
                                             "doc": f"fraction of the surface coat {i} covers (a mask connects here)"})
    ET.SubElement(nodedef, "output", {"name": "out", "type": "surfaceshader"})
    ng = ET.SubElement(root, "nodegraph", {"name": f"NG_{node}", "nodedef": f"ND_{node}"})
    g = _Graph(ng)

    # the base
    normal, tangent = ("interface", "base_normal"), ("interface", "base_tangent")
    if base.type == "conductor":
        t = _frame(g, "base", base.rotation, normal, tangent)
        below = g.node("conductor_bsdf", "base_bsdf", "BSDF",
                       ior=("color3", _vals(*(e / n_bottom for e in base.eta))),
                       extinction=("color3", _vals(*(k / n_bottom for k in base.k))),
                       roughness=("vector2", _vals(*base.roughness)), normal=("vector3", normal),
                       tangent=("vector3", t), **_film(base))
    elif base.type == "diffuse":
        below = g.node("oren_nayar_diffuse_bsdf", "base_bsdf", "BSDF", color=("color3", _vals(*base.albedo)),
                       roughness=("float", "0"), normal=("vector3", normal))
        dark = diffuse_darkening(stack)
        if dark is not None:
            below = g.node("multiply", "base_darkening", "BSDF", in1=("BSDF", ("node", below)),
                           in2=("color3", _vals(*dark)))
    else:
        t = _frame(g, "base", base.rotation, normal, tangent)
        below = g.node("dielectric_bsdf", "base_bsdf", "BSDF", ior=("float", _num(base_ior)),
                       roughness=("vector2", _vals(*base.roughness)), normal=("vector3", normal),
                       tangent=("vector3", t), scatter_mode=("string", "RT"), **_film(base))

    # the coats, bottom to top: each a layer over everything below it
    for i in reversed(range(len(stack.coats))):
        c = stack.coats[i]
        prefix = layer_prefix(i)
        normal, tangent = ("interface", f"{prefix}_normal"), ("interface", f"{prefix}_tangent")
        t = _frame(g, prefix, c.rotation, normal, tangent)
        top = g.node("dielectric_bsdf", f"{prefix}_bsdf", "BSDF", ior=("float", _num(indices[i][1])),
                     roughness=("vector2", _vals(*c.roughness)), normal=("vector3", normal),
                     tangent=("vector3", t), scatter_mode=("string", "R"), **_film(c))
        bare = below
        if c.has_absorption:
            below = g.node("multiply", f"{prefix}_absorption", "BSDF", in1=("BSDF", ("node", below)),
                           in2=("color3", _vals(*_round_trip(c))))
        layered = g.node("layer", f"{prefix}_layer", "BSDF", top=("BSDF", ("node", top)),
                         base=("BSDF", ("node", below)))
        if c.coverage < 1.0:  # the coat on a fraction of the surface: the spatial mix with what is under it
            below = g.node("mix", f"{prefix}_coverage", "BSDF", fg=("BSDF", ("node", layered)),
                           bg=("BSDF", ("node", bare)), mix=("float", ("interface", f"{prefix}_coverage")))
        else:
            below = layered
    g.node("surface", "surface", "surfaceshader", bsdf=("BSDF", ("node", below)))
    ET.SubElement(ng, "output", {"name": "out", "type": "surfaceshader", "nodename": "surface"})

    shader = f"{name}_shader"
    ET.SubElement(root, node, {"name": shader, "type": "surfaceshader"})
    mat = ET.SubElement(root, "surfacematerial", {"name": name, "type": "material"})
    ET.SubElement(mat, "input", {"name": "surfaceshader", "type": "surfaceshader", "nodename": shader})
    return MaterialXExport(_text(root), tuple(warnings), name)


# ----------------------------------------------------------------------------- OpenPBR
def open_pbr_fit(stack: Stack) -> str | None:
    """Why ``stack`` does not fit OpenPBR Surface, or None if it does (at most one coat over a
    base: OpenPBR v1.1 has one coat slab over its base substrate)."""
    stack = Stack.coerce(stack)
    check_kinds(stack)
    if len(stack.coats) > 1:
        return (f"{len(stack.coats)} coats: OpenPBR Surface has one coat over a base; export the layered "
                "document instead")
    return None


def open_pbr_document(stack: Stack) -> MaterialXExport:
    """The stack as one ``open_pbr_surface`` (module docstring); raises ``OpenPBRMismatch``
    (saying why) for a stack of more than one coat."""
    stack = Stack.coerce(stack)
    reason = open_pbr_fit(stack)
    if reason is not None:
        raise OpenPBRMismatch(reason)
    warnings, warn = _warner()
    name = identifier(stack.name)
    base = stack.base
    coat = stack.coats[0] if stack.coats else None
    n_above = coat.ior if coat else 1.0
    inputs: list[tuple[str, str, str]] = []  # (name, type, value)
    rotations = {}  # "geometry_tangent" / "geometry_coat_tangent" -> turn about the normal

    def put(key, type_, value):
        inputs.append((key, type_, value))

    if coat is not None:
        warn("stack", None, "OpenPBR's coat is albedo scaling with an approximate darkening (coat_darkening 1) "
             "and base roughening: not the adding-doubling statistics of the Lamella models")
        r, a, swap = _open_pbr_roughness(coat.roughness)
        put("coat_weight", "float", _num(coat.coverage))  # OpenPBR's coat weight is the coat's presence
        put("coat_ior", "float", _num(coat.ior))
        put("coat_roughness", "float", _num(r))
        put("coat_roughness_anisotropy", "float", _num(a))
        put("coat_darkening", "float", "1")
        if coat.has_absorption:
            t = _round_trip(coat)
            put("coat_color", "color3", _vals(*t))
            warn(0, ("sigma_a", "thickness"), f"coat_color = exp(-2 sigma_a thickness) = ({_vals(*t)}), the "
                 "normal-incidence round trip OpenPBR defines it as")
        else:
            put("coat_color", "color3", "1, 1, 1")
        if coat.has_scattering:
            warn(0, ("sigma_s", "g"), "OpenPBR's coat is a purely absorbing medium: scattering dropped")
        turn = coat.rotation + (math.pi / 2 if swap else 0.0)
        if turn != 0.0:
            rotations["geometry_coat_tangent"] = ("coat", turn)
    else:
        put("coat_weight", "float", "0")

    if base.type == "conductor":
        eta = [e / n_above for e in base.eta]
        k = [x / n_above for x in base.k]
        f0 = [_fresnel_conductor(1.0, e, x) for e, x in zip(eta, k)]
        edge = [_fresnel_conductor(OPEN_PBR_EDGE_MU, e, x) / _schlick(OPEN_PBR_EDGE_MU, f)
                for e, x, f in zip(eta, k, f0)]
        tint = [min(1.0, max(0.0, v)) for v in edge]
        r, a, swap = _open_pbr_roughness(base.roughness)
        put("base_weight", "float", "1")
        put("base_metalness", "float", "1")
        put("base_color", "color3", _vals(*f0))
        put("specular_weight", "float", "1")
        put("specular_color", "color3", _vals(*tint))
        put("specular_roughness", "float", _num(r))
        put("specular_roughness_anisotropy", "float", _num(a))
        warn("base", ("eta", "k"), "approximated by the F82-tint model: base_color = F0 and specular_color = "
             "F(82 deg) over Schlick's, from the exact Fresnel" + (f" of the metal under the coat, (eta + i k) / {n_above:g}"
                                                                  if coat else ""))
        if tint != edge:
            warn("base", ("eta", "k"), f"the F82 tint ({_vals(*edge)}) leaves [0, 1]: clamped")
        _single_scattering_warning(stack, warn)
        turn = base.rotation + (math.pi / 2 if swap else 0.0)
        if turn != 0.0:
            rotations["geometry_tangent"] = ("base", turn)
    elif base.type == "diffuse":
        put("base_weight", "float", "1")
        put("base_metalness", "float", "0")
        put("base_color", "color3", _vals(*base.albedo))
        put("base_diffuse_roughness", "float", "0")
        put("specular_weight", "float", "0")
    else:
        r, a, swap = _open_pbr_roughness(base.roughness)
        put("base_weight", "float", "1")
        put("base_metalness", "float", "0")
        put("transmission_weight", "float", "1")
        put("transmission_color", "color3", "1, 1, 1")
        put("specular_weight", "float", "1")
        put("specular_ior", "float", _num(base.ior))
        put("specular_roughness", "float", _num(r))
        put("specular_roughness_anisotropy", "float", _num(a))
        turn = base.rotation + (math.pi / 2 if swap else 0.0)
        if turn != 0.0:
            rotations["geometry_tangent"] = ("base", turn)

    # OpenPBR's thin film lies on the base's specular interface (thin_film_*, thickness in micrometres)
    if getattr(base, "film_thickness", 0.0) > 0.0:
        put("thin_film_weight", "float", "1")
        put("thin_film_thickness", "float", _num(base.film_thickness / 1000.0))
        put("thin_film_ior", "float", _num(base.film_ior))
        if coat is not None:
            warn("base", ("film_thickness", "film_ior"), "OpenPBR evaluates the film under the coat's index as its "
                 "base's interface does")
    if coat is not None and coat.film_thickness > 0.0:
        warn(0, ("film_thickness", "film_ior"), "OpenPBR has no film on its coat: dropped")
    warnings = list(_by_layer(warnings))
    root = _document([
        f"Lamella stack {stack.name!r} ({len(stack.coats)} coat(s) over a {base.type} base), as OpenPBR Surface.",
        "Written by `lamella export-mtlx` (its OpenPBR variant). What the export approximated or dropped:",
        *(f"- {w}" for w in warnings),
    ])
    shader = f"{name}_open_pbr"
    frames = {}
    if rotations:
        graph = f"NG_{name}_frames"
        ng = ET.SubElement(root, "nodegraph", {"name": graph})
        g = _Graph(ng)
        n = g.node("normal", "world_normal", "vector3", space=("string", "world"))
        t = g.node("tangent", "world_tangent", "vector3", space=("string", "world"))
        for key, (prefix, turn) in rotations.items():
            ref = _frame(g, prefix, turn, ("node", n), ("node", t))
            ET.SubElement(ng, "output", {"name": f"{prefix}_tangent", "type": "vector3", "nodename": ref[1]})
            frames[key] = (graph, f"{prefix}_tangent")
    el = ET.SubElement(root, "open_pbr_surface", {"name": shader, "type": "surfaceshader"})
    for key, type_, value in inputs:
        ET.SubElement(el, "input", {"name": key, "type": type_, "value": value})
    for key, (graph, output) in frames.items():
        ET.SubElement(el, "input", {"name": key, "type": "vector3", "nodegraph": graph, "output": output})
    mat = ET.SubElement(root, "surfacematerial", {"name": name, "type": "material"})
    ET.SubElement(mat, "input", {"name": "surfaceshader", "type": "surfaceshader", "nodename": shader})
    return MaterialXExport(_text(root), tuple(warnings), name)


__all__ = ["MaterialXExport", "MaterialXUnsupported", "OpenPBRMismatch", "MAPPED_KINDS", "check_kinds", "identifier",
           "layered_document", "open_pbr_document",
           "open_pbr_fit"]
