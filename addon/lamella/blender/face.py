"""A Lamella material's face: the one shading node an artist sees, textures and composes.

The face is a group node (``FACE``) in the material's own node tree. Its group (one per material,
``Lamella <material>``) has an input for every field of every layer, in the panel's order and
units, named "<layer label>: <field label>" ("Clear Coat: Roughness", in Blender's roughness r),
with the field's tooltip, and typed for its value (a reflectance a colour, any other RGB field
three values, a rotation an angle within a turn, a film thickness in nanometres), then ``Normal``
and ``Tangent``, and a ``BSDF`` output, with ``Thickness`` (0)
for the output's Thickness, which only EEVEE reads (``THICKNESS``). The artist links textures
into it and puts it anywhere in their tree (a Mix Shader, an Add Shader with an emission);
Lamella never touches a node or link outside the group except to link a face it has just created
(or a face of an earlier version that had no Thickness) into an output whose surface shows
nothing Lamella did not make: its BSDF into the surface, its Thickness into a free Thickness; and,
for glass, its own Thickness link, which EEVEE needs unlinked for a solid base and linked for a
thin-walled one (``material_nodes.eevee_settings``).

Each input belongs to a layer, not to a position: its key is ``<layer uid>/<field>``
(``FaceInput``), kept in the group (``SOCKETS_KEY``: interface socket identifier -> key), so a
texture, keyframe or link on a coat stays on that coat when others are added, removed, moved,
muted or duplicated. A muted coat keeps its inputs (and their links); they feed nothing.
The node records what Lamella last set on each input (``SHOWN_KEY``), so a value the artist types
there is told from it (``typed_values``, taken into the panel by ``socket_edits``).

Inside the group (rebuilt by ``wire``): each input clamped to its field's hard limits (a linked
value behaves as a panel value; a colour above a reflectance's 1 adds no energy), the normal
(the Normal input where linked, else the shading normal; the node group makes that choice itself) and the tangent (the
Tangent input where linked, else radial about the object's z, as the panel's default), then two
renderings of the same model side by side:

- the node group (``GROUP``: ``node_group``), what Cycles without OSL and EEVEE render;
- the OSL shader (``SCRIPT``), where it needs no file outside the .blend (a staged shader whose
  tables are all inside it: every material without a texture linked);

and a Mix Shader (``SWITCH``) whose factor the OSL shader drives: the shader writes 1 to it when
Cycles runs it; Cycles without OSL and EEVEE drop the Script node and read the factor's own 0, the
node group. No add-on code runs at render time, so a saved file renders the same without the
extension, in any of the three.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..core.backends.osl.emit import ENGINE_SWITCH
from ..core.layers import ANGLE, BASE_KINDS, COAT_KINDS, FLOAT, RGB, ROUGHNESS
from ..core.param_id import AXES, NORMAL as NORMAL_FIELD, layer_prefix, normal_socket, socket_name
from .kind_hooks import hooks
from .node_group import shared_group
from .osl_compile import set_socket
from .tooltips import field_tooltip, roughness_tooltip

FACE = "Lamella"  # the face node's name in the material
FACE_KEY = "lamella_face"  # a face group's layout version
FACE_LAYOUT = 1
SOCKETS_KEY = "lamella_sockets"  # face group: interface socket identifier -> input key
SHOWN_KEY = "lamella_shown"  # face node: input key -> the value Lamella last set on its socket
SCRIPT = "Lamella Shader"
GROUP = "Lamella Nodes"
SWITCH = "Lamella Switch"
NORMAL, TANGENT = "Normal", "Tangent"
FRAME_GROUP = ".lamella_face_frame_1"  # the shared normal and tangent picks (``_frame_group``)
# EEVEE's object thickness for the Material Output's Thickness (Cycles ignores it): 0, one interface.
# The node group's refraction closure is already the whole surface's refraction (a lobe about the
# transmitted direction at index REFRACT_ETA, ``lobe_kinds.transmission``); EEVEE's default thickness model adds
# a second refraction at that index, where anything off the lobe's axis is totally reflected, and
# EEVEE's ray-traced glass renders dark.
THICKNESS = "Thickness"
OUTPUTS = (("BSDF", "NodeSocketShader"), (THICKNESS, "NodeSocketFloat"))
BASE_UID = "base"


def is_face_tree(tree) -> bool:
    """Whether node group ``tree`` is a face's group."""
    return tree is not None and FACE_KEY in tree


def face_node(mat):
    """``mat``'s face node (by name, else the first group node of a face group), or None."""
    nt = mat.node_tree
    if nt is None:
        return None
    node = nt.nodes.get(FACE)
    if node is not None and node.bl_idname == "ShaderNodeGroup" and is_face_tree(node.node_tree):
        return node
    return next((n for n in nt.nodes if n.bl_idname == "ShaderNodeGroup" and is_face_tree(n.node_tree)), None)


@dataclass(frozen=True)
class FaceInput:
    """One input of the face: ``key`` (``<layer uid>/<field>``) names the layer and field it
    belongs to; ``name`` the label shown ("<layer label>: <field label>"); ``socket_type`` a
    Blender interface socket type and ``subtype``; ``value`` the panel's value (a float or an RGB
    tuple) as the socket shows it; ``lo``/``hi`` the hard limits a linked value is clamped to (None:
    open); ``shown`` the range the socket itself accepts (default ``lo``/``hi``); ``model`` the
    model socket it feeds now (``core.backends.ir.sockets``: ``coat0_roughness``), None for a muted
    layer or an input that feeds the model through a conversion: ``derived`` lists those (a kind's
    Blender hook: the conductor's reflectivity and edge tint make its eta and k); ``description``
    the socket's tooltip."""

    key: str
    name: str
    socket_type: str
    subtype: str
    value: object
    lo: float | None
    hi: float | None
    model: str | None
    derived: tuple = ()  # ((model sockets), (input keys they are made from), build(nt, sources) -> sockets), ...
    field: str = ""  # the layer field it sets (schema name, or a kind hook's property)
    axis: str = ""  # "x", "y": which roughness of an anisotropic interface
    description: str = ""
    shown: tuple | None = None  # (min, max) the socket accepts, where it differs from (lo, hi)

    @property
    def socket_range(self) -> tuple:
        lo, hi = self.shown if self.shown is not None else (self.lo, self.hi)
        return (-3.0e38 if lo is None else lo, 3.0e38 if hi is None else hi)

    @property
    def is_direction(self) -> bool:
        """A normal or a tangent: a direction, unlinked the shading frame's (no value shown)."""
        return self.field == NORMAL_FIELD


TURN = 2.0 * math.pi
# what the socket of each schema unit shows it as (a float socket's subtype)
UNIT_SUBTYPES = {"nm": "WAVELENGTH"}


def _field_inputs(kind, pg, uid: str, label: str, layer: int | None, shown: bool) -> list[FaceInput]:
    """``layer``: the layer's index in the model (a coat's among the shown coats; None: the
    base); ``shown``: whether the layer reaches the model (a muted coat's inputs feed nothing).
    A reflectance is a colour; any other RGB field (an absorption, a complex index) three values;
    a rotation an angle within a turn either way (the anisotropy repeats every half turn, so the
    socket shows the stored rotation wrapped into a half turn either way: the same look)."""
    def model(field: str, axis: str = "") -> str | None:
        return socket_name(layer, field, axis) if shown else None

    out = []
    for f in kind.fields:
        name, tip = f"{label}: {f.ui_label}", field_tooltip(f)
        if f.type == FLOAT:
            out.append(FaceInput(f"{uid}/{f.name}", name, "NodeSocketFloat", UNIT_SUBTYPES.get(f.unit, "NONE"),
                                 float(getattr(pg, f.name)), f.lo, f.hi, model(f.name), field=f.name,
                                 description=tip))
        elif f.type == ANGLE:
            out.append(FaceInput(f"{uid}/{f.name}", name, "NodeSocketFloat", "ANGLE",
                                 math.remainder(float(getattr(pg, f.name)), TURN), f.lo, f.hi, model(f.name),
                                 field=f.name, description=f"{tip}; the anisotropy repeats every half turn",
                                 shown=(-TURN, TURN)))
        elif f.type == RGB:
            out.append(FaceInput(f"{uid}/{f.name}", name, "NodeSocketColor" if f.color else "NodeSocketVector",
                                 "NONE", tuple(float(x) for x in getattr(pg, f.name)), f.lo, f.hi, model(f.name),
                                 field=f.name, description=tip))
        elif f.type == ROUGHNESS:
            x, y = AXES
            aniso = bool(getattr(pg, f"{f.name}_anisotropic"))
            out.append(FaceInput(f"{uid}/{f.name}", name, "NodeSocketFloat", "FACTOR", float(getattr(pg, f.name)),
                                 0.0, 1.0, model(f.name, x if aniso else ""), field=f.name, axis=x if aniso else "",
                                 description=roughness_tooltip(f)))
            if aniso:
                out.append(FaceInput(f"{uid}/{f.name}_y", f"{name} Y", "NodeSocketFloat", "FACTOR",
                                     float(getattr(pg, f"{f.name}_y")), 0.0, 1.0, model(f.name, y),
                                     field=f.name, axis=y, description=roughness_tooltip(f, across=True)))
    return out


def _layer_inputs(kind, pg, uid: str, label: str, layer: int | None, shown: bool) -> list[FaceInput]:
    inputs = _field_inputs(kind, pg, uid, label, layer, shown)
    hook = hooks(kind.type).face_inputs
    inputs = hook(pg, inputs, uid, label) if hook is not None else inputs
    # the layer's own normal (a bump on a coat, flakes on the base): unlinked, the shading normal
    return inputs + [FaceInput(f"{uid}/{NORMAL_FIELD}", f"{label}: Normal", "NodeSocketVector", "NONE",
                               (0.0, 0.0, 0.0), None, None, normal_socket(layer_prefix(layer)) if shown else None,
                               field=NORMAL_FIELD, description=f"The normal this layer's interface is about (a bump "
                                                               f"map's Normal); unlinked, the shading normal")]


def face_inputs(settings) -> list[FaceInput]:
    """The face's inputs for a material's Lamella ``settings``: every coat top to bottom (a muted
    one's feed nothing), then the base; Normal and Tangent are added by ``sync_interface``."""
    out, shown = [], 0
    for item in settings.coats:
        out += _layer_inputs(COAT_KINDS[item.kind], item.settings(), item.uid, item.name, shown, bool(item.show))
        shown += int(item.show)
    base = BASE_KINDS[settings.base.kind]
    out += _layer_inputs(base, settings.base.settings(), BASE_UID, "Base", None, True)
    return out


# ---------------------------------------------------------------- the group's interface
def _inputs(tree):
    return [s for s in tree.interface.items_tree if s.item_type == "SOCKET" and s.in_out == "INPUT"]


def socket_keys(tree) -> dict:
    """Interface socket identifier -> input key of a face group."""
    stored = tree.get(SOCKETS_KEY)
    return {k: str(v) for k, v in stored.items()} if stored is not None else {}


FRAME_TIPS = {NORMAL: "The shading normal of every layer without a Normal of its own (a bump map's Normal); "
                     "unlinked, the shading normal",
              TANGENT: "The direction anisotropic roughness and rotations are measured from; unlinked, a "
                       "tangent radial about the object's z axis"}


def sync_interface(tree, inputs: list[FaceInput]) -> None:
    """Make ``tree``'s interface the face's ``inputs`` (then Normal, Tangent; outputs BSDF and
    Thickness), keeping every socket whose key stays (and so the links, keyframes and drivers on
    it), renamed, retyped in place and moved to its place."""
    keys = socket_keys(tree)
    want = [(i.key, i.name, i.socket_type) for i in inputs] + [(NORMAL, NORMAL, "NodeSocketVector"),
                                                                 (TANGENT, TANGENT, "NodeSocketVector")]
    types = {k: t for k, _, t in want}
    have = {}
    for s in _inputs(tree):
        key = keys.get(s.identifier, s.name if s.name in (NORMAL, TANGENT) else None)
        if key in types and key not in have:
            if s.socket_type != types[key]:  # a colour that is now a value: retyped, its links kept
                s.socket_type = types[key]
            have[key] = s
        else:
            tree.interface.remove(s)
    outs = [s for s in tree.interface.items_tree if s.item_type == "SOCKET" and s.in_out == "OUTPUT"]
    for s in outs:
        if (s.name, s.socket_type) not in OUTPUTS:
            tree.interface.remove(s)
    for name, typ in OUTPUTS:
        if not any(s.name == name and s.socket_type == typ for s in outs):
            s = tree.interface.new_socket(name=name, in_out="OUTPUT", socket_type=typ)
            if name == THICKNESS:
                s.default_value = 0.0
    spec = {i.key: i for i in inputs}
    first = sum(1 for s in tree.interface.items_tree if s.item_type == "SOCKET" and s.in_out == "OUTPUT")
    for pos, (key, name, typ) in enumerate(want):
        s = have.get(key)
        if s is None:
            s = have[key] = tree.interface.new_socket(name=name, in_out="INPUT", socket_type=typ)
        if s.name != name:
            s.name = name
        i = spec.get(key)
        tip = FRAME_TIPS.get(key, "") if i is None else i.description
        if s.description != tip:
            s.description = tip
        if i is None or i.is_direction:  # Normal, Tangent, a layer's own normal
            s.hide_value = True
        else:
            s.hide_value = False
            if hasattr(s, "subtype") and s.subtype != i.subtype:
                try:
                    s.subtype = i.subtype
                except (TypeError, AttributeError):
                    pass
            if hasattr(s, "min_value"):
                s.min_value, s.max_value = i.socket_range
            set_socket(s, i.value)
        if s.position != first + pos:  # in order, every move is upward: it lands where it is asked to
            tree.interface.move(s, first + pos)
    tree[SOCKETS_KEY] = {s.identifier: key for key, s in have.items()}


def node_sockets(node) -> dict:
    """The face node's input sockets by input key."""
    tree = node.node_tree
    if tree is None:
        return {}
    by_ident = {s.identifier: s for s in node.inputs}
    return {k: by_ident[i] for i, k in socket_keys(tree).items() if i in by_ident}


def node_socket(node, key: str):
    """The face node's input socket of ``key``, or None."""
    return node_sockets(node).get(key)


def socket_value(sock) -> tuple:
    """What an input socket holds, as a tuple of its float32 numbers (one for a value)."""
    v = sock.default_value
    return tuple(float(x) for x in v) if hasattr(v, "__len__") else (float(v),)


def set_node_values(node, inputs: list[FaceInput]) -> None:
    """The face node's inputs show the panel's values (what the shader bakes where nothing is
    linked), and the node records what each now holds (``SHOWN_KEY``), so a value typed on the node
    afterwards is told from the one Lamella set (``typed_values``)."""
    socks = node_sockets(node)
    shown = {}
    for i in inputs:
        sock = socks.get(i.key)
        if sock is not None and not i.is_direction:
            set_socket(sock, i.value)
            shown[i.key] = socket_value(sock)
    node[SHOWN_KEY] = shown


def typed_values(node, inputs: list[FaceInput], animated=frozenset()) -> list[tuple[FaceInput, tuple]]:
    """The inputs whose value the artist typed on the node since Lamella last set it (neither
    linked nor animated, holding another value than the one ``set_node_values`` recorded), each
    with the value it holds now; they are recorded as seen."""
    shown = node.get(SHOWN_KEY)
    if shown is None:
        return []
    socks, out = node_sockets(node), []
    for i in inputs:
        sock, was = socks.get(i.key), shown.get(i.key)
        if sock is None or was is None or i.is_direction or sock.is_linked \
                or sock.path_from_id("default_value") in animated:
            continue
        now = socket_value(sock)
        if now != tuple(was):
            out.append((i, now))
            shown[i.key] = now
    return out


def live_keys(node, inputs: list[FaceInput], animated=frozenset()) -> frozenset:
    """The keys of the face inputs that are linked (a texture, an attribute, another node) or
    animated (keyframes or a driver on the input; ``animated``: the animated data paths of the
    node's tree, ``animation.animated_paths``)."""
    socks = node_sockets(node)

    def live(key):
        sock = socks.get(key)
        return sock is not None and (sock.is_linked or sock.path_from_id("default_value") in animated)

    return frozenset(i.key for i in inputs if live(i.key))


def linked_models(node, inputs: list[FaceInput], animated=frozenset()) -> tuple:
    """The model sockets whose face inputs are linked or animated (``live_keys``): what the shader
    must read live, so the renderer reads them on every frame in every engine. Sorted."""
    live = live_keys(node, inputs, animated)
    out = set()
    for i in inputs:
        if i.model and i.key in live:
            out.add(i.model)
        for models, keys, _ in i.derived:
            if live.intersection(keys):
                out.update(models)
    return tuple(sorted(out))


# ---------------------------------------------------------------- inside the group
X = 200.0


def _clamped(nt, src, i: FaceInput, y: float):
    """``src`` clamped to ``i``'s hard limits (a colour channel-wise)."""
    out = src
    if i.socket_type in ("NodeSocketColor", "NodeSocketVector"):
        for op, bound in (("MAXIMUM", i.lo), ("MINIMUM", i.hi)):
            if bound is None:
                continue
            n = nt.nodes.new("ShaderNodeVectorMath")
            n.operation, n.location, n.hide = op, (X if op == "MAXIMUM" else 2 * X, y), True
            n.inputs[1].default_value = (bound, bound, bound)
            nt.links.new(out, n.inputs[0])
            out = n.outputs[0]
        return out
    lo = -3.0e38 if i.lo is None else i.lo
    hi = 3.0e38 if i.hi is None else i.hi
    n = nt.nodes.new("ShaderNodeClamp")
    n.clamp_type, n.location, n.hide = "MINMAX", (X, y), True
    n.inputs["Min"].default_value, n.inputs["Max"].default_value = lo, hi
    nt.links.new(out, n.inputs["Value"])
    return n.outputs[0]


def _pick_vector(nt, given, fallback, location):
    """``given`` where it is not zero (a linked input), else ``fallback``."""
    length = nt.nodes.new("ShaderNodeVectorMath")
    length.operation, length.location, length.hide = "LENGTH", location, True
    nt.links.new(given, length.inputs[0])
    test = nt.nodes.new("ShaderNodeMath")
    test.operation, test.location, test.hide = "GREATER_THAN", (location[0] + X, location[1]), True
    nt.links.new(length.outputs["Value"], test.inputs[0])
    test.inputs[1].default_value = 1e-8
    mix = nt.nodes.new("ShaderNodeMix")
    mix.data_type, mix.location, mix.hide = "VECTOR", (location[0] + 2 * X, location[1]), True
    nt.links.new(test.outputs[0], _by_id(mix.inputs, "Factor_Float"))
    nt.links.new(fallback, _by_id(mix.inputs, "A_Vector"))
    nt.links.new(given, _by_id(mix.inputs, "B_Vector"))
    return _by_id(mix.outputs, "Result_Vector")


def _frame_group():
    """The nested group that picks the shading frame the OSL shader reads: the Normal input where
    linked (not zero), else the shading normal; the Tangent input likewise, else the tangent
    radial about the object's z axis. One per file (``FRAME_GROUP``), shared by every face
    (``node_group.shared_group``)."""
    return shared_group(FRAME_GROUP, _build_frame_group)


def _build_frame_group(tree) -> None:
    for in_out in ("INPUT", "OUTPUT"):
        for name in (NORMAL, TANGENT):
            tree.interface.new_socket(name=name, in_out=in_out, socket_type="NodeSocketVector")
    nt = tree
    gin = nt.nodes.new("NodeGroupInput")
    gin.location = (-X, 0.0)
    geometry = nt.nodes.new("ShaderNodeNewGeometry")
    geometry.location, geometry.hide = (0.0, 200.0), True
    radial = nt.nodes.new("ShaderNodeTangent")
    radial.direction_type, radial.axis, radial.location, radial.hide = "RADIAL", "Z", (0.0, 160.0), True
    gout = nt.nodes.new("NodeGroupOutput")
    gout.location = (4 * X, 0.0)
    nt.links.new(_pick_vector(nt, gin.outputs[NORMAL], geometry.outputs["Normal"], (X, 200.0)), gout.inputs[NORMAL])
    nt.links.new(_pick_vector(nt, gin.outputs[TANGENT], radial.outputs["Tangent"], (X, 160.0)), gout.inputs[TANGENT])


def _by_id(sockets, identifier):
    return next(s for s in sockets if s.identifier == identifier)


def wire(tree, inputs: list[FaceInput], script, group, live=frozenset()) -> None:
    """Rebuild the group's inside around ``script`` (the Script node, or None) and ``group`` (the
    node group's node, or None; one whose group waits to be built is kept, unwired), which are
    kept: everything else is made anew. The inputs whose keys are ``live`` (linked or animated:
    ``live_keys``; what the shader reads) are clamped to their fields' hard limits; the others
    hold the panel's values, inside the limits already, which the shader bakes."""
    nt = tree
    for n in [n for n in nt.nodes if n not in (script, group)]:
        nt.nodes.remove(n)
    if group is not None and group.node_tree is None:  # kept for the build that waits (``recompile``)
        group.location = (4 * X, -100.0)
        group = None
    for link in list(nt.links):
        nt.links.remove(link)
    keys = {k: ident for ident, k in socket_keys(tree).items()}
    gin = nt.nodes.new("NodeGroupInput")
    gin.location = (-X, 0.0)

    def port(key):
        return next(s for s in gin.outputs if s.identifier == keys[key])

    frame = nt.nodes.new("ShaderNodeGroup")
    frame.node_tree, frame.location, frame.hide = _frame_group(), (X, 200.0), True
    for name in (NORMAL, TANGENT):
        nt.links.new(port(name), frame.inputs[name])
    feeds = {NORMAL: frame.outputs[NORMAL], TANGENT: frame.outputs[TANGENT]}
    read = {sock.name for node in (script, group) if node is not None for sock in node.inputs}
    spec = {i.key: (k, i) for k, i in enumerate(inputs)}
    clamped = {}

    def clamp(key):
        if key not in live or spec[key][1].is_direction:  # a normal is a direction
            return port(key)
        if key not in clamped:
            k, i = spec[key]
            clamped[key] = _clamped(nt, port(key), i, -40.0 * k)
        return clamped[key]

    for i in inputs:
        if i.model in read:
            feeds[i.model] = clamp(i.key)
        for models, sources, build in i.derived:
            if any(m in read for m in models):
                feeds.update(zip(models, build(nt, [clamp(key) for key in sources])))
    for node in (script, group):
        if node is None:
            continue
        node.location = (4 * X, 300.0 if node is script else -100.0)
        for sock in node.inputs:
            # the node group falls back on the shading normal itself (its frame); the OSL
            # shader's Normal must be a normal, and the nodes that make it run only under OSL
            src = port(NORMAL) if node is group and sock.name == NORMAL else feeds.get(sock.name)
            if src is not None:
                nt.links.new(src, sock)
    gout = nt.nodes.new("NodeGroupOutput")
    gout.location = (7 * X, 0.0)
    gout.inputs[THICKNESS].default_value = 0.0
    shaders = [n.outputs["BSDF"] for n in (group, script) if n is not None and "BSDF" in n.outputs]
    if script is not None and group is not None:
        mix = nt.nodes.new("ShaderNodeMixShader")
        mix.name = mix.label = SWITCH
        mix.location = (6 * X, 0.0)
        mix.inputs["Fac"].default_value = 0.0
        nt.links.new(script.outputs[ENGINE_SWITCH], mix.inputs["Fac"])
        nt.links.new(group.outputs["BSDF"], mix.inputs[1])
        nt.links.new(script.outputs["BSDF"], mix.inputs[2])
        nt.links.new(mix.outputs[0], gout.inputs["BSDF"])
    elif shaders:
        nt.links.new(shaders[0], gout.inputs["BSDF"])
