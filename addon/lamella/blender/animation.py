"""Keyframes and drivers on a Lamella material's values, rendered by the renderer itself.

An input of the Lamella node that is keyframed or driven is read live by the shader (as a linked
one is: ``face.linked_models``), so every engine renders its value on every frame with no add-on
code at render time. Two things keep that true through an artist's work:

- **Panel animation is mirrored onto the node.** A keyframed or driven panel value
  (``lamella.coats[0].coat.roughness`` on the material) gets a copy of its F-curve or driver on the
  Lamella node's input of that layer and field (``mirror_panel``), made again at every compile and
  before every render and save, so a file renders its animation without the extension. The panel
  speaks the node's units (roughness r, angles in radians, colours channel by channel), so the
  keys copy as they are. A mirrored curve is marked (``MIRROR_KEY`` on the Lamella group) and
  removed when the panel's goes.
- **Animation stays with its layer.** F-curves and drivers address a node's inputs and the
  panel's coats by position (``nodes["Lamella"].inputs[3]``, ``lamella.coats[0]``); when inputs or
  coats move (a coat added above another), their paths are rewritten to follow the layer
  (``remap``, ``following_layers``).
"""
from __future__ import annotations

import re
from contextlib import contextmanager

from . import face

try:  # Blender 5.0 and newer: the helper for the channel bag of the assigned slot (``_channels``)
    from bpy_extras.anim_utils import animdata_get_channelbag_for_assigned_slot
except ImportError:  # 4.4 and 4.5 read the slot's channel bag themselves; before 4.4, ``Action.fcurves``
    animdata_get_channelbag_for_assigned_slot = None

MIRROR_KEY = "lamella_mirrored"  # Lamella group: the input keys whose animation mirrors the panel's
_PANEL_PATH = re.compile(r'^lamella\.(?:coats\[(\d+)\]|base)\.(\w+)\.(\w+)$')
_COAT_PATH = re.compile(r'^lamella\.coats\[(\d+)\](.*)$')
_INPUT_PATH = re.compile(r'^nodes\["((?:[^"\\]|\\.)*)"\]\.inputs\[(\d+)\]\.default_value$')


def _channels(ad):
    """What holds the F-curves of ``ad``'s action for ``ad``'s own ID: from Blender 4.4 (layered
    actions) the channelbag of its assigned slot; before, the action itself. (4.4 and 4.5 keep the
    action's legacy ``fcurves``, but it lists the first slot's only: a material and its node tree
    animated share one action, a slot each, so the node tree's curves are not there.)"""
    if animdata_get_channelbag_for_assigned_slot is not None:
        return animdata_get_channelbag_for_assigned_slot(ad)
    slot, layers = getattr(ad, "action_slot", None), getattr(ad.action, "layers", None)
    if slot is not None and layers:  # 4.4 and 4.5: layered actions, without that helper
        for layer in layers:
            for strip in layer.strips:
                bag = strip.channelbag(slot)
                if bag is not None:
                    return bag
        return None
    return ad.action


def fcurves(idblock) -> list:
    """The F-curves of ``idblock``'s action (its assigned slot's, from Blender 4.4's layered actions)."""
    ad = getattr(idblock, "animation_data", None)
    if ad is None or ad.action is None:
        return []
    bag = _channels(ad)
    return list(bag.fcurves) if bag is not None else []


def drivers(idblock) -> list:
    ad = getattr(idblock, "animation_data", None)
    return list(ad.drivers) if ad is not None else []


def animated_paths(idblock) -> set:
    """The data paths of ``idblock`` that a driver or its action's keyframes move."""
    return {c.data_path for c in (*fcurves(idblock), *drivers(idblock))}


def panel_key(settings, data_path: str) -> str | None:
    """The input key (``face.FaceInput.key``) of the panel value at ``data_path`` on a material,
    or None (not a value the Lamella node shows: another kind's hidden fields, a switch)."""
    m = _PANEL_PATH.match(data_path)
    if m is None:
        return None
    index, kind, field = m.groups()
    if index is None:
        layer, uid = settings.base, face.BASE_UID
    elif int(index) < len(settings.coats):
        layer = settings.coats[int(index)]
        uid = layer.uid
    else:
        return None
    return f"{uid}/{field}" if layer.kind == kind else None


# ---------------------------------------------------------------- following the inputs
def input_order(node) -> list[str]:
    """The keys of ``node``'s inputs in their order (a key per input; "" for one without)."""
    keys = face.socket_keys(node.node_tree) if node.node_tree is not None else {}
    return [keys.get(s.identifier, "") for s in node.inputs]


def remap(node, before: list[str]) -> int:
    """Rewrite the paths of the F-curves and drivers on ``node``'s inputs, whose keys were in the
    order ``before``, to the inputs' order now: each follows its key (an input gone keeps its old,
    now dangling, path: Blender shows it as an error, nothing renders from it). Returns how many
    changed."""
    after = {k: i for i, k in enumerate(input_order(node)) if k}
    changed = 0
    nt = node.id_data
    for c in (*fcurves(nt), *drivers(nt)):
        m = _INPUT_PATH.match(c.data_path)
        if m is None or m.group(1).replace('\\"', '"') != node.name:
            continue
        old = int(m.group(2))
        key = before[old] if old < len(before) else ""
        new = after.get(key)
        if new is not None and new != old:
            c.data_path = node.inputs[new].path_from_id("default_value")
            changed += 1
    return changed


@contextmanager
def following_layers(mat):
    """Around an edit of ``mat``'s list of coats (add, remove, move, duplicate): the F-curves and
    drivers on a coat's panel values follow the coat to its new place, and a removed coat's go
    with it."""
    before = [c.uid for c in mat.lamella.coats]
    yield
    after = {c.uid: i for i, c in enumerate(mat.lamella.coats)}
    ad = mat.animation_data
    if ad is None:
        return
    for kind, items in (("fcurve", fcurves(mat)), ("driver", drivers(mat))):
        for c in items:
            m = _COAT_PATH.match(c.data_path)
            if m is None:
                continue
            old = int(m.group(1))
            new = after.get(before[old]) if old < len(before) else None
            if new is None:
                if kind == "fcurve":
                    _remove_fcurve(mat, c)
                else:
                    ad.drivers.remove(c)
            elif new != old:
                c.data_path = f"lamella.coats[{new}]{m.group(2)}"


# ---------------------------------------------------------------- mirroring the panel
def _copy_keys(src, dst) -> None:
    dst.keyframe_points.clear()
    dst.keyframe_points.add(len(src.keyframe_points))
    for a, b in zip(src.keyframe_points, dst.keyframe_points):
        for attr in ("co", "handle_left", "handle_right"):
            setattr(b, attr, tuple(getattr(a, attr)))
        for attr in ("interpolation", "handle_left_type", "handle_right_type", "easing", "back", "amplitude",
                     "period"):
            setattr(b, attr, getattr(a, attr))
    dst.extrapolation = src.extrapolation
    dst.update()


def _copy_driver(src, dst) -> None:
    d, s = dst.driver, src.driver
    d.type = s.type
    d.use_self = s.use_self
    while d.variables:
        d.variables.remove(d.variables[0])
    for v in s.variables:
        w = d.variables.new()
        w.name, w.type = v.name, v.type
        for t_src, t_dst in zip(v.targets, w.targets):
            if v.type == "SINGLE_PROP":
                t_dst.id_type = t_src.id_type
            t_dst.id = t_src.id
            for attr in ("data_path", "bone_target", "transform_type", "transform_space", "rotation_mode"):
                if hasattr(t_src, attr):
                    setattr(t_dst, attr, getattr(t_src, attr))
    d.expression = s.expression


def _socket_fcurve(nt, sock, index: int):
    """The F-curve of ``sock``'s value (channel ``index``) in ``nt``'s action, made where missing."""
    path = sock.path_from_id("default_value")
    for c in fcurves(nt):
        if c.data_path == path and c.array_index == index:
            return c
    if isinstance(sock.default_value, float):
        sock.keyframe_insert("default_value", frame=0.0)
    else:
        sock.keyframe_insert("default_value", index=index, frame=0.0)
    return next(c for c in fcurves(nt) if c.data_path == path and c.array_index == index)


def mirror_panel(mat) -> bool:
    """Copy the keyframes and drivers of ``mat``'s panel values onto its Lamella node's inputs
    (and remove the copies whose panel animation is gone). Returns whether the set of mirrored
    inputs changed (the shader then reads others live: a structure edit)."""
    node = face.face_node(mat)
    if node is None or node.node_tree is None:
        return False
    if mat.animation_data is None and not node.node_tree.get(MIRROR_KEY):
        return False
    nt = node.id_data
    settings = mat.lamella
    sources = {}  # (key, channel) -> ("fcurve" | "driver", the panel's)
    for kind, items in (("fcurve", fcurves(mat)), ("driver", drivers(mat))):
        for c in items:
            key = panel_key(settings, c.data_path)
            if key is not None:
                sources[(key, c.array_index)] = (kind, c)
    before = sorted({str(k) for k in node.node_tree.get(MIRROR_KEY, [])})
    for (key, channel), (kind, src) in sources.items():
        sock = face.node_socket(node, key)
        if sock is None:
            continue
        index = channel if not isinstance(sock.default_value, float) else 0
        if kind == "fcurve":
            _copy_keys(src, _socket_fcurve(nt, sock, index))
        else:
            path = sock.path_from_id("default_value")
            dst = next((d for d in drivers(nt) if d.data_path == path and d.array_index == index), None)
            if dst is None:
                dst = sock.driver_add("default_value", index) if not isinstance(sock.default_value, float) \
                    else sock.driver_add("default_value")
            _copy_driver(src, dst)
    now = sorted({key for key, _ in sources})
    for key in set(before) - set(now):  # the panel's animation went: so does its copy
        sock = face.node_socket(node, key)
        if sock is None:
            continue
        path = sock.path_from_id("default_value")
        for c in [c for c in fcurves(nt) if c.data_path == path]:
            _remove_fcurve(nt, c)
        for d in drivers(nt):
            if d.data_path == path:
                nt.animation_data.drivers.remove(d)
    node.node_tree[MIRROR_KEY] = now
    return now != before


def _remove_fcurve(idblock, fc) -> None:
    _channels(idblock.animation_data).fcurves.remove(fc)
