"""`lamella bench pareto --quick`: the run-time-against-error benchmark runs end to end on a
scattering stack (every variant, the brute force, the cost sweeps, the plots and the tables), and what it
measures says what the product claims: the staged shader is more accurate than the Principled
stand-in, and brute force converges with samples."""
import json

import numpy as np
import pytest

pytest.importorskip("bpy")
from lamella_dev.bench import pareto  # noqa: E402

# one worker computes the shared fixture; a minute and a half of renders: `make test-long`
pytestmark = [pytest.mark.xdist_group("bench_pareto"), pytest.mark.slow]


@pytest.fixture(scope="session")  # once, however xdist interleaves modules
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("pareto")
    md = pareto.run(out, quick=True, progress=False)
    return out, md, json.loads((out / "pareto_quick.json").read_text())


def test_every_variant_renders_at_every_sample_count(quick):
    _, _, data = quick
    assert [r["stack"] for r in data["stacks"]] == list(pareto.QUICK.cases)
    for r in data["stacks"]:
        for v in pareto.VARIANTS:
            pts = r["curves"][v.label]
            ladder = pareto.QUICK.brute_ladder if v.engine == "reference" else pareto.QUICK.ladder
            assert [p["spp"] for p in pts] == list(ladder), (r["stack"], v.label)
            for p in pts:
                assert p["seconds"] > 0 and p["x_principled"] > 0
                assert all(np.isfinite(p[k]) and p[k] >= 0 for k in ("rmse", "delta_e00", "flip"))


def test_what_it_measures(quick):
    _, _, data = quick
    for r in data["stacks"]:
        last = {k: pts[-1] for k, pts in r["curves"].items()}
        assert last["osl all"]["rmse"] < last["principled"]["rmse"], r["stack"]
        brute = r["curves"]["brute force"]
        assert brute[-1]["rmse"] < brute[0]["rmse"], r["stack"]
    for key in ("coats", "depths"):
        assert data[key] and all(row[v.label] > 0 for row in data[key] for v in pareto.COST_VARIANTS)


def test_tables_and_plots_are_written(quick):
    out, md, data = quick
    text = md.read_text()
    for r in data["stacks"]:
        assert f"| {r['stack']} |" in text
    for png in ("pareto_quick_fronts.png", "pareto_quick_cost.png"):
        assert (out / "plots" / png).stat().st_size > 1000
        assert f"plots/{png}" in text
