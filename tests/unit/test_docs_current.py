"""The pages say what the code and the bench pages say today.

- Figures: every number README.md and docs/*.md quote in a paragraph, list item or table row
  that cites a bench page is one that page prints, and every measured figure (a time, a ratio, an
  error, a test count) in one that cites none is on some bench page (``lamella_dev.doc_figures``).
- Commands: every ``lamella ...`` command the pages show (fenced blocks and inline code) parses
  with the command's own parser, placeholders (STACK.json, DIR, N, ...) replaced by real values;
  the cheap ones (no render, no reference walk, no bpy) run; every ``make TARGET`` shown is a
  target; docs/commands.md names every subcommand and every registered bench.
- README's self-contained Python runs.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from lamella_dev import doc_figures
from lamella_dev.bench import BENCHES
from lamella_dev.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[2]
BENCH = ROOT / "bench"
STACKS = ROOT / "addon" / "lamella" / "data" / "stacks"
PRESETS = ROOT / "addon" / "lamella" / "data" / "presets"


def _quoting_pages() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def _command_pages() -> list[Path]:
    return [*_quoting_pages(), ROOT / "osl" / "README.md", ROOT / "node_groups" / "README.md",
            *sorted(BENCH.glob("*.md"))]


# ---------------------------------------------------------------- figures
def test_docs_quote_the_figures_of_the_bench_pages_they_cite():
    constants = doc_figures.source_constants(ROOT / "addon")
    stale = [str(s) for doc in _quoting_pages() for s in doc_figures.stale_figures(doc, BENCH, ROOT, constants)]
    assert not stale, "figures the cited bench page does not print (quote the page as it is):\n" + "\n".join(stale)


def _tree_with(tmp_path: Path, doc: str, text: str) -> Path:
    """tmp_path as a repository root holding ``doc`` with ``text`` and the real bench pages."""
    (tmp_path / doc).parent.mkdir(parents=True, exist_ok=True)
    (tmp_path / doc).write_text(text, encoding="utf-8")
    (tmp_path / "bench").symlink_to(BENCH, target_is_directory=True)
    return tmp_path / doc


def test_a_stale_figure_is_reported_with_its_file_line_and_page(tmp_path):
    real = (ROOT / "docs" / "extension.md").read_text(encoding="utf-8")
    assert real.count("4608 nodes") == 1
    doc = _tree_with(tmp_path, "docs/extension.md", real.replace("4608 nodes", "4463 nodes"))
    line = real[:real.index("4608 nodes")].count("\n") + 1
    stale = doc_figures.stale_figures(doc, tmp_path / "bench", tmp_path, doc_figures.source_constants(ROOT / "addon"))
    assert [(s.where, s.figure, s.pages) for s in stale] == [(f"docs/extension.md:{line}", "4463", ("bench/live_osl.md",))]
    assert str(stale[0]) == f"docs/extension.md:{line}: 4463 is not in bench/live_osl.md"


def test_the_figure_check_reads_rounding_and_leaves_out_what_is_not_a_figure(tmp_path):
    page = (BENCH / "live_osl.md").read_text(encoding="utf-8")
    assert "| 2310 |" in page and "| 2.52x |" in page and "| 0.0013 |" in page and "1.49x" in page
    doc = _tree_with(tmp_path, "docs/models.md", "\n\n".join([
        "Held: 2310 kB, 2.5x and 2.52x, 0.001, 1.5 (`bench/live_osl.md`).",  # as printed, or rounded from it
        "Stale: 2.53x and 2311 (`bench/live_osl.md`).",  # neither is a printed figure rounded
        "Not figures: Belcour 2018, Heitz et al. 2016, Blender 4.2, MaterialX 1.39, bpy 5.2.3, Eq. 21, "
        "`lamella bench live-osl --spp 97`, yamaguchi2019, rotated_60 (`bench/live_osl.md`).",
        "A constant by its name: 0.5 s (`recompile.DRAG_WINDOW`), 0.7 s (`recompile.SETTLE_DELAY`) "
        "(`bench/live_osl.md`).",
        "Cites no page: 123456.",
        "```\n98765 (`bench/live_osl.md`)\n```",
    ]) + "\n")
    stale = doc_figures.stale_figures(doc, tmp_path / "bench", tmp_path, doc_figures.source_constants(ROOT / "addon"))
    assert [(s.where, s.figure) for s in stale] == [("docs/models.md:3", "2.53"), ("docs/models.md:3", "2311"),
                                                      ("docs/models.md:7", "0.7")]


def test_a_measured_figure_in_a_block_citing_no_page_is_on_some_bench_page():
    stale = [str(s) for doc in _quoting_pages() for s in doc_figures.unheld_unit_figures(doc, BENCH, ROOT)]
    assert not stale, ("measured figures no bench page holds (link the bench page instead of the number):\n"
                       + "\n".join(stale))
    assert doc_figures.design_constants_moved(ROOT) == []


def test_a_measured_figure_no_page_holds_is_reported(tmp_path):
    doc = _tree_with(tmp_path, "docs/models.md", "The suite alone: 98765.4 s, 123457 passed; a drag window of 0.5 s.\n\n"
                     "Held somewhere: 4608 nodes, 2.52x.\n")
    stale = doc_figures.unheld_unit_figures(doc, tmp_path / "bench", tmp_path)
    assert [(s.where, s.figure) for s in stale] == [("docs/models.md:1", "98765.4 s"), ("docs/models.md:1", "123457 passed")]


def test_the_measured_figure_pattern_catches_what_it_is_for():
    found = {m.group(0).strip() for m in doc_figures.UNIT_FIGURE.finditer(
        "the suite alone: 856 s, 1521 passed, 52 skipped; 2.58x Principled; 14-16 ms and 28, 49 and 117 ms; "
        "ΔE00 1.3–2.5 against 2.7–19; relative L1 of 0.072, 0.098; 0.43 % relative L1; 274.5 kB; ~50 min")}
    for figure in ("856 s", "1521 passed", "52 skipped", "2.58x", "14-16 ms", "28, 49 and 117 ms",
                   "ΔE00 1.3–2.5 against 2.7–19", "relative L1 of 0.072, 0.098", "0.43 %", "274.5 kB", "50 min"):
        assert any(figure in f for f in found), (figure, found)
    for text in ("a 2x2 covariance", "480 x 270", "64 x 1 x 9", "Blender 4.2", "Eqs. 37-38", "128 px, 64 spp",
                 "8 coats", "4 samples", "ops.<name>", "CIEDE2000 (ΔE00) after"):
        assert not doc_figures.UNIT_FIGURE.search(text), text


# ---------------------------------------------------------------- commands
# A placeholder the pages write for a value, and the real value a command gets for it: by the
# option it follows (or the subcommand, for a positional), else by itself. An output goes into the
# test's folder. A placeholder missing here fails the test by name.
ANY_STACK = "gold_coated"  # a suite case
PLACEHOLDERS_AFTER = {
    "--wi": {"DEG": "30", "DEG,...": "0,30"},
    "--phi": {"DEG": "0"},
    "--model": {"M": "auto"},
    "--budget": {"K": "2"},
    "--live": {"NAME,...": "coat0_roughness,coat0_ior", "NAME": "coat0_roughness"},
    "--cases": {"a,b": "rotated_60,coat_over_brushed", "NAMES": "holdout_00", "...": "rotated_60"},
    "--only": {"NAMES": "ggx_albedo,tir"},
    "--material": {"NAME": "Gold"},
    "--blend": {"IN.blend": str(ROOT / "node_groups" / "lamella_node_groups.blend")},  # read, never written here
    "--sun-dir": {"X,Y,Z": "0,-1,1"},
    "--blender-python": {"PY": sys.executable},
    "--also": {"PYTHON": sys.executable},
    "bench": {"NAME": "accuracy"},
}
PLACEHOLDERS = {"STACK.json": ANY_STACK, "STACK": ANY_STACK, "CASE": ANY_STACK, "N": "4",
                "PRESET.json": str(PRESETS / "lacquered_gold.json"), "my_stack.json": str(STACKS / "gold_coated.json")}
OUTPUTS = {"-o", "--out", "--lut-dir", "--osl-out", "--node-groups-out"}  # files and folders: into tmp
# Commands that need no render, no reference walk and no bpy: each shown form runs.
CHEAP = {"lobes", "stack-format", "export-osl", "export-mtlx"}
PLACEHOLDER = re.compile(r"^(?:[A-Z][A-Z_]*(?:\.\w+)?|[A-Z]+,\.\.\.|a,b|\.\.\.)$")


def _code(page: Path):
    """(line, text) for every line of a fenced block and every inline code span of ``page``."""
    text = page.read_text(encoding="utf-8")
    fences = re.compile(r"^[ \t]*```.*?^[ \t]*```", re.S | re.M)
    for block in fences.finditer(text):
        for k, line in enumerate(block.group(0).splitlines()):
            yield text.count("\n", 0, block.start()) + k + 1, line.strip()
    prose = fences.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), text)
    for m in re.finditer(r"`([^`]+)`", prose):
        yield prose.count("\n", 0, m.start()) + 1, re.sub(r"\s+", " ", m.group(1)).strip()


def _shown_commands(page: Path):
    """(line, command) for every ``lamella ...`` in a fenced block or an inline code span of ``page``."""
    for line, code in _code(page):
        m = re.match(r"(?:\$ )?(lamella [a-z].*)", code)
        if m:
            yield line, m.group(1)


def _forms(command: str) -> list[str]:
    """A synopsis as the command lines it stands for: every optional part in (each alternative of
    ``a|b`` in turn), and every optional part out."""
    command = re.split(r"\s(?:#|>|;)|;", command.replace("\\|", "|"))[0].strip()
    bare = command
    while re.search(r"\[[^\[\]]*\]", bare):
        bare = re.sub(r"\s*\[[^\[\]]*\]", "", bare)
    full = command.replace("[", "").replace("]", "")
    ways = max([len(t.split("|")) for t in full.split()] + [1])
    forms = [" ".join(t.split("|")[min(i, len(t.split("|")) - 1)] for t in full.split()) for i in range(ways)]
    return list(dict.fromkeys([*forms, " ".join(t.split("|")[0] for t in bare.split())]))


def _concrete(form: str, out_dir: Path) -> list[str]:
    args, before = shlex.split(form)[1:], None
    for k, token in enumerate(args):
        value = PLACEHOLDERS_AFTER.get(before, {}).get(token) or PLACEHOLDERS.get(token)
        if before in OUTPUTS:
            value = str(out_dir / Path(value or token).name.lower())
        elif value is None and PLACEHOLDER.match(token):
            raise AssertionError(f"no value for the placeholder {token!r} after {before!r}: add one to PLACEHOLDERS")
        args[k] = value or token
        before = token
    return args


def _parse(args: list[str]) -> tuple[argparse.Namespace | None, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            return build_parser().parse_args(args), ""
        except SystemExit as e:
            return None, err.getvalue().strip().splitlines()[-1] if e.code else ""


def _subparser(args: list[str]) -> argparse.ArgumentParser | None:
    """The parser of the (sub)command ``args`` name (``bench``'s bench), or None if there is none."""
    parser = build_parser()
    for name in args[:2]:
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if not subs:
            break
        if name not in subs[0].choices:
            return None
        parser = subs[0].choices[name]
    return parser


def _mentions_ok(args: list[str]) -> str:
    """A mention (``lamella render --engine cycles-nodes``, no stack): the subcommand exists, and
    so does every option it names; the first problem, or ''."""
    parser = _subparser(args)
    if parser is None:
        return f"no subcommand {' '.join(args[:2])!r}"
    known = {s for a in parser._actions for s in a.option_strings}
    unknown = [t for t in args if t.startswith("-") and not re.match(r"-\d", t) and t.split("=")[0] not in known]
    return f"no option {unknown[0]} of lamella {args[0]}" if unknown else ""


def _command_problems(pages, root: Path, out_dir: Path) -> tuple[list[str], list[tuple[str, list[str]]]]:
    """(every shown command that does not parse, as file:line: command: why; the parsed forms of
    the cheap commands, to run)."""
    problems, runnable = [], []
    for page in pages:
        for line, command in _shown_commands(page):
            where = f"{page.relative_to(root)}:{line}"
            for form in _forms(command):
                args = _concrete(form, out_dir)
                mention = _mentions_ok(args)
                parsed, error = _parse(args)
                if mention or (parsed is None and error and not re.search(r"required|expected one argument", error)):
                    problems.append(f"{where}: {form}: {mention or error}")
                elif parsed is not None and "--help" not in args and (
                        args[0] in CHEAP or args[:2] == ["bench", "list"]):
                    runnable.append((f"{where}: {form}", args))
    return problems, runnable


@pytest.fixture(scope="module")
def shown(tmp_path_factory):
    out_dir = tmp_path_factory.mktemp("shown")
    return out_dir, *_command_problems(_command_pages(), ROOT, out_dir)


def test_every_shown_command_parses(shown):
    _, problems, runnable = shown
    assert not problems, "commands the pages show that `lamella` does not take:\n" + "\n".join(problems)
    assert {args[0] for _, args in runnable} == CHEAP | {"bench"}, runnable


def test_the_cheap_shown_commands_run(shown, monkeypatch, capsys):
    out_dir, _, runnable = shown
    monkeypatch.chdir(out_dir)
    failed = []
    for where, args in dict((" ".join(a), (w, a)) for w, a in runnable).values():
        try:
            code = main(args)
        except SystemExit as e:  # a refused stack or option: exit 2 with its message
            code = e.code
        if code != 0:
            failed.append(f"{where}: exit {code}: {capsys.readouterr().err.strip()[-300:]}")
    capsys.readouterr()
    assert not failed, "shown commands that fail:\n" + "\n".join(failed)
    assert (out_dir / "gold_coated.mtlx").is_file() and (out_dir / "wood.mtlx").is_file()


def test_a_renamed_option_in_a_shown_command_is_reported(tmp_path):
    real = (ROOT / "docs" / "commands.md").read_text(encoding="utf-8")
    row = "| `lamella plot STACK.json [-o out.png] [--spp N] [--wi DEG,...]` |"
    assert real.count(row) == 1
    page = tmp_path / "docs" / "commands.md"
    page.parent.mkdir()
    page.write_text(real.replace(row, row.replace("--spp N", "--samples N"))
                    .replace("`lamella bench thin-film`", "`lamella bench thin-films`"), encoding="utf-8")
    problems, _ = _command_problems([page], tmp_path, tmp_path)
    line = real[:real.index(row)].count("\n") + 1
    assert f"docs/commands.md:{line}: lamella plot STACK.json -o out.png --samples N --wi DEG,...: " \
           f"no option --samples of lamella plot" in problems, problems
    assert any("lamella bench thin-films: no subcommand 'bench thin-films'" in p for p in problems), problems
    assert len(problems) == 2, problems  # the shortest form, without the renamed option, parses


def test_every_shown_make_target_is_in_the_makefile():
    targets = set(re.findall(r"^([\w.-]+)\s*:(?!=)", (ROOT / "Makefile").read_text(), re.M))
    shown = [(f"{page.relative_to(ROOT)}:{line}", target) for page in _command_pages() for line, code in _code(page)
             for target in re.findall(r"(?:^|[\s;&(])make ([a-z][\w-]*)", code)]
    assert len(shown) > 20
    assert not [s for s in shown if s[1] not in targets], [s for s in shown if s[1] not in targets]


def test_the_command_reference_names_every_subcommand_and_bench():
    text = (ROOT / "docs" / "commands.md").read_text(encoding="utf-8")
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    missing = [f"lamella {name}" for name in sub.choices if f"`lamella {name}" not in text]
    missing += [f"lamella bench {name}" for name in BENCHES if f"`lamella bench {name}" not in text]
    assert not missing, f"docs/commands.md does not name: {', '.join(missing)}"


def test_the_shown_mxvalidate_command_says_the_export_is_valid(tmp_path, monkeypatch):
    shown = [line for line in (ROOT / "docs" / "materialx.md").read_text().splitlines() if line.startswith("mxvalidate")]
    tool = Path(sys.executable).with_name("mxvalidate")
    if not tool.is_file():
        pytest.skip("MaterialX's mxvalidate is not installed here")
    monkeypatch.chdir(tmp_path)
    assert main(["export-mtlx", "gold_coated", "-o", "gold_coated.mtlx"]) == 0
    assert shown == ["mxvalidate --stdlib gold_coated.mtlx"]
    out = subprocess.run([str(tool), *shlex.split(shown[0])[1:]], capture_output=True, text=True, check=True).stdout
    assert out.startswith("gold_coated.mtlx is a valid MaterialX document"), out
    bare = subprocess.run([str(tool), "gold_coated.mtlx"], capture_output=True, text=True).stdout
    assert "is not a valid" in bare  # what the page says happens without --stdlib


# ---------------------------------------------------------------- README's Python
def _python_blocks(page: Path) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", page.read_text(encoding="utf-8"), re.S | re.M)


def test_the_readme_python_that_needs_no_blender_runs(monkeypatch):
    blocks = [b for b in _python_blocks(ROOT / "README.md") if "bpy" not in b and "sys.argv" not in b]
    assert len(blocks) == 1 and "import lamella.core as lc" in blocks[0]
    monkeypatch.chdir(ROOT)  # the block names the stack file from the repository's root
    scope: dict = {}
    exec(compile(blocks[0], "README.md", "exec"), scope)
    assert scope["stack"].name == "gold_coated" and len(scope["gold"].coats) >= 1


def test_the_readme_batch_script_is_the_example_file():
    """The README's Blender script is docs/examples/batch_apply.py, which a Blender test runs."""
    script = next(b for b in _python_blocks(ROOT / "README.md") if "bpy" in b)
    assert script.strip() in (ROOT / "docs" / "examples" / "batch_apply.py").read_text(encoding="utf-8")


def test_the_checks_read_the_files_they_are_for():
    assert len(list(_shown_commands(ROOT / "docs" / "commands.md"))) > 40
    assert sum(1 for page in _command_pages() for _ in _shown_commands(page)) > 100
