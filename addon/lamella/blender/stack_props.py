"""Between a material's Lamella properties and the stack description (docs/design.md "Contract: the
stack description"), field by field through the layer-kind schema.

Blender stores floats in single precision; values read back are rounded to 7 significant digits
(6 for a GGX alpha, the square of the stored roughness), so a stack written and read back gives
the numbers that were written.
"""
from __future__ import annotations

import re
import uuid

from ..core.layers import ANGLE, BASE_KINDS, BOOL, COAT_KINDS, FLOAT, RGB, ROUGHNESS
from ..core.param_id import alpha_from_r, r_from_alpha
from ..core.stack import Stack
from ..core.stack_format import FORMAT
from .kind_hooks import hooks


def _r7(x: float) -> float:
    return float(f"{float(x):.7g}")


def _r6(x: float) -> float:
    return float(f"{float(x):.6g}")


def kind_values(kind, pg) -> dict:
    """One layer's JSON dict (type and every schema field) from its kind's PropertyGroup."""
    d = {"type": kind.type}
    for f in kind.fields:
        if f.type == BOOL:
            d[f.name] = bool(getattr(pg, f.name))
        elif f.type in (FLOAT, ANGLE):
            d[f.name] = _r7(getattr(pg, f.name))
        elif f.type == RGB:
            d[f.name] = [_r7(x) for x in getattr(pg, f.name)]
        elif f.type == ROUGHNESS:
            rx = getattr(pg, f.name)
            if getattr(pg, f"{f.name}_anisotropic"):
                d[f.name] = [_r6(alpha_from_r(rx)), _r6(alpha_from_r(getattr(pg, f"{f.name}_y")))]
            else:
                d[f.name] = _r6(alpha_from_r(rx))
    return d


def write_kind(kind, pg, layer) -> None:
    """Write a parsed layer (a kind's dataclass) into its kind's PropertyGroup (then the kind's
    ``written`` hook, ``kind_hooks``)."""
    for f in kind.fields:
        v = getattr(layer, f.name)
        if f.type in (FLOAT, ANGLE, BOOL):
            setattr(pg, f.name, v)
        elif f.type == RGB:
            setattr(pg, f.name, tuple(v))
        elif f.type == ROUGHNESS:
            ax, ay = v
            setattr(pg, f"{f.name}_anisotropic", ax != ay)
            setattr(pg, f.name, r_from_alpha(ax))
            setattr(pg, f"{f.name}_y", r_from_alpha(ay))
    written = hooks(kind.type).written
    if written is not None:
        written(pg)


def stack_dict(settings, include_muted: bool = False) -> dict:
    """The stack the material renders: its coats top to bottom (muted ones left out unless
    ``include_muted``) over its base, as a JSON-compatible dict (not yet validated)."""
    layers = [kind_values(COAT_KINDS[c.kind], c.settings()) for c in settings.coats if c.show or include_muted]
    return {"name": settings.stack_name, "layers": layers,
            "base": kind_values(BASE_KINDS[settings.base.kind], settings.base.settings())}


BASE_LABEL = "Base"  # the base's label: its inputs on the Lamella node are "Base: <field>"
CLEAR_ALPHA = 0.04  # a coat at most this rough (GGX alpha; Blender roughness 0.2) is a clear coat


def layer_label(layer) -> str:
    """A label for a new coat from what it is: a medium, tinted, brushed, clear or rough coat.
    Given once, when the coat is made; an edit of its values never changes it."""
    ax, ay = layer.roughness
    if layer.has_scattering:
        return "Medium" if layer.ior == 1.0 and ax == ay == 0.0 else "Scattering Coat"
    if layer.has_absorption:
        return "Tinted Coat"
    if ax != ay:
        return "Brushed Coat"
    return "Clear Coat" if max(ax, ay) <= CLEAR_ALPHA else "Rough Coat"


_NUMBERED = re.compile(r"^(.*?) (\d+)$")


def unique_label(label: str, taken) -> str:
    """``label``, or the next numbered one ("Clear Coat 2") if a layer of the material holds it
    (``taken``: the other layers' labels; the base's is always taken)."""
    taken = set(taken) | {BASE_LABEL}
    label = label.strip() or "Coat"
    if label not in taken:
        return label
    m = _NUMBERED.match(label)
    stem, n = (m.group(1), int(m.group(2))) if m else (label, 2)
    while f"{stem} {n}" in taken:
        n += 1
    return f"{stem} {n}"


def ensure_labels(settings) -> bool:
    """Give every coat a label no other layer of the material has (a file saved before labels
    were unique: the later of two alike is numbered). Returns whether any changed."""
    seen, changed = set(), False
    for item in settings.coats:
        label = unique_label(item.name, seen)
        if label != item.name:
            item.name = label
            changed = True
        seen.add(label)
    return changed


def new_uid() -> str:
    """A new layer identity (``LAMELLA_PG_layer.uid``)."""
    return uuid.uuid4().hex[:12]


def ensure_uids(settings) -> bool:
    """Give every coat an identity of its own (a coat from a file saved before identities, or two
    sharing one). Returns whether any changed."""
    seen, changed = set(), False
    for item in settings.coats:
        if not item.uid or item.uid in seen or item.uid == "base":
            item.uid = new_uid()
            changed = True
        seen.add(item.uid)
    return changed


def write_stack(settings, stack: Stack, labels=None) -> None:
    """Replace the material's layers and base by ``stack`` (already validated), stored in the
    current stack format. The coat at each position keeps its identity (the face's inputs, and
    the textures linked into them, stay with the position, as a whole-stack replacement means) and,
    unless ``labels`` is given, its label; ``labels`` (a preset's: one per coat, top to bottom,
    or () for none) names the coats anew, a coat without one by what it is (``layer_label``)."""
    settings.format = FORMAT
    settings.stack_name = stack.name
    kept = [(item.uid, item.name) for item in settings.coats]  # the layer at each position keeps its identity
    settings.coats.clear()
    given = None if labels is None else tuple(labels)
    taken = []
    for k, c in enumerate(stack.coats):
        item = settings.coats.add()
        item.kind = c.type
        uid, name = kept[k] if k < len(kept) else ("", "")
        item.uid = uid or new_uid()
        if given is not None:
            name = given[k] if k < len(given) else ""
        item.name = unique_label(name or layer_label(c), taken)
        taken.append(item.name)
        write_kind(COAT_KINDS[c.type], item.settings(), c)
    settings.active_index = 0
    settings.base.kind = stack.base.type
    write_kind(BASE_KINDS[stack.base.type], settings.base.settings(), stack.base)


def copy_layer(src, dst) -> None:
    """Copy one coat item's kind, visibility and every kind's fields (a duplicate: a layer of its
    own, with a new identity)."""
    dst.uid = new_uid()
    dst.kind = src.kind
    dst.show = src.show
    dst.name = src.name  # the caller makes it unique in its material (``unique_label``)
    for k in COAT_KINDS:
        s, d = getattr(src, k), getattr(dst, k)
        for prop in s.bl_rna.properties:
            if prop.identifier != "rna_type" and not prop.is_readonly:
                setattr(d, prop.identifier, getattr(s, prop.identifier))
