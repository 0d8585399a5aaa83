"""The `lamella` command: lobe tables, slice plots, and clear errors on bad stacks (the mistakes
on its options: test_cli_mistakes.py)."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

from lamella_dev.cli import main


def test_lobes_prints_every_model(capsys):
    assert main(["lobes", "rotated_60", "--wi", "30"]) == 0
    out = capsys.readouterr().out
    for m in ("belcour2018", "weier2020", "yamaguchi2019", "yamaguchi_refined", "tm2", "tm6", "tm6_refined"):
        assert m in out
    assert "auto (picked yamaguchi_refined for this stack)" in out
    assert out.count("reflection") == 16  # two lobes per model, eight models with auto


def test_lobes_reports_unsupported_stacks(tmp_path, capsys):
    """A scattering coat over a diffuse base: the thin-layer model says why it cannot, auto picks tm6_refined."""
    p = tmp_path / "fog.json"
    p.write_text(json.dumps({"layers": [{"ior": 1.0, "thickness": 1.0, "sigma_s": [0.5] * 3}],
                             "base": {"type": "diffuse"}}))
    assert main(["lobes", str(p), "--wi", "0"]) == 0
    out = capsys.readouterr().out
    assert "unsupported: endf: coat 0 scatters" in out
    assert "auto (picked tm6_refined for this stack)" in out


def test_bad_stack_names_layer_and_field(tmp_path):
    p = tmp_path / "bad.json"
    p.write_text(json.dumps({"layers": [{"ior": 1.5, "roughness": 2.0}], "base": {"type": "conductor"}}))
    r = subprocess.run([sys.executable, "-m", "lamella_dev.cli", "lobes", str(p), "--wi", "0"],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert "coat 0, field 'roughness'" in r.stderr


def test_plot_writes_a_png(tmp_path):
    out = tmp_path / "slices.png"
    assert main(["plot", "gold_coated", "-o", str(out), "--spp", "8", "--wi", "30"]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_of_glass_has_a_transmitted_row(tmp_path):
    """A dielectric base adds the transmitted slice (below the surface) to the figure."""
    from matplotlib.image import imread

    out, out_metal = tmp_path / "glass.png", tmp_path / "metal.png"
    assert main(["plot", "rough_glass_plate", "-o", str(out), "--spp", "8", "--wi", "30"]) == 0
    assert main(["plot", "gold_coated", "-o", str(out_metal), "--spp", "8", "--wi", "30"]) == 0
    assert imread(out).shape[0] > 1.4 * imread(out_metal).shape[0]


def test_trapping_bench_writes_its_table(tmp_path):
    """`lamella bench trapping` (bench/trapping.md): every variant at every angle, reference and models."""
    from lamella_dev.bench import trapping

    md = trapping.run(tmp_path, spp=2048)
    rows = [line for line in md.read_text().splitlines() if line.startswith("| ") and "°" in line]
    assert len(rows) == len(trapping.VARIANTS) * len(trapping.ANGLES)


@pytest.mark.parametrize("content, message", [
    ('{"layers": ' + "[" * 50000 + "]" * 50000 + ', "base": {"type": "conductor"}}', "nested too deeply"),
    (b"\xff\xfe not text", "cannot read it"),
    ('{"layers": [{"ior": 1e300}], "base": {"type": "conductor"}}', "coat 0, field 'ior'"),
])
def test_malformed_stack_files_exit_with_a_message_not_a_traceback(tmp_path, content, message):
    p = tmp_path / "bad.json"
    p.write_bytes(content if isinstance(content, bytes) else content.encode())
    r = subprocess.run([sys.executable, "-m", "lamella_dev.cli", "lobes", str(p), "--wi", "0"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and message in r.stderr and "Traceback" not in r.stderr, r.stderr[-2000:]
    r = subprocess.run([sys.executable, "-m", "lamella_dev.cli", "lobes", "x" * 5000, "--wi", "0"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr[-2000:]


# ---------------------------------------------------------------- lamella bench
def _documented_benches() -> set[str]:
    """The bench names the Makefile, the README and the command reference (docs/commands.md) run."""
    import re

    root = Path(__file__).resolve().parents[2]
    text = "".join((root / f).read_text() for f in ("Makefile", "README.md", "docs/commands.md"))
    return set(re.findall(r"lamella bench ([a-z][a-z0-9-]*)", text))


def test_every_bench_the_makefile_and_docs_run_is_a_subcommand():
    from lamella_dev.bench import BENCHES
    from lamella_dev.bench.registry import RESERVED
    from lamella_dev.cli import build_parser, cmd_bench

    names = _documented_benches() - set(RESERVED)  # `lamella bench list` is the command's own
    assert len(names) >= 20 and names <= set(BENCHES), names - set(BENCHES)
    for name in names:
        args = build_parser().parse_args(["bench", name])
        assert args.what == name and args.fn is cmd_bench and args.out is None


def test_bench_options_reach_their_bench():
    from lamella_dev.bench import scene
    from lamella_dev.cli import build_parser

    parse = build_parser().parse_args
    a = parse(["bench", "pareto", "--quick", "--cases", "fog_g09_d1,gold_coated", "--out", "x", "--replot"])
    assert (a.quick, a.replot, a.cases, a.out) == (True, True, ["fog_g09_d1", "gold_coated"], Path("x"))
    assert parse(["bench", "pareto"]).cases is None and not parse(["bench", "pareto"]).quick
    a = parse(["bench", "images", "--interfaces", "multiple", "--cases", "gold_coated"])
    assert (a.interfaces, a.cases) == ("multiple", ["gold_coated"])
    assert parse(["bench", "images"]).interfaces == "single"
    assert parse(["bench", "eevee-gap", "--cases", "gold_coated"]).cases == ["gold_coated"]
    assert parse(["bench", "holdout", "--references"]).references and not parse(["bench", "holdout"]).references
    assert parse(["bench", "scene"]).count == scene.COUNT and parse(["bench", "scene", "--count", "3"]).count == 3


def test_bench_list_and_help_name_every_bench(capsys):
    from lamella_dev.bench import BENCHES

    assert main(["bench", "list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == sorted(BENCHES)
    assert all(line.split(None, 1)[1] == BENCHES[line.split()[0]].description for line in lines)
    with pytest.raises(SystemExit):
        main(["bench", "--help"])
    helped = capsys.readouterr().out
    assert all(name in helped for name in BENCHES)


def test_bench_pages_are_written_by_one_helper(tmp_path):
    """``write_page``: the folder made, the data first (indented by one, a newline at the end), the
    page ending in one newline; no data, no JSON; a function for the text runs once the data is written."""
    from lamella_dev.bench import write_page

    out = tmp_path / "a" / "b"
    page = write_page(out, "x", "# X\n\nbody\n\n\n", {"k": [1, 2]})
    assert page == out / "x.md" and page.read_text(encoding="utf-8") == "# X\n\nbody\n"
    assert (out / "x.json").read_text() == '{\n "k": [\n  1,\n  2\n ]\n}\n'
    assert write_page(out, "y", "# Y °").read_text(encoding="utf-8") == "# Y °\n" and not (out / "y.json").exists()

    def text():
        assert (out / "z.json").is_file()
        return "# Z"

    assert write_page(out, "z", text, []).read_text() == "# Z\n"


def test_importing_the_benches_stays_cheap():
    """Every bench module is imported to register it (by the command too): none may import Blender or
    the plotting, progress-bar and MaterialX libraries before it runs."""
    heavy = ("bpy", "_cycles", "matplotlib", "tqdm", "MaterialX", "flip_evaluator")
    r = subprocess.run([sys.executable, "-c", "import sys, lamella_dev.bench, lamella_dev.cli; "
                        "lamella_dev.cli.build_parser(); "
                        f"print([m for m in {heavy!r} if m in sys.modules])"], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout.strip() == "[]", r.stdout + r.stderr[-2000:]
