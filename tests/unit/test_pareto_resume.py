"""`lamella bench pareto --resume`: a stack's measurements kept by an earlier run are reused while
their fingerprint (settings, stack, the model's lobes) matches, and rendered again when it does not."""
import dataclasses

import pytest

pytest.importorskip("bpy")
from lamella_dev.bench import pareto  # noqa: E402

CASE = "gold_coated"


@pytest.fixture
def partial_dir(tmp_path, monkeypatch):
    monkeypatch.setattr(pareto, "PARTIAL_DIR", tmp_path / "pareto")
    return tmp_path / "pareto"


def _row(name=CASE):
    return {"stack": name, "noise_rmse": 0.03, "curves": {"osl auto": [{"spp": 4, "seconds": 1.0, "x_principled": 1.0,
                                                                     "rmse": 0.1, "delta_e00": 2.0, "flip": 0.2}]}}


def test_kept_measurements_round_trip(partial_dir):
    s = dataclasses.replace(pareto.QUICK, cases=(CASE,))
    assert pareto.load_partial(CASE, s, quick=True) is None
    pareto.save_partial(_row(), pareto.fingerprint(CASE, s), quick=True)
    assert pareto.load_partial(CASE, s, quick=True) == _row()
    assert pareto.load_partial(CASE, s, quick=False) is None  # the full run keeps its own


def test_other_settings_or_model_do_not_match(partial_dir, monkeypatch):
    s = dataclasses.replace(pareto.QUICK, cases=(CASE,))
    pareto.save_partial(_row(), pareto.fingerprint(CASE, s), quick=True)
    assert pareto.load_partial(CASE, dataclasses.replace(s, ladder=(4, 16, 64)), quick=True) is None
    assert pareto.load_partial(CASE, dataclasses.replace(s, res=64), quick=True) is None
    # a model whose lobes differ (here: every roughness halved) makes another fingerprint
    from lamella.core import api

    real = api.lobes

    def halved(stack, wi, *a, **k):
        lb = real(stack, wi, *a, **k)
        return dataclasses.replace(lb, alpha_x=lb.alpha_x * 0.5)

    before = pareto.fingerprint(CASE, s)
    monkeypatch.setattr(pareto, "load_index", lambda: {"cases": {CASE: {"spp": 1, "noise_rmse": 0.5, "res": 128}}})
    assert pareto.fingerprint(CASE, s) != before  # another stored reference
    monkeypatch.undo()
    monkeypatch.setattr(pareto, "PARTIAL_DIR", partial_dir)
    assert pareto.fingerprint(CASE, s) == before
    monkeypatch.setattr(api, "lobes", halved)
    assert pareto.fingerprint(CASE, s) != before
    assert pareto.load_partial(CASE, s, quick=True) is None


def test_resume_renders_only_what_is_missing(partial_dir, monkeypatch, tmp_path):
    s = dataclasses.replace(pareto.QUICK, cases=("gold_coated", "fog_g09_d1"))
    pareto.save_partial(_row("gold_coated"), pareto.fingerprint("gold_coated", s), quick=True)
    rendered = []

    def curves(name, settings, bar=None):
        rendered.append(name)
        return _row(name)

    monkeypatch.setattr(pareto, "QUICK", s)
    monkeypatch.setattr(pareto, "stack_curves", curves)
    monkeypatch.setattr(pareto, "cost_sweep", lambda stacks, settings, bar=None: [])
    monkeypatch.setattr(pareto, "_write", lambda out_dir, stem, data: data)
    data = pareto.run(tmp_path / "out", quick=True, progress=False, resume=True)
    assert rendered == ["fog_g09_d1"]
    assert [r["stack"] for r in data["stacks"]] == ["gold_coated", "fog_g09_d1"]
    assert pareto.load_partial("fog_g09_d1", s, quick=True) == _row("fog_g09_d1")  # kept as it finished
    rendered.clear()
    pareto.run(tmp_path / "out", quick=True, progress=False, resume=False)
    assert rendered == ["gold_coated", "fog_g09_d1"]  # without --resume everything renders again
