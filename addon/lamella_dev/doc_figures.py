"""The figures README.md and docs/*.md quote, checked against the bench pages they cite.

A bench page (``bench/live_osl.md``, say) is written by the bench that measures it (``lamella bench live-osl``);
a page of prose that quotes one of its figures goes stale at the next measurement unless something
compares the two. ``stale_figures`` does: in every block of a page (a paragraph, a list item, a
table row, a heading) that cites a bench page, every number of the prose (code spans and fenced
blocks are commands and names, not quotes) must be one the cited pages print, as printed or
rounded from it (0.32 for the page's 0.323, not 4463 for its 4608). A block citing several pages
may quote any of them; ``bench/eevee_*.md`` cites every page it matches.

Numbers that are not measured figures are taken out of the prose first, each kind by one pattern
of ``NOT_FIGURES``: a year in a citation (Belcour 2018), a version (Blender 4.2, MaterialX 1.39),
an equation, section or figure number (Eq. 21). Settings a sentence states as inputs (128 px,
64 spp) are checked like figures: the page that measured at them prints them too. A design
constant is quoted with its name: a number equal to a module-level constant that the block names
in a code span (0.5 s, `recompile.DRAG_WINDOW`; `SVM_UNSURE` (150)) is that constant's value, read
from the source, so it is checked too.

A block that cites no page may still quote a measured figure (a time, a ratio, a percentage, a
size, an error, a test count: ``UNIT_FIGURE``): it must be a number some bench page prints
(``unheld_unit_figures``), unless it is one of the ``DESIGN_CONSTANTS`` (a bound chosen, not
measured, checked to be set where it says).
"""
from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path

# A page cited by path: bench/live_osl.md, bench/images.json, bench/eevee_*.md.
CITED_PAGE = re.compile(r"\bbench/([\w*]+\.(?:md|json))\b")

# A number as prose writes it: 4608, 1,000,000, 0.323, -0.5, 2.58 (of 2.58x), 13.2 (of 13.2 %).
# Not a digit inside a name (yamaguchi2019, rotated_60, coat0_ior, K2) or a path.
NUMBER = re.compile(r"(?<![\w.,/#@])(?<![A-Za-z_]-)-?(?:\d{1,3}(?:,\d{3})+|\d+)(?:\.\d+)?(?![\w.,]?\d|[A-Za-z_]*\d)")

_YEAR = r"(?:1[89]|20)\d\d[a-z]?"
# Numbers in the prose that are not measured figures, each pattern one kind, removed before the
# figures are read.
NOT_FIGURES = {
    # a paper cited by author and year (Belcour 2018, Heitz et al. 2016, Johnson & Christy 1972
    # and 1974, OpenPBR v1.1's "Weier and Belcour 2020"), the years of one author listed together
    "citation year": re.compile(rf"(?:\b[A-Z][a-zà-ž][\w'’-]*|\bal\.|\bd'Eon)(?:,)? {_YEAR}(?:(?:,| and) {_YEAR})*\b"),
    # a release of a tool: Blender 4.2, bpy 5.2.3, Python 3.13, MaterialX 1.39, OpenPBR v1.1
    "version": re.compile(r"\b(?:Blender|bpy|Python|MaterialX|materialx|OpenPBR|OSL|pytest|pytest-xdist|numpy|"
                          r"OpenEXR|Cycles|EEVEE)\s+v?\d+(?:\.\d+)+(?:\s*(?:to|and|,)\s*\d+(?:\.\d+)+)*"
                          r"|\bv\d+(?:\.\d+)+|\b\d+\.\d+\.\d+\b"),
    # a numbered part of a paper or a spec: Eq. 21, Eqs. 37-38, Section 5, Figure 3, Listing 3, § 4
    "paper part": re.compile(r"\b(?:Eqs?\.|Equations?|Sections?|Sec\.|Fig(?:ure)?s?\.?|Tables?|Listings?|"
                             r"Algorithms?|Appendix|§)\s?\d+(?:\s?[-–]\s?\d+)?"),
}


# A constant named in a code span: `recompile.DRAG_WINDOW`, `SVM_UNSURE`.
CONSTANT_NAME = re.compile(r"`[\w.]*?\b([A-Z][A-Z0-9_]*[A-Z0-9])`")


@dataclass(frozen=True)
class StaleFigure:
    """A figure a doc quotes that none of the pages its block cites prints."""

    where: str  # file:line
    figure: str
    pages: tuple[str, ...]

    def __str__(self) -> str:
        return f"{self.where}: {self.figure} is not in {', '.join(self.pages)}"


def page_numbers(text: str) -> set[Decimal]:
    """Every number a bench page prints (a JSON file's too), as written there."""
    return {_value(m.group(0)) for m in re.finditer(r"-?\d+(?:,\d{3})*(?:\.\d+)?(?:[eE][-+]?\d+)?", text)}


def _value(text: str) -> Decimal:
    return Decimal(text.replace(",", ""))


def held(figure: str, numbers: set[Decimal]) -> bool:
    """Whether ``figure`` is one of ``numbers`` or one of them rounded to the figure's decimals
    (0.32 holds for 0.323 and 0.3249, not for 0.326; 4463 for no number but 4462.5 to 4463.5)."""
    value = abs(_value(figure))
    decimals = len(figure.partition(".")[2])
    half = Decimal(5).scaleb(-decimals - 1)
    return any(abs(abs(n) - value) <= half for n in numbers)


def source_constants(package_dir: Path) -> dict[str, set[Decimal]]:
    """The module-level ``NAME = number`` of every Python file under ``package_dir``, by name (a
    name several modules define has each value)."""
    found: dict[str, set[Decimal]] = {}
    for file in sorted(package_dir.rglob("*.py")):
        for node in ast.parse(file.read_text(encoding="utf-8")).body:
            if (isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant)
                    and type(node.value.value) in (int, float)):
                for target in node.targets:
                    if isinstance(target, ast.Name) and target.id.isupper():
                        found.setdefault(target.id, set()).add(Decimal(repr(node.value.value)))
    return found


def blocks(text: str):
    """(first line number, [(line number, line)]) per paragraph, list item, table row or heading of
    a Markdown page; fenced blocks left out."""
    block, fenced = [], False
    for number, line in enumerate(text.splitlines(), 1):
        if line.lstrip().startswith("```"):
            fenced = not fenced
            if block:
                yield block
            block = []
            continue
        if fenced:
            continue
        starts = re.match(r"\s*(?:[-*+] |\||#|\d+\. )", line) or not line.strip()
        if starts and block:
            yield block
            block = []
        if line.strip():
            block.append((number, line))
    if block:
        yield block


def prose(block) -> list[tuple[int, str]]:
    """The block's lines with code spans (which may run over a line break), HTML comments and
    the numbers of ``NOT_FIGURES`` blanked, each line kept at its number."""
    text = "\n".join(line for _, line in block)
    blank = lambda m: re.sub(r"[^\n]", " ", m.group(0))  # noqa: E731: keeps every offset and line break
    text = re.sub(r"`[^`]*`|<!--.*?-->|\]\([^)]*\)", blank, text, flags=re.S)
    for pattern in NOT_FIGURES.values():
        text = pattern.sub(blank, text)
    return [(number, line) for (number, _), line in zip(block, text.split("\n"))]


def cited_pages(block, bench_dir: Path) -> list[Path]:
    names = {m.group(1) for _, line in block for m in CITED_PAGE.finditer(line)}
    return sorted({p for name in names for p in bench_dir.glob(name)})


def stale_figures(doc: Path, bench_dir: Path, root: Path,
                  constants: dict[str, set[Decimal]] | None = None) -> list[StaleFigure]:
    """Every figure ``doc`` quotes in a block citing a bench page that the page does not print
    (nor a constant the block names: ``constants``, by default ``source_constants`` of
    ``root``/addon)."""
    if constants is None:
        constants = source_constants(root / "addon")
    found, numbers = [], {}
    for block in blocks(doc.read_text(encoding="utf-8")):
        pages = cited_pages(block, bench_dir)
        if not pages:
            continue
        for p in pages:
            if p not in numbers:
                numbers[p] = page_numbers(p.read_text(encoding="utf-8"))
        named = set(CONSTANT_NAME.findall(" ".join(line for _, line in block)))
        printed = set().union(*(numbers[p] for p in pages), *(constants.get(name, set()) for name in named))
        for number, line in prose(block):
            for m in NUMBER.finditer(line):
                if not held(m.group(0), printed):
                    found.append(StaleFigure(f"{doc.relative_to(root)}:{number}", m.group(0),
                                             tuple(str(p.relative_to(root)) for p in pages)))
    return found


# ---------------------------------------------------------------- figures in a block citing no page
# A measured figure (a time, a ratio, a percentage, a size, an error: delta-E, RMSE, FLIP, relative
# L1, or a test count) is written by the bench that measures it. A block that quotes one without
# citing its page must still quote a number some bench page holds: by number, not by meaning (a
# small number is on most pages by chance; a figure of a few digits, the kind that goes stale, is
# held or reported).
_NUM = r"\d+(?:,\d{3})*(?:\.\d+)?(?:e[-−]?\d+)?"
_LIST = rf"{_NUM}(?:(?:\s?[-–]\s?|,\s|,?\s(?:and|or|to|against)\s|\s/\s){_NUM})*"
_UNIT = r"(?:x|×|%|kB|MB|GB|KiB|bytes|ms|s|seconds?|min|minutes?|hours?)"
UNIT_FIGURE = re.compile(
    rf"(?P<a>{_LIST})\s?{_UNIT}(?![\w/])(?!\s*\d)"  # 2.58x, 0.41 %, 14-16 ms, 274.5 kB, 856 s
    rf"|(?P<b>{_NUM})\s(?:passed|skipped|failed|xfailed|errors?|expected failures?)\b"  # test counts
    rf"|(?:ΔE00|ΔE|RMSE|FLIP|relative L1|\|bias\|)(?!\w)\)?[\s:=(]{{0,3}}(?:of\s|is\s|at best\s)?(?P<c>{_LIST})(?![\w.])"
    rf"|(?P<d>{_LIST})\s(?:relative L1|ΔE00|RMSE|FLIP)\b")
# Figures written with a unit that are design constants or a test's bound, chosen and not
# measured, which no bench page needs to hold: {figure as written: (the file that sets it, the text
# that sets it there)}. ``design_constants_moved`` checks each is still set so.
DESIGN_CONSTANTS = {
    "0.5 s": ("addon/lamella/blender/recompile.py", "DRAG_WINDOW = 0.5"),  # an edit this soon continues a drag
    "0.3 s": ("addon/lamella/blender/recompile.py", "SETTLE_DELAY = 0.3"),  # quiet before a drag settles
    "2.5 %": ("tests/unit/test_models.py", "0.025 * walk[0]"),  # bare rough metals against the walk
    "1 %": ("addon/lamella/core/backends/ir/lobe_budget.py", "AUTO_TOLERANCE = 0.01"),  # the automatic budget
    "0.5 %": ("tests/unit/test_staging.py", "worst < 0.005"),  # the staged shader against the traced model
    "10 %": ("tests/unit/test_accuracy.py", "1.1 * best"),  # `auto` against the best model
    "2 %": ("tests/unit/test_trapped_light.py", "(0.0, 0.02)"),  # trapped light at normal incidence
    "8 %": ("tests/unit/test_trapped_light.py", "(60.0, 0.08)"),  # and at 60 degrees
    "0.2 %": ("tests/blender/test_osl_exactness.py", "np.median(rel) < 0.002"),  # OSL against numpy per pixel
    "64 KiB": ("tools/eevee_uniform_block.py", "EEVEE's 64 KiB uniform block"),  # Blender's limit
}


def design_constants_moved(root: Path) -> list[str]:
    """The ``DESIGN_CONSTANTS`` no longer set where they say."""
    return [f"{figure}: {text!r} is not in {source}" for figure, (source, text) in DESIGN_CONSTANTS.items()
            if text not in (root / source).read_text(encoding="utf-8")]


def unheld_unit_figures(doc: Path, bench_dir: Path, root: Path) -> list[StaleFigure]:
    """Every measured figure (``UNIT_FIGURE``) in a block of ``doc`` that cites no bench page which
    no bench page prints (the blocks citing a page: ``stale_figures``)."""
    everywhere = set().union(*(page_numbers(p.read_text(encoding="utf-8")) for p in sorted(bench_dir.glob("*.md"))))
    found = []
    for block in blocks(doc.read_text(encoding="utf-8")):
        if cited_pages(block, bench_dir):
            continue
        text = re.sub(r"`[^`]*`", lambda m: re.sub(r"[^\n]", " ", m.group(0)), "\n".join(line for _, line in block),
                      flags=re.S)
        for (number, _), line in zip(block, text.split("\n")):
            for m in UNIT_FIGURE.finditer(line):
                figure = m.group(0).strip()
                values = re.findall(_NUM, next(g for g in m.groups() if g))
                if figure not in DESIGN_CONSTANTS and not all(
                        _value(v.replace("−", "-")) in everywhere for v in values):
                    found.append(StaleFigure(f"{doc.relative_to(root)}:{number}", figure, ("any bench page",)))
    return found
