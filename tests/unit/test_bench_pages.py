"""A bench page is what its benchmark writes from its stored measurements (bench/*.json): its
prose computes the figures it quotes, so a re-measurement leaves no stale copy behind, and a page
says one thing about what it measured."""
import json

from lamella_dev.bench import BENCH_DIR, accuracy, albedo_controls, pareto

PARETO_PLOTS = {"pareto": "plots/pareto_fronts.png", "cost": "plots/pareto_cost.png"}


def _stored(name: str):
    return json.loads((BENCH_DIR / f"{name}.json").read_text())


def test_pages_are_what_their_benchmarks_write_from_the_stored_measurements():
    data = _stored("accuracy")
    assert (BENCH_DIR / "accuracy.md").read_text() == accuracy.format_markdown(data["rows"], data["models"],
                                                                              data["rows_multiple"],
                                                                              accuracy.stored_floors(data))
    assert (BENCH_DIR / "albedo_controls.md").read_text() == albedo_controls.format_markdown(_stored("albedo_controls"))
    assert (BENCH_DIR / "pareto.md").read_text() == pareto.format_markdown(_stored("pareto"), PARETO_PLOTS)


def test_pareto_records_the_pixels_its_errors_are_taken_over():
    assert pareto.PIXELS == "sphere"
    data = _stored("pareto")
    page = pareto.format_markdown({**data, "settings": {**data["settings"], "pixels": pareto.PIXELS}}, PARETO_PLOTS)
    assert "over the pixels the sphere covers" in page and "frame" not in page


def test_the_stored_pareto_page_says_one_thing_about_its_pixels():
    data = _stored("pareto")
    page = pareto.format_markdown(data, PARETO_PLOTS)
    if data["settings"].get("pixels") != "sphere":  # measured before the mask was geometric
        assert "every pixel of the frame" in page and "reference, over the sphere" not in page
        assert page.count("background included") == 1


def test_the_readings_quote_the_rows_they_read():
    data = _stored("albedo_controls")
    worse = [{**r, "ratio": [x * 0.5 for x in r["ratio"]]} for r in data]
    assert albedo_controls.format_markdown(worse) != albedo_controls.format_markdown(data)
    rows = [r for r in data if r["control"] == "coat alpha 0.2, sigma_a 0/0/0, gold alpha 0.2"]
    off = max(abs(100.0 * (x - 1.0)) for r in rows for x in r["ratio"])
    reading = albedo_controls.format_markdown(data).split("Reading it:")[1]
    assert f"{off:.1f} % over rough gold" in reading


def test_the_image_pages_are_what_the_image_bench_writes_with_its_noise_control():
    """bench/images.md and images_multiple.md from their stored rows and the references' index,
    the noise control (the brute-force renderer at the same samples) on every case."""
    from lamella_dev.bench import images
    from lamella_dev.bench.image_references import IMAGE_REFERENCE_DIR, IMAGE_REFERENCE_DIR_MULTIPLE, load_index

    for stem, ref_dir in (("images", IMAGE_REFERENCE_DIR), ("images_multiple", IMAGE_REFERENCE_DIR_MULTIPLE)):
        data = _stored(stem)
        page = images.format_markdown(data["rows"], load_index(ref_dir), data["spp"], data["interfaces"])
        assert (BENCH_DIR / f"{stem}.md").read_text() == page.rstrip("\n") + "\n"
        cases = {r["case"] for r in data["rows"]}
        assert {r["case"] for r in data["rows"] if r["engine"] == images.BRUTE_FORCE} == cases
        assert "## Noise against model error" in page
