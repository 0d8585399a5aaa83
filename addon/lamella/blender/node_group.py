"""Build the node group of a stack from its node plan (``lamella.core.backends.nodes``).

The group ``Lamella <stack>`` has one input per socket of the model (``core.backends.ir.sockets``: roughness as Blender's r, a colour as one colour socket; named as the Script node's
sockets, so textures plug in the same way), a ``Normal`` and a ``Tangent`` input (unlinked: the
shading normal, and the tangent radial about the object's z, as in the OSL shader) and a ``BSDF``
output. Inside it:

- the local frame (the tangent made orthogonal to the normal, the bitangent) and the view
  direction in it, from the Geometry node's Incoming (``_frame``), a nested group every
  material of the same frame shares (``_frame_group``);
- the model's math as nested groups of at most ``CHUNK_NODES`` nodes (``_chunk_group``), one run
  of a section each, shared by name between every material and stack whose chunk is the same:
  an edit rebuilds only the chunks whose content changed;
- one BSDF node per lobe, in frames, summed by Add Shader nodes.

Rebuilding keeps the group (its name, its users and the links into its sockets): the group's
content is replaced, and its interface changes only where the parameters changed.
"""
from __future__ import annotations

import hashlib
from collections import defaultdict

import bpy

from ..core import luts
from ..core.backends.ir.sockets import by_param, sockets
from ..core.backends.nodes.partition import partition
from ..core.backends.nodes.plan import INSIDE_INPUT, TARGETS, Out, Plan, input_name, value_type
from ..core.param_id import normal_socket
from .osl_compile import set_socket

CHUNK_PREFIX = ".lamella_chunk_"  # a leading dot hides the nested groups from Blender's lists
SECTION_PREFIX = ".lamella_section_"
FRAME_PREFIX = ".lamella_frame_"
FRAME_VERSION = 1  # part of the frame groups' names: a change to ``_frame`` makes new ones
FRAME_OUTPUTS = (("N", "NodeSocketVector"), ("T", "NodeSocketVector"), ("B", "NodeSocketVector"),
                 ("V", "NodeSocketVector"), ("wi_x", "NodeSocketFloat"), ("wi_y", "NodeSocketFloat"),
                 ("wi_z", "NodeSocketFloat"))
X_STEP, Y_STEP = 180.0, 150.0


# ---------------------------------------------------------------- images
def table_image(file: str):
    """The EXR table ``file`` of the package as a Blender image, packed into the .blend (a file
    renders without the extension, wherever it is), loaded once per .blend and again only when the
    package's file differs from what is packed. Raw data: no colour management, four independent
    channels, full float precision."""
    path = luts.DATA_DIR / file
    digest = _file_digest(path)
    name = f".lamella_{file}"
    img = bpy.data.images.get(name)
    if img is None or img.library is not None or img.get(DIGEST_KEY) != digest or img.packed_file is None:
        if img is not None and img.library is None:
            img.name = f"{name}.old"  # nodes that read it keep it until they are rebuilt
        img = bpy.data.images.load(str(path), check_existing=False)
        img.name = name
        img.pack()
        img[DIGEST_KEY] = digest
    img.colorspace_settings.is_data = True
    img.alpha_mode = "CHANNEL_PACKED"
    if hasattr(img, "use_half_precision"):
        img.use_half_precision = False
    return img


DIGEST_KEY = "lamella_digest"  # custom property of a packed table image: the digest of the package's file
_DIGESTS: dict = {}


def _file_digest(path) -> str:
    key = str(path)
    if key not in _DIGESTS:
        _DIGESTS[key] = hashlib.sha256(path.read_bytes()).hexdigest()[:16]
    return _DIGESTS[key]


def missing_images(tree) -> list[str]:
    """The names of the images ``tree``'s Image Texture nodes (nested groups included) have lost:
    an image deleted leaves its node reading nothing."""
    gone, seen, todo = [], set(), [tree]
    while todo:
        t = todo.pop()
        if t is None or t.name_full in seen:
            continue
        seen.add(t.name_full)
        for n in t.nodes:
            if n.bl_idname == "ShaderNodeTexImage" and n.image is None:
                gone.append(n.label or n.name)
            elif n.bl_idname == "ShaderNodeGroup":
                todo.append(n.node_tree)
    return gone


# ---------------------------------------------------------------- helpers
def _socket(sockets, identifier):
    for s in sockets:
        if s.identifier == identifier:
            return s
    raise KeyError(identifier)


def material_table_image(name: str, pixels):
    """The image ``name`` holding a staged material's table (RGBA float, rows bottom first),
    created or updated in place and packed into the .blend, so the file renders elsewhere. Raw
    data: no colour management, full float precision."""
    h, w = pixels.shape[:2]
    img = bpy.data.images.get(name)
    kept = {}
    if img is not None and (tuple(img.size) != (w, h) or not img.is_float):
        kept = {k: img[k] for k in img.keys()}  # what says whose table it is
        bpy.data.images.remove(img)
        img = None
    if img is None:
        img = bpy.data.images.new(name, w, h, alpha=True, float_buffer=True, is_data=True)
        img.name = name
        for k, v in kept.items():
            img[k] = v
    img.colorspace_settings.is_data = True
    img.alpha_mode = "CHANNEL_PACKED"
    if hasattr(img, "use_half_precision"):
        img.use_half_precision = False
    img.pixels.foreach_set(pixels.astype("float32").reshape(-1))
    img.update()
    img.pack()
    return img


def _image(name: str):
    img = bpy.data.images.get(name)
    if img is not None and name.startswith(".lamella_table"):
        return img
    return table_image(name)


def _new_node(nt, bl_idname, props, location, label=""):
    n = nt.nodes.new(bl_idname)
    for k, v in props.items():
        setattr(n, k, _image(v) if k == "image" else v)
    n.location = location
    if label:
        n.label = label
    return n


def _interface(tree, in_out, name, socket_type, default=None):
    s = tree.interface.new_socket(name=name, in_out=in_out, socket_type=socket_type)
    if default is not None and hasattr(s, "default_value"):
        s.default_value = default
    return s


def _depths(plan: Plan, nodes: list[int]) -> dict[int, int]:
    local = set(nodes)
    depth = {}
    for i in nodes:
        ins = [v.node for v in plan.nodes[i].inputs.values() if isinstance(v, Out) and v.node in local]
        depth[i] = 1 + max((depth[j] for j in ins), default=0)
    return depth


# ---------------------------------------------------------------- chunks
def _intact(tree) -> bool:
    """Whether a nested group can be reused: every image it reads is still there."""
    return all(n.image is not None and not n.image.name.endswith(".old")
               for n in tree.nodes if n.bl_idname == "ShaderNodeTexImage")


def _chunk_group(plan: Plan, chunk):
    """The nested group of one chunk, reused when a group of the same content exists."""
    tree = bpy.data.node_groups.get(f"{CHUNK_PREFIX}{chunk.digest}")
    if tree is not None and _intact(tree):
        return tree
    if tree is not None:  # an image it read was deleted: built again under the same name
        tree.name = f"{tree.name}.broken"
    tree = _new_tree(plan, f"{CHUNK_PREFIX}{chunk.digest}", chunk)
    nt = tree
    depth = _depths(plan, chunk.nodes)
    rows: dict[int, int] = defaultdict(int)
    gin = nt.nodes.new("NodeGroupInput")
    gin.location = (-X_STEP, 0.0)
    made = {}
    for i in chunk.nodes:
        n = plan.nodes[i]
        d = depth[i]
        node = _new_node(nt, n.bl_idname, n.props, (d * X_STEP, -rows[d] * Y_STEP))
        rows[d] += 1
        made[i] = node
    gout = nt.nodes.new("NodeGroupOutput")
    gout.location = ((max(depth.values(), default=0) + 1) * X_STEP, 0.0)
    in_index = {v: k for k, v in enumerate(chunk.inputs)}
    for i in chunk.nodes:
        n, node = plan.nodes[i], made[i]
        for ident, v in n.inputs.items():
            sock = _socket(node.inputs, ident)
            if isinstance(v, Out):
                src = (_socket(made[v.node].outputs, v.socket) if v.node in made
                       else gin.outputs[in_index[v]])
                nt.links.new(src, sock)
            else:
                sock.default_value = float(v)
        _constant_inputs(node)
    for k, v in enumerate(chunk.outputs):
        nt.links.new(_socket(made[v.node].outputs, v.socket), gout.inputs[k])
    return tree


def _constant_inputs(node) -> None:
    """Hide the value of every unlinked input of a plan node (its literals, and the inputs its
    operation does not read, such as a binary Math node's third). EEVEE makes each unlinked input
    whose value shows a uniform, a 4-byte slot in the material's 64 KiB uniform block, and a
    group's unlinked or Value-fed input one per use: eight coats with media (21 000 nodes) needed
    88 096 bytes. A hidden value is a constant of the generated shader instead, which the GLSL
    compiler folds (measured: that stack's first EEVEE render took 13 s with hidden literals,
    39 s with literals as uniforms). Cycles reads the values either way."""
    for sock in node.inputs:
        if not sock.is_linked:
            sock.hide_value = True


def _new_tree(plan: Plan, name: str, chunk):
    """A nested group whose sockets carry the chunk's values with their types (``value_type``: a
    vector or colour passed through a float socket would be converted, as Blender converts links)."""
    tree = bpy.data.node_groups.new(name, "ShaderNodeTree")
    for k, v in enumerate(chunk.inputs):
        _interface(tree, "INPUT", input_name(plan, v, k), _SOCKET_TYPES[value_type(plan, v)])
    for k, v in enumerate(chunk.outputs):
        _interface(tree, "OUTPUT", f"out{k}", _SOCKET_TYPES[value_type(plan, v)])
    return tree


_SOCKET_TYPES = {"float": "NodeSocketFloat", "vector": "NodeSocketVector", "color": "NodeSocketColor"}


def _section_group(plan: Plan, section):
    """The nested group of a section: its chunks' groups, wired; reused like a chunk's."""
    tree = bpy.data.node_groups.get(f"{SECTION_PREFIX}{section.digest}")
    if tree is not None and all(n.node_tree is not None and _intact(n.node_tree)
                                for n in tree.nodes if n.bl_idname == "ShaderNodeGroup"):
        return tree
    if tree is not None:
        tree.name = f"{tree.name}.broken"
    tree = _new_tree(plan, f"{SECTION_PREFIX}{section.digest}", section)
    nt = tree
    gin = nt.nodes.new("NodeGroupInput")
    gin.location = (-2 * X_STEP, 0.0)
    in_index = {v: k for k, v in enumerate(section.inputs)}
    made = {}
    for k, c in enumerate(section.parts):
        node = nt.nodes.new("ShaderNodeGroup")
        node.node_tree = _chunk_group(plan, c)
        node.location = (k * 1.5 * X_STEP, -(k % 2) * Y_STEP)
        for j, v in enumerate(c.inputs):
            nt.links.new(made[v] if v in made else gin.outputs[in_index[v]], node.inputs[j])
        for j, v in enumerate(c.outputs):
            made[v] = node.outputs[j]
    gout = nt.nodes.new("NodeGroupOutput")
    gout.location = ((len(section.parts) + 1) * 1.5 * X_STEP, 0.0)
    for k, v in enumerate(section.outputs):
        nt.links.new(made[v], gout.inputs[k])
    return tree


# ---------------------------------------------------------------- the group
class _Vec:
    """Vector math in the group under construction."""

    def __init__(self, nt):
        self.nt = nt
        self.x = 0.0
        self.y = 400.0

    def node(self, bl_idname, props=None, inputs=None, out=0, label=""):
        n = _new_node(self.nt, bl_idname, props or {}, (self.x, self.y), label)
        self.y -= Y_STEP
        for ident, v in (inputs or {}).items():
            sock = _socket(n.inputs, ident)
            if isinstance(v, bpy.types.NodeSocket):
                self.nt.links.new(v, sock)
            else:
                sock.default_value = v
        return n.outputs[out] if isinstance(out, int) else _socket(n.outputs, out)

    def vmath(self, op, a, b=None, out=0):
        ins = {"Vector": a}
        if b is not None:
            ins["Vector_001"] = b
        return self.node("ShaderNodeVectorMath", {"operation": op}, ins, out)

    def math(self, op, a, b):
        return self.node("ShaderNodeMath", {"operation": op}, {"Value": a, "Value_001": b})

    def pick(self, use, a, b):
        """``a`` where ``use`` is 1, else ``b`` (a vector Mix)."""
        return self.node("ShaderNodeMix", {"data_type": "VECTOR", "clamp_factor": False},
                         {"Factor_Float": use, "A_Vector": b, "B_Vector": a}, "Result_Vector")

    def nonzero(self, v):
        return self.math("GREATER_THAN", self.vmath("LENGTH", v, out="Value"), 1e-8)

    def project(self, t, n):
        """t without its component along n."""
        d = self.vmath("DOT_PRODUCT", t, n, out="Value")
        return self.vmath("SUBTRACT", t, self.scale(n, d))

    def scale(self, v, s):
        return self.node("ShaderNodeVectorMath", {"operation": "SCALE"}, {"Vector": v, "Scale": s})


def _frame(g: _Vec, gin, tangent_input: bool, view_frame: bool = False):
    """(N, T, B, V, wi) of the shading point: the Normal input where linked (else the shading
    normal), the Tangent input made orthogonal to N, falling back like the OSL shader on the
    tangent radial about world z and then on N x y, N x x; V the unit vector toward the viewer.
    With ``view_frame`` (a staged isotropic stack) T is the view's azimuth, V made orthogonal to
    N, where the view is not along the normal."""
    geo = g.node("ShaderNodeNewGeometry", out="Normal")
    geo_node = geo.node
    n_in = gin.outputs["Normal"]
    n = g.vmath("NORMALIZE", g.pick(g.nonzero(n_in), n_in, geo))
    v = g.vmath("NORMALIZE", geo_node.outputs["Incoming"])
    px = g.node("ShaderNodeSeparateXYZ", inputs={"Vector": geo_node.outputs["Position"]}, out="X")
    neg_y = g.math("MULTIPLY", px.node.outputs["Y"], -1.0)
    radial = g.node("ShaderNodeCombineXYZ", inputs={"X": neg_y, "Y": px, "Z": 0.0})
    candidates = [g.project(v, n)] if view_frame else []
    candidates += [g.project(gin.outputs["Tangent"], n)] if tangent_input else []
    candidates += [g.project(radial, n), g.vmath("CROSS_PRODUCT", n, (0.0, 1.0, 0.0)),
                   g.vmath("CROSS_PRODUCT", n, (1.0, 0.0, 0.0))]
    t = candidates[-1]
    for c in reversed(candidates[:-1]):
        t = g.pick(g.nonzero(c), c, t)
    t = g.vmath("NORMALIZE", t)
    b = g.vmath("CROSS_PRODUCT", n, t)
    wi = [g.vmath("DOT_PRODUCT", v, axis, out="Value") for axis in (t, b, n)]
    return n, t, b, v, wi


def shared_group(name: str, build):
    """The file's nested group ``name``, which every material shares (its nodes are the same for
    all): ``build(tree)`` fills a new one where there is none of this file's own."""
    tree = bpy.data.node_groups.get(name)
    if tree is not None and tree.library is None and len(tree.nodes) > 2:
        return tree
    tree = bpy.data.node_groups.new(name, "ShaderNodeTree")
    build(tree)
    return tree


def _frame_group(view_frame: bool):
    """The nested group computing ``_frame`` (inputs Normal, Tangent; outputs ``FRAME_OUTPUTS``),
    one per file for each kind of frame (``shared_group``)."""
    return shared_group(f"{FRAME_PREFIX}{'view' if view_frame else 'shading'}_{FRAME_VERSION}",
                        lambda tree: _build_frame_group(tree, view_frame))


def _build_frame_group(tree, view_frame: bool) -> None:
    for socket in ("Normal", "Tangent"):
        _interface(tree, "INPUT", socket, "NodeSocketVector")
    for socket, typ in FRAME_OUTPUTS:
        _interface(tree, "OUTPUT", socket, typ)
    g = _Vec(tree)
    gin = tree.nodes.new("NodeGroupInput")
    gin.location = (-X_STEP, 0.0)
    n, t, b, v, wi = _frame(g, gin, tangent_input=True, view_frame=view_frame)
    gout = tree.nodes.new("NodeGroupOutput")
    gout.location = (g.x + 2 * X_STEP, 0.0)
    for sock, src in zip(FRAME_OUTPUTS, (n, t, b, v, *wi)):
        tree.links.new(src, gout.inputs[sock[0]])
    for node in tree.nodes:
        if node.bl_idname not in ("NodeGroupInput", "NodeGroupOutput"):
            _constant_inputs(node)


def _shared_frame(nt, gin, view_frame: bool, location):
    """(N, T, B, V, wi) from the shared frame group (``_frame_group``), fed by ``gin``'s Normal and
    Tangent."""
    node = nt.nodes.new("ShaderNodeGroup")
    node.node_tree = _frame_group(view_frame)
    node.label, node.location = "frame", location
    for socket in ("Normal", "Tangent"):
        nt.links.new(gin.outputs[socket], node.inputs[socket])
    out = [node.outputs[name] for name, _ in FRAME_OUTPUTS]
    return out[0], out[1], out[2], out[3], out[4:]


def _layer_frame(g: _Vec, key, inputs: dict, frame):
    """The frame of a closure about the layers' own normals (``layer_normals.frame_key``: each
    layer's normal input, the shading normal where it is zero, weighted by its tilt): the shading
    normal plus the weighted tilts, normalised; the shading tangent made orthogonal to it (the
    bitangent where the tangent lies along it); their cross product; the view and ``wi`` of the
    shading ``frame``."""
    n, t, b, v, wi = frame
    acc = n
    for layer, w in key:
        given = inputs[layer]
        nl = g.vmath("NORMALIZE", g.pick(g.nonzero(given), given, n))
        acc = g.vmath("ADD", acc, g.scale(g.project(nl, n), w))
    nl = g.vmath("NORMALIZE", acc)
    tl = g.project(t, nl)
    tl = g.vmath("NORMALIZE", g.pick(g.nonzero(tl), tl, g.project(b, nl)))
    return nl, tl, g.vmath("CROSS_PRODUCT", nl, tl), v, wi


def _local_to_world(g: _Vec, comps, frame, src):
    """The world vector of local components ``comps`` (plan values): x T + y B + z N."""
    n, t, b, v, wi = frame
    if all(isinstance(c, Out) and c.node < 0 for c in comps) and \
            [src(c) for c in comps] == wi:
        return v
    terms = []
    for c, axis in zip(comps, (t, b, n)):
        if not isinstance(c, Out):
            if c == 0.0:
                continue
            if c == 1.0:
                terms.append(axis)
                continue
        terms.append(g.scale(axis, src(c)))
    if len(terms) == 1 and terms[0] is n:
        return n
    acc = terms[0]
    for term in terms[1:]:
        acc = g.vmath("ADD", acc, term)
    return g.vmath("NORMALIZE", acc)


def group_name(stack_name: str) -> str:
    return f"Lamella {stack_name or 'stack'}"


def build_group(plan: Plan, name: str, tree=None):
    """Build (or rebuild in place) the node group of ``plan``; returns it."""
    if tree is None:
        tree = bpy.data.node_groups.get(name) or bpy.data.node_groups.new(name, "ShaderNodeTree")
    _sync_interface(tree, plan)
    tree.nodes.clear()
    tree.description = (f"Lamella layered material ({plan.model}): in Cycles the closures of the OSL shader; "
                        "in EEVEE each anisotropic lobe as isotropic lobes tilted along its streak, see docs/node_groups.md")
    nt = tree
    g = _Vec(nt)
    gin = nt.nodes.new("NodeGroupInput")
    gin.location = (-3 * X_STEP, 0.0)
    g.x = -X_STEP
    for image, pixels in plan.images.items():
        material_table_image(image, pixels)
    frame = _shared_frame(nt, gin, plan.frame == "view", (-X_STEP, 400.0))
    wi = frame[4]
    layer_normals = {n: gin.outputs[normal_socket(n)] for n in plan.normals}
    layer_frames = {b.frame: _layer_frame(g, b.frame, layer_normals, frame) for b in plan.bsdfs if b.frame}
    leaf_src = {}
    convert = by_param(plan.ids)
    colours = {}
    for k, leaf in enumerate(plan.leaves):
        if leaf in ("wi_x", "wi_y", "wi_z"):
            leaf_src[-1 - k] = wi[("wi_x", "wi_y", "wi_z").index(leaf)]
            continue
        if leaf == INSIDE_INPUT:  # a solid dielectric base's far side: seen from inside it
            geometry = nt.nodes.new("ShaderNodeNewGeometry")
            geometry.label, geometry.location = "seen from inside: the back faces", (-X_STEP, 700.0)
            leaf_src[-1 - k] = geometry.outputs["Backfacing"]
            continue
        sk, ch = convert[leaf]  # the parameter from its socket (panel units)
        sock = gin.outputs[sk.name]
        if sk.convert == "square":
            leaf_src[-1 - k] = g.math("MULTIPLY", sock, sock)
        elif sk.convert == "channels":
            if sk.name not in colours:
                colours[sk.name] = g.node("ShaderNodeSeparateColor", {"mode": "RGB"}, {"Color": sock}).node
            leaf_src[-1 - k] = colours[sk.name].outputs[ch]
        else:
            leaf_src[-1 - k] = sock

    sections = partition(plan)
    outs: dict[Out, object] = {}
    own: dict[int, object] = {}  # the nodes reading the material's own table, built here

    def src(v):
        if not isinstance(v, Out):
            return v
        if v.node in own:
            return _socket(own[v.node].outputs, v.socket)
        return leaf_src[v.node] if v.node < 0 else outs[v]

    frames = {}
    col = defaultdict(int)
    for c in sections:
        if c.own:
            for k, i in enumerate(c.nodes):
                n = plan.nodes[i]
                node = own[i] = _new_node(nt, n.bl_idname, n.props,
                                          ((len(frames) * 2 + 1) * X_STEP, -(col["own"] + k) * Y_STEP))
                for ident, v in n.inputs.items():
                    if isinstance(v, Out):
                        nt.links.new(src(v), _socket(node.inputs, ident))
                    else:
                        _socket(node.inputs, ident).default_value = float(v)
                _constant_inputs(node)
            col["own"] += len(c.nodes)
            continue
        sub = _section_group(plan, c)
        node = nt.nodes.new("ShaderNodeGroup")
        node.node_tree = sub
        node.label = plan.sections.get(c.scope, c.scope)
        fr = frames.get(c.scope)
        if fr is None:
            fr = frames[c.scope] = nt.nodes.new("NodeFrame")
            fr.label = plan.sections.get(c.scope, c.scope)
        node.parent = fr
        node.location = (len(frames) * 2 * X_STEP, -col[c.scope] * 2 * Y_STEP)
        col[c.scope] += 1
        for k, v in enumerate(c.inputs):
            nt.links.new(src(v), node.inputs[k])
        for k, v in enumerate(c.outputs):
            outs[v] = node.outputs[k]

    x = (len(frames) + 2) * 2 * X_STEP
    g.x, g.y = x, 400.0
    sums = {target: None for target in TARGETS}  # each target's closures, summed
    lobes = nt.nodes.new("NodeFrame")
    lobes.label = "lobes"
    for b in plan.bsdfs:
        color = g.node("ShaderNodeCombineColor", {"mode": "RGB"},
                       {"Red": src(b.color[0]), "Green": src(b.color[1]), "Blue": src(b.color[2])})
        bsdf = _new_node(nt, b.bl_idname, b.props, (x + X_STEP, g.y), b.label)
        bsdf.parent = lobes
        nt.links.new(color, bsdf.inputs["Color"])
        for sock, v in b.floats.items():
            s = bsdf.inputs[sock]
            if isinstance(v, Out):
                nt.links.new(src(v), s)
            elif sock == "IOR" and b.bl_idname in _INVERTS_ON_BACK_FACES:
                nt.links.new(_facing_ior(g, v), s)
            else:
                s.default_value = v
        for sock, comps in b.vectors.items():
            if comps is not None:
                nt.links.new(_local_to_world(g, comps, layer_frames.get(b.frame, frame), src), bsdf.inputs[sock])
        sums[b.target] = _added(nt, sums[b.target], bsdf.outputs[0], (x + 2 * X_STEP, g.y))
    shader = sums["all"]
    if sums["cycles"] is not None or sums["eevee"] is not None:
        cycles = _added(nt, shader, sums["cycles"], (x + 3 * X_STEP, g.y))
        eevee = _added(nt, shader, sums["eevee"], (x + 3 * X_STEP, g.y - Y_STEP))
        mix = _new_node(nt, "ShaderNodeMixShader", {}, (x + 4 * X_STEP, g.y), "EEVEE: the stand-ins")
        # Cycles drops the Shader to RGB node and reads the unlinked value of the socket it feeds
        mix.inputs["Fac"].default_value = 0.0
        nt.links.new(_eevee_switch(nt, (x + 3 * X_STEP, g.y + 2 * Y_STEP)), mix.inputs["Fac"])
        _link_or_empty(nt, cycles, mix.inputs[1])
        _link_or_empty(nt, eevee, mix.inputs[2])
        shader = mix.outputs[0]
    gout = nt.nodes.new("NodeGroupOutput")
    gout.location = (x + 3 * X_STEP, 0.0)
    if shader is not None:
        nt.links.new(shader, gout.inputs["BSDF"])
    return tree


def _added(nt, a, b, location):
    """The sum of the shader outputs ``a`` and ``b`` (either None: the other)."""
    if a is None or b is None:
        return a if b is None else b
    add = _new_node(nt, "ShaderNodeAddShader", {}, location)
    nt.links.new(a, add.inputs[0])
    nt.links.new(b, add.inputs[1])
    return add.outputs[0]


def _link_or_empty(nt, shader, socket) -> None:
    """``shader`` into ``socket``; nothing (no light) where it is None."""
    if shader is not None:
        nt.links.new(shader, socket)


def _eevee_switch(nt, location):
    """1 in EEVEE, 0 in Cycles (with or without OSL): the Shader to RGB of a white emission, which
    EEVEE evaluates and Cycles drops, reading the default value of the socket it is linked to
    instead (so that socket's default must be 0; ``bench/eevee_engine_switch.md``, measured in
    every supported Blender; the Light Path node cannot tell the engines apart)."""
    emission = _new_node(nt, "ShaderNodeEmission", {}, location, "white")
    emission.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    emission.inputs["Strength"].default_value = 1.0
    to_rgb = _new_node(nt, "ShaderNodeShaderToRGB", {}, (location[0] + X_STEP, location[1]), "1 in EEVEE, 0 in Cycles")
    nt.links.new(emission.outputs[0], to_rgb.inputs[0])
    return to_rgb.outputs["Color"]


# Cycles' refracting BSDF nodes take 1 / IOR on a back face (svm_node_closure_bsdf: ``eta =
# (sd->flag & SD_BACKFACING) ? 1.0f / eta : eta``); the OSL closure the node stands for takes its
# index as given on both sides. Without the correction, light inside a closed glass object meets
# index 1 / 100 at the far side and is trapped.
_INVERTS_ON_BACK_FACES = ("ShaderNodeBsdfRefraction",)


def _facing_ior(g, ior: float):
    """``ior`` on a front face and 1 / ``ior`` on a back face, so that a node that inverts its index
    on back faces refracts with ``ior`` on both, as the OSL closure does."""
    geo = g.node("ShaderNodeNewGeometry", {}, {}, out="Backfacing")
    return g.node("ShaderNodeMath", {"operation": "MULTIPLY_ADD"},
                  {"Value": geo, "Value_001": 1.0 / ior - ior, "Value_002": ior})


def _sync_interface(tree, plan: Plan):
    """Make the group's sockets the plan's parameters (sorted), Normal, Tangent and BSDF, keeping
    the sockets that stay (and so the links into them from the material)."""
    shown = {sk.name: sk for sk in sockets(plan.ids)}
    want = [(sk.name, "NodeSocketColor" if sk.kind == "color" else "NodeSocketFloat") for sk in shown.values()]
    want += [("Normal", "NodeSocketVector"), ("Tangent", "NodeSocketVector")]
    want += [(normal_socket(n), "NodeSocketVector") for n in plan.normals]
    items = {(s.name, s.in_out): s for s in tree.interface.items_tree if s.item_type == "SOCKET"}
    for (nm, io), s in list(items.items()):
        if io == "INPUT" and (nm not in dict(want) or s.socket_type != dict(want)[nm]):
            tree.interface.remove(s)
        elif io == "OUTPUT" and nm != "BSDF":
            tree.interface.remove(s)
    items = {(s.name, s.in_out): s for s in tree.interface.items_tree if s.item_type == "SOCKET"}
    for nm, typ in want:
        s = items.get((nm, "INPUT"))
        if s is None:
            s = _interface(tree, "INPUT", nm, typ)
        if typ == "NodeSocketVector":
            s.hide_value = True
        elif nm in shown:
            set_socket(s, shown[nm].value)
    if ("BSDF", "OUTPUT") not in items:
        _interface(tree, "OUTPUT", "BSDF", "NodeSocketShader")
    # order: parameters, Normal, Tangent
    for pos, (nm, _) in enumerate(want):
        s = next(s for s in tree.interface.items_tree if s.item_type == "SOCKET" and s.in_out == "INPUT" and s.name == nm)
        tree.interface.move(s, pos)
