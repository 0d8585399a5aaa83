"""What ships is what runs: the extension's package ``lamella`` never imports the development package
``lamella_dev`` (the reference, benchmarks, plots, the suite, the ``lamella`` command) and imports
itself only relatively (it is installed as ``bl_ext.<repository>.lamella``); a non-editable install
(a built wheel, not this checkout) emits OSL, its header and tables inside the package."""
import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "addon" / "lamella"
# The contract's import path of the stochastic reference (docs/design.md): an alias of
# lamella_dev.reference, left out of the extension zip like the rest of the development code.
CONTRACT_ALIAS = SHIPPED / "core" / "reference.py"


def _imports(path: Path):
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, 0, alias.name
        elif isinstance(node, ast.ImportFrom):
            yield node.lineno, node.level, node.module or ""


def test_the_shipped_package_never_imports_development_code():
    found = []
    for path in sorted(SHIPPED.rglob("*.py")):
        if path == CONTRACT_ALIAS:
            continue
        for line, level, module in _imports(path):
            top = module.split(".")[0]
            if level == 0 and top in ("lamella", "lamella_dev"):
                found.append(f"{path.relative_to(ROOT)}:{line}: import {module}")
    assert not found, "the extension imports itself relatively and never lamella_dev:\n" + "\n".join(found)


def test_the_contract_path_of_the_reference_is_the_development_module():
    from lamella.core import reference

    import lamella_dev.reference

    assert reference is lamella_dev.reference and callable(reference.eval_brdf_cos)


def test_the_check_sees_an_absolute_import(tmp_path):
    p = tmp_path / "m.py"
    p.write_text("from lamella_dev import suite\nfrom .core import api\n")
    assert [(level, module) for _, level, module in _imports(p)] == [(0, "lamella_dev"), (1, "core")]


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """The project built as a wheel and installed into a folder of its own (no editable link)."""
    pytest.importorskip("setuptools")
    import shutil

    tmp = tmp_path_factory.mktemp("wheel")
    # built from a copy: setuptools writes build/ and an egg-info beside the sources it builds
    src = tmp / "src"
    shutil.copytree(ROOT / "addon", src / "addon", ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy(ROOT / name, src / name)
    r = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                        "-w", str(tmp / "dist"), str(src)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-3000:]
    wheel = next((tmp / "dist").glob("lamella-*.whl"))
    site = tmp / "site"
    r = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(site), str(wheel)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-3000:]
    return site


def _run_installed(site: Path, code: str) -> str:
    """Run ``code`` with the installed copy first on the path and this checkout's addon/ off it."""
    prelude = (f"import sys; sys.path[:] = [{str(site)!r}] + [p for p in sys.path "
               f"if not p.startswith({str(ROOT / 'addon')!r})]\n")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    r = subprocess.run([sys.executable, "-c", prelude + code], capture_output=True, text=True, env=env, cwd=site)
    assert r.returncode == 0, r.stderr[-3000:]
    return r.stdout


def test_a_non_editable_install_emits_osl(installed, tmp_path):
    out = _run_installed(installed, f"""
import lamella, lamella_dev
from lamella.core import Stack
from lamella.core.backends.osl.emit import emit_osl
from lamella_dev import suite
assert lamella.__file__.startswith({str(installed)!r}), lamella.__file__
src = emit_osl(suite.load("gold_coated"), live=("coat0_roughness",))  # a textured coat reads the tables
assert "lamella_tex" in src, "the table header is not inlined"
from lamella_dev.cli import main
main(["export-osl", "gold_coated", "--live", "coat0_roughness", "-o", {str(tmp_path / 'bundle')!r}])
print("ok", len(src))
""")
    assert out.splitlines()[-1].startswith("ok")
    shaders = list((tmp_path / "bundle").glob("*.osl"))
    assert shaders and "lamella_tex" in shaders[0].read_text()
    assert list((tmp_path / "bundle").rglob("*.exr"))
