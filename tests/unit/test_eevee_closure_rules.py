"""The lobe-count rules the EEVEE closures bench compares (lamella_dev.bench.eevee_closures)."""
import math

import pytest

from lamella_dev.bench.eevee_closures import drop, merge

LOBES = [("reflection", (0.04, 0.04, 0.04), 0.02), ("backscatter", (0.1, 0.1, 0.1), 0.6),
         ("reflection", (0.3, 0.2, 0.1), 0.05), ("reflection", (0.2, 0.2, 0.2), 0.5),
         ("backscatter", (0.05, 0.02, 0.01), 0.9)]


def test_merge_keeps_energy_and_kinds_and_merges_the_closest_roughness_first():
    out = merge(LOBES, keep=3)
    assert len(out) == 3
    for kind in ("reflection", "backscatter"):
        for c in range(3):
            assert sum(l[1][c] for l in out if l[0] == kind) == pytest.approx(sum(l[1][c] for l in LOBES if l[0] == kind))
    # the first merge joins the two sharp reflections (alpha 0.02 and 0.05): closest in log alpha
    sharp = out[0]
    e1, e2 = 0.12, 0.6
    assert sharp[0] == "reflection"
    assert sharp[2] == pytest.approx(math.exp((e1 * math.log(0.02) + e2 * math.log(0.05)) / (e1 + e2)))


def test_merge_never_joins_lobes_of_different_kinds():
    two = [("reflection", (0.1,) * 3, 0.1), ("diffuse", (0.2,) * 3, 0.0), ("backscatter", (0.1,) * 3, 0.5)]
    assert merge(two, keep=1) == two


def test_drop_keeps_the_most_energetic_lobes_in_their_order():
    out = drop(LOBES, keep=3)
    assert out == [LOBES[1], LOBES[2], LOBES[3]]
