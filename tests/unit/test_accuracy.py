"""Accuracy against the stored stochastic references (tests never recompute them).

The figures in bench/accuracy.json are this code's: every model's relative L1 and albedo error on
every suite case reproduce within 1 % of each figure (+1e-4 for figures near zero). The numpy
models are deterministic and the references stored, so a model change moves them: a 1 % regression
of one figure fails, and so does an improvement nobody recorded (``lamella bench accuracy``). The
models are read from the registry, so a newly registered model is gated as soon as it is recorded.
The published claims are checked too: yamaguchi2019 beats weier2020 when interfaces are rotated.
"""
import json

import numpy as np
import pytest

from lamella_dev.bench import BENCH_DIR, REFERENCE_DIR, REFERENCE_DIR_MULTIPLE
from lamella_dev.bench.accuracy import MODELS, evaluate_case, load_reference
from lamella_dev import suite
from lamella.core.stack import Stack

pytestmark = pytest.mark.xdist_group("accuracy")  # one worker computes the shared fixture

RECORDED = json.loads((BENCH_DIR / "accuracy.json").read_text())
RELATIVE, FLOOR = 0.01, 1e-4  # how far a figure may move: 1 % of itself, and 1e-4 near zero


def same_figure(now: float, then: float) -> bool:
    return abs(now - then) <= RELATIVE * abs(then) + FLOOR


def recorded(case, model, wi, table="rows"):
    for r in RECORDED[table]:
        if r["case"] == case and r["model"] == model and r["wi"] == wi:
            return r
    raise KeyError((case, model, wi))


@pytest.fixture(scope="session")  # once, however xdist interleaves modules
def yardsticks():
    """(rows against the stored references, rows against the energy-conserving ones), by (case,
    model, wi); the models evaluated once for both (they share their directions)."""
    out = ({}, {})
    for name in suite.names():
        cache: dict = {}
        for table, ref_dir in zip(out, (REFERENCE_DIR, REFERENCE_DIR_MULTIPLE)):
            if (ref_dir / f"{name}.npz").exists():
                for r in evaluate_case(name, load_reference(name, ref_dir), cache=cache):
                    table[(r["case"], r["model"], r["wi"])] = r
    return out


@pytest.fixture(scope="session")
def rows(yardsticks):
    return yardsticks[0]


@pytest.fixture(scope="session")
def rows_multiple(yardsticks):
    return yardsticks[1]


def test_every_case_has_a_stored_reference():
    assert sorted(p.stem for p in REFERENCE_DIR.glob("*.npz")) == sorted(suite.names())
    for name in suite.names():
        ref = load_reference(name)
        assert Stack.from_dict(ref["meta"]["stack"]) == suite.load(name)
        assert "lamella references" in ref["meta"]["command"]


def test_every_case_has_a_stored_multiple_scattering_reference():
    """The energy-conserving yardstick: every suite case stored, made with multiple-scattering
    interfaces, of the stack as it is now."""
    from lamella_dev.bench import REFERENCE_DIR_MULTIPLE

    assert sorted(p.stem for p in REFERENCE_DIR_MULTIPLE.glob("*.npz")) == sorted(suite.names())
    for name in suite.names():
        ref = load_reference(name, REFERENCE_DIR_MULTIPLE)
        assert Stack.from_dict(ref["meta"]["stack"]) == suite.load(name)
        assert ref["meta"]["interfaces"] == "multiple" and "--interfaces multiple" in ref["meta"]["command"]


def test_pending_references_match_their_stacks():
    """The BRDF references of cases awaiting image references are of the stacks as they are now."""
    from lamella_dev.bench.accuracy import PENDING_DIR

    pending = suite.pending_descriptions()
    for path in PENDING_DIR.glob("*.npz"):
        assert path.stem in pending, path
        assert Stack.from_dict(load_reference(path.stem, PENDING_DIR)["meta"]["stack"]) == suite.load(path.stem)


def test_every_registered_model_is_recorded():
    """bench/accuracy.json holds every registered model (and auto): a new model reaches the gates."""
    from lamella.core.models import MODELS as REGISTRY

    assert set(MODELS) == {*REGISTRY, "auto"}
    assert set(RECORDED["models"]) == set(MODELS)
    assert {r["model"] for r in RECORDED["rows_multiple"]} == set(MODELS)


def test_the_gate_catches_a_small_regression():
    assert same_figure(0.2, 0.2) and same_figure(0.2019, 0.2) and same_figure(0.0, 0.00005)
    assert not same_figure(0.203, 0.2) and not same_figure(0.197, 0.2) and not same_figure(0.011, 0.01)


@pytest.mark.parametrize("case", suite.names())
def test_no_regression_against_recorded_figures(rows, case):
    for model in MODELS:
        for wi in suite.WI_DEGREES:
            now, then = rows[(case, model, wi)], recorded(case, model, wi)
            if "unsupported" in then:
                assert "unsupported" in now, (case, model, wi)
                continue
            for key in ("rel_l1", "albedo_err"):
                assert same_figure(now[key], then[key]), (case, model, wi, key, now[key], then[key])


@pytest.mark.parametrize("case", suite.names())
def test_no_regression_against_the_energy_conserving_references(rows_multiple, case):
    """The same gate against the multiple-scattering references (``rows_multiple`` of
    bench/accuracy.json), the yardstick the models are measured by."""
    for model in MODELS:
        for wi in suite.WI_DEGREES:
            now, then = rows_multiple[(case, model, wi)], recorded(case, model, wi, "rows_multiple")
            if "unsupported" in then:
                assert "unsupported" in now, (case, model, wi)
                continue
            for key in ("rel_l1", "albedo_err"):
                assert same_figure(now[key], then[key]), (case, model, wi, key, now[key], then[key])


@pytest.mark.parametrize("case", ["rotated_30", "rotated_60"])
def test_yamaguchi_beats_weier_on_rotated_interfaces(rows, case):
    """Yamaguchi et al. 2019's covariance against Weier and Belcour 2020's per-axis variances where
    the coat's and the base's axes are turned against each other. (rotated_90 is not such a case:
    its axes stay on the frame's, swapped, which per-axis variances hold exactly; there the two
    differ by their roughness mappings, and weier2020 measures ahead at normal incidence, behind at
    60 degrees.)"""
    mean = {m: np.mean([rows[(case, m, wi)]["rel_l1"] for wi in suite.WI_DEGREES])
            for m in ("yamaguchi2019", "weier2020")}
    assert mean["yamaguchi2019"] < mean["weier2020"], mean


def test_reference_noise_floor(rows):
    """The stored references resolve relative-L1 differences of 0.1 everywhere (measured worst:
    0.099, endf_thin_gold at 0 deg at 131072 walkers, and 0.093 for varnished_wood: narrow exit
    interfaces make the estimate noisy; the Makefile gives those cases more walkers)."""
    for (case, model, wi), r in rows.items():
        if "unsupported" not in r:  # a model that cannot run a case has no figures for it
            assert r["ref_noise"] < 0.1, (case, wi, r["ref_noise"])


@pytest.mark.parametrize("case", suite.names())
def test_auto_is_within_ten_percent_of_the_best_model(rows_multiple, case):
    """`auto` (a structural choice) is never worse than the best single model on a suite case by
    more than 10 % relative, in relative L1 averaged over the incidence angles (and over both
    sides where the stack transmits: a glass base's transmitted light is half of what it looks
    like, and what `auto` chooses endf for), against the energy-conserving references (the
    yardstick the models are measured by; against the single-scattering ones, which lose what a
    rough interface scatters again, endf on the rough glass plate is 0.29 against tm2's and tm6's
    0.27 on the reflected side)."""
    rows = rows_multiple

    def error(r):
        return 0.5 * (r["rel_l1"] + r["rel_l1_t"]) if "rel_l1_t" in r else r["rel_l1"]

    def mean(m):
        rs = [rows[(case, m, wi)] for wi in suite.WI_DEGREES]
        return np.mean([error(r) for r in rs]) if all("rel_l1" in r for r in rs) else np.inf

    best = min(mean(m) for m in MODELS if m != "auto")
    assert mean("auto") <= 1.1 * best, (mean("auto"), best)


def test_an_added_incidence_keeps_the_stored_ones(tmp_path):
    """``lamella references --wi 45`` adds an incidence to a stored reference: the others are kept
    as they were (same arrays), the file's angles stay sorted and its meta records the addition."""
    import shutil

    from lamella_dev.bench.accuracy import compute_references

    shutil.copy(REFERENCE_DIR / "gold_coated.npz", tmp_path / "gold_coated.npz")
    before = load_reference("gold_coated", tmp_path)
    compute_references(["gold_coated"], spp=4, albedo_spp=64, out_dir=tmp_path, angles=(45.0,), progress=lambda *_: None)
    after = load_reference("gold_coated", tmp_path)
    assert list(after["wi_degrees"]) == [0.0, 30.0, 45.0, 60.0, 75.0]
    for old_i, deg in enumerate(before["wi_degrees"]):
        if deg == 45.0:  # the added incidence, computed again
            continue
        new_i = list(after["wi_degrees"]).index(deg)
        for key in ("wo", "mean", "stderr", "albedo"):
            np.testing.assert_array_equal(after[f"{key}_{new_i}"], before[f"{key}_{old_i}"])
    assert after["meta"]["added"][-1] == {**after["meta"]["added"][-1], "wi_degrees": [45.0], "spp": 4}
    assert after["meta"]["command"] == before["meta"]["command"]
    rows = evaluate_case("gold_coated", after, ("auto",))
    assert sorted(r["wi"] for r in rows) == [0.0, 30.0, 45.0, 60.0, 75.0]
