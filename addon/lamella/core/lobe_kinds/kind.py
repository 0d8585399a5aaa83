"""What a lobe kind is (``LobeKind``: how the closure that renders it is evaluated, normalised,
printed in OSL and built from Blender nodes, all in one record) and the registry of kinds."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from ..registry import Registry, require_callables

GD_FLOOR = 1e-6  # GD is >= 0.2 for every alpha <= 1 at wi.z >= 0; the floor only guards wi.z < 0
SIDES = ("reflected", "transmitted")


@dataclass(frozen=True)
class LobeKind:
    """A closure is a function of its arguments, the named values ``args(ops, lobe, wi)`` turns a
    lobe into (roughness, axes, normal) and a backend prints or wires:
    ``cos_of_args(ops, a, wi, wo)``: f cos of the closure of weight 1 (exactly what the renderer's
    closure evaluates); ``scale_of_args(ops, a, wi)``: the normaliser that makes the closure carry
    its lobe's energy; ``side``: ``"reflected"`` or ``"transmitted"``; ``description``: one line
    for docs and tables; ``osl(a)``: the Cycles OSL closure call of weight 1, given the printed
    expressions of the arguments and the frame it is about (``osl_frame(a)``: the shading frame
    ``Normal``, ``Tn``, ``Bn``, or the frame of the layer's own normal);
    ``node(ops, a, wi)``: the Blender BSDF node (``bsdf_node.BsdfNode``) that makes the closure in
    Cycles without OSL, and in EEVEE what EEVEE makes of that node; ``eevee(ops, a, wi)``: where
    EEVEE must be given another node for the lobe (a refraction EEVEE follows through an object's
    thickness, which needs the true index), that node and the factor on the closure's weight that
    turns it into the node's (None: ``node`` in every renderer); ``rough``: the lobe is a
    microfacet lobe, a delta at zero roughness. ``closure_cos`` and ``scale`` are the same of a
    lobe."""

    name: str
    side: str
    cos_of_args: Callable
    scale_of_args: Callable
    args: Callable
    description: str
    osl: Callable[[dict], str]
    node: Callable
    rough: bool = True
    eevee: Callable | None = None

    def closure_cos(self, ops, lobe, wi, wo):
        return self.cos_of_args(ops, self.args(ops, lobe, wi), wi, wo)

    def scale(self, ops, lobe, wi):
        return self.scale_of_args(ops, self.args(ops, lobe, wi), wi)


FRAME_KEYS = ("N", "T", "B")  # the frame an OSL printer is given among its arguments (``osl_frame``)
SHADING_FRAME = ("Normal", "Tn", "Bn")  # the shader's shading frame (normal, tangent, bitangent)


def osl_frame(a: dict) -> tuple[str, str, str]:
    """(normal, tangent, bitangent) an OSL printer writes its closure about: the frame the emitter
    gives among the arguments (a layer's own normal), else the shading frame."""
    return tuple(a.get(k, d) for k, d in zip(FRAME_KEYS, SHADING_FRAME))


def _complete(kind: LobeKind) -> None:
    if not isinstance(kind, LobeKind):
        raise TypeError(f"a lobe kind is a LobeKind, got {type(kind).__name__}")
    if kind.side not in SIDES:
        raise ValueError(f"lobe kind {kind.name!r}: side is 'reflected' or 'transmitted', got {kind.side!r}")
    require_callables("lobe kind", kind, "cos_of_args", "scale_of_args", "args", "osl", "node")
    if not kind.description or "\n" in kind.description:
        raise ValueError(f"lobe kind {kind.name!r}: the description is one line")


KINDS: Registry[LobeKind] = Registry("lobe kind", _complete)
