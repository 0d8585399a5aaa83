"""`lamella bench lobe-floor`: every case's floor is at most the model's error and the page's
"above" column is their difference; on the one-coat cases, the scan of the base lobe's roughness
finds at least what the model's own roughness gives, and the wider shapes (two lobes, a tilted
lobe) contain the one lobe of the floor, so they find no worse (up to their coarser grids)."""
from lamella_dev.bench import lobe_floor
from lamella_dev import suite


def test_cases_are_one_isotropic_coat_over_a_conductor():
    names = lobe_floor.cases()
    assert "frosted_metal" in names and "gold_coated" in names
    for name in names:
        st = suite.load(name)
        assert len(st.coats) == 1 and st.base.type == "conductor" and not st.has_scattering


def test_the_best_roughness_is_no_worse_than_the_models():
    rows = lobe_floor.measure(["frosted_metal", "gold_coated"])
    assert {r["wi"] for r in rows} == {0.0, 30.0, 45.0, 60.0, 75.0} and len(rows) == 10
    for r in rows:
        # the scan is a grid: within its step of the model's roughness, never worse beyond rounding
        assert r["rel_l1_best_alpha"] <= r["rel_l1_model_shape"] + 0.01, r
        assert 0.0 < r["rel_l1_floor"] < 1.0
        assert r["rel_l1_floor_two"] <= r["rel_l1_floor"] + 0.01, r
        assert r["rel_l1_floor_tilted"] <= r["rel_l1_floor"] + 1e-9, r


def test_every_case_has_a_floor_at_most_the_models_error():
    rows = lobe_floor.measure_paths(["tinted_varnish"])
    assert len(rows) == 5
    for r in rows:
        assert 0.0 < r["rel_l1_floor"] <= r["rel_l1_auto"], r
        assert r["rel_l1_floor_plane"] <= r["rel_l1_floor"], r
        # each partial fit starts from the model's lobes and is never above them; the full fit starts
        # where the energies' fit ends
        assert max(r["rel_l1_widths"], r["rel_l1_energies"]) <= r["rel_l1_auto"] + 1e-12, r
        assert r["rel_l1_floor"] <= r["rel_l1_energies"] + 1e-12, r
        assert abs(r["above_floor"] - (r["rel_l1_auto"] - r["rel_l1_floor"])) < 1e-12
        assert len(r["alphas_fit"]) == len(r["kinds"]) == len(r["energies_fit"])
