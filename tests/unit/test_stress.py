"""`lamella stress`, the random-stack part, quick: random stacks over the schema's whole range
(edges weighted) under every model in float32 and float64 and through the baked path, none
failing; and every stack a full run ever found failing (shrunk, in ``stress_regressions.json``)
replayed."""
import json

import numpy as np
import pytest

from lamella_dev.bench import stress
from lamella.core.stack import Stack


def test_random_stacks_quick_run_finds_no_failure():
    # half of `lamella stress --quick`'s stacks (that run and the million-stack one are the bench's)
    n = stress.QUICK_STACKS // 2
    r = stress.random_stacks(n, 100, seed=1, staged_every=25, progress=False)
    assert not r["errors"], r["errors"]
    assert not r["failures"], json.dumps(r["failures"][:2])[:2000]
    ran = {m: s["float32"][0] for m, s in r["models"].items()}
    assert sum(ran.values()) >= 4 * n and r["staged"][0] >= 20, ran
    # the slack covers the transfer-matrix models' amplified rounding; the others hold far tighter
    # (a million stacks: at most 8e-6), and a regression there must not hide under it
    excess = {m: s["float32"][2] for m, s in r["models"].items() if s["float32"][0]}
    tight = {m: x for m, x in excess.items() if m not in ("tm2", "tm6", "tm6_refined")}
    assert all(x <= 5e-5 for x in tight.values()), excess


def test_the_checker_catches_what_it_looks_for():
    """The check is not vacuous: a lobe energy pushed above 1, or made NaN, fails the stack."""
    s = Stack.from_dict({"layers": [{"ior": 1.5, "roughness": 0.1}], "base": {"type": "diffuse", "albedo": 1.0}})
    wi = stress.directions(np.random.default_rng(0), 4)
    wo = np.abs(stress.directions(np.random.default_rng(1), 4))
    assert not stress.check_stack(s, "belcour2018", np.float32, wi, wo)
    from lamella.core.backends.ir import closures

    traced = closures.trace_closures(s, "belcour2018")
    original = traced.closures[0].lobe.weight
    try:
        for bad in (2.0, float("nan")):
            object.__setattr__(traced.closures[0].lobe, "weight", (bad, bad, bad))  # the cached trace's lobe
            assert stress.check_stack(s, "belcour2018", np.float32, wi, wo), bad
    finally:
        object.__setattr__(traced.closures[0].lobe, "weight", original)


def test_shrink_keeps_the_failure_and_drops_the_rest():
    d = {"layers": [{"ior": 1.5}, {"ior": 2.0, "roughness": 0.3}], "base": {"type": "conductor", "k": [3.0, 3.0, 3.0]}}
    small = stress.shrink(d, lambda x: any(c.get("ior") == 2.0 for c in x["layers"]))
    assert small["layers"] == [{"ior": 2.0}] and small["base"] == {"type": "conductor"}


REGRESSIONS = json.loads(stress.REGRESSIONS.read_text()) if stress.REGRESSIONS.exists() else []


@pytest.mark.parametrize("case", REGRESSIONS, ids=[f"{c['model']}-{k}" for k, c in enumerate(REGRESSIONS)])
def test_stacks_a_stress_run_found_failing_now_pass(case):
    dtype = np.float32 if case["dtype"] == "float32" else np.float64
    wi, wo = np.array(case["wi"]), np.array(case["wo"])
    if case["model"] == "staged":
        assert not stress.check_staged(Stack.from_dict(case["stack"]), wi, wo)
    else:
        assert not stress.check_stack(Stack.from_dict(case["stack"]), case["model"], dtype, wi, wo)
