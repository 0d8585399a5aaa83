"""Messages of the panel and the operators are translatable as in Blender's own scripts and the
Cycles add-on (``lamella/blender/i18n.py``): a text holding values is a template passed through
``iface_`` (labels) or ``rpt_`` (reports) and formatted after, and a label or property showing a
formatted text says ``translate=False``; fixed texts are literals Blender translates itself. Read
from the source (no Blender needed): an f-string or a concatenation in a label, a report or an
operator's error could never match a translation."""
import ast
import re
from pathlib import Path

import pytest

import lamella

BLENDER = Path(lamella.__file__).parent / "blender"
UI_CALLS = {"label", "prop", "operator", "menu", "operator_menu_enum"}  # layout calls with a text=
TRANSLATORS = {"iface_", "rpt_"}


def _names(node) -> set[str]:
    return {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}


def _is_text(node) -> bool:
    return isinstance(node, ast.JoinedStr) or (isinstance(node, ast.Constant) and isinstance(node.value, str))


def _built_in_code(node) -> bool:
    """An f-string, or a + with a string literal: English put together in code, untranslatable."""
    return any(isinstance(n, ast.JoinedStr)
               or (isinstance(n, ast.BinOp) and isinstance(n.op, ast.Add) and (_is_text(n.left) or _is_text(n.right)))
               for n in ast.walk(node))


def _formatted_words(node) -> bool:
    """``"literal with words".format(...)`` not through a translator."""
    for n in ast.walk(node):
        if (isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute) and n.func.attr == "format"
                and isinstance(n.func.value, ast.Constant)
                and any(c.isalpha() for c in re.sub(r"\{[^}]*\}", "", str(n.func.value.value)))):
            return True
    return False


def _messages():
    """(file, line, kind, message node, the call) of every text the interface shows."""
    for path in sorted(BLENDER.glob("*.py")):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if not isinstance(node, ast.Call):
                continue
            func = node.func
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            kw = {k.arg: k.value for k in node.keywords}
            if name in UI_CALLS and "text" in kw:
                yield path.name, node.lineno, "text", kw["text"], node
            elif name == "report" and len(node.args) == 2:
                yield path.name, node.lineno, "report", node.args[1], node
            elif name == "_wrapped" and len(node.args) >= 2:
                yield path.name, node.lineno, "wrapped", node.args[1], node
        if path.name == "operators.py":  # operators report the errors they raise
            for node in ast.walk(tree):
                if isinstance(node, ast.Raise) and isinstance(node.exc, ast.Call) and node.exc.args:
                    yield path.name, node.lineno, "raise", node.exc.args[0], node.exc


MESSAGES = list(_messages())


def test_the_scan_finds_the_panel_and_the_reports():
    kinds = {k for _, _, k, _, _ in MESSAGES}
    assert kinds == {"text", "report", "wrapped", "raise"} and len(MESSAGES) > 40


@pytest.mark.parametrize("where", [f"{f}:{line}" for f, line, *_ in MESSAGES])
def test_every_message_is_a_translatable_template(where):
    f, line, kind, msg, call = next(m for m in MESSAGES if f"{m[0]}:{m[1]}" == where)
    assert not _built_in_code(msg), f"{where}: an f-string or concatenation cannot be translated; use a template"
    assert not _formatted_words(msg), f"{where}: format a template from iface_/rpt_, not a literal"
    if kind == "text" and TRANSLATORS & _names(msg):
        translate = next((k.value for k in call.keywords if k.arg == "translate"), None)
        assert isinstance(translate, ast.Constant) and translate.value is False, (
            f"{where}: a translated, formatted text needs translate=False (Blender would look it up again)")


def test_the_check_catches_untranslatable_messages():
    bad = [ast.parse(s, mode="eval").body for s in (
        'f"Compiled ({model})"', '"Base: " + kind', '"wrote {path}".format(path=p)')]
    assert not _formatted_words(ast.parse('"{:.3f}, {}".format(x, y)', mode="eval").body)  # numbers only
    assert _built_in_code(bad[0]) and _built_in_code(bad[1]) and _formatted_words(bad[2])
    good = ast.parse('iface_("Compiled ({model})").format(model=m)', mode="eval").body
    assert not _built_in_code(good) and not _formatted_words(good)
