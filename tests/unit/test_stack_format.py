"""The stack format's version: written on every stack, older formats migrated, newer ones refused
with a message naming the field; and its reference page generated from the schema."""
import json
from pathlib import Path

import pytest

from lamella.core import Stack, StackError, stack_format
from lamella_dev import suite
from lamella.core.presets import builtin
from lamella_dev.stack_format_page import PAGE, render

ROOT = Path(__file__).resolve().parents[2]
GOLD = suite.load("gold_coated").to_dict()


def test_every_stack_written_says_its_format():
    d = suite.load("tinted_varnish").to_dict()
    assert d["format"] == stack_format.FORMAT
    assert Stack.from_json(json.dumps(d)).to_dict() == d


def test_a_stack_without_a_format_is_read_as_format_1():
    d = {k: v for k, v in GOLD.items() if k != "format"}
    assert Stack.from_dict(d) == Stack.from_dict({**d, "format": 1}) == suite.load("gold_coated")


@pytest.mark.parametrize("value", [stack_format.FORMAT + 1, 99])
def test_a_newer_format_is_refused_with_a_message_that_says_so(value):
    with pytest.raises(StackError) as e:
        Stack.from_dict({**GOLD, "format": value})
    assert (e.value.layer, e.value.field) == ("stack", "format")
    assert "newer Lamella" in str(e.value) and str(value) in str(e.value)


@pytest.mark.parametrize("value", [0, -3, "1", True, 1.5, None, [1]])
def test_a_format_that_is_not_a_version_is_refused(value):
    with pytest.raises(StackError) as e:
        Stack.from_dict({**GOLD, "format": value})
    assert (e.value.layer, e.value.field) == ("stack", "format")


def test_older_formats_run_every_migration_in_turn(monkeypatch):
    """Pretend two newer formats exist: a format-1 stack goes through both migrations, in order,
    and the caller's dict is left as it was."""
    first = stack_format.FORMAT
    seen = []

    def rename_ior(d):  # format N: coats called their index "n"
        seen.append(first)
        return {**d, "layers": [{**{k if k != "n" else "ior": v for k, v in c.items()}} for c in d["layers"]]}

    def name_it(d):
        seen.append(first + 1)
        return {**d, "name": d.get("name") or "unnamed"}

    monkeypatch.setattr(stack_format, "FORMAT", first + 2)
    monkeypatch.setitem(stack_format.MIGRATIONS, first, rename_ior)
    monkeypatch.setitem(stack_format.MIGRATIONS, first + 1, name_it)
    old = {"format": first, "layers": [{"type": "coat", "n": 1.4, "roughness": 0.1}], "base": GOLD["base"]}
    kept = json.loads(json.dumps(old))
    s = Stack.from_dict(old)
    assert seen == [first, first + 1]
    assert s.coats[0].ior == 1.4 and s.name == "unnamed"
    assert s.to_dict()["format"] == first + 2
    assert old == kept


def test_the_shipped_stacks_carry_the_current_format():
    for preset in builtin():
        assert json.loads(preset.path.read_text())["format"] == stack_format.FORMAT, preset.path


def test_the_reference_page_is_current():
    """docs/stack-format.md is what ``lamella stack-format`` writes from today's schema."""
    stored = (ROOT / PAGE).read_text(encoding="utf-8")
    assert stored == render(), f"regenerate it: lamella stack-format -o {PAGE}"


def test_the_reference_page_documents_every_field():
    from lamella.core.layers import BASE_KINDS, COAT_KINDS

    sections = {part.split("`", 1)[0]: part for part in render().split("### `")[1:]}
    for kind in (*COAT_KINDS.values(), *BASE_KINDS.values()):
        rows = {line.split("`")[1]: line for line in sections[kind.type].splitlines() if line.startswith("| `")}
        assert list(rows) == [f.name for f in kind.fields], kind.type
        for f in kind.fields:
            assert f.description in rows[f.name] and f.ui_label in rows[f.name]
