"""What each face of a mesh sees of a stack over a dielectric base: a solid substrate or a thin sheet.

A stack lists its layers from the medium the light comes from (vacuum) down to the base. Over a
dielectric base of absolute index n the base is a substrate the transmitted light enters.

**Solid** (the default). On a closed mesh the light that entered meets the far side from inside
the substrate. There the same interfaces lie in the reverse order: the substrate is the medium
the light comes from, the coats follow from the one touching the substrate up to the top one, and
the medium above the stack (vacuum) is the half-space below, which it enters or, past the
critical angle, is totally reflected back from. ``inside_view`` writes that stack: coat j of it is
the interior of the (k-1-j)-th coat of the k coats (its index, medium and film), under the
interface between it and the layer below it in the stack as drawn: the base's interface for
j = 0, the top interface of coat k-j otherwise; its base is the vacuum under the top coat's top
interface. The models put vacuum above a stack, and every interface reflects and refracts by the
ratio of the indices on its two sides alone (Fresnel, Snell, the microfacet statistics: Walter et
al. 2007), so the view's indices are divided by n: the substrate becomes the unit medium, the
vacuum below 1 / n. A thin film keeps its optical thickness (index times thickness, the phase of
Belcour and Barla 2017's Airy sum) and the ratios of its indices, so its thickness is multiplied
by n. A medium's absorption and scattering are per unit length and keep their values.

**Thin walled** (``thin_walled`` on the base). The substrate is a thin sheet: the light crossing
its top interface leaves at once through its back face, an interface of the same roughness and
film onto the medium above the stack, in the direction it came, and both faces of the mesh show
the stack as drawn. ``sheet`` writes that stack: the base becomes a coat of its index, roughness,
rotation and film (no medium) over a dielectric base of index 1 with the same roughness.

Either view keeps the stack's parameters: ``layer_params`` of a view reads the stack's own (each
socket stays the field the artist set) and rearranges them (``view_params``), so one shader takes
the same inputs on both faces. ``view_of`` is the stack the models run for one side; the shaders draw the inside
view where the surface is seen from behind (``backfacing``) and the stack as drawn elsewhere.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

OUTSIDE, INSIDE = "outside", "inside"
SIDES = (OUTSIDE, INSIDE)
# what a layer's interface carries, as the models read it (``layers.params.roughness_params``,
# ``layers.film``): it moves with the interface; the rest of a layer's parameters (its index, its
# medium) belong to its interior
INTERFACE_PARAMS = ("ax", "ay", "rotation", "film_thickness", "film_ior")
INTERFACE_FIELDS = ("roughness", "rotation", "film_thickness", "film_ior")
SHEET_FACE = 1000  # the coat index (``Stack.origin``) of a sheet's top face: past any real coat (``Stack.MAX_COATS``)


@dataclass(frozen=True)
class View:
    """How a view stack (``Stack.view``) was made from ``original`` (the stack as drawn, or a part of
    one): ``"inside"`` (``inside_view``) or ``"sheet"`` (``sheet``)."""

    original: object
    how: str


def is_solid(stack) -> bool:
    """A dielectric base that is a solid substrate: its far side shows the inside view."""
    return stack.base.kind.transmits and not getattr(stack.base, "thin_walled", False)


def is_sheet(stack) -> bool:
    """A dielectric base that is a thin sheet (``thin_walled``)."""
    return stack.base.kind.transmits and bool(getattr(stack.base, "thin_walled", False))


def faces(stack) -> str:
    """What the faces of a mesh show, part of a stack's structure: "solid" (the far side of a
    dielectric base shows the inside view), "sheet" (a thin-walled one) or "" (an opaque base)."""
    return "solid" if is_solid(stack) else "sheet" if is_sheet(stack) else ""


def _owners(stack) -> list:
    """The layer whose interface lies above each layer of the inside view, then above its base."""
    coats = stack.coats
    k = len(coats)
    if k == 0:
        return [stack.base]
    return [stack.base, *(coats[k - j] for j in range(1, k)), coats[0]]


def _interface_values(owner, n: float, target) -> dict:
    """The interface fields of layer ``owner`` as seen in a view whose indices are divided by ``n``,
    those layer ``target`` (the layer of the view under that interface) has. (The models read an
    interface from the parameters, ``view_params``, which carry all of it; the view's layers give
    its structure.)"""
    out = {}
    for f in INTERFACE_FIELDS:
        if hasattr(owner, f) and hasattr(target, f):
            out[f] = getattr(owner, f)
    if "film_thickness" in out:
        out["film_thickness"] = out["film_thickness"] * n
    if "film_ior" in out:
        out["film_ior"] = out["film_ior"] / n
    return out


def inside_view(stack):
    """The stack the far side of a solid dielectric base shows (module docstring), its values those
    of ``stack``; its parameters are ``stack``'s (``view_params``)."""
    if not is_solid(stack):
        raise ValueError("the inside view is that of a solid dielectric base")
    n = stack.base.ior
    coats, k = stack.coats, len(stack.coats)
    owners = _owners(stack)
    view_coats = tuple(replace(coats[k - 1 - j], ior=coats[k - 1 - j].ior / n,
                               **_interface_values(owners[j], n, coats[k - 1 - j])) for j in range(k))
    base = replace(stack.base, ior=1.0 / n, **_interface_values(owners[k], n, stack.base))
    return replace(stack, coats=view_coats, base=base, origin=(), view=View(stack, INSIDE))


def sheet(stack):
    """The stack a thin-walled dielectric base stands for (module docstring)."""
    if not is_sheet(stack):
        raise ValueError("a sheet is a thin-walled dielectric base")
    from ..layers import COAT_KINDS

    b = stack.base
    coat = COAT_KINDS["coat"].cls(ior=b.ior, roughness=b.roughness, rotation=b.rotation,
                                  film_thickness=b.film_thickness, film_ior=b.film_ior)
    back = replace(b, ior=1.0, film_thickness=0.0, thin_walled=False)
    origin = tuple(stack.layer_index(i) for i in range(len(stack.coats))) + (SHEET_FACE,)
    return replace(stack, coats=(*stack.coats, coat), base=back, origin=origin, view=View(stack, "sheet"))


def view_params(ops, view: View, coats_p: list, base_p: dict):
    """The view's parameters from those of the stack it was made from (``coats_p``, ``base_p``:
    ``layer_params`` of ``view.original``), as backend values."""
    if view.how == "sheet":
        coat = {"ior": base_p["ior"], **{k: base_p[k] for k in INTERFACE_PARAMS if k in base_p}}
        back = {k: v for k, v in base_p.items() if not k.startswith("film_")}
        back["ior"] = 1.0
        return [*coats_p, coat], back
    n = base_p["ior"]
    inv = 1.0 / n
    k = len(coats_p)
    owners = [base_p, *(coats_p[k - j] for j in range(1, k)), coats_p[0]] if k else [base_p]

    def interface(p):
        out = {key: p[key] for key in INTERFACE_PARAMS if key in p}
        if "film_thickness" in out:
            out["film_thickness"] = out["film_thickness"] * n
            out["film_ior"] = out["film_ior"] * inv
        return out

    coats = []
    for j in range(k):
        interior = coats_p[k - 1 - j]
        coats.append({**{key: v for key, v in interior.items() if key not in INTERFACE_PARAMS},
                      "ior": interior["ior"] * inv, **interface(owners[j])})
    base = {**{key: v for key, v in base_p.items() if key not in INTERFACE_PARAMS}, "ior": inv, **interface(owners[k])}
    return coats, base


def _owner_prefix(view_stack, layer: str | None) -> str | None:
    """The layer (prefix, ``param_id.layer_prefix``) of the stack as drawn whose interface a lobe of
    the inside view leaves (its ``Lobe.normal``)."""
    from ..param_id import layer_prefix

    original = view_stack.view.original
    k = len(original.coats)
    if layer is None:
        return None
    j = k if layer == "base" else int(layer[4:])
    if j == 0:
        return "base"
    return layer_prefix(original.layer_index(k - j))


def view_of(stack, seen_from: str):
    """The stack the models run for the view ``seen_from`` one side of the surface: the stack as
    drawn (a thin sheet written out, ``sheet``), or from inside a solid dielectric base
    (``inside_view``; an opaque base looks the same from either side)."""
    if seen_from not in SIDES:
        raise ValueError(f"seen_from must be one of {', '.join(SIDES)}, got {seen_from!r}")
    if is_sheet(stack):
        return sheet(stack)
    if seen_from == INSIDE and is_solid(stack):
        return inside_view(stack)
    return stack


def placed(view_stack, lobes):
    """``lobes`` of a view told the layer of the stack as drawn whose interface they leave: a
    sheet's top face is its base's; in the inside view, each interface's layer (its own normal
    bends them; the layers between are not weighed as prisms)."""
    view = getattr(view_stack, "view", None)
    if view is None:
        return lobes
    if view.how == "sheet":
        from ..param_id import layer_prefix

        face = layer_prefix(SHEET_FACE)
        for lobe in lobes:
            if lobe.normal == face:
                lobe.normal = "base"
            lobe.above = tuple(i for i in (lobe.above or ()) if i != SHEET_FACE) if lobe.above is not None else None
        return lobes
    for lobe in lobes:
        lobe.normal = _owner_prefix(view_stack, lobe.normal)
        lobe.above = ()
    return lobes


__all__ = ["OUTSIDE", "INSIDE", "SIDES", "View", "is_solid", "is_sheet", "faces", "inside_view", "sheet", "view_params",
           "view_of", "placed"]
