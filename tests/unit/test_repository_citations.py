"""The repository explains itself: every file a docstring or page points to exists, and papers are
cited by author and year, not by a number in a folder a newcomer does not have; work items (issue
numbers) belong in commit messages."""
import argparse
import ast
import fnmatch
import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TEXT_SUFFIXES = {".py", ".md", ".osl", ".h", ".toml"}
# a path into the repository: starts with one of its folders (or the package's) and names a file
PATH = re.compile(r"(?<![\w./-])((?:docs|bench|tests|tools|osl|addon|lamella|core|blender|data|demo_blend)"
                  r"/[\w./-]*\w\.(?:md|py|json|osl|h|npz|exr|toml|png))")
WORK_ITEM = re.compile(r"DESIGN\.md|\b[Pp]apers? 0\d\d\b|\b[Ii]ssues? #?\d+\b|\.\./shared|shared/papers")


def _tracked_text_files():
    try:
        out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
        paths = [ROOT / p for p in out.splitlines()]
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return [p for p in paths if p.suffix in TEXT_SUFFIXES and "references" not in p.parts and p.exists()]


def _lines(path, root=ROOT):
    for number, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
        yield f"{path.relative_to(root)}:{number}", line


def test_every_cited_file_exists():
    missing = []
    for path in _tracked_text_files():
        if path.name == Path(__file__).name:
            continue
        for where, line in _lines(path):
            for match in PATH.finditer(line):
                cited = match.group(1)
                if not any((base / cited).exists() for base in (ROOT, ROOT / "addon", ROOT / "addon" / "lamella", ROOT / "addon" / "lamella_dev")):
                    missing.append(f"{where}: {cited}")
    assert not missing, "cited files that do not exist:\n" + "\n".join(missing)


def test_no_work_items_or_numbered_papers():
    found = [f"{where}: {line.strip()}" for path in _tracked_text_files() if path.name != Path(__file__).name
             for where, line in _lines(path) if WORK_ITEM.search(line)]
    assert not found, "cite papers by author, year and equation, and leave work items to commits:\n" + "\n".join(found)


def test_the_checks_see_what_they_are_for():
    """The patterns catch what they are meant to (a check that matches nothing passes forever)."""
    assert PATH.search("see docs/missing_page.md").group(1) == "docs/missing_page.md"
    assert PATH.search("(`core/backends/ir/sockets.py`)").group(1) == "core/backends/ir/sockets.py"
    for text in ("DESIGN.md", "paper 001 Eq. 3", "(issue 3)", "Issue #12", "../shared/BLENDER_NOTES.md"):
        assert WORK_ITEM.search(text), text
    for text in ("Randrianandrasana et al. 2021, Eq. 37", "tissue 3", "paper 2021"):
        assert not WORK_ITEM.search(text), text


# ------------------------------------------------------------------ the pages cite what exists
# README.md, docs/*.md and bench/*.md name modules, functions, files, make targets and `lamella`
# subcommands. Each is resolved against the tree as it is: files against the tracked paths,
# modules and names by parsing the sources with ast (nothing is imported but the command's parser,
# and never bpy), make targets against the Makefile, subcommands against the command's argparse.

DOTTED = re.compile(r"^([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)+)(?:\(.*\))?(?:\[[^\]]*\](?:\(.*\))?)?$")
PATH_LIKE = re.compile(r"^(?:\.?[\w*-]+/)+[\w.*-]*$")
PY_FILE = re.compile(r"^[\w-]+\.py$")
FILE_SUFFIX = re.compile(r"\.(?:json|blend|osl|oso|exr|png|md|py|toml|h|cpp|mtlx|npz|zip|txt|csv)$")
MAKE = re.compile(r"(?:^|[\s;&|(])make ([a-z][\w-]*)")
COMMAND = re.compile(r"(?:^|[\s;&|(])lamella ([a-z][\w-]*)(?: ([a-z][\w-]*))?")
# Roots of dotted names that are Blender's (bpy's modules and operator namespaces, the extension's
# installed name), not ours and not importable without Blender.
FOREIGN_ROOTS = {"bpy", "bl_ext", "addon_utils", "wm", "mathutils", "np"}


def _tracked() -> set[str]:
    try:
        out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return {p for p in out.splitlines() if (ROOT / p).exists()}


def _doc_pages():
    """README.md, docs/*.md and bench/*.md (not the pages in deeper folders: a tool's own README)."""
    return [ROOT / p for p in sorted(_tracked())
            if p == "README.md" or re.fullmatch(r"(?:docs|bench)/[^/]+\.md", p)]


def _spans(path, root=ROOT):
    """(file:line, text, is_code_line) for every inline code span (which may run over a line break
    within its paragraph, as Markdown has it) and every line of a fenced block."""
    fenced, paragraph = False, []

    def inline(paragraph):
        text = " ".join(line for _, line in paragraph)
        starts = [0]
        for _, line in paragraph:
            starts.append(starts[-1] + len(line) + 1)
        for m in re.finditer(r"`([^`]+)`", text):
            k = max(i for i, start in enumerate(starts[:-1]) if start <= m.start())
            yield paragraph[k][0], re.sub(r"\s+", " ", m.group(1)).strip(), False

    for where, line in _lines(path, root):
        if line.lstrip().startswith("```"):
            yield from inline(paragraph)
            paragraph, fenced = [], not fenced
        elif fenced:
            yield where, line, True
        elif not line.strip() or line.lstrip().startswith(("|", "#")):
            yield from inline(paragraph + ([(where, line)] if line.strip() else []))
            paragraph = []
        else:
            paragraph.append((where, line))
    yield from inline(paragraph)


class _Source:
    """The packages under addon/, read with ast: every module's top-level names (defs, classes,
    assignments, imports) and its classes' members."""

    def __init__(self):
        self.modules = {}  # dotted name -> {"names": {name: kind}, "classes": {...}, ...}
        for file in sorted((ROOT / "addon").rglob("*.py")):
            rel = file.relative_to(ROOT / "addon").with_suffix("")
            parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
            self.modules[".".join(parts)] = self._read(file, ".".join(parts), rel.name == "__init__")
        self.classes = {}  # class name -> [(its members, whether it has bases)] over the modules
        for info in self.modules.values():
            for name, (members, has_bases) in info["classes"].items():
                self.classes.setdefault(name, []).append((members, has_bases))

    @staticmethod
    def _read(file, dotted, is_package):

        tree = ast.parse(file.read_text(encoding="utf-8"))
        package = dotted if is_package else dotted.rpartition(".")[0]
        names, classes, aliases, redirect, dynamic = {}, {}, {}, None, False
        for node in tree.body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                names[node.name] = ("def",)
                dynamic |= node.name == "__getattr__"
            elif isinstance(node, ast.ClassDef):
                names[node.name] = ("class",)
                members = set()
                for item in node.body:
                    if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                        members.add(item.name)
                    elif isinstance(item, ast.Assign):
                        members |= {t.id for t in item.targets if isinstance(t, ast.Name)}
                    elif isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name):
                        members.add(item.target.id)
                classes[node.name] = (members, any(not (isinstance(b, ast.Name) and b.id == "object")
                                                   for b in node.bases))
            elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                if isinstance(node.value, ast.Dict):  # a table's entries are cited by key (``luts.ggx_albedo``)
                    names.update({k.value: ("value",) for k in node.value.keys
                                  if isinstance(k, ast.Constant) and isinstance(k.value, str)})
                for t in targets:
                    if isinstance(t, (ast.Name, ast.Tuple, ast.List)):  # not ``a.b = ...`` or ``a[k] = ...``
                        names.update({n.id: ("value",) for n in ast.walk(t) if isinstance(n, ast.Name)})
                    # ``sys.modules[__name__] = other``: this module's name is another module
                    if (isinstance(t, ast.Subscript) and isinstance(node.value, ast.Name)
                            and ast.unparse(t.value) == "sys.modules"):
                        redirect = node.value.id
            elif isinstance(node, ast.Import):
                for a in node.names:
                    if a.asname:
                        aliases[a.asname] = a.name
                        names[a.asname] = ("module", a.name)
                    else:
                        names[a.name.split(".")[0]] = ("module", a.name.split(".")[0])
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    up = package.split(".")
                    up = up[:len(up) - (node.level - 1)] if node.level > 1 else up
                    base = ".".join(up + ([node.module] if node.module else []))
                for a in node.names:
                    names[a.asname or a.name] = ("from", base, a.name)
        return {"names": names, "classes": classes, "dynamic": dynamic,
                "redirect": aliases.get(redirect) if redirect else None}

    def _matching(self, parts):
        """Modules named by ``parts``: fully (``lamella.core.stack``) or by their last components
        (``backends.staging``, ``staging``), so a citation survives a module moving between folders."""
        want = ".".join(parts)
        return [m for m in self.modules if m == want or m.endswith("." + want)]

    def _in_module(self, module, rest, depth=0):
        if depth > 8:
            return True
        info = self.modules.get(module)
        if info is None:
            return True  # a module outside addon/ (the standard library, numpy): not ours to check
        if not rest:
            return True
        if info["redirect"]:
            return self._in_module(info["redirect"], rest, depth + 1)
        if info["dynamic"]:
            return True
        head, tail = rest[0], rest[1:]
        if f"{module}.{head}" in self.modules:
            return self._in_module(f"{module}.{head}", tail, depth + 1)
        kind = info["names"].get(head)
        if kind is None:  # a method cited through an instance (``stack.to_dict``)
            return not tail and any(head in members for members, _ in info["classes"].values())
        if kind[0] == "class" and tail:
            members, has_bases = info["classes"][head]
            return tail[0] in members or has_bases
        if kind[0] == "from":
            if f"{kind[1]}.{kind[2]}" in self.modules:
                return self._in_module(f"{kind[1]}.{kind[2]}", tail, depth + 1)
            return self._in_module(kind[1], [kind[2], *tail], depth + 1)
        if kind[0] == "module":
            return self._in_module(kind[1], tail, depth + 1)
        return True  # an attribute of a function or a value: not checked

    def resolves(self, dotted: str) -> bool | None:
        """True if ``dotted`` names something in addon/, False if it names a module or class of ours
        and then something it does not have, None if it is not ours (Blender's, the standard library's)."""
        parts = dotted.split(".")
        for k in range(len(parts), 0, -1):
            modules = self._matching(parts[:k])
            if modules:
                return any(self._in_module(m, parts[k:]) for m in modules)
        if parts[0] in self.classes:
            return any(parts[1] in members or has_bases for members, has_bases in self.classes[parts[0]])
        if any(info["names"].get(parts[0], ("module",))[0] in ("def", "value") for info in self.modules.values()):
            return True  # an attribute of a function or a value of ours: not checked
        return None


def _make_targets() -> set[str]:
    text = (ROOT / "Makefile").read_text()
    return {m.group(1) for m in re.finditer(r"^([\w.-]+)\s*:(?!=)", text, re.M)}


def _ignored(token: str) -> bool:
    """Whether git ignores ``token``: what the commands write (out/, dist/, the showcase scene), cited
    before it exists."""
    patterns = [p.strip() for p in (ROOT / ".gitignore").read_text().splitlines() if p.strip() and not p.startswith("#")]
    parts = token.split("/")
    prefixes = ["/".join(parts[:i]) for i in range(1, len(parts) + 1)]
    return any(fnmatch.fnmatch(prefix, pattern.rstrip("/")) for prefix in prefixes for pattern in patterns)


def _commands() -> dict[str, set[str] | None]:
    """`lamella`'s subcommands, each with the choices of its first positional argument (`bench`'s
    benchmarks) or None."""
    from lamella_dev.cli import build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    out = {}
    for name, parser in sub.choices.items():
        positional = [a for a in parser._actions if not a.option_strings and a.dest != "help"]
        out[name] = set(positional[0].choices) if positional and positional[0].choices else None
    return out


def _unresolved_citations(pages, root=ROOT):
    """Every citation in ``pages`` (named relative to ``root``) that does not resolve, as file:line: what."""
    tracked = _tracked()
    existing = set(tracked)
    for p in tracked:
        parts = p.split("/")
        existing |= {"/".join(parts[:i]) for i in range(1, len(parts))}
    basenames = {Path(p).name for p in tracked}
    source, targets, commands = _Source(), _make_targets(), _commands()

    def path_exists(token: str) -> bool:
        token = token.rstrip("/")
        if _ignored(token):
            return True
        if any(ch in token for ch in "*?["):
            return any(fnmatch.fnmatch(p, token) or fnmatch.fnmatch(p, "*/" + token) for p in existing)
        return token in existing or any(p.endswith("/" + token) for p in existing)

    bad = []
    for page in pages:
        for where, text, is_code in _spans(page, root):
            for m in MAKE.finditer(text):
                if m.group(1) not in targets:
                    bad.append(f"{where}: make {m.group(1)} (no such target in the Makefile)")
            for m in COMMAND.finditer(text):
                name, arg = m.groups()
                if name not in commands:
                    bad.append(f"{where}: lamella {name} (no such subcommand)")
                elif arg and commands[name] is not None and arg not in commands[name]:
                    bad.append(f"{where}: lamella {name} {arg} (not one of its choices)")
            if is_code:
                continue
            if "://" in text or "<" in text or text.startswith(("/", "~")):
                continue
            for token in text.split():
                token = token.strip(",;()")
                if PATH_LIKE.match(token) and "=" not in token:
                    if not path_exists(token) and source.resolves(token.replace("/", ".").strip(".")) is not True:
                        bad.append(f"{where}: {token} (no such file or folder)")
            if PY_FILE.match(text) and text not in basenames:
                bad.append(f"{where}: {text} (no such file)")
            m = DOTTED.match(text)
            if m and not FILE_SUFFIX.search(m.group(1)):
                dotted = m.group(1)
                found = source.resolves(dotted)
                first = dotted.split(".")[0]
                if found is False:
                    bad.append(f"{where}: {dotted} (not defined where it points)")
                elif found is None and not (first in FOREIGN_ROOTS or first[0].isupper() or _foreign_module(first)):
                    bad.append(f"{where}: {dotted} (no module or name {first!r} in addon/)")
    return bad


def _foreign_module(name: str) -> bool:
    """Whether ``name`` is a module outside the project: the standard library's or an installed one."""
    if name in sys.stdlib_module_names:
        return True
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):
        return False


def test_pages_cite_modules_names_files_targets_and_commands_that_exist():
    bad = _unresolved_citations(_doc_pages())
    assert not bad, "README.md, docs/ and bench/ cite what does not exist:\n" + "\n".join(bad)


def test_the_citation_check_catches_what_it_is_for(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("`lamella.core.backends.ir.trace._NO_SUCH_TABLE` and `trace._FOLD`, `staging.lookup`\n"
                    "`models.choose_auto`, `lamella.core.reference.eval_brdf_cos(stack, wi, wo)`\n"
                    "`no_such_module.function`, `bpy.ops.lamella.layer_add`, `sys.path`, `stack.to_dict()`\n"
                    "`make test`, `make no-such-target`, `lamella bench staging`, `lamella bench no-such`\n"
                    "`lamella no-such-command`, `lamella/core/layers/`, `lamella/core/no_such_folder/`\n"
                    "`core/param_id.ParamId`, `no_such_file.py`, `api.py`, `out/contact_sheet.png`\n"
                    "```sh\nmake demo\nmake no-such-demo\n```\n")
    reported = [bad.split(": ", 1)[1] for bad in _unresolved_citations([page], root=tmp_path)]
    for cited in ("lamella.core.backends.ir.trace._NO_SUCH_TABLE", "no_such_module.function", "make no-such-target",
                  "lamella bench no-such", "lamella no-such-command", "lamella/core/no_such_folder/",
                  "no_such_file.py", "make no-such-demo"):
        assert any(r.startswith(cited + " ") for r in reported), (cited, reported)
    assert len(reported) == 8, reported  # and nothing else: the rest of the page resolves
