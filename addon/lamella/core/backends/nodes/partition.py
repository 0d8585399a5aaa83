"""Chunks: a node plan cut into nested node groups. Blender's node editor slows down
quadratically with the nodes of one tree (creating a node costs time proportional to the tree's
size), so ``partition`` cuts the plan into chunks of at most ``CHUNK_NODES`` nodes, one per section
of the model where possible, and sections of chunks; each is a nested node group named by a digest
of its content, so that an edit rebuilds only the chunks it changes and materials of one structure
share them."""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field

from .plan import Out, Plan, input_name, value_type

CHUNK_NODES = 120  # nodes per nested group: creation time grows with the square of a tree's size
SECTION_CHUNKS = 16  # chunks per section group: links too cost time in proportion to their tree


@dataclass
class Chunk:
    """A run of plan nodes (indices ``nodes``) built as one nested group: its inputs are the
    outside values it reads, its outputs the values read after it. A section is a chunk of
    chunks (``parts``): a second level of nesting, so that no tree holds many links either.
    An ``own`` chunk is a run of nodes that read the material's own table (``own_nodes``), built
    in the material's group itself rather than nested, so that every nested group depends on the
    stack's structure alone and materials of one structure share them."""

    scope: str
    nodes: list
    inputs: list = field(default_factory=list)
    outputs: list = field(default_factory=list)
    parts: list = field(default_factory=list)
    digest: str = ""
    own: bool = False


def own_nodes(plan: Plan) -> frozenset[int]:
    """The plan nodes that read the material's own table images (``Plan.images``)."""
    return frozenset(i for i, n in enumerate(plan.nodes) if n.props.get("image") in plan.images)


def _stratified(plan: Plan, own: frozenset[int]) -> list[int]:
    """The plan's nodes in an order that keeps every node after what it reads and gathers the
    ``own`` nodes into as few runs as possible: a node's stratum is the most ``own`` nodes on a
    path into it; each stratum's other nodes come first, then its ``own`` nodes."""
    level: dict[int, int] = {}
    for i, n in enumerate(plan.nodes):
        deps = [v.node for v in n.inputs.values() if isinstance(v, Out) and v.node >= 0]
        level[i] = max((level[d] + (d in own) for d in deps), default=0)
    return sorted(range(len(plan.nodes)), key=lambda i: (level[i], i in own, i))


def _io(chunks: list[Chunk], owner: dict, plan: Plan, reads, extra=()) -> None:
    """Fill the inputs (outside values read, in first-read order) and outputs (values read by
    another chunk, by ``extra`` readers or by the BSDF nodes) of ``chunks``; ``reads(c)`` lists the
    values ``c`` reads."""
    wanted: dict[int, list] = {id(c): [] for c in chunks}
    for c in chunks:
        c.inputs = list(dict.fromkeys(v for v in reads(c) if v.node < 0 or owner.get(v.node) is not c))
        for v in c.inputs:
            if v.node in owner:
                wanted[id(owner[v.node])].append(v)
    for v in [*extra, *plan.outputs]:
        if v.node in owner:
            wanted[id(owner[v.node])].append(v)
    for c in chunks:
        c.outputs = list(dict.fromkeys(wanted[id(c)]))


def partition(plan: Plan, size: int = CHUNK_NODES, per_section: int = SECTION_CHUNKS) -> list[Chunk]:
    """Cut the plan's nodes (in ``_stratified`` order) into chunks of at most ``size`` nodes that
    never span two scopes of the model nor an ``own`` node, and group consecutive chunks of one
    scope into sections of at most ``per_section`` chunks. Returns the sections and the ``own``
    chunks in the order to build them, each section with its chunks as ``parts``; every chunk and
    section has its inputs, outputs and a digest of its content (names the nested group)."""
    own = own_nodes(plan)
    items: list[Chunk] = []  # sections and own chunks, in order
    chunks: list[Chunk] = []
    last = None
    for i in _stratified(plan, own):
        n = plan.nodes[i]
        if i in own:
            if last is None or not last.own:
                last = Chunk(n.scope, [], own=True)
                items.append(last)
            last.nodes.append(i)
            continue
        if last is None or last.own or last.scope != n.scope:
            last = None
        if last is None or len(last.parts[-1].nodes) >= size:
            if last is None or len(last.parts) >= per_section:
                last = Chunk(n.scope, [])
                items.append(last)
            chunks.append(Chunk(n.scope, []))
            last.parts.append(chunks[-1])
        last.parts[-1].nodes.append(i)
        last.nodes.append(i)
    sections = [s for s in items if not s.own]

    def node_reads(c):
        return [v for i in c.nodes for v in plan.nodes[i].inputs.values() if isinstance(v, Out)]

    own_reads = [v for i in sorted(own) for v in plan.nodes[i].inputs.values() if isinstance(v, Out)]
    _io(chunks, {i: c for c in chunks for i in c.nodes}, plan, node_reads, own_reads)
    _io(sections, {i: s for s in sections for i in s.nodes}, plan,
        lambda s: [v for c in s.parts for v in c.inputs], own_reads)
    for c in chunks:
        c.digest = _chunk_digest(plan, c)
    for s in sections:
        s.digest = _section_digest(plan, s)
    return items


def _hash(obj) -> str:
    return hashlib.sha1(json.dumps(obj).encode()).hexdigest()[:12]


def _chunk_digest(plan: Plan, c: Chunk) -> str:
    local = {i: k for k, i in enumerate(c.nodes)}
    inputs = {v: k for k, v in enumerate(c.inputs)}

    def ref(v):
        if not isinstance(v, Out):
            return repr(float(v))
        if v.node >= 0 and v.node in local:
            return f"n{local[v.node]}.{v.socket}"
        return f"i{inputs[v]}"

    body = [[plan.nodes[i].bl_idname, sorted(plan.nodes[i].props.items()),
             sorted((s, ref(v)) for s, v in plan.nodes[i].inputs.items())] for i in c.nodes]
    names = [(input_name(plan, v, k), value_type(plan, v)) for k, v in enumerate(c.inputs)]
    return _hash([body, [ref(v) for v in c.outputs], names])


def _section_digest(plan: Plan, s: Chunk) -> str:
    inputs = {v: k for k, v in enumerate(s.inputs)}
    made = {v: (k, j) for k, c in enumerate(s.parts) for j, v in enumerate(c.outputs)}

    def ref(v):
        return list(made[v]) if v in made else f"i{inputs[v]}"

    wiring = [[c.digest, [ref(v) for v in c.inputs]] for c in s.parts]
    names = [(input_name(plan, v, k), value_type(plan, v)) for k, v in enumerate(s.inputs)]
    return _hash([wiring, [ref(v) for v in s.outputs], names])
