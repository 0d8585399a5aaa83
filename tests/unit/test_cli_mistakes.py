"""Every mistake on the `lamella` command line is refused before any work: one line on stderr that
names the option and what it allows, exit status 2, no traceback, no file written.

The mistakes are generated from the parser itself (``cli.build_parser``, every subcommand and each
``bench NAME``): each option's checked type (``lamella_dev.arguments.Checked``) says what it
accepts, and its kind implies what to get wrong, so a new option is covered without a new test;
an option whose type the generator does not know fails ``test_every_option_is_checked``."""
import argparse
import subprocess
import sys

import pytest

from lamella_dev import cli
from lamella_dev.arguments import Checked

STACK = "gold_coated"  # the positional stack of the commands that take one
TMP = "{tmp}"  # stands for the test's tmp_path in the generated arguments
FLAGS = (argparse._StoreTrueAction, argparse._StoreFalseAction, argparse._HelpAction)


def _commands():
    """(the words that name a (sub)command, its parser) for `lamella` and every subcommand under it."""
    def walk(words, parser):
        yield words, parser
        for subs in (a for a in parser._actions if isinstance(a, argparse._SubParsersAction)):
            for name, sub in subs.choices.items():
                yield from walk([*words, name], sub)
    return list(walk([], cli.build_parser()))


def _valid(action) -> str:
    """A value ``action`` accepts (for the required options beside the one under test)."""
    if action.choices:
        return next(iter(action.choices))
    t = action.type
    if t.kind == "output_file":
        return f"{TMP}/out{t.limits['suffixes'][0]}"
    return {"input_file": f"{TMP}/scene.blend", "text": "Paint", "output_dir": f"{TMP}/out",
            "output_file_or_dir": f"{TMP}/out", "angle": "30"}[t.kind]


def _mistakes(action) -> list[str] | None:
    """What to get wrong in ``action``'s value, by what its type accepts; None for a type this
    generator does not know (an unchecked option)."""
    if action.choices is not None:
        return ["nosuch"]
    t = action.type
    if not isinstance(t, Checked):
        return None
    lim = t.limits
    if t.kind == "count":
        return ["abc", "1.5", "", str(lim["lo"] - 1), "-5"] + ([str(lim["hi"] + 1)] if lim["hi"] else [])
    if t.kind == "number":
        return ["abc", "nan", "inf", "", f"{lim['lo'] if lim['lo_open'] else lim['lo'] - 1:g}",
                f"{lim['hi'] if lim['hi_open'] else lim['hi'] + 1:g}"]
    if t.kind == "angle":
        return ["abc", "nan", "", f"{lim['hi'] + 5:g}", f"{lim['lo'] - 5:g}"]
    if t.kind == "angles":
        out = ["abc", "30,", ",", "nan", "", f"{lim['hi'] + 5:g}", f"{lim['lo'] - 5:g}"]
        if lim["only"]:
            out.append(str(next(x for x in range(int(lim["lo"]), int(lim["hi"])) if x not in lim["only"])))
        return out
    if t.kind == "direction":
        return ["1,0", "a,b,c", "0,0,0", "nan,0,1", "inf,0,1", "1,0,0,0", ""]
    if t.kind in ("name", "names"):
        return ["nosuch", "", *([",", f"{next(iter(lim['choices']()))},nosuch"] if t.kind == "names" else [])]
    if t.kind == "identifiers":
        return ["", ",", "a b", "x-y"]
    if t.kind == "text":
        return ["", "a\nb"]
    if t.kind == "path_text":
        return ["", 'a"b', "a\nb"]
    # no folder can be made in /proc; a file is no folder; no file system takes a name of 300 bytes
    not_creatable = ["/proc/x/y", f"{TMP}/a_file/y", f"{TMP}/{'x' * 300}/y"]
    if t.kind == "output_file":
        ext = lim["suffixes"][0]
        return [f"{TMP}/folder{ext}", *(p + ext for p in not_creatable), f"{TMP}/out.wrong"]
    if t.kind == "output_dir":
        return [f"{TMP}/a_file", *not_creatable]
    if t.kind == "output_file_or_dir":
        ext = lim["suffixes"][0]
        return [f"{TMP}/a_file", f"{TMP}/folder{ext}", *not_creatable, *(p + ext for p in not_creatable)]
    if t.kind == "input_file":
        return [f"{TMP}/missing", f"{TMP}/folder", *([f"{TMP}/a_file"] if lim["checks_content"] else [])]
    if t.kind == "program":
        return [f"{TMP}/missing", f"{TMP}/folder", f"{TMP}/a_file"]
    return None


def _options(parser):
    """The options of ``parser`` that take a value (not flags), and its positionals (not its subcommands)."""
    options = [a for a in parser._actions if a.option_strings and not isinstance(a, FLAGS)]
    positionals = [a for a in parser._actions if not a.option_strings and not isinstance(a, argparse._SubParsersAction)]
    return options, positionals


def _generated():
    """(id, argv, the option as typed) for every mistake of every option; and the options the
    generator does not know, as 'lamella <sub> --x (type)'."""
    cases, unknown = [], []
    for words, parser in _commands():
        options, positionals = _options(parser)
        for a in positionals:
            if a.dest != "stack":  # a stack is any name `_load_stack` resolves, or a file
                unknown.append(f"lamella {' '.join(words)} {a.dest} (a positional of type {a.type!r})")
        for action in options:
            typed = next((s for s in action.option_strings if s.startswith("--")), action.option_strings[0])
            mistakes = _mistakes(action)
            if mistakes is None:
                unknown.append(f"lamella {' '.join(words)} {typed} (type {action.type!r})")
                continue
            others = [w for o in options if o.required and o is not action
                      for w in (o.option_strings[0], _valid(o))]
            for value in mistakes:
                argv = [*words, *([STACK] if positionals else []), *others, f"{typed}={value}"]
                cases.append(pytest.param(argv, typed, id=" ".join([*words, f"{typed}={value!r}"])))
    return cases, unknown


CASES, UNKNOWN = _generated()


def test_every_option_is_checked():
    """Every option has a checked type (``lamella_dev.arguments``) or choices, or is a flag."""
    assert not UNKNOWN, "options the mistake generator does not know (give them a checked type):\n" + "\n".join(UNKNOWN)
    assert len(CASES) > 200


def test_the_generator_refuses_an_unchecked_option():
    p = argparse.ArgumentParser()
    for a in (p.add_argument("--x", type=float), p.add_argument("--y"), p.add_argument("--z", type=int)):
        assert _mistakes(a) is None


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """tmp_path as the working folder, holding a folder, a file that is no folder and a .blend;
    returns what is in it, to check nothing was added."""
    (tmp_path / "folder").mkdir()
    for ext in (".png", ".exr", ".mtlx", ".blend", ".md", ".osl"):
        (tmp_path / f"folder{ext}").mkdir()
    (tmp_path / "a_file").write_text("not a folder, not a .blend, not a program")
    (tmp_path / "scene.blend").write_bytes(b"BLENDER-v402")
    monkeypatch.chdir(tmp_path)
    return tmp_path, sorted(tmp_path.rglob("*"))


def _refused(argv, capsys) -> str:
    """``main(argv)`` exits with status 2: its one line on stderr, checked to be one line with no traceback."""
    with pytest.raises(SystemExit) as e:
        cli.main(argv)
    out, err = capsys.readouterr()
    lines = [line for line in err.splitlines() if line.strip()]
    assert e.value.code == 2, (e.value.code, err)
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.mark.parametrize("argv, option", CASES)
def test_a_mistake_is_one_line_naming_the_option(argv, option, workdir, capsys):
    tmp, before = workdir
    line = _refused([a.replace(TMP, str(tmp)) for a in argv], capsys)
    assert option in line, line
    assert sorted(tmp.rglob("*")) == before


# ---------------------------------------------------------------- the mistakes once reported, by name
@pytest.mark.parametrize("argv, message", [
    (["stress", "--stacks", "0"], "lamella stress: error: argument --stacks: must be a whole number, 1 or more, got 0"),
    (["stress", "--stacks", "-5"], "argument --stacks: must be a whole number, 1 or more, got -5"),
    (["lobes", STACK, "--wi", "30", "--model", "nosuch"], "argument --model: unknown model 'nosuch'; one of: auto,"),
    (["lobes", STACK, "--model", "tm66", "--wi", "30"], "unknown model 'tm66' (did you mean 'tm6'"),
    (["lobes", STACK, "--wi", "nan"], "argument --wi: must be an angle in degrees from 0 to 90, got 'nan'"),
    (["render", STACK, "--sun-dir", "1,0"], "argument --sun-dir: must be three comma-separated finite numbers"),
    (["render", STACK, "--sun-dir", "a,b,c"], "argument --sun-dir: must be three comma-separated finite numbers"),
    (["render", STACK, "--sun-dir", "0,0,0"], "(a direction needs a length), got '0,0,0'"),
    (["plot", STACK, "--wi", "abc"], "argument --wi: must be comma-separated angles in degrees from 0 to 90, got"),
    (["plot", STACK, "--wi", "30,"], "got '30,'"),
    (["plot", STACK, "--wi", "95"], "from 0 to 90, got '95'"),
    (["plot", STACK, "--spp", "-5"], "argument --spp: must be a whole number, 1 or more, got -5"),
    (["plot", STACK, "--spp", "0"], "argument --spp: must be a whole number, 1 or more, got 0"),
    (["bench", "pareto", "--cases", "nosuch"], "argument --cases: unknown suite case 'nosuch'; one of: "),
    (["bench", "eevee-anisotropy-fit", "--cases", "gold_coated"],
     "unknown anisotropic suite case 'gold_coated'; one of: coat_over_brushed"),
    (["references", "--cases", "nosuch"], "lamella references: error: argument --cases: unknown suite case 'nosuch'"),
    (["references", "--wi", "45,50"], "each one of 0, 30, 60, 75, 45, got '45,50'"),
    (["image-references", "--cases", "gold_coatd"], "(did you mean 'gold_coated'"),
    (["luts", "--only", "nosuch"], "argument --only: unknown table 'nosuch'; one of: ggx_albedo"),
    (["render", STACK, "--res", "0"], "argument --res: must be a whole number from 1 to 16384, got 0"),
    (["render", STACK, "--res", "20000"], "must be a whole number from 1 to 16384, got 20000"),
    (["render", STACK, "--spp", "many"], "argument --spp: must be a whole number, got 'many'"),
    (["render", STACK, "--out", "x.png"], "argument --out: must be a file ending in .exr (a linear float EXR), got"),
    (["render", STACK, "--out", "folder"], "is a folder"),
    (["apply", STACK, "--blend", "a_file", "--material", "m", "-o", "out.blend"],
     "argument --blend: must be a .blend file, but 'a_file' is not one"),
    (["apply", STACK, "--blend", "scene.blend", "--material", "m", "-o", "folder"], "argument -o/--out: "),
    (["export-osl", STACK, "-o", "a_file"], "argument -o/--out: must be a folder, but 'a_file' is a file"),
    (["export-osl", STACK, "-o", "/proc/x/bundle"], "cannot be written: no file can be created in '/proc'"),
    (["export-mtlx", STACK, "-o", "folder"], "argument -o/--out: must be a file ending in .mtlx"),
    (["export-mtlx", STACK, "-o", "a_file/x.mtlx"], "cannot be written: 'a_file' is a file, not a folder"),
    (["stack-format", "-o", "folder"], "lamella stack-format: error: argument -o/--out: must be a file ending in .md"),
    (["bench", "scene", "--count", "0"], "argument --count: must be a whole number, 1 or more, got 0"),
    (["bench", "energy", "--quick"], "unrecognized arguments: --quick"),  # an option of another bench
    (["bench", "images", "--interfaces", "double"], "invalid choice: 'double'"),
    (["bench"], "required: NAME"),
    # checks that need the stack or another option: in the command, before any work
    (["export-osl", STACK, "-o", "bundle", "--live", "nosuch"], "lamella: export-osl: not an input of this shader"),
    (["luts", "--only", "tir", "--out", "new"], "lamella: luts: --only keeps the other tables from new/tables.npz"),
    (["image-references", "--cases", "three_coats", "--thickness", "0.3"],
     "lamella: image-references: --thickness 0.3 x 3 coats of three_coats must stay below half"),
    (["lobes", "lacquered_gol", "--wi", "30"],
     "lamella: no stack 'lacquered_gol' (did you mean 'lacquered_gold'?): a stack is a JSON file's path, a suite "
     "case, an example or a preset id; `lamella stacks` lists the names"),
])
def test_the_reported_mistakes(argv, message, workdir, capsys):
    tmp, before = workdir
    assert message in _refused(argv, capsys)
    assert sorted(tmp.rglob("*")) == before


def test_apply_refuses_a_blend_that_is_not_one_in_its_own_process(tmp_path):
    """The command as a pipeline runs it: a subprocess, its one line, no traceback."""
    p = tmp_path / "scene.blend"
    p.write_text("not a blend file")
    r = subprocess.run([sys.executable, "-m", "lamella_dev.cli", "apply", STACK, "--blend", str(p),
                        "--material", "m", "-o", str(tmp_path / "out.blend")], capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.splitlines() == [f"lamella apply: error: argument --blend: must be a .blend file, but '{p}' is "
                                     "not one"]


# ---------------------------------------------------------------- a preset id is a stack
def test_every_preset_id_is_a_stack(capsys):
    """A preset's id names its stack; where a suite case of that name holds another stack, the bare
    name is refused with one line naming both, and ``preset:`` or ``suite:`` says which."""
    from lamella.core.presets import builtin
    from lamella_dev import suite

    for preset in builtin():
        assert cli._load_stack(f"preset:{preset.id}") == preset.load(), preset.id
        if preset.id in suite.names() and suite.load(preset.id).to_dict() != preset.load().to_dict():
            assert cli._load_stack(f"suite:{preset.id}") == suite.load(preset.id)
            with pytest.raises(SystemExit) as e:
                cli._load_stack(preset.id)
            assert e.value.code == 2
            err = capsys.readouterr().err.strip()
            assert "\n" not in err and f"suite:{preset.id} or preset:{preset.id}" in err, err
        else:
            assert cli._load_stack(preset.id) == preset.load(), preset.id


def test_lobes_and_the_exports_take_a_preset_id(tmp_path, capsys):
    assert cli.main(["lobes", "lacquered_gold", "--wi", "30", "--model", "auto"]) == 0
    assert "stack " in capsys.readouterr().out
    assert cli.main(["export-mtlx", "lacquered_gold", "-o", str(tmp_path / "x.mtlx")]) == 0
    assert (tmp_path / "x.mtlx").read_text().startswith("<?xml")
    assert cli.main(["export-osl", "lacquered_gold", "-o", str(tmp_path / "dir")]) == 0
    assert list((tmp_path / "dir").glob("*.osl"))


class _Loaded(Exception):
    pass


@pytest.mark.parametrize("argv", [
    ["render", "lacquered_gold"],
    ["plot", "lacquered_gold"],
    ["apply", "lacquered_gold", "--blend", "scene.blend", "--material", "m", "-o", "out.blend"],
])
def test_render_plot_and_apply_load_a_preset_id_first(argv, workdir, monkeypatch):
    """They take their stack through ``_load_stack`` before any work (no render, no Blender here)."""
    from lamella.core.presets import builtin

    loaded, load = [], cli._load_stack

    def load_then_stop(name):
        loaded.append(load(name))
        raise _Loaded

    monkeypatch.setattr(cli, "_load_stack", load_then_stop)
    with pytest.raises(_Loaded):
        cli.main(argv)
    assert loaded == [next(p for p in builtin() if p.id == "lacquered_gold").load()]


def test_stacks_lists_every_name_with_where_it_comes_from(capsys):
    assert cli.main(["stacks"]) == 0
    rows = dict(line.split(None, 1) for line in capsys.readouterr().out.splitlines())
    assert rows["gold_coated"] == "suite case" and rows["four_coats"] == "example"
    assert rows["lacquered_gold"] == "preset"
    assert rows["suite:varnished_wood"] == "suite case" and rows["preset:varnished_wood"] == "preset"
    assert "varnished_wood" not in rows  # two different stacks of one name: listed by source


def test_the_checks_import_nothing_heavy():
    """A refused option costs nothing: parsing imports no Blender, no plotting (render, apply, stress)."""
    heavy = ("bpy", "matplotlib", "MaterialX")
    code = ("import sys; from lamella_dev import cli\n"
            "for argv in (['render', 'gold_coated', '--spp', '0'], ['apply', 'gold_coated'],\n"
            "             ['stress', '--stacks', '0']):\n"
            "    try: cli.main(argv)\n"
            "    except SystemExit: pass\n"
            f"print([m for m in {heavy!r} if m in sys.modules])")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.stdout.strip().splitlines()[-1] == "[]", r.stdout + r.stderr[-2000:]
