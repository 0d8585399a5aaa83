"""The rule a model change is kept by: measured on the suite and on the hold-out stacks, the
suite's mean relative L1 (over cases and incidence angles, energy-conserving references) falls
and no (case, angle) of either set rises by more than ``RISE``.

``errors(model)`` measures a model (a name, ``"auto"`` or a model object) on both sets;
``AutoWith`` is ``auto`` with some of the models it chooses replaced (a study variant in place of
a published one, ``models.variant``); ``judge(before, after)`` applies the rule to two such
measurements.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from lamella.core import models
from lamella.core.stack import Stack
from . import suite

RISE = 0.02  # the largest rise of one (case, angle) a kept change may cause
HOLDOUT_PREFIX = "holdout_"


class AutoWith:
    """``auto`` with the models it would choose for a stack replaced as ``swap`` says (model name ->
    model object): the same decision table, another model in one of its rows."""

    def __init__(self, swap: dict, name: str = ""):
        self.swap = dict(swap)
        self.name = name or "auto with " + ", ".join(f"{k} -> {getattr(v, 'name', v)}" for k, v in swap.items())

    def run(self, ops, stack, wi):
        chosen = models.choose_auto(stack)
        return (self.swap.get(chosen) or models.get(chosen)).run(ops, stack, wi)


def errors(model="auto", cases=None) -> dict[tuple[str, float], float]:
    """Relative L1 of ``model`` per (case, incidence in degrees): every suite case against its
    energy-conserving reference, every hold-out stack against its own; ``cases``: only these
    names (suite or hold-out)."""
    from .bench.accuracy import evaluate_case, load_reference
    from .bench.holdout import stored
    from .bench.paths import REFERENCE_DIR_MULTIPLE

    named = [(n, load_reference(n, REFERENCE_DIR_MULTIPLE), None) for n in suite.names()
             if cases is None or n in cases]
    named += [(n, ref, Stack.from_dict(ref["meta"]["stack"])) for n, ref in stored().items()
              if cases is None or n in cases]
    out = {}
    for name, ref, stack in named:
        for row in evaluate_case(name, ref, (model,), stack=stack):
            if "rel_l1" in row:
                out[(name, row["wi"])] = row["rel_l1"]
    return out


@dataclass
class Verdict:
    """Means over the suite's and the hold-out's (case, angle) pairs before and after, the mean
    change per incidence angle, and the pairs that rose by more than ``RISE`` (case, angle,
    before, after)."""

    suite: tuple[float, float]
    holdout: tuple[float, float]
    per_angle: dict = field(default_factory=dict)
    rises: list = field(default_factory=list)

    @property
    def kept(self) -> bool:
        return self.suite[1] < self.suite[0] and not self.rises


def judge(before: dict, after: dict) -> Verdict:
    """The keep rule on two ``errors`` measurements (over the pairs both hold)."""
    keys = sorted(set(before) & set(after))
    if not keys:
        raise ValueError("the two measurements share no (case, angle)")

    def means(held_out: bool) -> tuple[float, float]:
        ks = [k for k in keys if k[0].startswith(HOLDOUT_PREFIX) == held_out]
        if not ks:
            return (float("nan"), float("nan"))
        return (float(np.mean([before[k] for k in ks])), float(np.mean([after[k] for k in ks])))

    angles = sorted({k[1] for k in keys})
    per_angle = {a: float(np.mean([after[k] - before[k] for k in keys if k[1] == a])) for a in angles}
    rises = [(k[0], k[1], before[k], after[k]) for k in keys if after[k] - before[k] > RISE]
    return Verdict(means(False), means(True), per_angle, rises)
