"""How the extension's Blender layer imports: every module of ``lamella.blender`` imports what it
uses at its top, by name (a reader and a tool can follow each), with no cycle among them; only
the package needs bpy, so ``import lamella`` and ``lamella.core`` run without it, and the
extension's entry module imports nothing until Blender registers it."""
import ast
import json
import subprocess
import sys
from pathlib import Path


ROOT = Path(__file__).resolve().parents[2]
BLENDER = ROOT / "addon" / "lamella" / "blender"


def _module_imports(path: Path):
    """The sibling modules ``path`` imports at its top (``from . import x``, ``from .x import y``),
    a ``try`` at the top included."""
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        found = [node] if isinstance(node, ast.ImportFrom) else (
            [n for n in ast.walk(node) if isinstance(n, ast.ImportFrom)] if isinstance(node, ast.Try) else [])
        for n in found:
            if n.level == 1:
                yield from ([n.module.split(".")[0]] if n.module else [a.name for a in n.names])


def test_the_modules_import_one_another_without_a_cycle():
    import graphlib

    names = {p.stem for p in BLENDER.glob("*.py")} - {"__init__"}
    graph = {p.stem: {m for m in _module_imports(p) if m in names} for p in BLENDER.glob("*.py")}
    graphlib.TopologicalSorter(graph).prepare()  # raises CycleError naming the cycle
    assert graph["__init__"] >= {"properties", "compiled", "recompile", "operators", "ui", "asset_library"}


def test_no_import_inside_a_function_or_class():
    """Every import is at its module's top (a version-dependent one in a ``try`` there)."""
    found = []
    for path in sorted(BLENDER.glob("*.py")):
        for top in ast.parse(path.read_text(encoding="utf-8")).body:
            if isinstance(top, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                found += [f"{path.name}:{n.lineno}" for n in ast.walk(top)
                          if isinstance(n, (ast.Import, ast.ImportFrom))]
    assert not found, found


def _run(code: str) -> dict:
    """``code`` in a fresh Python that cannot import bpy; its last line of output, as JSON."""
    blocked = "import sys\nsys.modules['bpy'] = None\n"
    r = subprocess.run([sys.executable, "-c", blocked + code], capture_output=True, text=True, cwd=ROOT,
                       timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_lamella_and_its_core_import_without_bpy():
    found = _run("import json, lamella, lamella.core, lamella.core.api\n"
                 "print(json.dumps(sorted(m for m in sys.modules if m.startswith('lamella.blender'))))")
    assert found == []


def test_the_extension_entry_imports_nothing_until_registered():
    """The entry module beside ``blender_manifest.toml`` (``bl_ext.<repo>.lamella``), loaded as
    Blender loads it, adds no module but itself: the Blender layer comes with ``register``."""
    found = _run(
        "import importlib.util, json\n"
        "before = set(sys.modules)\n"
        "spec = importlib.util.spec_from_file_location('lamella_entry', '__init__.py',\n"
        "                                              submodule_search_locations=['.'])\n"
        "ext = importlib.util.module_from_spec(spec)\n"
        "sys.modules['lamella_entry'] = ext\n"
        "spec.loader.exec_module(ext)\n"
        "print(json.dumps({'new': sorted(set(sys.modules) - before - {'lamella_entry'}),\n"
        "                  'api': [callable(getattr(ext, n)) for n in ('register', 'apply_stack', 'read_stack')]}))")
    assert found == {"new": [], "api": [True, True, True]}


def test_the_package_registers_the_built_in_kinds_hooks_and_its_modules_in_order(addon):
    # ``addon``: registered here, whatever another test of this worker left unregistered before
    import lamella.blender as blender
    from lamella.blender import asset_library, compiled, conductor_modes, kind_hooks, operators, properties
    from lamella.blender import recompile, ui

    assert kind_hooks.hooks("conductor") is conductor_modes.HOOKS and kind_hooks.hooks("coat") is kind_hooks.COAT_HOOKS
    assert blender._MODULES == (properties, compiled, recompile, operators, ui, asset_library)
