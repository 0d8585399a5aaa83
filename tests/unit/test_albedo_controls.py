"""`lamella bench albedo-controls`: the controls it runs, and the exact limit among them: a smooth
coat over a smooth conductor matches the energy-conserving walk at every absorption and angle."""
import numpy as np

from lamella_dev.bench import albedo_controls


def test_a_smooth_coat_over_smooth_gold_is_exact_at_every_absorption():
    rows = [r for r in albedo_controls.rows(walkers=8000) if r["control"].startswith("coat alpha 0,")
            and r["control"].endswith("gold alpha 0")]
    assert len(rows) == len(albedo_controls.ABSORPTIONS) * len(albedo_controls.ANGLES)
    for r in rows:
        model, walk, err = (np.array(r[k]) for k in ("model", "walk", "stderr"))
        assert np.all(np.abs(model - walk) <= 0.005 * walk + 4.0 * err), r


def test_controls_cover_every_factor():
    labels = [label for label, _ in albedo_controls.controls()]
    assert sum(label.startswith("bare gold") for label in labels) == 3
    assert len(labels) == 3 + 2 * 2 * len(albedo_controls.ABSORPTIONS)
