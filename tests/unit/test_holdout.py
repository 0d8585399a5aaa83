"""The hold-out set (`lamella bench holdout`): stacks drawn once at random, never tuned on; the
figures recorded in bench/holdout.json guard `auto` against changes that fit the suite and lose
elsewhere. A deliberate model change re-records them with `lamella bench holdout`."""
import json

import pytest

from lamella_dev.bench import BENCH_DIR, holdout
from lamella.core.stack import Stack

RECORDED = BENCH_DIR / "holdout.json"


@pytest.fixture(scope="module")
def refs():
    return holdout.stored()


def test_stored_references_are_the_drawn_stacks(refs):
    drawn = holdout.draw()
    assert set(refs) == set(drawn)
    for name, ref in refs.items():
        assert Stack.from_dict(ref["meta"]["stack"]) == drawn[name], name
        assert ref["meta"]["interfaces"] == "multiple"


def test_auto_on_the_holdout_set_keeps_its_recorded_figures(refs):
    """Each figure within 1 % of the recorded one (the accuracy gate's rule): the numpy model is
    deterministic, so only a model change moves them, and then bench/holdout.json is recorded again."""
    from .test_accuracy import same_figure

    from lamella_dev.bench.accuracy import evaluate_case

    then = {(r["case"], r["wi"]): r for r in json.loads(RECORDED.read_text())["rows"] if r["model"] == "auto"}
    now = {}
    for name, ref in refs.items():
        for r in evaluate_case(name, ref, ("auto",), stack=Stack.from_dict(ref["meta"]["stack"])):
            now[(name, r["wi"])] = r
    assert set(now) == set(then)
    for key, r in now.items():
        for figure in ("rel_l1", "albedo_err"):
            assert same_figure(r[figure], then[key][figure]), (key, figure, r[figure], then[key][figure])
