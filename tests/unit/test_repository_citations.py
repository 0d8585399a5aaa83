"""The repository explains itself: every file a docstring or page points to exists, and papers are
cited by author and year, not by a number in a folder a newcomer does not have; work items (issue
numbers) belong in commit messages."""
import re
import subprocess
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


def _lines(path):
    for number, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
        yield f"{path.relative_to(ROOT)}:{number}", line


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
    assert PATH.search("(`core/backends/sockets.py`)").group(1) == "core/backends/sockets.py"
    for text in ("DESIGN.md", "paper 001 Eq. 3", "(issue 3)", "Issue #12", "../shared/BLENDER_NOTES.md"):
        assert WORK_ITEM.search(text), text
    for text in ("Randrianandrasana et al. 2021, Eq. 37", "tissue 3", "paper 2021"):
        assert not WORK_ITEM.search(text), text
