"""Register pressure: whether Cycles' SVM (Cycles without OSL, what a GPU runs) can hold a node
plan's live values (``live_values``), and the measured limits behind the panel's warning."""
from __future__ import annotations

from .plan import INSIDE_INPUT, Out, Plan

SVM_STACK = 255  # floats Cycles' SVM keeps for the live values of one shader
SVM_HEADROOM = 40  # measured: plans peaking at up to 162 live values render, one at 230 runs out
# Textured stacks (bench/nodes.md, docs/node_groups.md): 121, 174 and 236 live values render,
# 206 (eight coats with media, only the base colour linked), 290 and 364 render black: the
# estimate orders them only roughly, so above this the panel says the group may not fit.
SVM_UNSURE = 150


def live_values(plan: Plan) -> int:
    """The most values that vary over the surface (they depend on the view direction) alive at
    once when the plan's nodes run in order, each output counted in floats until its last reader
    (the BSDF nodes read theirs at the end). Parameters are left out: Cycles folds nodes of
    unlinked group inputs into constants. Cycles' SVM compiles the nested groups in this order
    and holds the live values in a stack of ``SVM_STACK`` floats."""
    view = {-1 - k for k, name in enumerate(plan.leaves) if name.startswith("wi_") or name == INSIDE_INPUT}
    varying: set[int] = set()
    for i, n in enumerate(plan.nodes):
        if any(isinstance(v, Out) and (v.node in view or v.node in varying) for v in n.inputs.values()):
            varying.add(i)
    last: dict[Out, int] = {}
    for i, n in enumerate(plan.nodes):
        for v in n.inputs.values():
            if isinstance(v, Out) and v.node in varying:
                last[v] = i
    for v in plan.outputs:
        if v.node in varying:
            last[v] = len(plan.nodes)
    delta = [0] * (len(plan.nodes) + 2)
    for v, end in last.items():
        width = 3 if v.socket in ("Vector", "Color") else 1
        delta[v.node] += width
        delta[end] -= width
    live = peak = 0
    for d in delta:
        live += d
        peak = max(peak, live)
    return peak


def fits_svm(plan: Plan) -> bool:
    """Whether Cycles without OSL (SVM, what a GPU runs) can hold the plan's live values."""
    return live_values(plan) <= SVM_STACK - SVM_HEADROOM
