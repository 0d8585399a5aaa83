"""The node plan: what the node-graph backend makes of a traced model, pure data without bpy
(``lamella.blender.node_group`` instantiates it). Math nodes in topological order whose inputs are
``Out`` references or literals, the leaves (the group's inputs), the BSDF nodes of the lobes, the
material's table images, and the conventions every reader of a plan shares: a Math node's input
sockets, the table image's name and size, where a table's nodes sit in texture space, and the
type and name of a value passed into a nested group."""
from __future__ import annotations

from dataclasses import dataclass, field

from ..ir.closures import INSIDE_INPUT  # a leaf: 1 where the surface is seen from behind (a solid glass's far side)

MATH_IN = ("Value", "Value_001", "Value_002")  # socket identifiers of a Math node's inputs
TABLE_IMAGE = ".lamella_table"
TABLE_SIZE = 8192  # texels: the material table image's widest and tallest (GPUs take 16384; older ones 8192)


@dataclass(frozen=True)
class Out:
    """An output socket of a plan node (``node`` is the node's index in ``Plan.nodes``; a negative
    index -1 - k is the k-th leaf, a group input named ``Plan.leaves[k]``)."""

    node: int
    socket: str


@dataclass
class PlanNode:
    """One Blender node: its type, its properties, and its inputs by socket identifier (an
    ``Out`` or a literal float)."""

    bl_idname: str
    props: dict
    inputs: dict
    scope: str
    outputs: tuple = ("Value",)

    def key(self):
        return (self.bl_idname, tuple(sorted(self.props.items())),
                tuple(sorted((k, v if isinstance(v, Out) else float(v)) for k, v in self.inputs.items())))


@dataclass
class Bsdf:
    """A lobe's BSDF node: type and properties from the lobe kind, ``Color`` as three scalar
    outputs, other float sockets as values, vector sockets as local-frame (x = tangent, y =
    bitangent, z = normal) triples; ``None`` leaves a vector socket unlinked."""

    kind: str
    bl_idname: str
    props: dict
    color: tuple
    floats: dict
    vectors: dict
    label: str
    frame: tuple | None = None  # the layers' tilts its vectors' frame takes (``layer_normals.frame_key``; None: shading)
    target: str = "all"  # the renderers that draw it: "all", "cycles" or "eevee" (``TARGETS``)


TARGETS = ("all", "cycles", "eevee")  # an anisotropic lobe is drawn in Cycles, its round stand-ins in EEVEE


@dataclass
class Plan:
    """The node plan of one stack: math nodes in topological order, the leaves (the view direction
    ``wi_x``/``wi_y``/``wi_z`` in the local frame and the stack's parameters, whose defaults are in
    ``params``), the BSDF nodes, and the section title of every scope."""

    nodes: list
    leaves: list
    params: dict
    bsdfs: list
    sections: dict
    model: str
    stack_json: str = ""
    traced: tuple = field(default=(), repr=False)  # (tracer, expressions): what each output lowers
    frame: str = "shading"  # "view": the local x axis is the view's azimuth (staging)
    images: dict = field(default_factory=dict)  # material tables: image name -> pixels (rows bottom first)
    staged: object = field(default=None, repr=False)
    ids: dict = field(default_factory=dict)  # every parameter's ``ParamId`` (what it is), by name
    normals: tuple = ()  # the layers given a normal of their own: a vector input each (``param_id.normal_socket``)

    def leaf(self, name: str) -> Out:
        return Out(-1 - self.leaves.index(name), "Value")

    @property
    def outputs(self) -> list:
        """Every value the BSDF nodes read."""
        outs = []
        for b in self.bsdfs:
            outs += [*b.color, *b.floats.values()]
            for v in b.vectors.values():
                if v is not None:
                    outs += list(v)
        return [o for o in outs if isinstance(o, Out)]


def texel_range(n: int, offset: float = 0.0, rows: int | None = None) -> tuple[float, float]:
    """The texture coordinates of table coordinates 0 and 1 on an axis of n nodes: the texel
    centres of rows ``offset`` and ``offset + n - 1`` of an image ``rows`` high (a coordinate in
    between maps linearly, as ``lamella_tex`` in ``lamella/data/osl/lamella_luts.h``)."""
    rows = rows or n
    return (offset + 0.5) / rows, (offset + n - 0.5) / rows


_VECTOR_OUTPUTS = {"Vector", "Result_Vector", "Normal"}
_COLOR_OUTPUTS = {"Color", "Result_Color"}


def value_type(plan: Plan, v: Out) -> str:
    """What a plan value is: "vector" (a Combine XYZ's, a vector Mix's), "color" (an Image
    Texture's) or "float" (every leaf and every other output)."""
    if v.node < 0:
        return "float"
    return "vector" if v.socket in _VECTOR_OUTPUTS else "color" if v.socket in _COLOR_OUTPUTS else "float"


def input_name(plan: Plan, v: Out, k: int) -> str:
    """The socket name of a nested group's k-th input: the leaf's own name, else ``in<k>``."""
    return plan.leaves[-1 - v.node] if v.node < 0 else f"in{k}"
